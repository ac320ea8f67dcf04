"""Worlds for the static-geometry tests: random layouts of several configs, the presets,
and a hand-made one with the shapes the generators never make (slanted polygons, a
collinear vertex, a clockwise obstacle, diagonal walls)."""

from __future__ import annotations

import math

import numpy as np

from slam_env.config import RobotConfig, WorldConfig
from slam_env.world.layout_generators import preset_layout, random_layout
from slam_env.world.layouts import Layout

ROBOT_RADIUS = RobotConfig().radius
WALL = WorldConfig().wall_thickness


def _regular(cx: float, cy: float, r: float, n: int, phase: float) -> tuple:
    return tuple(
        (
            cx + r * math.cos(phase + 2 * math.pi * k / n),
            cy + r * math.sin(phase + 2 * math.pi * k / n),
        )
        for k in range(n)
    )


def slanted_layout() -> Layout:
    """10 × 8 m: a triangle, a hexagon, a rotated box, a clockwise box with a collinear
    vertex, diagonal and axis-aligned inner walls, eight landmarks."""
    return Layout(
        width=10.0,
        height=8.0,
        landmark_ids=(3, 1, 4, 15, 9, 2, 6, 5),
        landmark_positions=(
            (1.0, 6.5),
            (4.5, 6.8),
            (8.8, 7.0),
            (8.5, 1.0),
            (5.2, 3.9),
            (1.2, 1.2),
            (3.0, 4.2),
            (6.9, 5.6),
        ),
        obstacles=(
            ((2.0, 2.0), (3.3, 2.4), (2.4, 3.1)),
            _regular(7.0, 3.0, 0.8, 6, 0.3),
            _regular(4.0, 5.5, 0.7, 4, math.pi / 7),
            # clockwise, with a vertex in the middle of its top edge
            ((6.0, 7.5), (7.5, 7.5), (7.5, 6.5), (6.0, 6.5), (6.0, 7.0)),
        ),
        walls=((0.5, 4.0, 2.5, 5.2), (8.8, 2.5, 8.8, 5.5)),
        start_pose=(1.0, 3.0, 0.0),
        name="slanted",
    ).validate(ROBOT_RADIUS, wall_thickness=WALL)


def world_layouts() -> list[Layout]:
    """Random worlds of several configs and seeds, the three presets, and the slanted
    world."""
    configs = [
        (WorldConfig(), 0),
        (WorldConfig(), 1),
        (WorldConfig(n_obstacles=15, n_landmarks=30), 2),
        (WorldConfig(n_obstacles=0, n_landmarks=12), 3),
        (WorldConfig(width=8.0, height=6.0, n_landmarks=8, obstacle_size=(0.3, 1.0)), 4),
    ]
    layouts = [random_layout(c, ROBOT_RADIUS, np.random.default_rng(s)) for c, s in configs]
    layouts += [preset_layout(name, WorldConfig()) for name in ("open", "cluttered", "rooms")]
    layouts.append(slanted_layout())
    return layouts
