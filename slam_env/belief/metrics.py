"""SLAM metrics: pose and map error, NEES, Gaussian entropy, χ² bands, for one
estimate at a time (numpy; the equations the kernels share are theirs)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from slam_env.ekf import chi2_ppf
from slam_env.kernels.belief.diagnostics import pose_nees as kernel_pose_nees
from slam_env.kernels.belief.entropy import gaussian_entropy as kernel_gaussian_entropy
from slam_env.world.frames import wrap_angle


def pose_error(estimate, truth) -> np.ndarray:
    """(dx, dy, dθ) = estimate − truth, heading wrapped to [−π, π)."""
    err = np.asarray(estimate, dtype=np.float64)[:3] - np.asarray(truth, dtype=np.float64)[:3]
    err[2] = wrap_angle(err[2])
    return err


def nees(error, cov) -> float:
    """Normalised estimation error squared eᵀ Σ⁻¹ e: 0 for a zero error (an exactly
    known state), inf if Σ is singular along a non-zero e."""
    error = np.asarray(error, dtype=np.float64)
    if error.shape == (3,):
        return pose_nees_from_error(error.tolist(), np.asarray(cov, dtype=np.float64).tolist())
    if not error.any():
        return 0.0
    try:
        solved = np.linalg.solve(np.asarray(cov, dtype=np.float64), error)
    except np.linalg.LinAlgError:
        return math.inf
    return float(error @ solved)


def pose_nees_from_error(error: list[float], cov: list[list[float]]) -> float:
    """The pose NEES of an error (dx, dy, dθ) given as Python floats, its 3×3
    covariance as nested lists (symmetric: only the upper triangle is read); the
    per-step diagnostics' equation (:func:`slam_env.kernels.belief.diagnostics.pose_nees`)."""
    (a, b, c), (_, d, f), (_, _, g) = cov
    return kernel_pose_nees(error[0], error[1], error[2], a, b, c, d, f, g)


def map_rmse(estimates, truths) -> float:
    """Root-mean-square landmark position error over matched rows, m; nan if none."""
    diff = np.subtract(estimates, truths, dtype=np.float64)
    if diff.ndim != 2 or diff.shape[1] != 2:
        raise ValueError(f"estimates and truths must be (n, 2) arrays, got {diff.shape}")
    if len(diff) == 0:
        return math.nan
    return math.sqrt(float(np.vdot(diff, diff)) / len(diff))


def log_det_psd(cov, floor: float = 0.0, copy: bool = True) -> float:
    """log det(Σ + floor·I) of a symmetric PSD matrix Σ: every eigenvalue raised by
    ``floor``, which keeps the result finite for a singular Σ.

    Tries a Cholesky factorisation first (fast); falls back to eigenvalues (clamped at
    ``floor``, or at 1e-300 without one) when round-off leaves the matrix
    slightly indefinite. ``copy=False`` lets the floor be added to a float64 ``cov``
    in place (a caller's scratch array).
    """
    cov = np.array(cov, dtype=np.float64, copy=copy or None)
    if cov.size == 0:
        return 0.0
    if floor > 0.0:
        cov.flat[:: cov.shape[0] + 1] += floor
    try:
        chol = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        eig = np.linalg.eigvalsh(cov)
        return float(np.sum(np.log(np.maximum(eig, max(floor, 1e-300)))))
    return 2.0 * math.fsum(map(math.log, chol.diagonal().tolist()))


def gaussian_entropy(cov, floor: float = 0.0) -> float:
    """Differential entropy ½·log det(2πe Σ) of a Gaussian, nats."""
    cov = np.asarray(cov, dtype=np.float64)
    return kernel_gaussian_entropy(log_det_psd(cov, floor), cov.shape[0])


def nees_band(dof: int, runs: int, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided band for the NEES averaged over ``runs`` Monte Carlo runs: the
    sum of ``runs`` NEES values is χ²(runs·dof) under a consistent filter."""
    tail = (1.0 - confidence) / 2.0
    total = runs * dof
    return chi2_ppf(tail, total) / runs, chi2_ppf(1.0 - tail, total) / runs


def averaged_nees(episodes: Sequence[Any]) -> tuple[np.ndarray, np.ndarray]:
    """The NEES averaged over episodes step by step: ``(mean, runs)``, two (T_max,)
    arrays over the episodes' per-step NEES (1-D, lengths may differ). A step averages
    the episodes that reached it with a finite NEES (``runs`` of them; NaN where none)."""
    eps = [np.asarray(e, dtype=np.float64).reshape(-1) for e in episodes]
    t_max = max((e.size for e in eps), default=0)
    total = np.zeros(t_max)
    runs = np.zeros(t_max, dtype=np.int64)
    for e in eps:
        ok = np.isfinite(e)
        total[: e.size] += np.where(ok, e, 0.0)
        runs[: e.size] += ok
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(runs > 0, total / np.maximum(runs, 1), np.nan)
    return mean, runs


def nees_bands(dof: int, runs: Any, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """:func:`nees_band` for each entry of ``runs`` (an int array, e.g. the episodes
    averaged at each step): (lower, upper) arrays of its shape, NaN where runs is 0."""
    runs = np.asarray(runs, dtype=np.int64)
    lower = np.full(runs.shape, np.nan)
    upper = np.full(runs.shape, np.nan)
    for n in np.unique(runs[runs > 0]).tolist():
        lower[runs == n], upper[runs == n] = nees_band(dof, n, confidence)
    return lower, upper


def share_in_nees_band(
    episodes: Sequence[Any], dof: int = 3, confidence: float = 0.95, first_step: int = 1
) -> float:
    """The share of steps (from ``first_step``, among those some episode reached with a
    finite NEES) at which the NEES averaged over the episodes lies inside its two-sided
    ``confidence`` χ² band for that many episodes (:func:`nees_band`): about
    ``confidence`` for a consistent filter. NaN when there is no such step. Step 0, the
    reset, is left out by default: the pose is known exactly there (NEES 0)."""
    mean, runs = averaged_nees(episodes)
    mean, runs = mean[first_step:], runs[first_step:]
    counted = runs > 0
    if not counted.any():
        return math.nan
    lower, upper = nees_bands(dof, runs, confidence)
    inside = counted & (mean >= lower) & (mean <= upper)
    return float(np.count_nonzero(inside) / np.count_nonzero(counted))
