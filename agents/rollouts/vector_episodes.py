"""Episodes of an agent that acts on observations alone, on the native vector env.

A PPO policy's action depends on its observation only, so ``evaluate`` runs its
episodes side by side on ``slam_env/ActiveSLAM-v0``'s native vector env, which steps
all of them in one call: episode k of a batch is sub-env k, reset with its episode's
seed. Sub-env k replays the single env reset with that seed, so the episodes are
those of :func:`agents.rollouts.episodes.run_episode` (the tests hold the two equal, bit for
bit). The policy is asked one observation at a time: a forward pass over B rows
rounds differently from one over a single row (BLAS takes another kernel), and the
last bit of an action is enough to part two trajectories within an episode.

Agents whose actions depend on the order of their own random draws across episodes
(``random``), or that plan on the single env's belief (``frontier``, ``infogain``),
keep the single env: see :func:`acts_on_batches`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from agents.common.base import Agent
from agents.common.env import ENV_ID
from agents.common.info_rows import InfoRow
from agents.rollouts.records import EpisodeRecord, episode_record

#: Episodes run side by side at most (sub-envs of one vector env).
MAX_BATCH = 32


def acts_on_batches(agent: Any) -> bool:
    """Whether ``agent``'s episodes may run side by side: its action depends on the
    observation alone, not on the single env or on random draws shared across
    episodes (an agent says so with ``acts_on_batches = True``, as
    :class:`agents.learning.ppo_agent.PPOAgent` does)."""
    return getattr(agent, "acts_on_batches", False) is True


def run_episodes_batched(
    agent: Agent,
    seeds: Sequence[int],
    env_options: dict[str, Any] | None = None,
    max_steps: int | None = None,
    *,
    deterministic: bool = True,
    batch: int = MAX_BATCH,
) -> list[EpisodeRecord]:
    """One episode per seed (``reset(seed=seed)``), ``batch`` at a time on the native
    vector env; the records in the order of ``seeds``."""
    records: list[EpisodeRecord] = []
    for start in range(0, len(seeds), batch):
        chunk = [int(s) for s in seeds[start : start + batch]]
        records += _run_batch(agent, chunk, env_options, max_steps, deterministic)
    return records


def _run_batch(
    agent: Agent,
    seeds: list[int],
    env_options: dict[str, Any] | None,
    max_steps: int | None,
    deterministic: bool,
) -> list[EpisodeRecord]:
    b = len(seeds)
    kwargs = dict(env_options or {})
    if max_steps is not None:
        kwargs["max_episode_steps"] = max_steps
    venv = gym.make_vec(ENV_ID, num_envs=b, vectorization_mode="vector_entry_point", **kwargs)
    try:
        core = venv.unwrapped.core
        obs, info = venv.reset(seed=seeds)
        rows: list[list[dict[str, Any]]] = [[dict(InfoRow(info, k))] for k in range(b)]
        est = [[core.filter(k).pose.copy()] for k in range(b)]
        rewards: list[list[float]] = [[] for _ in range(b)]
        ends: list[dict[str, Any]] = [{} for _ in range(b)]
        running = np.ones(b, dtype=bool)
        episode_start = True
        action = venv.action_space.sample()  # the finished sub-envs' actions are ignored
        while running.any():
            for k in np.flatnonzero(running).tolist():
                row = {key: v[k] for key, v in obs.items()} if isinstance(obs, dict) else obs[k]
                action[k] = agent.predict(
                    row, episode_start=episode_start, deterministic=deterministic
                )[0]
            obs, reward, terminated, truncated, info = venv.step(action)
            episode_start = False
            done = terminated | truncated
            for k in np.flatnonzero(running).tolist():
                rows[k].append(dict(InfoRow(info, k)))
                est[k].append(core.filter(k).pose.copy())
                rewards[k].append(float(reward[k]))
                if done[k]:
                    # What the episode ended with, before the next step resets the sub-env.
                    running[k] = False
                    ends[k] = {
                        "layout": core.layout(k),
                        "belief": core.belief_overlay(k),
                    }
        n_landmarks = int(core.n_landmarks)
    finally:
        venv.close()
    return [
        episode_record(seeds[k], rows[k], est[k], rewards[k], n_landmarks=n_landmarks, **ends[k])
        for k in range(b)
    ]
