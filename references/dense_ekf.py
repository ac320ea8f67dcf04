"""A dense, textbook EKF-SLAM written straight from the seed equations.

The test oracle (and the benchmark's baseline) for :class:`slam_env.ekf.EKFSLAM`:
full (3+2n)×(3+2n) matrices everywhere, nothing clever. Deliberately independent of
``slam_env.ekf``: the models are re-derived here from seeds 000 and 004.

* Prediction: Σ = G Σ Gᵀ + R with G = blockdiag(G_x, I), R = blockdiag(R_x, 0),
  R_x = V M Vᵀ (odometry, plus two sideways terms, see ``predict``) or B Σu Bᵀ
  (velocity).
* Correction: full-width H (2×D per observation, stacked 2k×D in batch mode),
  K = Σ Hᵀ (H Σ Hᵀ + Q)⁻¹, μ += K ν (bearing innovations wrapped),
  Σ = (I − K H) Σ (I − K H)ᵀ + K Q Kᵀ (Joseph).
* New landmark: m = h⁻¹(z, μ_x); the augmented covariance
  [[Σ, Σ L̃ᵀ], [L̃ Σ, L Σ_x Lᵀ + W Q Wᵀ]] with L̃ = [L, 0, …, 0] (2×D).
* Gate: an observation with νᵀ S⁻¹ ν above the gate is rejected (batch: on its own
  2×2 block, before stacking).

Status codes: 0 corrected, 1 initialised, 2 rejected.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.models import MIN_ODOMETRY_TRANSLATION

CORRECTED, INITIALISED, REJECTED = 0, 1, 2
# The odometry reading drops the sideways part of a motion under the sensor's threshold:
# spread uniformly within ±threshold, a variance of threshold²/3 per position axis.
DROPPED_SIDEWAYS_VARIANCE = MIN_ODOMETRY_TRANSLATION**2 / 3.0


def odometry_noise_diagonal(u, alphas):
    """The diagonal of seed 000's M: (var δrot1, var δtr, var δrot2)."""
    rot1, trans, rot2 = (float(v) for v in u)
    a1, a2, a3, a4 = alphas
    return (
        a1 * rot1**2 + a2 * trans**2,
        a3 * trans**2 + a4 * (rot1**2 + rot2**2),
        a1 * rot2**2 + a2 * trans**2,
    )


def odometry_sideways_noise(th, u, alphas):
    """What the filter adds to seed 000's R_x = V M Vᵀ (3×3): across the direction of
    travel n = (−sin, cos)(θ + δrot1), the second-order term var(δrot1)·var(δtr) of
    the product δtr·δrot1 (V M Vᵀ's δtr²·var(δrot1) vanishes with δtr, its noise does
    not), and on each position axis the variance of the sideways part of a motion under
    1 mm, which the odometry reading drops."""
    var_rot1, var_trans, _ = odometry_noise_diagonal(u, alphas)
    n = np.array([-math.sin(th + float(u[0])), math.cos(th + float(u[0])), 0.0])
    dropped = np.diag([DROPPED_SIDEWAYS_VARIANCE, DROPPED_SIDEWAYS_VARIANCE, 0.0])
    return var_rot1 * var_trans * np.outer(n, n) + dropped


def wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


class DenseEKFSLAM:
    def __init__(
        self,
        motion_model,
        measurement_model,
        measurement_cov,
        alphas=None,
        control_noise=None,
        initial_pose=(0.0, 0.0, 0.0),
        initial_pose_cov=None,
        gate=None,
        correction="sequential",
    ):
        self.motion_model = motion_model
        self.measurement_model = measurement_model
        self.alphas = alphas
        self.control_noise = control_noise
        self.Q = np.array(measurement_cov, dtype=float)
        self.gate = gate
        self.correction = correction
        self.mu = np.array(initial_pose, dtype=float)
        self.mu[2] = wrap(self.mu[2])
        self.Sigma = (
            np.zeros((3, 3)) if initial_pose_cov is None else np.array(initial_pose_cov, float)
        )
        self.ids: list[int] = []
        self.n_rejected = 0

    # ----------------------------------------------------------------- read access
    @property
    def mean(self):
        return self.mu.copy()

    @property
    def cov(self):
        return self.Sigma.copy()

    @property
    def state_to_id(self):
        return np.array(self.ids, dtype=np.int64)

    # ----------------------------------------------------------------- prediction
    def predict(self, u):
        x, y, th = self.mu[:3]
        D = self.mu.size
        if self.motion_model == "odometry":
            rot1, trans, rot2 = (float(v) for v in u)
            g = np.array(
                [
                    x + trans * math.cos(th + rot1),
                    y + trans * math.sin(th + rot1),
                    wrap(th + rot1 + rot2),
                ]
            )
            Gx = np.array(
                [
                    [1.0, 0.0, -trans * math.sin(th + rot1)],
                    [0.0, 1.0, trans * math.cos(th + rot1)],
                    [0.0, 0.0, 1.0],
                ]
            )
            V = np.array(
                [
                    [-trans * math.sin(th + rot1), math.cos(th + rot1), 0.0],
                    [trans * math.cos(th + rot1), math.sin(th + rot1), 0.0],
                    [1.0, 0.0, 1.0],
                ]
            )
            M = np.diag(odometry_noise_diagonal(u, self.alphas))
            Rx = V @ M @ V.T + odometry_sideways_noise(th, u, self.alphas)
        else:
            dp, dth = (float(v) for v in u)
            sp, sth, bp, bth = self.control_noise
            g = np.array([x + dp * math.cos(th), y + dp * math.sin(th), wrap(th + dth)])
            Gx = np.array(
                [[1.0, 0.0, -dp * math.sin(th)], [0.0, 1.0, dp * math.cos(th)], [0.0, 0.0, 1.0]]
            )
            B = np.array([[math.cos(th), 0.0], [math.sin(th), 0.0], [0.0, 1.0]])
            Su = np.diag([sp**2 + bp * dp**2, sth**2 + bth * dth**2])
            Rx = B @ Su @ B.T
        G = np.eye(D)
        G[:3, :3] = Gx
        R = np.zeros((D, D))
        R[:3, :3] = Rx
        self.Sigma = G @ self.Sigma @ G.T + R
        self.mu[:3] = g

    # ----------------------------------------------------------------- models
    def _h_and_H(self, j):
        """ẑ (2,) and the full-width H (2×D) for the landmark in state slot j."""
        x, y, th = self.mu[:3]
        mx, my = self.mu[3 + 2 * j : 5 + 2 * j]
        D = self.mu.size
        H = np.zeros((2, D))
        dx, dy = mx - x, my - y
        if self.measurement_model == "range_bearing":
            q = dx**2 + dy**2
            sq = math.sqrt(q)
            zhat = np.array([sq, wrap(math.atan2(dy, dx) - th)])
            H[:, :3] = [[-dx / sq, -dy / sq, 0.0], [dy / q, -dx / q, -1.0]]
            H[:, 3 + 2 * j : 5 + 2 * j] = [[dx / sq, dy / sq], [-dy / q, dx / q]]
        else:
            c, s = math.cos(th), math.sin(th)
            Rt = np.array([[c, s], [-s, c]])  # R(θ)ᵀ
            zhat = Rt @ np.array([dx, dy])
            dRt = np.array([[-s, c], [-c, -s]])  # ∂R(θ)ᵀ/∂θ
            H[:, :2] = -Rt
            H[:, 2] = dRt @ np.array([dx, dy])
            H[:, 3 + 2 * j : 5 + 2 * j] = Rt
        return zhat, H

    def _innovation(self, z, zhat):
        nu = np.asarray(z, float) - zhat
        if self.measurement_model == "range_bearing":
            nu[1] = wrap(nu[1])
        return nu

    def _inverse(self, z):
        x, y, th = self.mu[:3]
        if self.measurement_model == "range_bearing":
            r, phi = z
            a = phi + th
            m = np.array([x + r * math.cos(a), y + r * math.sin(a)])
            L = np.array([[1.0, 0.0, -r * math.sin(a)], [0.0, 1.0, r * math.cos(a)]])
            W = np.array([[math.cos(a), -r * math.sin(a)], [math.sin(a), r * math.cos(a)]])
        else:
            c, s = math.cos(th), math.sin(th)
            Rot = np.array([[c, -s], [s, c]])
            m = np.array([x, y]) + Rot @ np.asarray(z, float)
            dRot = np.array([[-s, -c], [c, -s]])
            L = np.zeros((2, 3))
            L[:, :2] = np.eye(2)
            L[:, 2] = dRot @ np.asarray(z, float)
            W = Rot
        return m, L, W

    # ----------------------------------------------------------------- correction
    def _joseph(self, H, Q, nu):
        D = self.mu.size
        S = H @ self.Sigma @ H.T + Q
        K = self.Sigma @ H.T @ np.linalg.inv(S)
        self.mu = self.mu + K @ nu
        self.mu[2] = wrap(self.mu[2])
        IKH = np.eye(D) - K @ H
        self.Sigma = IKH @ self.Sigma @ IKH.T + K @ Q @ K.T

    def update(self, z, ids):
        z = np.asarray(z, float).reshape(-1, 2)
        ids = [int(i) for i in ids]
        k = len(ids)
        status = np.full(k, -1)
        nis = np.full(k, np.nan)
        known = [i for i in range(k) if ids[i] in self.ids]
        new = [i for i in range(k) if ids[i] not in self.ids]
        if self.correction == "sequential":
            for i in known:
                zhat, H = self._h_and_H(self.ids.index(ids[i]))
                nu = self._innovation(z[i], zhat)
                S = H @ self.Sigma @ H.T + self.Q
                nis[i] = nu @ np.linalg.inv(S) @ nu
                if self.gate is not None and nis[i] > self.gate:
                    status[i] = REJECTED
                    self.n_rejected += 1
                    continue
                self._joseph(H, self.Q, nu)
                status[i] = CORRECTED
        elif known:
            Hs, nus = [], []
            for i in known:
                zhat, H = self._h_and_H(self.ids.index(ids[i]))
                nu = self._innovation(z[i], zhat)
                S = H @ self.Sigma @ H.T + self.Q
                nis[i] = nu @ np.linalg.inv(S) @ nu
                if self.gate is not None and nis[i] > self.gate:
                    status[i] = REJECTED
                    self.n_rejected += 1
                    continue
                Hs.append(H)
                nus.append(nu)
                status[i] = CORRECTED
            if Hs:
                H = np.vstack(Hs)
                Q = np.kron(np.eye(len(Hs)), self.Q)
                self._joseph(H, Q, np.concatenate(nus))
        for i in new:
            m, L, W = self._inverse(z[i])
            D = self.mu.size
            Lfull = np.zeros((2, D))
            Lfull[:, :3] = L
            Smm = L @ self.Sigma[:3, :3] @ L.T + W @ self.Q @ W.T
            cross = Lfull @ self.Sigma  # Σ_{m, y} = L Σ_{x, y}
            self.Sigma = np.block([[self.Sigma, cross.T], [cross, Smm]])
            self.mu = np.concatenate([self.mu, m])
            self.ids.append(ids[i])
            status[i] = INITIALISED
        return status, nis
