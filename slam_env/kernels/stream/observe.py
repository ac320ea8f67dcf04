"""The raw observation of B worlds (float32, clipped to its bounds), the landmarks seen
so far, and the raw env's scripting reward."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from slam_env.kernels.base.compiling import kernel


class RawParams(NamedTuple):
    """The bounds the raw observation is clipped to (float64 copies of the float32
    bounds of its space: clipping in float64 then rounding to float32 equals rounding
    then clipping, the rounding is monotonic) and the raw env's reward."""

    odometry_low: np.ndarray  # (control_dim,)
    odometry_high: np.ndarray
    detection_low: np.ndarray  # (2,) per measurement component
    detection_high: np.ndarray
    new_landmark_bonus: float  # reward per landmark detected for the first time
    collision_penalty: float  # subtracted on a step with a collision
    report_ids: bool  # False: every detection's ID reads -1


class RawOutputs(NamedTuple):
    """Where :func:`observe_raw` writes, (B, …) each."""

    odometry: np.ndarray  # (B, control_dim) float32
    detections: np.ndarray  # (B, 2D) float32, row-major [z0, z1] pairs, zero padding
    ids: np.ndarray  # (B, D) float32, −1 padding, clutter and hidden IDs
    mask: np.ndarray  # (B, D) float32
    bumper: np.ndarray  # (B, 1) float32
    all_seen: np.ndarray  # (B,) bool, every landmark of the world seen
    new_terms: np.ndarray  # (B,) float64, the reward terms: new landmarks …
    collision_terms: np.ndarray  # (B,) … and collision,
    rewards: np.ndarray  # (B,) their sum


@kernel
def _clip(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


@kernel
def observe_raw(
    control: np.ndarray,
    z: np.ndarray,
    ids: np.ndarray,
    count: np.ndarray,
    collided: np.ndarray,
    landmark_ids: np.ndarray,
    params_fields: tuple,
    active: np.ndarray,
    seen: np.ndarray,
    out_fields: tuple,
) -> None:
    """The raw observation of each active world from its odometry reading
    ``control`` (B, c), its detections (z (B, D, 2), ids (B, D), count (B,)) and its
    collision flag; marks the detected IDs in ``seen`` (B, M) and pays the new ones
    (clutter, ID −1, is no landmark). The IDs read −1 where the sensor reports none.
    ``params_fields`` and ``out_fields`` are the fields of a :class:`RawParams` and a
    :class:`RawOutputs`, as plain tuples (see :mod:`slam_env.kernels`)."""
    params = RawParams(*params_fields)
    out = RawOutputs(*out_fields)
    for b in range(control.shape[0]):
        if not active[b]:
            continue
        for i in range(control.shape[1]):
            lo, hi = params.odometry_low[i], params.odometry_high[i]
            out.odometry[b, i] = _clip(control[b, i], lo, hi)
        k = count[b]
        new = 0
        for j in range(ids.shape[1]):
            if j < k:
                for c in range(2):
                    lo, hi = params.detection_low[c], params.detection_high[c]
                    out.detections[b, 2 * j + c] = _clip(z[b, j, c], lo, hi)
                lid = ids[b, j]
                out.ids[b, j] = lid if params.report_ids else -1.0
                out.mask[b, j] = 1.0
                if lid >= 0 and not seen[b, lid]:
                    seen[b, lid] = True
                    new += 1
            else:
                out.detections[b, 2 * j] = 0.0
                out.detections[b, 2 * j + 1] = 0.0
                out.ids[b, j] = -1.0
                out.mask[b, j] = 0.0
        out.bumper[b, 0] = 1.0 if collided[b] else 0.0
        out.new_terms[b] = params.new_landmark_bonus * new
        out.collision_terms[b] = -params.collision_penalty if collided[b] else 0.0
        out.rewards[b] = 0.0 + out.new_terms[b] + out.collision_terms[b]
        everything = True
        for i in range(landmark_ids.shape[1]):
            if not seen[b, landmark_ids[b, i]]:
                everything = False
                break
        out.all_seen[b] = everything


@kernel
def filter_inputs(
    odometry: np.ndarray,
    detections: np.ndarray,
    ids: np.ndarray,
    active: np.ndarray,
    out_u: np.ndarray,
    out_z: np.ndarray,
    out_ids: np.ndarray,
    counts: np.ndarray,
    out_counts: np.ndarray,
    known: bool,
) -> None:
    """What the filter reads of each active world's raw observation, as the belief
    wrapper reads it from the observation itself (float32 values, widened exactly):
    the control ``out_u`` (B, c) from ``odometry``, the first ``counts[b]``
    measurements ``out_z`` (B, D, 2) from ``detections`` (B, 2D) and their IDs
    ``out_ids`` (B, D) int64 from ``ids`` (B, D), their number in ``out_counts``. A
    filter with ``known`` correspondences cannot use a detection without an ID
    (clutter): those are left out."""
    for b in range(odometry.shape[0]):
        if not active[b]:
            continue
        for i in range(odometry.shape[1]):
            out_u[b, i] = odometry[b, i]
        k = 0
        for j in range(counts[b]):
            lid = int(ids[b, j])
            if known and lid < 0:
                continue
            out_z[b, k, 0] = detections[b, 2 * j]
            out_z[b, k, 1] = detections[b, 2 * j + 1]
            out_ids[b, k] = lid
            k += 1
        out_counts[b] = k
