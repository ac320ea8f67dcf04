"""Injected faults of B worlds (see :mod:`slam_env.world.kidnap` for what each one models).

Each step reads :data:`FAULT_UNIFORMS` uniforms per world whatever happens, in this
order: scan dropout, outlier event, outlier choice, outlier range, outlier bearing,
odometry dropout, kidnapping event; and, only where clutter is on (so that the streams
of every other configuration stay as they were), :data:`CLUTTER_UNIFORMS` more: clutter
event, range, bearing.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam_env.kernels.base.compiling import kernel

FAULT_UNIFORMS = 7
KIDNAP_UNIFORM = 6  # the column of the kidnapping event, read in Python
CLUTTER_UNIFORMS = 3


class FaultParams(NamedTuple):
    scan_dropout: float
    outlier_rate: float
    odometry_dropout: float
    outlier_min_range: float  # m, spurious detections lie in [this, max_range]
    max_range: float  # m
    bearing_span: float  # rad, spurious bearings lie in ±span/2
    cartesian: bool
    clutter_rate: float


@kernel
def _spurious(params: FaultParams, u_range: float, u_bearing: float) -> tuple[float, float]:
    """A spurious measurement inside the sensor's footprint: range in [min, max],
    bearing in ±span/2 (or that point in the robot frame)."""
    r = params.outlier_min_range + (params.max_range - params.outlier_min_range) * u_range
    phi = (u_bearing - 0.5) * params.bearing_span
    if params.cartesian:
        return r * math.cos(phi), r * math.sin(phi)
    return r, phi


@kernel
def _insert_outlier(
    params: FaultParams,
    seen: np.ndarray,
    u: np.ndarray,
    z: np.ndarray,
    ids: np.ndarray,
    rows: np.ndarray,
    k: int,
) -> int:
    """The outlier fault on one world's scan (``ids[:k]`` ascending): its new count."""
    if not (u[1] < params.outlier_rate and k < ids.shape[0]):
        return k
    # The candidates: IDs seen before and not detected now.
    n_candidates = 0
    j = 0
    for lid in range(seen.shape[0]):
        while j < k and ids[j] < lid:
            j += 1
        if seen[lid] and not (j < k and ids[j] == lid):
            n_candidates += 1
    if n_candidates == 0:
        return k
    pick = min(int(u[2] * n_candidates), n_candidates - 1)
    lid = -1
    j = 0
    for cand in range(seen.shape[0]):
        while j < k and ids[j] < cand:
            j += 1
        if seen[cand] and not (j < k and ids[j] == cand):
            if pick == 0:
                lid = cand
                break
            pick -= 1
    z0, z1 = _spurious(params, u[3], u[4])
    at = 0
    while at < k and ids[at] < lid:
        at += 1
    for m in range(k, at, -1):  # shift the later rows down one
        z[m, 0] = z[m - 1, 0]
        z[m, 1] = z[m - 1, 1]
        ids[m] = ids[m - 1]
        rows[m] = rows[m - 1]
    z[at, 0] = z0
    z[at, 1] = z1
    ids[at] = lid
    rows[at] = -1
    return k + 1


@kernel
def corrupt_scans(
    params_fields: tuple,
    seen: np.ndarray,
    uniforms: np.ndarray,
    offset: int,
    active: np.ndarray,
    z: np.ndarray,
    ids: np.ndarray,
    rows: np.ndarray,
    count: np.ndarray,
) -> None:
    """Scan dropout, then one spurious detection: with probability ``outlier_rate`` a
    random [range, bearing] (or robot-frame point) inside the sensor's footprint,
    reported with the ID of a landmark seen earlier in the episode (``seen`` (B, M))
    but not in this scan — a wrong association a χ² gate should reject. It is inserted
    in ID order with row −1, when the scan has a free row. Then clutter: with
    probability ``clutter_rate`` a random measurement of no landmark (ID −1, row −1),
    appended when the scan has a free row. Edits z (B, D, 2), ids (B, D), rows (B, D)
    and count (B,) in place. ``params_fields``: the fields of a :class:`FaultParams`,
    a plain tuple."""
    params = FaultParams(*params_fields)
    for b in range(count.shape[0]):
        if not active[b]:
            continue
        u = uniforms[b, offset:]
        if u[0] < params.scan_dropout:
            count[b] = 0
            continue
        k = _insert_outlier(params, seen[b], u, z[b], ids[b], rows[b], count[b])
        clutter = params.clutter_rate > 0.0 and u[FAULT_UNIFORMS] < params.clutter_rate
        if clutter and k < ids.shape[1]:
            z0, z1 = _spurious(params, u[FAULT_UNIFORMS + 1], u[FAULT_UNIFORMS + 2])
            z[b, k, 0] = z0
            z[b, k, 1] = z1
            ids[b, k] = -1
            rows[b, k] = -1
            k += 1
        count[b] = k


@kernel
def corrupt_odometry(
    dropout: float,
    bias: np.ndarray,
    uniforms: np.ndarray,
    offset: int,
    active: np.ndarray,
    reading: np.ndarray,
) -> None:
    """Odometry dropout (the reading is zero motion), then the constant ``bias``
    (control_dim,) added, in place on reading (B, control_dim)."""
    for b in range(reading.shape[0]):
        if not active[b]:
            continue
        lost = uniforms[b, offset + 5] < dropout
        for i in range(reading.shape[1]):
            reading[b, i] = (0.0 if lost else reading[b, i]) + bias[i]
