"""Per-step diagnostics of B worlds' beliefs against the truth: pose and heading
error, map RMSE, pose NEES and pose standard deviation."""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.angles import wrap
from slam_env.kernels.base.compiling import kernel

# The map RMSE of a belief that holds no landmark yet: the one place that says what
# it reads (a number, not an error, so that every world has one).
EMPTY_MAP_RMSE = math.nan
# The pose NEES where it is undefined: a pose covariance that is singular along the
# error, or beyond float64's resolution (its determinant underflows), gives inf, which
# no average or plot can use; like the empty map's RMSE, it is left out of info.
UNDEFINED_NEES = math.nan


# The rows of :func:`belief_diagnostics`'s output, in order:
DIAGNOSTICS = (
    "pose_error",  # m, |estimated − true position|
    "heading_error",  # rad, |wrapped estimated − true heading|
    "map_rmse",  # m, over the landmarks in the state (EMPTY_MAP_RMSE if none)
    "pose_nees",  # eᵀ P_xx⁻¹ e of the pose error e (UNDEFINED_NEES if not finite)
    "pose_std",  # m, √(P_xx[0, 0] + P_xx[1, 1]), 0 for a negative trace
)
POSE_ERROR, HEADING_ERROR, MAP_RMSE, POSE_NEES, POSE_STD = range(len(DIAGNOSTICS))


@kernel
def pose_nees(
    e0: float, e1: float, e2: float, a: float, b: float, c: float, d: float, f: float, g: float
) -> float:
    """eᵀ P⁻¹ e of the pose error e = (e0, e1, e2) for the symmetric 3×3 P with upper
    triangle (a, b, c; d, f; g), through its adjugate: 0 for a zero error (an exactly
    known pose, exactly right), inf when det P ≤ 0 (or NaN) or when the quadratic form
    comes out negative (P not positive definite although det P > 0: rounding can leave
    a nearly singular P so)."""
    if e0 == 0.0 and e1 == 0.0 and e2 == 0.0:
        return 0.0
    cof_a = d * g - f * f
    cof_b = c * f - b * g
    cof_c = b * f - c * d
    det = a * cof_a + b * cof_b + c * cof_c
    if not det > 0.0:
        return math.inf
    quad = (
        cof_a * e0 * e0
        + (a * g - c * c) * e1 * e1
        + (a * d - b * b) * e2 * e2
        + 2.0 * (cof_b * e0 * e1 + cof_c * e0 * e2 + (b * c - a * f) * e1 * e2)
    )
    if not quad >= 0.0:
        return math.inf
    return quad / det


@kernel
def belief_diagnostics(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    slot_to_id: np.ndarray,
    true_pose: np.ndarray,
    true_landmarks: np.ndarray,
    out: np.ndarray,
    active: np.ndarray,
) -> None:
    """The diagnostics of world b's belief (``x``, ``P``, ``n``, ``slot_to_id`` as in
    :class:`slam_env.kernels.belief.belief_state.BeliefBatch`) against its true pose
    ``true_pose[b]`` (x, y, θ) and landmark positions ``true_landmarks[b, id]``
    ((B, M, 2), by landmark ID), into ``out[:, b]`` ((len(DIAGNOSTICS), B) float64,
    a row per diagnostic). A slot whose ID is -1 (a landmark the filter started from
    clutter) has no true position and is left out of the map error."""
    for b in range(x.shape[0]):
        if not active[b]:
            continue
        e0 = x[b, 0] - true_pose[b, 0]
        e1 = x[b, 1] - true_pose[b, 1]
        e2 = wrap(x[b, 2] - true_pose[b, 2])
        out[POSE_ERROR, b] = math.hypot(e0, e1)
        out[HEADING_ERROR, b] = abs(e2)
        nees = pose_nees(
            e0, e1, e2, P[b, 0, 0], P[b, 0, 1], P[b, 0, 2], P[b, 1, 1], P[b, 1, 2], P[b, 2, 2]
        )
        out[POSE_NEES, b] = nees if math.isfinite(nees) else UNDEFINED_NEES
        position_var = P[b, 0, 0] + P[b, 1, 1]
        out[POSE_STD, b] = 0.0 if position_var < 0.0 else math.sqrt(position_var)
        k = n[b]
        if k == 0:
            out[MAP_RMSE, b] = EMPTY_MAP_RMSE
            continue
        total = 0.0
        matched = 0
        for i in range(k):
            lid = slot_to_id[b, i]
            if lid < 0:  # a landmark started from clutter: no true position
                continue
            dx = x[b, 3 + 2 * i] - true_landmarks[b, lid, 0]
            dy = x[b, 4 + 2 * i] - true_landmarks[b, lid, 1]
            total += dx * dx + dy * dy
            matched += 1
        out[MAP_RMSE, b] = math.sqrt(total / matched) if matched else EMPTY_MAP_RMSE
