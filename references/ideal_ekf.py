"""The "ideal EKF" of Huang, Mourikis & Roumeliotis ("Analysis and improvement of
the consistency of extended Kalman filter based SLAM", ICRA 2008): the yardstick of
how consistent any EKF linearisation can be, in ``bench_consistency.py``.

It is EKF-SLAM with known correspondences whose every Jacobian is evaluated at
linearisation points the caller gives (the truth, in ``bench_consistency.py``), while
the means, the innovations and the new landmarks' positions still come from the
estimates:

* :meth:`IdealEKF.predict` ``(u, at_pose)``: ``x ← g(x, u)``; ``P ← G P Gᵀ + R`` with
  ``G = ∂g/∂pose`` and ``R = J_u N(u) J_uᵀ`` (``J_u = ∂g/∂u``, ``N`` the control noise
  M or Σu) at ``at_pose``, the pose the step starts from;
* :meth:`IdealEKF.update` ``(z, ids, at_pose, at_landmarks)``: the known landmarks
  first, one at a time in the given order, each with ``H`` at ``at_pose`` and its
  landmark's point in ``at_landmarks``, ``ν = wrap(z − h(x))``, gated on its NIS
  ``νᵀS⁻¹ν`` and applied in Joseph form; then the new landmarks, in the given order,
  ``m = h⁻¹(z, pose)`` with ``L``, ``W`` at ``at_pose`` (and the measured z) in the
  augmented covariance ``[[P, P L̃ᵀ], [L̃ P, L P_xx Lᵀ + W Q Wᵀ]]``.

A point left ``None`` is the estimate the standard EKF linearises at there: the pose
before the prediction, the current (corrected so far) pose and landmark of each
correction, the corrected pose of a new landmark. With every point ``None`` the filter
is :class:`slam_env.ekf.EKFSLAM` with known IDs and sequential corrections (the tests
check it). Fed the truth it cannot run on a robot, but its covariance follows the
linearisation of the true system, whose unobservable directions (global translation
and rotation) it keeps.

Dense (3+2n)×(3+2n) matrices throughout, every model equation and Jacobian from
:mod:`slam_env.ekf.models`: a yardstick, not a product.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from slam_env.ekf import CORRECTED, INITIALISED, REJECTED, UpdateResult, checks
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.world.frames import wrap_angle

__all__ = ["IdealEKF"]


class IdealEKF:
    """EKF-SLAM with known IDs, every Jacobian at caller-given points (see the module).

    The keyword arguments are :class:`slam_env.ekf.EKFSLAM`'s of the same names (the
    ones ``bench_consistency.filter_kwargs`` gives); it corrects sequentially. Read the
    belief with ``mean``, ``cov``, ``pose``, ``pose_cov``, ``state_to_id``,
    ``landmark_means()``, ``n_landmarks`` and ``n_rejected``. Bad input raises
    ``ValueError``/``TypeError`` and leaves the filter as it was.
    """

    def __init__(
        self,
        *,
        motion_model: str = "odometry",
        measurement_model: str = "range_bearing",
        alphas: Any = None,
        control_noise: Any = None,
        measurement_cov: Any,
        max_landmarks: int,
        initial_pose: Any = (0.0, 0.0, 0.0),
        initial_pose_cov: Any = None,
        gate: float | None = None,
    ) -> None:
        checks.choice("motion_model", motion_model, tuple(MOTION_MODELS))
        checks.choice("measurement_model", measurement_model, tuple(MEASUREMENT_MODELS))
        name, noise = (
            ("alphas", alphas) if motion_model == "odometry" else ("control_noise", control_noise)
        )
        if noise is None:
            raise ValueError(f"{name} is required for motion_model={motion_model!r}")
        self.motion = MOTION_MODELS[motion_model]
        self.measurement = MEASUREMENT_MODELS[measurement_model]
        self.noise = checks.noise_params(noise, name)
        self.Q = checks.covariance(measurement_cov, "measurement_cov", 2, definite=True)
        self.max_landmarks = int(max_landmarks)
        self.gate = np.inf if gate is None else float(gate)
        self._angular = np.array(self.measurement.angular)
        self._x = checks.float_array(initial_pose, "initial_pose", (3,))
        self._x[2] = wrap_angle(float(self._x[2]))
        cov = np.zeros((3, 3)) if initial_pose_cov is None else initial_pose_cov
        self._P = checks.covariance(cov, "initial_pose_cov", 3, definite=False)
        self._ids: list[int] = []
        self.n_rejected = 0

    # ------------------------------------------------------------------ read access
    @property
    def n_landmarks(self) -> int:
        return len(self._ids)

    @property
    def mean(self) -> np.ndarray:
        """(3+2n,) the state mean (a copy)."""
        return self._x.copy()

    @property
    def cov(self) -> np.ndarray:
        """(3+2n, 3+2n) the state covariance (a copy)."""
        return self._P.copy()

    @property
    def pose(self) -> np.ndarray:
        return self._x[:3].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        return self._P[:3, :3].copy()

    @property
    def state_to_id(self) -> np.ndarray:
        """(n,) int64: the landmark ID of each slot, in the order first seen."""
        return np.array(self._ids, dtype=np.int64)

    def landmark_means(self) -> np.ndarray:
        """(n, 2) the landmark means in state order (a copy)."""
        return self._x[3:].reshape(-1, 2).copy()

    # ------------------------------------------------------------------ predict / update
    def predict(self, u: Any, at_pose: Any = None) -> None:
        """Prediction with control ``u``, its Jacobians at ``at_pose`` (3,) (None: the
        pose estimate before it)."""
        u = checks.float_array(u, "u", (self.motion.control_dim,))
        point = self._x[:3] if at_pose is None else checks.float_array(at_pose, "at_pose", (3,))
        G_x, _ = self.motion.jacobians(point, u)
        G = np.eye(self._x.shape[0])
        G[:3, :3] = G_x
        P = G @ self._P @ G.T
        P[:3, :3] += self.motion.pose_noise(point, u, self.noise)
        self._P = P
        self._x[:3] = self.motion.motion(self._x[:3], u)

    def update(
        self,
        z: Any,
        ids: Any,
        at_pose: Any = None,
        at_landmarks: Mapping[int, Any] | None = None,
    ) -> UpdateResult:
        """Fold in observations ``z: (k, 2)`` of landmarks ``ids: (k,)`` (distinct, in
        [0, max_landmarks)): the known ones corrected, the others added (see the
        module). The Jacobians at ``at_pose`` (3,) and at ``at_landmarks[id]`` (2,) of
        each known landmark; None: the current estimate. A known landmark whose point
        ``h`` cannot be linearised at (range-bearing: on the robot's) is rejected, as
        one that fails the gate. Returns an :class:`~slam_env.ekf.UpdateResult`
        (``nearest`` all NaN)."""
        z, ids = checks.observations(z, ids)
        if (
            not np.isfinite(z).all()
            or ((ids < 0) | (ids >= self.max_landmarks)).any()
            or np.unique(ids).shape[0] < ids.shape[0]
        ):
            raise checks.bad_observations(z, ids, self.max_landmarks)
        if at_pose is not None:
            at_pose = checks.float_array(at_pose, "at_pose", (3,))
        known = [j for j in range(len(ids)) if int(ids[j]) in self._ids]
        points = {}
        if at_landmarks is not None:
            missing = [int(ids[j]) for j in known if int(ids[j]) not in at_landmarks]
            if missing:
                raise ValueError(f"at_landmarks has no point for the landmarks {missing}")
            for j in known:
                points[j] = checks.float_array(at_landmarks[int(ids[j])], "at_landmarks", (2,))
        status = np.empty(len(ids), dtype=np.int8)
        nis = np.full(len(ids), np.nan)
        # On copies, committed at the end: a failure leaves the filter as it was.
        x, P, slots, rejected = self._x.copy(), self._P.copy(), list(self._ids), 0
        h = self.measurement
        for j in known:
            s = 3 + 2 * slots.index(int(ids[j]))
            pose_at = x[:3] if at_pose is None else at_pose
            mark_at = points.get(j, x[s : s + 2])
            if h.singular(pose_at, mark_at):
                status[j], rejected = REJECTED, rejected + 1  # h cannot be linearised
                continue
            H_x, H_m = h.jacobians(pose_at, mark_at)
            H = np.zeros((2, x.shape[0]))
            H[:, :3], H[:, s : s + 2] = H_x, H_m
            nu = z[j] - h.h(x[:3], x[s : s + 2])
            nu[self._angular] = wrap_angle(nu[self._angular])
            S = H @ P @ H.T + self.Q
            nis[j] = nu @ np.linalg.solve(S, nu)
            if nis[j] > self.gate:
                status[j], rejected = REJECTED, rejected + 1
                continue
            K = np.linalg.solve(S, H @ P).T  # P Hᵀ S⁻¹ (S and P symmetric)
            x = x + K @ nu
            x[2] = wrap_angle(float(x[2]))
            I_KH = np.eye(x.shape[0]) - K @ H
            P = I_KH @ P @ I_KH.T + K @ self.Q @ K.T
            status[j] = CORRECTED
        for j in range(len(ids)):
            if int(ids[j]) in self._ids:
                continue
            pose_at = x[:3] if at_pose is None else at_pose
            L, W = h.inverse_jacobians(pose_at, z[j])
            cross = L @ P[:3]
            block = L @ P[:3, :3] @ L.T + W @ self.Q @ W.T
            P = np.block([[P, cross.T], [cross, block]])
            x = np.concatenate([x, h.inverse(x[:3], z[j])])
            slots.append(int(ids[j]))
            status[j] = INITIALISED
        self._x, self._P, self._ids = x, P, slots
        self.n_rejected += rejected
        return UpdateResult(ids, status, nis, np.full(len(ids), np.nan))
