"""The robot's sensors for users' own worlds: a landmark sensor with IDs and a noisy
odometry sensor, over the same compiled functions as the envs' batched core.

Both are plain classes built from their frozen config (:class:`SensorConfig`,
:class:`OdometryConfig`); neither imports pymunk or gymnasium. All randomness comes
from the ``numpy.random.Generator`` passed to each call: one block of uniforms per
call, turned into what the model needs (Box–Muller normals), so the same seed and the
same inputs give bit-identical outputs.

Frames and units: poses are ``(x [m], y [m], θ [rad])`` in the world frame, θ
measured counter-clockwise from the world x axis. The robot frame has its x axis
along the heading and its y axis to the robot's left. Angles are reported wrapped to
[−π, π).

The noise covariances are those the filter's models use, and the sensors expose their
parameters (``LandmarkSensor.measurement_cov``, ``OdometrySensor.alphas`` /
``velocity_noise``), so a noise-matched filter is matched exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from slam_env.config import OdometryConfig, SensorConfig
from slam_env.kernels.base.models import odometry_variances, velocity_variances
from slam_env.kernels.stream.odometry import noisy_control, odometry_uniforms, true_control
from slam_env.kernels.stream.sensing import SensorParams, emit_detections, in_view, scan_uniforms

__all__ = ["Detections", "LandmarkSensor", "LineOfSight", "OdometrySensor"]

LineOfSight = Callable[[np.ndarray, np.ndarray, int], bool]
"""``line_of_sight(origin (2,), target (2,), landmark_index) -> True`` when the view
from ``origin`` to ``target`` is clear. Both arrays are read-only views."""


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

    Visibility, in this order (:mod:`slam_env.kernels.stream.sensing`):

    1. *Range and field of view*: the true range ``r ≤ max_range`` and the true
       bearing ``|φ| ≤ fov / 2`` (both inclusive; ``fov = 2π`` sees all around), in
       ascending ID order (stable for equal IDs).
    2. *Detection probability*: each candidate is dropped with probability ``1 − p``.
    3. *Occlusion*: ``line_of_sight(origin, target, i)`` is called for each
       remaining candidate only (``None``: nothing occludes).
    4. *max_detections*: if more landmarks remain, the nearest ones (true range,
       ties by ID) are kept; the output stays sorted by ID.
    5. *Noise*, added to the exact measurement.

    Randomness: one ``rng.random(N + 2D)`` call per scan (N landmarks, D =
    ``max_detections`` or N): uniform j decides the j-th landmark in ID order against
    the detection probability, and uniforms N + 2i, N + 2i + 1 give detection i's noise
    as a Box–Muller pair. Nothing is drawn when p = 1 and the noise is off (the output
    is then exact).
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
        cartesian = self.model == "cartesian"
        std = (
            (float(config.cartesian_std), float(config.cartesian_std))
            if cartesian
            else (float(config.range_std), float(config.bearing_std))
        )
        self._std = np.array(std)
        self._noisy = std[0] > 0.0 or std[1] > 0.0
        # max_detections is set per scan (None: as many as there are landmarks).
        self._params = SensorParams(
            self.max_range,
            0.5 * self.fov,
            0.5 * self.fov >= math.pi,
            self.detection_prob,
            0,
            cartesian,
            std[0],
            std[1],
        )

    @property
    def measurement_cov(self) -> np.ndarray:
        """Q (2×2): ``diag(σr², σφ²)`` for range-bearing, ``σz² I`` for cartesian."""
        return np.diag(self._std * self._std)

    @staticmethod
    def _as_positions(positions) -> np.ndarray:
        positions = np.ascontiguousarray(positions, dtype=np.float64)
        if positions.ndim != 2 or positions.shape[1] != 2:
            raise ValueError(f"positions must have shape (N, 2), got {positions.shape}")
        return positions

    def candidates(self, pose, positions) -> np.ndarray:
        """Indices (ascending, int64) of the landmarks within ``max_range`` and the
        field of view of ``pose``, before occlusion and detection probability."""
        positions = self._as_positions(positions)
        n = positions.shape[0]
        rows = np.empty(n, dtype=np.int64)
        found = np.empty((n, 3))
        params = self._params._replace(detection_prob=1.0)
        x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
        k = in_view(x, y, theta, positions, np.arange(n), params, np.empty(0), rows, found)
        return rows[:k].copy()

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
            rng: the only source of randomness (see the class docstring).
            line_of_sight: occlusion test, called only for candidates; ``None`` means
                nothing occludes. It must not modify its array arguments.

        Returns:
            :class:`Detections` sorted by landmark ID.
        """
        positions = self._as_positions(positions)
        n = positions.shape[0]
        ids = np.asarray(ids)
        if ids.shape != (n,):
            raise ValueError(f"ids must have shape ({n},), got {ids.shape}")
        if ids.size and ids.dtype.kind not in "iu":
            raise TypeError(f"ids must be integers, got dtype {ids.dtype}")
        ids = ids.astype(np.int64)
        x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
        d = self.max_detections or n
        params = self._params._replace(max_detections=d)
        draws = self.detection_prob < 1.0 or self._noisy
        uniforms = rng.random(scan_uniforms(n, d)) if draws else np.zeros(scan_uniforms(n, d))
        order = np.argsort(ids, kind="stable")
        rows = np.empty(n, dtype=np.int64)
        found = np.empty((n, 3))
        k = in_view(x, y, theta, positions, order, params, uniforms, rows, found)
        if line_of_sight is not None and k:
            # Read-only views: the callback cannot modify the caller's arrays.
            origin = np.array([x, y])
            origin.flags.writeable = False
            view = positions.view()
            view.flags.writeable = False
            keep = [line_of_sight(origin, view[i], i) for i in rows[:k].tolist()]
            kept = np.flatnonzero(keep)
            k = kept.size
            rows[:k] = rows[kept]
            found[:k] = found[kept]
        z = np.empty((d, 2))
        out_ids = np.empty(d, dtype=np.int64)
        out_rows = np.empty(d, dtype=np.int64)
        count = emit_detections(rows, found, k, params, uniforms[n:], ids, z, out_ids, out_rows)
        return Detections(z[:count].copy(), out_ids[:count].copy(), out_rows[:count].copy())


class OdometrySensor:
    """Noisy odometry: the robot's true motion pose0 → pose1, decomposed into a
    control u, plus Gaussian noise sampled in action space with exactly the
    covariance the filter's motion model uses (:mod:`slam_env.kernels.stream.odometry`).

    Model ``"odometry"`` (seed 000), ``dim = 3``: ``u = (δrot1 [rad], δtr [m],
    δrot2 [rad])`` (a backwards motion has δtr < 0 and a small δrot1); noise
    covariance ``M(u) = diag(α1·δrot1² + α2·δtr², α3·δtr² + α4·(δrot1² + δrot2²),
    α1·δrot2² + α2·δtr²)``, α1..α4 = :attr:`alphas` (unitless).

    Model ``"velocity"`` (seed 004), ``dim = 2``: ``u = (Δp [m], Δθ [rad])``; noise
    covariance ``Σu(u) = diag(σp² + βp·Δp², σθ² + βθ·Δθ²)`` with
    :attr:`velocity_noise` = (σp [m], σθ [rad], βp, βθ).

    Reading: ``u_noisy = u_true + sqrt(diag(C(u_true))) · ε``, the rotation entries
    wrapped to [−π, π), ε ~ N(0, I) from one ``rng.random(4)`` (odometry) or
    ``rng.random(2)`` (velocity) call, as Box–Muller pairs (always drawn, even when
    C = 0). :meth:`perturb` applies the noise to a control already computed with
    :meth:`true_control` (``measure = perturb ∘ true_control``).

    Caveat of the α-model: δrot1 is the direction of travel, so a translation just
    above the 1 mm threshold below which δrot1 is 0 (e.g. a push during an in-place
    turn) can give |δrot1| up to π/2 and a large α1·δrot1² noise.
    """

    def __init__(self, config: OdometryConfig) -> None:
        if not isinstance(config, OdometryConfig):
            raise TypeError(f"config must be an OdometryConfig, got {type(config).__name__}")
        self.config = config
        self.model = config.motion_model
        self.alphas = tuple(float(a) for a in config.alphas)  # α1..α4, unitless
        self.velocity_noise = tuple(float(v) for v in config.velocity_noise)  # σp, σθ, βp, βθ
        self._velocity = self.model == "velocity"
        self.dim: int = 2 if self._velocity else 3
        self.angle_indices: tuple[int, ...] = (1,) if self._velocity else (0, 2)
        """Entries of u that are angles (wrapped to [−π, π))."""
        self._noise = np.array(self.velocity_noise if self._velocity else self.alphas)

    def true_control(self, pose0, pose1) -> np.ndarray:
        """The noiseless control (dim,) that takes pose0 to pose1."""
        p0 = [float(v) for v in pose0[:3]]
        p1 = [float(v) for v in pose1[:3]]
        return np.array(true_control(self._velocity, *p0, *p1)[: self.dim])

    def noise_cov(self, u) -> np.ndarray:
        """The action-space noise covariance at u: M (3×3) or Σu (2×2), diagonal."""
        u = self._control(u)
        if self._velocity:
            return np.diag(velocity_variances(u[0], u[1], *self.velocity_noise))
        return np.diag(odometry_variances(u[0], u[1], u[2], *self.alphas))

    def perturb(self, u, rng: np.random.Generator) -> np.ndarray:
        """A noisy reading of the (true) control u: ``u + sqrt(diag(C(u)))·ε``,
        rotations wrapped. Returns a new (dim,) float64 array."""
        u = self._control(u)
        c2 = 0.0 if self._velocity else u[2]
        uniforms = rng.random(odometry_uniforms(self.dim))
        reading = noisy_control(self._velocity, u[0], u[1], c2, self._noise, uniforms, 0)
        return np.array(reading[: self.dim])

    def measure(self, pose0, pose1, rng: np.random.Generator) -> np.ndarray:
        """The noisy odometry reading (dim,) for the true motion pose0 → pose1."""
        return self.perturb(self.true_control(pose0, pose1), rng)

    def _control(self, u) -> list[float]:
        u = np.asarray(u, dtype=np.float64)
        if u.shape != (self.dim,):
            raise ValueError(f"u must have shape ({self.dim},), got {u.shape}")
        return u.tolist()
