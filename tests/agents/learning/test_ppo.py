"""PPO: training config, a tiny learn/save/load round trip, the agent and its checks."""

from __future__ import annotations

import dataclasses
import json
import math

import gymnasium as gym
import numpy as np
import pytest
import yaml

from agents.common.env import make_env
from agents.evaluation.compare import evaluate
from agents.learning.config import (
    DEFAULT_CONFIG_PATH,
    ConfigError,
    PPOParams,
    TrainConfig,
    config_from_dict,
    load_config,
)
from agents.learning.ppo_agent import PPOAgent, load_ppo_agent
from agents.learning.sb3.training import train
from agents.registry import make_agent

SMALL_WORLD = {"n_landmarks": 5, "width": 8.0, "height": 8.0, "n_obstacles": 1}


def tiny_config(out_dir, **overrides):
    cfg = {
        "total_timesteps": 128,
        "n_envs": 1,
        "seed": 1,
        "env_options": SMALL_WORLD,
        "max_episode_steps": 40,
        "progress_bar": False,
        "checkpoint_freq": 64,
        "eval_freq": 64,
        "eval_episodes": 1,
        "out_dir": str(out_dir),
        "ppo": {
            "n_steps": 64,
            "batch_size": 32,
            "n_epochs": 1,
            "net_arch": [16],
            "log_std_init": -1.0,
        },
    }
    cfg.update(overrides)
    return cfg


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("ppo")
    path = train(tiny_config(out))
    return out, path


# ---------------------------------------------------------------------- config
def test_default_yaml_lists_every_key_with_its_default():
    data = yaml.safe_load(DEFAULT_CONFIG_PATH.read_text())
    assert set(data) == {f.name for f in dataclasses.fields(TrainConfig)}
    assert set(data["ppo"]) == {f.name for f in dataclasses.fields(PPOParams)}
    # The shipped policy's file differs from the code's defaults only in its reward
    # shaping (env_options).
    shipped = load_config()
    assert shipped.env_options == {"reward_weights": data["env_options"]["reward_weights"]}
    assert dataclasses.replace(shipped, env_options={}) == TrainConfig()


def test_the_fast_config_is_the_default_one_on_64_sub_envs_with_a_smaller_mlp():
    # Its figures (docs/training.md) compare it with the default config: every key
    # but the sub-envs, the minibatch and the MLP is the same, the rollout too.
    default = load_config()
    fast = load_config(DEFAULT_CONFIG_PATH.with_name("ppo_fast.yaml"))
    ppo = {"n_steps": 32, "batch_size": 1024, "net_arch": [64, 64]}
    assert fast.n_envs == 64 and {k: getattr(fast.ppo, k) for k in ppo} == ppo
    assert fast.n_envs * fast.ppo.n_steps == default.n_envs * default.ppo.n_steps
    assert fast.ppo == dataclasses.replace(default.ppo, **ppo)
    others = {"n_envs": 64, "ppo": fast.ppo, "out_dir": "runs/fast", "model_name": "ppo_fast"}
    assert fast == dataclasses.replace(default, **others)


def test_load_config_applies_overrides(tmp_path):
    file = tmp_path / "c.yaml"
    file.write_text("n_envs: 4\nppo: {n_steps: 128}\n")
    cfg = load_config(file, seed=7, n_envs=None)  # None: a CLI flag left unset
    assert (cfg.n_envs, cfg.seed, cfg.ppo.n_steps) == (4, 7, 128)
    assert cfg.ppo.batch_size == PPOParams().batch_size  # defaults fill the rest


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ({"n_env": 2}, r"unknown config key\(s\) \['n_env'\]"),
        ({"ppo": {"learning_rat": 0.1}}, r"unknown ppo key\(s\) \['learning_rat'\]"),
        ({"n_envs": "two"}, "'n_envs' must be an int >= 1"),
        ({"n_envs": True}, "'n_envs' must be an int"),
        ({"total_timesteps": 0}, "'total_timesteps'"),
        ({"ppo": {"gamma": 1.5}}, "'ppo.gamma'"),
        ({"ppo": {"net_arch": []}}, "'ppo.net_arch'"),
        ({"ppo": {"activation": "gelu"}}, "'ppo.activation'"),
        ({"ppo": {"log_std_init": float("nan")}}, "'ppo.log_std_init'"),
        ({"start_method": "thread"}, "'start_method'"),
        ({"vectorization": "async"}, "'vectorization' must be one of .'native', 'subproc'"),
        ({"ppo": [1, 2]}, "'ppo' must be a mapping"),
        ([1, 2], "must be a mapping"),
    ],
)
def test_config_errors_name_the_key(data, match):
    with pytest.raises(ConfigError, match=match):
        config_from_dict(data)


def test_train_rejects_a_non_flat_observation(tmp_path):
    with pytest.raises(ConfigError, match="egocentric"):
        train(tiny_config(tmp_path, env_options={**SMALL_WORLD, "observation": "full"}))
    with pytest.raises(ValueError, match="n_landmark"):
        train(tiny_config(tmp_path, env_options={"n_landmark": 5}))
    # A random world that cannot be laid out fails here, not in a worker process.
    with pytest.raises(ValueError, match="could not place obstacle"):
        train(tiny_config(tmp_path, env_options={"width": 5.0, "height": 5.0}))
    assert not (tmp_path / "ppo_active_slam.zip").exists()


# ---------------------------------------------------------------------- train, save, load
def test_train_writes_model_config_checkpoints_evaluations_and_logs(trained):
    out, path = trained
    assert path == out / "ppo_active_slam.zip" and path.is_file()
    saved = load_config(out / "ppo_active_slam.yaml")
    assert saved == config_from_dict(tiny_config(out))  # the resolved config, reloadable
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        "ppo_active_slam_128_steps.zip",
        "ppo_active_slam_64_steps.zip",
    ]
    evals = np.load(out / "eval" / "evaluations.npz")
    assert list(evals["timesteps"]) == [64, 128]
    assert (out / "eval" / "best_model.zip").is_file()
    assert any((out / "tb").rglob("events.out.tfevents.*"))
    summary = json.loads((out / "training_summary.json").read_text())
    assert summary["timesteps"] == 128 and summary["env_steps_per_s"] > 0
    assert summary["vectorization"] == "native"  # the default
    # One thread steps the few sub-envs (at least 128 a thread), one runs torch.
    assert (summary["sampler_threads"], summary["torch_threads"]) == (1, 1)
    # Where the wall time went: env stepping, gradient updates and the rest add up.
    shares = [summary[f"{k}_share"] for k in ("env_step", "gradient_updates", "other")]
    assert all(0.0 < x < 1.0 for x in shares) and sum(shares) == pytest.approx(1.0, abs=1e-3)
    # The seconds are rounded to 1 ms and the shares to 1e-4: compare within that.
    env_s, updates_s, wall_s = (
        summary[k] for k in ("env_step_s", "gradient_updates_s", "wall_time_s")
    )
    assert env_s + updates_s <= wall_s + 1e-3
    ms = 5e-4
    low, high = (env_s - ms) / (wall_s + ms), (env_s + ms) / (wall_s - ms)
    assert low - 1e-4 <= summary["env_step_share"] <= high + 1e-4
    # The action σ started at e⁻¹ (log_std_init) and two small updates barely moved it.
    sigma = load_ppo_agent(path).model.policy.log_std.exp().detach().numpy()
    assert np.all(np.abs(sigma - math.exp(-1.0)) < 0.05)


def test_ppo_agent_loads_and_acts_deterministically(trained):
    _, path = trained
    env = make_env(SMALL_WORLD, 40)
    agent = make_agent(f"ppo:{path}", env)
    assert isinstance(agent, PPOAgent)
    obs, _ = env.reset(seed=0)
    a1, _ = agent.predict(obs)
    a2, _ = agent.predict(obs)
    assert env.action_space.contains(a1)
    np.testing.assert_array_equal(a1, a2)  # deterministic by default
    expected, _ = agent.model.predict(obs, deterministic=True)
    np.testing.assert_array_equal(a1, expected)
    samples = {tuple(agent.predict(obs, deterministic=False)[0]) for _ in range(5)}
    assert len(samples) > 1  # stochastic when asked
    assert agent.config["env_options"] == SMALL_WORLD  # the YAML next to the model
    # SB3's convention: the .zip suffix may be left off.
    assert load_ppo_agent(path.with_suffix("")).path == path
    env.close()


def test_ppo_agent_refuses_an_env_with_other_spaces(trained):
    _, path = trained
    trained_size = make_env(SMALL_WORLD).observation_space.shape[0]
    env = make_env({**SMALL_WORLD, "n_landmarks": 7})
    other_size = env.observation_space.shape[0]
    assert other_size == trained_size + 2 * 4  # four features per landmark slot
    with pytest.raises(
        ValueError,
        match=rf"observation space Box\(shape=\({trained_size},\).* != env.s "
        rf"Box\(shape=\({other_size},\)",
    ):
        make_agent(f"ppo:{path}", env)
    env.close()
    env = make_env({**SMALL_WORLD, "action_type": "discrete"})
    with pytest.raises(ValueError, match="action space"):
        load_ppo_agent(path, env)
    env.close()


def test_ppo_bad_files(tmp_path):
    env = gym.make("slam_env/ActiveSLAM-v0", **SMALL_WORLD)
    with pytest.raises(ValueError, match="not found"):
        make_agent(f"ppo:{tmp_path / 'missing.zip'}", env)
    junk = tmp_path / "junk.zip"
    junk.write_bytes(b"not a zip at all")
    with pytest.raises(ValueError, match="not a stable-baselines3 PPO model"):
        make_agent(f"ppo:{junk}", env)
    with pytest.raises(ValueError, match="needs a path"):
        make_agent("ppo:", env)
    env.close()


def test_evaluate_round_trip_with_a_trained_policy(trained, tmp_path):
    _, path = trained
    result = evaluate(
        ["random", f"ppo:{path}"],
        episodes=2,
        seed=0,
        env_options=SMALL_WORLD,
        out_dir=tmp_path,
        max_steps=20,
        progress=False,
        verbose=False,
    )
    assert [r["agent"] for r in result.summary] == ["random", "ppo:ppo_active_slam"]
    ppo_rows = [r for r in result.episodes if r["spec"] == f"ppo:{path}"]
    assert [r["seed"] for r in ppo_rows] == [0, 1]
    assert all(r["steps"] == 20 for r in ppo_rows)
    assert (tmp_path / "summary.csv").is_file()


def test_demo_runs_a_policy_on_the_world_it_was_trained_on(trained, tmp_path):
    from agents.evaluation.demo import demo

    _, path = trained
    # No env options given: the demo takes them from the YAML next to the policy
    # (the default world would not fit this small-world policy).
    result = demo(f"ppo:{path}", seed=1, out_dir=tmp_path, gif=False, verbose=False)
    assert result.metrics["steps"] == 40  # the trained max_episode_steps
    saved = json.loads((tmp_path / "demo_metrics.json").read_text())
    assert saved["env_options"] == SMALL_WORLD


def test_saved_policy_drops_the_optimiser_state_and_acts_the_same(tmp_path):
    from stable_baselines3 import PPO

    from agents.learning.sb3.runs import save_policy_file

    env = make_env(SMALL_WORLD)
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(64)  # Adam now holds moment estimates
    full, slim = tmp_path / "full.zip", tmp_path / "slim.zip"
    model.save(full)
    save_policy_file(model, slim)
    assert slim.stat().st_size < 0.6 * full.stat().st_size
    obs, _ = env.reset(seed=0)
    a = PPO.load(full, device="cpu").predict(obs, deterministic=True)[0]
    b = PPO.load(slim, device="cpu").predict(obs, deterministic=True)[0]
    np.testing.assert_array_equal(a, b)
    env.close()


def trained_parameters(out_dir, **overrides) -> list[np.ndarray]:
    cfg = tiny_config(out_dir, n_envs=2, eval_freq=0, checkpoint_freq=0, **overrides)
    model = load_ppo_agent(train(cfg)).model
    return [t.detach().numpy() for t in model.policy.parameters()]


def test_training_is_reproducible_and_the_same_whichever_the_vectorization(tmp_path):
    # The shipped policy's claim: the same config and seed give the same policy. The
    # native vector env's sub-env i replays the single env seeded seed + i, so the
    # in-process single envs (dummy) train the very same policy.
    native = trained_parameters(tmp_path / "a")
    for run, mode in (("b", "native"), ("c", "dummy")):
        other = trained_parameters(tmp_path / run, vectorization=mode)
        for first, second in zip(native, other, strict=True):
            np.testing.assert_array_equal(first, second)


def test_training_is_reproducible_with_worker_processes(tmp_path):
    first, second = (trained_parameters(tmp_path / r, vectorization="subproc") for r in "ab")
    for a, b in zip(first, second, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("verbose", [0, 1])
def test_training_without_tensorboard_writes_nothing_outside_its_folder(
    tmp_path, monkeypatch, capsys, verbose
):
    import tempfile

    import torch._dynamo  # noqa: F401  torch's own: its import makes torch's cache folder in temp

    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))  # where SB3 would make a folder
    cfg = tiny_config(tmp_path / "run", tensorboard=False, eval_freq=0, verbose=verbose)
    cfg["total_timesteps"] = cfg["ppo"]["n_steps"]  # one rollout, one table
    train(cfg)
    assert list(temp.iterdir()) == []
    assert ("total_timesteps" in capsys.readouterr().out) == (verbose >= 1)


def test_the_shipped_policy_is_small_and_fits_the_default_env():
    from agents.registry import SHIPPED_POLICY

    assert SHIPPED_POLICY.stat().st_size < 400_000
    env = make_env({})
    agent = make_agent("ppo", env)
    obs, _ = env.reset(seed=0)
    action, _ = agent.predict(obs)
    assert env.action_space.contains(action)
    env.close()


def test_ppo_episodes_side_by_side_equal_the_single_env_episodes(trained):
    # evaluate runs a policy's episodes on the native vector env; the same seeds give
    # the very same episodes as the single env, across batches (5 seeds, 2 at a time).
    from agents.common.base import RandomAgent
    from agents.rollouts.episodes import run_episode
    from agents.rollouts.vector_episodes import acts_on_batches, run_episodes_batched

    _, path = trained
    env = make_env(SMALL_WORLD, 40)
    agent = load_ppo_agent(path, env)
    assert acts_on_batches(agent) and not acts_on_batches(RandomAgent(env, seed=0))
    seeds = [7, 8, 9, 10, 11]
    batched = run_episodes_batched(agent, seeds, SMALL_WORLD, 40, batch=2)
    for seed, side_by_side in zip(seeds, batched, strict=True):
        alone = run_episode(env, agent, seed)
        assert side_by_side.seed == seed and side_by_side.world == alone.world
        np.testing.assert_equal(side_by_side.metrics(), alone.metrics())  # NaN equals NaN
        for name in ("true_poses", "est_poses", "entropy", "pose_nees", "rewards"):
            np.testing.assert_array_equal(getattr(side_by_side, name), getattr(alone, name))
        np.testing.assert_array_equal(
            side_by_side.belief.landmark_means, alone.belief.landmark_means
        )
        assert side_by_side.layout == alone.layout
    env.close()


@pytest.mark.parametrize("decisions", ["actions", "goals"])
def test_ctrl_c_keeps_the_policy_says_where_and_closes_the_envs(tmp_path, monkeypatch, decisions):
    from agents.learning.sb3.timing import TimedPPO

    def interrupted(self, *args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(TimedPPO, "learn", interrupted)
    closed = []
    import agents.learning.sb3.runs

    real_close = agents.learning.sb3.runs._close
    monkeypatch.setattr(
        agents.learning.sb3.runs,
        "_close",
        lambda env, quietly: (closed.append(quietly), real_close(env, quietly)),
    )
    extra = {"decisions": "goals", "vectorization": "dummy"} if decisions == "goals" else {}
    with pytest.raises(KeyboardInterrupt, match=r"model saved to .*ppo_active_slam\.zip"):
        train(tiny_config(tmp_path, **extra))
    assert (tmp_path / "ppo_active_slam.zip").is_file()
    summary = json.loads((tmp_path / "training_summary.json").read_text())
    assert summary["interrupted"] is True
    assert closed == [True, True]  # the training and evaluation envs, quietly
