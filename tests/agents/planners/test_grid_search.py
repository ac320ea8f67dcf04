"""Searches on the grid (agents.planners.grid_search); the compiled Dijkstra against the plain one:
test_search_kernel.py."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from agents.planners.grid_map import GridMap
from agents.planners.grid_search import astar, dijkstra, nearest_passable, path_from_parents
from tests.agents.grid_worlds import ROBOT_INFLATION, box_obstacle, cells_hit_box, small_layout


def test_astar_goes_around_an_obstacle():
    box = box_obstacle(5.0, 3.0, 2.0, 4.0)  # x 4..6, y 1..5: gaps of 1 m above and below
    grid = GridMap.from_layout(small_layout(obstacles=[box]), resolution=0.25)
    free = grid.passable(ROBOT_INFLATION)
    start, goal = grid.cell_of(1.0, 3.0), grid.cell_of(9.0, 3.0)
    path = astar(free, start, goal)
    assert path is not None
    assert path[0] == start and path[-1] == goal
    assert all(free[c] for c in path)
    steps = np.abs(np.diff(np.array(path), axis=0))
    assert steps.max() == 1  # 8-connected, contiguous
    # It detours through a gap: never through the (inflated) box.
    assert not cells_hit_box(grid, path, (4.0 - 0.35, 1.0 - 0.35, 6.0 + 0.35, 5.0 + 0.35))
    assert max(abs(grid.center(*c)[1] - 3.0) for c in path) > 2.0
    # Its cost matches the Dijkstra distance field.
    dist, parent = dijkstra(free, [start], resolution=grid.resolution)
    length = sum(
        grid.resolution * math.hypot(a[0] - b[0], a[1] - b[1]) for a, b in itertools.pairwise(path)
    )
    assert dist[goal] == pytest.approx(length)
    assert path_from_parents(parent, goal, grid.nx)[0] == start


def test_no_path_through_a_wall():
    grid = GridMap.from_layout(small_layout(walls=[(5.0, 0.0, 5.0, 6.0)]), resolution=0.25)
    free = grid.passable(ROBOT_INFLATION)
    start, goal = grid.cell_of(1.0, 3.0), grid.cell_of(9.0, 3.0)
    assert astar(free, start, goal) is None
    dist, _ = dijkstra(free, [start], resolution=grid.resolution)
    assert math.isinf(dist[goal])
    assert math.isfinite(dist[grid.cell_of(4.0, 5.0)])  # the start's side is reachable


def test_a_door_in_the_wall_lets_the_path_through():
    walls = [(5.0, 0.0, 5.0, 2.5), (5.0, 3.8, 5.0, 6.0)]  # a 1.3 m door
    grid = GridMap.from_layout(small_layout(walls=walls), resolution=0.25)
    free = grid.passable(ROBOT_INFLATION)
    path = astar(free, grid.cell_of(1.0, 1.0), grid.cell_of(9.0, 1.0))
    assert path is not None
    crossing = [grid.center(*c) for c in path if abs(grid.center(*c)[0] - 5.0) < 0.2]
    assert crossing and all(2.5 < y < 3.8 for _, y in crossing)


def test_dijkstra_multi_source_is_the_nearest_source_distance():
    free = np.ones((5, 9), dtype=bool)
    dist, parent = dijkstra(free, [(2, 0), (2, 8)], resolution=0.5)
    assert dist[2, 4] == pytest.approx(2.0)  # 4 cells from either source
    assert dist[2, 1] == pytest.approx(0.5) and dist[2, 7] == pytest.approx(0.5)
    assert parent[2 * 9 + 0] == -1
    # Corner cutting is not allowed: a diagonal needs both orthogonal cells free.
    # (0, 0) only touches (1, 1) diagonally, between two blocked cells: cut off.
    free = np.ones((3, 3), dtype=bool)
    free[0, 1] = free[1, 0] = False
    dist, _ = dijkstra(free, [(0, 0)], resolution=1.0)
    assert math.isinf(dist[1, 1]) and math.isinf(dist[2, 2])
    free[0, 1] = True
    dist, _ = dijkstra(free, [(0, 0)], resolution=1.0)
    assert dist[1, 1] == pytest.approx(2.0)  # around the corner: 2 straight moves
    assert dist[2, 2] == pytest.approx(2.0 + math.sqrt(2.0))


def test_nearest_passable_finds_the_closest_free_cell():
    free = np.zeros((7, 7), dtype=bool)
    free[3, 6] = free[0, 0] = True
    assert nearest_passable(free, (3, 4)) == (3, 6)
    assert nearest_passable(free, (3, 6)) == (3, 6)
    assert nearest_passable(np.zeros((3, 3), dtype=bool), (1, 1)) is None
