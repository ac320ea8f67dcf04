"""The GTSAM side of :class:`~slam_env.smoothing.isam2.ISAM2SLAM`: its recorded factors
and values made into GTSAM's, and the solvers they go into. This module imports
``gtsam`` at its top; :mod:`slam_env.smoothing.isam2` imports it only once the extra is
known to be installed.

The factors (recorded as arrays, see :class:`GraphBuilder`):

``PRIOR`` on x0: pose (3,), cov (3, 3)
    ``PriorFactorPose2``; ``cov`` is the world-frame covariance (the floor added),
    turned into the pose frame the factor's error is in: ``T⁻¹ cov T⁻ᵀ`` with
    ``T = T(θ0)`` (:func:`slam_env.smoothing.odometry.frame_jacobian`).
``MOTION`` between xa and xb: D (3,), P (3, 3)
    The odometry between two poses (:mod:`slam_env.smoothing.odometry`), one of:

    * ``"reference"``: a ``CustomFactor`` whose error is the batch smoother's,
      ``e = (R(θa)ᵀ(tb − ta) − D_xy, wrap(θb − θa − Dθ))`` whitened by ``P``: the cost
      ``references/smoother.py`` minimises, so a converged graph is its optimum. Its
      Jacobians in GTSAM's right-perturbed tangents are
      ``∂e/∂ξa = [[−1, 0, by], [0, −1, −bx], [0, 0, −1]]`` and
      ``∂e/∂ξb = [[cos Δ, −sin Δ, 0], [sin Δ, cos Δ, 0], [0, 0, 1]]`` with
      ``(bx, by) = R(θa)ᵀ(tb − ta)`` and ``Δ = θb − θa``. A Python callback, called
      where iSAM2 relinearises; GTSAM's binding hands it a copy of the whole
      ``Values``, so a call costs more as the graph grows.
    * ``"between"``: GTSAM's ``BetweenFactorPose2`` with the measured ``Pose2(D)`` and
      covariance ``J P Jᵀ``, ``J = blockdiag(R(Dθ)ᵀ, 1)`` (its error lives in the frame
      of ``xa·D``). Its error is ``Logmap(D⁻¹·xa⁻¹·xb)`` (the 4.3 wheels' Pose2 chart
      is the exponential map), which agrees with the reference error to first order
      only: on a noisy 80–120-step episode its optimum lies 1e-4–5e-4 m from the batch
      smoother's. (Its Jacobians include the Logmap's: exact at any error, as a
      finite-difference check of the 4.3.0 wheel shows.) Compiled, no Python callback.
``MEASURE`` of l from x: z (2,)
    ``"range_bearing"``: ``BearingRangeFactor2D`` with ``Rot2(φ)`` and ``r``; GTSAM
    orders the error (bearing, range), so ``Q`` is permuted to
    ``[[Qφφ, Qφr], [Qrφ, Qrr]]``. Its error, ``(wrap(φ̂ − φ), r̂ − r)``, is the filter's
    innovation negated: the same cost. ``"cartesian"``: ``gtsam_unstable.DeltaFactor``
    (``x.transformTo(l) − z``, GTSAM's factor for a point measured in the robot
    frame: ``z = R(θ)ᵀ(m − t)`` exactly, compiled), or where the build has no
    ``gtsam_unstable`` a ``CustomFactor`` with the same error.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

import gtsam
import numpy as np
import scipy.linalg

from slam_env.smoothing.odometry import frame_jacobian
from slam_env.smoothing.records import FACTOR_SIZES, MEASURE, MOTION, POSE

try:  # the robot-frame point factor; part of the PyPI wheels, not of every build
    from gtsam_unstable import DeltaFactor
except ImportError:  # pragma: no cover - the wheels have it
    DeltaFactor = None

__all__ = ["GraphBuilder", "make_solver"]

_TWO_PI = 2.0 * math.pi


def _wrap(angle: float) -> float:
    """An angle in [−π, π)."""
    return (angle + math.pi) % _TWO_PI - math.pi


def reference_motion_error(
    d0: float, d1: float, d2: float, keys: Any, values: Any, jacobians: Any
) -> np.ndarray:
    """The batch smoother's motion error between poses ``keys`` (see the module's
    docstring) with increment ``(d0, d1, d2)``, and its Jacobians into ``jacobians``
    when asked."""
    a = values.atPose2(keys[0])
    b = values.atPose2(keys[1])
    ta = a.theta()
    c, s = math.cos(ta), math.sin(ta)
    dx, dy = b.x() - a.x(), b.y() - a.y()
    bx, by = c * dx + s * dy, -s * dx + c * dy
    delta = b.theta() - ta
    if jacobians is not None:
        cd, sd = math.cos(delta), math.sin(delta)
        jacobians[0] = np.array([[-1.0, 0.0, by], [0.0, -1.0, -bx], [0.0, 0.0, -1.0]])
        jacobians[1] = np.array([[cd, -sd, 0.0], [sd, cd, 0.0], [0.0, 0.0, 1.0]])
    return np.array([bx - d0, by - d1, _wrap(delta - d2)])


def cartesian_error(z0: float, z1: float, this: Any, values: Any, jacobians: Any) -> np.ndarray:
    """``R(θ)ᵀ(m − t) − z`` and its Jacobians (pose in its own frame, then the point):
    ``[[−1, 0, hy], [0, −1, −hx]]`` and ``R(θ)ᵀ``, h the predicted measurement. The
    stand-in for ``DeltaFactor`` where ``gtsam_unstable`` is missing."""
    keys = this.keys()
    pose = values.atPose2(keys[0])
    m = values.atPoint2(keys[1])
    th = pose.theta()
    c, s = math.cos(th), math.sin(th)
    dx, dy = m[0] - pose.x(), m[1] - pose.y()
    hx, hy = c * dx + s * dy, -s * dx + c * dy
    if jacobians is not None:
        jacobians[0] = np.array([[-1.0, 0.0, hy], [0.0, -1.0, -hx]])
        jacobians[1] = np.array([[c, s], [-s, c]])
    return np.array([hx - z0, hy - z1])


_INDEX = (1 << 56) - 1  # a Symbol key's index bits


class GraphBuilder:
    """Makes recorded updates into GTSAM's factors and values for one estimator's
    models: ``motion_factor`` ("reference" or "between"), ``measurement_model``, Q.

    The "reference" motion factors share one callback, which reads each factor's
    increment from a table by the index of its later pose: no Python object per
    factor (thousands of closures would be thousands of objects for Python's cyclic
    garbage collector to walk, a cost that grows with the graph). An index is written
    once; a fresh builder (a reset) starts a fresh table, so factors still held by a
    copy keep reading theirs."""

    def __init__(self, motion_factor: str, measurement_model: str, Q: np.ndarray) -> None:
        self.motion_factor = motion_factor
        self.range_bearing = measurement_model == "range_bearing"
        if self.range_bearing:  # GTSAM's (bearing, range) order
            Q = np.array([[Q[1, 1], Q[1, 0]], [Q[0, 1], Q[0, 0]]])
        self.measurement_noise = gtsam.noiseModel.Gaussian.Covariance(np.array(Q, dtype=float))
        self._increments = np.zeros((64, 3))

    def _reference_error(self, this: Any, values: Any, jacobians: Any) -> np.ndarray:
        keys = this.keys()
        d = self._increments[keys[1] & _INDEX]
        return reference_motion_error(d[0], d[1], d[2], keys, values, jacobians)

    def _motion(self, xa: int, xb: int, D: np.ndarray, P: np.ndarray) -> Any:
        if self.motion_factor == "reference":
            i = xb & _INDEX
            if i >= self._increments.shape[0]:
                grown = np.zeros((2 * i + 1, 3))
                grown[: self._increments.shape[0]] = self._increments
                self._increments = grown
            self._increments[i] = D
            noise = gtsam.noiseModel.Gaussian.Covariance(P)
            return gtsam.CustomFactor(noise, [xa, xb], self._reference_error)
        J = frame_jacobian(-float(D[2]))  # blockdiag(R(Dθ)ᵀ, 1)
        noise = gtsam.noiseModel.Gaussian.Covariance(J @ P @ J.T)
        return gtsam.BetweenFactorPose2(xa, xb, gtsam.Pose2(*map(float, D)), noise)

    def _measurement(self, x: int, lm: int, z: np.ndarray) -> Any:
        if self.range_bearing:
            return gtsam.BearingRangeFactor2D(
                x, lm, gtsam.Rot2(float(z[1])), float(z[0]), self.measurement_noise
            )
        if DeltaFactor is not None:
            return DeltaFactor(x, lm, np.array(z, dtype=float), self.measurement_noise)
        error = partial(cartesian_error, float(z[0]), float(z[1]))
        return gtsam.CustomFactor(self.measurement_noise, [x, lm], error)

    def graph(self, kinds: np.ndarray, keys: np.ndarray, data: np.ndarray) -> Any:
        """A ``NonlinearFactorGraph`` of recorded factors: ``kinds (m,)``, ``keys
        (m, 2)`` (the prior's second unused) and their payloads one after another in
        ``data`` (see :mod:`slam_env.smoothing.records`)."""
        graph = gtsam.NonlinearFactorGraph()
        at = 0
        for kind, (a, b) in zip(kinds.tolist(), keys.tolist(), strict=True):
            size = FACTOR_SIZES[kind]
            payload = data[at : at + size]
            at += size
            if kind == MEASURE:
                graph.add(self._measurement(a, b, payload))
            elif kind == MOTION:
                graph.add(self._motion(a, b, payload[:3], payload[3:].reshape(3, 3)))
            else:  # PRIOR: the world-frame cov turned into the pose frame
                pose, cov = payload[:3], payload[3:].reshape(3, 3)
                Ti = frame_jacobian(-float(pose[2]))  # T(θ0)⁻¹
                noise = gtsam.noiseModel.Gaussian.Covariance(Ti @ cov @ Ti.T)
                graph.add(gtsam.PriorFactorPose2(a, gtsam.Pose2(*map(float, pose)), noise))
        return graph

    @staticmethod
    def values(kinds: np.ndarray, keys: np.ndarray, data: np.ndarray) -> Any:
        """``Values`` of recorded values: ``kinds (m,)`` (POSE, POINT), ``keys (m,)``,
        the numbers one after another in ``data``."""
        values = gtsam.Values()
        at = 0
        for kind, key in zip(kinds.tolist(), keys.tolist(), strict=True):
            if kind == POSE:
                x, y, th = data[at : at + 3].tolist()
                values.insert(key, gtsam.Pose2(x, y, th))
                at += 3
            else:
                values.insert(key, data[at : at + 2].copy())
                at += 2
        return values


def isam2_params(relinearize_threshold: float, relinearize_skip: int) -> Any:
    """``ISAM2Params`` with the estimator's relinearisation options, QR
    factorisation and the partial relinearisation check (GTSAM's defaults otherwise:
    Gauss–Newton steps, wildfire threshold 0.001, the linearised factors cached).

    The partial check looks for variables to relinearise from the root down, stopping
    at cliques that need none, instead of walking every variable's step: one of the
    costs of an update that grow with the trajectory.

    Not GTSAM's default Cholesky: the motion floor makes the information of a step
    1e8 in the directions the model has no noise in (sideways on a turn on the spot),
    and on the env's episodes Cholesky of the squared system then meets a frontal
    block that is not positive definite in float64 (``IndeterminantLinearSystem``
    near the pose before such a turn, where QR of the whitened Jacobian goes through).
    """
    params = gtsam.ISAM2Params()
    params.setFactorization("QR")
    params.enablePartialRelinearizationCheck = True
    params.setRelinearizeThreshold(relinearize_threshold)
    params.relinearizeSkip = relinearize_skip
    return params


def make_solver(relinearize_threshold: float, relinearize_skip: int, window: int | None) -> Any:
    """A fresh ``ISAM2``, or with a window of N poses an ``IncrementalFixedLagSmoother``
    whose lag keeps the N latest (timestamps are pose indices; a key older than the
    lag is marginalised: ``findKeysBefore(now − lag)`` takes the keys strictly before)."""
    params = isam2_params(relinearize_threshold, relinearize_skip)
    if window is None:
        return gtsam.ISAM2(params)
    return gtsam.IncrementalFixedLagSmoother(window - 0.5, params)


def joint_marginal(isam: Any, keys: list[int], dims: list[int]) -> np.ndarray:
    """The joint marginal covariance of ``keys`` (of tangent dimensions ``dims``) in
    that order, from iSAM2's Bayes tree: its joint Bayes net over them, a square-root
    information factor R (columns in the net's order), Σ = R⁻¹R⁻ᵀ. It equals
    ``jointMarginalCovariance`` (to ~1e-12 relative) at about half its cost, which
    turns the net into a factor graph and eliminates it again."""
    net = isam.jointBayesNet(keys)
    R, _ = net.matrix()
    dim_of = dict(zip(keys, dims, strict=True))
    start, at = {}, 0
    for i in range(net.size()):
        key = net.at(i).firstFrontalKey()
        start[key] = at
        at += dim_of[key]
    if at != R.shape[0] or len(start) != len(keys):  # a conditional of several keys
        return np.asarray(isam.jointMarginalCovariance(keys).fullMatrix())
    rows = np.concatenate([np.arange(start[k], start[k] + dim_of[k]) for k in keys])
    inverse = scipy.linalg.solve_triangular(R, np.eye(at))
    return (inverse @ inverse.T)[np.ix_(rows, rows)]


def copy_isam2(solver: Any) -> Any:
    """A deep copy of an ``ISAM2`` (its copy constructor)."""
    return gtsam.ISAM2(solver)


def optimized(graph: Any, values: Any, tolerance: float, max_iterations: int) -> Any:
    """Levenberg–Marquardt on the whole graph from ``values`` to convergence: the
    batch optimum (relative and absolute error decrease below ``tolerance``)."""
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(tolerance)
    params.setAbsoluteErrorTol(tolerance)
    params.setMaxIterations(max_iterations)
    return gtsam.LevenbergMarquardtOptimizer(graph, values, params).optimize()
