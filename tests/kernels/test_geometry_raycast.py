"""The compiled segment queries against pymunk's public ones: the same hits and the
same alphas, bit for bit, on random worlds and poses and on grazing rays built to sit on
the round-off: tangents, vertices, edges, capsule ends and sides, rays starting inside
or on a shape, rays ending on one, zero-length rays."""

from __future__ import annotations

import math

import numpy as np
import pymunk
import pytest

from slam_env.config import RobotConfig
from slam_env.kernels.base.compiling import kernel
from slam_env.kernels.world.raycast import (
    _node_entry,
    _tree_fraction,
    all_leaves,
    line_of_sight,
    lines_of_sight,
    near_leaves,
    range_scan,
    ray_fraction,
    ray_fractions,
    segment_fractions,
    sight_lines,
)
from slam_env.kernels.world.shape_queries import shape_alpha
from slam_env.kernels.world.static_geometry import StaticGeometry, empty_geometry
from slam_env.world.layouts import Layout
from slam_env.world.pymunk_world import _MOTION_FILTER, CAT_ROBOT, World
from slam_env.world.static_shapes import set_world, static_shapes
from tests.kernels.geometry_worlds import WALL, slanted_layout, world_layouts

LAYOUTS = world_layouts()
IDS = [f"{k}-{layout.name}" for k, layout in enumerate(LAYOUTS)]
_ALL = 0xFFFFFFFF


def space_of(layout: Layout) -> pymunk.Space:
    """The world's pymunk space: the referee."""
    return World(layout, RobotConfig(), 0.2, 4, WALL, validated=True).space


def pymunk_alpha(space: pymunk.Space, segment, skip: int = -1) -> float:
    """segment_query_first's alpha (1.0 for None), skipping post ``skip`` (−1: none)."""
    f = _MOTION_FILTER if skip < 0 else pymunk.ShapeFilter(group=skip + 1, mask=_ALL & ~CAT_ROBOT)
    hit = space.segment_query_first((segment[0], segment[1]), (segment[2], segment[3]), 0.0, f)
    return 1.0 if hit is None else hit.alpha


def assert_agrees(layout: Layout, segments: np.ndarray, skips: np.ndarray) -> np.ndarray:
    """Ray fractions and lines of sight of ``segments`` (Q, 4) in ``layout`` equal
    pymunk's, bit for bit; returns the alphas."""
    g = set_world(empty_geometry(1), 0, layout, WALL)
    space = space_of(layout)
    q = len(segments)
    worlds = np.zeros(q, dtype=np.int64)
    alphas = np.empty(q)
    ray_fractions(g, worlds, segments, alphas)
    visible = np.empty(q, dtype=np.bool_)
    lines_of_sight(g, worlds, segments, skips, visible)
    expected = np.array([pymunk_alpha(space, s) for s in segments.tolist()])
    expected_visible = np.array(
        [
            pymunk_alpha(space, s, k) == 1.0
            for s, k in zip(segments.tolist(), skips.tolist(), strict=True)
        ]
    )
    bad = np.flatnonzero(alphas.view(np.uint64) != expected.view(np.uint64))
    assert bad.size == 0, (
        f"ray {segments[bad[0]].tolist()}: {alphas[bad[0]]!r} != {expected[bad[0]]!r}"
    )
    bad = np.flatnonzero(visible != expected_visible)
    assert bad.size == 0, f"line of sight {segments[bad[0]].tolist()} skipping {skips[bad[0]]}"
    # the exact search of the tree, which ray_fraction falls back on, agrees on its own
    depths = np.empty(g.tree.shape[1], dtype=np.int64)
    searched = np.array([_tree_fraction(g, 0, *s, depths) for s in segments.tolist()])
    assert np.array_equal(searched.view(np.uint64), expected.view(np.uint64))
    return alphas


# ----------------------------------------------------------------------------- random


@pytest.mark.parametrize("index", range(len(LAYOUTS)), ids=IDS)
def test_random_rays_and_sight_lines_agree_with_pymunk(index: int) -> None:
    layout = LAYOUTS[index]
    rng = np.random.default_rng(100 + index)
    W, H = layout.width, layout.height
    n = 1200
    # rays anywhere, some starting outside the arena or inside a shape, some of zero
    # length, with the directions of scan beams
    starts = rng.uniform((-0.5, -0.5), (W + 0.5, H + 0.5), (n, 2))
    lengths = rng.uniform(0.0, 0.7 * max(W, H), n)
    lengths[::25] = 0.0
    headings = rng.uniform(-math.pi, math.pi, n)
    ends = starts + lengths[:, None] * np.column_stack([np.cos(headings), np.sin(headings)])
    rays = np.column_stack([starts, ends])
    # sight lines from random poses to landmarks, skipping the landmark's own post
    m = layout.n_landmarks
    k = 40 * m
    targets = rng.integers(0, m, k)
    origins = rng.uniform((0.0, 0.0), (W, H), (k, 2))
    sight = np.column_stack([origins, layout.landmark_array()[targets]])
    segments = np.ascontiguousarray(np.vstack([rays, sight]))
    skips = np.concatenate([rng.integers(-1, m, n), targets]).astype(np.int64)
    alphas = assert_agrees(layout, segments, skips)
    # both outcomes are exercised
    assert 0.2 < np.mean(alphas < 1.0) < 0.95
    assert np.any(alphas == 0.0)  # rays starting inside a shape


# ----------------------------------------------------------------------------- grazing


def _lines_through(p, direction, lengths) -> list[list[float]]:
    """Segments through point p along ``direction``: crossing it, ending on it,
    starting on it, both ways."""
    px, py = p
    dx, dy = direction
    out = []
    for a, b in lengths:
        out.append([px - a * dx, py - a * dy, px + b * dx, py + b * dy])  # across
        out.append([px - a * dx, py - a * dy, px, py])  # ending on p
        out.append([px, py, px + b * dx, py + b * dy])  # starting on p
        out.append([px + b * dx, py + b * dy, px - a * dx, py - a * dy])  # reversed
    return out


def _nudged(x: float, steps: int = 2) -> list[float]:
    """x and its float neighbours up to ``steps`` ulps away."""
    out = [x]
    lo = hi = x
    for _ in range(steps):
        lo, hi = math.nextafter(lo, -math.inf), math.nextafter(hi, math.inf)
        out += [lo, hi]
    return out


def grazing_rays(layout: Layout, rng: np.random.Generator) -> np.ndarray:
    """Rays on the round-off of every static shape of ``layout``."""
    shapes = static_shapes(layout, WALL)
    rays: list[list[float]] = []

    def spans() -> list[tuple[float, float]]:
        return [(float(rng.uniform(0.2, 3.0)), float(rng.uniform(0.2, 3.0))) for _ in range(2)]

    def circle_rays(cx: float, cy: float, r: float) -> None:
        for phi in [*rng.uniform(-math.pi, math.pi, 6).tolist(), 0.0, math.pi / 2]:
            c, s = math.cos(phi), math.sin(phi)
            for rr in [*_nudged(r, 1), r * (1 + 1e-12), r * (1 - 1e-12)]:
                tangent_point = (cx + rr * c, cy + rr * s)
                rays.extend(_lines_through(tangent_point, (-s, c), spans()))
            rays.extend(_lines_through((cx + r * c, cy + r * s), (c, s), spans()))  # radial
        # axis-aligned tangents on the bounding box's edges and just outside them
        for x in _nudged(cx - r) + _nudged(cx + r):
            rays.append([x, cy - 2.0, x, cy + 2.0])
            rays.append([x, cy + 0.5, x, cy - 0.05])
        for y in _nudged(cy - r) + _nudged(cy + r):
            rays.append([cx - 2.0, y, cx + 2.0, y])
        rays.append([cx, cy, cx, cy])  # zero length, inside
        rays.append([cx + r, cy, cx + r, cy])  # zero length, on the rim
        rays.append([cx + 2 * r, cy, cx + 2 * r, cy])  # zero length, outside

    for (ax, ay), (bx, by), r in shapes.segments:
        length = math.hypot(bx - ax, by - ay)
        ux, uy = (bx - ax) / length, (by - ay) / length
        nx, ny = uy, -ux
        for side in (1.0, -1.0):
            for rr in _nudged(r, 1):
                # along the face, past both ends, and ending and starting on it
                fa = (ax + side * rr * nx, ay + side * rr * ny)
                rays.append(
                    [fa[0] - ux, fa[1] - uy, fa[0] + (length + 1) * ux, fa[1] + (length + 1) * uy]
                )
                rays.extend(_lines_through(fa, (ux, uy), spans()))
                rays.extend(_lines_through(fa, (-side * nx, -side * ny), spans()))
            # onto the face's ends from outside, perpendicular
            for end in ((ax, ay), (bx, by)):
                p = (end[0] + side * r * nx, end[1] + side * r * ny)
                rays.extend(_lines_through(p, (side * nx, side * ny), spans()))
        circle_rays(ax, ay, r)  # the capsule's end caps
        circle_rays(bx, by, r)
        mid = ((ax + bx) / 2, (ay + by) / 2)
        rays.append([mid[0], mid[1], mid[0] + 3 * nx, mid[1] + 3 * ny])  # starts inside
        rays.append([mid[0], mid[1], mid[0], mid[1]])  # zero length inside

    for poly in shapes.polygons:
        n = len(poly)
        centre = (sum(x for x, _ in poly) / n, sum(y for _, y in poly) / n)
        for i in range(n):
            (x0, y0), (x1, y1) = poly[i - 1], poly[i]
            ex, ey = x1 - x0, y1 - y0
            length = math.hypot(ex, ey)
            ux, uy = ex / length, ey / length
            # through the vertex, from random directions and along the diagonals
            for phi in rng.uniform(-math.pi, math.pi, 4).tolist():
                rays.extend(_lines_through((x1, y1), (math.cos(phi), math.sin(phi)), spans()))
            d = math.hypot(x1 - centre[0], y1 - centre[1])
            rays.extend(
                _lines_through((x1, y1), ((x1 - centre[0]) / d, (y1 - centre[1]) / d), spans())
            )
            # along the edge (collinear), and a hair off it on both sides
            for off in (0.0, 1e-13, -1e-13, 1e-9, -1e-9):
                p0 = (x0 + off * uy, y0 - off * ux)
                rays.append(
                    [p0[0] - ux, p0[1] - uy, p0[0] + (length + 1) * ux, p0[1] + (length + 1) * uy]
                )
                rays.append([p0[0], p0[1], p0[0] + length * ux, p0[1] + length * uy])
            # onto the edge's midpoint from outside and from its own line
            m = ((x0 + x1) / 2, (y0 + y1) / 2)
            rays.extend(_lines_through(m, (uy, -ux), spans()))
            # shorter than the parallel tolerance, across the edge
            rays.append([m[0] + 4e-6 * uy, m[1] - 4e-6 * ux, m[0] - 4e-6 * uy, m[1] + 4e-6 * ux])
            rays.append([x1, y1, x1, y1])  # zero length on a vertex
        rays.append([centre[0], centre[1], centre[0] + 5.0, centre[1] + 1.0])  # starts inside
        rays.append([centre[0], centre[1], centre[0], centre[1]])

    for (cx, cy), r in shapes.circles:
        circle_rays(cx, cy, r)

    # into the arena's corners, where two walls' capsules overlap
    W, H = layout.width, layout.height
    for corner in ((0.0, 0.0), (W, 0.0), (W, H), (0.0, H)):
        inward = (0.5 * W - corner[0], 0.5 * H - corner[1])
        d = math.hypot(*inward)
        rays.extend(_lines_through(corner, (inward[0] / d, inward[1] / d), spans()))
    return np.ascontiguousarray(rays, dtype=np.float64)


@pytest.mark.parametrize("index", range(len(LAYOUTS)), ids=IDS)
def test_grazing_rays_agree_with_pymunk(index: int) -> None:
    layout = LAYOUTS[index]
    rng = np.random.default_rng(200 + index)
    rays = grazing_rays(layout, rng)
    skips = rng.integers(-1, layout.n_landmarks, len(rays)).astype(np.int64)
    alphas = assert_agrees(layout, rays, skips)
    assert len(rays) > 2000
    assert np.any(alphas == 0.0) and np.any(alphas == 1.0) and np.any((alphas > 0) & (alphas < 1))


def test_shape_queries_agree_with_pymunks_shape_queries() -> None:
    """Each shape on its own (no bounding-box tree) against pymunk's
    Shape.segment_query, which is cpShapeSegmentQuery itself."""
    layout = slanted_layout()
    g = set_world(empty_geometry(1), 0, layout, WALL)
    space = space_of(layout)
    rays = grazing_rays(layout, np.random.default_rng(3))[::3]
    # the space's static shapes in the order it got them: the kernels' shape numbers
    static = [s for s in space.shapes if s.body.body_type == pymunk.Body.STATIC]
    hits = np.zeros(3, dtype=np.int64)  # segments, polygons, circles
    kinds = (pymunk.Segment, pymunk.Poly, pymunk.Circle)
    for ray in rays.tolist():
        for number, shape in enumerate(static):
            hit = shape.segment_query((ray[0], ray[1]), (ray[2], ray[3]), 0.0)
            expected = 1.0 if hit is None else hit.alpha
            assert shape_alpha(g, 0, number, *ray) == expected, (number, ray)
            hits[[isinstance(shape, k) for k in kinds]] += expected < 1.0
    assert np.all(hits > 100)


def test_the_bounding_box_test_turns_grazing_hits_away() -> None:
    """A vertical ray one ulp outside a post's bounding box often hits the post by the
    post's own arithmetic, but the space's bounding-box tree never lets it try. The
    kernels answer as the space does."""
    layout = LAYOUTS[5]  # open: posts only
    g = set_world(empty_geometry(1), 0, layout, WALL)
    space = space_of(layout)
    posts = [
        s
        for s in space.shapes
        if isinstance(s, pymunk.Circle) and s.body.body_type == pymunk.Body.STATIC
    ]
    turned_away = 0
    for i, post in enumerate(posts):
        cx, cy, r = g.circles[0, i]
        for x in (math.nextafter(cx - r, -math.inf), math.nextafter(cx + r, math.inf)):
            for y0, y1 in ((cy - 3.0, cy + 3.0), (cy + 3.0, cy - 3.0), (cy - 0.5, cy + 0.01)):
                alone = post.segment_query((x, y0), (x, y1), 0.0)
                first = space.segment_query_first((x, y0), (x, y1), 0.0, _MOTION_FILTER)
                if (
                    alone is not None
                    and alone.alpha < 1.0
                    and (first is None or first.shape is not post)
                ):
                    turned_away += 1
                expected = 1.0 if first is None else first.alpha
                assert ray_fraction(g, 0, x, y0, x, y1) == expected
                assert line_of_sight(g, 0, x, y0, x, y1, -1) == (first is None)
    assert turned_away >= 30


def test_the_tree_decides_between_hits_an_ulp_apart() -> None:
    """Up the axis of the left boundary wall, through the bottom-left corner, the two
    walls' end caps are hit an ulp or so apart. pymunk does not always keep the
    smallest alpha: which cap its tree tries first, and whether the bound from the
    first prunes the second, decides. The kernels answer as pymunk does."""
    layout = LAYOUTS[5]
    g = set_world(empty_geometry(1), 0, layout, WALL)
    space = space_of(layout)
    static = [s for s in space.shapes if s.body.body_type == pymunk.Body.STATIC]
    rng = np.random.default_rng(12)
    not_smallest = 0
    for _ in range(300):
        a, b = (-WALL, float(rng.uniform(-3.0, -0.3))), (-WALL, float(rng.uniform(0.5, 3.0)))
        expected = pymunk_alpha(space, (*a, *b))
        alphas = [
            hit.alpha
            for shape in static
            if shape.bb.segment_query(a, b) < 1.0
            and (hit := shape.segment_query(a, b, 0.0)) is not None
        ]
        not_smallest += expected != min(alphas, default=1.0)
        assert ray_fraction(g, 0, *a, *b) == expected
    assert not_smallest >= 3


def row_layout(n: int) -> Layout:
    """n posts in a row: Chipmunk's tree over them is a chain, deeper than 63 levels."""
    return Layout(
        width=n + 2.0,
        height=4.0,
        landmark_ids=tuple(range(n)),
        landmark_positions=tuple((1.0 + k, 2.0) for k in range(n)),
        start_pose=(0.5, 0.5, 0.0),
    ).validate(RobotConfig().radius, wall_thickness=WALL)


def test_deep_trees_agree_with_pymunk() -> None:
    layout = row_layout(100)
    g = set_world(empty_geometry(1), 0, layout, WALL)
    depth, node = 0, int(np.flatnonzero(g.tree[0, :, 2] == 4 + 99)[0])  # the last post
    while g.tree[0, node, 3] >= 0:
        node, depth = g.tree[0, node, 3], depth + 1
    assert depth > 64
    rng = np.random.default_rng(13)
    n = 600
    # along the row, through it at a slant, and anywhere
    starts = np.column_stack([rng.uniform(-0.5, 20.0, n), rng.uniform(1.85, 2.15, n)])
    ends = np.column_stack([rng.uniform(60.0, 103.0, n), rng.uniform(1.85, 2.15, n)])
    ends[::3, 1] = rng.uniform(-1.0, 5.0, n)[::3]
    rays = np.column_stack([starts, ends])
    rays[1::2] = rays[1::2][:, [2, 3, 0, 1]]  # and backwards
    rays = np.vstack([rays, grazing_rays(layout, rng)[::7]])
    skips = rng.integers(-1, 100, len(rays)).astype(np.int64)
    alphas = assert_agrees(layout, np.ascontiguousarray(rays), skips)
    assert np.mean(alphas < 1.0) > 0.5


# ----------------------------------------------------------------------------- batches


def test_worlds_in_a_batch_are_independent() -> None:
    """World b of a batch answers as the same layout alone does, whatever the other
    worlds hold, before and after they are rewritten (growing the arrays)."""
    layouts = LAYOUTS[:4]
    g = empty_geometry(len(layouts))
    for b, layout in enumerate(layouts):
        g = set_world(g, b, layout, WALL)
    rng = np.random.default_rng(9)
    q = 3000
    worlds = rng.integers(0, len(layouts), q)
    segs = np.column_stack([rng.uniform(-0.5, 16.5, (q, 2)), rng.uniform(-0.5, 16.5, (q, 2))])
    skips = rng.integers(-1, 10, q)

    def batch(g: StaticGeometry, worlds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        alphas, visible = np.empty(q), np.empty(q, dtype=np.bool_)
        ray_fractions(g, worlds, segs, alphas)
        lines_of_sight(g, worlds, segs, skips, visible)
        return alphas, visible

    alphas, visible = batch(g, worlds)
    for b, layout in enumerate(layouts):
        alone = set_world(empty_geometry(1), 0, layout, WALL)
        mask = worlds == b
        a1, v1 = batch(alone, np.zeros(q, dtype=np.int64))
        assert np.array_equal(alphas[mask], a1[mask]) and np.array_equal(visible[mask], v1[mask])
    g = set_world(g, 3, LAYOUTS[2], WALL)  # more rows than world 3 had: the arrays grow
    after, after_visible = batch(g, worlds)
    keep = worlds != 3
    assert np.array_equal(after[keep], alphas[keep])
    assert np.array_equal(after_visible[keep], visible[keep])


def test_range_scan_is_the_ray_fraction_of_each_beam() -> None:
    layout = LAYOUTS[6]  # cluttered
    g = set_world(empty_geometry(1), 0, layout, WALL)
    space = space_of(layout)
    rng = np.random.default_rng(11)
    angles = np.linspace(-math.pi, math.pi, 16, endpoint=False)
    out = np.empty(16)
    for _ in range(100):
        x, y = rng.uniform(0.3, layout.width - 0.3, 2).tolist()
        theta, reach = float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(0.5, 6.0))
        range_scan(g, 0, x, y, theta, angles, reach, out)
        for k, a in enumerate(angles.tolist()):
            end = (x + reach * math.cos(theta + a), y + reach * math.sin(theta + a))
            assert out[k] == pymunk_alpha(space, (x, y, *end)) * reach


@kernel
def _near(g: StaticGeometry, x: float, y: float, reach: float, out: np.ndarray) -> int:
    return near_leaves(g, 0, x, y, reach, out)


@kernel
def _entry(g: StaticGeometry, node: int, ax: float, ay: float, bx: float, by: float) -> float:
    return _node_entry(g.tree_boxes, 0, node, ax, ay, bx, by)


@pytest.mark.parametrize("index", range(len(LAYOUTS)), ids=IDS)
def test_the_near_leaves_hold_every_box_a_beam_can_enter(index: int) -> None:
    """What the scan tries of a world: every leaf whose box some segment from the
    origin, no longer than the reach, enters (beams of exactly the reach, rounded as
    the scan rounds them, included), and fewer leaves than the world has where the
    reach is short."""
    layout = LAYOUTS[index]
    g = set_world(empty_geometry(1), 0, layout, WALL)
    leaves = np.flatnonzero(g.tree[0, :, 2] >= 0)
    out = np.empty(g.tree.shape[1], dtype=np.int64)
    rng = np.random.default_rng(300 + index)
    pruned = 0
    for _ in range(150):
        x, y = rng.uniform((-0.5, -0.5), (layout.width + 0.5, layout.height + 0.5)).tolist()
        reach = float(rng.uniform(0.1, 6.0))
        near = set(out[: _near(g, x, y, reach, out)].tolist())
        assert near <= set(leaves.tolist())
        pruned += len(near) < len(leaves)
        for heading in rng.uniform(-math.pi, math.pi, 24).tolist():
            length = reach if rng.random() < 0.5 else float(rng.uniform(0.0, reach))
            end = (x + length * math.cos(heading), y + length * math.sin(heading))
            entered = {int(n) for n in leaves if _entry(g, int(n), x, y, *end) < 1.0}
            assert entered <= near, (x, y, reach, heading)
    assert pruned > 50


@kernel
def _one_call(
    g: StaticGeometry,
    x: float,
    y: float,
    reach: float,
    segments: np.ndarray,
    targets: np.ndarray,
    skips: np.ndarray,
    k: int,
    fractions: np.ndarray,
    clear: np.ndarray,
) -> int:
    """A world's queries as the sensors make them: the leaves near (x, y) within
    ``reach`` (or all of them for an infinite reach), then every segment and every
    sight line in one call each. Returns how many leaves were tried."""
    leaves = np.empty(g.tree.shape[1], dtype=np.int64)
    if math.isinf(reach):
        count = all_leaves(g, 0, leaves)
    else:
        count = near_leaves(g, 0, x, y, reach, leaves)
    segment_fractions(g, 0, leaves, count, segments, fractions, np.empty_like(leaves))
    sight_lines(g, 0, leaves, count, x, y, targets, skips, k, clear)
    return count


@pytest.mark.parametrize("index", range(len(LAYOUTS)), ids=IDS)
def test_a_worlds_queries_in_one_call_are_pymunks(index: int) -> None:
    """segment_fractions and sight_lines answer many queries from one origin in one
    call, bit for bit as pymunk answers each: against all the leaves, and against the
    near leaves for queries no longer than the reach (the sensors' use); only the
    first k sight lines are written, each skipping its own post (or none)."""
    layout = LAYOUTS[index]
    g = set_world(empty_geometry(1), 0, layout, WALL)
    space = space_of(layout)
    posts = layout.landmark_array()
    rng = np.random.default_rng(700 + index)
    for _ in range(40):
        x, y = rng.uniform(0.2, (layout.width - 0.2, layout.height - 0.2)).tolist()
        reach = float(rng.uniform(0.5, 6.0))
        q = int(rng.integers(1, 20))
        heading = rng.uniform(-math.pi, math.pi, q)
        length = reach * rng.uniform(0.0, 1.0, q)
        segments = np.stack(
            [
                np.full(q, x),
                np.full(q, y),
                x + length * np.cos(heading),
                y + length * np.sin(heading),
            ],
            axis=1,
        )
        skips = np.full(q, -1)
        if len(posts):  # about half the sight lines end on a post, skipping it
            on_post = np.flatnonzero(rng.random(q) < 0.5)
            skips[on_post] = rng.integers(0, len(posts), on_post.size)
            segments[on_post, 2:] = posts[skips[on_post]]
        targets = np.ascontiguousarray(segments[:, 2:])
        reach = max(reach, float(np.hypot(*(targets - (x, y)).T).max()))
        k = int(rng.integers(0, q + 1))
        expected = np.array([pymunk_alpha(space, seg) for seg in segments.tolist()])
        expected_clear = [
            pymunk_alpha(space, seg, int(skip)) == 1.0
            for seg, skip in zip(segments[:k].tolist(), skips[:k].tolist(), strict=True)
        ]
        for limit in (reach, math.inf):
            fractions = np.full(q, -1.0)
            clear = np.zeros(q, dtype=np.bool_)
            sentinel = ~np.zeros(q - k, dtype=np.bool_)
            clear[k:] = sentinel
            _one_call(g, x, y, limit, segments, targets, skips, k, fractions, clear)
            assert np.array_equal(fractions.view(np.uint64), expected.view(np.uint64))
            assert clear[:k].tolist() == expected_clear
            assert clear[k:].all()  # past k: left as they were


@kernel
def _count_visible(g: StaticGeometry, targets: np.ndarray) -> tuple[int, float]:
    """A kernel of the sensing kind: per world and landmark, the line of sight from
    (1, 1) to the landmark, and the smallest ray fraction towards one."""
    seen, closest = 0, 1.0
    for b in range(g.counts.shape[0]):
        for i in range(g.counts[b, 2]):
            tx, ty = targets[b, i, 0], targets[b, i, 1]
            seen += line_of_sight(g, b, 1.0, 1.0, tx, ty, i)
            closest = min(closest, ray_fraction(g, b, 1.0, 1.0, tx, ty))
    return seen, closest


def test_the_queries_compose_inside_other_kernels() -> None:
    """line_of_sight and ray_fraction are compiled functions that another kernel calls
    per world and candidate (the sensing kernel's use)."""
    g = empty_geometry(2)
    targets = np.zeros((2, 30, 2))
    expected_seen, expected_closest = 0, 1.0
    for b, layout in enumerate(LAYOUTS[:2]):
        g = set_world(g, b, layout, WALL)
        pts = layout.landmark_array()
        targets[b, : len(pts)] = pts
        space = space_of(layout)
        for i, p in enumerate(pts.tolist()):
            expected_seen += pymunk_alpha(space, (1.0, 1.0, *p), i) == 1.0
            expected_closest = min(expected_closest, pymunk_alpha(space, (1.0, 1.0, *p)))
    assert _count_visible(g, targets) == (expected_seen, expected_closest)
    assert 0 < expected_seen < sum(layout.n_landmarks for layout in LAYOUTS[:2])
