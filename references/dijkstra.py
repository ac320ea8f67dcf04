"""The plain Python Dijkstra that :func:`agents.planners.grid_search.dijkstra` ran before its
inner loop was compiled (:mod:`agents.planners.search_kernel`): the reference the tests hold the
kernel to, bit for bit, and the baseline of ``bench_agents.py``."""

from __future__ import annotations

import heapq
import math

import numpy as np


def reference_dijkstra(passable, sources, resolution=1.0, cell_cost=None, max_cost=math.inf):
    """(dist, parent) as :func:`agents.planners.grid_search.dijkstra` returns them, computed by
    heapq over (distance, cell) tuples on Python lists."""
    ny, nx = passable.shape
    w = nx + 2
    pad = np.zeros((ny + 2, w), dtype=bool)
    pad[1:-1, 1:-1] = passable
    free = pad.ravel().tolist()
    pc = np.full((ny + 2, w), resolution, dtype=np.float64)
    if cell_cost is not None:
        pc[1:-1, 1:-1] = resolution * np.asarray(cell_cost, dtype=np.float64)
    cost = pc.ravel().tolist()
    dist = [math.inf] * len(free)
    parent = [-1] * len(free)
    heap = []
    for i, j in sources:
        if 0 <= i < ny and 0 <= j < nx:
            k = (i + 1) * w + j + 1
            if dist[k] > 0.0:
                dist[k] = 0.0
                heap.append((0.0, k))
    heapq.heapify(heap)
    r2 = math.sqrt(2.0)
    moves = [(1, 1.0, 0, 0), (-1, 1.0, 0, 0), (w, 1.0, 0, 0), (-w, 1.0, 0, 0)]
    moves += [(w + 1, r2, w, 1), (w - 1, r2, w, -1), (-w + 1, r2, -w, 1), (-w - 1, r2, -w, -1)]
    while heap:
        d, k = heapq.heappop(heap)
        if d > dist[k]:
            continue
        if d > max_cost:
            break
        for off, length, a, b in moves:
            m = k + off
            if not free[m] or (a and not (free[k + a] and free[k + b])):
                continue
            nd = d + length * cost[m]
            if nd < dist[m]:
                dist[m] = nd
                parent[m] = k
                heapq.heappush(heap, (nd, m))
    d = np.array(dist).reshape(ny + 2, w)[1:-1, 1:-1]
    par = np.array(parent)
    pi, pj = np.divmod(par, w)
    par = np.where(par >= 0, (pi - 1) * nx + (pj - 1), -1).reshape(ny + 2, w)[1:-1, 1:-1]
    return d, par.ravel()
