"""The active-SLAM reward as a wrapper over an :class:`~slam_env.belief.ekf_wrapper.EKFSLAMWrapper`,
for users' own stacks (``slam_env/ActiveSLAM-v0`` computes the same in its core)."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from slam_env.belief.reward import REWARD_TERMS, ActiveSLAMRewardWeights
from slam_env.kernels.belief.belief_state import SINGLE
from slam_env.kernels.belief.reward import RewardSignals, active_slam_reward

__all__ = ["ActiveSLAMReward"]


class ActiveSLAMReward(gym.Wrapper):
    """The active-SLAM reward over an :class:`EKFSLAMWrapper`, as named terms:

    * ``information_gain`` = w · (H_{t−1} − H_t): the entropy the step removed from the
      belief over all landmark slots. Discovering a landmark is worth about 10–15 nats
      (its slot goes from the arena-wide prior to a few cm), re-observing one a few
      tenths; dead reckoning costs a little. This is the term that drives exploration.
    * ``pose_uncertainty`` = −w · σ_pose (m): an information-gain reward alone does not
      care *when* the robot is lost; this term pays for closing loops early.
    * ``collision`` = −w on a step in contact: the map does not see obstacles.
    * ``step`` = −w: a small time cost, so that finishing early is better.
    * ``coverage`` = w · (the share of the arena newly swept by the sensor, from a
      :class:`slam_env.belief.coverage_wrapper.CoverageWrapper` below): off by default. Information
      gain pays only when a landmark turns up; this pays for looking where none has
      been seen yet, a dense signal that speeds up learning to explore.

    The terms are reported in ``info["reward_terms"]``; the raw env's scripting terms
    move to ``info["raw_reward_terms"]``. The reward is their sum, a Python float.
    """

    def __init__(self, env: gym.Env, weights: ActiveSLAMRewardWeights | None = None) -> None:
        super().__init__(env)
        self.weights = weights or ActiveSLAMRewardWeights()
        # The step's signals, the previous step's (the baseline of the gains), and the
        # terms and reward: the reward kernel's batch of one.
        self._now = RewardSignals(
            np.zeros(SINGLE), np.zeros(SINGLE), np.zeros(SINGLE, dtype=np.bool_), np.zeros(SINGLE)
        )
        self._last = np.zeros((SINGLE, 2))  # the previous entropy and swept fraction
        self._terms = np.zeros((SINGLE, len(REWARD_TERMS)))
        self._reward = np.zeros(SINGLE)
        self._one = np.ones(SINGLE, dtype=np.bool_)  # the kernel's mask: the one world

    @property
    def weights(self) -> ActiveSLAMRewardWeights:
        """The weights of the terms."""
        return self._weights

    @weights.setter
    def weights(self, weights: ActiveSLAMRewardWeights) -> None:
        if not isinstance(weights, ActiveSLAMRewardWeights):
            raise TypeError("weights must be an ActiveSLAMRewardWeights")
        self._weights = weights
        self._weight_array = np.array([getattr(weights, name) for name in REWARD_TERMS])

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._require_belief_info(info)
        self._last[0] = (info["entropy"], _swept_fraction(info))
        info["raw_reward_terms"] = info.pop("reward_terms", {})
        info["reward_terms"] = dict.fromkeys(REWARD_TERMS, 0.0)
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, _, terminated, truncated, info = self.env.step(action)
        now = self._now
        now.entropy[0] = info["entropy"]
        now.pose_std[0] = info["pose_std"]
        now.collision[0] = info["collision"]
        now.swept_fraction[0] = _swept_fraction(info)
        active_slam_reward(
            self._weight_array, *now, self._last, self._terms, self._reward, self._one
        )
        info["raw_reward_terms"] = info.pop("reward_terms", {})
        info["reward_terms"] = dict(zip(REWARD_TERMS, self._terms[0].tolist(), strict=True))
        return obs, self._reward.item(), terminated, truncated, info

    def _require_belief_info(self, info: dict[str, Any]) -> None:
        if "entropy" not in info:
            raise TypeError("ActiveSLAMReward must wrap an EKFSLAMWrapper (info has no entropy)")
        if self.weights.coverage and "swept_fraction" not in info:
            raise TypeError(
                "ActiveSLAMReward with a coverage weight must wrap a CoverageWrapper "
                "(info has no swept_fraction)"
            )


def _swept_fraction(info: dict[str, Any]) -> float:
    """The swept share of the arena from a CoverageWrapper below, 0 without one."""
    return info.get("swept_fraction", 0.0)
