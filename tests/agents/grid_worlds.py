"""Small known maps for the tests of the agents' grid, search and sweep modules."""

from __future__ import annotations

from agents.planners.grid_map import GridMap
from slam_env.world.layouts import Layout

ROBOT_INFLATION = 0.35  # m: robot radius 0.25 + margin


def box_obstacle(cx: float, cy: float, w: float, h: float) -> tuple[tuple[float, float], ...]:
    """An axis-aligned box obstacle (counter-clockwise)."""
    return (
        (cx - w / 2, cy - h / 2),
        (cx + w / 2, cy - h / 2),
        (cx + w / 2, cy + h / 2),
        (cx - w / 2, cy + h / 2),
    )


def small_layout(obstacles=(), walls=(), landmarks=((9.5, 5.5),)) -> Layout:
    return Layout(
        width=10.0,
        height=6.0,
        landmark_ids=tuple(range(len(landmarks))),
        landmark_positions=landmarks,
        obstacles=obstacles,
        walls=walls,
        start_pose=(1.0, 3.0, 0.0),
    )


def cells_hit_box(grid: GridMap, cells, box) -> bool:
    """Whether any of the cells' centres lies inside the box (xmin, ymin, xmax, ymax)."""
    x0, y0, x1, y1 = box
    for i, j in cells:
        x, y = grid.center(i, j)
        if x0 <= x <= x1 and y0 <= y <= y1:
            return True
    return False
