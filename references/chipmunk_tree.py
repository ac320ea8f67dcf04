"""The bounding-box tree of Chipmunk's static index as plain Python objects, one node
at a time: the reference that :func:`slam_env.kernels.world.chipmunk.bb_tree` (compiled)
is held to. cpfmin/cpfmax are ``a if a < b else b``, which keeps Chipmunk's sign of 0."""

from __future__ import annotations

from slam_env.kernels.world.chipmunk import Box, _fmax, _fmin


def _merge(a: Box, b: Box) -> Box:
    """cpBBMerge."""
    return (_fmin(a[0], b[0]), _fmin(a[1], b[1]), _fmax(a[2], b[2]), _fmax(a[3], b[3]))


def _area(a: Box) -> float:
    """cpBBArea."""
    return (a[2] - a[0]) * (a[3] - a[1])


def _merged_area(a: Box, b: Box) -> float:
    """cpBBMergedArea."""
    return (_fmax(a[2], b[2]) - _fmin(a[0], b[0])) * (_fmax(a[3], b[3]) - _fmin(a[1], b[1]))


def _proximity(a: Box, b: Box) -> float:
    """cpBBProximity."""
    return abs(a[0] + a[2] - b[0] - b[2]) + abs(a[1] + a[3] - b[1] - b[3])


class _Node:
    __slots__ = ("a", "b", "box", "parent", "shape")

    def __init__(self, box: Box, shape: int = -1) -> None:
        self.box, self.shape = box, shape
        self.a: _Node | None = None
        self.b: _Node | None = None
        self.parent: _Node | None = None


def _insert(root: _Node | None, leaf: _Node) -> _Node:
    """SubtreeInsert: from the root, descend to the child whose box grows least (by
    area, then by centre distance), pair the leaf with the leaf found there under a
    new node, and widen the boxes above it. Returns the root."""
    if root is None:
        return leaf
    node = root
    while node.shape < 0:
        a, b = node.a, node.b
        assert a is not None and b is not None
        cost_a = _area(b.box) + _merged_area(a.box, leaf.box)
        cost_b = _area(a.box) + _merged_area(b.box, leaf.box)
        if cost_a == cost_b:
            cost_a = _proximity(a.box, leaf.box)
            cost_b = _proximity(b.box, leaf.box)
        node = b if cost_b < cost_a else a
    parent = node.parent
    pair = _Node(_merge(leaf.box, node.box))
    pair.a, pair.b = leaf, node
    leaf.parent = node.parent = pair
    pair.parent = parent
    if parent is None:
        return pair
    if parent.a is node:
        parent.a = pair
    else:
        parent.b = pair
    above: _Node | None = parent
    while above is not None:
        above.box = _merge(above.box, leaf.box)
        above = above.parent
    return root


def bb_tree(boxes: list[Box]) -> tuple[list[tuple[int, int, int, int]], list[Box]]:
    """The bounding-box tree that Chipmunk's static index builds when shapes with
    these boxes are added to a space in this order (cpBBTreeInsert, no re-indexing).

    Returns its 2n − 1 nodes (none for no boxes) in depth-first order, the root first,
    each as ``(child_a, child_b, shape, parent)``: an inner node's two children (node
    indices) and shape −1, or a leaf's −1, −1 and its box's index; the parent's index
    (−1 for the root). And each node's box."""
    root: _Node | None = None
    for k, box in enumerate(boxes):
        root = _insert(root, _Node(box, shape=k))
    nodes: list[list[int]] = []
    node_boxes: list[Box] = []
    todo: list[tuple[_Node, int, int]] = [] if root is None else [(root, -1, 0)]
    while todo:  # depth first, child a before child b
        node, parent, side = todo.pop()
        index = len(nodes)
        if parent >= 0:
            nodes[parent][side] = index
        nodes.append([-1, -1, node.shape, parent])
        node_boxes.append(node.box)
        if node.shape < 0:
            assert node.a is not None and node.b is not None
            todo += [(node.b, index, 1), (node.a, index, 0)]
    return [(a, b, s, p) for a, b, s, p in nodes], node_boxes
