"""The update's one pass over the covariance, P ← P − Uᵀ U (``apply_factors``), held
to the plain sum it stands for: every entry as ((P − u₀ᵢu₀ⱼ) − u₁ᵢu₁ⱼ) − …, bit for
bit, whatever the live size's remainder by the kernel's blocks of four rows."""

from __future__ import annotations

import numpy as np
import pytest

from slam_env.kernels.ekf.corrections import apply_factors


def reference(P: np.ndarray, U: np.ndarray, r: int, d: int) -> np.ndarray:
    out = P.copy()
    for rho in range(r):
        out[:d, :d] -= np.outer(U[rho, :d], U[rho, :d])  # one rounding per product, per difference
    return out


@pytest.mark.parametrize("d", [1, 2, 3, 4, 5, 6, 7, 8, 9, 13, 43, 64, 101])
@pytest.mark.parametrize("r", [0, 2, 4, 10])
def test_apply_factors_is_the_plain_sum_bit_for_bit_and_leaves_the_rest(d: int, r: int) -> None:
    rng = np.random.default_rng(1000 * d + r)
    dmax = d + 6
    A = rng.normal(size=(dmax, dmax))
    P = A @ A.T + dmax * np.eye(dmax)
    P = (P + P.T) / 2  # exactly symmetric, as the filter keeps it
    U = np.full((12, dmax), np.nan)  # the factor rows past d are never read
    U[:, :d] = rng.normal(size=(12, d)) * rng.uniform(0.1, 3.0)
    expected = reference(P, U, r, d)
    apply_factors(P, U, r, d)
    np.testing.assert_array_equal(P, expected)
    assert np.array_equal(P, P.T)


def test_apply_factors_keeps_huge_and_tiny_entries_symmetric() -> None:
    rng = np.random.default_rng(7)
    d = 23
    P = np.diag(10.0 ** rng.uniform(-12, 12, size=d))
    U = rng.normal(size=(6, d)) * 10.0 ** rng.uniform(-8, 4, size=d)
    expected = reference(P, U, 6, d)
    apply_factors(P, U, 6, d)
    np.testing.assert_array_equal(P, expected)
    assert np.array_equal(P, P.T)
