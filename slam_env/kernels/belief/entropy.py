"""The belief entropy of B worlds over all M landmark slots.

H = ½ (D log 2πe + log det(Σ_full + floor·I)), D = 3 + 2M, where Σ_full is the
belief's covariance with each of the M − n unseen slots carrying an independent
prior (``prior_log_det`` = log det of its 2×2 block raised by the floor): the
dimension never changes, and discovering a landmark lowers H.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import kernel
from slam_env.kernels.base.linalg import cholesky_in_place, log_det_from_cholesky

LOG_2PI_E = math.log(2.0 * math.pi * math.e)


@kernel
def gaussian_entropy(log_det: float, dim: int) -> float:
    """½ log det(2πe Σ) = ½ (dim·log 2πe + log det Σ) of a dim-dimensional Gaussian."""
    return 0.5 * (dim * LOG_2PI_E + log_det)


@kernel
def slots_entropy(live_log_det: float, n: int, slots: int, prior_log_det: float) -> float:
    """The entropy over the pose and all ``slots`` landmark slots, from the log det
    of the live (3 + 2n)² block (raised by the floor) and the unseen slots' prior."""
    return gaussian_entropy(live_log_det + (slots - n) * prior_log_det, 3 + 2 * slots)


@kernel
def belief_entropy(
    P: np.ndarray,
    n: np.ndarray,
    slots: int,
    floor: float,
    prior_log_det: float,
    scratch: np.ndarray,
    entropy: np.ndarray,
    ok: np.ndarray,
    active: np.ndarray,
) -> None:
    """``entropy[b]`` of world b's belief (``P`` (B, dmax, dmax), ``n`` (B,) landmarks
    in the state) over all ``slots`` landmark slots, for Σ + ``floor``·I.

    The log det comes from a Cholesky factor of the live block's lower triangle,
    factored in ``scratch`` (at least (dmax, dmax) float64, overwritten). Where
    Σ + floor·I is not positive definite (round-off), ``ok[b]`` is False and
    ``entropy[b]`` NaN: the caller finishes that world (eigenvalues need LAPACK,
    which kernels do without).
    """
    for b in range(P.shape[0]):
        if not active[b]:
            continue
        d = 3 + 2 * n[b]
        for i in range(d):
            for j in range(i):
                scratch[i, j] = P[b, i, j]
            scratch[i, i] = P[b, i, i] + floor
        ok[b] = cholesky_in_place(scratch, d)
        if ok[b]:
            live = log_det_from_cholesky(scratch, d)
            entropy[b] = slots_entropy(live, n[b], slots, prior_log_det)
        else:
            entropy[b] = math.nan
