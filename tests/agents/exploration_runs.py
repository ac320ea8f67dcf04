"""Rollouts and checks shared by the exploration-agent tests (not a test module)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from agents.common.base import RandomAgent

ENV_ID = "slam_env/ActiveSLAM-v0"
#: Fixed seeds of the default world (a new random world per seed) for the thresholds.
SEEDS = (0, 1, 2)
#: The default world's landmark count.
N_LANDMARKS = 20


@dataclass
class Drive:
    """Where :func:`drive` left the env: the last observation and info, how the episode
    ended (both False while it goes on) and the actions taken."""

    obs: Any
    info: dict
    terminated: bool
    truncated: bool
    actions: list[np.ndarray]


def drive(agent, env: gym.Env, obs: Any, steps: int | None = None) -> Drive:
    """Step ``agent`` on ``env`` from ``obs`` for ``steps`` steps or, with None, to the
    end of the episode, passing ``episode_start=True`` on the first step as the
    evaluator does."""
    info: dict = {}
    actions: list[np.ndarray] = []
    terminated = truncated = False
    while not (terminated or truncated) and (steps is None or len(actions) < steps):
        action, _ = agent.predict(obs, episode_start=not actions, deterministic=True)
        actions.append(action)
        obs, _, terminated, truncated, info = env.step(action)
    return Drive(obs, info, bool(terminated), bool(truncated), actions)


@dataclass
class Episode:
    """What one rollout of an agent in the default env produced."""

    seed: int
    steps: int
    truncated: bool
    landmarks_known: int
    entropy: float
    seconds: float
    actions: list[np.ndarray] = field(default_factory=list)


def run_episode(make_agent, seed: int, **env_options) -> Episode:
    """One full episode of ``make_agent(env, seed=seed)`` on ``gym.make(ENV_ID)``."""
    env = gym.make(ENV_ID, **env_options)
    try:
        agent = make_agent(env, seed=seed)
        obs, _ = env.reset(seed=seed)
        start = time.perf_counter()
        run = drive(agent, env, obs)
        return Episode(
            seed=seed,
            steps=len(run.actions),
            truncated=run.truncated,
            landmarks_known=int(run.info["landmarks_known"]),
            entropy=float(run.info["entropy"]),
            seconds=time.perf_counter() - start,
            actions=run.actions,
        )
    finally:
        env.close()


def assert_valid_actions(episode: Episode, space: gym.spaces.Box) -> None:
    """Every action is a float32 (2,) array, finite and inside the action space."""
    assert episode.actions, "no action recorded"
    for k, action in enumerate(episode.actions):
        assert isinstance(action, np.ndarray), f"step {k}: {type(action).__name__}"
        assert action.shape == (2,) and action.dtype == np.float32, f"step {k}: {action!r}"
        assert np.all(np.isfinite(action)), f"step {k}: {action!r}"
        assert space.contains(action), f"step {k}: {action!r} outside {space}"


def assert_beats_random_on_default_episodes(make_agent) -> None:
    """On the default env (500 steps, a new random world per seed) the agent acts
    validly throughout, maps at least 90% of the landmarks on every seed, and beats
    the random agent on mean landmarks mapped and mean final belief entropy."""
    ours = [run_episode(make_agent, seed) for seed in SEEDS]
    baseline = [run_episode(RandomAgent, seed) for seed in SEEDS]
    space = gym.make(ENV_ID).action_space
    for episode in ours:
        assert episode.steps == 500 and episode.truncated
        assert_valid_actions(episode, space)
    known = {e.seed: e.landmarks_known for e in ours}
    assert all(k >= math.ceil(0.9 * N_LANDMARKS) for k in known.values()), known
    ours_known = np.mean([e.landmarks_known for e in ours])
    random_known = np.mean([e.landmarks_known for e in baseline])
    ours_entropy = np.mean([e.entropy for e in ours])
    random_entropy = np.mean([e.entropy for e in baseline])
    assert ours_known > random_known, (ours_known, random_known)
    assert ours_entropy < random_entropy, (ours_entropy, random_entropy)


def assert_same_seed_same_actions(make_agent, seed: int, env_seed: int, steps: int) -> None:
    """Two agents ``make_agent(env, seed=seed)`` act alike for ``steps`` steps in the
    default env reset with ``env_seed``."""

    def actions() -> np.ndarray:
        env = gym.make(ENV_ID)
        agent = make_agent(env, seed=seed)
        obs, _ = env.reset(seed=env_seed)
        return np.array(drive(agent, env, obs, steps).actions)

    np.testing.assert_array_equal(actions(), actions())


def assert_rejects_unsupported_envs(make_agent) -> None:
    """The heuristics need the ActiveSLAM env's belief and continuous actions."""
    with pytest.raises(TypeError, match="continuous"):
        make_agent(gym.make(ENV_ID, action_type="discrete"))
    with pytest.raises(TypeError, match="ActiveSLAM"):
        make_agent(gym.make("slam_env/Landmarks-v0"))
