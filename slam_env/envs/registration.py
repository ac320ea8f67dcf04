"""Registers the env IDs with Gymnasium (idempotent, so re-imports are harmless)."""

from __future__ import annotations

import gymnasium as gym

DEFAULT_MAX_EPISODE_STEPS = 500


def register_envs() -> None:
    if "slam_env/Landmarks-v0" not in gym.registry:
        gym.register(
            id="slam_env/Landmarks-v0",
            entry_point="slam_env.envs.landmarks:LandmarksEnv",
            vector_entry_point="slam_env.envs.vector:LandmarksVectorEnv",
            max_episode_steps=DEFAULT_MAX_EPISODE_STEPS,
        )
    if "slam_env/ActiveSLAM-v0" not in gym.registry:
        gym.register(
            id="slam_env/ActiveSLAM-v0",
            entry_point="slam_env.envs.active_slam:ActiveSLAMEnv",
            vector_entry_point="slam_env.envs.vector:ActiveSLAMVectorEnv",
            max_episode_steps=DEFAULT_MAX_EPISODE_STEPS,
        )
