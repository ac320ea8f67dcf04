"""The static geometry of B worlds as padded arrays, for the compiled segment queries
of :mod:`slam_env.kernels.world.raycast`.

A world's static shapes (:class:`StaticShapes`, listed from a layout by
:func:`slam_env.world.static_shapes.static_shapes`, from which the pymunk world builds
its space too) are four boundary walls just outside the arena and the inner walls, as
capsules; the convex obstacles, as polygons of radius 0; one post per landmark.

:class:`StaticGeometry` holds them for B worlds, env axis first, each kind padded to a
common capacity with live counts per world, together with the bounding-box tree that
pymunk's space keeps over them. Every value is what Chipmunk (pymunk's C engine) has
for the shape on a static body, computed with its arithmetic (:mod:`.chipmunk`), so
that the kernels reproduce pymunk's queries bit for bit. :func:`set_shapes` writes one
world's shapes and grows the capacities when it must.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from slam_env.kernels.world.chipmunk import (
    bb_tree,
    circle_box,
    circle_centre,
    polygon_data,
    segment_data,
)

__all__ = [
    "N_CIRCLES",
    "N_POLYGONS",
    "N_SEGMENTS",
    "StaticGeometry",
    "StaticShapes",
    "empty_geometry",
    "set_shapes",
]

Point = tuple[float, float]

# Columns of StaticGeometry.counts.
N_SEGMENTS, N_POLYGONS, N_CIRCLES = 0, 1, 2


class StaticShapes(NamedTuple):
    """A world's static shapes as plain Python data, in the order the space gets them.

    Attributes:
        segments: ``((ax, ay), (bx, by), radius)`` capsules: the 4 boundary walls, then
            the inner walls in layout order.
        polygons: the obstacles' vertices as the layout gives them (counter-clockwise).
        circles: ``((cx, cy), radius)``, the post of landmark row i at i.
    """

    segments: tuple[tuple[Point, Point, float], ...]
    polygons: tuple[tuple[Point, ...], ...]
    circles: tuple[tuple[Point, float], ...]


class StaticGeometry(NamedTuple):
    """Static geometry of B worlds (float64 values, int64 indices and counts; rows past
    a world's counts are padding that no kernel reads), as Chipmunk has it.

    Shapes are numbered in the order the space gets them: segments, then polygons,
    then circles (shape ``S + P + i`` is circle i of a world with S segments and P
    polygons).

    Attributes:
        segments: (B, S, 7) capsules ``[ax, ay, bx, by, radius, nx, ny]``: end points,
            half-thickness and Chipmunk's unit normal, the right-hand perpendicular of
            b − a.
        polygons: (B, P, V, 2) convex polygons' vertices, counter-clockwise, in the
            order of Chipmunk's convex hull (:func:`~.chipmunk.chipmunk_hull`).
        polygon_normals: (B, P, V, 2) the outward unit normal of the edge that ends at
            vertex v (from vertex v − 1, cyclically): Chipmunk's splitting plane v.
        polygon_sizes: (B, P) vertex count of each polygon.
        circles: (B, C, 3) ``[cx, cy, r]``; circle i is the post of landmark row i.
        tree: (B, T, 4) the space's bounding-box tree over a world's n shapes, its
            2n − 1 nodes depth-first from the root (node 0), each
            ``[child_a, child_b, -1, parent]`` for an inner node and
            ``[-1, -1, shape, parent]`` for a leaf (the root's parent is −1).
        tree_boxes: (B, T, 4) each node's box ``[left, bottom, right, top]``; a leaf's
            is its shape's box.
        counts: (B, 3) live segments, polygons and circles (columns
            :data:`N_SEGMENTS`, :data:`N_POLYGONS`, :data:`N_CIRCLES`).
    """

    segments: np.ndarray
    polygons: np.ndarray
    polygon_normals: np.ndarray
    polygon_sizes: np.ndarray
    circles: np.ndarray
    tree: np.ndarray
    tree_boxes: np.ndarray
    counts: np.ndarray

    @property
    def n_worlds(self) -> int:
        return self.counts.shape[0]


def empty_geometry(
    n_worlds: int, *, segments: int = 4, polygons: int = 0, vertices: int = 3, circles: int = 0
) -> StaticGeometry:
    """B = ``n_worlds`` empty worlds with room for the given numbers of rows each (and
    for the tree over them); :func:`set_shapes` grows them when a world needs more."""
    sizes = {
        "n_worlds": n_worlds,
        "segments": segments,
        "polygons": polygons,
        "vertices": vertices,
        "circles": circles,
    }
    for name, value in sizes.items():
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name} must be an int, got {type(value).__name__}")
        least = 1 if name == "n_worlds" else 0
        if value < least:
            raise ValueError(f"{name} must be >= {least}, got {value}")
    B, S, P, V, C = (int(v) for v in sizes.values())
    T = max(2 * (S + P + C) - 1, 0)
    return StaticGeometry(
        segments=np.zeros((B, S, 7)),
        polygons=np.zeros((B, P, V, 2)),
        polygon_normals=np.zeros((B, P, V, 2)),
        polygon_sizes=np.zeros((B, P), dtype=np.int64),
        circles=np.zeros((B, C, 3)),
        tree=np.full((B, T, 4), -1, dtype=np.int64),
        tree_boxes=np.zeros((B, T, 4)),
        counts=np.zeros((B, 3), dtype=np.int64),
    )


def set_shapes(geometry: StaticGeometry, b: int, shapes: StaticShapes) -> StaticGeometry:
    """Write world ``b`` from its static ``shapes``; return the geometry to use from now
    on: ``geometry`` itself, written in place, or, when the shapes need more rows than
    it has room for, new arrays (each short capacity at least doubled) with every other
    world copied over. Other worlds' rows are never changed."""
    segments = [segment_data(a, c, r) for a, c, r in shapes.segments]
    polygons = [polygon_data(p) for p in shapes.polygons]
    circles = [(*circle_centre(c), r) for c, r in shapes.circles]
    boxes = [box for _, box in segments] + [box for _, _, box in polygons]
    boxes += [circle_box(*row) for row in circles]
    nodes, node_boxes = bb_tree(boxes)
    g = _with_room(
        geometry,
        segments=len(segments),
        polygons=len(polygons),
        vertices=max((len(v) for v, _, _ in polygons), default=0),
        circles=len(circles),
    )

    for array in (g.segments, g.polygons, g.polygon_normals, g.circles, g.tree_boxes):
        array[b] = 0.0
    g.polygon_sizes[b] = 0
    g.tree[b] = -1
    for i, (row, _) in enumerate(segments):
        g.segments[b, i] = row
    for k, (verts, normals, _) in enumerate(polygons):
        n = len(verts)
        g.polygons[b, k, :n] = verts
        g.polygon_normals[b, k, :n] = normals
        g.polygon_sizes[b, k] = n
    for i, row in enumerate(circles):
        g.circles[b, i] = row
    if len(nodes):
        g.tree[b, : len(nodes)] = nodes
        g.tree_boxes[b, : len(nodes)] = node_boxes
    g.counts[b] = (len(segments), len(polygons), len(circles))
    return g


def _with_room(geometry: StaticGeometry, **need: int) -> StaticGeometry:
    """``geometry``, or a copy with every capacity that is short of ``need`` at least
    doubled (and at least ``need``)."""
    g = geometry
    have = {
        "segments": g.segments.shape[1],
        "polygons": g.polygons.shape[1],
        "vertices": g.polygons.shape[2],
        "circles": g.circles.shape[1],
    }
    if all(need[k] <= have[k] for k in have):
        return geometry
    room = {k: have[k] if need[k] <= have[k] else max(need[k], 2 * have[k]) for k in have}
    grown = empty_geometry(g.n_worlds, **room)
    S, P, V, C = have.values()
    T = g.tree.shape[1]
    grown.segments[:, :S] = g.segments
    grown.polygons[:, :P, :V] = g.polygons
    grown.polygon_normals[:, :P, :V] = g.polygon_normals
    grown.polygon_sizes[:, :P] = g.polygon_sizes
    grown.circles[:, :C] = g.circles
    grown.tree[:, :T] = g.tree
    grown.tree_boxes[:, :T] = g.tree_boxes
    grown.counts[:] = g.counts
    return grown
