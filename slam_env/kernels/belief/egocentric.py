"""The egocentric belief encoding of B worlds: flat float32 features a policy learns
from (layout: :class:`slam_env.belief.encodings.EgocentricEncoding`), clipped to their bounds."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel, kernel


class EgocentricParams(NamedTuple):
    """What fixes the features (passed to :func:`encode_egocentric` unpacked)."""

    scales: np.ndarray  # (5,) float64: width, height (m, the arena), max_range (m, the
    # scale of robot-frame positions), position and heading std scales (σ → tanh(σ/s))
    low: np.ndarray  # (F,) float64, F = 7 + 4M: the bounds, float64 copies of the
    high: np.ndarray  # float32 bounds of the space (clipping in float64 then rounding
    # to float32 equals rounding then clipping: the rounding is monotonic)


@kernel
def _std_feature(variance: float, scale: float) -> float:
    """tanh(σ / scale), a negative variance (round-off) read as 0; NaN stays NaN."""
    return math.tanh(math.sqrt(0.0 if variance < 0.0 else variance) / scale)


@borrowing_kernel
def encode_egocentric(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    slot_to_id: np.ndarray,
    scales: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    tail: np.ndarray,
    out: np.ndarray,
    clipped: np.ndarray,
    active: np.ndarray,
    feat: np.ndarray,
) -> None:
    """World b's features into ``out[b, :F]`` (float32), then ``tail[b]`` ((B, T)
    float32, the raw proximity readings, already inside their bounds) as it is.
    ``scales``, ``low``, ``high``: an :class:`EgocentricParams`.

    A belief that leaves the bounds, or holds a NaN or an infinity, has diverged: its
    features are clipped onto the bounds (NaN read as 0) and ``clipped[b]`` is True.
    ``feat``: (F,) float64 scratch.
    """
    width, height, max_range, position_scale, heading_scale = scales
    size = low.shape[0]
    for b in range(x.shape[0]):
        if not active[b]:
            continue
        feat[:] = 0.0
        px, py, theta = x[b, 0], x[b, 1], x[b, 2]
        c, s = math.cos(theta), math.sin(theta)
        feat[0] = px / width
        feat[1] = py / height
        feat[2] = c
        feat[3] = s
        feat[4] = _std_feature(P[b, 0, 0], position_scale)
        feat[5] = _std_feature(P[b, 1, 1], position_scale)
        feat[6] = _std_feature(P[b, 2, 2], heading_scale)
        # The robot frame, R(θ)ᵀ (m − t), scaled by the sensor range.
        ck, sk = c / max_range, s / max_range
        for i in range(n[b]):
            row = 3 + 2 * i
            rx, ry = x[b, row] - px, x[b, row + 1] - py
            slot = 7 + 4 * slot_to_id[b, i]
            feat[slot] = 1.0
            feat[slot + 1] = rx * ck + ry * sk
            feat[slot + 2] = ry * ck - rx * sk
            trace = P[b, row, row] + P[b, row + 1, row + 1]
            feat[slot + 3] = _std_feature(trace, position_scale)
        inside = True
        for k in range(size):
            if not low[k] <= feat[k] <= high[k]:  # or NaN
                inside = False
        clipped[b] = not inside
        for k in range(size):
            v = feat[k]
            if not inside:
                v = min(max(0.0 if math.isnan(v) else v, low[k]), high[k])
            out[b, k] = np.float32(v)
        for k in range(tail.shape[1]):
            out[b, size + k] = tail[b, k]
