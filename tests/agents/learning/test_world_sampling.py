"""Training across worlds: the distribution, the vector env that draws a setting per
episode, and a training smoke run with world sampling."""

from __future__ import annotations

import numpy as np
import pytest

from agents.common.env import make_env
from agents.common.episode_length import episode_length
from agents.evaluation.suite import agent_observation, suite_settings
from agents.learning.config import ConfigError, config_from_dict
from agents.learning.ppo_agent import load_ppo_agent
from agents.learning.sb3.training import train
from agents.learning.sb3.world_sampling import WorldSamplingVecEnv
from agents.learning.worlds import WorldDistribution
from agents.registry import make_agent
from slam_env.belief.local_encoding import local_space
from tests.belief.test_local_observation import local_space_with_extras

ACTIVE = "slam_env/ActiveSLAM-v0"
WORLDS = {
    "presets": ["random", "rooms"],
    "arena_sizes": [8.0, 10.0],
    "landmark_counts": [4, 7],
    "obstacle_counts": [0, 2],
    "sensor_ranges": [2.0, 4.0],
    "fovs": [2.0, 6.28],
}


def test_episode_length_scales_with_the_arena():
    assert episode_length(16.0, 16.0) == 500
    assert episode_length(8.0, 8.0) == 250
    assert episode_length(32.0, 20.0) == 1000


def test_the_distribution_draws_every_field_from_its_choices():
    dist = WorldDistribution.from_mapping(WORLDS)
    rng = np.random.default_rng(0)
    draws = [dist.sample(rng) for _ in range(200)]
    assert {d["preset"] for d in draws} == {"random", "rooms"}
    assert {d["width"] for d in draws} == {8.0, 10.0}
    assert all(d["width"] == d["height"] for d in draws)
    assert {d["n_landmarks"] for d in draws} == {4, 7}
    assert {d["n_obstacles"] for d in draws} == {0, 2}
    assert {d["max_range"] for d in draws} == {2.0, 4.0}
    assert {d["fov"] for d in draws} == {2.0, 6.28}
    assert WorldDistribution().sample(rng) == {"preset": "random"}


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ({"preset": ["random"]}, "unknown worlds key"),
        ({"presets": ["maze"]}, "unknown"),
        ({"arena_sizes": []}, "non-empty"),
        ({"landmark_counts": [0]}, "> 0"),
        ({"obstacle_counts": [-1]}, ">= 0"),
        ({"sensor_ranges": ["far"]}, "floats"),
        ({"landmark_counts": [2.5]}, "ints"),
    ],
)
def test_bad_distributions_are_refused(data, match):
    with pytest.raises(ValueError, match=match):
        WorldDistribution.from_mapping(data)


LOCAL = {"observation": "local"}


@pytest.mark.parametrize(
    ("worlds", "match"),
    [
        ({"fovs": [2.0944, 360]}, r"worlds.fovs value 360.0 cannot run: .*fov must be in"),
        ({"fovs": [2.0, 6.2832]}, r"worlds.fovs value 6.2832 "),  # just above 2π
        ({"arena_sizes": [8, 1000]}, r"worlds setting .*'arena_sizes': 1000.* arena cells"),
        ({"landmark_counts": [5, 1e9]}, r"worlds.landmark_counts must hold ints"),
        # Each alone can run (500 landmarks fit a 90 m arena), not the two together.
        (
            {"arena_sizes": [8, 90], "landmark_counts": [10, 500]},
            r"worlds setting .*'arena_sizes': 8.0, 'landmark_counts': 500.*n_landmarks = 500",
        ),
    ],
)
def test_settings_that_cannot_run_are_refused_up_front(worlds, match):
    with pytest.raises(ConfigError, match=match):
        config_from_dict({"worlds": worlds, "env_options": LOCAL})
    if "must hold" not in match:
        with pytest.raises(ValueError, match=match):
            WorldSamplingVecEnv(ACTIVE, 2, WorldDistribution.from_mapping(worlds), LOCAL)


def test_every_setting_of_a_runnable_distribution_is_drawn():
    """A distribution that passes its checks draws each of its values (none is dropped
    as if it could not be laid out)."""
    worlds = {"fovs": [2.0944, 6.28], "arena_sizes": [8.0, 12.0]}
    config_from_dict({"worlds": worlds, "env_options": LOCAL})
    dist = WorldDistribution.from_mapping(worlds)
    venv = WorldSamplingVecEnv(ACTIVE, 8, dist, LOCAL, seed=0, max_episode_steps=2)
    try:
        venv.reset()
        drawn = {(s["fov"], s["width"]) for s in venv.settings}
        for _ in range(8):
            venv.step(np.zeros((8, 2), np.float32))
            drawn |= {(s["fov"], s["width"]) for s in venv.settings}
        assert venv.episodes_drawn == 8 * 5
        assert drawn == {(f, a) for f in worlds["fovs"] for a in worlds["arena_sizes"]}
    finally:
        venv.close()


def test_each_group_draws_a_new_setting_when_its_episodes_end():
    dist = WorldDistribution.from_mapping(WORLDS)
    venv = WorldSamplingVecEnv(ACTIVE, 4, dist, {"observation": "local"}, groups=2, seed=3)
    try:
        assert venv.observation_space == local_space_with_extras()
        obs = venv.reset()
        assert all(obs[k].shape[0] == 4 for k in obs)
        lengths = venv.lengths.copy()
        assert set(lengths.tolist()) <= {250, 312}  # 8 m and 10 m arenas
        first = [dict(s) for s in venv.settings]
        drawn = venv.episodes_drawn
        actions = np.zeros((4, 2), np.float32)
        for _ in range(int(lengths.min())):
            obs, rewards, dones, infos = venv.step(actions)
        g = int(np.argmin(lengths))
        rows = slice(2 * g, 2 * g + 2)
        assert dones[rows].all()
        assert all(infos[i]["TimeLimit.truncated"] for i in range(2 * g, 2 * g + 2))
        assert all("terminal_observation" in infos[i] for i in range(2 * g, 2 * g + 2))
        assert venv.episodes_drawn == drawn + int((lengths == lengths.min()).sum())
        assert venv.observation_space.contains({k: v[0] for k, v in obs.items()})
        assert rewards.dtype == np.float32 and first
    finally:
        venv.close()


def test_the_same_seed_draws_the_same_settings():
    dist = WorldDistribution.from_mapping(WORLDS)
    runs = []
    for _ in range(2):
        venv = WorldSamplingVecEnv(ACTIVE, 2, dist, {"observation": "local"}, seed=5)
        obs = venv.reset()
        runs.append((venv.settings, obs["robot"].copy()))
        venv.close()
    assert runs[0][0] == runs[1][0]
    np.testing.assert_array_equal(runs[0][1], runs[1][1])


def test_a_world_dependent_observation_is_refused():
    with pytest.raises(ConfigError, match="observation: local"):
        train({"worlds": WORLDS, "env_options": {}, "total_timesteps": 64, "n_envs": 2})
    with pytest.raises(ConfigError, match="native"):
        config_from_dict({"worlds": WORLDS, "vectorization": "dummy"})
    with pytest.raises(ConfigError, match="world_groups"):
        config_from_dict({"worlds": WORLDS, "n_envs": 4, "world_groups": 3})


def test_training_smoke_run_with_world_sampling(tmp_path):
    path = train(
        {
            "total_timesteps": 256,
            "n_envs": 4,
            "world_groups": 2,
            "seed": 1,
            "env_options": {"observation": "local"},
            "worlds": WORLDS,
            "max_episode_steps": 40,
            "progress_bar": False,
            "tensorboard": False,
            "checkpoint_freq": 0,
            "eval_freq": 128,
            "eval_episodes": 1,
            "out_dir": str(tmp_path),
            "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 1, "net_arch": [16]},
        }
    )
    agent = load_ppo_agent(path)
    assert set(local_space().spaces) <= set(agent.observation_space.spaces)
    assert agent.observation_space == local_space_with_extras()
    assert (tmp_path / "training_summary.json").is_file()
    # The suite gives it the local observation it was trained on; other agents any.
    assert agent_observation(f"ppo: {path}") == "local"
    assert agent_observation("ppo") is None and agent_observation("frontier") is None
    # The policy loads and acts on every setting of the default suite.
    for setting in suite_settings("default"):
        env = make_env({**setting.env_options, "observation": "local"}, 3)
        agent = make_agent(f"ppo:{path}", env)
        obs, _ = env.reset(seed=0)
        for _ in range(3):
            obs, *_ = env.step(agent.predict(obs)[0])
        env.close()
