"""What a range-and-FOV sensor sweeps: :func:`sensor_footprint` (the cells it sees from
a pose, with occlusion by the known map; vectorised), :class:`CoverageMap` (the cells
swept during an episode) and :func:`box_sum` (cells counted in windows: the unswept
area around a candidate target)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from agents.planners.grid_map import GridMap


def sensor_footprint(
    grid: GridMap,
    pose: Sequence[float],
    max_range: float,
    fov: float,
    *,
    occluders: GridMap | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The cells of ``grid`` whose centres a range-and-FOV sensor at ``pose`` sees.

    A centre is seen when its distance is ≤ ``max_range`` (m), its bearing from the
    heading within ±``fov``/2 (rad) and, with ``occluders``, the segment to it crosses
    no opaque cell of that map. Only the window around the sensor is examined.

    Returns:
        (i, j) index arrays of the seen cells.
    """
    x, y, th = float(pose[0]), float(pose[1]), float(pose[2])
    res = grid.resolution
    j0 = max(math.floor((x - max_range) / res), 0)
    j1 = min(math.ceil((x + max_range) / res) + 1, grid.nx)
    i0 = max(math.floor((y - max_range) / res), 0)
    i1 = min(math.ceil((y + max_range) / res) + 1, grid.ny)
    empty = np.zeros(0, dtype=np.intp)
    if j0 >= j1 or i0 >= i1:
        return empty, empty
    dx = grid.xs[None, j0:j1] - x
    dy = grid.ys[i0:i1, None] - y
    inside = dx * dx + dy * dy <= max_range * max_range
    if fov < 2.0 * math.pi:
        bearing = np.arctan2(dy, dx) - th
        bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
        inside &= np.abs(bearing) <= 0.5 * fov
    ii, jj = np.nonzero(inside)
    ii += i0
    jj += j0
    if occluders is not None and len(ii):
        ok = occluders.line_of_sight(
            (x, y), np.stack([grid.xs[jj], grid.ys[ii]], axis=-1), step=occluders.resolution
        )
        ii, jj = ii[ok], jj[ok]
    return ii, jj


class CoverageMap:
    """The cells a sensor has swept during an episode, and where landmarks may be.

    Args:
        grid: the coverage grid (its ``clearance`` marks cells inside the known map's
            obstacles, which cannot hold a landmark and are never "unswept").
        max_range: m, the sensor range.
        fov: rad, the full field of view.
        occluders: the map whose opaque cells block the sensor (default ``grid``).
        range_margin: m, a cell counts as swept only if its centre is this much
            inside the range (a cell has extent; the pose is an estimate).
        fov_margin: rad, the same for the field-of-view edges.
    """

    def __init__(
        self,
        grid: GridMap,
        max_range: float,
        fov: float,
        *,
        occluders: GridMap | None = None,
        range_margin: float = 0.0,
        fov_margin: float = 0.0,
    ) -> None:
        self.grid = grid
        self.occluders = occluders or grid
        self.range = max(float(max_range) - range_margin, 0.0)
        self.fov = float(fov) if fov >= 2.0 * math.pi else max(float(fov) - 2.0 * fov_margin, 0.0)
        self.swept = np.zeros(grid.shape, dtype=bool)
        self.relevant = grid.clearance > 0.0  # cells that may hold a landmark
        self.abandoned = np.zeros(grid.shape, dtype=bool)  # given up: never counted unswept
        self._exposure = np.zeros(grid.shape, dtype=np.int32)

    def footprint(self, pose: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """(i, j) of the cells seen from ``pose`` (no side effect)."""
        return sensor_footprint(self.grid, pose, self.range, self.fov, occluders=self.occluders)

    def sweep(self, pose: Sequence[float]) -> int:
        """Mark the footprint of ``pose`` swept; return how many relevant cells were new."""
        ii, jj = self.footprint(pose)
        new = int(np.count_nonzero(~self.swept[ii, jj] & self.relevant[ii, jj]))
        self.swept[ii, jj] = True
        return new

    def expose(self, position: Sequence[float], radius: float, limit: int) -> int:
        """Count one step for each unswept cell within ``radius`` (m) of ``position``;
        abandon those counted more than ``limit`` steps: a cell that stays unswept
        while the robot spends that long next to it is out of sight (behind an
        obstacle, in a corner), and chasing it would trap the robot. Returns how many
        cells were abandoned."""
        g = self.grid
        x, y = float(position[0]), float(position[1])
        j0 = max(math.floor((x - radius) / g.resolution), 0)
        j1 = min(math.ceil((x + radius) / g.resolution) + 1, g.nx)
        i0 = max(math.floor((y - radius) / g.resolution), 0)
        i1 = min(math.ceil((y + radius) / g.resolution) + 1, g.ny)
        if j0 >= j1 or i0 >= i1:
            return 0
        dx = g.xs[None, j0:j1] - x
        dy = g.ys[i0:i1, None] - y
        near = (dx * dx + dy * dy <= radius * radius) & self.unswept[i0:i1, j0:j1]
        counts = self._exposure[i0:i1, j0:j1]
        counts += near
        give_up = near & (counts > limit)
        self.abandoned[i0:i1, j0:j1] |= give_up
        return int(np.count_nonzero(give_up))

    @property
    def unswept(self) -> np.ndarray:
        """(ny, nx) bool: relevant cells neither swept nor abandoned."""
        return self.relevant & ~self.swept & ~self.abandoned

    def fraction_swept(self) -> float:
        """Share of the relevant cells swept so far."""
        n = int(np.count_nonzero(self.relevant))
        return 1.0 if n == 0 else float(np.count_nonzero(self.relevant & self.swept)) / n


def box_sum(mask: np.ndarray, radius: int) -> np.ndarray:
    """(ny, nx) the number of true cells of ``mask`` in the (2r+1)² window around each
    cell (clipped at the border), from an integral image."""
    a = np.asarray(mask, dtype=np.float64)
    ny, nx = a.shape
    s = np.zeros((ny + 1, nx + 1))
    s[1:, 1:] = a.cumsum(0).cumsum(1)
    i = np.arange(ny)
    j = np.arange(nx)
    i0 = np.clip(i - radius, 0, ny)[:, None]
    i1 = np.clip(i + radius + 1, 0, ny)[:, None]
    j0 = np.clip(j - radius, 0, nx)[None, :]
    j1 = np.clip(j + radius + 1, 0, nx)[None, :]
    return s[i1, j1] - s[i0, j1] - s[i1, j0] + s[i0, j0]
