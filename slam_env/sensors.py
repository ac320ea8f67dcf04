"""The robot's sensors: a landmark sensor with IDs and a noisy odometry sensor.

Both are plain classes built from their frozen config (:class:`SensorConfig`,
:class:`OdometryConfig`); neither imports pymunk or gymnasium. All randomness comes
from the ``numpy.random.Generator`` passed to each call, drawn in a documented fixed
order, so the same seed and the same inputs give bit-identical outputs.

Frames and units: poses are ``(x [m], y [m], θ [rad])`` in the world frame, θ
measured counter-clockwise from the world x axis. The robot frame has its x axis
along the heading and its y axis to the robot's left. Angles are reported wrapped to
[−π, π).

The noise covariances are those of :mod:`slam_env.ekf.models` (the functions the
filter uses), and the sensors expose their parameters (``LandmarkSensor.measurement_cov``,
``OdometrySensor.alphas`` / ``velocity_noise``), so a noise-matched filter is matched
exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from slam_env.config import OdometryConfig, SensorConfig
from slam_env.ekf.models import (
    odometry_action_cov,
    velocity_control_cov,
    velocity_control_variances,
)
from slam_env.geometry import (
    _BELOW_PI,
    TWO_PI,
    odometry_from_poses,
    velocity_from_poses,
    wrap_float,
)

__all__ = ["Detections", "LandmarkSensor", "LineOfSight", "OdometrySensor"]

LineOfSight = Callable[[np.ndarray, np.ndarray, int], bool]
"""``line_of_sight(origin (2,), target (2,), landmark_index) -> True`` when the view
from ``origin`` to ``target`` is clear. Both arrays are read-only views."""

_PI = math.pi

_EMPTY_Z = np.zeros((0, 2), dtype=np.float64)
_EMPTY_I = np.zeros(0, dtype=np.int64)
for _a in (_EMPTY_Z, _EMPTY_I):
    _a.flags.writeable = False


@dataclass(frozen=True, slots=True)
class Detections:
    """One scan of the landmark sensor: k detections, sorted by landmark ID.

    Attributes:
        z: (k, 2) float64. ``"range_bearing"``: rows ``[r [m], φ [rad]]``, φ measured
            from the robot's heading, counter-clockwise positive, wrapped to [−π, π).
            ``"cartesian"``: rows ``[x, y]`` [m], the landmark in the robot frame.
        ids: (k,) int64 landmark IDs (the seed's signature s), strictly ascending
            when the input IDs are unique.
        index: (k,) int64 row of each detection in the ``positions``/``ids`` arrays
            given to :meth:`LandmarkSensor.sense`.
    """

    z: np.ndarray
    ids: np.ndarray
    index: np.ndarray

    def __len__(self) -> int:
        return int(self.ids.shape[0])


class LandmarkSensor:
    """A 2D landmark sensor that reports each visible landmark's ID (known
    correspondences).

    Model ``"range_bearing"`` (seed 000): for a landmark m and robot pose (x, y, θ),
    ``z = [r, φ] + η`` with ``r = √((mx−x)² + (my−y)²)``,
    ``φ = wrap(atan2(my−y, mx−x) − θ)`` and ``η ~ N(0, Q)``,
    ``Q = diag(σr², σφ²)`` (``range_std`` [m], ``bearing_std`` [rad]). The noisy
    bearing is wrapped again to [−π, π); the noisy range is *not* clipped at 0 (that
    would bias it away from the model), which matters only for landmarks closer
    than a few σr.

    Model ``"cartesian"`` (seed 004): ``z = R(θ)ᵀ(m − t) + η``, the landmark in the
    robot frame, ``η ~ N(0, σz² I)`` (``cartesian_std`` [m]).

    Visibility, applied in this order (also the order of the random draws):

    1. *Range and field of view* (vectorised over all landmarks): the true range
       ``r ≤ max_range`` and the true bearing ``|φ| ≤ fov / 2`` (both inclusive;
       ``fov = 2π`` sees all around). The candidates are then put in ascending ID
       order, which every later step keeps.
    2. *Detection probability*: if ``detection_prob < 1``, one ``rng.random(k)``
       call drops each candidate independently with probability ``1 − p``.
    3. *Occlusion*: ``line_of_sight(origin, target, i)`` is called for each
       remaining candidate only (``None``: nothing occludes). Dropping before
       occluding gives the same distribution and saves the costlier ray queries.
    4. *max_detections*: if more landmarks remain, the nearest ones (true range,
       ties by ID) are kept; the output stays sorted by ID.
    5. *Noise*: one ``rng.standard_normal((k, 2))`` call, skipped when the
       standard deviations are all zero (the output is then exact).

    Output: a :class:`Detections` of k ≤ N rows sorted by landmark ID.
    """

    def __init__(self, config: SensorConfig) -> None:
        if not isinstance(config, SensorConfig):
            raise TypeError(f"config must be a SensorConfig, got {type(config).__name__}")
        self.config = config
        self.model = config.measurement_model
        self.max_range = float(config.max_range)
        self.fov = float(config.fov)
        self.detection_prob = float(config.detection_prob)
        self.max_detections = config.max_detections
        self._half_fov = 0.5 * self.fov
        self._all_around = self._half_fov >= math.pi
        if self.model == "range_bearing":
            std = (float(config.range_std), float(config.bearing_std))
        else:
            std = (float(config.cartesian_std), float(config.cartesian_std))
        self._std = np.array(std, dtype=np.float64)
        self._std_pair = std
        self._noisy = bool(std[0] > 0.0 or std[1] > 0.0)

    @property
    def measurement_cov(self) -> np.ndarray:
        """Q (2×2): ``diag(σr², σφ²)`` for range-bearing, ``σz² I`` for cartesian."""
        return np.diag(self._std * self._std)

    def _in_view(
        self, x: float, y: float, theta: float, points: np.ndarray
    ) -> tuple[np.ndarray, list[tuple[int, float, float]]]:
        """Step 1 of the class docstring, from the pose (x, y, θ).

        ``points`` are the N landmark positions as complex numbers ``mx + i·my``
        ((N,) complex128, see :meth:`_as_points`). Returns the robot-frame coordinates
        d = R(θ)ᵀ(m − t) of every landmark as an (N,) complex array ``d_x + i·d_y``, and
        ``(row, r, φ)`` of those within range and field of view, in ascending row
        order, with the true range r = |d| and bearing φ = atan2(d_y, d_x) ∈ [−π, π].
        φ computed in the robot frame equals the seed's wrap(atan2(my − y, mx − x) − θ)
        without the cancellation of subtracting θ.

        A numpy call costs about a microsecond whatever its size, so for tens of
        landmarks the number of calls matters more than the arithmetic. As complex
        numbers the rotation and the offset are one call each: m·e^(−iθ) − t·e^(−iθ),
        i.e. ``d_x = mx·c + my·s − (x·c + y·s)``, ``d_y = my·c − mx·s − (y·c − x·s)``.
        r and φ are then computed vectorised on views of d's two parts, and the two
        tests run on Python floats. d, r and φ stay numpy operations because the seeded
        stream depends on their last bits (``math.hypot`` rounds unlike ``np.hypot``).
        """
        rot = complex(math.cos(theta), -math.sin(theta))
        d = points * rot
        d -= complex(x, y) * rot  # in place: no second temporary
        dx, dy = d.real, d.imag  # views
        # np.hypot, not np.abs(d): numpy's complex abs rounds differently (less exactly).
        r = np.hypot(dx, dy).tolist()
        phi = np.arctan2(dy, dx).tolist()
        max_range = self.max_range
        rows = [i for i, ri in enumerate(r) if ri <= max_range]
        if self._all_around:
            return d, [(i, r[i], phi[i]) for i in rows]
        half_fov = self._half_fov
        return d, [(i, r[i], phi[i]) for i in rows if -half_fov <= phi[i] <= half_fov]

    @staticmethod
    def _as_positions(positions) -> np.ndarray:
        positions = np.asarray(positions, dtype=np.float64)
        if positions.ndim != 2 or positions.shape[1] != 2:
            raise ValueError(f"positions must have shape (N, 2), got {positions.shape}")
        return positions

    @staticmethod
    def _as_points(positions: np.ndarray) -> np.ndarray:
        """(N, 2) float64 positions as the (N,) complex128 ``x + i·y`` that
        :meth:`_scan` takes: a view of the same memory when ``positions`` is
        C-contiguous (a copy otherwise), so the values are exactly the same."""
        return np.ascontiguousarray(positions).view(np.complex128).reshape(-1)

    def candidates(self, pose, positions) -> np.ndarray:
        """Indices (ascending, int64) of the landmarks within ``max_range`` and the
        field of view of ``pose``, before occlusion and detection probability."""
        positions = self._as_positions(positions)
        x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
        found = self._in_view(x, y, theta, self._as_points(positions))[1]
        return np.array([f[0] for f in found], dtype=np.int64)

    def sense(
        self,
        pose,
        positions,
        ids,
        rng: np.random.Generator,
        line_of_sight: LineOfSight | None = None,
    ) -> Detections:
        """Detect the landmarks seen from ``pose``.

        Args:
            pose: (x, y, θ) of the sensor in the world frame [m, m, rad].
            positions: (N, 2) landmark positions in the world frame [m].
            ids: (N,) integer landmark IDs, row-aligned with ``positions``.
            rng: the only source of randomness (see the class docstring for the order).
            line_of_sight: occlusion test, called only for candidates; ``None`` means
                nothing occludes. It must not modify its array arguments.

        Returns:
            :class:`Detections` sorted by landmark ID.
        """
        positions = self._as_positions(positions)
        ids = np.asarray(ids)
        if ids.shape != (positions.shape[0],):
            raise ValueError(f"ids must have shape ({positions.shape[0]},), got {ids.shape}")
        x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
        visible = None
        if line_of_sight is not None:
            # Read-only views: the callback cannot modify the caller's arrays.
            origin = np.array([x, y])
            origin.flags.writeable = False
            view = positions.view()
            view.flags.writeable = False

            def visible(_x: float, _y: float, row: int) -> bool:
                return line_of_sight(origin, view[row], row)

        points = self._as_points(positions)
        rows, _, z = self._scan(x, y, theta, points, ids.tolist(), rng, visible)
        if not rows:
            return Detections(_EMPTY_Z.copy(), _EMPTY_I.copy(), _EMPTY_I.copy())
        index = np.array(rows, dtype=np.int64)
        return Detections(np.array(z, dtype=np.float64), ids.take(index).astype(np.int64), index)

    def _scan(
        self,
        x: float,
        y: float,
        theta: float,
        points: np.ndarray,
        ids: Sequence,
        rng: np.random.Generator,
        visible: Callable[[float, float, int], bool] | None,
        *,
        ids_ascending: bool = False,
    ) -> tuple[list[int], list, list[tuple[float, float]]]:
        """:meth:`sense` without its input checks and without building arrays, for a
        caller whose inputs are already canonical (the env, every step): the pose as
        Python floats, ``points`` the N landmark positions as (N,) complex128
        ``x + i·y`` (:meth:`_as_points`), ``ids`` the N landmark IDs as a Python list,
        and ``visible(x, y, row)`` the occlusion test of one row from the pose's
        position (``None``: nothing occludes; the env passes
        ``World._landmark_visible_from`` itself). ``ids_ascending=True`` promises
        that ``ids`` never decrease along the rows, so that row order is already ID
        order (the env checks it once per world). Same steps, same draws.

        Returns the detections as three lists sorted by ID: their rows in
        ``points``, their IDs, and their ``z`` as tuples of Python floats.
        """
        d, found = self._in_view(x, y, theta, points)  # (row, r, φ) ascending row
        if len(found) > 1 and not ids_ascending:
            listed = [ids[f[0]] for f in found]
            if listed != sorted(listed):
                # Python's sort is stable, like argsort(kind="stable"): equal IDs keep
                # their row order.
                order = sorted(range(len(found)), key=listed.__getitem__)
                found = [found[j] for j in order]
        if self.detection_prob < 1.0 and found:
            draws = rng.random(len(found)).tolist()
            found = [f for f, u in zip(found, draws, strict=True) if u < self.detection_prob]
        if visible is not None:
            found = [f for f in found if visible(x, y, f[0])]
        if self.max_detections is not None and len(found) > self.max_detections:
            by_range = sorted(range(len(found)), key=lambda j: found[j][1])  # stable
            found = [found[j] for j in sorted(by_range[: self.max_detections])]
        k = len(found)
        if k == 0:
            return [], [], []
        rows = [f[0] for f in found]
        # The k rows as Python floats: each value gets the arithmetic of the vectorised
        # z + σ·ε (one multiply, one add) and the same wrap, so the bits are the same.
        noise = rng.standard_normal((k, 2)).tolist() if self._noisy else None
        s0, s1 = self._std_pair
        if self.model == "range_bearing":
            # wrap: +π (landmark straight behind) becomes −π; noise may leave [−π, π)
            if noise is None:
                z = [(r, wrap_float(phi)) for _, r, phi in found]
            else:
                z = [
                    (r + n0 * s0, wrap_float(phi + n1 * s1))
                    for (_, r, phi), (n0, n1) in zip(found, noise, strict=True)
                ]
        else:
            local = d.take(rows).tolist()  # Python complex numbers d_x + i·d_y
            if noise is None:
                z = [(w.real, w.imag) for w in local]
            else:
                z = [
                    (w.real + n0 * s0, w.imag + n1 * s1)
                    for w, (n0, n1) in zip(local, noise, strict=True)
                ]
        return rows, [ids[i] for i in rows], z


class OdometrySensor:
    """Noisy odometry: the robot's true motion pose0 → pose1, decomposed into a
    control u, plus Gaussian noise sampled in action space with exactly the
    covariance the filter's motion model uses.

    Model ``"odometry"`` (seed 000), ``dim = 3``: ``u = (δrot1 [rad], δtr [m],
    δrot2 [rad])`` from :func:`slam_env.geometry.odometry_from_poses` (a backwards
    motion has δtr < 0 and a small δrot1); noise covariance
    ``M(u) = odometry_action_cov(u, alphas)``, α1..α4 = :attr:`alphas` (unitless).

    Model ``"velocity"`` (seed 004), ``dim = 2``: ``u = (Δp [m], Δθ [rad])`` from
    :func:`slam_env.geometry.velocity_from_poses`; noise covariance
    ``Σu(u) = velocity_control_cov(u, velocity_noise)`` with
    :attr:`velocity_noise` = (σp [m], σθ [rad], βp, βθ).

    Reading: ``u_noisy = u_true + sqrt(diag(C(u_true))) · ε``, ε ~ N(0, I_dim) from
    one ``rng.standard_normal(dim)`` call (always made, even when C = 0), with C = M
    or Σu (diagonal), evaluated at the *true* control; the rotation entries are
    wrapped to [−π, π). :meth:`perturb` applies the noise to a control already
    computed with :meth:`true_control` (``measure = perturb ∘ true_control``).

    Caveat of the α-model: δrot1 is the direction of travel, so a translation just
    above ``odometry_from_poses``'s 1 mm threshold (e.g. a push during an in-place
    turn) can give |δrot1| up to π/2 and a large α1·δrot1² noise; below it δrot1 = 0.
    """

    def __init__(self, config: OdometryConfig) -> None:
        if not isinstance(config, OdometryConfig):
            raise TypeError(f"config must be an OdometryConfig, got {type(config).__name__}")
        self.config = config
        self.model = config.motion_model
        self.alphas = tuple(float(a) for a in config.alphas)  # α1..α4, unitless
        self.velocity_noise = tuple(float(v) for v in config.velocity_noise)  # σp, σθ, βp, βθ
        self._odometry = self.model == "odometry"
        self.dim: int = 3 if self._odometry else 2
        self.angle_indices: tuple[int, ...] = (0, 2) if self._odometry else (1,)
        """Entries of u that are angles (wrapped to [−π, π))."""
        # `_true_control(pose0, pose1)`: :meth:`true_control` as a tuple of Python
        # floats, the env's hot path. The geometry function itself, not a method that
        # calls it: one call fewer per step.
        self._true_control: Callable[..., tuple[float, ...]] = (
            odometry_from_poses if self._odometry else velocity_from_poses
        )

    def true_control(self, pose0, pose1) -> np.ndarray:
        """The noiseless control (dim,) that takes pose0 to pose1."""
        return np.array(self._true_control(pose0, pose1), dtype=np.float64)

    def noise_cov(self, u) -> np.ndarray:
        """The action-space noise covariance at u: M (3×3) or Σu (2×2), diagonal."""
        if self._odometry:
            return odometry_action_cov(u, self.alphas)
        return velocity_control_cov(u, self.velocity_noise)

    def perturb(self, u, rng: np.random.Generator) -> np.ndarray:
        """A noisy reading of the (true) control u: ``u + sqrt(diag(C(u)))·ε``,
        rotations wrapped. Returns a new (dim,) float64 array."""
        u = np.asarray(u, dtype=np.float64)
        if u.shape != (self.dim,):
            raise ValueError(f"u must have shape ({self.dim},), got {u.shape}")
        return np.array(self._perturb(u.tolist(), rng), dtype=np.float64)

    def _perturb(self, u: Sequence[float], rng: np.random.Generator) -> tuple[float, ...]:
        """:meth:`perturb` of a control of ``dim`` Python floats, returned as Python
        floats, unchecked: the env's hot path, where numpy's per-call overhead on a
        3-vector costs more than the arithmetic. Same draw, and each entry gets the
        arithmetic of the vectorised form (sqrt, one multiply, one add), so same bits."""
        sqrt = math.sqrt
        if self._odometry:
            rot1, trans, rot2 = u
            # odometry_action_variances(u, alphas), written out: a call and its float
            # conversions cost more than the arithmetic. The test
            # test_perturb_is_bitwise_the_vectorised_formula holds it to noise_cov.
            a1, a2, a3, a4 = self.alphas
            r1, t, r2 = rot1 * rot1, trans * trans, rot2 * rot2
            e1, e2, e3 = rng.standard_normal(3).tolist()
            # wrap_float, written out for the same reason
            w1 = (rot1 + sqrt(a1 * r1 + a2 * t) * e1 + _PI) % TWO_PI - _PI
            w3 = (rot2 + sqrt(a1 * r2 + a2 * t) * e3 + _PI) % TWO_PI - _PI
            return (
                _BELOW_PI if w1 > _BELOW_PI else w1,
                trans + sqrt(a3 * t + a4 * (r1 + r2)) * e2,
                _BELOW_PI if w3 > _BELOW_PI else w3,
            )
        v1, v2 = velocity_control_variances(u, self.velocity_noise)
        e1, e2 = rng.standard_normal(2).tolist()
        dp, dth = u
        return (dp + sqrt(v1) * e1, wrap_float(dth + sqrt(v2) * e2))

    def measure(self, pose0, pose1, rng: np.random.Generator) -> np.ndarray:
        """The noisy odometry reading (dim,) for the true motion pose0 → pose1."""
        return self.perturb(self.true_control(pose0, pose1), rng)
