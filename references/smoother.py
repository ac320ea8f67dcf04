"""The batch least-squares SLAM solution (full smoothing) with known correspondences:
the optimum an EKF-SLAM filter is measured against in ``bench_consistency.py``.

Unknowns: every pose ``x_1 … x_T`` and every landmark seen, stacked as
``v = [x_1, …, x_T, m_0, …, m_(L−1)]`` (``3T + 2L``). ``x_0`` is the filter's prior,
the true start pose with zero covariance, so it is held fixed (it also fixes the
gauge). The cost is ``½‖r(v)‖²`` with the residuals whitened by the noise models the
filter uses (:mod:`slam_env.kernels.base.models`):

* a *motion factor* per step t, between ``x_(t−1)`` and ``x_t``: the pose change
  expressed in the frame of ``x_(t−1)`` minus the change the control predicts,
  ``e = [R(θ_(t−1))ᵀ(t_t − t_(t−1)) − d_xy, wrap(θ_t − θ_(t−1) − d_θ)]`` with
  ``d = g(0, u_t)``, whitened by ``R_t = V M(u_t) Vᵀ`` (``B Σu Bᵀ`` for the velocity
  model) evaluated at heading 0. This is the filter's ``R_x`` rotated into the frame of
  ``x_(t−1)``, so ``eᵀR_t⁻¹e`` equals the world-frame form with ``R_x`` at ``θ_(t−1)``,
  and the whitening does not depend on the unknowns. ``R_t`` is singular where the
  model has no noise in some direction (a turn on the spot has no sideways noise, a
  stop none at all), so ``MOTION_FLOOR`` is added to its diagonal;
* a *measurement factor* per detection: ``wrap(z − h(x_t, m_j))`` (the model's own
  innovation), whitened by ``Q``.

:func:`smooth` solves it on the analytic sparse Jacobian, by default with
Levenberg–Marquardt steps solved directly (``scipy.sparse.linalg.splu`` on the sparse
normal equations, ``solver="sparse_lm"``), or with ``scipy.optimize.least_squares``
(trust-region reflective, LSMR steps, ``solver="trf"``). Both reach the same minimum
(the test checks it); on a 500-step episode of the default world started from the
EKF, "trf" took 43 s and "sparse_lm" 0.4–0.9 s (LSMR needs thousands of iterations
per step on the stiff motion factors), so the benchmark uses "sparse_lm" and "trf"
stays as the check. Initialisation: dead reckoning
from the controls and each landmark from its first sighting (:func:`dead_reckoning`,
:func:`first_sightings`), or any estimate the caller gives (the EKF's filtered
trajectory and final map in the benchmark).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.optimize
import scipy.sparse
import scipy.sparse.linalg

from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.kernels.base import models as km
from slam_env.world.frames import wrap_angle

__all__ = [
    "MOTION_FLOOR",
    "SOLVERS",
    "Episode",
    "SmootherProblem",
    "SmootherResult",
    "dead_reckoning",
    "first_sightings",
    "smooth",
]

# Variance (m², rad²) added to the diagonal of every motion factor's covariance: where
# the model has no noise (the sideways direction of a turn on the spot, a stop) the
# factor would be a hard constraint. 1e-8 is a 0.1 mm (0.1 mrad) standard deviation,
# far below a moving step's noise (the env's odometry reading also drops sideways
# motions under 1 mm, see slam_env.kernels.stream.odometry.MIN_ODOMETRY_TRANSLATION).
MOTION_FLOOR = 1e-8
# LSMR's atol/btol inside each trust-region step.
LSMR_TOLERANCE = 1e-14


@dataclass(frozen=True)
class Episode:
    """One episode's data as the filter and the smoother read it.

    ``start_pose: (3,)`` the known ``x_0``; ``controls: (T, c)`` the odometry readings
    (c = 3 for "odometry", 2 for "velocity"); the detections, flattened over steps:
    ``steps: (K,) int64`` the step t ∈ [1, T] of each (taken at pose ``x_t``, after
    control t), ``ids: (K,) int64`` its landmark ID, ``z: (K, 2)`` the measurement.
    ``motion_model``/``measurement_model`` name the models, ``motion_params`` their
    noise (α1..α4, or σp, σθ, βp, βθ) and ``measurement_cov`` Q (2×2).
    """

    start_pose: np.ndarray
    controls: np.ndarray
    steps: np.ndarray
    ids: np.ndarray
    z: np.ndarray
    motion_model: str = "odometry"
    motion_params: tuple[float, float, float, float] = (0.005, 0.002, 0.01, 0.001)
    measurement_model: str = "range_bearing"
    measurement_cov: np.ndarray | None = None

    @property
    def n_steps(self) -> int:
        return int(self.controls.shape[0])

    def detections_at(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        """``(z (k, 2), ids (k,))`` taken at step t, in the order recorded."""
        lo, hi = np.searchsorted(self.steps, [t, t + 1])
        return self.z[lo:hi], self.ids[lo:hi]


def _control3(u: np.ndarray) -> tuple[float, float, float]:
    """A control as the three floats :func:`km.motion_predict` takes (u2 = 0 for the
    two-entry velocity control)."""
    return float(u[0]), float(u[1]), float(u[2]) if u.shape[0] > 2 else 0.0


def _motion_code(episode: Episode) -> int:
    return MOTION_MODELS[episode.motion_model].code


def dead_reckoning(episode: Episode) -> np.ndarray:
    """(T+1, 3) the poses the controls alone give from ``start_pose``."""
    code = _motion_code(episode)
    params = tuple(map(float, episode.motion_params))
    poses = np.empty((episode.n_steps + 1, 3))
    poses[0] = episode.start_pose
    for t, u in enumerate(episode.controls, start=1):
        x, y, th = poses[t - 1]
        poses[t] = km.motion_predict(code, x, y, th, *_control3(u), *params)[:3]
    return poses


def first_sightings(episode: Episode, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(ids (L,), landmarks (L, 2))``: every landmark seen, in order of ID, placed by
    the inverse model from its first detection at ``poses[t]``."""
    code = MEASUREMENT_MODELS[episode.measurement_model].code
    ids, first = np.unique(episode.ids, return_index=True)
    marks = np.empty((ids.shape[0], 2))
    for i, k in enumerate(first):
        x, y, th = poses[episode.steps[k]]
        marks[i] = km.inverse(code, x, y, th, *map(float, episode.z[k]))
    return ids, marks


def _whitener(cov: np.ndarray) -> np.ndarray:
    """W with Wᵀ W = cov⁻¹ (the inverse of cov's Cholesky factor): ‖W e‖² = eᵀ cov⁻¹ e."""
    return np.linalg.inv(np.linalg.cholesky(cov))


class SmootherProblem:
    """The whitened residuals ``r(v)`` and their sparse Jacobian for one episode.

    ``landmark_ids: (L,)`` the landmarks in ``v``, in order (every ID in the episode).
    Residual rows: ``3T`` motion rows (step t at rows 3(t−1)…3t−1), then 2 rows per
    detection in the episode's order. Variable columns: pose t ≥ 1 at 3(t−1)…3t−1,
    landmark i at 3T + 2i, 3T + 2i + 1.
    """

    def __init__(self, episode: Episode) -> None:
        if episode.measurement_cov is None:
            raise ValueError("the episode needs its measurement_cov Q to be whitened")
        self.episode = episode
        T = self.n_steps = episode.n_steps
        code = _motion_code(episode)
        params = tuple(map(float, episode.motion_params))
        # Each step's predicted change d = g(0, u) and its covariance, in the frame of
        # the pose before it (heading 0), and the whitener of that covariance.
        self._delta = np.empty((T, 3))
        self._motion_w = np.empty((T, 3, 3))
        for t, u in enumerate(episode.controls):
            out = km.motion_predict(code, 0.0, 0.0, 0.0, *_control3(u), *params)
            r00, r01, r02, r11, r12, r22 = out[5:]
            cov = np.array([[r00, r01, r02], [r01, r11, r12], [r02, r12, r22]])
            self._delta[t] = out[:3]
            self._motion_w[t] = _whitener(cov + MOTION_FLOOR * np.eye(3))
        self._meas_code = MEASUREMENT_MODELS[episode.measurement_model].code
        self._meas_w = _whitener(np.asarray(episode.measurement_cov, dtype=np.float64))
        self.landmark_ids, slots = np.unique(episode.ids, return_inverse=True)
        self._slots = slots.astype(np.int64)
        self._steps = episode.steps.astype(np.int64)
        self._z = np.asarray(episode.z, dtype=np.float64)
        K = self.n_detections = int(self._steps.shape[0])
        self.n_variables = 3 * T + 2 * self.landmark_ids.shape[0]
        self.n_residuals = 3 * T + 2 * K
        self._rows, self._cols = self._structure()

    # ------------------------------------------------------------------ layout
    def _structure(self) -> tuple[np.ndarray, np.ndarray]:
        """The (row, column) of every Jacobian entry, in the order :meth:`jacobian`
        writes its values: the motion blocks (3×6 per step: x_(t−1), then x_t), then
        the measurement blocks (2×5 per detection: x_t, then m_j). Entries in the
        columns of the fixed x_0 are kept (their values are dropped)."""
        T = self.n_steps
        t = np.arange(T)
        rows = 3 * t[:, None, None] + np.arange(3)[None, :, None]  # (T, 3, 1)
        prev = 3 * (t - 1)[:, None] + np.arange(3)  # (T, 3): −3.. for x_0
        cur = 3 * t[:, None] + np.arange(3)
        cols = np.concatenate([prev, cur], axis=1)[:, None, :]  # (T, 1, 6)
        m_rows, m_cols = np.broadcast_arrays(rows, cols)
        k = np.arange(self.n_detections)
        rows = 3 * T + 2 * k[:, None, None] + np.arange(2)[None, :, None]  # (K, 2, 1)
        pose = 3 * (self._steps - 1)[:, None] + np.arange(3)
        mark = 3 * T + 2 * self._slots[:, None] + np.arange(2)
        cols = np.concatenate([pose, mark], axis=1)[:, None, :]  # (K, 1, 5)
        z_rows, z_cols = np.broadcast_arrays(rows, cols)
        return (
            np.concatenate([m_rows.ravel(), z_rows.ravel()]),
            np.concatenate([m_cols.ravel(), z_cols.ravel()]),
        )

    def pack(self, poses: np.ndarray, landmarks: np.ndarray) -> np.ndarray:
        """v from ``poses: (T+1, 3)`` (row 0, x_0, is not an unknown) and
        ``landmarks: (L, 2)`` in the order of ``landmark_ids``."""
        return np.concatenate([np.asarray(poses)[1:].ravel(), np.asarray(landmarks).ravel()])

    def unpack(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(poses (T+1, 3) with x_0 first and headings wrapped, landmarks (L, 2))``."""
        T = self.n_steps
        poses = np.empty((T + 1, 3))
        poses[0] = self.episode.start_pose
        poses[1:] = v[: 3 * T].reshape(T, 3)
        poses[:, 2] = wrap_angle(poses[:, 2])
        return poses, v[3 * T :].reshape(-1, 2).copy()

    def _poses(self, v: np.ndarray) -> np.ndarray:
        """(T+1, 3) x_0 … x_T from v (headings as they are in v)."""
        start = np.asarray(self.episode.start_pose, dtype=np.float64)[None]
        return np.concatenate([start, v[: 3 * self.n_steps].reshape(-1, 3)])

    # ------------------------------------------------------------------ residuals
    def _motion_errors(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(e (T, 3), the step's displacement (T, 2) in the world, cos/sin (T, 2) of
        the heading before it)."""
        prev, cur = poses[:-1], poses[1:]
        c, s = np.cos(prev[:, 2]), np.sin(prev[:, 2])
        dx, dy = cur[:, 0] - prev[:, 0], cur[:, 1] - prev[:, 1]
        e = np.empty((self.n_steps, 3))
        e[:, 0] = c * dx + s * dy - self._delta[:, 0]
        e[:, 1] = -s * dx + c * dy - self._delta[:, 1]
        e[:, 2] = wrap_angle(cur[:, 2] - prev[:, 2] - self._delta[:, 2])
        return e, np.stack([dx, dy], axis=1), np.stack([c, s], axis=1)

    def _measurement_terms(
        self, poses: np.ndarray, landmarks: np.ndarray, with_jacobian: bool
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """(ν (K, 2), [H_x | H_m] (K, 2, 5) or None) of every detection."""
        code = self._meas_code
        nu = np.empty((self.n_detections, 2))
        H = np.empty((self.n_detections, 2, 5)) if with_jacobian else None
        for k, (t, j) in enumerate(zip(self._steps.tolist(), self._slots.tolist(), strict=True)):
            x, y, th = poses[t]
            mx, my = landmarks[j]
            zh0, zh1 = km.observe(code, x, y, th, mx, my)
            nu[k] = km.innovation(code, self._z[k, 0], self._z[k, 1], zh0, zh1)
            if H is not None:
                H[k] = np.reshape(km.jacobian(code, x, y, th, mx, my), (2, 5))
        return nu, H

    def residuals(self, v: np.ndarray) -> np.ndarray:
        """r(v): (3T + 2K,) the whitened motion and measurement errors."""
        poses = self._poses(v)
        landmarks = v[3 * self.n_steps :].reshape(-1, 2)
        e, _, _ = self._motion_errors(poses)
        nu, _ = self._measurement_terms(poses, landmarks, with_jacobian=False)
        return np.concatenate(
            [np.einsum("tij,tj->ti", self._motion_w, e).ravel(), (nu @ self._meas_w.T).ravel()]
        )

    def cost(self, v: np.ndarray) -> float:
        """½‖r(v)‖², the cost ``least_squares`` minimises."""
        r = self.residuals(v)
        return 0.5 * float(r @ r)

    def jacobian(self, v: np.ndarray) -> scipy.sparse.csr_matrix:
        """∂r/∂v, sparse (3T + 2K, 3T + 2L)."""
        T = self.n_steps
        poses = self._poses(v)
        landmarks = v[3 * T :].reshape(-1, 2)
        _, d, cs = self._motion_errors(poses)
        c, s = cs[:, 0], cs[:, 1]
        # ∂e/∂x_(t−1) = [[−c, −s, −s·dx + c·dy], [s, −c, −c·dx − s·dy], [0, 0, −1]],
        # ∂e/∂x_t = [[c, s, 0], [−s, c, 0], [0, 0, 1]] (e in the frame of x_(t−1)).
        J = np.zeros((T, 3, 6))
        J[:, 0, 0], J[:, 0, 1] = -c, -s
        J[:, 1, 0], J[:, 1, 1] = s, -c
        J[:, 0, 2] = -s * d[:, 0] + c * d[:, 1]
        J[:, 1, 2] = -c * d[:, 0] - s * d[:, 1]
        J[:, 2, 2] = -1.0
        J[:, 0, 3], J[:, 0, 4] = c, s
        J[:, 1, 3], J[:, 1, 4] = -s, c
        J[:, 2, 5] = 1.0
        J = np.einsum("tij,tjk->tik", self._motion_w, J)
        J[0, :, :3] = 0.0  # x_0 is fixed
        _, H = self._measurement_terms(poses, landmarks, with_jacobian=True)
        Hw = -np.einsum("ij,kjl->kil", self._meas_w, H)  # r = W ν, ν = z − h
        values = np.concatenate([J.ravel(), Hw.ravel()])
        keep = self._cols >= 0
        return scipy.sparse.csr_matrix(
            (values[keep], (self._rows[keep], self._cols[keep])),
            shape=(self.n_residuals, self.n_variables),
        )


@dataclass(frozen=True)
class SmootherResult:
    """What :func:`smooth` found: ``poses (T+1, 3)`` (x_0 the given start),
    ``landmark_ids (L,)`` and ``landmarks (L, 2)`` in ID order, the final ``cost``
    ½‖r‖², ``optimality`` (‖∇cost‖∞ at the end), ``initial_cost``, ``nfev``,
    ``success``, the solver's ``message`` and ``redundancy``, the residuals less the
    unknowns (2·cost is about χ² with that many dof when the noise models hold)."""

    poses: np.ndarray
    landmark_ids: np.ndarray
    landmarks: np.ndarray
    cost: float
    initial_cost: float
    optimality: float
    nfev: int
    success: bool
    message: str
    redundancy: int


SOLVERS = ("sparse_lm", "trf")


def _scipy_trf(problem: SmootherProblem, v0: np.ndarray, tolerance: float, max_nfev: int) -> Any:
    """``scipy.optimize.least_squares``, trust-region reflective with LSMR steps on the
    sparse Jacobian: x, cost, optimality, nfev, success, message."""
    return scipy.optimize.least_squares(
        problem.residuals,
        v0,
        jac=problem.jacobian,
        method="trf",
        tr_solver="lsmr",
        # With LSMR's default tolerances the steps are too rough to converge on the
        # stiff motion factors (the floor's directions).
        tr_options={"atol": LSMR_TOLERANCE, "btol": LSMR_TOLERANCE},
        ftol=tolerance,
        xtol=tolerance,
        gtol=tolerance,
        max_nfev=max_nfev,
    )


def _sparse_lm(
    problem: SmootherProblem, v0: np.ndarray, tolerance: float, max_nfev: int
) -> scipy.optimize.OptimizeResult:
    """Levenberg–Marquardt with a sparse direct solve of each step
    ``(JᵀJ + λ·diag(JᵀJ)) δ = −Jᵀr`` (SuperLU, :func:`scipy.sparse.linalg.splu`): the
    normal equations of this problem are banded along the trajectory plus the
    landmark columns, which a direct factorisation takes in milliseconds where LSMR
    needs thousands of iterations (the stiff motion factors make JᵀJ ill-conditioned).
    Stops when the largest gradient entry, or the step, or the relative decrease of
    the cost falls below ``tolerance`` (as scipy's gtol, xtol, ftol). Returns what
    ``least_squares`` returns (the fields :func:`smooth` reads)."""
    v = v0.copy()
    r = problem.residuals(v)
    cost = 0.5 * float(r @ r)
    damping, nfev, message, success = 1e-4, 1, "the maximum number of evaluations", False
    while nfev < max_nfev:
        J = problem.jacobian(v)
        gradient = J.T @ r
        if np.max(np.abs(gradient), initial=0.0) < tolerance:
            message, success = "the gradient vanishes (gtol)", True
            break
        normal = (J.T @ J).tocsc()
        diagonal = scipy.sparse.diags(np.maximum(normal.diagonal(), 1e-12))
        while nfev < max_nfev:
            step = scipy.sparse.linalg.splu((normal + damping * diagonal).tocsc()).solve(-gradient)
            trial = v + step
            r_trial = problem.residuals(trial)
            nfev += 1
            trial_cost = 0.5 * float(r_trial @ r_trial)
            if trial_cost <= cost:
                break
            damping *= 10.0
        else:
            break
        decrease = cost - trial_cost
        v, r, cost = trial, r_trial, trial_cost
        damping = max(damping / 10.0, 1e-12)
        if np.linalg.norm(step) < tolerance * (tolerance + np.linalg.norm(v)):
            message, success = "the step vanishes (xtol)", True
            break
        if decrease <= tolerance * cost:
            message, success = "the cost stopped decreasing (ftol)", True
            break
    J = problem.jacobian(v)
    return scipy.optimize.OptimizeResult(
        x=v,
        cost=cost,
        optimality=float(np.max(np.abs(J.T @ r), initial=0.0)),
        nfev=nfev,
        success=success,
        message=message,
    )


def smooth(
    episode: Episode,
    initial_poses: np.ndarray | None = None,
    initial_landmarks: dict[int, np.ndarray] | None = None,
    *,
    solver: str = "sparse_lm",
    tolerance: float = 1e-10,
    max_nfev: int = 200,
) -> SmootherResult:
    """The batch least-squares solution of ``episode``.

    ``initial_poses: (T+1, 3)`` and ``initial_landmarks`` (landmark ID → (2,)) start
    the solver; by default dead reckoning, and each landmark missing from
    ``initial_landmarks`` is placed from its first sighting at the initial poses.
    ``solver``: ``"sparse_lm"`` (:func:`_sparse_lm`, the default: on a 500-step episode
    of the default world about 100× faster than ``"trf"`` and at the same minimum) or
    ``"trf"`` (``scipy.optimize.least_squares``, LSMR steps). ``tolerance`` is the
    gtol/xtol/ftol of either, ``max_nfev`` their budget of residual evaluations.
    """
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    problem = SmootherProblem(episode)
    poses = dead_reckoning(episode) if initial_poses is None else np.asarray(initial_poses, float)
    if poses.shape != (episode.n_steps + 1, 3):
        raise ValueError(f"initial_poses must be ({episode.n_steps + 1}, 3), got {poses.shape}")
    ids, marks = first_sightings(episode, poses)
    for i, lid in enumerate(ids.tolist()):
        if initial_landmarks is not None and lid in initial_landmarks:
            marks[i] = initial_landmarks[lid]
    v0 = problem.pack(poses, marks)
    fit = (_sparse_lm if solver == "sparse_lm" else _scipy_trf)(problem, v0, tolerance, max_nfev)
    out_poses, out_marks = problem.unpack(fit.x)
    return SmootherResult(
        poses=out_poses,
        landmark_ids=problem.landmark_ids.copy(),
        landmarks=out_marks,
        cost=float(fit.cost),
        initial_cost=problem.cost(v0),
        optimality=float(fit.optimality),
        nfev=int(fit.nfev),
        success=bool(fit.success),
        message=str(fit.message),
        redundancy=problem.n_residuals - problem.n_variables,
    )
