"""Episode rollouts shared by the exploration-agent tests (not a test module)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import gymnasium as gym
import numpy as np

import slam_env  # noqa: F401  (registers the env IDs)

ENV_ID = "slam_env/ActiveSLAM-v0"
#: Fixed seeds of the default world (a new random world per seed) for the thresholds.
SEEDS = (0, 1, 2)
#: The default world's landmark count.
N_LANDMARKS = 20


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
    """One full episode of ``make_agent(env, seed=seed)`` on ``gym.make(ENV_ID)``,
    passing ``episode_start=True`` on the first step as the evaluator does."""
    env = gym.make(ENV_ID, **env_options)
    try:
        agent = make_agent(env, seed=seed)
        obs, info = env.reset(seed=seed)
        actions: list[np.ndarray] = []
        start = time.perf_counter()
        steps = 0
        terminated = truncated = False
        while not (terminated or truncated):
            action, _ = agent.predict(obs, episode_start=steps == 0, deterministic=True)
            actions.append(action)
            obs, _, terminated, truncated, info = env.step(action)
            steps += 1
        seconds = time.perf_counter() - start
        return Episode(
            seed=seed,
            steps=steps,
            truncated=bool(truncated),
            landmarks_known=int(info["landmarks_known"]),
            entropy=float(info["entropy"]),
            seconds=seconds,
            actions=actions,
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
