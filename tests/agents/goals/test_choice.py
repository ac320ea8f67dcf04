"""The goal-choosing policy: its features, the agent that runs it, the decision-level
env it learns in, training it and loading it."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import yaml
from gymnasium.utils.env_checker import check_env

from agents.cli.main import main as cli_main
from agents.common.env import make_env
from agents.evaluation.suite import suite_settings
from agents.goals.choice import (
    CHOICES,
    N_FEATURES,
    GoalChoiceAgent,
    choice_space,
    feature_space,
)
from agents.learning.config import ConfigError, config_from_dict
from agents.learning.goal_env import GoalChoiceEnv
from agents.learning.sb3.goal_training import load_goal_agent
from agents.learning.sb3.training import train
from agents.learning.worlds import WorldDistribution
from agents.planners.frontier import EXPLORE, LOCALISE, REFINE, FrontierAgent
from agents.registry import SHIPPED_GOAL_POLICY, SHIPPED_POLICY, agent_label, make_agent

INFORMATION_ONLY = {
    "reward_weights": {
        "information_gain": 1.0,
        "pose_uncertainty": 0.0,
        "collision": 0.0,
        "step": 0.0,
        "coverage": 0.0,
    }
}
SMALL_WORLDS = WorldDistribution(
    presets=("random", "rooms"),
    arena_sizes=(8.0, 10.0),
    landmark_counts=(4, 9),
    obstacle_counts=(0, 2),
    sensor_ranges=(2.0, 4.0),
    fovs=(2.0, 2 * np.pi),
)


class Recorder:
    """A policy that answers from a fixed cycle of choices and keeps what it saw."""

    def __init__(self, cycle: tuple[int, ...] = (0,)) -> None:
        self.cycle = cycle
        self.seen: list[np.ndarray] = []

    def __call__(self, features: np.ndarray) -> int:
        self.seen.append(features)
        return self.cycle[(len(self.seen) - 1) % len(self.cycle)]


def run(agent: GoalChoiceAgent, env: gym.Env, seed: int, steps: int) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    actions = []
    for _ in range(steps):
        action, _ = agent.predict(obs)
        actions.append(action)
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    return actions


def test_features_have_one_size_on_every_setting_of_the_suite():
    for setting in suite_settings("default"):
        env = make_env(setting.env_options, 25)
        policy = Recorder(tuple(range(len(CHOICES))))
        run(GoalChoiceAgent(env, policy, seed=0), env, seed=1, steps=25)
        env.close()
        assert policy.seen, setting.name
        for x in policy.seen:
            assert x.shape == (N_FEATURES,) and x.dtype == np.float32
            assert feature_space().contains(x), (setting.name, x)


def test_the_features_say_what_the_docstring_says():
    """choice_features against the belief and world they describe, mid-episode."""
    assert [(c.mode, c.gain_weight) for c in CHOICES] == [  # as the README documents
        (EXPLORE, 1.5), (EXPLORE, 0.5), (EXPLORE, 4.0), (LOCALISE, 1.5), (REFINE, 1.5)
    ]  # fmt: skip
    env = make_env({}, 500)
    agent = GoalChoiceAgent(env, Recorder((0, 1, 2)), seed=0)
    env.reset(seed=3)
    agent.reset()
    for step in range(400):  # 120 steps, then on to the next choice, left pending
        action = agent.begin_step()
        if action is None:
            if step >= 120:
                break
            action = agent.finish_step(step % 3)
        env.step(action)
    steps_begun = step + 1  # the pending choice is the step after the `step` env steps
    x = agent.features().astype(np.float64)
    f = agent._base.filter
    cfg = env.unwrapped.config
    n = f.n_landmarks
    sig = np.sqrt(np.trace(f.landmark_covs(), axis1=1, axis2=2))
    assert n > 0
    pose_sigma = math.sqrt(f.pose_cov[0, 0] + f.pose_cov[1, 1])
    expected = {
        0: pose_sigma / 0.4,  # the frontier agent's loop-closing threshold
        1: math.sqrt(f.pose_cov[2, 2]) / 0.1,
        2: math.log1p(n) / 4.0,
        3: sig.mean(),
        4: sig.max(),
        5: agent.memory.coverage.fraction_swept(),
        7: steps_begun / 500,  # a 16 m arena's episode length
        8: cfg.sensor.max_range / 5.0,
        9: cfg.sensor.fov / (2 * math.pi),
        10: 16.0 / 32.0,
    }
    for i, value in expected.items():
        assert x[i] == pytest.approx(value, rel=1e-5, abs=1e-6), i
    assert x[11:14].tolist() == [float(agent.mode == m) for m in (EXPLORE, LOCALISE, REFINE)]
    for c in range(3):  # per weighting: a target, its path in arena sides, area, turn
        has, path, area, turn = x[14 + 4 * c : 18 + 4 * c]
        assert has == 1.0 and 0.0 <= path < 1.5 and 0.0 < area < 5.0 and 0.0 <= turn <= 1.0
    # Weighing area more never picks a target with less of it (0.5, then 1.5, then 4.0).
    assert x[18 + 2] <= x[14 + 2] + 1e-6 and x[14 + 2] <= x[22 + 2] + 1e-6
    assert x[29] == 1.0 and 0.0 <= x[30] < 1.5  # a revisit: its path in arena sides
    assert np.isclose(sig, x[31], rtol=1e-5).any()  # and its landmark's σ, in m


def test_a_choice_sets_the_planners_mode_and_weighting():
    env = make_env({}, 80)
    agent = GoalChoiceAgent(env, Recorder(), seed=0)
    env.reset(seed=2)
    agent.reset()
    assert agent.begin_step() is None  # the first step needs a goal
    first = agent.features()
    action = agent.finish_step(1)
    assert env.action_space.contains(action)
    assert agent.mode == EXPLORE and agent._gain_weight == CHOICES[1].gain_weight == 0.5
    assert agent.goal is not None or agent._look_at is not None  # a path, or a point to face
    # Nothing is known yet: neither a loop closure nor a revisit has a landmark, and
    # their features are all zero.
    assert not first[-6:].any()
    for _ in range(60):  # explore on, then stop at the next choice
        env.step(action)
        action = agent.begin_step()
        if action is None:
            action = agent.finish_step(0)
    while action is not None:
        env.step(action)
        action = agent.begin_step()
    assert agent._base.filter.n_landmarks > 0
    assert agent.features()[-3] == 1.0  # a landmark to revisit
    agent.finish_step(4)
    assert agent.mode == REFINE and agent.target_landmark is not None


@pytest.mark.parametrize("choice", [3, 4])  # a loop closure, a revisit
def test_a_choice_with_no_landmark_to_go_to_is_handed_on_to_exploring(choice):
    """Before any landmark is known, a loop closure or a revisit has no target: the
    planner explores (at the frontier agent's weighting) instead of standing still."""
    env = make_env({}, 40)
    agent = GoalChoiceAgent(env, Recorder(), seed=0)
    env.reset(seed=2)
    agent.reset()
    assert agent.begin_step() is None
    assert agent.features()[-6] == 0.0 and agent.features()[-3] == 0.0  # nothing known
    action = agent.finish_step(choice)
    assert agent.mode == EXPLORE and agent._gain_weight == CHOICES[0].gain_weight
    assert agent.goal is not None and np.abs(action).max() > 0.0


def test_bad_choices_are_refused_and_change_nothing():
    env = make_env({}, 60)
    agent = GoalChoiceAgent(env, Recorder(), seed=0)
    env.reset(seed=2)
    agent.reset()
    with pytest.raises(RuntimeError, match="begin_step"):
        agent.finish_step(0)
    assert agent.begin_step() is None
    for bad in (-1, len(CHOICES)):
        with pytest.raises(ValueError, match="choice must be"):
            agent.finish_step(bad)
        assert agent.goal is None and agent.mode == EXPLORE
    assert env.action_space.contains(agent.finish_step(0))


SMALL_ARENA = {"width": 8.0, "height": 8.0, "n_landmarks": 10, "n_obstacles": 2}


@pytest.mark.parametrize(("options", "steps"), [({}, 120), (SMALL_ARENA, 250)])
def test_always_the_frontier_weighting_without_loop_closing_is_the_frontier_agent_so(
    options, steps
):
    """Choice 0 every time is the frontier agent with its loop closing switched off,
    also once nothing is left to sweep (the small arena): exploring then hands over to
    the revisits under way, which go round the landmarks as the frontier agent's do."""
    ours = make_env(options, steps)
    theirs = make_env(options, steps)
    no_loops = {"loop_close_std": 1e6, "loop_close_done_std": 1e6}
    agent = GoalChoiceAgent(ours, Recorder((0,)), seed=3)
    a = run(agent, ours, seed=4, steps=steps)
    b = run(FrontierAgent(theirs, seed=3, **no_loops), theirs, seed=4, steps=steps)
    assert len(a) == len(b) == steps
    np.testing.assert_array_equal(np.array(a), np.array(b))
    assert agent.mode == (REFINE if options else EXPLORE)


def test_the_env_passes_the_checker_and_repeats_itself():
    env = GoalChoiceEnv(INFORMATION_ONLY, SMALL_WORLDS, max_episode_steps=40)
    check_env(env, skip_render_check=True)

    def stream(seed: int) -> list[tuple]:
        obs, _ = env.reset(seed=seed)
        out = [obs.tobytes()]
        for k in range(30):
            obs, reward, terminated, truncated, _ = env.step(k % len(CHOICES))
            out.append((obs.tobytes(), reward, terminated, truncated))
            if terminated or truncated:
                obs, _ = env.reset()
                out.append(obs.tobytes())
        return out

    assert stream(5) == stream(5)
    assert stream(5) != stream(6)
    env.close()


@pytest.mark.parametrize("bonus, until", [(0.0, 1.0), (15.0, 1.0), (15.0, 0.25)])
def test_the_return_is_the_entropy_taken_off_and_the_discoveries_per_landmark(bonus, until):
    extra = {"discovery_bonus": bonus} if bonus else {}  # 0 and 1 are the defaults
    extra.update({"discovery_until": until} if until < 1 else {})
    env = GoalChoiceEnv(INFORMATION_ONLY, max_episode_steps=50, **extra)
    _, info = env.reset(seed=3)
    start, n, known = info["entropy"], len(info["landmark_ids"]), info["landmarks_known"]
    paid_up_to = until * n  # 5 of the 20 landmarks with 0.25: the cap is reached
    total, done, choices = 0.0, False, 0
    while not done:
        _, reward, terminated, truncated, info = env.step(choices % len(CHOICES))
        assert isinstance(reward, float)
        total += reward
        done = terminated or truncated
        choices += 1
    assert truncated and choices > 1 and info["landmarks_known"] > known
    assert until == 1 or known < paid_up_to < info["landmarks_known"]  # the cap bites
    paid = min(info["landmarks_known"], paid_up_to) - known
    expected = (start - info["entropy"] + bonus * paid) / n
    assert total == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_the_remaining_schedule_pays_each_discovery_by_the_share_of_the_episode_left():
    horizon = 60
    env = GoalChoiceEnv(
        INFORMATION_ONLY,
        max_episode_steps=horizon,
        discovery_bonus=15.0,
        discovery_schedule="remaining",
    )
    _, info = env.reset(seed=3)
    start, n = info["entropy"], len(info["landmark_ids"])
    inner, t = env._env, env._t  # the env steps before the first choice
    known = [info["landmarks_known"]]
    step = inner.step

    def recording_step(action):
        out = step(action)
        known.append(out[4]["landmarks_known"])
        return out

    inner.step = recording_step
    total, done = 0.0, False
    while not done:
        _, reward, terminated, truncated, info = env.step(0)
        total += reward
        done = terminated or truncated
    gains = np.diff(known)
    assert gains.sum() > 1 and len(gains) == horizon - t
    shares = 1.0 - (t + np.arange(len(gains))) / horizon  # 1 at step 1, 1/T at step T
    expected = (start - info["entropy"] + 15.0 * float(gains @ shares)) / n
    assert total == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_in_a_world_of_one_landmark_the_return_is_not_divided():
    env = GoalChoiceEnv(
        {**INFORMATION_ONLY, "n_landmarks": 1}, max_episode_steps=40, discovery_bonus=15.0
    )
    _, info = env.reset(seed=8)  # a world whose landmark is found within 40 steps
    start, known = info["entropy"], info["landmarks_known"]
    total, done = 0.0, False
    while not done:
        _, reward, terminated, truncated, info = env.step(0)
        total += reward
        done = terminated or truncated
    assert (known, info["landmarks_known"]) == (0, 1)
    assert total == pytest.approx(start - info["entropy"] + 15.0, rel=1e-9)


@pytest.mark.parametrize("bonus", [-1.0, math.inf, math.nan, True, "1"])
def test_a_bad_discovery_bonus_is_refused(bonus):
    with pytest.raises(ValueError, match="discovery_bonus"):
        GoalChoiceEnv({}, discovery_bonus=bonus)
    with pytest.raises(ConfigError, match="discovery_bonus"):
        config_from_dict({"decisions": "goals", "vectorization": "dummy", "discovery_bonus": bonus})


@pytest.mark.parametrize("schedule", ["late", "", None, 1])
def test_a_bad_discovery_schedule_is_refused(schedule):
    with pytest.raises(ValueError, match="discovery_schedule"):
        GoalChoiceEnv({}, discovery_schedule=schedule)
    with pytest.raises(ConfigError, match="discovery_schedule"):
        config_from_dict(
            {"decisions": "goals", "vectorization": "dummy", "discovery_schedule": schedule}
        )


@pytest.mark.parametrize("until", [0.0, -0.5, 1.01, math.inf, math.nan, True, "1"])
def test_a_bad_discovery_until_is_refused(until):
    with pytest.raises(ValueError, match="discovery_until"):
        GoalChoiceEnv({}, discovery_until=until)
    with pytest.raises(ConfigError, match="discovery_until"):
        config_from_dict({"decisions": "goals", "vectorization": "dummy", "discovery_until": until})


def test_worlds_that_cannot_be_laid_out_are_drawn_again():
    crowded = {"presets": ("random",), "arena_sizes": (8.0,), "obstacle_counts": (40,)}
    env = GoalChoiceEnv(
        {}, WorldDistribution(**{**crowded, "obstacle_counts": (40, 1)}), max_episode_steps=20
    )
    for seed in range(3):
        env.reset(seed=seed)  # the 40-obstacle draws fail, the 1-obstacle ones do not
    with pytest.raises(ValueError, match="no layable setting"):
        GoalChoiceEnv({}, WorldDistribution(**crowded)).reset(seed=0)
    env.close()


def test_bad_actions_are_refused():
    env = GoalChoiceEnv({}, max_episode_steps=20)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    env.reset(seed=0)
    for bad in (len(CHOICES), -1, 0.5, "0"):
        with pytest.raises(ValueError, match="action must be"):
            env.step(bad)


def test_goal_training_configs_are_checked():
    with pytest.raises(ConfigError, match="decisions"):
        config_from_dict({"decisions": "waypoints"})
    with pytest.raises(ConfigError, match="subproc or dummy"):
        config_from_dict({"decisions": "goals", "vectorization": "native"})
    cfg = config_from_dict({"decisions": "goals", "vectorization": "dummy", "worlds": {}})
    assert cfg.decisions == "goals"
    with pytest.raises(ConfigError, match="0 unless decisions is goals"):
        config_from_dict({"discovery_bonus": 1.0})  # the env steps' reward has no such term
    with pytest.raises(ConfigError, match="1 unless decisions is goals"):
        config_from_dict({"discovery_until": 0.5})
    with pytest.raises(ConfigError, match="'flat' unless decisions is goals"):
        config_from_dict({"discovery_schedule": "remaining"})


def tiny_goal_config(out_dir, ppo: dict | None = None, **overrides) -> dict:
    """A goal-training config small enough for a test: two envs in small sampled worlds,
    no checkpoints, evaluations or logs; ``ppo`` entries and ``overrides`` replace the
    defaults."""
    return {
        "decisions": "goals",
        "total_timesteps": 64,
        "n_envs": 2,
        "vectorization": "dummy",
        "env_options": INFORMATION_ONLY,
        "worlds": {"arena_sizes": [8.0], "landmark_counts": [4, 9]},
        "max_episode_steps": 30,
        "progress_bar": False,
        "tensorboard": False,
        "checkpoint_freq": 0,
        "eval_freq": 0,
        "out_dir": str(out_dir),
        "ppo": {"n_steps": 32, "batch_size": 32, "n_epochs": 1, "net_arch": [8], **(ppo or {})},
        **overrides,
    }


def test_training_smoke_run_then_the_policy_runs_on_every_setting_of_the_suite(tmp_path):
    path = train(tiny_goal_config(tmp_path, seed=1, eval_freq=32, eval_episodes=1))
    assert (tmp_path / "training_summary.json").is_file()
    assert (tmp_path / "eval" / "evaluations.npz").is_file()
    assert agent_label(f"goals:{path}") == "goals:" + path.stem
    for setting in suite_settings("default"):
        env = make_env(setting.env_options, 12)
        agent = make_agent(f"goals:{path}", env, seed=0)
        actions = run(agent, env, seed=0, steps=12)
        assert all(env.action_space.contains(a) for a in actions)
        env.close()


def goal_policy_parameters(out_dir, seed: int) -> list[np.ndarray]:
    """The weights of a tiny goal policy trained as the shipped one is: worker
    processes, every episode in a world drawn from the config's distribution."""
    from stable_baselines3 import PPO

    config = tiny_goal_config(
        out_dir,
        ppo={"n_epochs": 2},
        vectorization="subproc",
        seed=seed,
        worlds={"arena_sizes": [8.0, 12.0], "landmark_counts": [4, 9]},
    )
    path = train(config)
    return [t.detach().numpy() for t in PPO.load(path, device="cpu").policy.parameters()]


def test_goal_training_is_reproducible_from_its_seed(tmp_path):
    # The shipped policy's claim: its config and seed train it again bit for bit (the
    # worlds each worker draws included); another seed trains another policy.
    first, again, other = (
        goal_policy_parameters(tmp_path / run, seed) for run, seed in (("a", 3), ("b", 3), ("c", 4))
    )
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)
    assert any(not np.array_equal(a, c) for a, c in zip(first, other, strict=True))


def test_goal_training_keeps_the_learners_torch_threads(tmp_path):
    import torch

    before = torch.get_num_threads()
    config = tiny_goal_config(
        tmp_path,
        ppo={"n_steps": 16, "batch_size": 16},
        total_timesteps=16,
        n_envs=1,
        vectorization="subproc",
        start_method="fork",
        torch_threads=2,
        worlds={"arena_sizes": [8.0], "landmark_counts": [4]},
        max_episode_steps=20,
    )
    try:
        train(config)
        assert torch.get_num_threads() == 2  # the workers' envs set theirs, not the learner's
    finally:
        torch.set_num_threads(before)


def test_loading_refuses_what_is_not_a_goal_policy(tmp_path):
    env = make_env({}, 10)
    with pytest.raises(ValueError, match="not a goal-choosing policy"):
        load_goal_agent(SHIPPED_POLICY, env)
    with pytest.raises(ValueError, match="not found"):
        make_agent(f"goals:{tmp_path / 'missing.zip'}", env)
    with pytest.raises(ValueError, match="needs a path"):
        make_agent("goals:", env)
    assert choice_space().n == len(CHOICES) and LOCALISE in {c.mode for c in CHOICES}


def test_the_shipped_policy_runs_on_every_setting_of_the_suite():
    assert SHIPPED_GOAL_POLICY.is_file()
    assert SHIPPED_GOAL_POLICY.stat().st_size < 1_000_000  # a small file, shipped in the wheel
    assert agent_label("goals") == "goals"
    for setting in suite_settings("default"):
        env = make_env(setting.env_options, 15)
        agent = make_agent("goals", env, seed=0)
        assert isinstance(agent, GoalChoiceAgent)
        actions = run(agent, env, seed=0, steps=15)
        assert len(actions) == 15 and all(env.action_space.contains(a) for a in actions)
        env.close()


def test_cli_trains_a_goal_policy_and_says_how_many_choices(tmp_path, capsys):
    config = tmp_path / "goals.yaml"
    config.write_text(
        yaml.safe_dump(
            {
                "decisions": "goals",
                "vectorization": "dummy",
                "discovery_bonus": 2.0,
                "discovery_schedule": "remaining",
                "env_options": INFORMATION_ONLY,
                "worlds": {"arena_sizes": [8.0], "landmark_counts": [4]},
                "max_episode_steps": 20,
                "checkpoint_freq": 0,
                "eval_freq": 0,
                "tensorboard": False,
                "ppo": {"n_steps": 16, "batch_size": 16, "n_epochs": 1, "net_arch": [8]},
            }
        )
    )
    out = tmp_path / "run"
    argv = ["train", "--config", str(config), "--total-steps", "32", "--n-envs", "1"]
    assert cli_main([*argv, "--out", str(out), "--no-progress"]) == 0
    saved = yaml.safe_load((out / "ppo_active_slam.yaml").read_text())
    assert (saved["decisions"], saved["discovery_bonus"]) == ("goals", 2.0)
    assert saved["discovery_schedule"] == "remaining"
    printed = capsys.readouterr().out
    assert "32 choices in" in printed and "choices/s with 1 envs, dummy" in printed
