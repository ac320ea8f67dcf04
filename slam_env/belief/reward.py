"""The active-SLAM reward's named terms and their weights (the reward itself is the
kernel :func:`slam_env.kernels.belief.reward.active_slam_reward`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["REWARD_TERMS", "ActiveSLAMRewardWeights"]

REWARD_TERMS = ("information_gain", "pose_uncertainty", "collision", "step", "coverage")


@dataclass(frozen=True)
class ActiveSLAMRewardWeights:
    """Weights of the active-SLAM reward terms (see :class:`ActiveSLAMReward`)."""

    information_gain: float = 0.1  # per nat of entropy removed
    pose_uncertainty: float = 0.1  # per m of pose standard deviation, each step
    collision: float = 1.0  # per step in contact
    step: float = 0.01  # per step
    coverage: float = 0.0  # per share of the arena newly swept (needs a CoverageWrapper)

    def __post_init__(self) -> None:
        for name in REWARD_TERMS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"reward weight {name} must be a number, got {value!r}")
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"reward weight {name} must be finite and >= 0, got {value}")
