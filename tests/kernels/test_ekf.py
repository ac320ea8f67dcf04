"""The batched EKF kernels: B worlds in one call equal B independent EKFSLAM filters
bit for bit (different models, data and masks per world, some worlds failing while
the others commit), every error code leaves its world exactly as it was, and the
outputs of untouched worlds and padding say so."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from slam_env.ekf import EKFSLAM, Status, kernel_config
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.kernels.base.models import wrap_angle
from slam_env.kernels.ekf import codes as ekf_codes
from slam_env.kernels.ekf import filter as ekf

M = 8  # landmark capacity of every world
DMAX = 3 + 2 * M
CONFIGS = [
    ("odometry", "range_bearing", "sequential", 9.21),
    ("velocity", "cartesian", "batch", None),
    ("odometry", "cartesian", "batch", 13.8),
    ("velocity", "range_bearing", "sequential", None),
    ("odometry", "range_bearing", "batch", None),
    ("velocity", "cartesian", "sequential", 9.21),
]
ALPHAS = (0.02, 0.01, 0.02, 0.01)
CONTROL_NOISE = (0.02, 0.01, 0.01, 0.05)
Q = {
    "range_bearing": np.array([[0.04**2, 1e-5], [1e-5, math.radians(2.0) ** 2]]),
    "cartesian": np.array([[0.05**2, 2e-4], [2e-4, 0.03**2]]),
}
PRIOR = np.diag([0.01, 0.02, 0.003])


def make_filter(config) -> EKFSLAM:
    motion, measurement, correction, gate = config
    return EKFSLAM(
        motion_model=motion,
        measurement_model=measurement,
        alphas=ALPHAS,
        control_noise=CONTROL_NOISE,
        measurement_cov=Q[measurement],
        max_landmarks=M,
        initial_pose=(0.1, -0.2, 3.1),
        initial_pose_cov=PRIOR,
        gate=gate,
        correction=correction,
    )


class Batch:
    """The state of B filters as the vector env holds it, built from the configs."""

    def __init__(self, configs, max_obs: int) -> None:
        B = len(configs)
        self.x = np.zeros((B, DMAX))
        self.P = np.zeros((B, DMAX, DMAX))
        self.n = np.zeros(B, dtype=np.int64)
        self.id_to_slot = np.full((B, M), -1, dtype=np.int64)
        self.slot_to_id = np.full((B, M), -1, dtype=np.int64)
        self.n_rejected = np.zeros(B, dtype=np.int64)
        self.first = np.zeros((B, DMAX))
        rows = [
            kernel_config(
                motion,
                measurement,
                correction,
                ALPHAS if motion == "odometry" else CONTROL_NOISE,
                Q[measurement],
                gate,
            )
            for motion, measurement, correction, gate in configs
        ]
        self.params = np.array([p for p, _ in rows])
        self.modes = np.array([m for _, m in rows])
        self.x[:, :3] = (0.1, -0.2, wrap_angle(3.1))  # the prior as EKFSLAM takes it
        self.first[:, :3] = self.x[:, :3]
        self.P[:, :3, :3] = PRIOR
        self.error = np.zeros(B, dtype=np.int64)
        self.work = np.empty(ekf.update_workspace_size(DMAX, max_obs))

    def state(self):
        return (
            self.x, self.P, self.n, self.id_to_slot, self.slot_to_id, self.n_rejected,
            self.first,
        )  # fmt: skip

    def snapshot(self, b: int) -> list[np.ndarray]:
        return [a[b].copy() for a in self.state()]

    def predict(self, u, mask):
        ekf.predict(
            self.x, self.P, self.n, self.first, u, self.params, self.modes, mask, self.error
        )  # fmt: skip
        return self.error.copy()

    def update(self, z, ids, counts, mask):
        B, D = ids.shape
        status = np.full((B, D), 99, dtype=np.int8)
        nis = np.zeros((B, D))
        ekf.update(
            *self.state(), self.params, self.modes, z, ids, counts, mask, status, nis,
            self.error, self.work,
        )  # fmt: skip
        return status, nis, self.error.copy()


def filter_state(f: EKFSLAM) -> list[np.ndarray]:
    x, P, n, slot_to_id = f.belief_arrays()
    return [
        x[0], P[0], n[0], f.id_to_state, slot_to_id[0], np.int64(f.n_rejected), f._firstb[0],
    ]  # fmt: skip


def assert_same(batch: Batch, b: int, f: EKFSLAM) -> None:
    for mine, theirs in zip(batch.snapshot(b), filter_state(f), strict=True):
        np.testing.assert_array_equal(mine, theirs)


def test_b_worlds_equal_b_independent_filters_bit_for_bit():
    rng = np.random.default_rng(5)
    B, D = len(CONFIGS), 5
    batch = Batch(CONFIGS, D + 1)
    filters = [make_filter(c) for c in CONFIGS]
    truth = rng.uniform(-6, 6, size=(B, M, 2))
    poses = np.tile([0.1, -0.2, 3.1], (B, 1))
    outcomes = {"ok": 0, "fpe": 0, "masked": 0, "statuses": set()}
    for _ in range(40):
        u = np.zeros((B, 3))
        mask = rng.random(B) < 0.8
        for b, (motion, *_rest) in enumerate(CONFIGS):
            if motion == "odometry":
                u[b] = rng.uniform(-0.3, 0.3), rng.uniform(-0.1, 0.6), rng.uniform(-0.3, 0.3)
            else:
                u[b, :2] = rng.uniform(-0.1, 0.6), rng.uniform(-0.4, 0.4)
        overflow = rng.random(B) < 0.1  # a control whose noise overflows: refused
        u[overflow, :2] = 1e200
        error = batch.predict(u, mask)
        for b, f in enumerate(filters):
            if not mask[b]:
                assert error[b] == ekf_codes.OK
                continue
            cdim = MOTION_MODELS[CONFIGS[b][0]].control_dim
            if overflow[b]:
                with pytest.raises(FloatingPointError, match="overflow"):
                    f.predict(u[b, :cdim])
                assert error[b] == ekf_codes.OVERFLOW
            else:
                f.predict(u[b, :cdim])
                assert error[b] == ekf_codes.OK
                poses[b] = MOTION_MODELS[CONFIGS[b][0]].motion(poses[b], u[b, :cdim])
            assert_same(batch, b, f)

        # Observations: different counts per world, padding left as garbage.
        z = rng.normal(size=(B, D + 1, 2)) * 1e3
        ids = rng.integers(-5, 50, size=(B, D + 1))
        counts = rng.integers(0, D + 1, size=B)
        mask = rng.random(B) < 0.8
        absurd = rng.random(B) < 0.15  # a new landmark at 1e300 m: its covariance overflows
        for b in range(B):
            k = int(counts[b])
            ids[b, :k] = rng.permutation(M)[:k]
            hm = MEASUREMENT_MODELS[CONFIGS[b][1]]
            z[b, :k] = hm.h(poses[b], truth[b, ids[b, :k]]) + rng.normal(size=(k, 2)) * 0.02
            if k and rng.random() < 0.3:
                z[b, 0, 0] += 3.0  # an outlier: a gated world rejects it if it is known
            unseen = np.flatnonzero(batch.id_to_slot[b] < 0)
            unseen = np.setdiff1d(unseen, ids[b, :k])
            if absurd[b] and unseen.size and k < D + 1:
                ids[b, k], z[b, k] = unseen[0], (1e300, 0.3)
                counts[b] = k + 1
        status, nis, error = batch.update(z, ids, counts, mask)
        for b, f in enumerate(filters):
            k = int(counts[b])
            if not mask[b]:
                outcomes["masked"] += 1
                assert error[b] == ekf_codes.OK
                assert (status[b] == ekf_codes.UNUSED).all() and np.isnan(nis[b]).all()
                assert_same(batch, b, f)
                continue
            try:
                result = f.update(z[b, :k], ids[b, :k])
            except FloatingPointError:
                outcomes["fpe"] += 1
                assert error[b] in (
                    ekf_codes.OVERFLOW,
                    ekf_codes.NOT_FINITE,
                    ekf_codes.NOT_POSITIVE_DEFINITE,
                )
                assert (status[b] == ekf_codes.UNUSED).all() and np.isnan(nis[b]).all()
            else:
                outcomes["ok"] += 1
                assert error[b] == ekf_codes.OK
                np.testing.assert_array_equal(status[b, :k], result.status)
                np.testing.assert_array_equal(nis[b, :k], result.nis)
                assert (status[b, k:] == ekf_codes.UNUSED).all() and np.isnan(nis[b, k:]).all()
                outcomes["statuses"].update(result.status.tolist())
            assert_same(batch, b, f)
    assert outcomes["ok"] > 100 and outcomes["fpe"] >= 5 and outcomes["masked"] >= 20
    assert outcomes["statuses"] == {Status.CORRECTED, Status.INITIALISED, Status.REJECTED}


def test_the_status_codes_are_the_filters():
    assert tuple(Status) == (
        ekf_codes.CORRECTED, ekf_codes.INITIALISED, ekf_codes.REJECTED, ekf_codes.DISCARDED,
        ekf_codes.TENTATIVE,
    )  # fmt: skip
    assert len(ekf_codes.ERROR_NAMES) == ekf_codes.OVERFLOW + 1


def _two_worlds(max_obs: int = 3) -> Batch:
    """Two odometry + range-bearing worlds with landmarks 0 and 3 in the state."""
    config = ("odometry", "range_bearing", "sequential", None)
    batch = Batch([config, config], max_obs)
    z = np.array([[[2.0, 0.1], [3.0, -0.4], [0, 0]]] * 2)
    ids = np.array([[0, 3, 0]] * 2)
    _, _, error = batch.update(z, ids, np.array([2, 2]), np.ones(2, dtype=np.bool_))
    assert (error == ekf_codes.OK).all() and (batch.n == 2).all()
    batch.predict(np.array([[0.1, 0.5, 0.0]] * 2), np.ones(2, dtype=np.bool_))
    return batch


@pytest.mark.parametrize(
    ("z", "ids", "count", "code"),
    [
        ([[2.0, 0.1], [np.nan, 0.0]], [0, 1], 2, ekf_codes.BAD_INPUT),
        ([[2.0, 0.1], [np.inf, 0.0]], [0, 1], 2, ekf_codes.BAD_INPUT),
        ([[2.0, 0.1], [1.0, 0.0]], [0, M], 2, ekf_codes.BAD_ID),
        ([[2.0, 0.1], [1.0, 0.0]], [-1, 2], 2, ekf_codes.BAD_ID),
        ([[2.0, 0.1], [1.0, 0.0], [1.0, 1.0]], [3, 1, 3], 3, ekf_codes.DUPLICATE_ID),
        ([[2.0, 0.1], [1.0, 0.0]], [0, 1], 4, ekf_codes.BAD_INPUT),
        ([[2.0, 0.1], [1.0, 0.0]], [0, 1], -1, ekf_codes.BAD_INPUT),
        ([[2.1, 0.1], [1e300, 0.0]], [0, 1], 2, ekf_codes.OVERFLOW),
    ],
)
def test_a_refused_world_keeps_its_state_and_the_other_commits(z, ids, count, code):
    batch = _two_worlds()
    z = np.array([z + [[0.0, 0.0]] * (3 - len(z))] * 2, dtype=np.float64)
    ids = np.array([ids + [0] * (3 - len(ids))] * 2, dtype=np.int64)
    z[1, : len(z[0])] = [[2.1, 0.1], [1.0, 0.2], [2.0, 2.0]]
    ids[1] = [0, 1, 2]
    before = batch.snapshot(0)
    status, nis, error = batch.update(z, ids, np.array([count, 3]), np.ones(2, dtype=np.bool_))
    assert error.tolist() == [code, ekf_codes.OK]
    for mine, then in zip(batch.snapshot(0), before, strict=True):
        np.testing.assert_array_equal(mine, then)
    assert (status[0] == ekf_codes.UNUSED).all() and np.isnan(nis[0]).all()
    assert status[1].tolist() == [ekf_codes.CORRECTED, ekf_codes.INITIALISED, ekf_codes.INITIALISED]
    assert batch.n.tolist() == [2, 4]


@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_an_indefinite_covariance_is_refused_after_corrections_were_made(correction):
    config = ("odometry", "range_bearing", correction, None)
    batch = Batch([config], 3)
    one = np.ones(1, dtype=np.bool_)
    z = np.array([[[2.0, 0.1], [3.0, -0.4], [2.5, 0.3]]])
    batch.update(z, np.array([[0, 3, 1]]), np.array([3]), one)
    s = 3 + 2 * int(batch.id_to_slot[0, 3])
    batch.P[0, s : s + 2, s : s + 2] = -10.0 * np.eye(2)  # white box: S is indefinite
    before = batch.snapshot(0)
    status, _, error = batch.update(z + 0.01, np.array([[0, 1, 3]]), np.array([3]), one)
    assert error.tolist() == [ekf_codes.NOT_POSITIVE_DEFINITE]
    assert (status == ekf_codes.UNUSED).all()
    for mine, then in zip(batch.snapshot(0), before, strict=True):
        np.testing.assert_array_equal(mine, then)


def test_a_non_finite_belief_is_refused():
    config = ("odometry", "cartesian", "sequential", None)
    batch = Batch([config], 2)
    one = np.ones(1, dtype=np.bool_)
    batch.update(np.array([[[1.0, 2.0], [0, 0]]]), np.array([[5, 0]]), np.array([1]), one)
    batch.x[0, 3] = 1e308  # white box: the landmark so far that its innovation overflows
    batch.x[0, 0] = -1e308
    before = batch.snapshot(0)
    _, _, error = batch.update(
        np.array([[[1.0, 2.0], [0, 0]]]), np.array([[5, 0]]), np.array([1]), one
    )
    assert error.tolist() == [ekf_codes.NOT_FINITE]
    for mine, then in zip(batch.snapshot(0), before, strict=True):
        np.testing.assert_array_equal(mine, then)


def test_too_small_a_workspace_is_refused_for_the_worlds_asked_for():
    """The workspace must hold the largest count of the worlds asked for (3 here), not
    the rows of the padded arrays (5)."""
    batch = _two_worlds()
    batch.work = np.empty(ekf.update_workspace_size(DMAX, 3) - 1)
    before = [batch.snapshot(b) for b in range(2)]
    z = np.ones((2, 5, 2))
    ids = np.tile(np.arange(5), (2, 1))
    status, _, error = batch.update(z, ids, np.array([3, 5]), np.array([True, False]))
    assert error.tolist() == [ekf_codes.SMALL_WORKSPACE, ekf_codes.OK]
    assert (status == ekf_codes.UNUSED).all()
    for b in range(2):
        for mine, then in zip(batch.snapshot(b), before[b], strict=True):
            np.testing.assert_array_equal(mine, then)
    batch.work = np.empty(ekf.update_workspace_size(DMAX, 3))
    status, _, error = batch.update(z, ids, np.array([3, 5]), np.array([True, False]))
    assert error.tolist() == [ekf_codes.OK, ekf_codes.OK]
    assert (status[0, :3] != ekf_codes.UNUSED).all() and (status[0, 3:] == ekf_codes.UNUSED).all()


def test_predict_refuses_a_non_finite_control_and_an_overflow_per_world():
    batch = _two_worlds()
    before = [batch.snapshot(b) for b in range(2)]
    u = np.array([[0.1, np.nan, 0.0], [0.0, 1e200, 0.0]])
    error = batch.predict(u, np.ones(2, dtype=np.bool_))
    assert error.tolist() == [ekf_codes.BAD_INPUT, ekf_codes.OVERFLOW]
    for b in range(2):
        for mine, then in zip(batch.snapshot(b), before[b], strict=True):
            np.testing.assert_array_equal(mine, then)
    # A landmark cross-covariance that would overflow is refused too.
    batch.P[1, 2, 3:7] = 1e299
    batch.P[1, 3:7, 2] = 1e299
    before = batch.snapshot(1)
    error = batch.predict(np.array([[0.1, 0.2, 0.0], [0.0, 100.0, 0.0]]), np.ones(2, np.bool_))
    assert error.tolist() == [ekf_codes.OK, ekf_codes.OVERFLOW]
    for mine, then in zip(batch.snapshot(1), before, strict=True):
        np.testing.assert_array_equal(mine, then)


def test_predict_touches_only_the_masked_worlds_and_reads_two_columns_for_velocity():
    configs = [("velocity", "cartesian", "batch", None)] * 2
    batch = Batch(configs, 1)
    before = batch.snapshot(1)
    error = batch.predict(np.array([[0.5, 0.1]]).repeat(2, 0), np.array([True, False]))
    assert error.tolist() == [ekf_codes.OK, ekf_codes.OK]
    expected = MOTION_MODELS["velocity"].motion((0.1, -0.2, 3.1), (0.5, 0.1))
    np.testing.assert_allclose(batch.x[0, :3], expected, rtol=0, atol=1e-15)
    for mine, then in zip(batch.snapshot(1), before, strict=True):
        np.testing.assert_array_equal(mine, then)


def test_the_workspace_grows_with_the_detections_and_the_state():
    for dmax in (3, 43):
        sizes = [ekf.update_workspace_size(dmax, D) for D in range(6)]
        assert sizes[0] > 0 and all(a < b for a, b in itertools.pairwise(sizes))
    assert ekf.update_workspace_size(45, 5) > ekf.update_workspace_size(43, 5)


def test_the_workspace_is_as_large_as_an_update_needs_and_no_larger():
    """D observations of known landmarks in batch mode use the workspace up to its
    last entry (the gate's mark of observation D − 1; the invariant filter's transport
    rows, which any world of a batch may need, come before it); one entry less is refused
    (test_too_small_a_workspace_is_refused_for_the_worlds_asked_for)."""
    D = 3
    batch = Batch([("odometry", "cartesian", "batch", None)], D)
    one = np.ones(1, dtype=np.bool_)
    z = np.array([[[1.0, 2.0], [2.0, -1.0], [3.0, 0.5]]])
    ids = np.array([[4, 0, 6]])
    batch.update(z, ids, np.array([D]), one)
    batch.work[:] = np.nan
    _, _, error = batch.update(z + 0.01, ids, np.array([D]), one)
    assert error.tolist() == [ekf_codes.OK]
    assert batch.work[-1] == 1.0


@pytest.mark.parametrize(("heading", "row"), [(0.0, 1), (-math.pi / 2, 0)])
def test_predict_judges_the_new_cross_covariances_not_their_terms(heading, row):
    """Huge old entries whose update cancels are accepted: the overflow check is on
    the new value G P_xm (row x gains a = −δtr·sin(θ+δrot1) times the heading row,
    row y gains b = δtr·cos(θ+δrot1) times it)."""
    batch = _two_worlds()
    batch.x[:, 2] = heading
    batch.P[:, 2, 3:7] = batch.P[:, 3:7, 2] = 1e298
    batch.P[:, row, 3:7] = batch.P[:, 3:7, row] = -1e300  # cancelled by 100 × 1e298
    error = batch.predict(np.array([[0.0, 100.0, 0.0]] * 2), np.ones(2, dtype=np.bool_))
    assert error.tolist() == [ekf_codes.OK, ekf_codes.OK]
    assert np.abs(batch.P[:, row, 3:7]).max() < 1e286
