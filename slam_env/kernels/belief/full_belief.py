"""The full belief encoding of B worlds: mean, covariance and known-mask slotted by
landmark ID (layout: :class:`slam_env.belief.encodings.FullEncoding`), float32, clipped."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel, kernel


class FullBelief(NamedTuple):
    """Where :func:`encode_full` writes (unpacked), D = 3 + 2M."""

    mean: np.ndarray  # (B, D) float32
    cov: np.ndarray  # (B, D·D) float32, row-major
    known: np.ndarray  # (B, M) float32, 1 for a landmark in the state
    clipped: np.ndarray  # (B,) bool


@kernel
def _slot_row(k: int, slot_to_id: np.ndarray, b: int) -> int:
    """The ID-slotted row of state row k: the pose keeps its rows, landmark slot i's
    rows 3 + 2i, 4 + 2i go to 3 + 2·ID, 4 + 2·ID."""
    if k < 3:
        return k
    i = (k - 3) // 2
    return 3 + 2 * slot_to_id[b, i] + (k - 3) % 2


@kernel
def _clip(v: float, bound: float) -> float:
    """v clipped to ±bound, NaN read as 0."""
    return 0.0 if math.isnan(v) else min(max(v, -bound), bound)


@borrowing_kernel
def encode_full(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    slot_to_id: np.ndarray,
    mean_bound: np.ndarray,
    cov_bound: float,
    mean: np.ndarray,
    cov: np.ndarray,
    known: np.ndarray,
    clipped: np.ndarray,
    active: np.ndarray,
) -> None:
    """World b's belief into ``mean[b]``, ``cov[b]``, ``known[b]`` (a
    :class:`FullBelief`): entries clipped to ``±mean_bound`` ((D,) float64) and
    ``±cov_bound`` (NaN read as 0), unknown slots zero; ``clipped[b]`` is True where
    any entry was changed (or NaN)."""
    dim = mean_bound.shape[0]
    for b in range(x.shape[0]):
        if not active[b]:
            continue
        mean[b, :] = 0.0
        cov[b, :] = 0.0
        known[b, :] = 0.0
        d = 3 + 2 * n[b]
        changed = False
        for i in range(n[b]):
            known[b, slot_to_id[b, i]] = 1.0
        for k in range(d):
            row = _slot_row(k, slot_to_id, b)
            v = x[b, k]
            c = _clip(v, mean_bound[row])
            changed |= c != v
            mean[b, row] = np.float32(c)
            for m in range(d):
                w = P[b, k, m]
                c = _clip(w, cov_bound)
                changed |= c != w
                cov[b, row * dim + _slot_row(m, slot_to_id, b)] = np.float32(c)
        clipped[b] = changed
