"""The active-SLAM reward of B worlds as named terms (the formula: README and
:class:`slam_env.belief.reward_wrapper.ActiveSLAMReward`):

    information_gain = w₀ (H_{t−1} − H_t)      pose_uncertainty = −w₁ σ_pose
    collision = −w₂ in contact, else 0         step = −w₃
    coverage = w₄ (s_t − s_{t−1})

and the reward, their sum in that order.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from slam_env.kernels.base.compiling import kernel


class RewardSignals(NamedTuple):
    """What a step's terms are paid on, (B,) each (passed to
    :func:`active_slam_reward` unpacked)."""

    entropy: np.ndarray  # float64, nats
    pose_std: np.ndarray  # float64, m
    collision: np.ndarray  # bool, the step ended in contact
    swept_fraction: np.ndarray  # float64, 0 without a coverage memory


@kernel
def active_slam_reward(
    weights: np.ndarray,
    entropy: np.ndarray,
    pose_std: np.ndarray,
    collision: np.ndarray,
    swept_fraction: np.ndarray,
    last: np.ndarray,
    terms: np.ndarray,
    reward: np.ndarray,
    active: np.ndarray,
) -> None:
    """``terms[b]`` ((B, 5) float64, in the order above) and ``reward[b]`` of world b's
    step (the :class:`RewardSignals` ``entropy`` … ``swept_fraction``) against
    ``last[b]`` ((B, 2) float64: the previous entropy and swept fraction, which then
    take this step's, the baseline of the next). ``weights`` (5,) float64, each ≥ 0."""
    for b in range(terms.shape[0]):
        if not active[b]:
            continue
        terms[b, 0] = weights[0] * (last[b, 0] - entropy[b])
        terms[b, 1] = -weights[1] * pose_std[b]
        terms[b, 2] = -weights[2] if collision[b] else 0.0
        terms[b, 3] = -weights[3]
        terms[b, 4] = weights[4] * (swept_fraction[b] - last[b, 1])
        total = 0.0
        for k in range(5):
            total += terms[b, k]
        reward[b] = total
        last[b, 0] = entropy[b]
        last[b, 1] = swept_fraction[b]
