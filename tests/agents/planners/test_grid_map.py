"""The known map on a grid (agents.planners.grid_map)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.planners.grid_map import GridMap
from tests.agents.grid_worlds import ROBOT_INFLATION, box_obstacle, small_layout


def test_grid_clearance_is_signed_distance_to_the_known_map():
    grid = GridMap.from_layout(
        small_layout(obstacles=[box_obstacle(5.0, 3.0, 2.0, 2.0)]), resolution=0.25
    )
    assert grid.shape == (24, 40)
    i, j = grid.cell_of(5.1, 3.1)  # inside the box: negative, ~0.9 m from its edges
    assert grid.clearance[i, j] == pytest.approx(-0.875, abs=1e-9)
    i, j = grid.cell_of(2.6, 3.1)  # 1.375 m left of the box, 2.6 m from the left edge
    assert grid.clearance[i, j] == pytest.approx(1.375, abs=1e-9)
    i, j = grid.cell_of(0.1, 3.1)  # next to the arena edge
    assert grid.clearance[i, j] == pytest.approx(0.125, abs=1e-9)
    assert grid.opaque[grid.cell_of(5.0, 3.0)] and not grid.opaque[grid.cell_of(1.0, 1.0)]


def test_grid_ignores_landmarks_the_robot_has_not_mapped():
    """The known map is the arena, obstacles and walls: moving the true landmarks
    changes nothing an agent plans with."""
    a = GridMap.from_layout(small_layout(landmarks=((1.0, 1.0), (8.0, 5.0))))
    b = GridMap.from_layout(small_layout(landmarks=((5.0, 3.0),)))
    np.testing.assert_array_equal(a.clearance, b.clearance)


def test_inner_walls_have_thickness():
    grid = GridMap.from_layout(small_layout(walls=[(5.0, 0.0, 5.0, 6.0)]), resolution=0.25)
    i, j = grid.cell_of(5.6, 3.0)  # centre x = 5.625: 0.625 from the axis, 0.525 from the face
    assert grid.clearance[i, j] == pytest.approx(0.525, abs=1e-9)


def test_passable_blocks_discs_around_estimated_posts():
    grid = GridMap.from_layout(small_layout(), resolution=0.25)
    free = grid.passable(ROBOT_INFLATION, np.array([[5.0, 3.0]]), disc_radius=0.45)
    assert not free[grid.cell_of(5.1, 3.1)]
    assert free[grid.cell_of(5.8, 3.1)]
    assert grid.passable(ROBOT_INFLATION)[grid.cell_of(5.1, 3.1)]


def test_line_of_sight_is_blocked_by_obstacles_only():
    grid = GridMap.from_layout(
        small_layout(obstacles=[box_obstacle(5.0, 3.0, 1.0, 1.0)]), resolution=0.25
    )
    targets = np.array([[8.0, 3.0], [8.0, 5.5], [3.0, 3.0]])
    np.testing.assert_array_equal(grid.line_of_sight((2.0, 3.0), targets), [False, True, True])
