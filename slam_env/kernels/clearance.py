"""How far a point is from the static shapes of a world: what the robot's motion asks
pymunk's point queries, computed in the motion kernel to settle steps that no shape is
near enough to touch (see :func:`slam_env.kernels.motion.drive`)."""

from __future__ import annotations

import math

from slam_env.kernels import inline_kernel
from slam_env.kernels.geometry import N_CIRCLES, N_POLYGONS, N_SEGMENTS, StaticGeometry
from slam_env.kernels.shape_queries import distance_sq_to_segment


@inline_kernel
def clearance(geometry: StaticGeometry, b: int, x: float, y: float) -> float:
    """The distance (m) from (x, y) to the nearest wall, obstacle or post of world
    ``b``, 0 inside one: the distance of pymunk's ``point_query_nearest`` (every shape
    but the robot), to round-off."""
    counts = geometry.counts
    nearest = math.inf
    segments = geometry.segments
    for i in range(counts[b, N_SEGMENTS]):
        ax, ay, bx, by, r = (
            segments[b, i, 0],
            segments[b, i, 1],
            segments[b, i, 2],
            segments[b, i, 3],
            segments[b, i, 4],
        )
        nearest = min(nearest, math.sqrt(distance_sq_to_segment(x, y, ax, ay, bx, by)) - r)
    vertices, normals = geometry.polygons, geometry.polygon_normals
    for k in range(counts[b, N_POLYGONS]):
        n = geometry.polygon_sizes[b, k]
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
        nearest = min(nearest, math.sqrt(edges) if outside else 0.0)
    circles = geometry.circles
    for i in range(counts[b, N_CIRCLES]):
        cx, cy, r = circles[b, i, 0], circles[b, i, 1], circles[b, i, 2]
        nearest = min(nearest, math.hypot(x - cx, y - cy) - r)
    return max(nearest, 0.0)
