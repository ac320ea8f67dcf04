"""The First-Estimates Jacobian EKF (``linearization="fej"``) and the
observability-constrained EKF (``"oc"``) against a dense filter whose Jacobians are
finite differences at the points they claim (FEJ: the pose the last prediction
produced and each landmark's first estimate; OC: the latest estimates, then projected
off the unobservable directions at the first estimates, by least squares), their
defining property (the linearised system never learns the global rotation, which the
true one cannot), and ``"standard"`` against the dense textbook filter of the seeds."""

from __future__ import annotations

import numpy as np
import pytest

from references import dense_ekf
from slam_env.ekf import EKFSLAM
from slam_env.ekf.models import (
    MEASUREMENT_MODELS,
    MOTION_MODELS,
    odometry_action_cov,
    velocity_control_cov,
)
from slam_env.world.frames import wrap_angle
from tests.ekf.test_filter_reference import ALPHAS, COMBOS, CONTROL_NOISE, Q, run_against_dense

STEP = 1e-6  # central differences: error O(STEP²) on smooth models


def numeric_jacobian(f, x: np.ndarray, angle_rows: tuple[int, ...] = ()) -> np.ndarray:
    cols = []
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx[i] = STEP
        diff = f(x + dx) - f(x - dx)
        for r in angle_rows:
            diff[r] = wrap_angle(diff[r])
        cols.append(diff / (2 * STEP))
    return np.stack(cols, axis=1)


def unobservable_directions(pose: np.ndarray, landmark: np.ndarray) -> np.ndarray:
    """(5, 3): the global x and y translations and the rotation about the origin
    (:func:`_rotation_direction`), as changes of (x, y, θ, m_x, m_y) at these points."""
    N = np.zeros((5, 3))
    N[[0, 3], 0] = N[[1, 4], 1] = 1.0
    N[:, 2] = _rotation_direction(pose, [landmark])
    return N


class DenseFirstEstimates:
    """FEJ- or OC-EKF-SLAM (``linearization``) with full matrices, sequential
    corrections, no gate; every Jacobian a finite difference of the models' f and h,
    OC's H then projected by a least-squares solve."""

    def __init__(
        self,
        motion: str,
        measurement: str,
        pose0: np.ndarray,
        cov0: np.ndarray,
        linearization: str,
    ):
        self.linearization = linearization
        self.mm, self.hm = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]
        self.motion, self.measurement = motion, measurement
        self.mu, self.Sigma = pose0.copy(), cov0.copy()
        self.first = pose0.copy()  # first estimates: the predicted pose, then landmarks
        self.slot: dict[int, int] = {}
        self.bearing = (1,) if measurement == "range_bearing" else ()

    def predict(self, u: np.ndarray) -> None:
        pose = self.mu[:3].copy()
        new = self.mm.motion(pose, u)
        # G at the first estimates: f's Jacobian is [[1, 0, −Δy], [0, 1, Δx], [0, 0, 1]]
        # in its displacement; FEJ takes the displacement between the first estimates.
        G_x = np.eye(3)
        G_x[0, 2] = -(new[1] - self.first[1])
        G_x[1, 2] = new[0] - self.first[0]
        V = numeric_jacobian(lambda v: self.mm.motion(pose, v), u, angle_rows=(2,))
        cov_u = (
            odometry_action_cov(u, ALPHAS)
            if self.motion == "odometry"
            else velocity_control_cov(u, CONTROL_NOISE)
        )
        d = self.mu.size
        G = np.eye(d)
        G[:3, :3] = G_x
        R = np.zeros((d, d))
        R[:3, :3] = V @ cov_u @ V.T
        if self.motion == "odometry":
            R[:3, :3] += dense_ekf.odometry_sideways_noise(pose[2], u, ALPHAS)
        self.Sigma = G @ self.Sigma @ G.T + R
        self.mu[:3] = new
        self.first[:3] = new

    def update(self, z: np.ndarray, ids: np.ndarray) -> None:
        q = Q[self.measurement]
        for zj, lid in zip(z, ids, strict=True):
            if lid not in self.slot:
                continue
            s = 3 + 2 * self.slot[lid]
            d = self.mu.size

            def h_at(pose_and_landmark: np.ndarray) -> np.ndarray:
                p, m = pose_and_landmark[:3], pose_and_landmark[3:]
                return self.hm.h(p, m[None])[0]

            firsts = np.concatenate([self.first[:3], self.first[s : s + 2]])
            if self.linearization == "fej":
                H5 = numeric_jacobian(h_at, firsts, angle_rows=self.bearing)
            else:  # the nearest H (least squares) with H N = 0 at the first estimates
                latest = np.concatenate([self.mu[:3], self.mu[s : s + 2]])
                H5 = numeric_jacobian(h_at, latest, angle_rows=self.bearing)
                N = unobservable_directions(firsts[:3], firsts[3:])
                H5 = H5 - np.linalg.lstsq(N, H5.T, rcond=None)[0].T @ N.T
            H = np.zeros((2, d))
            H[:, :3], H[:, s : s + 2] = H5[:, :3], H5[:, 3:]
            nu = zj - self.hm.h(self.mu[:3], self.mu[s : s + 2][None])[0]
            if self.bearing:
                nu[1] = wrap_angle(nu[1])
            S = H @ self.Sigma @ H.T + q
            K = self.Sigma @ H.T @ np.linalg.inv(S)
            self.mu = self.mu + K @ nu
            self.mu[2] = wrap_angle(self.mu[2])
            A = np.eye(d) - K @ H
            self.Sigma = A @ self.Sigma @ A.T + K @ q @ K.T
        for zj, lid in zip(z, ids, strict=True):
            if lid in self.slot:
                continue
            pose = self.mu[:3].copy()
            m = self.hm.inverse(pose, zj[None])[0]
            # L at the first estimates, as H: the start of a landmark is a correction
            # from no prior, h(pose, m) = z solved for m, so L = −H_m⁻¹ H_x with H at the
            # predicted pose and the landmark's first estimate m. W (noise) at the mean.
            H5 = numeric_jacobian(
                lambda pm: self.hm.h(pm[:3], pm[3:][None])[0],
                np.concatenate([self.first[:3], m]),
                angle_rows=self.bearing,
            )
            L = -np.linalg.solve(H5[:, 3:], H5[:, :3])
            W = numeric_jacobian(
                lambda zz, pose=pose: self.hm.inverse(pose, zz[None])[0], zj.copy()
            )
            d = self.mu.size
            cross = L @ self.Sigma[:3, :]
            block = L @ self.Sigma[:3, :3] @ L.T + W @ q @ W.T
            self.Sigma = np.block([[self.Sigma, cross.T], [cross, block]])
            self.mu = np.concatenate([self.mu, m])
            self.first = np.concatenate([self.first, m])
            self.slot[lid] = (d - 3) // 2


def _random_control(rng: np.random.Generator, motion: str) -> np.ndarray:
    """A forward move with some turning, in the control of ``motion``."""
    if motion == "odometry":
        return np.array([rng.uniform(-0.3, 0.3), rng.uniform(0.1, 0.6), rng.uniform(-0.3, 0.3)])
    return np.array([rng.uniform(0.1, 0.6), rng.uniform(-0.4, 0.4)])


@pytest.mark.parametrize(("motion", "measurement", "correction"), COMBOS)
def test_the_standard_linearization_is_the_seeds_filter_to_1e_12(
    dense_reference, motion, measurement, correction
):
    """``linearization="standard"`` is the filter of the seeds, unchanged by FEJ's
    bookkeeping: the dense textbook filter's mean and covariance to 1e-12."""
    counts = run_against_dense(
        dense_reference, motion, measurement, correction, seed=0, atol=1e-12,
        linearization="standard",
    )  # fmt: skip
    assert counts["corrected"] > 50 and counts["initialised"] == 12


@pytest.mark.parametrize("linearization", ["fej", "oc"])
@pytest.mark.parametrize("motion", ["odometry", "velocity"])
@pytest.mark.parametrize("measurement", ["range_bearing", "cartesian"])
def test_fej_and_oc_match_a_dense_filter_with_the_jacobians_they_claim(
    motion, measurement, linearization
):
    rng = np.random.default_rng(4)
    truth = rng.uniform(-5, 5, size=(10, 2))
    pose0 = np.array([0.3, -0.2, 0.4])
    cov0 = np.diag([0.01, 0.02, 0.003])
    f = EKFSLAM(
        motion_model=motion,
        measurement_model=measurement,
        alphas=ALPHAS,
        control_noise=CONTROL_NOISE,
        measurement_cov=Q[measurement],
        max_landmarks=10,
        initial_pose=pose0,
        initial_pose_cov=cov0,
        linearization=linearization,
    )
    dense = DenseFirstEstimates(motion, measurement, pose0, cov0, linearization)
    mm, hm = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]
    pose = pose0.copy()
    for _ in range(40):
        u = _random_control(rng, motion)
        pose = mm.motion(pose, u)
        f.predict(u)
        dense.predict(u)
        ids = rng.permutation(10)[: rng.integers(0, 5)]
        z = hm.h(pose, truth[ids]) + rng.normal(size=(ids.size, 2)) * 0.03
        f.update(z, ids)
        dense.update(z, ids)
        mean = f.mean
        assert abs(wrap_angle(mean[2] - dense.mu[2])) < 1e-6
        mean[2] = dense.mu[2]
        np.testing.assert_allclose(mean, dense.mu, rtol=0, atol=1e-6)
        np.testing.assert_allclose(f.cov, dense.Sigma, rtol=0, atol=1e-7)
    assert f.n_landmarks >= 8


def test_the_first_estimates_jacobian_is_fs_jacobian_where_the_estimates_agree():
    """Before any correction the first estimate is the estimate: FEJ's G is then f's
    Jacobian at the mean, by finite differences, and FEJ predicts as the standard EKF."""
    pose0 = np.array([0.3, -0.2, 0.4])
    u = np.array([0.2, 0.5, -0.1])
    G = numeric_jacobian(lambda p: MOTION_MODELS["odometry"].motion(p, u), pose0, (2,))
    cov0 = np.diag([0.0, 0.0, 1.0])  # P after = G P Gᵀ + R: column θ of G, read off
    f = {
        lin: EKFSLAM(
            alphas=(0, 0, 0, 0),
            measurement_cov=Q["range_bearing"],
            max_landmarks=1,
            initial_pose=pose0,
            initial_pose_cov=cov0,
            linearization=lin,
        )
        for lin in ("standard", "fej")
    }
    for filt in f.values():
        filt.predict(u)
    np.testing.assert_allclose(f["fej"].pose_cov[:, 2], G[:, 2], atol=1e-8)
    np.testing.assert_array_equal(f["fej"].pose_cov, f["standard"].pose_cov)


def _rotation_direction(pose: np.ndarray, landmarks: list[np.ndarray]) -> np.ndarray:
    """The state's change under a small global rotation about the origin:
    (−y, x, 1, −m1y, m1x, …) at the given points."""
    parts = [np.array([-pose[1], pose[0], 1.0])]
    parts += [np.array([-m[1], m[0]]) for m in landmarks]
    return np.concatenate(parts)


@pytest.mark.parametrize("motion", ["odometry", "velocity"])
@pytest.mark.parametrize("measurement", ["range_bearing", "cartesian"])
@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_fej_and_oc_never_learn_the_global_rotation(motion, measurement, correction):
    """FEJ's and OC's reason to exist (Huang, Mourikis & Roumeliotis): the linearised
    system keeps the true one's unobservable rotation. So a prior variance c along the
    global rotation's direction N (at the first estimates: the pose the last prediction
    produced, each landmark as it was started) is carried, never corrected: two such
    filters on the same data, one started with P0 and one with P0 + c N₀N₀ᵀ, differ by
    exactly c N Nᵀ at every step, through predictions (G N = N'), corrections (H N = 0)
    and new landmarks (L N_pose = N_landmark), including scans that correct known
    landmarks and start new ones together. The standard EKF does not keep it."""
    rng = np.random.default_rng(7)
    truth = rng.uniform(-5, 5, size=(12, 2))
    pose0 = np.array([0.7, -0.4, 0.3])
    cov0 = np.diag([0.01, 0.02, 0.003])
    c = 0.01
    n0 = _rotation_direction(pose0, [])
    mm, hm = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]

    def make(lin: str, cov: np.ndarray) -> EKFSLAM:
        return EKFSLAM(
            motion_model=motion, measurement_model=measurement, alphas=ALPHAS,
            control_noise=CONTROL_NOISE, measurement_cov=Q[measurement], max_landmarks=12,
            initial_pose=pose0, initial_pose_cov=cov, linearization=lin,
            correction=correction,
        )  # fmt: skip

    worst = {}
    for lin in ("fej", "oc", "standard"):
        a, b = make(lin, cov0), make(lin, cov0 + c * np.outer(n0, n0))
        rng = np.random.default_rng(11)
        pose, first_marks, mixed, worst[lin] = pose0.copy(), {}, 0, 0.0
        for _ in range(40):
            u = _random_control(rng, motion)
            pose = mm.motion(pose, u)
            a.predict(u)
            b.predict(u)
            predicted = a.pose
            ids = rng.permutation(12)[: rng.integers(0, 6)]
            z = hm.h(pose, truth[ids]) + rng.normal(size=(ids.size, 2)) * 0.03
            known = np.isin(ids, list(first_marks))
            mixed += bool(known.any() and not known.all())
            a.update(z, ids)
            b.update(z, ids)
            for lid in ids.tolist():
                first_marks.setdefault(lid, a.landmark(lid)[0])
            n = _rotation_direction(predicted, [first_marks[i] for i in a.state_to_id.tolist()])
            worst[lin] = max(worst[lin], float(np.abs(b.cov - a.cov - c * np.outer(n, n)).max()))
        assert mixed >= 3  # scans that both correct and start landmarks
    assert worst["fej"] < 1e-9 and worst["oc"] < 1e-9
    assert worst["standard"] > 1e-4
