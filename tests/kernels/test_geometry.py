"""The static geometry arrays: the shapes of a layout, Chipmunk's hull and per-edge
data, capacity growth and world-by-world independence in a batch."""

from __future__ import annotations

import math

import numpy as np
import pymunk
import pytest

from slam_env.config import RobotConfig
from slam_env.kernels.world.chipmunk import chipmunk_hull
from slam_env.kernels.world.static_geometry import (
    N_CIRCLES,
    N_POLYGONS,
    N_SEGMENTS,
    StaticGeometry,
    empty_geometry,
)
from slam_env.world.layouts import LANDMARK_POST_RADIUS, Layout
from slam_env.world.pymunk_world import World
from slam_env.world.static_shapes import set_world, static_shapes
from tests.kernels.geometry_worlds import WALL, slanted_layout, world_layouts


def small_layout(n_landmarks: int = 2) -> Layout:
    return Layout(
        width=6.0,
        height=5.0,
        landmark_ids=tuple(range(n_landmarks)),
        landmark_positions=tuple((1.0 + k, 4.0) for k in range(n_landmarks)),
        obstacles=(((3.0, 1.0), (4.0, 1.0), (4.0, 2.0), (3.0, 2.0)),),
        start_pose=(1.0, 1.0, 0.0),
    )


def test_static_shapes_are_the_boundary_walls_obstacles_and_posts() -> None:
    layout = slanted_layout()
    t = 0.15
    shapes = static_shapes(layout, t)
    W, H = layout.width, layout.height
    boundary = shapes.segments[:4]
    # each boundary wall's inner face lies on an arena edge
    assert [s[2] for s in shapes.segments] == [t] * (4 + len(layout.walls))
    assert boundary[0][:2] == ((-t, -t), (W + t, -t))
    assert boundary[2][:2] == ((W + t, H + t), (-t, H + t))
    assert [s[1] for s in boundary] == [s[0] for s in boundary[1:]] + [boundary[0][0]]
    assert [(*a, *b) for a, b, _ in shapes.segments[4:]] == list(layout.walls)
    assert shapes.polygons == layout.obstacles
    assert shapes.circles == tuple((p, LANDMARK_POST_RADIUS) for p in layout.landmark_positions)


def test_the_world_space_holds_the_static_shapes() -> None:
    """World builds its pymunk space from static_shapes: read back through pymunk's
    public accessors, the space holds those shapes, the polygons as Chipmunk's hull."""
    layout = slanted_layout()
    space = World(layout, RobotConfig(), 0.2, 4, WALL).space
    shapes = static_shapes(layout, WALL)
    static = [s for s in space.shapes if s.body.body_type == pymunk.Body.STATIC]
    segments = [(tuple(s.a), tuple(s.b), s.radius) for s in static if isinstance(s, pymunk.Segment)]
    polygons = [[tuple(v) for v in s.get_vertices()] for s in static if isinstance(s, pymunk.Poly)]
    circles = [(tuple(s.offset), s.radius) for s in static if isinstance(s, pymunk.Circle)]
    assert segments == list(shapes.segments)
    assert polygons == [chipmunk_hull(list(p)) for p in shapes.polygons]
    assert circles == list(shapes.circles)


def _pymunk_hull(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    return [(v.x, v.y) for v in pymunk.Poly(None, points).get_vertices()]


def test_chipmunk_hull_matches_pymunk_vertex_for_vertex() -> None:
    """Same vertices in the same order as pymunk's own Poly, on point sets with
    collinear and repeated points, either winding."""
    rng = np.random.default_rng(0)
    for trial in range(3000):
        n = int(rng.integers(1, 12))
        kind = trial % 4
        if kind == 0:
            pts = rng.uniform(-5, 5, (n, 2))
        elif kind == 1:  # a small integer lattice: collinear and repeated points
            pts = rng.integers(-3, 4, (n, 2)).astype(float)
        elif kind == 2:  # on a circle, in angular order
            angles = np.sort(rng.uniform(0, 2 * np.pi, n))
            pts = np.column_stack([np.cos(angles), np.sin(angles)])
        else:
            pts = rng.integers(0, 3, (n, 2)) * 0.5
        points = [(float(x), float(y)) for x, y in pts]
        if trial % 3 == 0:
            points.reverse()
        assert chipmunk_hull(points) == _pymunk_hull(points), points
    for layout in world_layouts():
        for poly in layout.obstacles:
            assert chipmunk_hull(list(poly)) == _pymunk_hull(list(poly))


def test_chipmunk_hull_drops_collinear_points_and_starts_at_the_lowest_x() -> None:
    square = [(1.0, 1.0), (1.0, 0.0), (0.5, 0.0), (0.0, 0.0), (0.0, 1.0)]
    assert chipmunk_hull(square) == [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    assert chipmunk_hull([(2.0, 3.0)] * 3) == [(2.0, 3.0)]
    assert chipmunk_hull([]) == []


def test_rows_hold_the_shapes_with_chipmunks_normals_and_boxes() -> None:
    layout = slanted_layout()
    g = set_world(empty_geometry(1), 0, layout, WALL)
    shapes = static_shapes(layout, WALL)
    S, P, C = len(shapes.segments), len(shapes.polygons), len(shapes.circles)
    assert g.counts[0].tolist() == [S, P, C]
    for row, (a, b, r) in zip(g.segments[0, :S], shapes.segments, strict=True):
        assert row[:5].tolist() == [*a, *b, r]
        d = np.subtract(b, a)
        # the right-hand unit perpendicular of b − a
        np.testing.assert_allclose(row[5:], [d[1], -d[0]] / np.hypot(*d), rtol=0, atol=1e-15)
    for k, poly in enumerate(shapes.polygons):
        hull = chipmunk_hull(list(poly))
        n = g.polygon_sizes[0, k]
        assert n == len(hull) and g.polygons[0, k, :n].tolist() == [list(v) for v in hull]
        v = g.polygons[0, k, :n]
        edges = v - np.roll(v, 1, axis=0)  # edge i ends at vertex i
        outward = np.column_stack([edges[:, 1], -edges[:, 0]])
        outward /= np.hypot(outward[:, 0], outward[:, 1])[:, None]
        np.testing.assert_allclose(g.polygon_normals[0, k, :n], outward, rtol=0, atol=1e-15)
        # counter-clockwise: every other vertex is inside each edge's half-plane
        for i in range(n):
            assert np.all((v - v[i]) @ g.polygon_normals[0, k, i] <= 1e-12)
    # the collinear vertex of the last obstacle is gone
    assert g.polygon_sizes[0, P - 1] == len(layout.obstacles[-1]) - 1
    assert g.circles[0, :C].tolist() == [[*p, r] for p, r in shapes.circles]


def test_the_arrays_follow_the_kernel_conventions() -> None:
    g = set_world(empty_geometry(2), 1, slanted_layout(), WALL)
    for name, array in zip(StaticGeometry._fields, g, strict=True):
        assert array.flags.c_contiguous, name
        assert array.shape[0] == 2, name
        int_fields = ("polygon_sizes", "tree", "counts")
        assert array.dtype == (np.int64 if name in int_fields else np.float64), name
    assert g.n_worlds == 2


def test_the_tree_holds_each_shape_once_under_boxes_that_contain_it() -> None:
    for layout in world_layouts():
        g = set_world(empty_geometry(1), 0, layout, WALL)
        n = int(g.counts[0].sum())
        tree, boxes = g.tree[0, : 2 * n - 1], g.tree_boxes[0, : 2 * n - 1]
        assert np.all(g.tree[0, 2 * n - 1 :] == -1)
        assert tree[0, 3] == -1  # the root
        leaves = tree[tree[:, 2] >= 0]
        assert sorted(leaves[:, 2].tolist()) == list(range(n))
        assert np.all(leaves[:, :2] == -1)
        for node in np.flatnonzero(tree[:, 2] < 0):
            a, b = tree[node, :2]
            assert tree[a, 3] == node and tree[b, 3] == node
            merged = [
                *np.minimum(boxes[a, :2], boxes[b, :2]),
                *np.maximum(boxes[a, 2:], boxes[b, 2:]),
            ]
            assert boxes[node].tolist() == merged
        # a leaf's box is its shape's (the circles' and segments' as Chipmunk makes them)
        S, P, _C = g.counts[0]
        for node in np.flatnonzero(tree[:, 2] >= S + P):
            cx, cy, r = g.circles[0, tree[node, 2] - S - P]
            assert boxes[node].tolist() == [cx - r, cy - r, cx + r, cy + r]
        for node in np.flatnonzero((tree[:, 2] >= 0) & (tree[:, 2] < S)):
            ax, ay, bx, by, r = g.segments[0, tree[node, 2], :5]
            expected = [min(ax, bx) - r, min(ay, by) - r, max(ax, bx) + r, max(ay, by) + r]
            assert boxes[node].tolist() == expected


def _rows(g: StaticGeometry, b: int) -> list:
    """World b's live rows, as plain lists."""
    S, P, C = g.counts[b]
    return [
        g.segments[b, :S].tolist(),
        [g.polygons[b, k, : g.polygon_sizes[b, k]].tolist() for k in range(P)],
        [g.polygon_normals[b, k, : g.polygon_sizes[b, k]].tolist() for k in range(P)],
        g.tree[b, : 2 * (S + P + C) - 1].tolist(),
        g.tree_boxes[b, : 2 * (S + P + C) - 1].tolist(),
        g.circles[b, :C].tolist(),
    ]


def test_capacity_grows_and_keeps_the_other_worlds() -> None:
    g = empty_geometry(3, segments=4, polygons=1, vertices=4, circles=2)
    g = set_world(g, 0, small_layout(2), WALL)
    assert set_world(g, 2, small_layout(1), WALL) is g  # it fits: written in place
    before = [_rows(g, 0), _rows(g, 2)]
    big = world_layouts()[2]  # 15 obstacles, 30 landmarks
    grown = set_world(g, 1, big, WALL)
    assert grown is not g
    assert grown.circles.shape[1] == 30 and grown.polygons.shape[1] == 15
    assert grown.segments.shape[1] == 4  # only what is short grows
    assert [_rows(grown, 0), _rows(grown, 2)] == before
    assert grown.counts[1].tolist() == [4, 15, 30]
    assert _rows(grown, 1) == _rows(set_world(empty_geometry(1), 0, big, WALL), 0)
    # one row short: the capacity doubles rather than creeping up a row at a time
    again = set_world(grown, 0, small_layout(31), WALL)
    assert again.circles.shape[1] == 60 and again.counts[0, N_CIRCLES] == 31


def test_a_world_written_again_drops_its_old_rows() -> None:
    g = set_world(empty_geometry(2), 0, world_layouts()[2], WALL)
    g = set_world(g, 1, slanted_layout(), WALL)
    other = _rows(g, 1)
    g2 = set_world(g, 0, small_layout(1), WALL)
    assert g2 is g
    assert g.counts[0].tolist() == [4, 1, 1]
    # padding past the counts is cleared, and world 1 is untouched
    assert not g.circles[0, 1:].any() and not g.polygons[0, 1:].any()
    assert not g.segments[0, 4:].any() and not g.polygon_sizes[0, 1:].any()
    assert _rows(g, 1) == other
    assert g.counts[:, N_SEGMENTS].tolist() == [4, 6]
    assert g.counts[:, N_POLYGONS].tolist() == [1, 4]
    assert g.counts[:, N_CIRCLES].tolist() == [1, 8]


def test_refused_arguments_write_nothing() -> None:
    g = set_world(empty_geometry(2), 0, small_layout(2), WALL)
    snapshot = [a.copy() for a in g]
    cases = [
        (TypeError, (g, 0, "layout", WALL)),
        (TypeError, (g, 1.0, small_layout(), WALL)),
        (TypeError, (g, True, small_layout(), WALL)),
        (ValueError, (g, 2, small_layout(), WALL)),
        (ValueError, (g, -1, small_layout(), WALL)),
        (ValueError, (g, 0, small_layout(), 0.0)),
        (ValueError, (g, 0, small_layout(), math.nan)),
        (TypeError, (g, 0, small_layout(), "thick")),
        (TypeError, (tuple(g), 0, small_layout(), WALL)),
    ]
    for error, args in cases:
        with pytest.raises(error):
            set_world(*args)
    assert all(np.array_equal(a, b) for a, b in zip(g, snapshot, strict=True))


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"n_worlds": 0}, ValueError),
        ({"n_worlds": 2, "circles": -1}, ValueError),
        ({"n_worlds": 2.0}, TypeError),
        ({"n_worlds": 2, "segments": True}, TypeError),
    ],
)
def test_empty_geometry_checks_its_sizes(kwargs, error) -> None:
    n = kwargs.pop("n_worlds")
    with pytest.raises(error):
        empty_geometry(n, **kwargs)
