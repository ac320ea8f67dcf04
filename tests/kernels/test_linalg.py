"""The small dense linear algebra of the kernels against numpy's LAPACK."""

from __future__ import annotations

import numpy as np
import pytest

from slam_env.kernels.base.linalg import (
    cholesky_in_place,
    log_det_from_cholesky,
    solve_lower_in_place,
    solve_lower_transposed_in_place,
)


def _spd(rng: np.random.Generator, n: int) -> np.ndarray:
    a = rng.standard_normal((n, n))
    return a @ a.T + 0.1 * np.eye(n)


@pytest.mark.parametrize("n", [1, 2, 5, 17])
def test_cholesky_matches_numpy_on_the_leading_block(n: int) -> None:
    rng = np.random.default_rng(n)
    A = _spd(rng, n)
    buf = np.full((n + 3, n + 3), 7.0)  # a larger array: only the n×n block is used
    buf[:n, :n] = A
    assert cholesky_in_place(buf, n)
    L = np.tril(buf[:n, :n])
    np.testing.assert_allclose(L, np.linalg.cholesky(A), rtol=1e-12, atol=1e-12)
    assert np.all(np.triu(buf[:n, :n], 1) == np.triu(A, 1))  # upper triangle untouched
    assert np.all(buf[n:, :] == 7.0) and np.all(buf[:, n:] == 7.0)
    assert log_det_from_cholesky(buf, n) == pytest.approx(np.linalg.slogdet(A)[1], rel=1e-12)


@pytest.mark.parametrize("bad", [np.diag([1.0, -1.0]), np.diag([1.0, 0.0]), np.diag([np.nan, 1.0])])
def test_cholesky_refuses_a_matrix_that_is_not_positive_definite(bad: np.ndarray) -> None:
    assert not cholesky_in_place(bad.copy(), 2)


def test_triangular_solves_invert_l_and_its_transpose() -> None:
    rng = np.random.default_rng(3)
    n = 6
    L = np.linalg.cholesky(_spd(rng, n))
    b = rng.standard_normal(n)
    x = b.copy()
    solve_lower_in_place(L, x, n)
    np.testing.assert_allclose(L @ x, b, rtol=1e-12, atol=1e-12)
    y = b.copy()
    solve_lower_transposed_in_place(L, y, n)
    np.testing.assert_allclose(L.T @ y, b, rtol=1e-12, atol=1e-12)
