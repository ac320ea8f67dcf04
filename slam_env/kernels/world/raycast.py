"""Segment queries against the static geometry of B worlds (:mod:`.static_geometry`): the
landmark sensor's line of sight and the proximity scan, compiled.

:func:`line_of_sight` and :func:`ray_fraction` answer what pymunk's
``Space.segment_query_first(a, b, 0.0, filter)`` answers for the world's space, bit
for bit: the same hits, the same alphas. Per shape they run Chipmunk's own arithmetic
(:mod:`.shape_queries`). Which shapes a query tries, and so which of two hits an ulp
apart comes back, is decided by the space's bounding-box tree, and pymunk 7.3 searches
it with a stack (SubtreeSegmentQuery in Munk2D's cpBBTree.c): from the root, a popped
inner node pushes each child whose box the query enters before the best alpha found
*so far*, the farther one first; a popped leaf's shape counts when its alpha is below
the best. So:

* A shape is never tried when the query does not enter its box before alpha 1. Box
  and shape round on their own, so this turns some grazing hits away (a ray one ulp
  outside a post's box often hits the post by the post's arithmetic).
* A line of sight is decided before anything is hit, while the bound is still 1, and
  boxes nest (a node's box holds its children's, and the box test rounds
  monotonically), so every shape whose box the query enters before 1 is tried, in any
  order: the kernel tries them in a plain loop and stops at the first hit.
* A ray fraction is the smallest alpha, unless the shape holding it is pruned by a
  bound set by another shape's hit, which needs that hit within the few ulps between
  the first shape's alpha and its box's entry alpha. The loop notes whether that can
  have happened, and only then the kernel searches the tree exactly as Chipmunk does
  (:func:`_tree_fraction`; rays into the corner where two walls meet, for instance).
* A hit counts only at alpha < 1: touching at the very end is clear.

The tree is pymunk 7.3's (an ulp-level difference from Chipmunk 7.0.3, which checks the
bound when a child is reached rather than when it is pushed); pyproject pins pymunk 7.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import inline_kernel, kernel
from slam_env.kernels.world.shape_queries import query_box_entry, shape_alpha
from slam_env.kernels.world.static_geometry import N_CIRCLES, N_POLYGONS, N_SEGMENTS, StaticGeometry

__all__ = [
    "all_leaves",
    "beam_segments",
    "line_of_sight",
    "lines_of_sight",
    "near_leaves",
    "range_scan",
    "ray_fraction",
    "ray_fractions",
    "segment_fractions",
    "sight_lines",
]

# How much farther than a query's reach a box may lie and still be tried, relative to
# the coordinates' size: far above the rounding of a segment's end point, far below
# any distance that matters.
NEAR_MARGIN = 1e-9


@inline_kernel
def _node_entry(
    boxes: np.ndarray, b: int, node: int, ax: float, ay: float, bx: float, by: float
) -> float:
    """:func:`~.shape_queries.query_box_entry` for the box of tree node ``node`` of
    world ``b``."""
    return query_box_entry(
        boxes[b, node, 0], boxes[b, node, 1], boxes[b, node, 2], boxes[b, node, 3], ax, ay, bx, by
    )


@inline_kernel
def _ranked(
    alpha: float, entry: float, best: float, best_entry: float, runner_up: float
) -> tuple[float, float, float]:
    """A tried shape's ``alpha``, its box entered at ``entry``, ranked: (the smallest
    alpha so far, where the query enters that shape's box, the smallest alpha of the
    other shapes)."""
    if alpha < best:
        return alpha, entry, best
    if alpha < runner_up:
        return best, best_entry, alpha
    return best, best_entry, runner_up


@inline_kernel
def all_leaves(geometry: StaticGeometry, b: int, out: np.ndarray) -> int:
    """Every leaf of world ``b``'s tree (one per shape), in node order, into ``out`` (at
    least the tree's rows); returns how many."""
    g = geometry
    n = g.counts[b, N_SEGMENTS] + g.counts[b, N_POLYGONS] + g.counts[b, N_CIRCLES]
    count = 0
    for node in range(2 * n - 1):
        if g.tree[b, node, 2] >= 0:
            out[count] = node
            count += 1
    return count


@inline_kernel
def near_leaves(
    geometry: StaticGeometry, b: int, x: float, y: float, reach: float, out: np.ndarray
) -> int:
    """The leaves of world ``b``'s tree whose box a segment from (x, y) no longer than
    ``reach`` can enter, in node order, into ``out`` (at least the tree's rows); returns
    how many. A box farther than ``reach`` (by a margin far above rounding) is left
    out: a query that lies wholly outside a box never tries its shape."""
    g = geometry
    n = g.counts[b, N_SEGMENTS] + g.counts[b, N_POLYGONS] + g.counts[b, N_CIRCLES]
    limit = reach + NEAR_MARGIN * (reach + abs(x) + abs(y) + 1.0)
    limit_sq = limit * limit
    count = 0
    for node in range(2 * n - 1):
        if g.tree[b, node, 2] < 0:
            continue
        boxes = g.tree_boxes
        dx = max(boxes[b, node, 0] - x, x - boxes[b, node, 2], 0.0)
        dy = max(boxes[b, node, 1] - y, y - boxes[b, node, 3], 0.0)
        if dx * dx + dy * dy <= limit_sq:
            out[count] = node
            count += 1
    return count


# The queries of one world come in batches, each batch one call: a compiled call, even
# an inlined one, increfs and decrefs every array of the geometry it is passed (about
# 40 ns for StaticGeometry), several times the cost of trying a leaf, so no per-query or
# per-leaf function takes the geometry; only shape_alpha does, for a box entered.


@inline_kernel
def sight_lines(
    geometry: StaticGeometry,
    b: int,
    leaves: np.ndarray,
    count: int,
    ax: float,
    ay: float,
    targets: np.ndarray,
    skip_circles: np.ndarray,
    k: int,
    out: np.ndarray,
) -> None:
    """``out[j]``: True when nothing in world ``b`` but circle ``skip_circles[j]`` (a
    landmark's own post; −1 to skip none) blocks the segment from a to ``targets[j]``,
    for j < k: pymunk's ``segment_query_first(a, target, 0.0, filter) is None`` for a
    filter that passes every static shape but that post. Tries the first ``count``
    ``leaves``: :func:`all_leaves`, or :func:`near_leaves` of a for a reach no shorter
    than any of the segments (the same answers)."""
    g = geometry
    boxes, tree = g.tree_boxes, g.tree
    first_circle = g.counts[b, N_SEGMENTS] + g.counts[b, N_POLYGONS]
    for j in range(k):
        bx, by = targets[j, 0], targets[j, 1]
        skip = skip_circles[j]
        skip_shape = first_circle + skip if skip >= 0 else -1
        clear = True
        for i in range(count):
            node = leaves[i]
            shape = tree[b, node, 2]
            if shape == skip_shape or not _node_entry(boxes, b, node, ax, ay, bx, by) < 1.0:
                continue  # its box not entered before alpha 1 (as the C's test reads)
            if shape_alpha(g, b, shape, ax, ay, bx, by) < 1.0:
                clear = False
                break
        out[j] = clear


@inline_kernel
def segment_fractions(
    geometry: StaticGeometry,
    b: int,
    leaves: np.ndarray,
    count: int,
    segments: np.ndarray,
    out: np.ndarray,
    depths: np.ndarray,
) -> None:
    """``out[q]``: the fraction in [0, 1] of ``segments[q]`` (``[ax, ay, bx, by]``)
    before the first shape of world ``b`` that it hits, 1.0 when clear:
    ``segment_query_first(a, b, 0.0, filter).alpha`` (1.0 for None) for a filter that
    passes every static shape. Tries the first ``count`` ``leaves`` (as
    :func:`sight_lines` does); ``depths``: scratch as long as ``leaves`` for the tree
    search (:func:`_tree_fraction`)."""
    g = geometry
    boxes, tree = g.tree_boxes, g.tree
    for q in range(segments.shape[0]):
        ax, ay, bx, by = segments[q, 0], segments[q, 1], segments[q, 2], segments[q, 3]
        best, best_entry, runner_up = 1.0, math.inf, 1.0
        for i in range(count):
            node = leaves[i]
            entry = _node_entry(boxes, b, node, ax, ay, bx, by)
            if entry < 1.0:
                alpha = shape_alpha(g, b, tree[b, node, 2], ax, ay, bx, by)
                best, best_entry, runner_up = _ranked(alpha, entry, best, best_entry, runner_up)
        # Until the best shape is tried, the bound is 1 or another shape's alpha, so at
        # least runner_up; every box on the way to it is entered at best_entry or
        # before. Below runner_up, nothing can prune it.
        if best == 1.0 or best_entry < runner_up:
            out[q] = best
        else:
            out[q] = _tree_fraction(g, b, ax, ay, bx, by, depths)


@kernel
def line_of_sight(
    geometry: StaticGeometry,
    b: int,
    ax: float,
    ay: float,
    bx: float,
    by: float,
    skip_circle: int,
) -> bool:
    """One :func:`sight_lines` query against every shape of world ``b``."""
    leaves = np.empty(geometry.tree.shape[1], dtype=np.int64)
    count = all_leaves(geometry, b, leaves)
    out = np.empty(1, dtype=np.bool_)
    sight_lines(
        geometry, b, leaves, count, ax, ay, np.array([[bx, by]]), np.array([skip_circle]), 1,
        out,
    )  # fmt: skip
    return out[0]


@kernel
def ray_fraction(
    geometry: StaticGeometry, b: int, ax: float, ay: float, bx: float, by: float
) -> float:
    """One :func:`segment_fractions` query against every shape of world ``b``."""
    leaves = np.empty(geometry.tree.shape[1], dtype=np.int64)
    count = all_leaves(geometry, b, leaves)
    out = np.empty(1)
    depths = np.empty_like(leaves)
    segment_fractions(geometry, b, leaves, count, np.array([[ax, ay, bx, by]]), out, depths)
    return out[0]


# Tree levels whose child still to search is kept in the bits of an int64; deeper ones
# (only long rows of shapes make them) go to the caller's scratch, cleared when first
# needed.
_BIT_LEVELS = 63


@kernel
def _tree_fraction(
    geometry: StaticGeometry,
    b: int,
    ax: float,
    ay: float,
    bx: float,
    by: float,
    deep: np.ndarray,
) -> float:
    """:func:`ray_fraction` by searching world ``b``'s tree exactly as pymunk 7.3 does.

    Between an inner node and its descendants, Chipmunk's stack can only hold that
    node's second child, pushed or not when the node was popped. So the walk keeps,
    per depth on the current path, which child (if any) is still to be searched, and
    when a subtree is done climbs to the deepest depth with one: the same order
    without a stack (numba cannot cache a recursive function, and allocating a stack
    per query would cost more than the search). ``deep``: (tree width,) int64 scratch
    for the depths beyond the bits."""
    g = geometry
    tree, boxes = g.tree, g.tree_boxes
    if g.counts[b, N_SEGMENTS] + g.counts[b, N_POLYGONS] + g.counts[b, N_CIRCLES] == 0:
        return 1.0
    best = 1.0
    node = 0  # the root is searched without a box test
    depth = 0
    pending_a = 0  # bit d: the node at depth d on the path has child_a still to search
    pending_b = 0  # ... or child_b
    deep_used = False  # deep[d]: the same for depths ≥ _BIT_LEVELS: 0, 1 (a), 2 (b)
    while True:
        shape = tree[b, node, 2]
        if shape < 0:
            child_a, child_b = tree[b, node, 0], tree[b, node, 1]
            t_a = _node_entry(boxes, b, child_a, ax, ay, bx, by)
            t_b = _node_entry(boxes, b, child_b, ax, ay, bx, by)
            # the child entered first is searched first (child_b on a tie)
            if t_a < t_b:
                first, t_first, later, t_later, later_code = child_a, t_a, child_b, t_b, 2
            else:
                first, t_first, later, t_later, later_code = child_b, t_b, child_a, t_a, 1
            if t_first < best:
                if t_later < best:  # pushed under the first: searched after its subtree
                    if depth < _BIT_LEVELS:
                        if later_code == 1:
                            pending_a |= 1 << depth
                        else:
                            pending_b |= 1 << depth
                    else:
                        if not deep_used:
                            deep[:] = 0
                            deep_used = True
                        deep[depth] = later_code
                node = first
                depth += 1
                continue
            if t_later < best:
                node = later
                depth += 1
                continue
        else:
            alpha = shape_alpha(g, b, shape, ax, ay, bx, by)
            if alpha < best:
                best = alpha
        # This subtree is done: climb to the deepest node with a child still to search.
        if pending_a == 0 and pending_b == 0 and not deep_used:
            return best
        while True:
            if depth == 0:
                return best
            depth -= 1
            node = tree[b, node, 3]
            if depth < _BIT_LEVELS:
                bit = 1 << depth
                if pending_a & bit:
                    pending_a &= ~bit
                    node = tree[b, node, 0]
                    break
                if pending_b & bit:
                    pending_b &= ~bit
                    node = tree[b, node, 1]
                    break
            elif deep_used and deep[depth] != 0:
                node = tree[b, node, deep[depth] - 1]
                deep[depth] = 0
                break
        depth += 1


# ----------------------------------------------------------------------------- batches


@kernel
def lines_of_sight(
    geometry: StaticGeometry,
    worlds: np.ndarray,
    segments: np.ndarray,
    skip_circles: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[q] = line_of_sight(geometry, worlds[q], *segments[q], skip_circles[q])``
    for Q queries: ``worlds`` (Q,) int64, ``segments`` (Q, 4) ``[ax, ay, bx, by]``,
    ``skip_circles`` (Q,) int64, ``out`` (Q,) bool."""
    leaves = np.empty(geometry.tree.shape[1], dtype=np.int64)
    for q in range(worlds.shape[0]):
        b = worlds[q]
        count = all_leaves(geometry, b, leaves)
        sight_lines(
            geometry, b, leaves, count, segments[q, 0], segments[q, 1], segments[q:q + 1, 2:],
            skip_circles[q:q + 1], 1, out[q:q + 1],
        )  # fmt: skip


@kernel
def ray_fractions(
    geometry: StaticGeometry, worlds: np.ndarray, segments: np.ndarray, out: np.ndarray
) -> None:
    """``out[q] = ray_fraction(geometry, worlds[q], *segments[q])`` for Q queries:
    ``worlds`` (Q,) int64, ``segments`` (Q, 4) ``[ax, ay, bx, by]``, ``out`` (Q,)
    float64."""
    leaves = np.empty(geometry.tree.shape[1], dtype=np.int64)
    depths = np.empty_like(leaves)
    for q in range(worlds.shape[0]):
        b = worlds[q]
        count = all_leaves(geometry, b, leaves)
        segment_fractions(geometry, b, leaves, count, segments[q : q + 1], out[q : q + 1], depths)


@inline_kernel
def beam_segments(
    x: float, y: float, theta: float, angles: np.ndarray, reach: float, out: np.ndarray
) -> None:
    """``out[k]`` (``[ax, ay, bx, by]``): the beam of length ``reach`` from (x, y) at
    ``angles[k]`` (rad) from the heading θ."""
    for k in range(angles.shape[0]):
        out[k, 0] = x
        out[k, 1] = y
        out[k, 2] = x + reach * math.cos(theta + angles[k])
        out[k, 3] = y + reach * math.sin(theta + angles[k])


@kernel
def range_scan(
    geometry: StaticGeometry,
    b: int,
    x: float,
    y: float,
    theta: float,
    angles: np.ndarray,
    max_range: float,
    out: np.ndarray,
) -> None:
    """The proximity scan of world ``b`` from the pose (x, y, θ): ``out[k]`` (m) is the
    free distance along the beam at ``angles[k]`` (rad, robot frame), at most
    ``max_range``: the :func:`ray_fraction` of the beam from (x, y) to
    (x + max_range·cos(θ + a), y + max_range·sin(θ + a)), times ``max_range``."""
    leaves = np.empty(geometry.tree.shape[1], dtype=np.int64)
    count = near_leaves(geometry, b, x, y, max_range, leaves)
    segments = np.empty((angles.shape[0], 4))
    beam_segments(x, y, theta, angles, max_range, segments)
    segment_fractions(geometry, b, leaves, count, segments, out, np.empty_like(leaves))
    for k in range(angles.shape[0]):
        out[k] *= max_range
