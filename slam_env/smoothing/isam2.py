"""iSAM2 SLAM: the smoothing belief beside the filter, with the shape of
:class:`~slam_env.ekf.filter.EKFSLAM`'s API (known correspondences). The graph (a
prior on the start, a motion factor between consecutive pose variables, a factor per
detection), the keyframes and window, what ``cov`` is and how it differs from the
filter's, what an update costs and why it grows: ``docs/smoothing.md``.

Inputs are checked before anything changes; every iSAM2 update since the reset is
recorded (:mod:`slam_env.smoothing.records`), so a failed GTSAM update, a pickle and a
windowed copy replay it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from slam_env.ekf import checks
from slam_env.ekf.configuration import checked_config
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.ekf.results import Status, UpdateResult
from slam_env.extras import require
from slam_env.kernels.base import models as km
from slam_env.kernels.base.models import wrap_angle
from slam_env.smoothing.keyframes import Keyframes, keyframes_of
from slam_env.smoothing.odometry import (
    PRIOR_FLOOR,
    compose,
    compose_pose,
    frame_jacobian,
    propagate,
)
from slam_env.smoothing.records import MEASURE, MOTION, POINT, POSE, PRIOR, update_op

__all__ = [
    "ISAM2SLAM",
    "MOTION_FACTORS",
    "Keyframes",
    "landmark_key",
    "pose_key",
]

MOTION_FACTORS = ("reference", "between")
_INT8 = np.dtype(np.int8)
_CORRECTED, _INITIALISED = int(Status.CORRECTED), int(Status.INITIALISED)
_REJECTED, _DISCARDED = int(Status.REJECTED), int(Status.DISCARDED)

# GTSAM's Symbol keys: the character in the top 8 bits, the index below
# (gtsam.symbol("x", i) == pose_key(i)).
_X, _L = ord("x") << 56, ord("l") << 56


def pose_key(i: int) -> int:
    """The GTSAM key of pose variable i (``gtsam.symbol("x", i)``)."""
    return _X | i


def landmark_key(landmark_id: int) -> int:
    """The GTSAM key of the landmark with this ID (``gtsam.symbol("l", id)``)."""
    return _L | landmark_id


def _positive_int(value: Any, name: str, allow_none: bool = False) -> int | None:
    if value is None and allow_none:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {value}")
    return int(value)


class ISAM2SLAM:
    """SLAM by incremental smoothing (iSAM2, GTSAM) with known correspondences.

    ``ISAM2SLAM(*, motion_model="odometry", measurement_model="range_bearing",
    alphas=None, control_noise=None, measurement_cov, max_landmarks,
    initial_pose=(0, 0, 0), initial_pose_cov=zeros((3, 3)), motion_factor="between",
    relinearize_threshold=0.02, relinearize_skip=1, keyframes=None, window=None)``

    Arguments (keyword only)
        motion_model, measurement_model, alphas, control_noise, measurement_cov,
        max_landmarks, initial_pose, initial_pose_cov: as
        :class:`~slam_env.ekf.filter.EKFSLAM`'s (the same checks and messages).
        motion_factor: ``"between"`` (GTSAM's ``BetweenFactorPose2``, compiled; its
            optimum agrees with the batch smoother's to first order, ~0.3 mm apart on
            the test episodes) or ``"reference"`` (the batch smoother's own motion
            error, so that :meth:`optimize` reaches ``references.smoother.smooth``'s
            optimum; a Python callback, 2–3× slower). See :mod:`slam_env.smoothing.graph`.
        relinearize_threshold: a variable whose linear step exceeds this (in its
            tangent: m, rad) is relinearised; relinearize_skip: checked every that
            many updates (GTSAM's defaults are 0.1 and 10; 0.02 and 1 keep the map
            within 0.3% of the batch optimum's RMSE on the benchmark's episodes, 0.1
            within 5%).
        keyframes: ``None`` (a pose variable per step), an int k (every k steps) or a
            :class:`Keyframes`.
        window: ``None`` (keep every pose) or N ≥ 1 (marginalise all but the N
            latest pose variables).

    Use
        ``predict(u)``, ``update(z, ids) -> UpdateResult`` (known IDs: each
        observation ``CORRECTED``, ``INITIALISED`` (a new landmark), ``REJECTED``
        (range-bearing with the landmark on the robot) or ``DISCARDED`` (a step that
        is no keyframe); ``nis`` and ``nearest`` are NaN: the smoother computes no
        innovation covariance); ``optimize()`` (the full update); read the belief with
        ``mean``/``cov``, ``pose``/``pose_cov``, ``landmark(id)``, ``landmark_means()``,
        ``state_to_id``/``id_to_state``, ``trajectory()``. Reads return fresh copies.
        ``reset(initial_pose=None, initial_pose_cov=None)``, ``copy()``, pickling.
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
        motion_factor: str = "between",
        relinearize_threshold: float = 0.02,
        relinearize_skip: int = 1,
        keyframes: Any = None,
        window: int | None = None,
    ) -> None:
        config = checked_config(
            motion_model=motion_model,
            measurement_model=measurement_model,
            alphas=alphas,
            control_noise=control_noise,
            measurement_cov=measurement_cov,
            max_landmarks=max_landmarks,
            gate=None,
            correction="sequential",
            data_association="known",
            linearization="standard",
            match_gate=None,
            new_landmark_gate=None,
            new_landmark_sightings=1,
            wide_pairing_scans=1,
        )
        checks.choice("motion_factor", motion_factor, MOTION_FACTORS)
        threshold = checks.number(relinearize_threshold, "relinearize_threshold")
        if threshold < 0.0:
            raise ValueError(f"relinearize_threshold must be >= 0, got {threshold}")
        skip = _positive_int(relinearize_skip, "relinearize_skip")
        frames = keyframes_of(keyframes)
        window = _positive_int(window, "window", allow_none=True)
        pose0, cov0 = self._check_prior(initial_pose, initial_pose_cov)
        require("gtsam", "ISAM2SLAM")

        self._config = config
        self._options = (motion_factor, threshold, skip, frames, window)
        self._initial_pose = pose0
        self._initial_pose_cov = cov0
        self._setup()
        self._start(pose0, cov0)

    # ------------------------------------------------------------------ setup
    def _setup(self) -> None:
        """The derived attributes: the models' codes, the GTSAM factor maker and a
        fresh solver (rebuilt after unpickling, never pickled)."""
        from slam_env.smoothing import graph  # gtsam, now known to be there

        c = self._config
        motion_factor, threshold, skip, _, window = self._options
        self._graph = graph
        self._N = c.max_landmarks
        self._motion_code = MOTION_MODELS[c.motion_model].code
        self._meas_code = MEASUREMENT_MODELS[c.measurement_model].code
        self._control_dim = MOTION_MODELS[c.motion_model].control_dim
        noise = c.alphas if c.motion_model == "odometry" else c.control_noise
        self._noise = tuple(map(float, noise))
        self._builder = graph.GraphBuilder(motion_factor, c.measurement_model, c.measurement_cov)
        self._solver = graph.make_solver(threshold, skip, window)
        self._stale()

    def _stale(self) -> None:
        """Forget the cached reads (the estimate changed)."""
        self._est: tuple[np.ndarray, np.ndarray] | None = None
        self._joint: np.ndarray | None = None

    @staticmethod
    def _check_prior(pose: Any, cov: Any) -> tuple[np.ndarray, np.ndarray]:
        pose = checks.float_array(pose, "initial_pose", (3,))
        pose[2] = wrap_angle(float(pose[2]))
        cov = np.zeros((3, 3)) if cov is None else cov
        return pose, checks.covariance(cov, "initial_pose_cov", 3, definite=False)

    def _start(self, pose: np.ndarray, cov: np.ndarray) -> None:
        """An empty map at the prior (the solver fresh)."""
        self._ops: list[tuple] = []
        self._id_to_slot = np.full(self._N, -1, dtype=np.int64)
        self._slot_to_id = np.full(self._N, -1, dtype=np.int64)
        self._n = 0
        self._n_poses = 1  # pose variables made since the reset (x_0 … x_(n_poses−1))
        self._pose_steps = [0]  # the step (predictions since the reset) of each
        self._t = 0
        self._increment = (0.0, 0.0, 0.0)  # the odometry since the latest pose variable
        self._increment_cov = np.zeros((3, 3))
        self._steps = 0  # predictions since the latest pose variable
        self._n_rejected = 0
        self._n_discarded = 0
        key = pose_key(0)
        prior = np.concatenate([pose, (cov + PRIOR_FLOOR * np.eye(3)).ravel()])
        self._commit(update_op([PRIOR], [(key, 0)], [prior], [POSE], [key], [pose], (key,), 0.0))

    def reset(self, initial_pose: Any = None, initial_pose_cov: Any = None) -> None:
        """Start a new episode with no landmarks and a fresh graph. ``None`` takes the
        value given to the constructor; the counters restart at 0."""
        pose = self._initial_pose if initial_pose is None else initial_pose
        cov = self._initial_pose_cov if initial_pose_cov is None else initial_pose_cov
        pose, cov = self._check_prior(pose, cov)
        self._setup()  # a fresh solver, and a fresh builder (copies keep theirs)
        self._start(pose, cov)

    # ------------------------------------------------------------------ the solver
    def _apply(self, op: tuple) -> None:
        """Run one recorded operation on the solver."""
        if op[0] == "update":
            _, fkinds, fkeys, fdata, vkinds, vkeys, vdata, stamped, now = op
            graph = self._builder.graph(fkinds, fkeys, fdata)
            new_values = self._builder.values(vkinds, vkeys, vdata)
            if self.window is None:
                self._solver.update(graph, new_values)
            else:  # the pose and every landmark stamped now: landmarks never age out
                self._solver.update(graph, new_values, dict.fromkeys(stamped.tolist(), now))
            return
        _, tolerance, max_iterations = op  # "optimize"
        _, threshold, skip, _, window = self._options
        if window is None:
            graph = self._solver.getFactorsUnsafe()
            best = self._graph.optimized(
                graph, self._solver.calculateEstimate(), tolerance, max_iterations
            )
            self._solver = self._graph.make_solver(threshold, skip, None)
            self._solver.update(graph, best)
            return
        self._est = None
        before = self._read_estimate()
        for _ in range(max_iterations):
            self._solver.update()
            self._est = None
            after = self._read_estimate()
            change = max(
                float(np.max(np.abs(a - b), initial=0.0))
                for a, b in zip(after, before, strict=True)
            )
            if change < math.sqrt(tolerance):
                break
            before = after

    def _commit(self, op: tuple) -> None:
        """Apply ``op`` and record it; if GTSAM fails, rebuild the solver from the
        record (the estimator as it was) and raise."""
        self._stale()
        try:
            self._apply(op)
        except RuntimeError as exc:
            self._replay()
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise FloatingPointError(f"the iSAM2 update was refused: {first}") from None
        except BaseException:
            self._replay()
            raise
        self._ops.append(op)

    def _replay(self) -> None:
        """A fresh solver with every recorded operation applied again."""
        _, threshold, skip, _, window = self._options
        self._solver = self._graph.make_solver(threshold, skip, window)
        self._stale()
        for op in self._ops:
            self._apply(op)

    def optimize(self, tolerance: float = 1e-12, max_iterations: int = 100) -> None:
        """The full update: Levenberg–Marquardt on the whole graph from the current
        estimate until the error's relative and absolute decrease fall below
        ``tolerance`` (or ``max_iterations``), then a fresh iSAM2 built at that
        optimum, which later updates continue from. With a window, up to
        ``max_iterations`` iSAM2 updates without new factors (the marginalised part
        stays as it was linearised)."""
        tolerance = checks.number(tolerance, "tolerance")
        if tolerance <= 0.0:
            raise ValueError(f"tolerance must be > 0, got {tolerance}")
        max_iterations = _positive_int(max_iterations, "max_iterations")
        self._commit(("optimize", tolerance, max_iterations))

    # ------------------------------------------------------------------ predict / update
    def predict(self, u: Any) -> None:
        """Odometry u: (δrot1, δtr, δrot2) for "odometry", (Δp, Δθ) for "velocity",
        composed into the increment since the latest pose variable (no GTSAM call;
        the next keyframe's update adds it to the graph as one motion factor)."""
        row = np.empty(self._control_dim)
        checks.control_into(u, row, self._config.motion_model)
        if not np.isfinite(row).all():
            raise checks.bad_control(row)
        u3 = (float(row[0]), float(row[1]), float(row[2]) if row.shape[0] > 2 else 0.0)
        increment, cov = compose(
            self._motion_code, self._noise, self._increment, self._increment_cov, u3
        )
        if not (np.isfinite(increment).all() and np.isfinite(cov).all()):
            raise FloatingPointError("predict refused: the odometry's covariance overflows")
        self._increment, self._increment_cov = increment, cov
        self._steps += 1
        self._t += 1
        self._joint = None  # the mean is read through the increment; the cov is not

    def update(self, z: Any, ids: Any = None) -> UpdateResult:
        """Fold in k observations ``z: (k, 2)`` of landmarks ``ids: (k,)`` taken at the
        current pose: one iSAM2 update with the step's motion factor (when a
        prediction came since the latest pose variable and the step is a keyframe),
        one measurement factor per observation and the new variables. Returns an
        :class:`~slam_env.ekf.results.UpdateResult` (see the class's docstring)."""
        if ids is None:
            raise TypeError("ids are required: ISAM2SLAM takes known correspondences")
        zk, idk = checks.observations(z, ids)
        k = idk.shape[0]
        N = self._N
        if k and (
            not np.isfinite(zk).all()
            or idk.min() < 0
            or idk.max() >= N
            or np.unique(idk).shape[0] != k
        ):
            raise checks.bad_observations(zk, idk, N)
        slots = self._id_to_slot[idk]
        new = slots < 0
        status = np.empty(k, _INT8)
        nis = np.full(k, np.nan)
        nearest = np.full(k, np.nan)
        frames = self._options[3]
        moved = self._steps > 0
        if (
            moved
            and frames is not None
            and not new.any()
            and not frames.due(self._steps, self._increment)
        ):
            status[:] = _DISCARDED
            self._n_discarded += k
            return UpdateResult(idk, status, nis, nearest)
        if not moved and k == 0:
            return UpdateResult(idk, status, nis, nearest)

        pose = self.pose
        x, y, th = (float(v) for v in pose)
        fkinds: list[int] = []
        fkeys: list[tuple[int, int]] = []
        fdata: list[np.ndarray] = []
        vkinds: list[int] = []
        vkeys: list[int] = []
        vdata: list[np.ndarray] = []
        last = pose_key(self._n_poses - 1)
        if moved:
            key = pose_key(self._n_poses)
            fkinds.append(MOTION)
            fkeys.append((last, key))
            fdata.append(np.concatenate([self._increment, self._increment_cov.ravel()]))
            vkinds.append(POSE)
            vkeys.append(key)
            vdata.append(pose)
        else:
            key = last
        marks = self._read_estimate()[1] if (~new).any() else None
        code = self._meas_code
        new_ids = []
        for i in range(k):
            lid = int(idk[i])
            z0, z1 = float(zk[i, 0]), float(zk[i, 1])
            m = km.inverse(code, x, y, th, z0, z1) if new[i] else marks[slots[i]]
            if km.singular(code, x, y, float(m[0]), float(m[1])):
                status[i] = _REJECTED  # the bearing has no Jacobian there
                continue
            if new[i]:
                vkinds.append(POINT)
                vkeys.append(landmark_key(lid))
                vdata.append(np.array(m, dtype=np.float64))
                new_ids.append(lid)
                status[i] = _INITIALISED
            else:
                status[i] = _CORRECTED
            fkinds.append(MEASURE)
            fkeys.append((key, landmark_key(lid)))
            fdata.append(zk[i])
        if fkinds:
            stamped: tuple[int, ...] = ()
            if self.window is not None:  # the pose and every landmark, stamped alike
                ids_now = (*self._slot_to_id[: self._n].tolist(), *new_ids)
                stamped = (key, *(landmark_key(lid) for lid in ids_now))
            now = float(self._n_poses - 1 + moved)
            self._commit(update_op(fkinds, fkeys, fdata, vkinds, vkeys, vdata, stamped, now))
        # The update went through: the bookkeeping follows it.
        if moved and fkinds:
            self._n_poses += 1
            self._pose_steps.append(self._t)
            self._increment = (0.0, 0.0, 0.0)
            self._increment_cov = np.zeros((3, 3))
            self._steps = 0
        for lid in new_ids:
            self._id_to_slot[lid] = self._n
            self._slot_to_id[self._n] = lid
            self._n += 1
        self._n_rejected += int(np.count_nonzero(status == _REJECTED))
        return UpdateResult(idk, status, nis, nearest)

    # ------------------------------------------------------------------ reads
    def _read_estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """(the latest pose variable's estimate (3,), the landmarks' (n, 2) in state
        order), cached until the next change (the cache's own arrays)."""
        if self._est is None:
            s = self._solver
            p = s.calculateEstimatePose2(pose_key(self._n_poses - 1))
            pose = np.array([p.x(), p.y(), wrap_angle(p.theta())])
            marks = np.empty((self._n, 2))
            for i, lid in enumerate(self._slot_to_id[: self._n].tolist()):
                marks[i] = s.calculateEstimatePoint2(landmark_key(lid))
            self._est = (pose, marks)
        return self._est

    def _isam2(self) -> Any:
        """The ``ISAM2`` inside the solver (the fixed-lag smoother's, with a window)."""
        return self._solver if self.window is None else self._solver.getISAM2()

    @property
    def n_landmarks(self) -> int:
        """n, the number of landmarks in the state."""
        return self._n

    @property
    def dim(self) -> int:
        """3 + 2n, the length of the state."""
        return 3 + 2 * self._n

    @property
    def n_rejected(self) -> int:
        """Observations rejected (range-bearing, landmark on the robot) since the reset."""
        return self._n_rejected

    @property
    def n_discarded(self) -> int:
        """Observations left out between keyframes since the reset."""
        return self._n_discarded

    @property
    def n_updates(self) -> int:
        """iSAM2 updates recorded since the reset (the prior's included): what the
        graph and the record hold grows with them."""
        return len(self._ops)

    @property
    def n_poses(self) -> int:
        """Pose variables made since the reset (x_0 included; with a window, fewer are
        still in the graph)."""
        return self._n_poses

    @property
    def pose(self) -> np.ndarray:
        """(3,) the current pose: the latest pose variable's estimate composed with
        the odometry since (a copy)."""
        pose = self._read_estimate()[0]
        return compose_pose(pose, self._increment) if self._steps else pose.copy()

    @property
    def mean(self) -> np.ndarray:
        """(3+2n,) [x, y, θ, m_0x, m_0y, …] in state order (θ in [−π, π))."""
        return np.concatenate([self.pose, self._read_estimate()[1].ravel()])

    def landmark_means(self) -> np.ndarray:
        """(n, 2) landmark means in state order (a copy)."""
        return self._read_estimate()[1].copy()

    def _world(self, cov: np.ndarray) -> np.ndarray:
        """A joint marginal with the latest pose first from GTSAM's pose tangent to the
        world frame (T = blockdiag(R(θ), 1) on the pose rows and columns), then the
        odometry since propagated. A fresh array."""
        theta = float(self._read_estimate()[0][2])
        T = frame_jacobian(theta)
        cov = np.array(cov, dtype=np.float64)
        cov[:3, :] = T @ cov[:3, :]
        cov[:, :3] = cov[:, :3] @ T.T
        if self._steps:
            cov = propagate(cov, theta, self._increment, self._increment_cov)
        return 0.5 * (cov + cov.T)

    @property
    def cov(self) -> np.ndarray:
        """(3+2n, 3+2n) the joint marginal covariance of the current pose and the map
        (past poses integrated out), world frame, state order (a copy)."""
        if self._joint is None:
            keys = [pose_key(self._n_poses - 1)]
            keys += [landmark_key(lid) for lid in self._slot_to_id[: self._n].tolist()]
            isam = self._isam2()
            if len(keys) == 1:
                joint = isam.marginalCovariance(keys[0])
            else:
                joint = self._graph.joint_marginal(isam, keys, [3] + [2] * self._n)
            self._joint = self._world(joint)
        return self._joint.copy()

    @property
    def pose_cov(self) -> np.ndarray:
        """(3, 3) the current pose's marginal covariance, world frame (a copy)."""
        if self._joint is not None:
            return self._joint[:3, :3].copy()
        return self._world(self._isam2().marginalCovariance(pose_key(self._n_poses - 1)))

    def landmark(self, landmark_id: int) -> tuple[np.ndarray, np.ndarray]:
        """(mean (2,), marginal cov (2, 2)) of one landmark; ``ValueError`` if unknown."""
        lid = checks.landmark_id(landmark_id)
        if not 0 <= lid < self._N or self._id_to_slot[lid] < 0:
            raise ValueError(f"landmark id {lid} is not in the state")
        slot = int(self._id_to_slot[lid])
        cov = self._isam2().marginalCovariance(landmark_key(lid))
        return self._read_estimate()[1][slot].copy(), np.array(cov, dtype=np.float64)

    @property
    def state_to_id(self) -> np.ndarray:
        """(n,) int64: the landmark ID of each slot, in state order (a copy)."""
        return self._slot_to_id[: self._n].copy()

    @property
    def id_to_state(self) -> np.ndarray:
        """(max_landmarks,) int64: the slot of each landmark ID, -1 if not in the state."""
        return self._id_to_slot.copy()

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """``(steps (m,), poses (m, 3))``: the smoothed estimate of every pose variable
        still in the graph (all of them without a window), each with the step it was
        taken at (predictions since the reset; 0 the start)."""
        first = 0 if self.window is None else max(0, self._n_poses - self.window)
        s = self._solver
        poses = np.empty((self._n_poses - first, 3))
        for row, i in enumerate(range(first, self._n_poses)):
            p = s.calculateEstimatePose2(pose_key(i))
            poses[row] = (p.x(), p.y(), wrap_angle(p.theta()))
        return np.array(self._pose_steps[first:], dtype=np.int64), poses

    # ------------------------------------------------------------------ options
    @property
    def motion_model(self) -> str:
        return self._config.motion_model

    @property
    def measurement_model(self) -> str:
        return self._config.measurement_model

    @property
    def measurement_cov(self) -> np.ndarray:
        """Q (2×2), a copy."""
        return self._config.measurement_cov.copy()

    @property
    def max_landmarks(self) -> int:
        return self._config.max_landmarks

    @property
    def motion_factor(self) -> str:
        return self._options[0]

    @property
    def relinearize_threshold(self) -> float:
        return self._options[1]

    @property
    def relinearize_skip(self) -> int:
        return self._options[2]

    @property
    def keyframes(self) -> Keyframes | None:
        return self._options[3]

    @property
    def window(self) -> int | None:
        return self._options[4]

    def __repr__(self) -> str:
        c = self._config
        return (
            f"ISAM2SLAM(motion_model={c.motion_model!r}, "
            f"measurement_model={c.measurement_model!r}, motion_factor={self.motion_factor!r}, "
            f"keyframes={self.keyframes!r}, window={self.window}, n_landmarks={self._n}, "
            f"n_poses={self._n_poses}, max_landmarks={c.max_landmarks})"
        )

    # ------------------------------------------------------------------ copy / pickle
    _CONFIG = ("_config", "_options", "_initial_pose", "_initial_pose_cov")
    _STATE = (
        "_ops", "_id_to_slot", "_slot_to_id", "_n", "_n_poses", "_pose_steps", "_t",
        "_increment", "_increment_cov", "_steps", "_n_rejected", "_n_discarded",
    )  # fmt: skip

    def _state_copy(self, new: ISAM2SLAM) -> None:
        for name in self._CONFIG:
            setattr(new, name, getattr(self, name))
        for name in self._STATE:
            value = getattr(self, name)
            setattr(new, name, value.copy() if hasattr(value, "copy") else value)

    def copy(self) -> ISAM2SLAM:
        """An independent copy (the recorded factors are shared: never changed)."""
        new = object.__new__(type(self))
        self._state_copy(new)
        new._setup()
        if self.window is None:
            new._solver = self._graph.copy_isam2(self._solver)
        else:
            new._replay()
        return new

    __copy__ = copy

    def __deepcopy__(self, memo: dict) -> ISAM2SLAM:
        return self.copy()

    def __getstate__(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in self._CONFIG + self._STATE}

    def __setstate__(self, state: dict[str, Any]) -> None:
        for name, value in state.items():
            setattr(self, name, value)
        require("gtsam", "ISAM2SLAM")
        self._setup()
        self._replay()
