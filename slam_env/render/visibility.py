"""The landmark sensor's visible region from a pose, traced for the pictures.

The sensor detects a landmark in range and in its field of view when the segment to it
is clear of walls, obstacles and other landmarks' posts (see
:mod:`slam_env.kernels.stream.sensing`). The region is traced with the world's own range
query, :meth:`slam_env.world.pymunk_world.World.range_scan`, which stops at that same geometry, over
rays spread across the field of view: a landmark whose line of sight is blocked lies in
a shadow of the region, one that is detected is reached by it (up to its own post).
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np

#: Angle between neighbouring rays, rad: a 0.1 m post 5 m away spans about 2.3°.
RAY_SPACING = math.radians(1.0)
_FULL_CIRCLE = 2.0 * math.pi - 1e-9


class RangeQuery(Protocol):
    """What the region needs of a world: :meth:`slam_env.world.pymunk_world.World.range_scan`."""

    def range_scan(
        self, x: float, y: float, theta: float, angles: tuple[float, ...], max_range: float
    ) -> list[float]: ...


def sensor_ray_angles(fov: float, spacing: float = RAY_SPACING) -> tuple[float, ...]:
    """Ray angles (rad, robot frame) across a field of view ``fov`` (rad) at most
    ``spacing`` apart: both edges of a wedge included, a full circle (fov ≥ 2π)
    without its repeated end."""
    if not (math.isfinite(fov) and fov > 0.0):
        raise ValueError(f"fov must be a finite angle > 0, got {fov}")
    if not (math.isfinite(spacing) and spacing > 0.0):
        raise ValueError(f"spacing must be a finite angle > 0, got {spacing}")
    if fov >= _FULL_CIRCLE:
        n = max(8, math.ceil(2.0 * math.pi / spacing))
        return tuple(-math.pi + 2.0 * math.pi * i / n for i in range(n))
    n = max(2, math.ceil(fov / spacing) + 1)
    return tuple(-0.5 * fov + fov * i / (n - 1) for i in range(n))


def visible_region(
    world: RangeQuery,
    pose: Any,
    max_range: float,
    fov: float,
    spacing: float = RAY_SPACING,
) -> np.ndarray:
    """The polygon (K, 2), world frame, m, of what the landmark sensor at ``pose``
    (x, y, θ) sees in ``world``: the sensor's position, then the end of each ray of
    :func:`sensor_ray_angles` (the first wall, obstacle or post it meets, or
    ``max_range``). All around (fov ≥ 2π) the ray ends alone enclose it."""
    if not (math.isfinite(max_range) and max_range > 0.0):
        raise ValueError(f"max_range must be a finite number > 0, got {max_range}")
    x, y, theta = (float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3))
    angles = sensor_ray_angles(fov, spacing)
    reach = np.asarray(world.range_scan(x, y, theta, angles, float(max_range)))
    heading = theta + np.asarray(angles)
    ends = np.stack([x + reach * np.cos(heading), y + reach * np.sin(heading)], axis=1)
    if fov >= _FULL_CIRCLE:
        return ends
    return np.concatenate([[[x, y]], ends], axis=0)
