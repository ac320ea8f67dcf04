"""The dense right-invariant EKF of ``references/invariant_ekf.py``: its group
operations against scipy's matrix exponential, every Jacobian against central finite
differences of the invariant error dynamics and measurements (each motion ×
measurement model), the propagation Jacobian the same at two estimates of one step,
and the reported covariance J_r P J_rᵀ."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.linalg import expm

from references import dense_ekf
from references import invariant_ekf as inv

STEP = 1e-6
ALPHAS = (0.02, 0.01, 0.02, 0.01)
CONTROL_NOISE = (0.02, 0.01, 0.01, 0.05)
Q = np.diag([0.04**2, 0.03**2])
CONTROLS = {"odometry": np.array([0.2, 0.7, -0.15]), "velocity": np.array([0.6, 0.25])}
PAIRS = list(itertools.product(["odometry", "velocity"], ["range_bearing", "cartesian"]))


def numeric_jacobian(f, x):
    cols = []
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx[i] = STEP
        cols.append((f(x + dx) - f(x - dx)) / (2 * STEP))
    return np.stack(cols, axis=1)


def estimate(seed: int, n: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.uniform(-3, 3, 2), [rng.uniform(-3, 3)], rng.uniform(-6, 6, 2 * n)])


def as_matrix(y: np.ndarray) -> np.ndarray:
    """χ ∈ SE_{1+N}(2) as a (3 + N) square matrix."""
    k = 1 + (y.size - 3) // 2
    X = np.eye(2 + k)
    X[:2, :2] = inv.rot(y[2])
    X[:2, 2:] = inv.points(y).T
    return X


def hat(xi: np.ndarray) -> np.ndarray:
    k = 1 + (xi.size - 3) // 2
    A = np.zeros((2 + k, 2 + k))
    A[:2, :2] = xi[2] * inv.J
    A[:2, 2:] = inv.points(xi).T
    return A


@pytest.mark.parametrize("seed", range(4))
def test_exp_retract_and_log_error_are_the_group_exponential_and_logarithm(seed):
    y = estimate(seed)
    xi = np.random.default_rng(10 + seed).normal(size=y.size) * 0.7
    np.testing.assert_allclose(
        as_matrix(inv.exp_retract(y, xi)), expm(hat(xi)) @ as_matrix(y), atol=1e-12
    )
    np.testing.assert_allclose(inv.log_error(inv.exp_retract(y, xi), y), xi, atol=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_the_retraction_jacobian_is_the_first_order_change_of_the_state(seed):
    y = estimate(seed)
    numeric = numeric_jacobian(lambda xi: inv.exp_retract(y, xi), np.zeros(y.size))
    np.testing.assert_allclose(inv.retraction_jacobian(y), numeric, atol=1e-8)


@pytest.mark.parametrize("motion", ["odometry", "velocity"])
def test_the_propagation_jacobian_is_the_identity_at_any_estimate(motion):
    """F = ∂ξ_t/∂ξ_{t−1} of the true error dynamics, by central differences at two
    different estimates of the same step: the same matrix, the identity."""
    u = CONTROLS[motion]

    def F_at(y):
        def error_after(xi):
            return inv.log_error(
                inv.compose(motion, inv.exp_retract(y, xi), u), inv.compose(motion, y, u)
            )

        return numeric_jacobian(error_after, np.zeros(y.size))

    F_a, F_b = F_at(estimate(0)), F_at(estimate(1))
    np.testing.assert_allclose(F_a, F_b, atol=1e-8)
    np.testing.assert_allclose(F_a, np.eye(F_a.shape[0]), atol=1e-8)


@pytest.mark.parametrize("motion", ["odometry", "velocity"])
@pytest.mark.parametrize("seed", range(3))
def test_the_noise_jacobian_is_the_errors_change_with_the_control(motion, seed):
    y, u = estimate(seed), CONTROLS[motion]
    f = inv.InvariantEKFSLAM(motion, "cartesian", Q, alphas=ALPHAS, control_noise=CONTROL_NOISE)
    f.mu = y.copy()
    numeric = numeric_jacobian(
        lambda e: inv.log_error(inv.compose(motion, y, u + e), inv.compose(motion, y, u)),
        np.zeros(u.size),
    )
    np.testing.assert_allclose(f.noise_jacobian(u), numeric, atol=1e-8)


@pytest.mark.parametrize(("motion", "measurement"), PAIRS)
def test_the_measurement_jacobian_in_invariant_coordinates(motion, measurement):
    """H = ∂h(exp(ξ) χ̂)/∂ξ after a step of ``motion`` (the estimate it predicts)."""
    y = inv.compose(motion, estimate(5), CONTROLS[motion])
    for j in range(3):
        numeric = numeric_jacobian(
            lambda xi, j=j: inv.observe(measurement, inv.exp_retract(y, xi), j), np.zeros(y.size)
        )
        H = inv.invariant_H(measurement, y, j)
        np.testing.assert_allclose(H, numeric, atol=1e-7)
        assert np.all(H[:, 2] == 0.0)  # the heading column is empty


@pytest.mark.parametrize("measurement", ["range_bearing", "cartesian"])
def test_the_new_landmark_jacobians_in_invariant_coordinates(measurement):
    """ξ_new of m = p + R c(z) against the estimate [ŷ, m̂]: L = [I₂, 0, …] in the
    state's error, W = R̂ Dc(z) in the measurement's."""
    y = estimate(3)
    z = np.array([2.5, 0.4]) if measurement == "range_bearing" else np.array([1.5, -2.0])
    f = inv.InvariantEKFSLAM("odometry", measurement, Q, alphas=ALPHAS)
    f.mu, f.P, f.ids = y.copy(), np.zeros((y.size, y.size)), [10, 11, 12]
    f.update(z[None], [13])
    y_new = f.mu

    def landmark_error(xi_and_dz):
        xi, dz = xi_and_dz[: y.size], xi_and_dz[y.size :]
        truth = inv.exp_retract(y, xi)
        c, _ = inv.robot_frame_point(measurement, z + dz)
        m = truth[:2] + inv.rot(truth[2]) @ c
        return inv.log_error(np.concatenate([truth, m]), y_new)[-2:]

    numeric = numeric_jacobian(landmark_error, np.zeros(y.size + 2))
    L = np.zeros((2, y.size))
    L[:, :2] = np.eye(2)
    _, Dc = inv.robot_frame_point(measurement, z)
    np.testing.assert_allclose(numeric[:, : y.size], L, atol=1e-8)
    np.testing.assert_allclose(numeric[:, y.size :], inv.rot(y[2]) @ Dc, atol=1e-8)
    # The new landmark's block: W Q Wᵀ from a known pose.
    W = inv.rot(y[2]) @ Dc
    np.testing.assert_allclose(f.P[-2:, -2:], W @ Q @ W.T, atol=1e-15)


def test_the_reported_covariance_is_the_mapped_invariant_one():
    cov0 = np.diag([0.01, 0.02, 0.003])
    pose0 = np.array([1.5, -2.0, 0.4])
    f = inv.InvariantEKFSLAM("odometry", "range_bearing", Q, alphas=ALPHAS, initial_pose=pose0,
                             initial_pose_cov=cov0)  # fmt: skip
    np.testing.assert_allclose(f.cov, cov0, atol=1e-15)  # the prior, mapped back
    f.predict(CONTROLS["odometry"])
    f.update(np.array([[2.0, 0.3], [3.0, -0.4]]), [0, 1])
    f.update(np.array([[1.9, 0.35], [3.1, -0.45]]), [0, 1])
    Jr = inv.retraction_jacobian(f.mu)
    np.testing.assert_allclose(f.cov, Jr @ f.P @ Jr.T, atol=0)
    assert not np.allclose(Jr, np.eye(f.mu.size))  # the map is not the identity here


@pytest.mark.parametrize("motion", ["odometry", "velocity"])
def test_its_prediction_of_the_state_covariance_is_the_standard_ekfs(motion):
    """docs/filter.md, "How the kernels keep it": J_r(ŷ_t) J_r(ŷ_{t−1})⁻¹ is the
    standard G and J_r G_t the standard action Jacobian, so one prediction from the
    same covariance gives the same mapped covariance as the seeds' EKF."""
    cov0 = np.diag([0.01, 0.02, 0.003])
    kwargs = dict(alphas=ALPHAS, control_noise=CONTROL_NOISE, initial_pose=(1.0, -2.0, 0.5),
                  initial_pose_cov=cov0)  # fmt: skip
    a = inv.InvariantEKFSLAM(motion, "cartesian", Q, **kwargs)
    b = dense_ekf.DenseEKFSLAM(motion, "cartesian", Q, **kwargs)
    for filt in (a, b):
        filt.update(np.array([[2.0, 0.5], [-1.0, 3.0]]), [0, 1])
        filt.predict(CONTROLS[motion])
    np.testing.assert_allclose(a.mean, b.mean, atol=1e-14)
    np.testing.assert_allclose(a.cov, b.cov, atol=1e-14)
