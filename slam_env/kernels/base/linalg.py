"""Small dense linear algebra for the kernels: Cholesky factorisation, triangular
solves and the log-determinant, on the leading n×n block of a square array.

Written out rather than taken from ``np.linalg``: numba's ``np.linalg`` needs SciPy's
LAPACK at run time, and the matrices here are small (a 2k×2k innovation covariance,
a belief of tens of rows), where a plain loop costs less than a LAPACK call.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import kernel, summing_kernel


@summing_kernel
def cholesky_in_place(A: np.ndarray, n: int) -> bool:
    """Overwrite the lower triangle of ``A[:n, :n]`` with its Cholesky factor L
    (A = L Lᵀ), reading only that lower triangle; the strict upper triangle is left as
    it was. Returns False, with A partly overwritten, when A is not positive definite
    (a pivot ≤ 0 or NaN)."""
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        A[j, j] = d
        for i in range(j + 1, n):
            t = A[i, j]
            for k in range(j):
                t -= A[i, k] * A[j, k]
            A[i, j] = t / d
    return True


@kernel
def solve_lower_in_place(L: np.ndarray, b: np.ndarray, n: int) -> None:
    """b ← L⁻¹ b for the lower-triangular ``L[:n, :n]`` (forward substitution)."""
    for i in range(n):
        t = b[i]
        for k in range(i):
            t -= L[i, k] * b[k]
        b[i] = t / L[i, i]


@kernel
def solve_lower_transposed_in_place(L: np.ndarray, b: np.ndarray, n: int) -> None:
    """b ← L⁻ᵀ b for the lower-triangular ``L[:n, :n]`` (back substitution on Lᵀ)."""
    for i in range(n - 1, -1, -1):
        t = b[i]
        for k in range(i + 1, n):
            t -= L[k, i] * b[k]
        b[i] = t / L[i, i]


@kernel
def log_det_from_cholesky(L: np.ndarray, n: int) -> float:
    """log det(A) = 2 Σ log Lᵢᵢ from the Cholesky factor of A."""
    total = 0.0
    for i in range(n):
        total += math.log(L[i, i])
    return 2.0 * total
