"""How far a point is from the static shapes of a world: what the robot's motion asks
pymunk's point queries, computed in the motion kernel to settle its steps, contacts
included (see :func:`slam_env.kernels.world.motion.drive`)."""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import inline_kernel
from slam_env.kernels.world.shape_queries import distance_sq_to_segment
from slam_env.kernels.world.static_geometry import N_CIRCLES, N_POLYGONS, N_SEGMENTS, StaticGeometry


@inline_kernel
def shape_clearance(geometry: StaticGeometry, b: int, shape: int, x: float, y: float) -> float:
    """The distance (m) from (x, y) to shape ``shape`` of world ``b`` (numbered
    segments, then polygons, then circles, as the tree's leaves number them); 0 inside
    a polygon, negative inside a segment's or circle's radius."""
    g = geometry
    n_segments = g.counts[b, N_SEGMENTS]
    if shape < n_segments:
        s = g.segments
        ax, ay, bx, by = s[b, shape, 0], s[b, shape, 1], s[b, shape, 2], s[b, shape, 3]
        return math.sqrt(distance_sq_to_segment(x, y, ax, ay, bx, by)) - s[b, shape, 4]
    k = shape - n_segments
    if k < g.counts[b, N_POLYGONS]:
        vertices, normals = g.polygons, g.polygon_normals
        n = g.polygon_sizes[b, k]
        outside = False
        edges = math.inf
        px, py = vertices[b, k, n - 1, 0], vertices[b, k, n - 1, 1]
        for i in range(n):
            vx, vy = vertices[b, k, i, 0], vertices[b, k, i, 1]
            # Edge i runs from vertex i − 1 to vertex i; its normal points outwards.
            if normals[b, k, i, 0] * (x - vx) + normals[b, k, i, 1] * (y - vy) > 0.0:
                outside = True
            edges = min(edges, distance_sq_to_segment(x, y, px, py, vx, vy))
            px, py = vx, vy
        return math.sqrt(edges) if outside else 0.0
    i = k - g.counts[b, N_POLYGONS]
    cx, cy, r = g.circles[b, i, 0], g.circles[b, i, 1], g.circles[b, i, 2]
    return math.hypot(x - cx, y - cy) - r


@inline_kernel
def clearance(geometry: StaticGeometry, b: int, x: float, y: float) -> float:
    """The distance (m) from (x, y) to the nearest wall, obstacle or post of world
    ``b``, 0 inside one: the distance of pymunk's ``point_query_nearest`` (every shape
    but the robot), to round-off."""
    counts = geometry.counts
    nearest = math.inf
    for shape in range(counts[b, N_SEGMENTS] + counts[b, N_POLYGONS] + counts[b, N_CIRCLES]):
        nearest = min(nearest, shape_clearance(geometry, b, shape, x, y))
    return max(nearest, 0.0)


@inline_kernel
def clearance_among(
    geometry: StaticGeometry, b: int, x: float, y: float, leaves: np.ndarray, count: int
) -> float:
    """:func:`clearance` over the shapes of the first ``count`` tree ``leaves`` only
    (``math.inf`` for none): the same distance wherever the nearest shape is one of
    them."""
    nearest = math.inf
    for i in range(count):
        shape = geometry.tree[b, leaves[i], 2]
        nearest = min(nearest, shape_clearance(geometry, b, shape, x, y))
    return max(nearest, 0.0)
