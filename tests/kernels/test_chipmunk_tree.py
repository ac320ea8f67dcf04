"""The compiled bounding-box tree against the plain Python one (the reference), node
for node and bit for bit: the segment queries visit it in this order, and which of two
hits an ulp apart they keep depends on it."""

from __future__ import annotations

import numpy as np
import pytest

from references.chipmunk_tree import bb_tree as reference_tree
from slam_env.kernels.world.chipmunk import bb_tree


def _random_boxes(rng: np.random.Generator, n: int, grid: bool) -> list[tuple[float, ...]]:
    if grid:  # whole-metre boxes: many equal insertion costs, decided by proximity
        corners = rng.integers(-3, 4, (n, 2)).astype(float)
        sizes = rng.integers(0, 3, (n, 2)).astype(float)
    else:
        corners = rng.uniform(-20.0, 20.0, (n, 2))
        sizes = rng.uniform(0.0, 5.0, (n, 2))
    boxes = np.concatenate([corners, corners + sizes], axis=1)
    boxes[rng.random((n, 4)) < 0.1] = -0.0  # Chipmunk keeps the sign of a zero
    return [tuple(row) for row in boxes.tolist()]


@pytest.mark.parametrize("grid", [False, True])
def test_the_compiled_tree_is_the_reference_tree(grid):
    rng = np.random.default_rng(7 + grid)
    for n in [1, 2, 3, 5, *rng.integers(4, 60, 40).tolist()]:
        boxes = _random_boxes(rng, n, grid)
        nodes, node_boxes = bb_tree(boxes)
        want_nodes, want_boxes = reference_tree(boxes)
        assert nodes.shape == (2 * n - 1, 4) and nodes.dtype == np.int64
        np.testing.assert_array_equal(nodes, np.array(want_nodes, dtype=np.int64))
        want = np.array(want_boxes, dtype=np.float64)
        # Bit for bit, signs of zero included.
        np.testing.assert_array_equal(node_boxes.view(np.int64), want.view(np.int64))


def test_no_boxes_no_tree():
    nodes, node_boxes = bb_tree([])
    assert nodes.shape == (0, 4) and node_boxes.shape == (0, 4)
