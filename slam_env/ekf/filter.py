"""EKF-SLAM (seeds 000 and 004): the standalone filter, with known correspondences or
its own data association, and the standard or First-Estimates Jacobian linearisation.

:class:`EKFSLAM` is one filter, usable without gymnasium or pymunk (a robot's logs, a
notebook). It holds its state as a batch of one and runs the same compiled kernels as
the vector envs (:mod:`slam_env.kernels.ekf.filter`), so there is one implementation of the
filter; this class adds the checks of its inputs, and its base class
:class:`~slam_env.ekf.belief_reads.BeliefReads` the reads of its belief.

State and storage
-----------------
The state is ``y = [x, y, θ, m_0x, m_0y, …, m_(n-1)x, m_(n-1)y]`` (``3 + 2n``) with
mean ``x`` and covariance ``P`` (textbook names). Landmarks are appended in the order
they are first seen: *slot* ``i`` holds rows ``3+2i, 4+2i``; ``state_to_id[i]`` is its
landmark ID and ``id_to_state[id]`` its slot (``-1`` when unknown), as in seed 004.
Storage for ``max_landmarks`` landmarks is allocated once, as arrays with a leading
axis of 1 (:meth:`EKFSLAM.belief_arrays`); the live state is the top-left ``(3+2n)``
block, so adding a landmark never reallocates or copies ``P``.

Costs (``d = 3 + 2n``)
---------------------
* ``predict``: ``P_xx ← G P_xx Gᵀ + R_x``, ``P_xm ← G P_xm`` — O(d).
* ``update`` with k corrections: each reads the 5 rows of ``P`` its ``H`` touches
  (less the corrections before it), O(k·d), and its Joseph update is kept as a factor
  ``Y: d×2`` of ``P ← P − Y Yᵀ``; the k factors are applied together at the end, so
  ``P`` is streamed once per update, not k times. Batch mode stacks the observations
  (S: 2k×2k). A new landmark costs O(d).
No dense ``d×d`` G, R or H is ever built, nothing larger than S is factorised, and
P stays exactly symmetric.

Correspondences and linearisation
---------------------------------
``data_association="known"`` (the seeds) takes each observation's landmark ID from the
caller. ``"nearest_neighbor"`` and ``"jcbb"`` take observations without IDs and choose
the landmarks themselves (:mod:`slam_env.kernels.ekf.association`): individual
compatibility within ``match_gate``, or Joint Compatibility Branch and Bound; an
observation compatible with no landmark starts a new one only if none lies within the
wider ``new_landmark_gate``, and is discarded otherwise; with ``wide_pairing_scans``
> 1, JCBB withholds a *wide* pairing (one whose innovation covariance dwarfs the
sensor's noise: a loop closing) until its landmark has been paired that way, without a
rival observation, in that many consecutive scans. The filter then owns the
identities: a landmark's ID is its slot. ``linearization="fej"`` evaluates the
Jacobians at the first estimates, ``"oc"`` takes FEJ's prediction and each measurement
Jacobian at the latest estimate less the least change that keeps the global rotation
unobservable (:mod:`slam_env.kernels.ekf.filter`); ``"invariant"`` is the
right-invariant EKF of Barrau & Bonnabel (:mod:`slam_env.kernels.ekf.invariant`);
``"standard"`` is the seeds' filter.

Atomic calls
------------
Whatever happens inside ``predict``/``update``, a call either completes or leaves the
mean, covariance, ID maps and counters exactly as they were, and raises
``TypeError``/``ValueError`` (bad input) or ``FloatingPointError`` (numerical
breakdown: an innovation covariance that is not positive definite, a non-finite
intermediate, a covariance that would overflow).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np

from slam_env.ekf import checks
from slam_env.ekf.belief_reads import BeliefReads
from slam_env.ekf.chi2 import joint_gates
from slam_env.ekf.configuration import checked_config, kernel_config
from slam_env.ekf.models import MOTION_MODELS
from slam_env.ekf.results import UpdateResult
from slam_env.kernels.base.models import wrap_angle
from slam_env.kernels.base.pinning import pin
from slam_env.kernels.ekf import association
from slam_env.kernels.ekf import codes as ekf_codes
from slam_env.kernels.ekf import filter as ekf
from slam_env.kernels.ekf.associated_update import correction_workspaces

__all__ = ["EKFSLAM"]

_INT8 = np.dtype(np.int8)  # an update's status array


# What a kernel's error code means to the caller of EKFSLAM.
_NUMERICAL_ERRORS = {
    ekf_codes.NOT_POSITIVE_DEFINITE: "the innovation covariance S is not positive definite: the "
    "state covariance is no longer positive semi-definite",
    ekf_codes.NOT_FINITE: "a non-finite value arose (the belief and the observations are beyond "
    "float64)",
    ekf_codes.OVERFLOW: f"a covariance entry would exceed {ekf_codes.COV_LIMIT:g}, or the mean "
    "overflow",
}


class EKFSLAM(BeliefReads):
    """EKF-SLAM with known correspondences: a robot pose and point landmarks.

    ``EKFSLAM(*, motion_model="odometry", measurement_model="range_bearing",
    alphas=None, control_noise=None, measurement_cov, max_landmarks,
    initial_pose=(0, 0, 0), initial_pose_cov=zeros((3, 3)), gate=None,
    correction="sequential")``

    Arguments (keyword only)
        motion_model: ``"odometry"``, u = (δrot1, δtr, δrot2) (seed 000) with the
            action-space noise M(u; α1..α4) of :func:`~slam_env.ekf.models.odometry_action_cov`;
            or ``"velocity"``, u = (Δp, Δθ) (seed 004) with the control noise
            Σu(u; σp, σθ, βp, βθ) of :func:`~slam_env.ekf.models.velocity_control_cov`.
        measurement_model: ``"range_bearing"``, z = [r, φ] (seed 000), or
            ``"cartesian"``, z = R(θ)ᵀ(m − t) (seed 004).
        alphas: (α1, α2, α3, α4) ≥ 0; required for the odometry model.
        control_noise: (σp, σθ, βp, βθ) ≥ 0; required for the velocity model.
        measurement_cov: Q, 2×2 symmetric positive definite, entries ≤ 1e300.
        max_landmarks: landmark IDs are ints in [0, max_landmarks); storage for
            that many landmarks is allocated up front.
        initial_pose, initial_pose_cov: the prior on the pose ((3,), 3×3 PSD, entries
            ≤ 1e300); also what :meth:`reset` uses when called without arguments.
        gate: ``None`` accepts every observation; a number is a χ² threshold on
            ``νᵀS⁻¹ν`` (2 dof, see :func:`~slam_env.ekf.chi2.chi2_gate`) above which an
            observation of a known landmark is rejected: not applied, counted in
            ``n_rejected``.
        correction: ``"sequential"`` (one observation at a time, re-linearised at the
            current mean) or ``"batch"`` (all known observations stacked, each gated
            on its own first).
        data_association: ``"known"`` (the caller gives each observation's landmark
            ID), ``"nearest_neighbor"`` or ``"jcbb"`` (the filter chooses; see the
            module's docstring).
        match_gate, new_landmark_gate: the association's χ² thresholds on an
            observation's D² to a landmark (2 dof): compatible within ``match_gate``
            (default :func:`~slam_env.ekf.chi2.chi2_gate` (0.999)); a new landmark only where every
            landmark lies beyond ``new_landmark_gate`` (default 0.99999), which must be
            at least ``match_gate``. JCBB's joint test is at ``match_gate``'s
            probability, 2 dof per pairing.
        new_landmark_sightings: 1 (a new landmark starts at its first sighting) or 2
            (it is held as tentative until a second, consistent sighting: what keeps
            clutter out of the map; see :mod:`slam_env.kernels.ekf.association`).
        wide_pairing_scans: 1 (JCBB commits every pairing of its hypothesis at once)
            or more (``"jcbb"`` only): a *wide* pairing, whose innovation covariance S
            has ``det S`` above ``WIDE_RATIO²`` (100) times ``det Q`` (the pose is that
            uncertain relative to the landmark: a loop closing), is withheld (the
            observation discarded) unless its landmark has had such a pairing, with no
            other observation of the scan compatible with it, in this many consecutive
            scans; one landmark is followed at a time. What keeps a new landmark seen
            where a mapped one is expected from being taken for it (see
            :mod:`slam_env.kernels.ekf.association`, "Wide pairings").
        linearization: ``"standard"`` (the seeds), ``"fej"`` (First-Estimates
            Jacobian EKF), ``"oc"`` (observability-constrained EKF) or ``"invariant"``
            (right-invariant EKF; ``cov`` is its error covariance mapped to the state's
            coordinates, docs/filter.md "The right-invariant EKF").

    Use
        ``predict(u)``, ``update(z, ids) -> UpdateResult`` (``ids`` None where the
        filter associates); read the belief with
        ``mean``/``cov`` (``(3+2n,)``/``(3+2n, 3+2n)``), ``pose``/``pose_cov``,
        ``landmark(id)``, ``landmark_means()``/``landmark_covs()`` (state order),
        ``state_to_id``/``id_to_state``. Every read returns a fresh copy, except
        ``belief_views()`` and ``belief_arrays()``: read-only views for a per-step
        reader. Invalid input raises ``ValueError``/``TypeError`` naming what was
        wrong, a numerical breakdown ``FloatingPointError``; either way the filter is
        left exactly as it was. ``copy()`` is an independent deep copy
        (``copy_with_known_ids()`` one that takes the IDs it is given, for planners);
        instances pickle.
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
        correction: str = "sequential",
        data_association: str = "known",
        linearization: str = "standard",
        match_gate: float | None = None,
        new_landmark_gate: float | None = None,
        new_landmark_sightings: int = 1,
        wide_pairing_scans: int = 1,
    ) -> None:
        config = checked_config(
            motion_model=motion_model,
            measurement_model=measurement_model,
            alphas=alphas,
            control_noise=control_noise,
            measurement_cov=measurement_cov,
            max_landmarks=max_landmarks,
            gate=gate,
            correction=correction,
            data_association=data_association,
            linearization=linearization,
            match_gate=match_gate,
            new_landmark_gate=new_landmark_gate,
            new_landmark_sightings=new_landmark_sightings,
            wide_pairing_scans=wide_pairing_scans,
        )
        pose0, cov0 = self._check_prior(initial_pose, initial_pose_cov)

        self._config = config
        self._initial_pose = pose0
        self._initial_pose_cov = cov0
        n_max = config.max_landmarks
        dmax = 3 + 2 * n_max
        # The state, a batch of one (slam_env.kernels.ekf.filter): x (1, dmax), P (1, dmax,
        # dmax), n (1,), id_to_slot (1, N), slot_to_id (1, N), n_rejected (1,).
        self._xb = np.zeros((1, dmax))
        self._Pb = np.zeros((1, dmax, dmax))
        self._nb = np.zeros(1, dtype=np.int64)
        self._id_to_slot_b = np.full((1, n_max), -1, dtype=np.int64)
        self._slot_to_id_b = np.full((1, n_max), -1, dtype=np.int64)
        self._n_rejected_b = np.zeros(1, dtype=np.int64)
        self._firstb = np.zeros((1, dmax))
        self._tentativeb = np.zeros((1, association.HELD_ROWS, association.TENTATIVE_WIDTH))
        self._setup()
        self._set_prior(pose0, cov0)

    # ------------------------------------------------------------------ setup
    def _setup(self) -> None:
        """The derived attributes: views of the state, the kernels' configuration and
        scratch (rebuilt after copy and unpickling, never pickled)."""
        self._x = self._xb[0]
        self._P = self._Pb[0]
        self._id_to_slot = self._id_to_slot_b[0]
        self._slot_to_id = self._slot_to_id_b[0]
        c = self._config
        self._N = c.max_landmarks  # (read by every landmark lookup)
        self._u = np.zeros((1, MOTION_MODELS[c.motion_model].control_dim))
        self._u_row = self._u[0]  # the control, written in place by predict
        noise = c.alphas if c.motion_model == "odometry" else c.control_noise
        params, modes = kernel_config(
            c.motion_model,
            c.measurement_model,
            c.correction,
            noise,
            c.measurement_cov,
            c.gate,
            c.data_association,
            c.linearization,
            c.association_gates,
            c.new_landmark_sightings,
            c.wide_pairing_scans,
        )
        self._params = params[None]
        self._modes = modes[None]
        self._mask = np.ones(1, dtype=np.bool_)
        self._error = np.zeros(1, dtype=np.int64)
        self._count = np.zeros(1, dtype=np.int64)
        # The tentative sightings an update would keep (read only where the filter
        # associates, as the joint gates grown with the workspaces).
        self._held = np.empty_like(self._tentativeb)
        self._associates = c.data_association != "known"
        self._jcbb = c.data_association == "jcbb"
        # The kernels' compiled code pinned to the arrays this filter owns (and to the
        # types of the per-call ones: the outputs it allocates, and z and the IDs as
        # checks.observations returns them), called with those arrays bound: a call
        # pays neither numba's typing of its arguments nor a dozen attribute reads.
        # Each is pinned at its first call (_pinned_*), so a filter that is made but
        # never predicts or updates (the env's template) loads none of their kernels.
        # Only the workspaces are ever replaced (_grow_workspace drops the update's and
        # the association's pins, taken again at their next call).
        self._predict: Callable[..., int] | None = None
        self._max_obs = -1
        self._grow_workspace(min(self._N, 8))

    @property
    def associates(self) -> bool:
        """Whether the filter chooses the landmarks of its observations itself."""
        return self._associates

    def _grow_workspace(self, max_obs: int) -> None:
        """Room in the kernels' workspaces for ``max_obs`` observations per update,
        and the update's kernels pinned to them."""
        if max_obs <= self._max_obs:
            return
        self._max_obs = max_obs
        work, fwork, iwork = correction_workspaces(
            self._xb.shape[1], self._N, max_obs, self._associates
        )
        # Pinned to the types of the per-call arrays too: z and the IDs as
        # checks.observations returns them, the outputs as update allocates them.
        z, ids = checks.observations(np.empty((0, 2)), np.empty(0, dtype=np.int64))
        status, nis, nearest = np.empty(0, dtype=np.int8), np.empty(0), np.empty(0)
        state = (
            self._xb, self._Pb, self._nb, self._id_to_slot_b, self._slot_to_id_b,
            self._n_rejected_b, self._firstb, self._params, self._modes, self._count,
            self._mask, self._error, work,
        )  # fmt: skip
        self._update: Callable[..., int] | None = None
        self._update_types = state, (z, ids, status, nis, nearest)
        if self._associates:
            self._joint_gates = joint_gates(self._config.association_gates[0], max_obs)
            belief = (self._xb, self._Pb, self._nb, self._params, self._modes, self._joint_gates)
            held = (self._tentativeb, self._held, fwork, iwork)
            # A batch of one: (1, k, 2) observations, (1, k) IDs and distances.
            batched = (z[None], self._count, self._mask, ids[None], nis[None])
            self._associate_call: tuple[Callable[..., bool], tuple] | None = None
            self._associate_types = belief, batched, held

    def _pinned_predict(self) -> Callable[..., int]:
        """The prediction's kernel pinned to this filter's arrays (once)."""
        args = (
            self._xb, self._Pb, self._nb, self._firstb, self._u, self._params, self._modes,
            self._mask, self._error,
        )  # fmt: skip
        self._predict = partial(pin(ekf.predict_one, *args, 0.0, 0.0, 0.0), *args)
        return self._predict

    def _pinned_update(self) -> Callable[..., int]:
        """The update's kernel pinned to this filter's arrays and workspace (once per
        workspace)."""
        state, per_call = self._update_types
        self._update = partial(pin(ekf.update_one, *state, *per_call), *state)
        return self._update

    def _pinned_association(self) -> tuple[Callable[..., bool], tuple]:
        """The association's kernel pinned to this filter's belief and workspace, and
        the held arrays it is called with (once per workspace)."""
        belief, batched, held = self._associate_types
        compiled = pin(association.associate, *belief, *batched, *held)
        self._associate_call = partial(compiled, *belief), held
        return self._associate_call

    @staticmethod
    def _check_prior(pose: Any, cov: Any) -> tuple[np.ndarray, np.ndarray]:
        pose = checks.float_array(pose, "initial_pose", (3,))
        pose[2] = wrap_angle(float(pose[2]))
        cov = np.zeros((3, 3)) if cov is None else cov
        return pose, checks.covariance(cov, "initial_pose_cov", 3, definite=False)

    def _set_prior(self, pose: np.ndarray, cov: np.ndarray) -> None:
        self._x[:3] = pose
        self._firstb[0, :3] = pose
        self._tentativeb[..., association.AGE] = -1.0  # no tentative sightings, no hold
        self._P[:3, :3] = cov
        self._nb[0] = 0
        self._n_rejected_b[0] = 0
        self._id_to_slot.fill(-1)
        self._slot_to_id.fill(-1)

    def reset(self, initial_pose: Any = None, initial_pose_cov: Any = None) -> None:
        """Start a new episode with no landmarks, reusing the storage.

        ``None`` takes the value given to the constructor. ``n_rejected`` restarts at 0.
        """
        pose = self._initial_pose if initial_pose is None else initial_pose
        cov = self._initial_pose_cov if initial_pose_cov is None else initial_pose_cov
        pose, cov = self._check_prior(pose, cov)
        self._set_prior(pose, cov)

    # ------------------------------------------------------------------ read access
    @property
    def motion_model(self) -> str:
        return self._config.motion_model

    @property
    def measurement_model(self) -> str:
        return self._config.measurement_model

    @property
    def correction(self) -> str:
        return self._config.correction

    @property
    def gate(self) -> float | None:
        return self._config.gate

    @property
    def data_association(self) -> str:
        return self._config.data_association

    @property
    def linearization(self) -> str:
        return self._config.linearization

    @property
    def new_landmark_sightings(self) -> int:
        return self._config.new_landmark_sightings

    @property
    def wide_pairing_scans(self) -> int:
        return self._config.wide_pairing_scans

    @property
    def association_gates(self) -> tuple[float, float]:
        """(match_gate, new_landmark_gate), the association's χ² thresholds."""
        return self._config.association_gates

    @property
    def measurement_cov(self) -> np.ndarray:
        """Q (2×2), a copy."""
        return self._config.measurement_cov.copy()

    @property
    def max_landmarks(self) -> int:
        return self._config.max_landmarks

    def __repr__(self) -> str:
        c = self._config
        return (
            f"EKFSLAM(motion_model={c.motion_model!r}, "
            f"measurement_model={c.measurement_model!r}, correction={c.correction!r}, "
            f"data_association={c.data_association!r}, linearization={c.linearization!r}, "
            f"n_landmarks={self.n_landmarks}, max_landmarks={c.max_landmarks}, gate={c.gate})"
        )

    # ------------------------------------------------------------------ copy / pickle
    # The state; everything else in __dict__ is configuration (shared by copies, which
    # never mutate it) or rebuilt by _setup.
    _STATE = (
        "_xb", "_Pb", "_nb", "_id_to_slot_b", "_slot_to_id_b", "_n_rejected_b", "_firstb",
        "_tentativeb",
    )  # fmt: skip
    _CONFIG = ("_config", "_initial_pose", "_initial_pose_cov")

    def copy(self) -> EKFSLAM:
        """An independent deep copy (for planners that simulate on the belief)."""
        new = object.__new__(type(self))
        for name in self._CONFIG:
            setattr(new, name, getattr(self, name))
        d = self.dim
        new._Pb = np.empty_like(self._Pb)
        new._Pb[0, :d, :d] = self._Pb[0, :d, :d]
        for name in self._STATE:
            if name == "_Pb":
                continue
            setattr(new, name, getattr(self, name).copy())
        new._setup()
        return new

    __copy__ = copy

    def copy_with_known_ids(self) -> EKFSLAM:
        """An independent copy that takes each observation's landmark from the caller
        (``data_association="known"``), by the IDs of :attr:`state_to_id`: for a planner
        that predicts the observations of landmarks it picks, whichever association this
        filter runs (one that associates owns its IDs: a landmark's ID is its slot)."""
        new = self.copy()
        if self._associates:
            new._config = self._config._replace(data_association="known", wide_pairing_scans=1)
            new._setup()
        return new

    def _view_over(self, storage: tuple[np.ndarray, ...]) -> EKFSLAM:
        """A filter with this one's configuration over ``storage``: the state arrays of
        :attr:`_STATE` (``x, P, n, id_to_slot, slot_to_id, n_rejected, first,
        tentative``) of a batch of one, e.g.
        views of row b of :class:`slam_env.ekf.batch.FilterBatch`'s (shared, not
        copied: what one does, the other sees). Pickling or copying it copies the
        state, as for any filter."""
        new = object.__new__(type(self))
        for name in self._CONFIG:
            setattr(new, name, getattr(self, name))
        for name, array in zip(self._STATE, storage, strict=True):
            setattr(new, name, array)
        new._setup()
        return new

    def __deepcopy__(self, memo: dict) -> EKFSLAM:
        return self.copy()

    def __getstate__(self) -> dict[str, Any]:
        state = {name: getattr(self, name) for name in self._CONFIG + self._STATE}
        d = self.dim
        state["_Pb"] = self._Pb[:, :d, :d].copy()  # the live block only
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        live = state.pop("_Pb")
        for name, value in state.items():
            setattr(self, name, value)
        dmax = 3 + 2 * self._config.max_landmarks
        d = live.shape[1]
        self._Pb = np.zeros((1, dmax, dmax))
        self._Pb[:, :d, :d] = live
        self._setup()

    # ------------------------------------------------------------------ predict / update
    def predict(self, u: Any) -> None:
        """Prediction with control u: (δrot1, δtr, δrot2) for "odometry", (Δp, Δθ)
        for "velocity".

        Only the robot block and the robot–map cross-covariance change (seed 000
        §2.1): ``P_xx ← G P_xx Gᵀ + R_x``, ``P_xm ← G P_xm`` with ``R_x = V M Vᵀ``
        plus two sideways terms (odometry, see
        :func:`slam_env.kernels.base.models.odometry_predict`) or ``B Σu Bᵀ`` (velocity).
        Landmarks do not move. O(n). A prediction whose covariance would overflow is
        refused (``FloatingPointError``).
        """
        u_row = self._u_row
        floats = type(u) is tuple and len(u) == len(u_row)  # the short path: no array
        if floats:
            a, b, c = u if len(u) == 3 else (*u, 0.0)
            floats = type(a) is float and type(b) is float and type(c) is float
        if not floats:
            checks.control_into(u, u_row, self._config.motion_model)
            a, b, c = (*u_row.tolist(), 0.0)[:3]
        error = (self._predict or self._pinned_predict())(a, b, c)
        if error:
            self._raise(int(error), "predict", lambda: checks.bad_control(u_row))

    def update(self, z: Any, ids: Any = None) -> UpdateResult:
        """Fold in k observations ``z: (k, 2)`` of landmarks ``ids: (k,)``.

        With known correspondences ``ids`` are required. A filter that associates
        chooses the landmarks itself (at the belief before the update) and takes
        ``ids`` None or all ``-1`` (a sensor that reports no IDs). Known landmarks are
        corrected first, in the given order (sequentially, re-linearised each time,
        or stacked in batch mode), each passing the χ² gate if one is set; then new
        landmarks are initialised from the corrected belief, in the given order (seed
        000 §2.2). Returns an :class:`UpdateResult`.
        """
        associates = self._associates
        if ids is None and not associates:
            raise TypeError("ids are required with data_association='known'")
        zk, idk = checks.observations(z, ids)
        if associates and (idk != -1).any():
            raise ValueError(
                f"data_association={self._config.data_association!r} chooses the landmarks itself: "
                f"ids must be None or all -1, got {idk.tolist()}"
            )
        k = idk.shape[0]
        if self._jcbb:
            pairings = min(k, int(self._nb[0]))
            checks.jcbb_pairings(
                pairings, f"min(rows, landmarks) = min({k}, {int(self._nb[0])})", "pass fewer rows"
            )
        if k > self._max_obs:
            self._grow_workspace(k)
        status = np.empty(k, _INT8)
        nis = np.empty(k)
        nearest = np.empty(k)
        # The same steps as kernels.correction.correct, called one by one: through that
        # kernel's tuples a step of this filter costs about 10% more (measured at N = 20).
        if associates:
            if not np.isfinite(zk).all():
                raise checks.bad_observations(zk, np.zeros(k, dtype=np.int64), self._N)
            self._count[0] = k
            associate, held = self._associate_call or self._pinned_association()
            if not associate(zk[None], self._count, self._mask, idk[None], nearest[None], *held):
                raise RuntimeError("the association's workspace is too small")  # a bug here
        code = (self._update or self._pinned_update())(zk, idk, status, nis, nearest)
        if code:
            self._raise(code, "update", lambda: checks.bad_observations(zk, idk, self._N))
        if associates:
            self._tentativeb[...] = self._held  # kept only once the update has succeeded
        return UpdateResult(idk, status, nis, nearest)

    @staticmethod
    def _raise(code: int, call: str, bad_input: Any) -> None:
        """The exception for a kernel's error code (the state is as it was)."""
        if code in _NUMERICAL_ERRORS:
            raise FloatingPointError(f"{call} refused: {_NUMERICAL_ERRORS[code]}")
        if code in (ekf_codes.BAD_INPUT, ekf_codes.BAD_ID, ekf_codes.DUPLICATE_ID):
            raise bad_input()
        raise RuntimeError(f"{call}: kernel error {ekf_codes.ERROR_NAMES[code]!r}")  # a bug here
