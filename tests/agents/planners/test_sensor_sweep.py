"""The sensor footprint, the coverage map and box sums (agents.planners.sensor_sweep)."""

from __future__ import annotations

import math

import numpy as np

from agents.planners.grid_map import GridMap
from agents.planners.sensor_sweep import CoverageMap, box_sum, sensor_footprint
from tests.agents.grid_worlds import box_obstacle, small_layout


def test_sweep_marks_cells_inside_range_and_fov_only():
    grid = GridMap.from_layout(small_layout(), resolution=0.5)
    pose = (5.0, 3.0, 0.0)
    ii, jj = sensor_footprint(grid, pose, max_range=3.0, fov=math.pi / 2)
    seen = np.zeros(grid.shape, dtype=bool)
    seen[ii, jj] = True
    assert seen[grid.cell_of(7.2, 3.2)]  # ahead, in range
    assert seen[grid.cell_of(6.7, 4.2)]  # ahead-left, inside ±45°
    assert not seen[grid.cell_of(3.2, 3.2)]  # behind
    assert not seen[grid.cell_of(5.2, 5.2)]  # 90° to the left: outside the FOV
    assert not seen[grid.cell_of(8.7, 3.2)]  # beyond the range
    # Every marked centre really is inside the sector.
    dx, dy = grid.xs[jj] - pose[0], grid.ys[ii] - pose[1]
    assert np.all(np.hypot(dx, dy) <= 3.0)
    assert np.all(np.abs(np.arctan2(dy, dx)) <= math.pi / 4)


def test_sweep_does_not_see_through_obstacles():
    layout = small_layout(obstacles=[box_obstacle(6.5, 3.0, 0.6, 1.0)])
    grid = GridMap.from_layout(layout, resolution=0.5)
    fine = GridMap.from_layout(layout, resolution=0.25)
    ii, jj = sensor_footprint(grid, (5.0, 3.0, 0.0), 4.0, math.pi / 2, occluders=fine)
    seen = np.zeros(grid.shape, dtype=bool)
    seen[ii, jj] = True
    assert seen[grid.cell_of(5.7, 3.2)]  # in front of the obstacle
    assert not seen[grid.cell_of(8.2, 3.2)]  # straight behind it
    assert seen[grid.cell_of(8.2, 4.7)]  # beside it, in the clear


def test_coverage_map_counts_new_cells_and_abandons_hidden_ones():
    grid = GridMap.from_layout(small_layout(), resolution=0.5)
    cov = CoverageMap(grid, max_range=3.0, fov=math.pi / 2)
    first = cov.sweep((5.0, 3.0, 0.0))
    assert first > 0
    assert cov.sweep((5.0, 3.0, 0.0)) == 0  # nothing new from the same pose
    assert 0.0 < cov.fraction_swept() < 1.0
    behind = grid.cell_of(4.2, 3.2)
    assert cov.unswept[behind]
    assert cov.expose((5.0, 3.0), radius=1.0, limit=3) == 0
    for _ in range(3):
        cov.expose((5.0, 3.0), radius=1.0, limit=3)
    assert cov.abandoned[behind] and not cov.unswept[behind]
    assert not cov.abandoned[grid.cell_of(1.2, 1.2)]


def test_box_sum_matches_a_brute_force_window_count():
    rng = np.random.default_rng(0)
    mask = rng.random((7, 9)) < 0.4
    out = box_sum(mask, 2)
    for i in range(7):
        for j in range(9):
            expected = mask[max(i - 2, 0) : i + 3, max(j - 2, 0) : j + 3].sum()
            assert out[i, j] == expected
