"""ActiveSLAM-v0 (the batched core as a batch of one) computes exactly what the
composable wrappers compute over the raw env: LandmarksEnv → EKFSLAMWrapper →
CoverageWrapper → ActiveSLAMReward, with the same options."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.active_options import ACTIVE_SLAM_DEFAULTS
from slam_env.coverage import CoverageWrapper
from slam_env.env import LandmarksEnv
from slam_env.wrappers import ActiveSLAMReward, ActiveSLAMRewardWeights, EKFSLAMWrapper
from tests.streams import assert_same

# (the belief's options, the world's options)
CONFIGS = [
    ({}, {}),
    ({"observation": "full", "correction": "batch"}, {"n_landmarks": 8}),
    (
        {"coverage": False, "reward_weights": {"coverage": 0.0, "step": 0.3}},
        {"motion_model": "velocity", "measurement_model": "cartesian"},
    ),
    (
        {"filter_alphas": (0.02, 0.01, 0.02, 0.01), "gate": 5.0},
        {"outlier_rate": 0.3, "kidnap_rate": 0.01, "preset": "cluttered"},
    ),
    ({"reward_weights": {"coverage": 20.0}}, {"scan_beams": 0, "bumper": False}),
    # FEJ, and clutter, which a filter told the IDs leaves out.
    ({"linearization": "fej"}, {"clutter_rate": 0.3}),
]


def wrapper_stack(belief: dict[str, Any], world: dict[str, Any]) -> gym.Env:
    raw = LandmarksEnv(**{**ACTIVE_SLAM_DEFAULTS, **world})
    env: gym.Env = EKFSLAMWrapper(
        raw,
        observation=belief.get("observation", "egocentric"),
        correction=belief.get("correction", "sequential"),
        gate=belief.get("gate", EKFSLAMWrapper.__init__.__defaults__[2]),
        alphas=belief.get("filter_alphas"),
        linearization=belief.get("linearization", "standard"),
    )
    if belief.get("coverage", True):
        env = CoverageWrapper(env)
    weights = ActiveSLAMRewardWeights(**belief.get("reward_weights", {}))
    return ActiveSLAMReward(env, weights)


@pytest.mark.parametrize(("belief", "world"), CONFIGS)
def test_the_core_is_the_wrapper_stack_bit_for_bit(belief, world) -> None:
    core = gym.make("slam_env/ActiveSLAM-v0", max_episode_steps=None, **belief, **world)
    stack = wrapper_stack(belief, world)
    assert core.observation_space == stack.observation_space
    rng = np.random.default_rng(0)
    for episode in range(2):
        assert_same(core.reset(seed=episode), stack.reset(seed=episode), f"reset {episode}")
        for t in range(250):
            action = np.array([rng.uniform(-0.3, 1.0), rng.uniform(-1, 1)], np.float32)
            assert_same(list(core.step(action)), list(stack.step(action)), f"step {episode}.{t}")
    assert core.unwrapped.filter.n_landmarks > 0
