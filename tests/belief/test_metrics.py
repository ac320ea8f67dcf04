"""slam_env.belief.metrics against independent computations (issue 17): the same numbers
from numpy's solvers and determinants, or from their definitions by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.belief import metrics


def _spd(rng: np.random.Generator, d: int) -> np.ndarray:
    a = rng.normal(size=(d, d))
    return a @ a.T + 0.05 * np.eye(d)


def test_pose_error_takes_the_pose_off_longer_vectors():
    estimate = np.array([1.0, 2.0, 3.0, 9.0, 9.0])  # a whole state: pose first
    truth = np.array([0.5, 2.5, -3.0])
    err = metrics.pose_error(estimate, truth)
    assert err.shape == (3,)
    np.testing.assert_allclose(err, [0.5, -0.5, 6.0 - 2 * math.pi], atol=1e-12)


@pytest.mark.parametrize("d", [2, 3, 5])
def test_nees_is_the_quadratic_form_of_the_inverse(d):
    rng = np.random.default_rng(d)
    for _ in range(50):
        cov = _spd(rng, d)
        e = rng.normal(size=d)
        expected = e @ np.linalg.inv(cov) @ e
        assert metrics.nees(e, cov) == pytest.approx(expected, rel=1e-9)


def test_pose_nees_reads_only_the_upper_triangle():
    """The 3×3 pose NEES assumes symmetry and reads the upper triangle: a lower
    triangle of garbage changes nothing."""
    rng = np.random.default_rng(7)
    cov = _spd(rng, 3)
    e = rng.normal(size=3)
    garbage = np.triu(cov) + np.tril(rng.normal(size=(3, 3)) * 100, -1)
    nees = metrics.pose_nees_from_error(e.tolist(), garbage.tolist())
    assert nees == pytest.approx(e @ np.linalg.solve(cov, e), rel=1e-9)


@pytest.mark.parametrize("d", [2, 3, 4])
def test_nees_of_an_exact_estimate_is_zero_and_of_a_singular_miss_inf(d):
    assert metrics.nees(np.zeros(d), np.zeros((d, d))) == 0.0
    singular = np.diag([1.0] * (d - 1) + [0.0])
    assert metrics.nees(np.ones(d), np.zeros((d, d))) == math.inf
    if d == 3:  # through the adjugate: det ≤ 0 is inf, whatever the error
        assert metrics.nees(np.ones(3), singular) == math.inf
        assert metrics.nees(np.ones(3), -np.eye(3)) == math.inf
        # det > 0 with two negative eigenvalues: the quadratic form is −1, not a NEES
        indefinite = np.diag([-1.0, -1.0, 1.0])
        assert metrics.nees(np.array([1.0, 0.0, 0.0]), indefinite) == math.inf
        assert metrics.nees(np.array([0.0, 0.0, 2.0]), indefinite) == 4.0


def test_map_rmse_by_hand():
    est = np.array([[1.0, 1.0], [4.0, -2.0], [0.0, 0.0]])
    truth = np.array([[1.0, 0.0], [1.0, 2.0], [0.0, 0.0]])
    # Squared errors 1, 9 + 16, 0 over three landmarks.
    assert metrics.map_rmse(est, truth) == pytest.approx(math.sqrt(26.0 / 3.0), rel=1e-15)
    assert metrics.map_rmse(est[1:2], truth[1:2]) == pytest.approx(5.0, rel=1e-15)
    for shape in [(4,), (2, 3), (2, 2, 2)]:
        with pytest.raises(ValueError, match=r"\(n, 2\)"):
            metrics.map_rmse(np.zeros(shape), np.zeros(shape))


@pytest.mark.parametrize("d", [1, 3, 8])
def test_log_det_psd_matches_slogdet_with_and_without_a_floor(d):
    cov = _spd(np.random.default_rng(d), d)
    before = cov.copy()
    assert metrics.log_det_psd(cov) == pytest.approx(np.linalg.slogdet(cov)[1], rel=1e-12)
    floored = np.linalg.slogdet(cov + 0.3 * np.eye(d))[1]
    assert metrics.log_det_psd(cov, floor=0.3) == pytest.approx(floored, rel=1e-12)
    np.testing.assert_array_equal(cov, before)  # copied, not raised in place
    assert metrics.log_det_psd(np.zeros((0, 0))) == 0.0


def test_log_det_psd_clamps_eigenvalues_of_an_indefinite_matrix():
    """Cholesky fails; the eigenvalues are clamped at the floor, or at 1e-300 without
    one (a singular Σ has log det −inf: clamped, it stays a finite number)."""
    cov = np.diag([2.0, 0.0, -1e-9])
    assert metrics.log_det_psd(cov) == pytest.approx(math.log(2.0) + 2 * math.log(1e-300))
    # With a floor the eigenvalues are raised by it, then clamped at it.
    expected = math.log(2.0 + 1e-4) + math.log(1e-4) + math.log(1e-4)
    assert metrics.log_det_psd(np.diag([2.0, 0.0, -1e-3]), floor=1e-4) == pytest.approx(expected)


def test_gaussian_entropy_matches_its_definition():
    cov = _spd(np.random.default_rng(11), 4)
    expected = 0.5 * np.linalg.slogdet(2 * math.pi * math.e * cov)[1]
    assert metrics.gaussian_entropy(cov) == pytest.approx(expected, rel=1e-12)
    floored = 0.5 * np.linalg.slogdet(2 * math.pi * math.e * (cov + 0.01 * np.eye(4)))[1]
    assert metrics.gaussian_entropy(cov, floor=0.01) == pytest.approx(floored, rel=1e-12)


@pytest.mark.parametrize(("dof", "runs", "confidence"), [(3, 50, 0.95), (2, 1, 0.99), (6, 10, 0.9)])
def test_nees_band_is_the_chi2_interval_of_the_averaged_nees(dof, runs, confidence):
    from scipy.stats import chi2

    lo, hi = metrics.nees_band(dof, runs, confidence)
    tail = (1 - confidence) / 2
    assert lo == pytest.approx(chi2.ppf(tail, dof * runs) / runs, rel=1e-6)
    assert hi == pytest.approx(chi2.ppf(1 - tail, dof * runs) / runs, rel=1e-6)
