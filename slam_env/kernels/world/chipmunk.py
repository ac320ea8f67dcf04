"""What Chipmunk (the C engine of pymunk 7.3) caches for a static shape, and the
bounding-box tree of a space's static shapes, computed from plain shapes with
Chipmunk's own arithmetic (plain Python for the shapes, a compiled kernel for the
tree; run when a world is built).

The compiled segment queries (:mod:`slam_env.kernels.world.raycast`) reproduce pymunk's bit
for bit only on the same data: the same polygon hull and vertex order, the same unit
normals, the same boxes, and the same tree, whose visiting order decides which of two
hits an ulp apart a query keeps. Nothing here reads pymunk; the tests hold each piece
to what pymunk's public API shows of it, and the queries to pymunk's queries.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from slam_env.kernels.base.compiling import inline_kernel, kernel

__all__ = ["Box", "bb_tree", "chipmunk_hull", "circle_box", "polygon_data", "segment_data"]

Point = tuple[float, float]
Box = tuple[float, float, float, float]  # cpBB: left, bottom, right, top

# Chipmunk's transforms (a, b, c, d, tx, ty): x' = a·x + c·y + tx, y' = b·x + d·y + ty.
# pymunk builds a polygon with the identity as its vertex transform; a static body at
# the origin with angle 0 has c = −sin 0 = −0.0. They move nothing, but they are applied
# as Chipmunk applies them, so that even the signs of zeros are the same.
_PYMUNK_IDENTITY = (1.0, 0.0, 0.0, 1.0, 0.0, 0.0)
_STATIC_BODY = (1.0, 0.0, -0.0, 1.0, 0.0, 0.0)
_DBL_MIN = sys.float_info.min  # cpvnormalize adds it to the length: no division by 0


def _transform_point(t: tuple[float, ...], x: float, y: float) -> Point:
    """cpTransformPoint."""
    a, b, c, d, tx, ty = t
    return (a * x + c * y + tx, b * x + d * y + ty)


def _transform_vector(t: tuple[float, ...], x: float, y: float) -> Point:
    """cpTransformVect."""
    a, b, c, d, _, _ = t
    return (a * x + c * y, b * x + d * y)


def _normalize(x: float, y: float) -> Point:
    """cpvnormalize."""
    s = 1.0 / (math.sqrt(x * x + y * y) + _DBL_MIN)
    return (x * s, y * s)


def _fmin(a: float, b: float) -> float:
    """cpfmin (which of two equal values it returns can matter for the sign of 0)."""
    return a if a < b else b


def _fmax(a: float, b: float) -> float:
    """cpfmax."""
    return a if a > b else b


# ----------------------------------------------------------------------------- shapes


def segment_data(a: Point, b: Point, radius: float) -> tuple[tuple[float, ...], Box]:
    """A capsule on the static body: its row ``[ax, ay, bx, by, radius, nx, ny]``, with
    n = rperp(normalize(b − a)) (cpSegmentShapeInit, then the cached transform), and
    its box (cpSegmentShapeCacheData)."""
    ux, uy = _normalize(b[0] - a[0], b[1] - a[1])
    nx, ny = _transform_vector(_STATIC_BODY, uy, -ux)
    ax, ay = _transform_point(_STATIC_BODY, *a)
    bx, by = _transform_point(_STATIC_BODY, *b)
    left, right = (ax, bx) if ax < bx else (bx, ax)
    bottom, top = (ay, by) if ay < by else (by, ay)
    box = (left - radius, bottom - radius, right + radius, top + radius)
    return (ax, ay, bx, by, radius, nx, ny), box


def polygon_data(vertices: tuple[Point, ...]) -> tuple[list[Point], list[Point], Box]:
    """A polygon of radius 0 on the static body, as cpPolyShapeNew and its cached data
    make it: the vertices (pymunk's identity transform, Chipmunk's convex hull, the
    body's transform), the normal of the edge ending at each vertex,
    normalize(rperp(v_i − v_{i−1})), and the box."""
    hull = chipmunk_hull([_transform_point(_PYMUNK_IDENTITY, x, y) for x, y in vertices])
    verts: list[Point] = []
    normals: list[Point] = []
    left, bottom, right, top = math.inf, math.inf, -math.inf, -math.inf
    for i in range(len(hull)):
        (x0, y0), (x1, y1) = hull[i - 1], hull[i]
        nx, ny = _normalize(y1 - y0, -(x1 - x0))
        vx, vy = _transform_point(_STATIC_BODY, x1, y1)
        verts.append((vx, vy))
        normals.append(_transform_vector(_STATIC_BODY, nx, ny))
        left, right = _fmin(left, vx), _fmax(right, vx)
        bottom, top = _fmin(bottom, vy), _fmax(top, vy)
    # The polygon's radius, 0, widens the box as Chipmunk adds it.
    return verts, normals, (left - 0.0, bottom - 0.0, right + 0.0, top + 0.0)


def circle_box(cx: float, cy: float, r: float) -> Box:
    """cpBBNewForCircle."""
    return (cx - r, cy - r, cx + r, cy + r)


def circle_centre(c: Point) -> Point:
    """A circle's centre on the static body (cpCircleShapeCacheData)."""
    return _transform_point(_STATIC_BODY, *c)


# ----------------------------------------------------------------------------- hull


def chipmunk_hull(points: list[Point]) -> list[Point]:
    """The convex hull of ``points`` exactly as Chipmunk's cpConvexHull (tolerance 0)
    returns it: counter-clockwise, starting from the lowest-x point (lowest y among
    ties), with collinear and repeated points dropped. The order matters: a polygon's
    segment query keeps the last edge it hits, and a ray through a vertex hits two.

    QuickHull: split by the line through the extreme points, keep the point farthest
    from each side's line, recurse on the points outside the two new edges."""
    if not points:
        return []
    buf = list(points)
    start = end = 0
    lo = hi = buf[0]
    for i in range(1, len(buf)):
        v = buf[i]
        if v[0] < lo[0] or (v[0] == lo[0] and v[1] < lo[1]):
            lo, start = v, i
        elif v[0] > hi[0] or (v[0] == hi[0] and v[1] > hi[1]):
            hi, end = v, i
    if start == end:
        return [buf[0]]
    buf[0], buf[start] = buf[start], buf[0]
    j = start if end == 0 else end
    buf[1], buf[j] = buf[j], buf[1]
    # The hull is written over the front of the same buffer as Chipmunk does it, so
    # that the points still to be read are the same ones.
    n = _hull_reduce(buf, 2, len(buf) - 2, buf[0], buf[1], buf[0], 1) + 1
    return buf[:n]


def _hull_partition(buf: list[Point], first: int, count: int, a: Point, b: Point) -> int:
    """Move the points of buf[first:first+count] strictly left of a → b to the front,
    the farthest one first; return how many there are (QHullPartition)."""
    if count == 0:
        return 0
    dx, dy = b[0] - a[0], b[1] - a[1]
    farthest, pivot = 0.0, 0
    head, tail = 0, count - 1
    while head <= tail:
        px, py = buf[first + head]
        value = (px - a[0]) * dy - (py - a[1]) * dx  # cpvcross(p − a, b − a)
        if value > 0.0:
            if value > farthest:
                farthest, pivot = value, head
            head += 1
        else:
            h, t = first + head, first + tail
            buf[h], buf[t] = buf[t], buf[h]
            tail -= 1
    if pivot != 0:
        buf[first], buf[first + pivot] = buf[first + pivot], buf[first]
    return head


def _hull_reduce(
    buf: list[Point], first: int, count: int, a: Point, pivot: Point, b: Point, out: int
) -> int:
    """Write the hull vertices between a and b (pivot, the farthest point, among them)
    at buf[out:]; return how many (QHullReduce)."""
    if count < 0:
        return 0
    if count == 0:
        buf[out] = pivot
        return 1
    left = _hull_partition(buf, first, count, a, pivot)
    index = _hull_reduce(buf, first + 1, left - 1, a, buf[first], pivot, out)
    buf[out + index] = pivot
    index += 1
    right = _hull_partition(buf, first + left, count - left, pivot, b)
    if right == 0:  # nothing outside pivot → b: the edge is on the hull
        return index
    return index + _hull_reduce(
        buf, first + left + 1, right - 1, pivot, buf[first + left], b, out + index
    )


# ----------------------------------------------------------------------------- tree


@inline_kernel
def _merged_area(a: np.ndarray, b: np.ndarray) -> float:
    """cpBBMergedArea (cpfmin/cpfmax: ``a if a < b else b``, which keeps the sign of 0
    that Chipmunk keeps)."""
    right = a[2] if a[2] > b[2] else b[2]
    left = a[0] if a[0] < b[0] else b[0]
    top = a[3] if a[3] > b[3] else b[3]
    bottom = a[1] if a[1] < b[1] else b[1]
    return (right - left) * (top - bottom)


@inline_kernel
def _area(a: np.ndarray) -> float:
    """cpBBArea."""
    return (a[2] - a[0]) * (a[3] - a[1])


@inline_kernel
def _proximity(a: np.ndarray, b: np.ndarray) -> float:
    """cpBBProximity: the distance between the boxes' centres, doubled, in the L1 norm."""
    return abs(a[0] + a[2] - b[0] - b[2]) + abs(a[1] + a[3] - b[1] - b[3])


@inline_kernel
def _merge_into(out: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
    """out ← cpBBMerge(a, b) (``out`` may be ``a``)."""
    left = a[0] if a[0] < b[0] else b[0]
    bottom = a[1] if a[1] < b[1] else b[1]
    right = a[2] if a[2] > b[2] else b[2]
    top = a[3] if a[3] > b[3] else b[3]
    out[0], out[1], out[2], out[3] = left, bottom, right, top


@kernel
def _build_tree(boxes: np.ndarray, tree: np.ndarray, tree_boxes: np.ndarray) -> None:
    """The tree of :func:`bb_tree` into ``tree`` (2n − 1, 4) int64 and ``tree_boxes``
    (2n − 1, 4) for ``boxes`` (n, 4), n ≥ 1.

    SubtreeInsert, leaf after leaf in the boxes' order: from the root, descend to the
    child whose box grows least (by area, then by centre distance), pair the leaf with
    the leaf found there under a new node, and widen the boxes above it. Then the
    nodes are numbered depth first, child a before child b."""
    n = boxes.shape[0]
    m = 2 * n - 1
    # Nodes in creation order: children, shape (−1 inner), parent, box.
    child_a = np.full(m, -1, np.int64)
    child_b = np.full(m, -1, np.int64)
    shape = np.full(m, -1, np.int64)
    parent = np.full(m, -1, np.int64)
    box = np.empty((m, 4))
    root = -1
    count = 0
    for k in range(n):
        leaf = count
        count += 1
        box[leaf] = boxes[k]
        shape[leaf] = k
        if root < 0:
            root = leaf
            continue
        node = root
        while shape[node] < 0:
            a, b = child_a[node], child_b[node]
            ba, bb, bl = box[a], box[b], box[leaf]
            cost_a = _area(bb) + _merged_area(ba, bl)
            cost_b = _area(ba) + _merged_area(bb, bl)
            if cost_a == cost_b:
                cost_a, cost_b = _proximity(ba, bl), _proximity(bb, bl)
            node = b if cost_b < cost_a else a
        above = parent[node]
        pair = count
        count += 1
        _merge_into(box[pair], box[leaf], box[node])
        child_a[pair], child_b[pair] = leaf, node
        parent[leaf] = pair
        parent[node] = pair
        parent[pair] = above
        if above < 0:
            root = pair
            continue
        if child_a[above] == node:
            child_a[above] = pair
        else:
            child_b[above] = pair
        while above >= 0:
            _merge_into(box[above], box[above], box[leaf])
            above = parent[above]
    # Depth first, child a before child b: a stack of (node, its parent's new index,
    # which side of that parent it is).
    stack = np.empty((m, 3), np.int64)
    stack[0, 0], stack[0, 1], stack[0, 2] = root, -1, 0
    top = 1
    index = 0
    while top > 0:
        top -= 1
        node, above, side = stack[top, 0], stack[top, 1], stack[top, 2]
        if above >= 0:
            tree[above, side] = index
        tree[index, 0] = -1
        tree[index, 1] = -1
        tree[index, 2] = shape[node]
        tree[index, 3] = above
        tree_boxes[index] = box[node]
        if shape[node] < 0:
            stack[top, 0], stack[top, 1], stack[top, 2] = child_b[node], index, 1
            stack[top + 1, 0], stack[top + 1, 1], stack[top + 1, 2] = child_a[node], index, 0
            top += 2
        index += 1


def bb_tree(boxes: list[Box]) -> tuple[np.ndarray, np.ndarray]:
    """The bounding-box tree that Chipmunk's static index builds when shapes with
    these boxes are added to a space in this order (cpBBTreeInsert, no re-indexing).

    Returns its 2n − 1 nodes (none for no boxes) in depth-first order, the root first,
    as rows ``(child_a, child_b, shape, parent)`` ((2n − 1, 4) int64): an inner node's
    two children (node indices) and shape −1, or a leaf's −1, −1 and its box's index;
    the parent's index (−1 for the root). And each node's box ((2n − 1, 4))."""
    n = len(boxes)
    tree = np.empty((max(2 * n - 1, 0), 4), dtype=np.int64)
    tree_boxes = np.empty((tree.shape[0], 4))
    if n:
        _build_tree(np.array(boxes, dtype=np.float64).reshape(n, 4), tree, tree_boxes)
    return tree, tree_boxes
