"""The belief-side kernels over B worlds against the plain code they replaced
(references/belief_numpy.py), world by world."""

from __future__ import annotations

import math

import numpy as np
import pytest

from references import belief_numpy as reference
from slam_env.belief.coverage import CoverageGrid
from slam_env.belief.encodings import BeliefGeometry, EgocentricEncoding, FullEncoding
from slam_env.belief.entropy import BeliefEntropy
from slam_env.ekf import EKFSLAM
from slam_env.kernels.belief.belief_state import BeliefBatch
from slam_env.kernels.belief.coverage import coverage_step
from slam_env.kernels.belief.diagnostics import DIAGNOSTICS, EMPTY_MAP_RMSE, belief_diagnostics
from slam_env.kernels.belief.entropy import belief_entropy
from slam_env.kernels.belief.reward import RewardSignals, active_slam_reward

M = 6  # landmark slots
DMAX = 3 + 2 * M
GEOMETRY = BeliefGeometry(max_landmarks=M, width=16.0, height=12.0, max_range=5.0)


def random_batch(rng: np.random.Generator, counts: list[int]) -> BeliefBatch:
    """Beliefs with counts[b] landmarks (random IDs in random order); the storage
    beyond each live block holds garbage, which no kernel may read."""
    B = len(counts)
    x = rng.normal(size=(B, DMAX)) * 1e6
    P = rng.normal(size=(B, DMAX, DMAX)) * 1e6
    slot_to_id = rng.integers(-5, 50, size=(B, M))
    for b, n in enumerate(counts):
        d = 3 + 2 * n
        x[b, :d] = np.concatenate(
            [[8.0, 6.0, rng.uniform(-math.pi, math.pi)], rng.uniform(0, 12, 2 * n)]
        )
        a = rng.normal(size=(d, d)) * rng.uniform(0.05, 0.5)
        P[b, :d, :d] = a @ a.T + 1e-3 * np.eye(d)
        slot_to_id[b, :n] = rng.permutation(M)[:n]
    return BeliefBatch(x, P, np.array(counts, dtype=np.int64), slot_to_id)


def live(batch: BeliefBatch, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    d = 3 + 2 * int(batch.n[b])
    return batch.x[b, :d], batch.P[b, :d, :d], batch.slot_to_id[b, : batch.n[b]]


COUNTS = [0, 1, 3, M, 2, 5]


def test_the_belief_batch_views_the_filters_storage():
    f = EKFSLAM(
        alphas=(0.01, 0.01, 0.01, 0.01), max_landmarks=4, measurement_cov=np.diag([0.01, 0.001])
    )
    f.update(np.array([[2.0, 0.3], [3.0, -0.5]]), np.array([3, 1]))
    belief = f.belief_batch()
    assert belief.x.shape == (1, 11) and belief.P.shape == (1, 11, 11)
    assert belief.n.tolist() == [2] and belief.slot_to_id[0, :2].tolist() == [3, 1]
    assert np.shares_memory(belief.x, f._x) and np.shares_memory(belief.P, f._P)
    assert np.shares_memory(belief.n, f._nb)  # the live count, not a copy
    np.testing.assert_array_equal(belief.x[0, :7], f.mean)
    np.testing.assert_array_equal(belief.P[0, :7, :7], f.cov)


def test_entropy_kernel_matches_the_lapack_reference():
    batch = random_batch(np.random.default_rng(0), COUNTS)
    entropy = BeliefEntropy(M, GEOMETRY.width, GEOMETRY.height)
    out, ok = np.empty(len(COUNTS)), np.empty(len(COUNTS), dtype=np.bool_)
    entropy.batch(batch.P, batch.n, out, ok)
    assert ok.all()
    for b in range(len(COUNTS)):
        expected = reference.belief_entropy(live(batch, b)[1], M, 16.0, 12.0)
        assert out[b] == pytest.approx(expected, rel=1e-13), b
        assert entropy(live(batch, b)[1]) == out[b]


def test_a_world_not_positive_definite_is_flagged_and_finished_by_the_fallback():
    batch = random_batch(np.random.default_rng(1), [2, 2, 1])
    P = batch.P
    P[1, 4, 4] = -1.0  # indefinite even with the floor
    entropy = BeliefEntropy(M, GEOMETRY.width, GEOMETRY.height)
    out, ok = np.empty(3), np.empty(3, dtype=np.bool_)
    scratch = np.empty((DMAX, DMAX))
    everyone = np.ones(len(COUNTS), dtype=np.bool_)
    belief_entropy(P, batch.n, M, 1e-4, entropy.prior_log_det, scratch, out, ok, everyone)
    assert ok.tolist() == [True, False, True] and math.isnan(out[1])
    entropy.batch(P, batch.n, out, ok)
    for b in range(3):
        expected = reference.belief_entropy(live(batch, b)[1], M, 16.0, 12.0)
        assert out[b] == pytest.approx(expected, rel=1e-13), b


def test_diagnostics_kernel_matches_the_reference():
    rng = np.random.default_rng(2)
    batch = random_batch(rng, COUNTS)
    B = len(COUNTS)
    true_pose = batch.x[:, :3] + rng.normal(size=(B, 3)) * 0.2
    true_pose[0, 2] = batch.x[0, 2] + 2 * math.pi - 0.01  # the heading error wraps
    truth = rng.uniform(0, 12, size=(B, M, 2))
    rows = np.empty((len(DIAGNOSTICS), B))
    belief_diagnostics(*batch, true_pose, truth, rows, np.ones(batch.x.shape[0], dtype=np.bool_))
    out = dict(zip(DIAGNOSTICS, rows, strict=True))
    for b in range(B):
        mean, cov, ids = live(batch, b)
        expected = reference.diagnostics(mean, cov, ids, true_pose[b], truth[b])
        for key, value in expected.items():
            got = out[key][b]
            if key == "map_rmse" and not ids.size:
                assert got is EMPTY_MAP_RMSE or (math.isnan(got) and math.isnan(EMPTY_MAP_RMSE))
            else:
                assert got == pytest.approx(value, rel=1e-14), (b, key)
        assert out["heading_error"][b] == expected["heading_error"]  # the same wrap, exactly
        assert out["pose_nees"][b] == expected["pose_nees"]  # the same adjugate, exactly
    assert out["heading_error"][0] == pytest.approx(0.01, rel=1e-9)


def test_diagnostics_of_degenerate_beliefs():
    x = np.zeros((2, 3))
    P = np.zeros((2, 3, 3))
    P[1] = np.diag([-1e-15, 0.0, 1.0])  # round-off below zero
    x[1, 0] = 0.5
    rows = np.empty((len(DIAGNOSTICS), 2))
    belief_diagnostics(
        x,
        P,
        np.zeros(2, np.int64),
        np.zeros((2, 0), np.int64),
        np.zeros((2, 3)),
        np.zeros((2, 0, 2)),
        rows,
        np.ones(2, dtype=np.bool_),
    )
    out = dict(zip(DIAGNOSTICS, rows.tolist(), strict=True))
    # Exactly right: 0; singular and wrong: undefined, which the info leaves out.
    assert out["pose_nees"][0] == 0.0 and math.isnan(out["pose_nees"][1])
    assert out["pose_std"] == [0.0, 0.0]
    assert out["pose_error"] == [0.0, 0.5]


@pytest.mark.parametrize("tail_size", [0, 3])
def test_egocentric_kernel_is_bit_identical_to_the_reference(tail_size):
    rng = np.random.default_rng(3)
    batch = random_batch(rng, COUNTS)
    batch.x[2, 5] = 1e9  # far outside: clipped
    batch.x[3, 0] = np.nan  # NaN: clipped
    batch.P[4, 1, 1] = -1e-14  # round-off: read as zero
    enc = EgocentricEncoding(GEOMETRY)
    B = len(COUNTS)
    tail = rng.uniform(0, 1, size=(B, tail_size)).astype(np.float32)
    out = np.empty((B, enc.size + tail_size), np.float32)
    clipped = np.empty(B, np.bool_)
    enc.encode_batch(batch, tail, out, clipped)
    for b in range(B):
        expected, was_clipped = reference.egocentric(enc, *live(batch, b), tail[b].tolist())
        np.testing.assert_array_equal(out[b], expected)
        assert clipped[b] == was_clipped
    assert clipped.tolist() == [False, False, True, True, False, False]


def test_full_kernel_is_bit_identical_to_the_reference():
    rng = np.random.default_rng(4)
    batch = random_batch(rng, COUNTS)
    batch.x[2, 4] = -1e9
    batch.P[3, 2, 4] = np.nan
    batch.P[5, 0, 0] = np.inf
    enc = FullEncoding(GEOMETRY)
    out = enc.empty(len(COUNTS))
    enc.encode_batch(batch, out)
    for b in range(len(COUNTS)):
        expected, was_clipped = reference.full(enc, *live(batch, b))
        np.testing.assert_array_equal(out.mean[b], expected["mean"])
        np.testing.assert_array_equal(out.cov[b], expected["cov"])
        np.testing.assert_array_equal(out.known[b], expected["known"])
        assert out.clipped[b] == was_clipped
    assert out.clipped.tolist() == [False, False, True, True, False, True]


GRIDS = [
    {"width": 16.0, "height": 16.0, "sweep_range": 4.5, "fov": 2 * math.pi / 3},
    {
        "width": 9.3,
        "height": 5.1,
        "sweep_range": 2.0,
        "fov": 1.0,
        "cell": 0.25,
        "sectors": 5,
        "ring_edges": (1.0, 3.0),
        "heading_bins": 17,
    },
    {
        "width": 7.0,
        "height": 11.0,
        "sweep_range": 3.0,
        "fov": 2 * math.pi,
        "cell": 1.0,
        "ring_edges": (),
    },
]


@pytest.mark.parametrize("kwargs", GRIDS)
def test_coverage_kernels_match_the_numpy_grid(kwargs):
    grid = CoverageGrid(**kwargs)
    plain = reference.CoverageGrid(**kwargs)
    rng = np.random.default_rng(5)
    for _ in range(40):
        x = rng.uniform(-2, kwargs["width"] + 2)
        y = rng.uniform(-2, kwargs["height"] + 2)
        theta = rng.uniform(-10, 10)
        assert grid.sweep(x, y, theta) == plain.sweep(x, y, theta)
        np.testing.assert_array_equal(grid.swept, plain.swept)
        assert grid.swept_fraction == plain.swept_fraction
        np.testing.assert_array_equal(grid.features(x, y, theta), plain.features(x, y, theta))


def test_coverage_of_b_worlds_sharing_one_table():
    """Worlds stepped together in one call equal each stepped alone."""
    kwargs = GRIDS[0]
    B = 4
    rng = np.random.default_rng(6)
    poses = rng.uniform(0, 16, size=(30, B, 3))
    alone = [CoverageGrid(**kwargs) for _ in range(B)]
    together = CoverageGrid(**kwargs)
    padded = np.repeat(together._padded, B, axis=0)
    flat = padded.reshape(B, -1)
    n_swept = np.zeros(B, np.int64)
    held = np.full(B, -1, np.int64)
    class_counts = np.repeat(together._class_counts, B, axis=0)
    new = np.empty(B, np.int64)
    features = np.empty((B, 1 + together.n_features))
    state = (*together.tables, flat, n_swept, held, class_counts)
    for step in poses:
        counts = np.empty(2 * together.n_features, np.int64)
        coverage_step(*state, step, True, new, features, counts, np.ones(len(step), np.bool_))
        for b, grid in enumerate(alone):
            assert new[b] == grid.sweep(*step[b])
            np.testing.assert_array_equal(features[b, 1:], grid.features(*step[b]))
            assert features[b, 0] == grid.swept_fraction
    p = together.tables.pad
    for b, grid in enumerate(alone):
        np.testing.assert_array_equal(padded[b, p:-p, p:-p], grid.swept)


def test_reward_kernel_is_the_sum_of_its_terms_in_order():
    rng = np.random.default_rng(7)
    B = 5
    weights = rng.uniform(0, 2, 5)
    last = np.stack([rng.normal(size=B) * 10, rng.uniform(0, 0.5, B)], axis=1)
    before = last.copy()
    now = RewardSignals(
        rng.normal(size=B) * 10,
        rng.uniform(0, 1, B),
        rng.uniform(size=B) < 0.5,
        rng.uniform(0.5, 1, B),
    )
    terms, reward = np.empty((B, 5)), np.empty(B)
    active_slam_reward(weights, *now, last, terms, reward, np.ones(len(reward), dtype=np.bool_))
    for b in range(B):
        w = weights.tolist()
        expected = [
            w[0] * (before[b, 0] - now.entropy[b]),
            -w[1] * now.pose_std[b],
            -w[2] if now.collision[b] else 0.0,
            -w[3],
            w[4] * (now.swept_fraction[b] - before[b, 1]),
        ]
        assert terms[b].tolist() == expected
        assert reward[b] == sum(expected)
    np.testing.assert_array_equal(last, np.stack([now.entropy, now.swept_fraction], axis=1))


def test_the_belief_kernels_leave_inactive_worlds_as_they_were():
    """A world outside the mask (a sub-env being reset) is neither read nor written."""
    batch = random_batch(np.random.default_rng(9), COUNTS)
    b = len(COUNTS)
    active = np.ones(b, dtype=np.bool_)
    active[1] = False
    true_pose = np.zeros((b, 3))
    truth = np.zeros((b, M, 2))
    rows = np.full((len(DIAGNOSTICS), b), 7.0)
    belief_diagnostics(*batch, true_pose, truth, rows, active)
    assert (rows[:, 1] == 7.0).all() and not (rows[:, 0] == 7.0).all()
    out, ok = np.full(b, 7.0), np.ones(b, dtype=np.bool_)
    BeliefEntropy(M, 16.0, 12.0).batch(batch.P, batch.n, out, ok, active)
    assert out[1] == 7.0 and out[0] != 7.0
    terms, reward = np.full((b, 5), 7.0), np.full(b, 7.0)
    last = np.zeros((b, 2))
    now = (np.ones(b), np.ones(b), np.zeros(b, np.bool_), np.zeros(b))
    active_slam_reward(np.ones(5), *now, last, terms, reward, active)
    assert (terms[1] == 7.0).all() and reward[1] == 7.0 and (last[1] == 0.0).all()
    assert reward[0] != 7.0 and last[0, 0] == 1.0
