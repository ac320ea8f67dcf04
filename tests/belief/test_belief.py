"""Belief encodings and SLAM metrics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.belief import metrics
from slam_env.belief.encodings import (
    BeliefGeometry,
    EgocentricEncoding,
    FullEncoding,
    slot_indices,
    unpack_full_belief,
)

GEOMETRY = BeliefGeometry(max_landmarks=6, width=16.0, height=12.0, max_range=5.0)


def _belief(rng, ids):
    """A random valid belief with landmarks ``ids`` in that (state) order."""
    n = len(ids)
    dim = 3 + 2 * n
    mean = np.concatenate([[4.0, 5.0, 2.5], rng.uniform(0, 12, 2 * n)])
    a = rng.normal(size=(dim, dim)) * 0.1
    return mean, a @ a.T + 1e-3 * np.eye(dim), np.array(ids)


def test_egocentric_features_follow_the_documented_layout():
    rng = np.random.default_rng(0)
    mean, cov, ids = _belief(rng, [4, 1, 3])
    enc = EgocentricEncoding(GEOMETRY)
    obs, clipped = enc.encode(mean, cov, ids)
    assert not clipped and obs.dtype == np.float32 and enc.space.contains(obs)
    x, y, th = mean[:3]
    expected = np.zeros(7 + 4 * 6)
    expected[:7] = [
        x / 16.0,
        y / 12.0,
        math.cos(th),
        math.sin(th),
        math.tanh(math.sqrt(cov[0, 0])),
        math.tanh(math.sqrt(cov[1, 1])),
        math.tanh(math.sqrt(cov[2, 2]) / 0.5),
    ]
    for slot, lid in enumerate(ids):
        m = mean[3 + 2 * slot : 5 + 2 * slot]
        d = m - mean[:2]
        local = [
            math.cos(th) * d[0] + math.sin(th) * d[1],
            -math.sin(th) * d[0] + math.cos(th) * d[1],
        ]
        block = cov[3 + 2 * slot : 5 + 2 * slot, 3 + 2 * slot : 5 + 2 * slot]
        expected[7 + 4 * lid : 11 + 4 * lid] = [
            1.0,
            local[0] / 5.0,
            local[1] / 5.0,
            math.tanh(math.sqrt(np.trace(block))),
        ]
    np.testing.assert_allclose(obs, expected, rtol=1e-6, atol=1e-6)


def test_egocentric_tail_is_appended_as_it_is():
    rng = np.random.default_rng(3)
    mean, cov, ids = _belief(rng, [5, 0])
    enc = EgocentricEncoding(GEOMETRY)
    plain, _ = enc.encode(mean, cov, ids)
    tail = [0.25, 1.0, 0.0]
    obs, clipped = enc.encode(mean, cov, ids, tail)
    assert not clipped and obs.dtype == np.float32
    np.testing.assert_array_equal(obs, np.concatenate([plain, np.float32(tail)]))
    mean[3] = 1e9  # a clipped belief keeps its tail too
    obs, clipped = enc.encode(mean, cov, ids, tail)
    assert clipped and obs.shape == (plain.size + 3,)
    np.testing.assert_array_equal(obs[-3:], np.float32(tail))


def test_egocentric_never_hands_out_nan_and_reports_it():
    rng = np.random.default_rng(1)
    mean, cov, ids = _belief(rng, [0, 2])
    mean[4] = np.nan
    cov[0, 0] = np.inf
    enc = EgocentricEncoding(GEOMETRY)
    obs, clipped = enc.encode(mean, cov, ids)
    assert clipped and np.isfinite(obs).all() and enc.space.contains(obs)
    far = mean.copy()
    far[3] = 1e9  # a landmark estimate absurdly far away: clipped into the bounds
    obs, clipped = enc.encode(far, np.nan_to_num(cov, posinf=1.0), ids)
    assert clipped and enc.space.contains(obs)


def test_full_encoding_is_the_belief_slotted_by_id():
    rng = np.random.default_rng(2)
    mean, cov, ids = _belief(rng, [5, 0, 2])
    enc = FullEncoding(GEOMETRY)
    obs, clipped = enc.encode(mean, cov, ids)
    assert not clipped and enc.space.contains(obs)
    full_mean, full_cov, known = unpack_full_belief(obs)
    idx = slot_indices(ids)
    np.testing.assert_allclose(full_mean[idx], mean, rtol=1e-6)
    np.testing.assert_allclose(full_cov[np.ix_(idx, idx)], cov, rtol=1e-5, atol=1e-7)
    assert known.tolist() == [True, False, True, False, False, True]
    # Landmark 5 sits in entries 13, 14 whatever its place in the state.
    np.testing.assert_allclose(full_mean[13:15], mean[3:5], rtol=1e-6)


def test_nees_matches_a_linear_solve_and_handles_degenerate_cases():
    rng = np.random.default_rng(3)
    for _ in range(200):
        a = rng.normal(size=(3, 3))
        cov = a @ a.T + 0.01 * np.eye(3)
        e = rng.normal(size=3)
        assert metrics.nees(e, cov) == pytest.approx(e @ np.linalg.solve(cov, e), rel=1e-8)
    assert metrics.nees(np.zeros(3), np.zeros((3, 3))) == 0.0  # exactly known, exactly right
    assert metrics.nees(np.ones(3), np.zeros((3, 3))) == math.inf
    e2 = np.array([1.0, 2.0])
    assert metrics.nees(e2, np.diag([1.0, 4.0])) == pytest.approx(2.0)


def test_pose_error_wraps_the_heading():
    err = metrics.pose_error([1.0, 2.0, math.pi - 0.1], [0.5, 2.0, -math.pi + 0.1])
    np.testing.assert_allclose(err, [0.5, 0.0, -0.2], atol=1e-12)


def test_entropy_and_log_det():
    cov = np.diag([1.0, 4.0, 9.0])
    assert metrics.log_det_psd(cov) == pytest.approx(math.log(36.0))
    h = metrics.gaussian_entropy(cov)
    assert h == pytest.approx(0.5 * (3 * math.log(2 * math.pi * math.e) + math.log(36.0)))
    singular = np.diag([1.0, 0.0])
    assert math.isfinite(metrics.log_det_psd(singular, floor=1e-4))
    assert metrics.log_det_psd(singular, floor=1e-4) == pytest.approx(
        math.log(1.0 + 1e-4) + math.log(1e-4)
    )


def test_log_det_psd_without_a_copy_raises_the_callers_array():
    cov = np.diag([1.0, 4.0, 0.0])
    expected = metrics.log_det_psd(cov, floor=1e-4)
    scratch = cov.copy()
    assert metrics.log_det_psd(scratch, floor=1e-4, copy=False) == pytest.approx(expected)
    np.testing.assert_array_equal(scratch, cov + 1e-4 * np.eye(3))  # in place
    assert metrics.log_det_psd(cov, floor=1e-4) == expected  # the default copies


def test_map_rmse():
    est = np.array([[0.0, 0.0], [3.0, 4.0]])
    tru = np.zeros((2, 2))
    assert metrics.map_rmse(est, tru) == pytest.approx(math.sqrt(25.0 / 2))
    assert math.isnan(metrics.map_rmse(np.zeros((0, 2)), np.zeros((0, 2))))
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        metrics.map_rmse(np.zeros((2, 3)), np.zeros((2, 3)))


def test_nees_band_is_the_issue_band():
    lo, hi = metrics.nees_band(dof=3, runs=50)
    assert (round(lo, 2), round(hi, 2)) == (2.36, 3.72)
