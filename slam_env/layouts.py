"""World layouts: the arena, obstacles, inner walls, landmarks and start pose.

A :class:`Layout` is plain data (no pymunk): random worlds are drawn from a seed,
presets are named maps, and user worlds come from a dict or a JSON/YAML file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

Point = tuple[float, float]


@dataclass(frozen=True)
class Layout:
    """A world. The arena is the rectangle [0, width] × [0, height] (m), closed by
    boundary walls that are implicit (not listed in ``walls``).

    Attributes:
        width, height: arena size, m.
        landmark_ids: (N,) distinct non-negative ints.
        landmark_positions: (N,) (x, y) points, m, in the same order as the IDs.
        obstacles: convex polygons, each a tuple of (x, y) vertices, m.
        walls: inner wall segments (x0, y0, x1, y1), m (rooms and corridors).
        start_pose: the robot's start (x, y, θ), m and rad.
        name: a label for plots and logs.
    """

    width: float
    height: float
    landmark_ids: tuple[int, ...]
    landmark_positions: tuple[Point, ...]
    obstacles: tuple[tuple[Point, ...], ...] = ()
    walls: tuple[tuple[float, float, float, float], ...] = ()
    start_pose: tuple[float, float, float] = (1.0, 1.0, 0.0)
    name: str = "custom"

    @property
    def n_landmarks(self) -> int:
        return len(self.landmark_ids)

    def landmark_array(self) -> np.ndarray:
        """(N, 2) float64 landmark positions, a fresh array."""
        return np.array(self.landmark_positions, dtype=np.float64).reshape(-1, 2)

    def id_array(self) -> np.ndarray:
        """(N,) int64 landmark IDs, a fresh array."""
        return np.array(self.landmark_ids, dtype=np.int64)
