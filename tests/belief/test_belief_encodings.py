"""The belief encodings' bounds and clipping against the documented layout (issue 17):
the spaces written out by hand, beliefs placed exactly on and just beyond the bounds,
round-off in the variances."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.belief.encodings import (
    BeliefGeometry,
    EgocentricEncoding,
    FullEncoding,
    slot_indices,
    unpack_full_belief,
)

GEOMETRY = BeliefGeometry(max_landmarks=3, width=12.0, height=8.0, max_range=4.0)
EXTENT = 10 * 12.0  # ten arena sizes
REL = 2 * EXTENT / 4.0  # robot-frame bound / max_range


def test_egocentric_space_bounds_by_hand():
    space = EgocentricEncoding(GEOMETRY).space
    low = [-10, -10, -1, -1, 0, 0, 0] + [0, -REL, -REL, 0] * 3
    high = [11, 11, 1, 1, 1, 1, 1] + [1, REL, REL, 1] * 3
    np.testing.assert_array_equal(space.low, np.float32(low))
    np.testing.assert_array_equal(space.high, np.float32(high))
    assert space.dtype == np.float32


def test_full_space_bounds_by_hand():
    space = FullEncoding(GEOMETRY).space
    high_mean = np.full(9, EXTENT, np.float32)
    high_mean[2] = np.float32(math.pi)
    np.testing.assert_array_equal(space["mean"].high, high_mean)
    np.testing.assert_array_equal(space["mean"].low, -high_mean)
    np.testing.assert_array_equal(space["cov"].high, np.full(81, EXTENT**2, np.float32))
    np.testing.assert_array_equal(space["cov"].low, np.full(81, -(EXTENT**2), np.float32))
    np.testing.assert_array_equal(space["known"].low, np.zeros(3, np.float32))
    np.testing.assert_array_equal(space["known"].high, np.ones(3, np.float32))


def test_slot_indices_place_landmark_i_in_rows_3_plus_2i():
    np.testing.assert_array_equal(slot_indices(np.array([2, 0])), [0, 1, 2, 7, 8, 3, 4])
    np.testing.assert_array_equal(slot_indices(np.array([], dtype=np.int64)), [0, 1, 2])


def test_unpack_full_belief_inverts_the_full_encoding():
    mean = np.array([1.0, 2.0, 0.5, 5.0, 6.0])
    cov = np.diag([0.25, 0.5, 0.125, 1.0, 2.0])
    obs, _ = FullEncoding(GEOMETRY).encode(mean, cov, np.array([1]))
    full_mean, full_cov, known = unpack_full_belief(obs)
    assert full_mean.dtype == full_cov.dtype == np.float64 and full_cov.shape == (9, 9)
    np.testing.assert_array_equal(full_mean, [1, 2, 0.5, 0, 0, 5, 6, 0, 0])
    np.testing.assert_array_equal(np.diag(full_cov), [0.25, 0.5, 0.125, 0, 0, 1, 2, 0, 0])
    assert known.tolist() == [False, True, False]


def _on_bounds(ex: float, ey: float, x: float, y: float) -> tuple[np.ndarray, np.ndarray]:
    """A belief with the robot at (x, y) facing +x and landmark 0 at (ex, ey)·max_range
    in its frame."""
    mean = np.array([x, y, 0.0, x + 4.0 * ex, y + 4.0 * ey])
    return mean, np.eye(5) * 0.01


@pytest.mark.parametrize(
    ("ex", "ey", "x", "y"),
    [(REL, -REL, 0.0, 0.0), (0.0, 0.0, -10 * 12.0, 11 * 8.0), (-REL, REL, 11 * 12.0, -10 * 8.0)],
)
def test_egocentric_belief_exactly_on_its_bounds_is_not_clipped(ex, ey, x, y):
    enc = EgocentricEncoding(GEOMETRY)
    mean, cov = _on_bounds(ex, ey, x, y)
    obs, clipped = enc.encode(mean, cov, np.array([0]))
    assert not clipped and enc.space.contains(obs)
    assert obs[8] == np.float32(ex) and obs[9] == np.float32(ey)


@pytest.mark.parametrize(
    ("ex", "ey", "x", "y", "index", "side"),
    [
        (REL * 1.001, 0.0, 1.0, 1.0, 8, "high"),
        (0.0, -REL * 1.001, 1.0, 1.0, 9, "low"),
        (0.0, 0.0, -10.01 * 12.0, 1.0, 0, "low"),
        (0.0, 0.0, 1.0, 11.01 * 8.0, 1, "high"),
    ],
)
def test_egocentric_belief_beyond_a_bound_is_clipped_onto_it(ex, ey, x, y, index, side):
    enc = EgocentricEncoding(GEOMETRY)
    mean, cov = _on_bounds(ex, ey, x, y)
    obs, clipped = enc.encode(mean, cov, np.array([0]))
    assert clipped and enc.space.contains(obs)
    assert obs[index] == getattr(enc.space, side)[index]
    # The other features are as computed, unclipped.
    plain, _ = enc.encode(*_on_bounds(0.0, 0.0, 1.0, 1.0), np.array([0]))
    assert obs[4] == plain[4] and obs[7] == 1.0


def test_negative_variances_from_round_off_read_as_zero():
    enc = EgocentricEncoding(GEOMETRY)
    mean = np.array([1.0, 1.0, 0.3, 3.0, 2.0])
    cov = np.diag([-1e-12, -1e-15, -1e-13, -1e-12, 1e-13])
    obs, clipped = enc.encode(mean, cov, np.array([2]))
    assert not clipped
    np.testing.assert_array_equal(obs[4:7], [0.0, 0.0, 0.0])
    # The landmark's trace is −1e-12 + 1e-13 < 0: zero as well.
    assert obs[7 + 8] == 1.0 and obs[10 + 8] == 0.0


def test_scales_of_the_uncertainty_features():
    enc = EgocentricEncoding(GEOMETRY)
    mean = np.array([1.0, 1.0, 0.0, 3.0, 2.0])
    cov = np.diag([0.25, 1.0, 0.04, 0.5, 0.5])
    obs, _ = enc.encode(mean, cov, np.array([1]))
    expected = [math.tanh(0.5 / 1.0), math.tanh(1.0 / 1.0), math.tanh(0.2 / 0.5)]
    np.testing.assert_allclose(obs[4:7], expected, rtol=1e-6)
    assert obs[7 + 4 + 3] == pytest.approx(math.tanh(1.0), rel=1e-6)


def test_full_encoding_clips_onto_its_bounds_and_zeroes_nan():
    enc = FullEncoding(GEOMETRY)
    mean = np.array([EXTENT, -EXTENT, math.pi, 5.0, 6.0])
    cov = np.eye(5) * EXTENT**2
    obs, clipped = enc.encode(mean, cov, np.array([0]))
    assert not clipped  # exactly on the bounds
    mean[3], cov[4, 4] = 2 * EXTENT, np.nan
    obs, clipped = enc.encode(mean, cov, np.array([0]))
    assert clipped and enc.space.contains(obs)
    assert obs["mean"][3] == np.float32(EXTENT) and obs["cov"][4 * 9 + 4] == 0.0
    mean[3], cov[4, 4] = 5.0, -2 * EXTENT**2
    obs, clipped = enc.encode(mean, cov, np.array([0]))
    assert clipped and obs["cov"][4 * 9 + 4] == np.float32(-(EXTENT**2))
