"""A dense, textbook right-invariant EKF-SLAM (Barrau & Bonnabel, "An EKF-SLAM algorithm
with consistency properties", 2015): the referee of ``linearization="invariant"``.

The equations are those of docs/filter.md, "The right-invariant EKF". Full matrices
everywhere, one equation per line. It is kept apart from ``slam_env`` on purpose, and
the seeds' models are derived again here, in the group:

* state χ ∈ SE_{1+N}(2), kept as the vector y = (x, y, θ, m1x, m1y, …); error
  χ = exp(ξ) χ̂, ξ = (ξ_p, ξ_θ, ξ_1, …) ordered as y; P = Cov(ξ);
* prediction χ ← χ U(u), F = I, P ← P + G M Gᵀ with G = Ad_χ̂ [B_u; 0];
* correction with H in invariant coordinates, χ̂ ← exp(K ν) χ̂, Joseph form;
* new landmark ξ_new = ξ_p + R̂ Dc(z) δz (L = [I₂, 0], W = R̂ Dc(z));
* reported covariance J_r P J_rᵀ (:func:`retraction_jacobian`).

It is :class:`references.dense_ekf.DenseEKFSLAM` (its constructor, ``update`` and
statuses) with these pieces in place of the standard ones.
"""

from __future__ import annotations

import math

import numpy as np

from references import dense_ekf
from references.dense_ekf import CORRECTED, INITIALISED, REJECTED, wrap

__all__ = ["CORRECTED", "INITIALISED", "REJECTED", "InvariantEKFSLAM"]
J = np.array([[0.0, -1.0], [1.0, 0.0]])


def rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def V(phi):
    """SE(2)'s left Jacobian: exp of (ξ_θ, v) moves a point by V(ξ_θ) v."""
    if phi == 0.0:
        return np.eye(2)
    return (math.sin(phi) / phi) * np.eye(2) + ((1.0 - math.cos(phi)) / phi) * J


def points(y):
    """The columns of χ after R: position, then landmarks, as (1 + N, 2)."""
    return np.concatenate([y[:2], y[3:]]).reshape(-1, 2)


def from_points(theta, pts):
    pts = np.asarray(pts).reshape(-1)
    return np.concatenate([pts[:2], [wrap(theta)], pts[2:]])


def exp_retract(y, xi):
    """χ = exp(ξ) χ̂ as a state vector: θ̂ + ξ_θ; each point R(ξ_θ) q̂ + V(ξ_θ) ξ_q."""
    phi = xi[2]
    xi_points = points(xi)
    new = points(y) @ rot(phi).T + xi_points @ V(phi).T
    return from_points(y[2] + phi, new)


def log_error(y, y_hat):
    """ξ = log(χ χ̂⁻¹): χ χ̂⁻¹ has rotation θ − θ̂ and points q − R(θ − θ̂) q̂."""
    phi = wrap(y[2] - y_hat[2])
    translations = points(y) - points(y_hat) @ rot(phi).T
    xi_points = translations @ np.linalg.inv(V(phi)).T
    out = np.concatenate([xi_points[0], [phi], xi_points[1:].reshape(-1)])
    return out


def rotation_direction(y):
    """v(ŷ) = (−ŷ, x̂, 0, −m̂1y, m̂1x, …): J q̂ for each point, 0 at the heading."""
    jq = points(y) @ J.T
    return np.concatenate([jq[0], [0.0], jq[1:].reshape(-1)])


def retraction_jacobian(y):
    """J_r = ∂y/∂ξ at ξ = 0: δy = ξ + ξ_θ v(ŷ), so J_r = I + v e_θᵀ."""
    Jr = np.eye(y.size)
    Jr[:, 2] += rotation_direction(y)
    return Jr


def adjoint(y):
    """Ad_χ: (ξ_q, ξ_θ) ↦ (R ξ_q − ξ_θ J q, ξ_θ) for every point q of χ."""
    d = y.size
    R = rot(y[2])
    Ad = np.zeros((d, d))
    Ad[2, 2] = 1.0
    rows = [0, *range(3, d, 2)]
    for q, r in zip(points(y), rows, strict=True):
        Ad[r : r + 2, r : r + 2] = R
        Ad[r : r + 2, 2] = -J @ q
    return Ad


def body_increment(motion, u):
    """U(u) = (φ_u, t_u): odometry rotates δrot1, moves δtr, rotates δrot2; the
    velocity model moves Δp, then rotates Δθ."""
    if motion == "odometry":
        rot1, trans, rot2 = u
        return rot1 + rot2, trans * np.array([math.cos(rot1), math.sin(rot1)])
    dp, dth = u
    return dth, np.array([dp, 0.0])


def body_jacobian(motion, u):
    """B_u with U(u + ε) ≈ U(u) exp(B_u ε): rows (translation, heading)."""
    phi, _ = body_increment(motion, u)
    if motion == "odometry":
        rot1, trans, _ = u
        dt_du = np.array(
            [
                [-trans * math.sin(rot1), math.cos(rot1), 0.0],
                [trans * math.cos(rot1), math.sin(rot1), 0.0],
            ]
        )
        dphi_du = np.array([1.0, 0.0, 1.0])
    else:
        dt_du = np.array([[1.0, 0.0], [0.0, 0.0]])
        dphi_du = np.array([0.0, 1.0])
    return np.vstack([rot(phi).T @ dt_du, dphi_du])


def compose(motion, y, u):
    """χ U(u): the pose moves in its own frame, the landmarks stay."""
    phi, t = body_increment(motion, u)
    out = y.copy()
    out[:2] = y[:2] + rot(y[2]) @ t
    out[2] = wrap(y[2] + phi)
    return out


def action_cov(motion, u, alphas, control_noise):
    """M (seed 000) or Σu (seed 004)."""
    if motion == "odometry":
        rot1, trans, rot2 = u
        a1, a2, a3, a4 = alphas
        return np.diag(
            [
                a1 * rot1**2 + a2 * trans**2,
                a3 * trans**2 + a4 * (rot1**2 + rot2**2),
                a1 * rot2**2 + a2 * trans**2,
            ]
        )
    dp, dth = u
    sp, sth, bp, bth = control_noise
    return np.diag([sp**2 + bp * dp**2, sth**2 + bth * dth**2])


def observe(measurement, y, j):
    """h: the landmark in slot j in the robot frame, c = R(θ)ᵀ(m − p), or ρ(c)."""
    c = rot(y[2]).T @ (y[3 + 2 * j : 5 + 2 * j] - y[:2])
    if measurement == "cartesian":
        return c
    return np.array([math.hypot(c[0], c[1]), math.atan2(c[1], c[0])])


def invariant_H(measurement, y, j):
    """H in invariant coordinates: [−R̂ᵀ, 0, …, R̂ᵀ, …] (cartesian), Dρ(ĉ) of it
    (range-bearing)."""
    d = y.size
    Rt = rot(y[2]).T
    H = np.zeros((2, d))
    H[:, :2] = -Rt
    H[:, 3 + 2 * j : 5 + 2 * j] = Rt
    if measurement == "cartesian":
        return H
    c = Rt @ (y[3 + 2 * j : 5 + 2 * j] - y[:2])
    r = math.hypot(c[0], c[1])
    D_rho = np.array([[c[0] / r, c[1] / r], [-c[1] / r**2, c[0] / r**2]])
    return D_rho @ H


def robot_frame_point(measurement, z):
    """c(z) and Dc(z): the measured landmark in the robot frame."""
    if measurement == "cartesian":
        return np.asarray(z, float), np.eye(2)
    r, phi = z
    c = np.array([r * math.cos(phi), r * math.sin(phi)])
    Dc = np.array([[math.cos(phi), -r * math.sin(phi)], [math.sin(phi), r * math.cos(phi)]])
    return c, Dc


class InvariantEKFSLAM(dense_ekf.DenseEKFSLAM):
    """The seeds' dense filter (its constructor, ``update`` loop, gate and new-landmark
    augmentation) with the invariant pieces in place of the standard ones: ``Sigma``
    holds P, the covariance of ξ, and ``cov`` reports J_r P J_rᵀ."""

    def __init__(self, motion_model, measurement_model, measurement_cov, **kwargs):
        super().__init__(motion_model, measurement_model, measurement_cov, **kwargs)
        Jr_inv = np.linalg.inv(retraction_jacobian(self.mu))
        self.Sigma = Jr_inv @ self.Sigma @ Jr_inv.T  # the prior's error, invariant coordinates

    @property
    def P(self):
        return self.Sigma

    @P.setter
    def P(self, value):
        self.Sigma = value

    @property
    def cov(self):
        Jr = retraction_jacobian(self.mu)
        return Jr @ self.P @ Jr.T

    # ----------------------------------------------------------------- prediction
    def noise_jacobian(self, u):
        """G = Ad_χ̂' [B_u; 0], at the predicted estimate χ̂' = χ̂ U(u)."""
        d = self.mu.size
        B = np.zeros((d, len(u)))
        B[:3] = body_jacobian(self.motion_model, u)
        return adjoint(compose(self.motion_model, self.mu, u)) @ B

    def predict(self, u):
        u = np.asarray(u, float)
        F = np.eye(self.mu.size)  # the error's propagation: the identity, at any estimate
        G = self.noise_jacobian(u)
        M = action_cov(self.motion_model, u, self.alphas, self.control_noise)
        self.P = F @ self.P @ F.T + G @ M @ G.T
        if self.motion_model == "odometry":
            # The filter's sideways terms, on the position only: J_r leaves them as they are.
            self.P[:3, :3] += dense_ekf.odometry_sideways_noise(self.mu[2], u, self.alphas)
        self.mu = compose(self.motion_model, self.mu, u)

    # ----------------------------------------------------------------- correction
    def _h_and_H(self, j):
        """ẑ and H in invariant coordinates for the landmark in slot j."""
        return observe(self.measurement_model, self.mu, j), invariant_H(
            self.measurement_model, self.mu, j
        )

    def _joseph(self, H, Q, nu):
        d = self.mu.size
        S = H @ self.P @ H.T + Q
        K = self.P @ H.T @ np.linalg.inv(S)
        self.mu = exp_retract(self.mu, K @ nu)  # χ̂ ← exp(K ν) χ̂
        IKH = np.eye(d) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ Q @ K.T

    def _inverse(self, z):
        """m = p + R(θ) c(z); in invariant coordinates ξ_new = ξ_p + W δz:
        L = [I₂, 0] on (ξ_p, ξ_θ), W = R̂ Dc(z)."""
        c, Dc = robot_frame_point(self.measurement_model, z)
        R = rot(self.mu[2])
        m = self.mu[:2] + R @ c
        L = np.zeros((2, 3))
        L[:, :2] = np.eye(2)
        return m, L, R @ Dc
