"""The active-SLAM reward's named terms and their weights (the reward itself is the
kernel :func:`slam_env.kernels.belief.reward.active_slam_reward`)."""

from __future__ import annotations

from dataclasses import dataclass

from slam_env.config import check_options, option

__all__ = ["REWARD_TERMS", "ActiveSLAMRewardWeights"]

REWARD_TERMS = ("information_gain", "pose_uncertainty", "collision", "step", "coverage")


@dataclass(frozen=True)
class ActiveSLAMRewardWeights:
    """Weights of the active-SLAM reward terms (see :class:`ActiveSLAMReward`)."""

    information_gain: float = option(0.1, "per nat of entropy the step removed", low=0)
    pose_uncertainty: float = option(0.1, "per m of pose standard deviation, each step", low=0)
    collision: float = option(1.0, "per step in contact", low=0)
    step: float = option(0.01, "per step", low=0)
    coverage: float = option(0.0, "per share of the arena newly swept (needs coverage)", low=0)

    def __post_init__(self) -> None:
        check_options(self)
