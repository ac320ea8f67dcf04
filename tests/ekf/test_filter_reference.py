"""EKFSLAM against the dense textbook EKF-SLAM of ``dense_reference.py``: same mean,
covariance, landmark order, statuses and NIS to 1e-9 over random sequences of
predictions, corrections (with gate rejections) and new landmarks, for every
motion × measurement model and both correction modes; and the batched kernels
(:mod:`slam_env.kernels.ekf.filter`) the same way, all eight combinations in one batch."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from references import invariant_ekf
from slam_env.ekf import EKFSLAM, chi2_gate, kernel_config
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.kernels.ekf import filter as ekf
from slam_env.world.frames import wrap_angle

ALPHAS = (0.02, 0.01, 0.02, 0.01)
CONTROL_NOISE = (0.02, 0.01, 0.01, 0.05)
Q = {
    "range_bearing": np.array([[0.04**2, 1e-5], [1e-5, math.radians(2.0) ** 2]]),
    "cartesian": np.array([[0.05**2, 2e-4], [2e-4, 0.03**2]]),
}
COMBOS = list(
    itertools.product(
        ["odometry", "velocity"], ["range_bearing", "cartesian"], ["sequential", "batch"]
    )
)


def assert_same_belief(f, ref, atol=1e-9):
    mean, ref_mean = f.mean, ref.mean
    assert mean.shape == ref_mean.shape
    np.testing.assert_array_equal(f.state_to_id, ref.state_to_id)
    assert abs(wrap_angle(mean[2] - ref_mean[2])) <= atol
    mean[2] = ref_mean[2]
    np.testing.assert_allclose(mean, ref_mean, rtol=0, atol=atol)
    np.testing.assert_allclose(f.cov, ref.cov, rtol=0, atol=atol)


def random_control(rng, motion):
    if motion == "odometry":
        return np.array([rng.uniform(-0.4, 0.4), rng.uniform(-0.2, 0.8), rng.uniform(-0.4, 0.4)])
    return np.array([rng.uniform(-0.2, 0.8), rng.uniform(-0.5, 0.5)])


def run_against_dense(
    dense_reference, motion, measurement, correction, seed, atol=1e-9, steps=60,
    reference=None, **filter_options,
):  # fmt: skip
    """Drive EKFSLAM (with ``filter_options``) and the dense filter (``reference``, a
    class with DenseEKFSLAM's interface, that one by default) through the same random
    sequence of ``steps`` steps, checking they agree after every call; returns how
    often each status occurred."""
    rng = np.random.default_rng(seed)
    n_landmarks = 12
    truth = rng.uniform(-6, 6, size=(n_landmarks, 2))
    hm, mm = MEASUREMENT_MODELS[measurement], MOTION_MODELS[motion]
    pose0 = np.array([0.1, -0.2, 3.1])  # near ±π: heading wrapping is exercised
    cov0 = np.diag([0.01, 0.02, 0.003])
    gate = chi2_gate(0.99)
    kwargs = dict(
        alphas=ALPHAS,
        control_noise=CONTROL_NOISE,
        measurement_cov=Q[measurement],
        initial_pose=pose0,
        initial_pose_cov=cov0,
        gate=gate,
        correction=correction,
    )
    f = EKFSLAM(
        motion_model=motion,
        measurement_model=measurement,
        max_landmarks=n_landmarks,
        **kwargs,
        **filter_options,
    )
    ref = (reference or dense_reference.DenseEKFSLAM)(motion, measurement, **kwargs)
    true_pose = pose0.copy()
    chol_q = np.linalg.cholesky(Q[measurement])
    counts = {"corrected": 0, "initialised": 0, "rejected": 0}
    for step in range(steps):
        u = random_control(rng, motion)
        true_pose = mm.motion(true_pose, u)
        f.predict(u)
        ref.predict(u)
        assert_same_belief(f, ref, atol)
        k = int(rng.integers(0, 6))
        ids = rng.permutation(n_landmarks)[:k]
        z = hm.h(true_pose, truth[ids]).reshape(k, 2) + rng.normal(size=(k, 2)) @ chol_q.T
        known = np.flatnonzero(f.id_to_state[ids] >= 0)
        if known.size and step % 5 == 3:
            z[known[0], 0] += 2.0  # a gross outlier on a known landmark: the gate rejects it
        res = f.update(z, ids)
        status, nis = ref.update(z, ids)
        np.testing.assert_array_equal(res.ids, ids)
        np.testing.assert_array_equal(res.status, status)
        # NIS = νᵀS⁻¹ν magnifies state differences by ~|ν|/σ²: compare it relatively.
        np.testing.assert_allclose(res.nis, nis, rtol=1e-6, atol=0, equal_nan=True)
        assert f.n_rejected == ref.n_rejected
        assert_same_belief(f, ref, atol)
        counts["corrected"] += int(np.sum(status == 0))
        counts["initialised"] += int(np.sum(status == 1))
        counts["rejected"] += int(np.sum(status == 2))
    return counts


@pytest.mark.parametrize(("motion", "measurement", "correction"), COMBOS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_agrees_with_the_dense_textbook_filter(
    dense_reference, motion, measurement, correction, seed
):
    counts = run_against_dense(dense_reference, motion, measurement, correction, seed)
    # The sequence exercised every branch.
    assert counts["initialised"] == 12
    assert counts["corrected"] > 50
    assert counts["rejected"] >= 2


@pytest.mark.parametrize(
    ("motion", "measurement"), [("odometry", "range_bearing"), ("velocity", "cartesian")]
)
def test_batch_and_sequential_differ_only_by_relinearisation(motion, measurement):
    """With the pose known exactly the landmarks are independent and re-linearising
    changes nothing: batch equals sequential. Once the pose is uncertain they are
    two (close) approximations of the same posterior."""
    kwargs = dict(
        motion_model=motion,
        measurement_model=measurement,
        alphas=ALPHAS,
        control_noise=CONTROL_NOISE,
        measurement_cov=Q[measurement],
        max_landmarks=4,
    )
    seq = EKFSLAM(correction="sequential", **kwargs)
    bat = EKFSLAM(correction="batch", **kwargs)
    z0 = np.array([[2.0, 0.5], [3.0, -0.5], [2.5, 1.0]])
    for f in (seq, bat):
        f.update(z0, [0, 1, 2])  # initialise three landmarks from a known pose
        f.update(z0[[2, 0, 1]] + 0.01, [2, 0, 1])  # correct them: independent observations
    np.testing.assert_allclose(seq.mean, bat.mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(seq.cov, bat.cov, rtol=0, atol=1e-12)
    mm, hm = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]
    u = (0.3, 0.5, -0.2) if motion == "odometry" else (0.5, 0.1)
    landmarks = hm.inverse(np.zeros(3), z0[[1, 2, 0]])
    z1 = hm.h(mm.motion(np.zeros(3), u), landmarks) + 0.02
    for f in (seq, bat):
        f.predict(u)  # the pose is uncertain and correlated with the map now
        f.update(z1, [1, 2, 0])
    gap = np.abs(seq.mean - bat.mean).max()
    assert 1e-9 < gap < 1e-3
    assert 1e-12 < np.abs(seq.cov - bat.cov).max() < 1e-2


@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_many_observations_in_one_update(dense_reference, correction):
    """More observations in one update than the factor buffer starts with."""
    rng = np.random.default_rng(11)
    n = 30
    truth = rng.uniform(-8, 8, size=(n, 2))
    capacity = 100  # d < the storage: the factor buffer must grow by count, not size
    hm = MEASUREMENT_MODELS["range_bearing"]
    kwargs = dict(
        alphas=ALPHAS,
        measurement_cov=Q["range_bearing"],
        initial_pose_cov=np.diag([0.01, 0.01, 0.002]),
        correction=correction,
    )
    f = EKFSLAM(max_landmarks=capacity, **kwargs)
    ref = dense_reference.DenseEKFSLAM("odometry", "range_bearing", **kwargs)
    pose = np.zeros(3)
    chol_q = np.linalg.cholesky(Q["range_bearing"])
    schedule = (np.arange(12), rng.permutation(12)[:10], np.arange(n), rng.permutation(n)[:25])
    for ids in (*schedule, rng.permutation(n)):
        u = random_control(rng, "odometry")
        pose = MOTION_MODELS["odometry"].motion(pose, u)
        for g in (f, ref):
            g.predict(u)
        z = hm.h(pose, truth[ids]) + rng.normal(size=(ids.size, 2)) @ chol_q.T
        res = f.update(z, ids)
        status, _ = ref.update(z, ids)
        np.testing.assert_array_equal(res.status, status)
        assert_same_belief(f, ref)
    assert f.n_landmarks == n


@pytest.mark.parametrize(("linearization", "steps"), [("standard", 50), ("invariant", 100)])
def test_the_batched_kernels_agree_with_the_dense_filter_for_every_combination(
    dense_reference, linearization, steps
):
    """One batch of 8 worlds, one per motion × measurement × correction combination,
    each against its own dense textbook filter (the seeds', or the right-invariant
    one of ``references/invariant_ekf.py``), to 1e-9 after every call."""
    rng = np.random.default_rng(8)
    B, M, D = len(COMBOS), 10, 5
    dmax = 3 + 2 * M
    pose0 = np.array([0.1, -0.2, wrap_angle(3.1)])
    cov0 = np.diag([0.01, 0.02, 0.003])
    gate = chi2_gate(0.99)
    x, P = np.zeros((B, dmax)), np.zeros((B, dmax, dmax))
    x[:, :3], P[:, :3, :3] = pose0, cov0
    n, n_rejected = np.zeros(B, np.int64), np.zeros(B, np.int64)
    id_to_slot, slot_to_id = np.full((B, M), -1), np.full((B, M), -1)
    first = x.copy()
    config = [
        kernel_config(
            m,
            h,
            c,
            ALPHAS if m == "odometry" else CONTROL_NOISE,
            Q[h],
            gate,
            linearization=linearization,
        )
        for m, h, c in COMBOS
    ]
    params = np.array([p for p, _ in config])
    modes = np.array([m for _, m in config])
    reference = (
        invariant_ekf.InvariantEKFSLAM
        if linearization == "invariant"
        else dense_reference.DenseEKFSLAM
    )
    refs = [
        reference(
            m,
            h,
            Q[h],
            alphas=ALPHAS,
            control_noise=CONTROL_NOISE,
            initial_pose=pose0,
            initial_pose_cov=cov0,
            gate=gate,
            correction=c,
        )
        for m, h, c in COMBOS
    ]
    truth = rng.uniform(-6, 6, size=(B, M, 2))
    poses = np.tile(pose0, (B, 1))
    everywhere, error = np.ones(B, dtype=np.bool_), np.zeros(B, np.int64)
    work = np.empty(ekf.update_workspace_size(dmax, D))
    counts = {"corrected": 0, "initialised": 0, "rejected": 0}
    for _ in range(steps):
        u = np.zeros((B, 3))
        for b, (motion, _, _) in enumerate(COMBOS):
            cdim = MOTION_MODELS[motion].control_dim
            u[b, :cdim] = random_control(rng, motion)
            poses[b] = MOTION_MODELS[motion].motion(poses[b], u[b, :cdim])
            refs[b].predict(u[b, :cdim])
        ekf.predict(x, P, n, first, u, params, modes, everywhere, error)
        assert (error == 0).all()
        z, ids = np.zeros((B, D, 2)), np.zeros((B, D), np.int64)
        k = rng.integers(0, D + 1, size=B)
        for b, (_, measurement, _) in enumerate(COMBOS):
            ids[b, : k[b]] = rng.permutation(M)[: k[b]]
            hm = MEASUREMENT_MODELS[measurement]
            z[b, : k[b]] = (
                hm.h(poses[b], truth[b, ids[b, : k[b]]]) + rng.normal(size=(k[b], 2)) * 0.03
            )
            if k[b] and rng.random() < 0.2:
                z[b, 0, 0] += 2.0  # an outlier the gate rejects if the landmark is known
        status, nis = np.empty((B, D), np.int8), np.empty((B, D))
        ekf.update(
            x, P, n, id_to_slot, slot_to_id, n_rejected, first, params, modes, z, ids, k,
            everywhere, status, nis, error, work,
        )  # fmt: skip
        assert (error == 0).all()
        for b, ref in enumerate(refs):
            ref_status, ref_nis = ref.update(z[b, : k[b]], ids[b, : k[b]])
            np.testing.assert_array_equal(status[b, : k[b]], ref_status)
            np.testing.assert_allclose(nis[b, : k[b]], ref_nis, rtol=1e-6, equal_nan=True)
            d = 3 + 2 * n[b]
            np.testing.assert_array_equal(slot_to_id[b, : n[b]], ref.state_to_id)
            assert n_rejected[b] == ref.n_rejected
            mean = x[b, :d].copy()
            assert abs(wrap_angle(mean[2] - ref.mean[2])) <= 1e-9
            mean[2] = ref.mean[2]
            np.testing.assert_allclose(mean, ref.mean, rtol=0, atol=1e-9)
            np.testing.assert_allclose(P[b, :d, :d], ref.cov, rtol=0, atol=1e-9)
            for name, code in (("corrected", 0), ("initialised", 1), ("rejected", 2)):
                counts[name] += int(np.sum(ref_status == code))
    assert counts["initialised"] == B * M and counts["corrected"] > 500 and counts["rejected"] > 10
