"""The pymunk world's sight queries: line of sight and range scans, compiled against
the static geometry, hold to pymunk's own segment queries on the same space."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.config import WorldConfig
from slam_env.world.layout_generators import preset_layout
from slam_env.world.pymunk_world import _MOTION_FILTER, World
from tests.world.world_samples import DT, ROBOT, SUBSTEPS, T, arena, pymunk_sees, world


def test_line_of_sight() -> None:
    w = world(
        arena(
            landmark_ids=(10, 11, 12, 13),
            landmark_positions=((8.0, 2.0), (8.0, 9.0), (2.0, 9.0), (2.0, 5.0)),
        )
    )
    pos = w.landmark_positions
    # Free space, and the target's own post does not block (the segment ends inside it).
    assert w.line_of_sight((2.0, 2.5), pos[3], 3)
    assert w.line_of_sight(np.array([2.0, 2.5]), pos[3], 3)
    # The inner wall x = 5 (y 1..4) blocks the view from (2, 2.5) to landmark 10 at (8, 2).
    assert not w.line_of_sight((2.0, 2.5), pos[0], 0)
    # The box [6, 7] × [6, 7] blocks a view across it.
    assert not w.line_of_sight((6.5, 4.0), (6.5, 9.0), 1)
    assert w.line_of_sight((5.5, 4.0), (5.5, 9.0), 1)
    # Another landmark's post blocks: (2, 2.5) → (2, 9) passes through post 13 at (2, 5).
    assert not w.line_of_sight((2.0, 2.5), pos[2], 2)
    # …but not when that post is the target.
    assert w.line_of_sight((2.0, 2.5), pos[3], 3)
    # The robot itself never blocks, wherever it is.
    w.set_pose(2.0, 4.0, 0.0)
    assert w.line_of_sight((2.0, 3.0), pos[3], 3)


def test_line_of_sight_is_pymunks_segment_query() -> None:
    w = World(preset_layout("cluttered", WorldConfig()), ROBOT, DT, SUBSTEPS, T)
    rng = np.random.default_rng(7)
    pos = w.landmark_positions
    blocked = 0
    for _ in range(500):
        x, y = rng.uniform(0, w.layout.width), rng.uniform(0, w.layout.height)
        i = int(rng.integers(len(pos)))
        expected = pymunk_sees(w, (x, y), pos[i], i)
        assert w._landmark_visible_from(x, y, i) == expected
        assert w.line_of_sight((x, y), pos[i], i) == expected
        assert w.line_of_sight((x, y), pos[i], i - len(pos)) == expected  # counted from the end
        blocked += not expected
    assert 50 < blocked < 450
    with pytest.raises(IndexError):
        w.line_of_sight((1.0, 1.0), pos[0], len(pos))


def test_range_scan_measures_the_free_distance() -> None:
    w = world()
    w.set_pose(2.0, 5.0, 0.0)
    angles = (0.0, math.pi / 2, math.pi, -math.pi / 2)
    ahead, left, behind, right = w.range_scan(*w.pose, angles, 3.0)
    assert behind == pytest.approx(2.0, abs=1e-9)  # the boundary at x = 0
    assert ahead == 3.0  # nothing within reach
    assert left == 3.0 and right == 3.0
    w.set_pose(8.0, 5.0, 0.0)
    (ahead,) = w.range_scan(*w.pose, (0.0,), 3.0)
    assert ahead == pytest.approx(2.0, abs=1e-9)  # the boundary at x = 10
    # Posts and obstacles block beams too: the box [6, 7]² seen from (3, 6.5).
    (box,) = w.range_scan(3.0, 6.5, 0.0, (0.0,), 5.0)
    assert box == pytest.approx(3.0, abs=1e-9)


def test_range_scan_is_pymunks_segment_query() -> None:
    w = World(preset_layout("rooms", WorldConfig()), ROBOT, DT, SUBSTEPS, T)
    rng = np.random.default_rng(9)
    angles = tuple(2.0 * math.pi * k / 16 for k in range(16))
    short = 0
    for _ in range(100):
        x, y = float(rng.uniform(0.3, 15.7)), float(rng.uniform(0.3, 15.7))
        theta, reach = float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(0.5, 5.0))
        scan = w.range_scan(x, y, theta, angles, reach)
        for a, distance in zip(angles, scan, strict=True):
            end = (x + reach * math.cos(theta + a), y + reach * math.sin(theta + a))
            hit = w.space.segment_query_first((x, y), end, 0.0, _MOTION_FILTER)
            assert distance == (reach if hit is None else hit.alpha * reach)
            short += hit is not None
    assert short > 100
