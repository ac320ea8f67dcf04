"""The compiled distance to the nearest static shape against pymunk's point queries:
the same distance to round-off, on random points of random worlds and on points a
hair off each shape's surface, and 0 inside a shape."""

from __future__ import annotations

import numpy as np
import pytest

from slam_env.config import RobotConfig
from slam_env.kernels.world.clearance import clearance, clearance_among
from slam_env.kernels.world.raycast import all_leaves, near_leaves
from slam_env.kernels.world.static_geometry import empty_geometry
from slam_env.world.pymunk_world import _MOTION_FILTER, World
from slam_env.world.static_shapes import set_world, static_shapes
from tests.kernels.geometry_worlds import WALL, world_layouts

LAYOUTS = world_layouts()
IDS = [f"{k}-{layout.name}" for k, layout in enumerate(LAYOUTS)]


def near_surfaces(layout, rng: np.random.Generator) -> np.ndarray:
    """Points within a millimetre of every shape's surface, both sides: around posts,
    along and at the ends of walls, at and between obstacles' vertices."""
    shapes = static_shapes(layout, WALL)
    points = []
    for (cx, cy), r in shapes.circles:
        angle = rng.uniform(0, 2 * np.pi, 8)
        dist = r + rng.uniform(-1e-3, 1e-3, 8)
        points += list(zip(cx + dist * np.cos(angle), cy + dist * np.sin(angle), strict=True))
    for (ax, ay), (bx, by), r in shapes.segments:
        t = np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 6)])
        angle = rng.uniform(0, 2 * np.pi, 8)
        dist = r + rng.uniform(-1e-3, 1e-3, 8)
        x = ax + t * (bx - ax) + dist * np.cos(angle)
        y = ay + t * (by - ay) + dist * np.sin(angle)
        points += list(zip(x, y, strict=True))
    for polygon in shapes.polygons:
        vertices = np.array(polygon)
        for i in range(len(vertices)):
            a, b = vertices[i - 1], vertices[i]
            for t in (0.0, rng.uniform()):
                p = a + t * (b - a) + rng.uniform(-1e-3, 1e-3, 2)
                points.append(tuple(p))
    return np.array(points)


@pytest.mark.parametrize("index", range(len(LAYOUTS)), ids=IDS)
def test_clearance_is_the_distance_of_pymunks_point_query(index: int) -> None:
    layout = LAYOUTS[index]
    rng = np.random.default_rng(index)
    geometry = set_world(empty_geometry(1), 0, layout, WALL)
    space = World(layout, RobotConfig(), 0.2, 4, WALL, validated=True).space
    uniform = rng.uniform((-0.5, -0.5), (layout.width + 0.5, layout.height + 0.5), (400, 2))
    points = np.concatenate([uniform, near_surfaces(layout, rng)])
    inside = 0
    for x, y in points.tolist():
        hit = space.point_query_nearest((x, y), 1e6, _MOTION_FILTER)
        expected = max(hit.distance, 0.0)
        inside += hit.distance < 0.0
        assert clearance(geometry, 0, x, y) == pytest.approx(expected, abs=1e-12), (x, y)
    assert inside > 10  # the points inside shapes were asked about too


def test_clearance_reads_its_own_worlds_row() -> None:
    first, second = LAYOUTS[0], LAYOUTS[-1]
    geometry = set_world(empty_geometry(2), 0, first, WALL)
    geometry = set_world(geometry, 1, second, WALL)
    alone = set_world(empty_geometry(1), 0, second, WALL)
    for x, y in [(1.0, 1.0), (3.0, 4.0), (5.5, 2.5)]:
        assert clearance(geometry, 1, x, y) == clearance(alone, 0, x, y)


@pytest.mark.parametrize("index", range(len(LAYOUTS)), ids=IDS)
def test_the_distance_among_the_near_shapes_is_the_distance(index: int) -> None:
    """Over every leaf, the distance among the leaves is the distance, bit for bit;
    over the leaves near a point, it is wherever a shape lies within that reach (and
    at least the reach where none does), as the motion kernel relies on."""
    layout = LAYOUTS[index]
    rng = np.random.default_rng(100 + index)
    geometry = set_world(empty_geometry(1), 0, layout, WALL)
    leaves = np.empty(geometry.tree.shape[1], dtype=np.int64)
    count = all_leaves(geometry, 0, leaves)
    uniform = rng.uniform((-0.5, -0.5), (layout.width + 0.5, layout.height + 0.5), (300, 2))
    points = np.concatenate([uniform, near_surfaces(layout, rng)])
    kinds = set()
    for x, y in points.tolist():
        whole = clearance(geometry, 0, x, y)
        assert clearance_among(geometry, 0, x, y, leaves, count) == whole
        reach = rng.uniform(0.1, 2.0)
        near = near_leaves(geometry, 0, x, y, reach, leaves)
        among = clearance_among(geometry, 0, x, y, leaves, near)
        if whole <= reach:
            assert among == whole, (x, y, reach)
            kinds.add("within")
        else:
            assert among >= reach, (x, y, reach)
            kinds.add("beyond")
        count = all_leaves(geometry, 0, leaves)
    assert kinds == {"within", "beyond"}
