"""Planning utilities of the exploration agents: known map, search, control, sweeps."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from agents.navigation import (
    ControllerParams,
    CoverageMap,
    GridMap,
    PathFollower,
    StuckDetector,
    astar,
    box_sum,
    dijkstra,
    nearest_passable,
    path_from_parents,
    sensor_footprint,
    unicycle_control,
)
from slam_env.layouts import Layout

ROBOT_INFLATION = 0.35  # m: robot radius 0.25 + margin


def _box(cx: float, cy: float, w: float, h: float) -> tuple[tuple[float, float], ...]:
    """An axis-aligned box obstacle (counter-clockwise)."""
    return (
        (cx - w / 2, cy - h / 2),
        (cx + w / 2, cy - h / 2),
        (cx + w / 2, cy + h / 2),
        (cx - w / 2, cy + h / 2),
    )


def _layout(obstacles=(), walls=(), landmarks=((9.5, 5.5),)) -> Layout:
    return Layout(
        width=10.0,
        height=6.0,
        landmark_ids=tuple(range(len(landmarks))),
        landmark_positions=landmarks,
        obstacles=obstacles,
        walls=walls,
        start_pose=(1.0, 3.0, 0.0),
    )


def _cells_hit_box(grid: GridMap, cells, box) -> bool:
    """Whether any of the cells' centres lies inside the box (xmin, ymin, xmax, ymax)."""
    x0, y0, x1, y1 = box
    for i, j in cells:
        x, y = grid.center(i, j)
        if x0 <= x <= x1 and y0 <= y <= y1:
            return True
    return False


# --------------------------------------------------------------------------- the known map


def test_grid_clearance_is_signed_distance_to_the_known_map():
    grid = GridMap.from_layout(_layout(obstacles=[_box(5.0, 3.0, 2.0, 2.0)]), resolution=0.25)
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
    a = GridMap.from_layout(_layout(landmarks=((1.0, 1.0), (8.0, 5.0))))
    b = GridMap.from_layout(_layout(landmarks=((5.0, 3.0),)))
    np.testing.assert_array_equal(a.clearance, b.clearance)


def test_inner_walls_have_thickness():
    grid = GridMap.from_layout(_layout(walls=[(5.0, 0.0, 5.0, 6.0)]), resolution=0.25)
    i, j = grid.cell_of(5.6, 3.0)  # centre x = 5.625: 0.625 from the axis, 0.525 from the face
    assert grid.clearance[i, j] == pytest.approx(0.525, abs=1e-9)


def test_passable_blocks_discs_around_estimated_posts():
    grid = GridMap.from_layout(_layout(), resolution=0.25)
    free = grid.passable(ROBOT_INFLATION, np.array([[5.0, 3.0]]), disc_radius=0.45)
    assert not free[grid.cell_of(5.1, 3.1)]
    assert free[grid.cell_of(5.8, 3.1)]
    assert grid.passable(ROBOT_INFLATION)[grid.cell_of(5.1, 3.1)]


def test_line_of_sight_is_blocked_by_obstacles_only():
    grid = GridMap.from_layout(_layout(obstacles=[_box(5.0, 3.0, 1.0, 1.0)]), resolution=0.25)
    targets = np.array([[8.0, 3.0], [8.0, 5.5], [3.0, 3.0]])
    np.testing.assert_array_equal(grid.line_of_sight((2.0, 3.0), targets), [False, True, True])


# --------------------------------------------------------------------------- search


def test_astar_goes_around_an_obstacle():
    box = _box(5.0, 3.0, 2.0, 4.0)  # x 4..6, y 1..5: gaps of 1 m above and below
    grid = GridMap.from_layout(_layout(obstacles=[box]), resolution=0.25)
    free = grid.passable(ROBOT_INFLATION)
    start, goal = grid.cell_of(1.0, 3.0), grid.cell_of(9.0, 3.0)
    path = astar(free, start, goal)
    assert path is not None
    assert path[0] == start and path[-1] == goal
    assert all(free[c] for c in path)
    steps = np.abs(np.diff(np.array(path), axis=0))
    assert steps.max() == 1  # 8-connected, contiguous
    # It detours through a gap: never through the (inflated) box.
    assert not _cells_hit_box(grid, path, (4.0 - 0.35, 1.0 - 0.35, 6.0 + 0.35, 5.0 + 0.35))
    assert max(abs(grid.center(*c)[1] - 3.0) for c in path) > 2.0
    # Its cost matches the Dijkstra distance field.
    dist, parent = dijkstra(free, [start], resolution=grid.resolution)
    length = sum(
        grid.resolution * math.hypot(a[0] - b[0], a[1] - b[1]) for a, b in itertools.pairwise(path)
    )
    assert dist[goal] == pytest.approx(length)
    assert path_from_parents(parent, goal, grid.nx)[0] == start


def test_no_path_through_a_wall():
    grid = GridMap.from_layout(_layout(walls=[(5.0, 0.0, 5.0, 6.0)]), resolution=0.25)
    free = grid.passable(ROBOT_INFLATION)
    start, goal = grid.cell_of(1.0, 3.0), grid.cell_of(9.0, 3.0)
    assert astar(free, start, goal) is None
    dist, _ = dijkstra(free, [start], resolution=grid.resolution)
    assert math.isinf(dist[goal])
    assert math.isfinite(dist[grid.cell_of(4.0, 5.0)])  # the start's side is reachable


def test_a_door_in_the_wall_lets_the_path_through():
    walls = [(5.0, 0.0, 5.0, 2.5), (5.0, 3.8, 5.0, 6.0)]  # a 1.3 m door
    grid = GridMap.from_layout(_layout(walls=walls), resolution=0.25)
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


# --------------------------------------------------------------------------- control


def test_controller_turns_on_the_spot_toward_a_waypoint_behind():
    params = ControllerParams()
    left = unicycle_control((0.0, 0.0, 0.0), (-2.0, 0.3), params)
    right = unicycle_control((0.0, 0.0, 0.0), (-2.0, -0.3), params)
    for action in (left, right):
        assert action.dtype == np.float32 and action.shape == (2,)
        assert action[0] == 0.0  # heading error > turn_in_place: no forward motion
        assert abs(action[1]) == pytest.approx(1.0)  # saturated turn
    assert left[1] > 0.0 > right[1]
    ahead = unicycle_control((0.0, 0.0, 0.0), (3.0, 0.0), params)
    assert ahead[0] == pytest.approx(1.0) and ahead[1] == pytest.approx(0.0)
    slight = unicycle_control((0.0, 0.0, 0.0), (3.0, 0.5), params)
    assert 0.0 < slight[0] < 1.0 and slight[1] > 0.0
    gentle = unicycle_control((0.0, 0.0, 0.0), (-2.0, 0.3), ControllerParams(turn_limit=0.5))
    assert gentle[1] == pytest.approx(0.5)


def test_controller_drives_a_unicycle_to_a_waypoint_behind():
    params = ControllerParams()
    x, y, th = 0.0, 0.0, 0.0
    goal = (-2.0, 1.0)
    for step in range(60):
        v_frac, w_frac = unicycle_control((x, y, th), goal, params, stop_distance=0.0)
        if step < 3:
            assert v_frac == 0.0  # it first turns around
        v, w = v_frac * params.max_speed, w_frac * params.max_turn_rate
        x += v * params.dt * math.cos(th)
        y += v * params.dt * math.sin(th)
        th += w * params.dt
        if math.hypot(x - goal[0], y - goal[1]) < 0.1:
            break
    assert math.hypot(x - goal[0], y - goal[1]) < 0.1


def test_path_follower_tracks_an_l_shaped_path():
    params = ControllerParams()
    points = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    follower = PathFollower(points, lookahead=0.5, params=params)
    x, y, th = 0.0, 0.0, 0.0
    worst = 0.0
    for _ in range(60):
        v_frac, w_frac = follower.action((x, y, th))
        x += v_frac * params.max_speed * params.dt * math.cos(th)
        y += v_frac * params.max_speed * params.dt * math.sin(th)
        th += w_frac * params.max_turn_rate * params.dt
        off = min(abs(y) if x <= 2.0 else math.inf, abs(x - 2.0) if y >= 0.0 else math.inf)
        worst = max(worst, min(off, math.hypot(x - 2.0, y)))
    assert math.hypot(x - 2.0, y - 2.0) < 0.3
    assert worst < 0.5  # stays near the path


# --------------------------------------------------------------------------- sweeps


def test_sweep_marks_cells_inside_range_and_fov_only():
    grid = GridMap.from_layout(_layout(), resolution=0.5)
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
    layout = _layout(obstacles=[_box(6.5, 3.0, 0.6, 1.0)])
    grid = GridMap.from_layout(layout, resolution=0.5)
    fine = GridMap.from_layout(layout, resolution=0.25)
    ii, jj = sensor_footprint(grid, (5.0, 3.0, 0.0), 4.0, math.pi / 2, occluders=fine)
    seen = np.zeros(grid.shape, dtype=bool)
    seen[ii, jj] = True
    assert seen[grid.cell_of(5.7, 3.2)]  # in front of the obstacle
    assert not seen[grid.cell_of(8.2, 3.2)]  # straight behind it
    assert seen[grid.cell_of(8.2, 4.7)]  # beside it, in the clear


def test_coverage_map_counts_new_cells_and_abandons_hidden_ones():
    grid = GridMap.from_layout(_layout(), resolution=0.5)
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


def test_stuck_detector_fires_only_when_commanded_motion_does_not_happen():
    det = StuckDetector(steps=4, step_length=0.2)
    assert not any(det.update((0.2 * k, 0.0), 1.0) for k in range(10))  # moving: fine
    det.clear()
    assert not any(det.update((0.0, 0.0), 0.0) for _ in range(10))  # standing still on purpose
    det.clear()
    flags = [det.update((0.0, 0.01 * k), 1.0) for k in range(5)]
    assert flags == [False, False, False, False, True]
