"""The compiled Dijkstra (agents.planners.search_kernel) against the plain Python search it
replaced (references/dijkstra.py): equal distances and parents, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.planners.grid_search import dijkstra
from references.dijkstra import reference_dijkstra


def _case(seed: int):
    rng = np.random.default_rng(seed)
    ny, nx = (int(v) for v in rng.integers(1, 40, size=2))
    passable = rng.random((ny, nx)) > rng.uniform(0.0, 0.5)
    # Integer costs (and none) make many equal-length paths: ties decide the parents.
    kind = seed % 3
    cell_cost = (
        None
        if kind == 0
        else rng.integers(1, 4, size=(ny, nx)).astype(float)
        if kind == 1
        else 1.0 + rng.random((ny, nx))
    )
    sources = [
        (int(i), int(j)) for i, j in rng.integers(-2, max(ny, nx) + 2, size=(rng.integers(1, 4), 2))
    ]
    max_cost = math.inf if seed % 4 else float(rng.uniform(0.0, 15.0))
    resolution = float(rng.choice([1.0, 0.25, 0.1]))
    return passable, sources, resolution, cell_cost, max_cost


@pytest.mark.parametrize("seed", range(60))
def test_compiled_dijkstra_equals_the_python_search_bit_for_bit(seed):
    passable, sources, resolution, cell_cost, max_cost = _case(seed)
    args = dict(resolution=resolution, cell_cost=cell_cost, max_cost=max_cost)
    dist, parent = dijkstra(passable, sources, **args)
    ref_dist, ref_parent = reference_dijkstra(passable, sources, **args)
    assert dist.shape == passable.shape and parent.shape == (passable.size,)
    np.testing.assert_array_equal(dist, ref_dist)
    np.testing.assert_array_equal(parent, ref_parent)


def test_an_open_grid_of_equal_costs_keeps_the_python_tie_breaks():
    # Every cell of an open grid has many shortest paths: the parents are the heap's
    # pop order, which must be (distance, cell) as heapq's tuples are.
    passable = np.ones((60, 80), dtype=bool)
    passable[20:40, 30] = False
    dist, parent = dijkstra(passable, [(30, 10), (5, 70)], resolution=0.1)
    ref_dist, ref_parent = reference_dijkstra(passable, [(30, 10), (5, 70)], resolution=0.1)
    np.testing.assert_array_equal(dist, ref_dist)
    np.testing.assert_array_equal(parent, ref_parent)


def test_no_source_on_the_grid_reaches_nothing():
    dist, parent = dijkstra(np.ones((4, 5), dtype=bool), [(-1, 0), (4, 2)])
    assert np.isinf(dist).all() and (parent == -1).all()
