"""Planning utilities shared by the heuristic exploration agents.

Everything here works on the *known* map only: the layout's arena, obstacles and inner
walls (what a robot is given before it starts), never the true landmark positions or
the true pose. Numpy and the standard library; the search's inner loop is compiled
(:mod:`agents.search_kernel`).

- :class:`GridMap` rasterises the known map: the signed clearance (m) of every cell
  centre to the nearest obstacle, wall or arena edge; ``passable(inflation)`` is the
  configuration space of a disc robot, ``opaque`` what blocks the sensor.
- :func:`dijkstra` (a distance field from one or many source cells) and :func:`astar`
  (one path) on an 8-connected grid without corner cutting; :func:`path_from_parents`.
- :func:`unicycle_control` maps (estimated pose, waypoint) to an action in [−1, 1]²;
  :class:`PathFollower` runs it along a path with a look-ahead point (pure pursuit).
- :func:`sensor_footprint` and :class:`CoverageMap`: the cells a range-and-FOV sensor
  sweeps from a pose, with occlusion by the known map — vectorised; :func:`box_sum`
  counts cells in windows (the unswept area around a candidate target).
- Agent plumbing: :class:`ExplorationMemory` (an episode's grids, inflated by the robot
  and the estimated landmark posts), :class:`EpisodeWatch` (notices a new episode
  without ``episode_start``), :class:`StuckDetector` (blocked by something unmapped),
  :func:`belief_env` (checks the env the agents need), :func:`make_params`.

Conventions: a grid has ``shape = (ny, nx)``; cell ``(i, j)`` (row ``i`` along y,
column ``j`` along x) covers ``[j·res, (j+1)·res] × [i·res, (i+1)·res]`` and its
centre is ``((j + ½)·res, (i + ½)·res)``. Flat indices are ``i·nx + j``.
"""

from __future__ import annotations

import dataclasses
import heapq
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.search_kernel import dijkstra_fill
from slam_env.config import EnvConfig
from slam_env.geometry import wrap_angle
from slam_env.layouts import DEFAULT_WALL_THICKNESS, LANDMARK_POST_RADIUS, Layout

SQRT2 = math.sqrt(2.0)


# --------------------------------------------------------------------------- the known map


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


# --------------------------------------------------------------------------- search


def _padded(passable: np.ndarray) -> tuple[np.ndarray, int]:
    """The passable mask with a one-cell blocked border, flattened, and its row
    stride: neighbours of an inner cell never leave the array."""
    ny, nx = passable.shape
    pad = np.zeros((ny + 2, nx + 2), dtype=np.bool_)
    pad[1:-1, 1:-1] = passable
    return pad.ravel(), nx + 2


def _moves(w: int) -> tuple[tuple[int, float, int, int], ...]:
    """8-connected moves on a padded grid of row stride w: (offset, length in cells,
    and for a diagonal the two orthogonal offsets that must be free — no corner
    cutting; 0 for straight moves)."""
    return (
        (1, 1.0, 0, 0),
        (-1, 1.0, 0, 0),
        (w, 1.0, 0, 0),
        (-w, 1.0, 0, 0),
        (w + 1, SQRT2, w, 1),
        (w - 1, SQRT2, w, -1),
        (-w + 1, SQRT2, -w, 1),
        (-w - 1, SQRT2, -w, -1),
    )


def dijkstra(
    passable: np.ndarray,
    sources: Iterable[tuple[int, int]],
    *,
    resolution: float = 1.0,
    cell_cost: np.ndarray | None = None,
    max_cost: float = math.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """Shortest path lengths from the nearest of ``sources`` over passable cells
    (8-connected, no corner cutting).

    Args:
        passable: (ny, nx) bool.
        sources: (i, j) cells, distance 0 (a blocked source still starts the search).
        resolution: the cell side; distances are in its unit (m).
        cell_cost: optional (ny, nx) multiplier ≥ 1 of the length of a move *into* a
            cell (e.g. to keep away from obstacles).
        max_cost: stop expanding beyond this distance (farther cells hold upper
            bounds or inf).

    Returns:
        ``dist`` (ny, nx) float (inf where unreached) and ``parent`` (ny·nx,) int
        flat index of each reached cell's predecessor (−1 for sources and unreached).
    """
    ny, nx = passable.shape
    free, w = _padded(passable)
    cost = np.full((ny + 2, w), float(resolution))
    if cell_cost is not None:
        cost[1:-1, 1:-1] = resolution * np.asarray(cell_cost, dtype=np.float64)
    dist = np.full(free.size, math.inf)
    parent = np.full(free.size, -1, dtype=np.int64)
    starts = []
    for i, j in sources:
        i, j = int(i), int(j)
        if 0 <= i < ny and 0 <= j < nx:
            k = (i + 1) * w + j + 1
            if dist[k] > 0.0:
                dist[k] = 0.0
                starts.append(k)
    starts_arr = np.array(starts, dtype=np.int64)
    dijkstra_fill(free, cost.ravel(), _moves(w), starts_arr, float(max_cost), dist, parent)
    # Padded flat indices back to the (ny, nx) grid's.
    pi, pj = np.divmod(parent, w)
    par = np.where(parent >= 0, (pi - 1) * nx + (pj - 1), -1)
    par = par.reshape(ny + 2, w)[1:-1, 1:-1].ravel()
    return dist.reshape(ny + 2, w)[1:-1, 1:-1], par


def path_from_parents(parent: np.ndarray, goal: tuple[int, int], nx: int) -> list[tuple[int, int]]:
    """The cells from the search's source to ``goal`` (inclusive), following
    ``parent`` from :func:`dijkstra`; ``[goal]`` when goal is a source."""
    k = int(goal[0]) * nx + int(goal[1])
    cells = []
    seen = 0
    limit = len(parent)
    while k >= 0 and seen <= limit:
        cells.append(divmod(k, nx))
        k = int(parent[k])
        seen += 1
    cells.reverse()
    return cells


def astar(
    passable: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    *,
    cell_cost: np.ndarray | None = None,
) -> list[tuple[int, int]] | None:
    """A* on an 8-connected grid (octile heuristic, no corner cutting).

    Returns the cells from ``start`` to ``goal`` inclusive, or None when the goal is
    blocked or unreachable. The start may be blocked (a robot inside the inflation
    band still gets out). ``cell_cost`` as in :func:`dijkstra` (multipliers ≥ 1 keep
    the heuristic admissible).
    """
    ny, nx = passable.shape
    si, sj = int(start[0]), int(start[1])
    gi, gj = int(goal[0]), int(goal[1])
    if not (0 <= si < ny and 0 <= sj < nx and 0 <= gi < ny and 0 <= gj < nx):
        raise ValueError(f"start {start} or goal {goal} is outside the {ny}×{nx} grid")
    if not passable[gi, gj]:
        return None
    free_cells, w = _padded(passable)
    free = free_cells.tolist()  # Python's own bools: this search runs in the interpreter
    if cell_cost is None:
        cost = None
    else:
        pc = np.ones((ny + 2, nx + 2))
        pc[1:-1, 1:-1] = np.maximum(np.asarray(cell_cost, dtype=np.float64), 1.0)
        cost = pc.ravel().tolist()
    s, g = (si + 1) * w + sj + 1, (gi + 1) * w + gj + 1
    gi, gj = gi + 1, gj + 1
    dist = {s: 0.0}
    parent = {s: -1}
    closed: set[int] = set()
    c = SQRT2 - 1.0

    def h(k: int) -> float:
        di = abs(k // w - gi)
        dj = abs(k % w - gj)
        return c * min(di, dj) + max(di, dj)

    heap = [(h(s), 0.0, s)]
    pop, push = heapq.heappop, heapq.heappush
    moves = _moves(w)
    while heap:
        _, d, k = pop(heap)
        if k in closed:
            continue
        if k == g:
            cells = []
            while k >= 0:
                cells.append((k // w - 1, k % w - 1))
                k = parent[k]
            cells.reverse()
            return cells
        closed.add(k)
        for off, length, a, b in moves:
            m = k + off
            if not free[m] or (a and not (free[k + a] and free[k + b])):
                continue
            nd = d + (length if cost is None else length * cost[m])
            if nd < dist.get(m, math.inf):
                dist[m] = nd
                parent[m] = k
                push(heap, (nd + h(m), nd, m))
    return None


def nearest_passable(
    passable: np.ndarray, cell: tuple[int, int], max_radius: int = 8
) -> tuple[int, int] | None:
    """The passable cell nearest to ``cell`` (itself if passable) within
    ``max_radius`` cells (Chebyshev window), or None."""
    i, j = cell
    if passable[i, j]:
        return (int(i), int(j))
    ny, nx = passable.shape
    i0, i1 = max(i - max_radius, 0), min(i + max_radius + 1, ny)
    j0, j1 = max(j - max_radius, 0), min(j + max_radius + 1, nx)
    window = passable[i0:i1, j0:j1]
    if not window.any():
        return None
    ii, jj = np.nonzero(window)
    d2 = (ii + i0 - i) ** 2 + (jj + j0 - j) ** 2
    k = int(np.argmin(d2))
    return int(ii[k] + i0), int(jj[k] + j0)


# --------------------------------------------------------------------------- control


@dataclass(frozen=True)
class ControllerParams:
    """Gains and limits of :func:`unicycle_control`.

    Attributes:
        max_speed: m/s at action 1.0 (the env's ``robot.max_speed``).
        max_turn_rate: rad/s at action 1.0 (the env's ``robot.max_turn_rate``).
        heading_gain: 1/s, commanded turn rate per rad of heading error.
        turn_in_place: rad, heading error above which the robot stops and turns.
        cruise: fraction of ``max_speed`` used when aligned (0, 1].
        turn_limit: fraction of ``max_turn_rate`` never exceeded (0, 1]: odometry
            noise grows with the square of each step's rotation, so gentle turns
            cost the heading estimate less per radian.
        dt: s, one env step (speeds are capped to reach, not overshoot, the goal).
    """

    max_speed: float = 1.0
    max_turn_rate: float = 1.5
    heading_gain: float = 2.5
    turn_in_place: float = math.radians(60.0)
    cruise: float = 1.0
    turn_limit: float = 1.0
    dt: float = 0.2

    def __post_init__(self) -> None:
        for name in ("max_speed", "max_turn_rate", "heading_gain", "turn_in_place", "dt"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"ControllerParams.{name} must be finite and > 0, got {value}")
        for name in ("cruise", "turn_limit"):
            value = getattr(self, name)
            if not 0.0 < value <= 1.0:
                raise ValueError(f"ControllerParams.{name} must be in (0, 1], got {value}")


def unicycle_control(
    pose: Sequence[float],
    waypoint: Sequence[float],
    params: ControllerParams | None = None,
    *,
    stop_distance: float | None = None,
) -> np.ndarray:
    """Action (speed, turn) fractions in [−1, 1] (float32 (2,)) that drive a unicycle
    at ``pose`` (x, y, θ) toward ``waypoint`` (x, y).

    The turn rate is proportional to the heading error e (saturated); the speed is
    ``cruise·cos²(e)``, zero when |e| exceeds ``turn_in_place`` (turn on the spot),
    and, when ``stop_distance`` (m) is given, capped so that the robot does not run
    past the point ``stop_distance`` short of the waypoint.
    """
    p = params or ControllerParams()
    dx = float(waypoint[0]) - float(pose[0])
    dy = float(waypoint[1]) - float(pose[1])
    dist = math.hypot(dx, dy)
    if dist < 1e-9:
        return np.zeros(2, dtype=np.float32)
    err = wrap_angle(math.atan2(dy, dx) - float(pose[2]))
    turn = max(-p.turn_limit, min(p.turn_limit, p.heading_gain * err / p.max_turn_rate))
    speed = 0.0 if abs(err) > p.turn_in_place else p.cruise * math.cos(err) ** 2
    if stop_distance is not None:
        room = max(dist - stop_distance, 0.0)
        speed = min(speed, room / (p.max_speed * p.dt))
    return np.array([speed, turn], dtype=np.float32)


class PathFollower:
    """Pure pursuit along a polyline with :func:`unicycle_control`.

    Args:
        points: (k, 2) the path in world coordinates (m), start to goal.
        lookahead: m, distance along the path of the point the robot steers at.
        params: the controller.
    """

    def __init__(
        self,
        points: np.ndarray,
        lookahead: float = 0.6,
        params: ControllerParams | None = None,
    ) -> None:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if not len(pts):
            raise ValueError("a path needs at least one point")
        self.points = pts
        seg = np.hypot(*np.diff(pts, axis=0).T) if len(pts) > 1 else np.zeros(0)
        self.arc = np.concatenate([[0.0], np.cumsum(seg)])  # (k,) arc length, m
        self.lookahead = float(lookahead)
        self.params = params or ControllerParams()
        self._index = 0  # the path point closest to the robot so far (monotone)

    @property
    def goal(self) -> np.ndarray:
        return self.points[-1].copy()

    def progress(self, position: Sequence[float]) -> tuple[float, float]:
        """Update the closest path point (searching forward) and return
        (distance from the path (m), arc length left to the goal (m))."""
        window = self.points[self._index : self._index + 12]
        d = np.hypot(window[:, 0] - position[0], window[:, 1] - position[1])
        k = int(np.argmin(d))
        self._index += k
        return float(d[k]), float(self.arc[-1] - self.arc[self._index])

    def target(self) -> np.ndarray:
        """The look-ahead point: ``lookahead`` m further along the path."""
        want = self.arc[self._index] + self.lookahead
        k = int(np.searchsorted(self.arc, want))
        return self.points[min(k, len(self.points) - 1)].copy()

    def action(self, pose: Sequence[float]) -> np.ndarray:
        """The action toward the look-ahead point; slows down to stop at the goal."""
        self.progress(pose)
        return unicycle_control(pose, self.target(), self.params, stop_distance=0.0)


# --------------------------------------------------------------------------- sensor sweep


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


# --------------------------------------------------------------------------- agent plumbing


def make_params(cls: type, params: dict[str, Any]) -> Any:
    """``cls(**params)`` for a parameter dataclass, with a ``TypeError`` that lists the
    valid names for an unknown one."""
    valid = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(params) - valid)
    if unknown:
        raise TypeError(f"unknown {cls.__name__} {unknown}; valid: {sorted(valid)}")
    return cls(**params)


def belief_env(env: Any) -> Any:
    """The ``slam_env/ActiveSLAM-v0`` env under ``env``'s wrappers: the object whose
    ``filter`` holds the belief and whose ``layout`` is the known map. Raises
    ``TypeError`` for anything else (the heuristics plan on the EKF belief) and for a
    discrete action space (they output continuous speed and turn commands)."""
    from gymnasium import spaces

    base = getattr(env, "unwrapped", env)
    if not (hasattr(base, "filter") and hasattr(type(base), "layout")):
        raise TypeError(
            "the exploration heuristics act on the EKF-SLAM belief: pass an env made with "
            f"gym.make('slam_env/ActiveSLAM-v0'), got {type(base).__name__}"
        )
    space = getattr(env, "action_space", None)
    if not isinstance(space, spaces.Box) or space.shape != (2,):
        raise TypeError(
            "the exploration heuristics need the continuous Box(-1, 1, (2,)) action space "
            f"(action_type='continuous'), got {space!r}"
        )
    return base


def is_truthy(flag: object) -> bool:
    """``episode_start`` as SB3 passes it: None, a bool, or a (1,)-array."""
    if flag is None:
        return False
    return bool(np.any(np.asarray(flag)))


class EpisodeWatch:
    """Detects the start of a new episode from what an agent can see, for callers that
    do not pass ``episode_start``: the raw env's layout or the filter object changed,
    the filter lost landmarks, or its pose covariance is back to exactly zero (the
    known start pose) after the agent has acted."""

    def __init__(self) -> None:
        self._layout: object = None
        self._filter: object = None
        self._n_landmarks = 0
        self._acted = False

    def is_new(self, base: Any) -> bool:
        """Whether ``base`` (the ActiveSLAM env) started an episode since :meth:`mark`."""
        layout = base.layout
        f = base.filter
        new = (
            layout is not self._layout
            or f is not self._filter
            or f.n_landmarks < self._n_landmarks
            or (self._acted and not np.any(f.pose_cov))
        )
        return bool(new)

    def mark(self, base: Any) -> None:
        """Record the state after the agent chose an action."""
        self._layout = base.layout
        self._filter = base.filter
        self._n_landmarks = int(base.filter.n_landmarks)
        self._acted = True

    def forget(self) -> None:
        self._acted = False
        self._n_landmarks = 0


class StuckDetector:
    """Notices that the robot is blocked by something it does not know about: over the
    last ``steps`` steps it commanded at least ``min_command`` of the max speed, but
    its (estimated) position moved less than ``ratio`` of the commanded distance.
    Odometry measures the true motion, so a robot pushing against an unmapped
    obstacle sees its estimate stand still.

    Args:
        steps: the window, env steps.
        min_command: speed fraction that counts as "trying to move".
        ratio: fraction of the commanded travel below which the robot is stuck.
        step_length: m travelled in one step at full speed (max_speed · dt).
    """

    def __init__(
        self,
        steps: int = 4,
        min_command: float = 0.3,
        ratio: float = 0.25,
        step_length: float = 0.2,
    ) -> None:
        self.steps = int(steps)
        self.min_command = float(min_command)
        self.ratio = float(ratio)
        self.step_length = float(step_length)
        self._positions: list[tuple[float, float]] = []
        self._commands: list[float] = []

    def clear(self) -> None:
        self._positions.clear()
        self._commands.clear()

    def update(self, position: Sequence[float], command: float) -> bool:
        """Record the position at which ``command`` (speed fraction) is issued; True
        when the robot is stuck (the window is then cleared)."""
        self._positions.append((float(position[0]), float(position[1])))
        self._commands.append(float(command))
        if len(self._positions) > self.steps + 1:
            del self._positions[0]
            del self._commands[0]
        if len(self._positions) <= self.steps:
            return False
        cmds = self._commands[:-1]  # the commands whose motion has been observed
        if min(cmds) < self.min_command:
            return False
        (x0, y0), (x1, y1) = self._positions[0], self._positions[-1]
        expected = sum(abs(c) for c in cmds) * self.step_length
        if math.hypot(x1 - x0, y1 - y0) < self.ratio * expected:
            self.clear()
            return True
        return False


class ExplorationMemory:
    """Per-episode memory of an exploring robot, built from the known map only.

    Holds the planning grid and its configuration space (known map inflated by the
    robot radius plus ``safety_margin``, and the *estimated* landmark posts), an
    obstacle-proximity cost for the planner, and the coverage grid the sensor has
    swept from the estimated poses.

    Args:
        layout: the known map (its landmarks are never read).
        config: the env's :class:`~slam_env.config.EnvConfig` (robot radius, sensor
            range and FOV, wall thickness).
        planning_resolution, coverage_resolution: m, the two grids' cells.
        safety_margin: m, extra inflation beyond the robot radius.
        soft_clearance: m, cells closer than this to the known map cost more.
        proximity_cost: the extra cost factor of a cell at the inflation boundary.
        range_margin, fov_margin: see :class:`CoverageMap`.
    """

    def __init__(
        self,
        layout: Layout,
        config: EnvConfig,
        *,
        planning_resolution: float = 0.25,
        coverage_resolution: float = 0.5,
        safety_margin: float = 0.07,
        soft_clearance: float = 0.8,
        proximity_cost: float = 3.0,
        range_margin: float = 0.4,
        fov_margin: float = math.radians(4.0),
    ) -> None:
        wall = float(config.world.wall_thickness)
        robot = config.robot
        sensor = config.sensor
        self.layout = layout
        self.grid = GridMap.from_layout(layout, planning_resolution, wall)
        self.coverage = CoverageMap(
            GridMap.from_layout(layout, coverage_resolution, wall),
            sensor.max_range,
            sensor.fov,
            occluders=self.grid,
            range_margin=range_margin,
            fov_margin=fov_margin,
        )
        self.inflation = float(robot.radius) + safety_margin
        self.post_radius = LANDMARK_POST_RADIUS + self.inflation
        self.static_free = self.grid.passable(self.inflation)
        self.free = self.static_free.copy()
        self._posts = np.zeros((0, 2))
        self._bumps: list[tuple[float, float, float]] = []
        band = max(soft_clearance - self.inflation, 1e-9)
        closeness = np.clip((soft_clearance - self.grid.clearance) / band, 0.0, 1.0)
        self.cell_cost = 1.0 + proximity_cost * closeness
        # The coverage cell of each planning cell (row and column maps).
        cg = self.coverage.grid
        self.cov_rows = np.clip((self.grid.ys / cg.resolution).astype(np.intp), 0, cg.ny - 1)
        self.cov_cols = np.clip((self.grid.xs / cg.resolution).astype(np.intp), 0, cg.nx - 1)

    def set_posts(self, means: np.ndarray) -> None:
        """Block the estimated landmark posts (k, 2) in the configuration space."""
        self._posts = np.asarray(means, dtype=np.float64).reshape(-1, 2)
        self._update_free()

    def add_bump(self, point: Sequence[float], radius: float) -> None:
        """Block a disc of ``radius`` (m) around ``point``: something the robot ran
        into there (in the estimated frame) that the known map does not show where
        the robot thinks it is."""
        self._bumps.append((float(point[0]), float(point[1]), float(radius)))
        self._update_free()

    def _update_free(self) -> None:
        free = self.grid.passable(self.inflation, self._posts, self.post_radius)
        for x, y, r in self._bumps:
            free &= self.grid.passable(-math.inf, np.array([[x, y]]), r)
        self.free = free

    def on_planning_grid(self, coverage_values: np.ndarray) -> np.ndarray:
        """Resample a (coverage-grid) array onto the planning grid."""
        return coverage_values[self.cov_rows[:, None], self.cov_cols[None, :]]

    def start_cell(self, position: Sequence[float]) -> tuple[int, int]:
        """The planning cell to search from: the robot's, or the nearest free one."""
        cell = self.grid.cell_of(position[0], position[1])
        near = nearest_passable(self.free, cell)
        return cell if near is None else near

    def path_points(self, cells: Sequence[tuple[int, int]]) -> np.ndarray:
        """(k, 2) world coordinates of the centres of ``cells``."""
        arr = np.asarray(cells, dtype=np.intp).reshape(-1, 2)
        return np.stack([self.grid.xs[arr[:, 1]], self.grid.ys[arr[:, 0]]], axis=-1)

    def is_free_at(self, points: np.ndarray) -> np.ndarray:
        """(k,) bool: whether each point (k, 2) lies in a free planning cell."""
        i, j = self.grid.cells_of(points)
        return self.free[i, j]
