"""EKFSLAM behaviour: the structure of predict / new landmarks, information gain,
the gate, long-run numerical health, storage, read access, copy, pickle, reset."""

from __future__ import annotations

import copy
import math
import pickle
import subprocess
import sys

import numpy as np
import pytest

from slam_env.ekf import (
    CORRECTED,
    DISCARDED,
    EKFSLAM,
    INITIALISED,
    REJECTED,
    TENTATIVE,
    Status,
    UpdateResult,
    chi2_gate,
    chi2_ppf,
)
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS

ALPHAS = (0.01, 0.005, 0.01, 0.005)
CONTROL_NOISE = (0.01, 0.005, 0.005, 0.02)
Q = {
    "range_bearing": np.diag([0.05**2, math.radians(1.0) ** 2]),
    "cartesian": np.diag([0.05**2, 0.05**2]),
}
MODEL_PAIRS = [
    ("odometry", "range_bearing"),
    ("odometry", "cartesian"),
    ("velocity", "range_bearing"),
    ("velocity", "cartesian"),
]


def make(motion="odometry", measurement="range_bearing", **kwargs):
    kwargs.setdefault("max_landmarks", 10)
    return EKFSLAM(
        motion_model=motion,
        measurement_model=measurement,
        alphas=ALPHAS,
        control_noise=CONTROL_NOISE,
        measurement_cov=Q[measurement],
        **kwargs,
    )


def control(motion, forward=0.5, turn=0.1):
    return (turn, forward, turn) if motion == "odometry" else (forward, 2 * turn)


def observe(f, pose, landmarks, ids):
    hm = MEASUREMENT_MODELS[f.measurement_model]
    return f.update(hm.h(pose, landmarks[ids]), ids)


LANDMARKS = np.array([[3.0, 1.0], [2.0, -2.0], [4.0, 3.0], [-1.0, 2.5], [5.0, -1.0]])


# --------------------------------------------------------------------------- structure


@pytest.mark.parametrize(("motion", "measurement"), MODEL_PAIRS)
def test_predict_changes_only_the_robot_rows(motion, measurement):
    f = make(motion, measurement, initial_pose_cov=np.diag([0.01, 0.01, 0.001]))
    observe(f, np.zeros(3), LANDMARKS, [0, 1, 2])
    f.predict(control(motion))
    observe(f, MOTION_MODELS[motion].motion(np.zeros(3), control(motion)), LANDMARKS, [0, 1])
    mean0, cov0 = f.mean, f.cov
    f.predict(control(motion, 0.7, -0.2))
    mean1, cov1 = f.mean, f.cov
    np.testing.assert_array_equal(mean1[3:], mean0[3:])  # landmarks do not move
    np.testing.assert_array_equal(cov1[3:, 3:], cov0[3:, 3:])  # nor does their covariance
    assert not np.array_equal(cov1[:3, 3:], cov0[:3, 3:])  # P_xm ← G P_xm
    G, _ = MOTION_MODELS[motion].jacobians(mean0[:3], control(motion, 0.7, -0.2))
    np.testing.assert_allclose(cov1[:3, 3:], G @ cov0[:3, 3:], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(cov1[3:, :3], cov1[:3, 3:].T)
    assert np.all(np.diag(cov1)[:2] > np.diag(cov0)[:2])  # motion adds uncertainty


@pytest.mark.parametrize(("motion", "measurement"), MODEL_PAIRS)
def test_new_landmark_is_initialised_with_the_inverse_model(motion, measurement):
    hm = MEASUREMENT_MODELS[measurement]
    f = make(motion, measurement, initial_pose_cov=np.diag([0.02, 0.01, 0.003]))
    observe(f, np.zeros(3), LANDMARKS, [3])
    f.predict(control(motion))
    pose, before = f.pose, f.cov
    z = hm.h(pose, LANDMARKS[[1, 4]]) + 0.01
    res = f.update(z, [1, 4])
    np.testing.assert_array_equal(res.status, [INITIALISED, INITIALISED])
    assert np.isnan(res.nis).all()
    after = f.cov
    np.testing.assert_array_equal(after[:5, :5], before)  # nothing else changed
    L, W = hm.inverse_jacobians(pose, z)
    np.testing.assert_allclose(
        f.landmark_means(), np.vstack([LANDMARKS[[3]], hm.inverse(pose, z)]), atol=0.3
    )
    np.testing.assert_allclose(f.mean[5:], hm.inverse(pose, z).ravel(), rtol=0, atol=1e-15)
    for j, s in enumerate((5, 7)):
        # Σ_mm = L Σ_xx Lᵀ + W Q Wᵀ; Σ_m,y = L Σ_x,y for the whole state so far.
        expected = L[j] @ before[:3, :3] @ L[j].T + W[j] @ Q[measurement] @ W[j].T
        np.testing.assert_allclose(after[s : s + 2, s : s + 2], expected, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(
            after[s : s + 2, :5], L[j] @ before[:3, :5], rtol=1e-12, atol=1e-15
        )
        assert np.abs(after[s : s + 2, :3]).max() > 1e-4  # correlated with the pose
        assert np.abs(after[s : s + 2, 3:5]).max() > 1e-6  # and with the older landmark
    np.testing.assert_allclose(
        after[5:7, 7:9], L[0] @ before[:3, :3] @ L[1].T, rtol=1e-12, atol=1e-15
    )
    assert not np.allclose(after[5:7, 5:7], np.eye(2))


def test_a_known_pose_gives_landmarks_only_the_sensor_noise():
    f = make(measurement="cartesian")
    f.update([[1.0, 2.0]], [7])
    mean, cov = f.landmark(7)
    np.testing.assert_allclose(mean, [1.0, 2.0])
    np.testing.assert_allclose(cov, Q["cartesian"], rtol=1e-15)
    assert f.n_landmarks == 1 and f.state_to_id.tolist() == [7] and f.id_to_state[7] == 0


# --------------------------------------------------------------------------- information


@pytest.mark.parametrize(("motion", "measurement"), MODEL_PAIRS)
@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_reobserving_a_landmark_shrinks_its_covariance(motion, measurement, correction):
    f = make(motion, measurement, correction=correction, initial_pose_cov=np.diag([0.01] * 3))
    hm = MEASUREMENT_MODELS[measurement]
    observe(f, np.zeros(3), LANDMARKS, [0, 2])
    for _ in range(5):
        _, before = f.landmark(2)
        pose_before = f.pose_cov
        res = f.update(hm.h(np.zeros(3), LANDMARKS[[2]]), [2])
        assert res.status.tolist() == [CORRECTED]
        _, after = f.landmark(2)
        # before − after is PSD and not zero: information was gained.
        assert np.linalg.eigvalsh(before - after).min() >= -1e-15
        assert np.trace(after) < np.trace(before)
        assert np.linalg.eigvalsh(pose_before - f.pose_cov).min() >= -1e-15


# --------------------------------------------------------------------------- gate


def _settled_filter(correction):
    f = make(correction=correction, gate=chi2_gate(0.999), initial_pose_cov=np.diag([1e-4] * 3))
    for _ in range(3):
        observe(f, np.zeros(3), LANDMARKS, [0, 1, 2])
    return f


@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_an_outlier_is_rejected_by_the_gate_and_counted(correction):
    f = _settled_filter(correction)
    hm = MEASUREMENT_MODELS["range_bearing"]
    assert f.n_rejected == 0
    before = f.mean, f.cov
    z = hm.h(np.zeros(3), LANDMARKS[[1]])
    z[0, 0] += 10 * 0.05  # 10σ range error
    res = f.update(z, [1])
    assert res.status.tolist() == [REJECTED]
    assert res.nis[0] > f.gate and res.nis[0] > 20.0
    assert f.n_rejected == 1
    np.testing.assert_array_equal(f.mean, before[0])  # not applied
    np.testing.assert_array_equal(f.cov, before[1])
    # Mixed with good observations: only the outlier is dropped.
    good = hm.h(np.zeros(3), LANDMARKS[[0, 2]])
    reference = f.copy()
    reference.update(good, [0, 2])
    res = f.update(np.vstack([good[:1], z, good[1:]]), [0, 1, 2])
    assert res.status.tolist() == [CORRECTED, REJECTED, CORRECTED]
    assert f.n_rejected == 2
    np.testing.assert_allclose(f.mean, reference.mean, rtol=0, atol=1e-15)
    np.testing.assert_allclose(f.cov, reference.cov, rtol=0, atol=1e-15)
    # A new landmark is never gated; reset clears the count.
    assert f.update([[50.0, 3.0]], [9]).status.tolist() == [INITIALISED]
    f.reset()
    assert f.n_rejected == 0


@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_a_landmark_on_the_robot_is_rejected_not_a_crash(correction):
    # Range 0: the landmark is initialised exactly on the robot, where the bearing
    # and H are undefined; observing it again cannot be linearised.
    f = make(correction=correction, initial_pose_cov=np.diag([1e-4] * 3))
    f.update([[0.0, 0.3], [2.0, 0.1]], [4, 5])
    before = f.mean, f.cov
    res = f.update([[0.1, 0.3]], [4])
    assert res.status.tolist() == [REJECTED] and np.isnan(res.nis[0])
    assert f.n_rejected == 1
    np.testing.assert_array_equal(f.mean, before[0])
    np.testing.assert_array_equal(f.cov, before[1])
    # The other landmark is still corrected in the same update.
    res = f.update([[0.1, 0.3], [2.0, 0.1]], [4, 5])
    assert res.status.tolist() == [REJECTED, CORRECTED] and f.n_rejected == 2


def test_without_a_gate_everything_is_applied():
    f = make(initial_pose_cov=np.diag([1e-4] * 3))
    observe(f, np.zeros(3), LANDMARKS, [0])
    res = f.update([[LANDMARKS[0, 0] + 5.0, 0.3]], [0])
    assert res.status.tolist() == [CORRECTED] and res.nis[0] > 100
    assert f.n_rejected == 0


def test_chi2_helpers():
    assert chi2_gate(0.95) == pytest.approx(5.991464547107979, rel=1e-12)
    assert chi2_ppf(0.95, 1) == pytest.approx(3.841458820694124, rel=1e-10)
    assert chi2_ppf(0.99, 3) == pytest.approx(11.344866730144373, rel=1e-10)
    assert chi2_ppf(0.95, 10) == pytest.approx(18.307038053275146, rel=1e-10)
    # The 95% band of the NEES averaged over 50 runs, 3 dof: [2.36, 3.72].
    assert chi2_ppf(0.025, 150) / 50 == pytest.approx(2.36, abs=5e-3)
    assert chi2_ppf(0.975, 150) / 50 == pytest.approx(3.72, abs=5e-3)
    for bad in (0.0, 1.0, -0.1, math.nan):
        with pytest.raises(ValueError, match="probability"):
            chi2_ppf(bad, 2)
    with pytest.raises(ValueError, match="dof"):
        chi2_ppf(0.5, 0)


# --------------------------------------------------------------------------- health


@pytest.mark.parametrize(
    ("motion", "measurement", "correction"),
    [("odometry", "range_bearing", "sequential"), ("velocity", "cartesian", "batch")],
)
def test_covariance_stays_symmetric_psd_over_10000_random_steps(motion, measurement, correction):
    rng = np.random.default_rng(7)
    mm, hm = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]
    landmarks = rng.uniform(-8, 8, size=(15, 2))
    f = make(motion, measurement, correction=correction, max_landmarks=15, gate=chi2_gate(0.999))
    chol_q = np.linalg.cholesky(Q[measurement])
    pose = np.zeros(3)
    for step in range(10_000):
        turn = rng.uniform(-0.3, 0.3)
        if np.hypot(*pose[:2]) > 7.0:  # stay in the arena: head back to the centre
            turn = math.remainder(math.atan2(-pose[1], -pose[0]) - pose[2], 2 * math.pi)
        u = control(motion, rng.uniform(0.0, 0.5), turn / 2)
        pose = mm.motion(pose, u)
        f.predict(u)
        near = np.flatnonzero(np.hypot(*(landmarks - pose[:2]).T) < 4.0)
        ids = rng.permutation(near)[: rng.integers(0, 6)]
        z = hm.h(pose, landmarks[ids]).reshape(-1, 2) + rng.normal(size=(ids.size, 2)) @ chol_q.T
        f.update(z, ids)
        P = f.cov
        assert np.isfinite(P).all() and np.isfinite(f.mean).all()
        np.testing.assert_array_equal(P, P.T)  # exactly symmetric
        if step % 10 == 0:
            assert np.linalg.eigvalsh(P).min() >= -1e-12 * np.abs(P).max()
    assert f.n_landmarks == 15
    assert f.n_rejected < 0.01 * 10_000
    assert np.hypot(*(f.pose[:2] - pose[:2])) < 0.5  # it tracked the robot


# --------------------------------------------------------------------------- storage


def test_storage_is_preallocated_and_never_reallocated():
    f = make(max_landmarks=5)
    P, x = f._P, f._x
    assert P.shape == (13, 13) and x.shape == (13,)
    for lid in range(5):
        f.update([[2.0 + lid, 0.1 * lid]], [lid])
        f.predict((0.1, 0.2, 0.0))
        assert f._P is P and f._x is x
    assert f.n_landmarks == 5 and f.cov.shape == (13, 13)
    with pytest.raises(ValueError, match="beyond capacity"):
        f.update([[1.0, 0.0]], [5])


# --------------------------------------------------------------------------- read access


def test_read_access_returns_consistent_copies():
    f = make(initial_pose=(1.0, 2.0, 0.5), initial_pose_cov=np.diag([0.01, 0.02, 0.003]))
    observe(f, np.array([1.0, 2.0, 0.5]), LANDMARKS, [4, 1, 3])
    f.predict((0.1, 0.4, 0.0))
    observe(f, f.pose, LANDMARKS, [1, 0])
    n = f.n_landmarks
    assert n == 4 and f.dim == 3 + 2 * n
    mean, cov = f.mean, f.cov
    assert mean.shape == (3 + 2 * n,) and cov.shape == (3 + 2 * n, 3 + 2 * n)
    np.testing.assert_array_equal(f.state_to_id, [4, 1, 3, 0])
    id_to_state = f.id_to_state
    assert id_to_state.shape == (10,) and id_to_state.dtype == np.int64
    np.testing.assert_array_equal(id_to_state[[4, 1, 3, 0]], [0, 1, 2, 3])
    assert (np.delete(id_to_state, [4, 1, 3, 0]) == -1).all()
    np.testing.assert_array_equal(f.pose, mean[:3])
    np.testing.assert_array_equal(f.pose_cov, cov[:3, :3])
    means, covs, cross = f.landmark_means(), f.landmark_covs(), f.landmark_pose_covs()
    assert means.shape == (n, 2) and covs.shape == (n, 2, 2) and cross.shape == (n, 2, 3)
    for slot, lid in enumerate(f.state_to_id):
        s = 3 + 2 * slot
        m, c = f.landmark(lid)
        np.testing.assert_array_equal(m, mean[s : s + 2])
        np.testing.assert_array_equal(c, cov[s : s + 2, s : s + 2])
        np.testing.assert_array_equal(means[slot], m)
        np.testing.assert_array_equal(covs[slot], c)
        np.testing.assert_array_equal(cross[slot], cov[s : s + 2, :3])
    # Every read is a copy: writing to it changes nothing.
    for arr in (mean, cov, f.pose, f.pose_cov, means, covs, cross, f.state_to_id, f.id_to_state):
        arr[...] = 0
    np.testing.assert_array_equal(f.mean, mean * 0 + f.mean)  # unchanged object reads
    assert f.mean[0] != 0 and f.cov[0, 0] != 0 and f.landmark_covs()[0, 0, 0] != 0
    assert f.state_to_id.tolist() == [4, 1, 3, 0]
    with pytest.raises(ValueError, match="not in the state"):
        f.landmark(2)
    with pytest.raises(ValueError, match="not in the state"):
        f.landmark(10)
    with pytest.raises(TypeError, match="int"):
        f.landmark(1.0)


def test_update_result():
    f = make(gate=chi2_gate(0.999), initial_pose_cov=np.diag([1e-4] * 3))
    observe(f, np.zeros(3), LANDMARKS, [0, 1])
    z = MEASUREMENT_MODELS["range_bearing"].h(np.zeros(3), LANDMARKS[[1, 2, 0]])
    z[2, 1] += 0.5
    res = f.update(z, np.array([1, 2, 0], dtype=np.int32))
    assert len(res) == 3
    assert res.ids.dtype == np.int64 and res.ids.tolist() == [1, 2, 0]
    assert [Status(s) for s in res.status] == [CORRECTED, INITIALISED, REJECTED]
    np.testing.assert_array_equal(res.corrected, [True, False, False])
    np.testing.assert_array_equal(res.initialised, [False, True, False])
    np.testing.assert_array_equal(res.rejected, [False, False, True])
    assert np.isfinite(res.nis[[0, 2]]).all() and np.isnan(res.nis[1])
    empty = f.update(np.zeros((0, 2)), [])
    assert len(empty) == 0 and empty.status.shape == (0,)


def test_each_status_mask_picks_its_own_status():
    statuses = [CORRECTED, INITIALISED, REJECTED, DISCARDED, TENTATIVE]
    res = UpdateResult(np.arange(5), np.array(statuses, dtype=np.int8), np.zeros(5), np.zeros(5))
    masks = [res.corrected, res.initialised, res.rejected, res.discarded, res.tentative]
    for i, mask in enumerate(masks):
        np.testing.assert_array_equal(mask, np.arange(5) == i)


# --------------------------------------------------------------------------- copy, pickle, reset


@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_copy_and_pickle_are_independent_and_equal(correction):
    f = make(correction=correction, gate=5.0, initial_pose_cov=np.diag([0.01] * 3))
    observe(f, np.zeros(3), LANDMARKS, [0, 1, 2])
    f.predict((0.1, 0.3, 0.0))
    clones = [f.copy(), copy.copy(f), copy.deepcopy(f), pickle.loads(pickle.dumps(f))]
    pose = MOTION_MODELS["odometry"].motion(np.zeros(3), (0.1, 0.3, 0.0))
    for g in clones:
        assert g._P is not f._P and g._x is not f._x
        np.testing.assert_array_equal(g.mean, f.mean)
        np.testing.assert_array_equal(g.cov, f.cov)
        assert g.n_rejected == f.n_rejected and g.gate == f.gate
        assert g.correction == correction
        # The same storage for max_landmarks (the kernels' batch of one), not only the
        # same live block.
        shapes = [a.shape for a in f.belief_arrays()]
        assert [a.shape for a in g.belief_arrays()] == shapes
    # Evolving a clone leaves the original alone; evolving both alike stays equal.
    before = f.mean, f.cov, f.id_to_state
    for g in clones:
        g.predict((0.0, 0.5, 0.1))
        observe(g, pose, LANDMARKS, [1, 3])
    np.testing.assert_array_equal(f.mean, before[0])
    np.testing.assert_array_equal(f.cov, before[1])
    np.testing.assert_array_equal(f.id_to_state, before[2])
    f.predict((0.0, 0.5, 0.1))
    observe(f, pose, LANDMARKS, [1, 3])
    for g in clones:
        np.testing.assert_array_equal(g.mean, f.mean)
        np.testing.assert_array_equal(g.cov, f.cov)
        np.testing.assert_array_equal(g.state_to_id, f.state_to_id)


def test_reset_starts_a_new_episode_in_the_same_storage():
    f = make(initial_pose=(1.0, 1.0, 0.0), initial_pose_cov=np.eye(3) * 0.01, gate=1e-3)
    P = f._P
    observe(f, np.zeros(3), LANDMARKS, [0, 1])
    f.update([[3.0, 0.5]], [0])
    assert f.n_rejected == 1
    f.reset(initial_pose=(2.0, 3.0, 7.0), initial_pose_cov=np.diag([0.1, 0.2, 0.3]))
    assert f._P is P
    assert f.n_landmarks == 0 and f.n_rejected == 0 and f.state_to_id.size == 0
    assert (f.id_to_state == -1).all()
    np.testing.assert_allclose(f.mean, [2.0, 3.0, 7.0 - 2 * math.pi])
    np.testing.assert_array_equal(f.cov, np.diag([0.1, 0.2, 0.3]))
    f.reset()  # back to the constructor's prior
    np.testing.assert_array_equal(f.mean, [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(f.cov, np.eye(3) * 0.01)
    # A reset filter behaves like a fresh one.
    fresh = make(initial_pose=(1.0, 1.0, 0.0), initial_pose_cov=np.eye(3) * 0.01, gate=1e-3)
    for g in (f, fresh):
        g.predict((0.1, 0.2, 0.3))
        observe(g, np.array([1.0, 1.0, 0.0]), LANDMARKS, [3, 2])
    np.testing.assert_array_equal(f.mean, fresh.mean)
    np.testing.assert_array_equal(f.cov, fresh.cov)


def test_the_heading_stays_wrapped():
    f = make(initial_pose=(0.0, 0.0, 3.1), initial_pose_cov=np.diag([1e-3] * 3))
    for _ in range(30):
        f.predict((0.1, 0.1, 0.1))
        assert -math.pi <= f.pose[2] < math.pi
    observe(f, f.pose, LANDMARKS, [0])
    f.predict((0.0, 0.0, 0.0))
    observe(f, f.pose + np.array([0.0, 0.0, 0.2]), LANDMARKS, [0])
    assert -math.pi <= f.pose[2] < math.pi


def test_belief_views_are_the_live_belief_read_only():
    f = make()
    f.predict(control("odometry"))
    observe(f, f.pose, LANDMARKS, [3, 1])
    mean, cov, ids = f.belief_views()
    np.testing.assert_array_equal(mean, f.mean)
    np.testing.assert_array_equal(cov, f.cov)
    np.testing.assert_array_equal(ids, f.state_to_id)
    for view in (mean, cov, ids):
        with pytest.raises(ValueError, match="read-only"):
            view[0] = 0
    before = f.mean
    f.predict(control("odometry"))  # the views follow the filter (and stay its size)
    assert not np.array_equal(mean, before) and np.array_equal(mean, f.mean)


def test_update_takes_lists_and_arrays_alike():
    a, b = make(), make()
    z = MEASUREMENT_MODELS["range_bearing"].h(a.pose, LANDMARKS[[0, 2]])
    ra = a.update(z, np.array([0, 2]))
    rb = b.update(z.tolist(), [0, 2])
    np.testing.assert_array_equal(a.mean, b.mean)
    for x, y in zip((ra.ids, ra.status, ra.nis), (rb.ids, rb.status, rb.nis), strict=True):
        np.testing.assert_array_equal(x, y)
    assert rb.ids.dtype == np.int64 and rb.status.dtype == np.int8


# --------------------------------------------------------------------------- purity


# That the filter's modules import no gymnasium or pymunk is an import contract
# (pyproject.toml, "The filter stands alone"; tests/test_layers.py breaks it on purpose).


def test_the_filter_runs_where_gymnasium_and_pymunk_cannot_be_imported():
    code = (
        "import sys\n"
        "for name in ('gymnasium', 'pymunk', 'pygame'):\n"
        "    sys.modules[name] = None  # import fails\n"
        "from slam_env.ekf import EKFSLAM\n"
        "f = EKFSLAM(alphas=(0.01,) * 4, measurement_cov=[[0.01, 0], [0, 0.001]], "
        "max_landmarks=3)\n"
        "f.predict((0.1, 0.2, 0.0))\n"
        "print(f.update([[2.0, 0.1]], [1]).status.tolist())\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    assert out.stdout.strip() == "[1]"
