"""One episode of an agent on a single env, from its seeded reset to its end, as an
:class:`~agents.rollouts.records.EpisodeRecord`."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from agents.common.base import Agent
from agents.rollouts.records import EpisodeRecord, episode_record


def run_episode(
    env: gym.Env,
    agent: Agent,
    seed: int,
    *,
    deterministic: bool = True,
    render_every: int = 0,
    collect_detections: bool = False,
) -> EpisodeRecord:
    """Run one episode from ``env.reset(seed=seed)`` until it terminates or is
    truncated. ``render_every`` > 0 keeps ``env.render()`` every that many steps
    (and the last); ``collect_detections`` keeps world-frame detection points."""
    base = env.unwrapped
    obs, info = env.reset(seed=seed)
    rows: list[dict[str, Any]] = []
    est: list[np.ndarray] = []
    rewards: list[float] = []
    frames: list[np.ndarray] = []
    detections: list[np.ndarray] = []

    def record(step: int, done: bool) -> None:
        rows.append(info)
        est.append(np.asarray(base.filter.pose, dtype=np.float64).copy())
        if render_every and (step % render_every == 0 or done):
            frames.append(np.asarray(env.render()))
        if collect_detections:
            detections.append(base.render_frame().detections_world)

    record(0, False)
    state, episode_start, step = None, True, 0
    while True:
        action, state = agent.predict(
            obs, state=state, episode_start=episode_start, deterministic=deterministic
        )
        obs, reward, terminated, truncated, info = env.step(action)
        step += 1
        rewards.append(float(reward))
        episode_start = False
        done = bool(terminated or truncated)
        record(step, done)
        if done:
            break

    return episode_record(
        seed,
        rows,
        est,
        rewards,
        n_landmarks=int(base.n_landmarks),
        layout=base.layout,
        belief=base.belief_overlay(),
        frames=frames,
        detections_world=detections,
    )
