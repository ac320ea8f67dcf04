"""The landmark sensor with IDs for users' own worlds, over the same compiled functions
as the envs' batched core (its twin for odometry: :mod:`.odometry_sensor`).

A plain class built from its frozen :class:`~slam_env.config.SensorConfig`; it imports
neither pymunk nor gymnasium. All randomness comes from the ``numpy.random.Generator``
passed to each call: one block of uniforms per call, turned into what the model needs
(Box–Muller normals), so the same seed and the same inputs give bit-identical outputs.

Frames and units: poses are ``(x [m], y [m], θ [rad])`` in the world frame, θ
measured counter-clockwise from the world x axis. The robot frame has its x axis
along the heading and its y axis to the robot's left. Angles are reported wrapped to
[−π, π).

The noise covariance is the one the filter's measurement model uses, and the sensor
exposes it (``LandmarkSensor.measurement_cov``), so a noise-matched filter is matched
exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from slam_env.config import SensorConfig
from slam_env.kernels.stream.sensing import SensorParams, emit_detections, in_view, scan_uniforms

__all__ = ["Detections", "LandmarkSensor", "LineOfSight"]

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
