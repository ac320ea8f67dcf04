"""The known map on a grid, for the heuristic agents' planning and sweeping.

:class:`GridMap` rasterises what a robot is given before it starts (the layout's
arena, obstacles and inner walls; never the landmarks or the true pose): the signed
clearance (m) of every cell centre to the nearest obstacle, wall or arena edge;
``passable(inflation)`` is the configuration space of a disc robot, ``opaque`` what
blocks the sensor.

Conventions: a grid has ``shape = (ny, nx)``; cell ``(i, j)`` (row ``i`` along y,
column ``j`` along x) covers ``[j·res, (j+1)·res] × [i·res, (i+1)·res]`` and its
centre is ``((j + ½)·res, (i + ½)·res)``. Flat indices are ``i·nx + j``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from slam_env.world.layouts import DEFAULT_WALL_THICKNESS, Layout


def _segment_distances(
    px: np.ndarray, py: np.ndarray, x0: float, y0: float, x1: float, y1: float
) -> np.ndarray:
    """Distance (m) from each point (px, py) (arrays of one shape) to a segment."""
    ex, ey = x1 - x0, y1 - y0
    ee = ex * ex + ey * ey
    dx, dy = px - x0, py - y0
    t = np.clip((dx * ex + dy * ey) / ee, 0.0, 1.0) if ee > 0.0 else np.zeros_like(px)
    return np.hypot(dx - t * ex, dy - t * ey)


def _polygon_signed_distances(
    px: np.ndarray, py: np.ndarray, poly: Sequence[tuple[float, float]]
) -> np.ndarray:
    """Signed distance (m) from each point to a convex counter-clockwise polygon:
    negative inside."""
    inside = np.ones(px.shape, dtype=bool)
    best = np.full(px.shape, np.inf)
    x0, y0 = poly[-1]
    for x1, y1 in poly:
        inside &= (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0) >= 0.0
        np.minimum(best, _segment_distances(px, py, x0, y0, x1, y1), out=best)
        x0, y0 = x1, y1
    return np.where(inside, -best, best)


class GridMap:
    """The known map on a regular grid.

    Args:
        width, height: the arena [0, width] × [0, height] (m).
        resolution: the cell side (m).
        clearance: (ny, nx) signed distance (m) from each cell centre to the nearest
            obstacle surface, wall surface or arena edge; negative inside one.

    Build it with :meth:`from_layout`.
    """

    def __init__(self, width: float, height: float, resolution: float, clearance: np.ndarray):
        if not (resolution > 0.0 and math.isfinite(resolution)):
            raise ValueError(f"resolution must be finite and > 0, got {resolution!r}")
        self.width = float(width)
        self.height = float(height)
        self.resolution = float(resolution)
        self.clearance = np.asarray(clearance, dtype=np.float64)
        self.ny, self.nx = self.clearance.shape
        self.xs = (np.arange(self.nx) + 0.5) * self.resolution  # (nx,) cell-centre x, m
        self.ys = (np.arange(self.ny) + 0.5) * self.resolution  # (ny,) cell-centre y, m
        self.opaque = self.clearance <= 0.0  # (ny, nx) cells that block the sensor

    @classmethod
    def from_layout(
        cls,
        layout: Layout,
        resolution: float = 0.25,
        wall_thickness: float = DEFAULT_WALL_THICKNESS,
    ) -> GridMap:
        """Rasterise a layout's known map (arena edge, obstacles, inner walls of
        half-thickness ``wall_thickness``). Landmark posts are not part of it."""
        if not (resolution > 0.0 and math.isfinite(resolution)):
            raise ValueError(f"resolution must be finite and > 0, got {resolution!r}")
        w, h = float(layout.width), float(layout.height)
        nx = max(1, math.ceil(w / resolution - 1e-9))
        ny = max(1, math.ceil(h / resolution - 1e-9))
        xs = (np.arange(nx) + 0.5) * resolution
        ys = (np.arange(ny) + 0.5) * resolution
        px, py = np.meshgrid(xs, ys)  # (ny, nx)
        clear = np.minimum(np.minimum(px, w - px), np.minimum(py, h - py))
        for poly in layout.obstacles:
            np.minimum(clear, _polygon_signed_distances(px, py, poly), out=clear)
        for x0, y0, x1, y1 in layout.walls:
            d = _segment_distances(px, py, x0, y0, x1, y1) - wall_thickness
            np.minimum(clear, d, out=clear)
        return cls(w, h, resolution, clear)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.ny, self.nx)

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(i, j) of the cell holding (x, y), clipped to the grid."""
        j = min(max(math.floor(x / self.resolution), 0), self.nx - 1)
        i = min(max(math.floor(y / self.resolution), 0), self.ny - 1)
        return i, j

    def cells_of(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(i, j) index arrays of the cells holding ``points`` (..., 2), clipped."""
        points = np.asarray(points, dtype=np.float64)
        j = np.clip(np.floor(points[..., 0] / self.resolution), 0, self.nx - 1).astype(np.intp)
        i = np.clip(np.floor(points[..., 1] / self.resolution), 0, self.ny - 1).astype(np.intp)
        return i, j

    def center(self, i: int, j: int) -> tuple[float, float]:
        """The world coordinates (m) of cell (i, j)'s centre."""
        return float(self.xs[j]), float(self.ys[i])

    def passable(
        self,
        inflation: float,
        discs: np.ndarray | None = None,
        disc_radius: float = 0.0,
    ) -> np.ndarray:
        """(ny, nx) bool: cells whose centre keeps ``inflation`` (m) from the known map
        and ``disc_radius`` (m) from each of the points ``discs`` (k, 2) — e.g. the
        estimated landmark posts, inflated by the robot radius."""
        free = self.clearance > inflation
        if discs is not None and len(discs) and disc_radius > 0.0:
            r = disc_radius
            for x, y in np.asarray(discs, dtype=np.float64).reshape(-1, 2).tolist():
                j0 = max(math.floor((x - r) / self.resolution), 0)
                j1 = min(math.ceil((x + r) / self.resolution) + 1, self.nx)
                i0 = max(math.floor((y - r) / self.resolution), 0)
                i1 = min(math.ceil((y + r) / self.resolution) + 1, self.ny)
                if j0 >= j1 or i0 >= i1:
                    continue
                dx = self.xs[j0:j1] - x
                dy = self.ys[i0:i1, None] - y
                free[i0:i1, j0:j1] &= dx * dx + dy * dy > r * r
        return free

    def line_of_sight(
        self, origin: Sequence[float], targets: np.ndarray, step: float | None = None
    ) -> np.ndarray:
        """(k,) bool: whether the segments origin → targets (k, 2) cross no opaque cell,
        sampled every ``step`` m (default half a cell); the end points are excluded."""
        targets = np.asarray(targets, dtype=np.float64).reshape(-1, 2)
        if not len(targets):
            return np.zeros(0, dtype=bool)
        step = 0.5 * self.resolution if step is None else float(step)
        ox, oy = float(origin[0]), float(origin[1])
        dx = targets[:, 0] - ox
        dy = targets[:, 1] - oy
        n = max(1, math.ceil(float(np.max(np.hypot(dx, dy))) / step))
        t = (np.arange(1, n) / n)[None, :]  # (1, n-1), excludes both ends
        if t.size == 0:
            return np.ones(len(targets), dtype=bool)
        sx = ox + dx[:, None] * t
        sy = oy + dy[:, None] * t
        j = np.clip((sx / self.resolution).astype(np.intp), 0, self.nx - 1)
        i = np.clip((sy / self.resolution).astype(np.intp), 0, self.ny - 1)
        return ~self.opaque[i, j].any(axis=1)
