"""Injected faults of B worlds (see :mod:`slam_env.faults` for what each one models).

Each step reads :data:`FAULT_UNIFORMS` uniforms per world whatever happens, in this
order: scan dropout, outlier event, outlier choice, outlier range, outlier bearing,
odometry dropout, kidnapping event.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam_env.kernels import kernel

FAULT_UNIFORMS = 7
KIDNAP_UNIFORM = 6  # the column of the kidnapping event, read in Python


class FaultParams(NamedTuple):
    scan_dropout: float
    outlier_rate: float
    odometry_dropout: float
    outlier_min_range: float  # m, spurious detections lie in [this, max_range]
    max_range: float  # m
    bearing_span: float  # rad, spurious bearings lie in ±span/2
    cartesian: bool


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
    in ID order with row −1, when the scan has a free row. Edits z (B, D, 2), ids
    (B, D), rows (B, D) and count (B,) in place. ``params_fields``: the fields of a
    :class:`FaultParams`, a plain tuple."""
    params = FaultParams(*params_fields)
    for b in range(count.shape[0]):
        if not active[b]:
            continue
        u = uniforms[b, offset:]
        if u[0] < params.scan_dropout:
            count[b] = 0
            continue
        k = count[b]
        if not (u[1] < params.outlier_rate and k < ids.shape[1]):
            continue
        # The candidates: IDs seen before and not detected now (ids[b, :k] ascend).
        n_candidates = 0
        j = 0
        for lid in range(seen.shape[1]):
            while j < k and ids[b, j] < lid:
                j += 1
            if seen[b, lid] and not (j < k and ids[b, j] == lid):
                n_candidates += 1
        if n_candidates == 0:
            continue
        pick = min(int(u[2] * n_candidates), n_candidates - 1)
        lid = -1
        j = 0
        for cand in range(seen.shape[1]):
            while j < k and ids[b, j] < cand:
                j += 1
            if seen[b, cand] and not (j < k and ids[b, j] == cand):
                if pick == 0:
                    lid = cand
                    break
                pick -= 1
        r = params.outlier_min_range + (params.max_range - params.outlier_min_range) * u[3]
        phi = (u[4] - 0.5) * params.bearing_span
        at = 0
        while at < k and ids[b, at] < lid:
            at += 1
        for m in range(k, at, -1):  # shift the later rows down one
            z[b, m, 0] = z[b, m - 1, 0]
            z[b, m, 1] = z[b, m - 1, 1]
            ids[b, m] = ids[b, m - 1]
            rows[b, m] = rows[b, m - 1]
        if params.cartesian:
            z[b, at, 0] = r * math.cos(phi)
            z[b, at, 1] = r * math.sin(phi)
        else:
            z[b, at, 0] = r
            z[b, at, 1] = phi
        ids[b, at] = lid
        rows[b, at] = -1
        count[b] = k + 1


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
