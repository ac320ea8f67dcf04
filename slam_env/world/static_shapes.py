"""A world's static shapes from its layout, for the pymunk space and the kernels' arrays
(:class:`~slam_env.kernels.world.static_geometry.StaticGeometry`): one list of shapes
that both are built from, so that the kernels' queries reproduce pymunk's."""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.world.static_geometry import StaticGeometry, StaticShapes, set_shapes
from slam_env.world.layouts import LANDMARK_POST_RADIUS, Layout

__all__ = ["set_world", "static_shapes"]


def static_shapes(layout: Layout, wall_thickness: float) -> StaticShapes:
    """The static shapes of ``layout``. The boundary walls lie outside the arena, with
    their inner face on its edge; inner walls have half-thickness ``wall_thickness``."""
    t = float(wall_thickness)
    W, H = layout.width, layout.height
    corners = ((-t, -t), (W + t, -t), (W + t, H + t), (-t, H + t))
    boundary = tuple((corners[i], corners[(i + 1) % 4], t) for i in range(4))
    inner = tuple(((x0, y0), (x1, y1), t) for x0, y0, x1, y1 in layout.walls)
    posts = tuple(((x, y), LANDMARK_POST_RADIUS) for x, y in layout.landmark_positions)
    return StaticShapes(boundary + inner, tuple(layout.obstacles), posts)


def set_world(
    geometry: StaticGeometry, b: int, layout: Layout, wall_thickness: float
) -> StaticGeometry:
    """Write world ``b`` from ``layout``'s :func:`static_shapes` (see
    :func:`~slam_env.kernels.world.static_geometry.set_shapes`: the geometry to use from
    now on is returned). Nothing is written when an argument is refused."""
    if not isinstance(geometry, StaticGeometry):
        raise TypeError(f"geometry must be a StaticGeometry, got {type(geometry).__name__}")
    if not isinstance(layout, Layout):
        raise TypeError(f"layout must be a Layout, got {type(layout).__name__}")
    if isinstance(b, (bool, np.bool_)) or not isinstance(b, (int, np.integer)):
        raise TypeError(f"b must be an int, got {type(b).__name__}")
    if not 0 <= b < geometry.n_worlds:
        raise ValueError(f"b must be in [0, {geometry.n_worlds}), got {b}")
    if isinstance(wall_thickness, (bool, np.bool_)) or not isinstance(
        wall_thickness, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"wall_thickness must be a number, got {type(wall_thickness).__name__}")
    if not (math.isfinite(wall_thickness) and wall_thickness > 0):
        raise ValueError(f"wall_thickness must be finite and > 0, got {wall_thickness!r}")

    return set_shapes(geometry, b, static_shapes(layout, wall_thickness))
