"""Searches on an 8-connected grid without corner cutting (a
:class:`~agents.planners.grid_map.GridMap`'s passable cells): :func:`dijkstra` (a
distance field from one or many source cells; its inner loop compiled in
:mod:`agents.planners.search_kernel`), :func:`path_from_parents`, :func:`astar` (one
path) and :func:`nearest_passable`. Cells and flat indices as
:mod:`agents.planners.grid_map` says.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable

import numpy as np

from agents.planners.search_kernel import dijkstra_fill

SQRT2 = math.sqrt(2.0)


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
