"""EKF-SLAM with known correspondences (seeds 000 and 004), O(N) prediction and
O(N²) correction, in pure numpy.

State and storage
-----------------
The state is ``y = [x, y, θ, m_0x, m_0y, …, m_(n-1)x, m_(n-1)y]`` (``3 + 2n``) with
mean ``x`` and covariance ``P`` (textbook names). Landmarks are appended in the order
they are first seen: *slot* ``i`` holds rows ``3+2i, 4+2i``; ``state_to_id[i]`` is its
landmark ID and ``id_to_state[id]`` its slot (``-1`` when unknown), as in seed 004.
Storage for ``max_landmarks`` landmarks is allocated once; the live state is the
top-left ``(3+2n)`` block, so adding a landmark never reallocates or copies ``P``.
Entries outside the live block are never read.

Costs (``d = 3 + 2n``)
---------------------
* ``predict``: ``P_xx ← G P_xx Gᵀ + R_x``, ``P_xm ← G P_xm`` — O(d).
* one correction: ``C = P Hᵀ`` from the 5 rows of ``P`` that ``H`` touches,
  ``S = H C + Q`` (2×2, Cholesky), the mean step ``K ν`` — O(d) — and the Joseph
  update written as ``P ← P − Y Yᵀ`` with one well-scaled factor ``Y: d×2`` — O(d²).
* ``update`` with k observations applies the k factors together at its end, as one
  symmetric rank-2k product: ``P`` is streamed once per update, not k times. Each
  sequential correction sees the rows it needs already corrected by the ones
  before it (O(k·d)), so this is exactly the sequential filter. Batch mode stacks
  the k observations (S: 2k×2k) and applies the same update.
* a new landmark: one ``2×3`` by ``3×d`` product — O(d).
No dense ``d×d`` G, R or H is ever built, nothing larger than S is factorised, and
P stays exactly symmetric.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.geometry import wrap_angle

__all__ = [
    "CORRECTED",
    "CORRECTION_MODES",
    "EKFSLAM",
    "INITIALISED",
    "REJECTED",
    "Status",
    "UpdateResult",
    "chi2_gate",
    "chi2_ppf",
]

CORRECTION_MODES = ("sequential", "batch")
_TWO_PI = 2.0 * math.pi


class Status(enum.IntEnum):
    """What ``EKFSLAM.update`` did with one observation."""

    CORRECTED = 0  # a known landmark: the EKF correction was applied
    INITIALISED = 1  # a new landmark: added to the state from the inverse model
    REJECTED = 2  # a known landmark that failed the χ² gate (or that h cannot
    # linearise: range-bearing with the landmark estimated on the robot): not
    # applied, counted in n_rejected


CORRECTED = Status.CORRECTED
INITIALISED = Status.INITIALISED
REJECTED = Status.REJECTED
# Plain ints for the hot loop.
_CORRECTED, _INITIALISED, _REJECTED = int(CORRECTED), int(INITIALISED), int(REJECTED)


@dataclass(frozen=True)
class UpdateResult:
    """Per-observation outcome of one ``EKFSLAM.update``, in the order given.

    ``ids: (k,) int64`` the landmark IDs; ``status: (k,) int8`` :class:`Status` codes;
    ``nis: (k,) float64`` the normalised innovation squared ``νᵀS⁻¹ν`` of each
    correction or rejection (``nan`` for an initialised landmark, and for a landmark
    the model cannot linearise, e.g. one estimated exactly on the robot).
    Sequential mode evaluates ν and S at the belief corrected by the observations
    before it; batch mode at the belief before the update (S its own 2×2 block).
    """

    ids: np.ndarray
    status: np.ndarray
    nis: np.ndarray

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    @property
    def corrected(self) -> np.ndarray:
        """(k,) bool: observations applied as corrections."""
        return self.status == Status.CORRECTED

    @property
    def initialised(self) -> np.ndarray:
        """(k,) bool: observations that added a new landmark."""
        return self.status == Status.INITIALISED

    @property
    def rejected(self) -> np.ndarray:
        """(k,) bool: observations rejected by the gate (not applied)."""
        return self.status == Status.REJECTED


# --------------------------------------------------------------------------- χ² helpers


def _gammainc_lower(a: float, x: float) -> float:
    """Regularised lower incomplete gamma P(a, x) (series / continued fraction)."""
    if x <= 0.0:
        return 0.0
    log_prefix = -x + a * math.log(x) - math.lgamma(a)
    if x < a + 1.0:
        term = total = 1.0 / a
        n = a
        while abs(term) > abs(total) * 1e-17:
            n += 1.0
            term *= x / n
            total += term
        return total * math.exp(log_prefix)
    # Lentz's continued fraction for Q(a, x).
    tiny = 1e-300
    b = x + 1.0 - a
    c = 1.0 / tiny
    d = 1.0 / b
    h = d
    i = 0
    while True:
        i += 1
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-16 or i > 10_000:
            break
    return 1.0 - math.exp(log_prefix) * h


def chi2_ppf(p: float, dof: int) -> float:
    """The p-quantile of the χ² distribution with ``dof`` degrees of freedom.

    Pure Python (no scipy): closed form for 2 dof, otherwise bisection on the
    regularised incomplete gamma function, accurate to ~1e-12 relative.
    """
    if isinstance(p, bool) or not isinstance(p, (int, float)) or not 0.0 < p < 1.0:
        raise ValueError(f"chi2 probability must be in (0, 1), got {p!r}")
    if isinstance(dof, bool) or not isinstance(dof, (int, np.integer)) or dof < 1:
        raise ValueError(f"chi2 dof must be an int >= 1, got {dof!r}")
    if dof == 2:
        return -2.0 * math.log1p(-p)
    a = 0.5 * dof
    lo, hi = 0.0, max(1.0, float(dof))
    while _gammainc_lower(a, 0.5 * hi) < p:
        lo, hi = hi, 2.0 * hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _gammainc_lower(a, 0.5 * mid) < p:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-13 * hi:
            break
    return 0.5 * (lo + hi)


def chi2_gate(probability: float = 0.99, dof: int = 2) -> float:
    """The χ² validation gate for ``EKFSLAM(gate=...)``: an observation with
    ``νᵀS⁻¹ν`` above it is rejected. A correct, noise-matched filter rejects a
    fraction ``1 − probability`` of good observations (seed 004 validation)."""
    return chi2_ppf(probability, dof)


# --------------------------------------------------------------------------- validation


def _number(value: Any, name: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return value


def _float_array(value: Any, name: str, shape: tuple[int, ...]) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be an array of numbers: {exc}") from None
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    return arr


def _covariance(value: Any, name: str, n: int, definite: bool) -> np.ndarray:
    cov = _float_array(value, name, (n, n))
    scale = max(1.0, float(np.abs(cov).max()))
    if np.abs(cov - cov.T).max() > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric, got {cov.tolist()}")
    cov = 0.5 * (cov + cov.T)
    if definite:
        try:
            np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            raise ValueError(
                f"{name} must be symmetric positive definite (a noise-free sensor makes "
                f"the innovation covariance singular), got {cov.tolist()}"
            ) from None
    elif np.linalg.eigvalsh(cov).min() < -1e-12 * scale:
        raise ValueError(f"{name} must be positive semi-definite, got {cov.tolist()}")
    return cov


def _noise_params(value: Any, name: str) -> tuple[float, float, float, float]:
    try:
        items = list(value)
    except TypeError:
        raise TypeError(f"{name} must be a sequence of 4 numbers, got {value!r}") from None
    if len(items) != 4:
        raise ValueError(f"{name} must have 4 entries, got {len(items)}")
    out = []
    for i, item in enumerate(items):
        v = _number(item, f"{name}[{i}]")
        if v < 0.0:
            raise ValueError(f"{name}[{i}] must be >= 0, got {v}")
        out.append(v)
    return out[0], out[1], out[2], out[3]


def _as_landmark_id(value: Any) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"landmark id must be an int, got {type(value).__name__}")
    return int(value)


# --------------------------------------------------------------------------- the filter


class EKFSLAM:
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
        measurement_cov: Q, 2×2 symmetric positive definite.
        max_landmarks: landmark IDs are ints in [0, max_landmarks); storage for
            that many landmarks is allocated up front.
        initial_pose, initial_pose_cov: the prior on the pose ((3,), 3×3 PSD); also
            what :meth:`reset` uses when called without arguments.
        gate: ``None`` accepts every observation; a number is a χ² threshold on
            ``νᵀS⁻¹ν`` (2 dof, see :func:`chi2_gate`) above which an observation of a
            known landmark is rejected: not applied, counted in ``n_rejected``.
        correction: ``"sequential"`` (one observation at a time, re-linearised at the
            current mean) or ``"batch"`` (all known observations stacked, each gated
            on its own first).

    Use
        ``predict(u)``, ``update(z, ids) -> UpdateResult``; read the belief with
        ``mean``/``cov`` (``(3+2n,)``/``(3+2n, 3+2n)``), ``pose``/``pose_cov``,
        ``landmark(id)``, ``landmark_means()``/``landmark_covs()`` (state order),
        ``state_to_id``/``id_to_state``. Every read returns a fresh copy, except
        ``belief_views()``: read-only views for a per-step reader. Invalid
        input raises ``ValueError``/``TypeError`` naming what was wrong and leaves the
        filter unchanged. ``copy()`` is an independent deep copy; instances pickle.
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
    ) -> None:
        if motion_model not in MOTION_MODELS:
            raise ValueError(
                f"motion_model must be one of {tuple(MOTION_MODELS)}, got {motion_model!r}"
            )
        if measurement_model not in MEASUREMENT_MODELS:
            raise ValueError(
                f"measurement_model must be one of {tuple(MEASUREMENT_MODELS)}, "
                f"got {measurement_model!r}"
            )
        if correction not in CORRECTION_MODES:
            raise ValueError(f"correction must be one of {CORRECTION_MODES}, got {correction!r}")
        self._alphas = None if alphas is None else _noise_params(alphas, "alphas")
        self._control_noise = (
            None if control_noise is None else _noise_params(control_noise, "control_noise")
        )
        if motion_model == "odometry" and self._alphas is None:
            raise ValueError("alphas (α1, α2, α3, α4) are required for motion_model='odometry'")
        if motion_model == "velocity" and self._control_noise is None:
            raise ValueError(
                "control_noise (σp, σθ, βp, βθ) is required for motion_model='velocity'"
            )
        Q = _covariance(measurement_cov, "measurement_cov", 2, definite=True)
        if isinstance(max_landmarks, (bool, np.bool_)) or not isinstance(
            max_landmarks, (int, np.integer)
        ):
            raise TypeError(f"max_landmarks must be an int, got {type(max_landmarks).__name__}")
        if max_landmarks < 0:
            raise ValueError(f"max_landmarks must be >= 0, got {max_landmarks}")
        if gate is not None:
            gate = _number(gate, "gate")
            if gate <= 0.0:
                raise ValueError(f"gate must be > 0 (a χ² threshold) or None, got {gate}")
        pose0, cov0 = self._check_prior(initial_pose, initial_pose_cov)

        self._motion_name = motion_model
        self._measurement_name = measurement_model
        self._correction = correction
        self._gate = gate
        self._Q = Q
        self._N = int(max_landmarks)
        self._initial_pose = pose0
        self._initial_pose_cov = cov0
        self._setup_models()
        dmax = 3 + 2 * self._N
        self._x = np.zeros(dmax)  # mean, (3+2N,) storage; live part [:3+2n]
        self._P = np.zeros((dmax, dmax))  # covariance storage; live part [:d, :d]
        self._id_to_slot = np.full(self._N, -1, dtype=np.int64)
        self._slot_to_id = np.full(self._N, -1, dtype=np.int64)
        self._allocate_scratch()
        self._n = 0
        self._n_rejected = 0
        self._set_prior(pose0, cov0)

    # ------------------------------------------------------------------ setup
    def _setup_models(self) -> None:
        self._mm = MOTION_MODELS[self._motion_name]
        self._hm = MEASUREMENT_MODELS[self._measurement_name]
        self._noise = self._alphas if self._motion_name == "odometry" else self._control_noise
        self._angle0, self._angle1 = self._hm.angular
        self._q = (float(self._Q[0, 0]), float(self._Q[0, 1]), float(self._Q[1, 1]))

    def _allocate_scratch(self) -> None:
        dmax = 3 + 2 * self._N
        # Flat buffers, used as contiguous (rows, d) views.
        self._T = np.empty(dmax * dmax)  # a low-rank term of the covariance update
        self._grow_factors(min(self._N, 8))  # grows with the observations per update
        self._H = np.empty((2, 5))
        self._F = np.empty((3, 2))

    @staticmethod
    def _check_prior(pose: Any, cov: Any) -> tuple[np.ndarray, np.ndarray]:
        pose = _float_array(pose, "initial_pose", (3,))
        pose[2] = wrap_angle(float(pose[2]))
        cov = np.zeros((3, 3)) if cov is None else cov
        return pose, _covariance(cov, "initial_pose_cov", 3, definite=False)

    def _set_prior(self, pose: np.ndarray, cov: np.ndarray) -> None:
        self._x[:3] = pose
        self._P[:3, :3] = cov
        self._n = 0
        self._n_rejected = 0
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
        return self._motion_name

    @property
    def measurement_model(self) -> str:
        return self._measurement_name

    @property
    def correction(self) -> str:
        return self._correction

    @property
    def gate(self) -> float | None:
        return self._gate

    @property
    def measurement_cov(self) -> np.ndarray:
        """Q (2×2), a copy."""
        return self._Q.copy()

    @property
    def max_landmarks(self) -> int:
        return self._N

    @property
    def n_landmarks(self) -> int:
        """n, the number of landmarks in the state."""
        return self._n

    @property
    def n_rejected(self) -> int:
        """Observations rejected by the gate since the last reset."""
        return self._n_rejected

    @property
    def dim(self) -> int:
        """3 + 2n, the length of the live state."""
        return 3 + 2 * self._n

    @property
    def mean(self) -> np.ndarray:
        """x: (3+2n,) the state mean [x, y, θ, m_0x, m_0y, …] (a copy; θ in [−π, π))."""
        return self._x[: 3 + 2 * self._n].copy()

    @property
    def cov(self) -> np.ndarray:
        """P: (3+2n, 3+2n) the state covariance (a copy)."""
        d = 3 + 2 * self._n
        return self._P[:d, :d].copy()

    def belief_views(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Read-only *views* of the live ``mean``, ``cov`` and ``state_to_id``, for a
        caller that reads the belief every step (the gym wrapper) and need not pay
        for copies. They are valid until the next ``predict``/``update``/``reset``."""
        d = 3 + 2 * self._n
        views = self._x[:d], self._P[:d, :d], self._slot_to_id[: self._n]
        for view in views:
            view.flags.writeable = False
        return views

    @property
    def pose(self) -> np.ndarray:
        """(3,) the pose mean (a copy)."""
        return self._x[:3].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        """(3, 3) the pose covariance (a copy)."""
        return self._P[:3, :3].copy()

    @property
    def state_to_id(self) -> np.ndarray:
        """(n,) int64: the landmark ID of each slot, in state order (a copy)."""
        return self._slot_to_id[: self._n].copy()

    @property
    def id_to_state(self) -> np.ndarray:
        """(max_landmarks,) int64: the slot of each landmark ID, -1 if not in the
        state (a copy). Slot i is rows 3+2i, 4+2i of the mean and covariance."""
        return self._id_to_slot.copy()

    def landmark(self, landmark_id: int) -> tuple[np.ndarray, np.ndarray]:
        """(mean (2,), cov (2, 2)) of one landmark; ``ValueError`` if it is unknown."""
        lid = _as_landmark_id(landmark_id)
        if not 0 <= lid < self._N or self._id_to_slot[lid] < 0:
            raise ValueError(f"landmark id {lid} is not in the state")
        s = 3 + 2 * int(self._id_to_slot[lid])
        return self._x[s : s + 2].copy(), self._P[s : s + 2, s : s + 2].copy()

    def landmark_means(self) -> np.ndarray:
        """(n, 2) landmark means in state order (a copy)."""
        return self._x[3 : 3 + 2 * self._n].reshape(self._n, 2).copy()

    def landmark_covs(self) -> np.ndarray:
        """(n, 2, 2) the landmarks' marginal covariances in state order (a copy)."""
        n = self._n
        rs, cs = self._P.strides
        blocks = np.lib.stride_tricks.as_strided(
            self._P[3:, 3:], shape=(n, 2, 2), strides=(2 * (rs + cs), rs, cs), writeable=False
        )
        return blocks.copy()

    def landmark_pose_covs(self) -> np.ndarray:
        """(n, 2, 3) each landmark's cross-covariance with the pose, in state order."""
        d = 3 + 2 * self._n
        return self._P[3:d, :3].reshape(self._n, 2, 3).copy()

    def __repr__(self) -> str:
        return (
            f"EKFSLAM(motion_model={self._motion_name!r}, "
            f"measurement_model={self._measurement_name!r}, correction={self._correction!r}, "
            f"n_landmarks={self._n}, max_landmarks={self._N}, gate={self._gate})"
        )

    # ------------------------------------------------------------------ copy / pickle
    def copy(self) -> EKFSLAM:
        """An independent deep copy (for planners that simulate on the belief)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        d = 3 + 2 * self._n
        new._x = self._x.copy()
        new._P = np.empty_like(self._P)
        new._P[:d, :d] = self._P[:d, :d]
        new._id_to_slot = self._id_to_slot.copy()
        new._slot_to_id = self._slot_to_id.copy()
        new._allocate_scratch()
        return new

    __copy__ = copy

    def __deepcopy__(self, memo: dict) -> EKFSLAM:
        return self.copy()

    # Derived or scratch attributes: rebuilt on unpickling, never pickled.
    _TRANSIENT = ("_T", "_Ub", "_k_cap", "_H", "_F", "_mm", "_hm", "_noise", "_q")

    def __getstate__(self) -> dict[str, Any]:
        d = 3 + 2 * self._n
        state = {
            k: v
            for k, v in self.__dict__.items()
            if k not in self._TRANSIENT and k != "_P" and not k.startswith("_angle")
        }
        state["_P"] = self._P[:d, :d].copy()  # the live block only
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        live = state.pop("_P")
        self.__dict__.update(state)
        dmax = 3 + 2 * self._N
        d = live.shape[0]
        self._P = np.zeros((dmax, dmax))
        self._P[:d, :d] = live
        self._setup_models()
        self._allocate_scratch()

    # ------------------------------------------------------------------ predict
    def predict(self, u: Any) -> None:
        """Prediction with control u: (δrot1, δtr, δrot2) for "odometry", (Δp, Δθ)
        for "velocity".

        Only the robot block and the robot–map cross-covariance change (seed 000
        §2.1): ``P_xx ← G P_xx Gᵀ + R_x``, ``P_xm ← G P_xm`` with ``R_x = V M Vᵀ``
        (odometry) or ``B Σu Bᵀ`` (velocity). Landmarks do not move. O(n).
        """
        mm = self._mm
        if type(u) is np.ndarray and u.shape == (mm.control_dim,) and u.dtype.kind == "f":
            uv = u.tolist()  # what a wrapper passes every step: no conversion needed
        else:
            try:
                arr = np.asarray(u, dtype=np.float64)
            except (TypeError, ValueError) as exc:
                raise TypeError(f"u must be an array of numbers: {exc}") from None
            if arr.shape != (mm.control_dim,):
                raise ValueError(
                    f"u must have shape ({mm.control_dim},) for the {mm.name} model, "
                    f"got {arr.shape}"
                )
            uv = arr.tolist()
        if not all(map(math.isfinite, uv)):
            raise ValueError(f"u must be finite, got {uv}")
        x, P = self._x, self._P
        d = 3 + 2 * self._n
        px, py, pth = x[:3].tolist()
        # G = [[1, 0, a], [0, 1, b], [0, 0, 1]] for both models; R_x by its upper triangle.
        nx, ny, nth, a, b, (r00, r01, r02, r11, r12, r22) = mm.linearise(
            px, py, pth, uv, self._noise
        )
        (p00, p01, p02), (_, p11, p12), (_, _, p22) = P[:3, :3].tolist()
        # G P_xx Gᵀ + R_x on the 3×3, in floats (P_xx is kept exactly symmetric).
        q02 = p02 + a * p22
        q12 = p12 + b * p22
        n00 = p00 + a * p02 + a * q02 + r00
        n01 = p01 + a * p12 + b * q02 + r01
        n11 = p11 + b * p12 + b * q12 + r11
        n02 = q02 + r02
        n12 = q12 + r12
        n22 = p22 + r22
        P[:3, :3] = ((n00, n01, n02), (n01, n11, n12), (n02, n12, n22))
        if d > 3:
            # P_xm ← G P_xm: rows x and y gain a, b times the heading row (which, like
            # the landmark rows, is unchanged), mirrored into P_mx.
            row = P[2, 3:d]
            P[0, 3:d] += a * row
            P[1, 3:d] += b * row
            P[3:d, :2] = P[:2, 3:d].T
        x[:3] = (nx, ny, nth)

    # ------------------------------------------------------------------ update
    def update(self, z: Any, ids: Any) -> UpdateResult:
        """Fold in k observations ``z: (k, 2)`` of landmarks ``ids: (k,)``.

        Known landmarks are corrected first, in the given order (sequentially,
        re-linearised each time, or stacked in batch mode), each passing the χ² gate
        if one is set; then new landmarks are initialised from the corrected belief,
        in the given order (seed 000 §2.2). Returns an :class:`UpdateResult`.
        """
        z, zl, id_list = self._check_observations(z, ids)
        k = len(id_list)
        status = [_INITIALISED] * k  # the known ones are overwritten
        nis = [math.nan] * k
        slots = self._id_to_slot
        known: list[int] = []
        new: list[int] = []
        for i, lid in enumerate(id_list):
            (known if slots[lid] >= 0 else new).append(i)
        if known:
            saved = self._x[: 3 + 2 * self._n].copy(), self._n_rejected
            try:
                if self._correction == "batch":
                    self._correct_batch(z, id_list, known, status, nis)
                else:
                    self._correct_sequential(zl, id_list, known, status, nis)
            except FloatingPointError as exc:
                # Only a covariance that lost definiteness gets here (S ⪰ Q ≻ 0 when
                # P ⪰ 0). P is written last, so restoring the mean undoes the call.
                self._x[: saved[0].size] = saved[0]
                self._n_rejected = saved[1]
                raise FloatingPointError(
                    f"{exc}: the state covariance is no longer positive semi-definite"
                ) from None
        if new:
            self._initialise(z[new], [id_list[i] for i in new])
        return UpdateResult(
            np.array(id_list, dtype=np.int64).reshape(k),
            np.array(status, dtype=np.int8),
            np.array(nis, dtype=np.float64),
        )

    def _check_observations(
        self, z: Any, ids: Any
    ) -> tuple[np.ndarray, list[list[float]], list[int]]:
        """z as a (k, 2) float64 array and as nested lists, the IDs as a list."""
        try:
            z = np.asarray(z, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"z must be a (k, 2) array of numbers: {exc}") from None
        if z.ndim != 2 or z.shape[1] != 2:
            raise ValueError(f"z must have shape (k, 2), got {z.shape}")
        ids_arr = np.asarray(ids)
        if ids_arr.ndim != 1 or ids_arr.shape[0] != z.shape[0]:
            raise ValueError(
                f"ids must have shape ({z.shape[0]},) to match z {z.shape}, got {ids_arr.shape}"
            )
        if ids_arr.dtype.kind not in "iu" and ids_arr.size:
            raise TypeError(f"ids must be integers, got dtype {ids_arr.dtype}")
        zl = z.tolist()
        for row, (a, b) in enumerate(zl):
            if not (math.isfinite(a) and math.isfinite(b)):
                raise ValueError(f"z must be finite; row {row} is {[a, b]}")
        id_list = ids_arr.tolist()
        for lid in id_list:
            if lid < 0:
                raise ValueError(f"landmark id {lid} is negative; ids must be in [0, {self._N})")
            if lid >= self._N:
                raise ValueError(f"landmark id {lid} is beyond capacity (max_landmarks={self._N})")
        if len(set(id_list)) != len(id_list):
            seen: set[int] = set()
            dup = next(lid for lid in id_list if lid in seen or seen.add(lid))
            raise ValueError(f"duplicate landmark id {dup} in one update")
        return z, zl, id_list

    def _grow_factors(self, k: int) -> None:
        """Room for the Joseph factors of k corrections in one update (2 rows each)
        and a scratch row."""
        self._k_cap = k
        self._Ub = np.empty((2 * k + 1) * (3 + 2 * self._N))

    def _factor_buffer(self, k: int, d: int) -> np.ndarray:
        """A contiguous (2k + 1, d) scratch view for the factors of k corrections."""
        if k > self._k_cap:
            self._grow_factors(k)
        return self._Ub[: (2 * k + 1) * d].reshape(2 * k + 1, d)

    def _apply_joseph(self, Y: np.ndarray) -> None:
        """P ← P − Yᵀ Y on the live block (Y: (r, d), the stacked row factors).

        ``Y.T @ Y`` is a symmetric rank-r product that numpy evaluates with BLAS syrk
        and mirrors, so P stays exactly symmetric whatever the BLAS; P is read and
        written once per update, however many observations it folds in.
        """
        d = Y.shape[1]
        T = self._T[: d * d].reshape(d, d)
        Pv = self._P[:d, :d]
        np.matmul(Y.T, Y, out=T)
        np.subtract(Pv, T, out=Pv)

    def _correct_sequential(
        self,
        zl: list[list[float]],
        id_list: list[int],
        known: list[int],
        status: list[int],
        nis: list[float],
    ) -> None:
        """Sequential EKF corrections, one observation at a time, each re-linearised
        at the mean corrected by the ones before it.

        One observation: with C = P Hᵀ (d×2), S = H C + Q = L Lᵀ (Cholesky) and the
        gain K = C G, G = S⁻¹ as computed, the Joseph form is

            P⁺ = (I − KH) P (I − KH)ᵀ + K Q Kᵀ = P − K Cᵀ − C Kᵀ + K S Kᵀ
               = P − Y₀ Y₀ᵀ + Z Zᵀ,   Y₀ = C L⁻ᵀ,  Z = (C − K S) L⁻ᵀ,

        an identity for *any* gain. Why Joseph: G is S⁻¹ only up to rounding, and
        the Joseph form stays the covariance of the estimate actually made with that
        gain: the gain error E = I − S G enters as the PSD term Z Zᵀ, where the short
        form (I − KH) P takes it at first order and drifts from symmetry. With
        W = L⁻¹ E L the two terms share one factor: Y₀ Y₀ᵀ − Z Zᵀ = Y Yᵀ with
        Y = C L⁻ᵀ V, V Vᵀ = I − Wᵀ W (2×2 Cholesky, V = I when the gain is exact).
        So P⁺ = P − Y Yᵀ: Y is as well scaled as the textbook factor C L⁻ᵀ, and the
        update is a symmetric (syrk) product, so P stays exactly symmetric.

        Cost: the mean is corrected at once (O(d)); the O(d²) covariance update is
        deferred. Observation j only needs the 5 rows of P that its H touches: the
        rows at the start of the update minus Σ Yᵢ Yᵢᵀ over the corrections before it
        (O(j·d)). At the end all of them are applied as one rank-2k update
        (:meth:`_apply_joseph`), so an update streams P once however many
        observations it has. Mathematically this is exactly the sequential filter.
        """
        x, P = self._x, self._P
        d = 3 + 2 * self._n
        U = self._factor_buffer(len(known), d)  # rows Y₁ᵀ, Y₂ᵀ, … (+ a scratch row)
        H, F = self._H, self._F
        slots = self._id_to_slot
        lin = self._hm.linearise
        q00, q01, q11 = self._q
        gate = self._gate
        r = 0  # factor rows in use: 2 per applied correction
        for i in known:
            s = 3 + 2 * int(slots[id_list[i]])
            idx = (0, 1, 2, s, s + 1)  # the non-zero columns of H
            try:
                zh0, zh1, h0, h1 = lin(*x.take(idx).tolist())
            except ZeroDivisionError:  # the landmark estimate sits on the robot
                status[i] = _REJECTED
                self._n_rejected += 1
                continue
            zi = zl[i]
            nu0 = zi[0] - zh0
            nu1 = zi[1] - zh1
            if self._angle0:
                nu0 = (nu0 + math.pi) % _TWO_PI - math.pi
            if self._angle1:
                nu1 = (nu1 + math.pi) % _TWO_PI - math.pi
            # The 5 rows of the current P that H touches (P = Pᵀ): those at the start
            # of the update minus Σ Yᵢ Yᵢᵀ of the corrections made since.
            R = P.take(idx, axis=0)[:, :d]
            if r:
                Ur = U[:r]
                R -= np.dot(Ur.take(idx, axis=1).T, Ur)
            H.flat = h0 + h1  # the 5 non-zero columns of H (2×5)
            Ct = np.dot(H, R)  # Cᵀ = H P (2×d)
            (c00, c01, c02, c03, c04), (c10, c11, c12, c13, c14) = Ct.take(idx, 1).tolist()
            # S = H P Hᵀ + Q, entry by entry (the (1, 0) entry is the (0, 1) one).
            s00 = c00 * h0[0] + c01 * h0[1] + c02 * h0[2] + c03 * h0[3] + c04 * h0[4] + q00
            s01 = c00 * h1[0] + c01 * h1[1] + c02 * h1[2] + c03 * h1[3] + c04 * h1[4] + q01
            s11 = c10 * h1[0] + c11 * h1[1] + c12 * h1[2] + c13 * h1[3] + c14 * h1[4] + q11
            # Cholesky S = L Lᵀ of the 2×2 and L⁻¹ = [[i00, 0], [i10, i11]].
            if not s00 > 0.0:
                raise FloatingPointError("innovation covariance S is not positive definite")
            l00 = math.sqrt(s00)
            l10 = s01 / l00
            v = s11 - l10 * l10
            if not v > 0.0:
                raise FloatingPointError("innovation covariance S is not positive definite")
            l11 = math.sqrt(v)
            i00 = 1.0 / l00
            i11 = 1.0 / l11
            i10 = -l10 * i00 * i11
            w0 = i00 * nu0  # w = L⁻¹ν, NIS = νᵀS⁻¹ν = |w|²
            w1 = i10 * nu0 + i11 * nu1
            value = w0 * w0 + w1 * w1
            nis[i] = value
            if gate is not None and value > gate:
                status[i] = _REJECTED
                self._n_rejected += 1
                continue
            # G = S⁻¹ = L⁻ᵀ L⁻¹ = [[g00, g01], [g01, g11]] and its error E = I − S G.
            g00 = i00 * i00 + i10 * i10
            g01 = i10 * i11
            g11 = i11 * i11
            e00 = 1.0 - (s00 * g00 + s01 * g01)
            e01 = -(s00 * g01 + s01 * g11)
            e10 = -(s01 * g00 + s11 * g01)
            e11 = 1.0 - (s01 * g01 + s11 * g11)
            # W = L⁻¹ E L, then V = chol(I − Wᵀ W) and the rows of Yᵀ = Vᵀ L⁻¹ Cᵀ.
            el00 = e00 * l00 + e01 * l10
            el10 = e10 * l00 + e11 * l10
            x00 = i00 * el00
            x01 = i00 * e01 * l11
            x10 = i10 * el00 + i11 * el10
            x11 = (i10 * e01 + i11 * e11) * l11
            b00 = 1.0 - (x00 * x00 + x10 * x10)
            b01 = -(x00 * x01 + x10 * x11)
            b11 = 1.0 - (x01 * x01 + x11 * x11)
            v00 = math.sqrt(b00)
            v10 = b01 / v00
            v11 = math.sqrt(b11 - v10 * v10)
            F.flat = (
                v00 * i00 + v10 * i10,
                v10 * i11,
                v11 * i10,
                v11 * i11,
                g00 * nu0 + g01 * nu1,  # the mean step (K ν)ᵀ = (G ν)ᵀ Cᵀ
                g01 * nu0 + g11 * nu1,
            )
            np.dot(F, Ct, out=U[r : r + 3])
            x[:d] += U[r + 2]
            x[2] = wrap_angle(float(x[2]))
            status[i] = _CORRECTED
            r += 2
        if r:
            self._apply_joseph(U[:r])

    def _correct_batch(
        self,
        z: np.ndarray,
        id_list: list[int],
        known: list[int],
        status: list[int],
        nis: list[float],
    ) -> None:
        """Batch EKF correction: all known observations linearised at the same mean,
        each gated on its own 2×2 block of S, the accepted ones stacked (H: 2k×d
        through its 5k non-zero columns) and applied at once with the Joseph form of
        :meth:`_correct_sequential` in 2k×2k matrices."""
        x, P = self._x, self._P
        d = 3 + 2 * self._n
        lin = self._hm.linearise
        pose = x[:3].tolist()
        zl = z.tolist()
        q00, q01, q11 = self._q
        gate = self._gate
        rows, nus, cols, obs = [], [], [], []
        for i in known:
            s = 3 + 2 * int(self._id_to_slot[id_list[i]])
            try:
                zh0, zh1, h0, h1 = lin(*pose, *x[s : s + 2].tolist())
            except ZeroDivisionError:  # the landmark estimate sits on the robot
                status[i] = _REJECTED
                self._n_rejected += 1
                continue
            nu0 = zl[i][0] - zh0
            nu1 = zl[i][1] - zh1
            if self._angle0:
                nu0 = (nu0 + math.pi) % _TWO_PI - math.pi
            if self._angle1:
                nu1 = (nu1 + math.pi) % _TWO_PI - math.pi
            rows.append((h0, h1))
            nus.append((nu0, nu1))
            cols.extend((0, 1, 2, s, s + 1))
            obs.append(i)
        if not obs:
            return
        k = len(obs)
        Hb = np.zeros((2 * k, 5 * k))  # block-diagonal: the non-zero columns of H
        Hb.reshape(k, 2, k, 5)[np.arange(k), :, np.arange(k), :] = rows
        Ct = np.dot(Hb, P.take(cols, axis=0)[:, :d])  # Cᵀ = H P (2k×d)
        S = np.dot(Ct.take(cols, axis=1), Hb.T)  # H P Hᵀ
        S += S.T
        S *= 0.5
        Sl = S.tolist()
        keep = []
        for j, (nu0, nu1) in enumerate(nus):
            # Each observation's own NIS, on its 2×2 block of S (the gate's statistic).
            a = Sl[2 * j][2 * j] + q00
            b = Sl[2 * j][2 * j + 1] + q01
            c = Sl[2 * j + 1][2 * j + 1] + q11
            value = (c * nu0 * nu0 - 2.0 * b * nu0 * nu1 + a * nu1 * nu1) / (a * c - b * b)
            nis[obs[j]] = value
            if gate is not None and value > gate:
                status[obs[j]] = _REJECTED
                self._n_rejected += 1
            else:
                keep.append(j)
        if not keep:
            return
        if len(keep) < k:
            sel = [r for j in keep for r in (2 * j, 2 * j + 1)]
            Ct, S = Ct[sel], S[np.ix_(sel, sel)]
            nus = [nus[j] for j in keep]
            obs = [obs[j] for j in keep]
        n = len(keep)
        ar = np.arange(n)
        S.reshape(n, 2, n, 2)[ar, :, ar, :] += self._Q  # + blockdiag(Q, …, Q)
        # Joseph form as in _correct_sequential: S = L Lᵀ, G = S⁻¹, E = I − S G,
        # W = L⁻¹ E L, V Vᵀ = I − Wᵀ W, Yᵀ = Vᵀ L⁻¹ Cᵀ.
        eye = np.eye(S.shape[0])
        try:
            Lc = np.linalg.cholesky(S)
        except np.linalg.LinAlgError:
            raise FloatingPointError("innovation covariance S is not positive definite") from None
        Li = np.linalg.solve(Lc, eye)  # L⁻¹ (triangular)
        G = Li.T @ Li
        W = Li @ (eye - S @ G) @ Lc
        V = np.linalg.cholesky(eye - W.T @ W)
        x[:d] += np.dot(np.dot(G, np.ravel(nus)), Ct)  # x += K ν, K = C G
        x[2] = wrap_angle(float(x[2]))
        self._apply_joseph(np.dot(np.dot(V.T, Li), Ct))
        for i in obs:
            status[i] = _CORRECTED

    def _initialise(self, z: np.ndarray, new_ids: list[int]) -> None:
        """Append new landmarks from the inverse model (seed 000 §2.2).

        m = h⁻¹(z, x_pose); with L = ∂h⁻¹/∂pose and W = ∂h⁻¹/∂z:
        P_mm = L P_xx Lᵀ + W Q Wᵀ and P_m,y = L P_x,y with the whole state (which
        includes the landmarks added before it in this call). O(d) per landmark.
        """
        x, P = self._x, self._P
        d = 3 + 2 * self._n
        k = len(new_ids)
        pose = x[:3].copy()
        m = self._hm.inverse(pose, z)
        Lj, Wj = self._hm.inverse_jacobians(pose, z)
        L = Lj.reshape(2 * k, 3)
        rows = L @ P[:3, :d]  # P_m,y = L P_x,y   (2k × d)
        block = rows[:, :3] @ L.T  # L P_xx Lᵀ between all new landmarks
        view = block.reshape(k, 2, k, 2)
        ar = np.arange(k)
        view[ar, :, ar, :] += Wj @ self._Q @ Wj.transpose(0, 2, 1)
        e = d + 2 * k
        P[d:e, :d] = rows
        P[:d, d:e] = rows.T
        P[d:e, d:e] = block
        P[d:e, d:e] += block.T
        P[d:e, d:e] *= 0.5
        x[d:e] = m.ravel()
        slots = np.arange(self._n, self._n + k)
        self._id_to_slot[new_ids] = slots
        self._slot_to_id[slots] = new_ids
        self._n += k
