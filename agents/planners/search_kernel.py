"""The compiled inner loop of :func:`agents.planners.grid_search.dijkstra`.

A planning agent's every decision spreads a distance field over the whole known map
(4,096 cells of 0.25 m in the default 16 m arena, 16 times as many at 64 m): in Python,
with ``heapq``, that was more than half of a frontier agent's episode. This is the same
search, move for move, compiled: the same sums in the same order, and the heap pops
``(distance, cell)`` in the same lexicographic order as ``heapq`` pops its tuples, so
that distances *and* parents equal the Python loop's bit for bit
(``tests/agents/planners/test_search_kernel.py`` holds it to that loop,
``references/dijkstra.py``).
"""

from __future__ import annotations

import numpy as np

from slam_env.kernels.base.compiling import inline_kernel, kernel


@inline_kernel
def _before(d: np.ndarray, k: np.ndarray, a: int, b: int) -> bool:
    """Entry ``a`` of the heap sorts before entry ``b``: (distance, cell) order."""
    return d[a] < d[b] or (d[a] == d[b] and k[a] < k[b])


@inline_kernel
def _swap(d: np.ndarray, k: np.ndarray, a: int, b: int) -> None:
    d[a], d[b] = d[b], d[a]
    k[a], k[b] = k[b], k[a]


@inline_kernel
def _sift_up(d: np.ndarray, k: np.ndarray, at: int) -> None:
    while at > 0:
        up = (at - 1) // 2
        if not _before(d, k, at, up):
            return
        _swap(d, k, at, up)
        at = up


@inline_kernel
def _sift_down(d: np.ndarray, k: np.ndarray, size: int) -> None:
    at = 0
    while True:
        child = 2 * at + 1
        if child >= size:
            return
        if child + 1 < size and _before(d, k, child + 1, child):
            child += 1
        if not _before(d, k, child, at):
            return
        _swap(d, k, at, child)
        at = child


@kernel
def dijkstra_fill(
    free: np.ndarray,
    cost: np.ndarray,
    moves: tuple,
    starts: np.ndarray,
    max_cost: float,
    dist: np.ndarray,
    parent: np.ndarray,
) -> None:
    """Shortest path lengths over a padded grid, written into ``dist`` and ``parent``.

    Args:
        free: (n,) bool, the passable mask with a blocked one-cell border, flattened:
            a neighbour of an inner cell is never outside.
        cost: (n,) float64, the length of a straight move *into* each cell.
        moves: the 8 moves of :func:`agents.planners.grid_search._moves` (flat offset, length
            in cells, and for a diagonal the two orthogonal offsets that must be free:
            no corner cutting).
        starts: (s,) int64 flat indices of the sources, each distinct.
        max_cost: cells beyond this distance are not expanded.
        dist: (n,) float64, filled with inf except the sources (0) on entry; out:
            the distances (inf where unreached).
        parent: (n,) int64, −1 on entry; out: each reached cell's predecessor.
    """
    # Each push lowers a cell's distance, so a cell is pushed at most once per
    # neighbour, plus once as a source.
    capacity = 8 * free.size + starts.size + 1
    heap_d = np.empty(capacity)
    heap_k = np.empty(capacity, dtype=np.int64)
    size = 0
    for s in starts:
        heap_d[size] = 0.0
        heap_k[size] = s
        size += 1
        _sift_up(heap_d, heap_k, size - 1)
    while size > 0:
        d, k = heap_d[0], heap_k[0]
        size -= 1
        if size > 0:
            heap_d[0], heap_k[0] = heap_d[size], heap_k[size]
            _sift_down(heap_d, heap_k, size)
        if d > dist[k]:
            continue
        if d > max_cost:
            break
        for off, length, a, b in moves:
            m = k + off
            if not free[m] or (a != 0 and not (free[k + a] and free[k + b])):
                continue
            nd = d + length * cost[m]
            if nd < dist[m]:
                dist[m] = nd
                parent[m] = k
                heap_d[size] = nd
                heap_k[size] = m
                size += 1
                _sift_up(heap_d, heap_k, size - 1)
