"""Bad inputs (controls, observations, resets, lookups) raise a clear ValueError or
TypeError naming what was wrong, and a failed call leaves the filter unchanged."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.ekf import EKFSLAM
from tests.ekf.filter_options import with_


@pytest.fixture
def busy_filter():
    f = EKFSLAM(**with_(gate=9.0))
    f.update([[2.0, 0.1], [3.0, -0.4]], [0, 3])
    f.predict((0.1, 0.5, 0.0))
    f.update([[1.6, 0.0], [9.0, 0.0]], [0, 3])  # the second one is rejected
    assert f.n_rejected == 1
    return f


@pytest.mark.parametrize(
    ("u", "error", "match"),
    [
        ((0.1, 0.5), ValueError, r"u must have shape \(3,\)"),
        ([[0.1, 0.5, 0.0]], ValueError, r"u must have shape \(3,\)"),
        ((0.1, math.nan, 0.0), ValueError, "u must be finite"),
        ((0.1, math.inf, 0.0), ValueError, "u must be finite"),
        (("a", 0.5, 0.0), TypeError, "u must be an array of numbers"),
    ],
)
def test_bad_control_is_refused_and_changes_nothing(
    busy_filter, take_snapshot, same_snapshot, u, error, match
):
    before = take_snapshot(busy_filter)
    with pytest.raises(error, match=match):
        busy_filter.predict(u)
    same_snapshot(before, take_snapshot(busy_filter))


@pytest.mark.parametrize(
    ("z", "ids", "error", "match"),
    [
        ([[2.0, 0.1]], [5], ValueError, r"landmark id 5 is beyond capacity \(max_landmarks=5\)"),
        ([[2.0, 0.1], [1.0, 0.0]], [0, 99], ValueError, "landmark id 99 is beyond capacity"),
        ([[2.0, 0.1]], [-1], ValueError, "landmark id -1 is negative"),
        ([[2.0, 0.1], [1.0, 0.0], [1.0, 1.0]], [1, 4, 1], ValueError, "duplicate landmark id 1"),
        ([[2.0, 0.1], [1.0, 0.0]], [0, 0], ValueError, "duplicate landmark id 0"),
        ([[2.0, math.nan]], [1], ValueError, r"z must be finite; row 0"),
        ([[2.0, 0.1], [math.inf, 0.0]], [1, 0], ValueError, r"z must be finite; row 1"),
        ([2.0, 0.1], [1], ValueError, r"z must have shape \(k, 2\)"),
        ([[2.0, 0.1, 0.0]], [1], ValueError, r"z must have shape \(k, 2\)"),
        ([[2.0, 0.1]], [1, 2], ValueError, r"ids must have shape \(1,\)"),
        ([[2.0, 0.1]], 1, ValueError, r"ids must have shape \(1,\)"),
        ([[2.0, 0.1]], [1.0], TypeError, "ids must be integers"),
        ([[2.0, 0.1]], [True], TypeError, "ids must be integers"),
        ([["a", "b"]], [1], TypeError, r"z must be a \(k, 2\) array of numbers"),
    ],
)
def test_bad_observations_are_refused_and_change_nothing(
    busy_filter, take_snapshot, same_snapshot, z, ids, error, match
):
    before = take_snapshot(busy_filter)
    with pytest.raises(error, match=match):
        busy_filter.update(z, ids)
    same_snapshot(before, take_snapshot(busy_filter))
    # ... and the filter still works afterwards.
    busy_filter.update([[1.5, 0.0]], [0])


@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_a_late_bad_id_is_caught_before_anything_is_applied(
    take_snapshot, same_snapshot, correction
):
    f = EKFSLAM(**with_(correction=correction))
    f.update([[2.0, 0.1], [3.0, -0.4]], [0, 3])
    before = take_snapshot(f)
    # Valid corrections and a new landmark come first; the bad id is last.
    with pytest.raises(ValueError, match="beyond capacity"):
        f.update([[2.1, 0.1], [3.1, -0.4], [1.0, 1.0], [1.0, 0.0]], [0, 3, 2, 7])
    same_snapshot(before, take_snapshot(f))


def test_bad_reset_is_refused_and_changes_nothing(busy_filter, take_snapshot, same_snapshot):
    before = take_snapshot(busy_filter)
    with pytest.raises(ValueError, match="initial_pose_cov must be positive semi-definite"):
        busy_filter.reset(initial_pose_cov=-np.eye(3))
    with pytest.raises(ValueError, match=r"initial_pose must have shape \(3,\)"):
        busy_filter.reset(initial_pose=(1.0, 2.0))
    same_snapshot(before, take_snapshot(busy_filter))


def test_unknown_landmark_lookup(busy_filter):
    with pytest.raises(ValueError, match="landmark id 1 is not in the state"):
        busy_filter.landmark(1)
    with pytest.raises(ValueError, match="landmark id -2 is not in the state"):
        busy_filter.landmark(-2)
    with pytest.raises(TypeError, match="landmark id must be an int"):
        busy_filter.landmark("0")
    mean, cov = busy_filter.landmark(np.int64(3))
    assert mean.shape == (2,) and cov.shape == (2, 2)


@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_a_covariance_that_lost_definiteness_is_reported_and_changes_nothing(
    take_snapshot, same_snapshot, correction
):
    f = EKFSLAM(**with_(correction=correction, gate=9.0))
    f.update([[2.0, 0.1], [3.0, -0.4], [2.5, 0.3]], [0, 3, 1])
    # White box: corrupt landmark 3's block so that S = H P Hᵀ + Q is indefinite
    # (a valid filter cannot get there: S ⪰ Q ≻ 0 whenever P ⪰ 0).
    s = 3 + 2 * int(f.id_to_state[3])
    f._P[s : s + 2, s : s + 2] = -10.0 * np.eye(2)
    before = take_snapshot(f)
    # Landmark 0 is corrected and landmark 1 rejected before landmark 3 fails.
    with pytest.raises(FloatingPointError, match="not positive definite"):
        f.update([[2.1, 0.12], [9.0, 0.0], [3.0, -0.4]], [0, 1, 3])
    same_snapshot(before, take_snapshot(f))


@pytest.mark.parametrize(
    ("call", "args", "match"),
    [
        ("predict", (np.array([0.1, 0.2, 0.0]) + 0j,), "u must be an array of numbers"),
        ("predict", (np.array([True, False, True]),), "u must be an array of numbers"),
        ("predict", (np.array(["0.1", "0.2", "0"]),), "u must be an array of numbers"),
        ("predict", (np.array([0.1, 0.2, None], dtype=object),), "u must be an array of numbers"),
        ("predict", ([0.1, 0.2, 1j],), "u must be an array of numbers"),
        ("update", (np.array([[2.0, 0.1]]) + 0j, [1]), r"z must be a \(k, 2\) array of numbers"),
        ("update", (np.array([[True, False]]), [1]), r"z must be a \(k, 2\) array of numbers"),
        ("update", ([[2.0, None]], [1]), r"z must be a \(k, 2\) array of numbers"),
        ("update", ([[2.0, 0.1]], np.array([1 + 0j])), "ids must be integers"),
        ("update", ([[2.0, 0.1]], np.array(["1"])), "ids must be integers"),
        ("update", ([[2.0, 0.1]], np.array([2**63], dtype=np.uint64)), "beyond the int64 range"),
    ],
)
def test_values_that_are_not_real_numbers_are_refused_not_cast(
    busy_filter, take_snapshot, same_snapshot, call, args, match
):
    before = take_snapshot(busy_filter)
    with pytest.raises((TypeError, ValueError), match=match):
        getattr(busy_filter, call)(*args)
    same_snapshot(before, take_snapshot(busy_filter))


def test_numpy_numbers_are_taken_as_numbers():
    f = EKFSLAM(
        **with_(
            gate=np.float32(9.0),
            alphas=np.array([0.01, 0.01, 0.01, 0.01], dtype=np.float32),
            max_landmarks=np.int64(5),
        )
    )
    f.predict(np.array([0.1, 0.5, 0.0], dtype=np.float32))
    res = f.update(np.array([[2.0, 0.1]], dtype=np.float32), np.array([3], dtype=np.uint8))
    assert res.status.tolist() == [1] and res.ids.dtype == np.int64
    assert f.gate == pytest.approx(9.0)


def test_the_belief_arrays_are_the_live_batched_state_read_only(busy_filter):
    x, P, n, slot_to_id = busy_filter.belief_arrays()
    assert x.shape == (1, 13) and P.shape == (1, 13, 13) and n.shape == (1,)
    assert slot_to_id.shape == (1, 5) and n.dtype == slot_to_id.dtype == np.int64
    d = busy_filter.dim
    np.testing.assert_array_equal(x[0, :d], busy_filter.mean)
    np.testing.assert_array_equal(P[0, :d, :d], busy_filter.cov)
    np.testing.assert_array_equal(slot_to_id[0, : n[0]], busy_filter.state_to_id)
    for view in (x, P, n, slot_to_id):
        with pytest.raises(ValueError, match="read-only"):
            view[0] = 0
    busy_filter.update([[1.0, 1.0]], [4])  # they follow the filter
    assert n[0] == 3 and x[0, 7] == busy_filter.mean[7]
