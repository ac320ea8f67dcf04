"""Chipmunk's segment query against one shape, and its bounding-box test, compiled:
the pieces of :mod:`slam_env.kernels.world.raycast`.

Each mirrors the C of the engine pymunk 7.3 bundles (Munk2D, a Chipmunk 7 fork),
operation for operation, for a query of radius 0 against a static shape, because the
grazing cases are decided by round-off:

* cpShapeSegmentQuery first asks whether the start point lies inside or on the shape
  (its point query): if so the hit is at alpha 0.
* Circles solve CircleSegmentQuery's quadratic; a tangent ray hits when the
  discriminant rounds to ≥ 0. A zero-length query never hits a circle (0/0).
* Capsules (walls) intersect the face pushed out by the radius when the query crosses
  the face's extent, and otherwise try the two end circles.
* Polygons try each edge that the start lies outside of; an edge is skipped when the
  query's extent along its normal is under :data:`POLYGON_PARALLEL_TOLERANCE`, and the
  *last* edge hit wins, which decides rays through a vertex.

Each returns the shape's alpha in [0, 1] or 1.0 when it finds none; a hit at exactly 1
counts for nothing in segment_query_first either. Divisions by zero are ruled out
before they happen, with the answers the C's infinities and NaNs would give.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import inline_kernel, kernel
from slam_env.kernels.world.static_geometry import N_POLYGONS, N_SEGMENTS, StaticGeometry

__all__ = [
    "POLYGON_PARALLEL_TOLERANCE",
    "box_entry",
    "distance_sq_to_segment",
    "query_box_entry",
    "shape_alpha",
]

# cpPolyShapeSegmentQuery skips an edge when |a·n − b·n| is below this ("10e-6").
POLYGON_PARALLEL_TOLERANCE = 1e-5


@kernel
def _slab(
    low: float, high: float, a: float, d: float, tmin: float, tmax: float
) -> tuple[float, float]:
    """One axis of cpBBSegmentQuery (d ≠ 0): [tmin, tmax] narrowed to the alphas where
    a + alpha·d lies in [low, high]."""
    t1 = (low - a) / d
    t2 = (high - a) / d
    lo = t1 if t1 < t2 else t2  # cpfmin
    hi = t1 if t1 > t2 else t2  # cpfmax
    return (tmin if tmin > lo else lo), (tmax if tmax < hi else hi)


@kernel
def box_entry(
    left: float, bottom: float, right: float, top: float, ax: float, ay: float, bx: float, by: float
) -> float:
    """cpBBSegmentQuery: the alpha (≥ 0) where a → b enters the box, ∞ if it misses."""
    dx = bx - ax
    dy = by - ay
    tmin = -math.inf
    tmax = math.inf
    if dx == 0.0:
        if ax < left or right < ax:
            return math.inf
    else:
        tmin, tmax = _slab(left, right, ax, dx, tmin, tmax)
    if dy == 0.0:
        if ay < bottom or top < ay:
            return math.inf
    else:
        tmin, tmax = _slab(bottom, top, ay, dy, tmin, tmax)
    if tmin <= tmax and tmax >= 0.0 and tmin <= 1.0:
        return tmin if tmin > 0.0 else 0.0
    return math.inf


@kernel
def query_box_entry(
    left: float, bottom: float, right: float, top: float, ax: float, ay: float, bx: float, by: float
) -> float:
    """:func:`box_entry`, or ∞ at once for a query that lies wholly on one side of the
    box. That shortcut changes no answer: the box test rounds monotonically, so such a
    box's entry alpha would be ≥ 1 (or its exit < 0), and no query searches a box it
    enters at 1 or later."""
    if (ax < left and bx < left) or (ax > right and bx > right):
        return math.inf
    if (ay < bottom and by < bottom) or (ay > top and by > top):
        return math.inf
    return box_entry(left, bottom, right, top, ax, ay, bx, by)


@kernel
def _clamp01(num: float, den: float) -> float:
    """cpfclamp01(num / den), with den == 0 answered as the C's ±∞ or NaN would be."""
    if den == 0.0:  # ±∞ clamps to 1 or 0; NaN (0/0) passes cpfmin(NaN, 1) as 1
        return 0.0 if num < 0.0 else 1.0
    t = num / den
    t = t if t < 1.0 else 1.0  # cpfmin(t, 1)
    return 0.0 if t < 0.0 else t  # cpfmax(0, t)


@kernel
def distance_sq_to_segment(
    px: float, py: float, ax: float, ay: float, bx: float, by: float
) -> float:
    """|p − c|² for c = cpClosetPointOnSegment(p, a, b), with Chipmunk's rounding.
    Chipmunk takes the square root; it is 0 exactly when this is."""
    dx = ax - bx
    dy = ay - by
    t = _clamp01(dx * (px - bx) + dy * (py - by), dx * dx + dy * dy)
    ex = px - (bx + dx * t)
    ey = py - (by + dy * t)
    return ex * ex + ey * ey


@kernel
def _circle_alpha(
    cx: float, cy: float, r: float, ax: float, ay: float, bx: float, by: float
) -> float:
    """CircleSegmentQuery (no point query): where a → b enters the circle."""
    dax = ax - cx
    day = ay - cy
    dbx = bx - cx
    dby = by - cy
    aa = dax * dax + day * day
    ab = dax * dbx + day * dby
    bb = dbx * dbx + dby * dby
    qa = aa - 2.0 * ab + bb
    qb = ab - aa
    det = qb * qb - qa * (aa - r * r)
    if det >= 0.0 and qa != 0.0:  # qa == 0: t is ±∞ or NaN, never in [0, 1]
        t = (-qb - math.sqrt(det)) / qa
        if t >= 0.0 and t <= 1.0:
            return t
    return 1.0


@kernel
def _segment_shape_alpha(
    sax: float,
    say: float,
    sbx: float,
    sby: float,
    r: float,
    nx: float,
    ny: float,
    ax: float,
    ay: float,
    bx: float,
    by: float,
) -> float:
    """The capsule from (sax, say) to (sbx, sby) of radius r and unit normal (nx, ny):
    0 when a is within r of the segment, else cpSegmentShapeSegmentQuery."""
    if math.sqrt(distance_sq_to_segment(ax, ay, sax, say, sbx, sby)) - r <= 0.0:
        return 0.0
    d = (sax - ax) * nx + (say - ay) * ny
    fx, fy = (-nx, -ny) if d > 0.0 else (nx, ny)  # the normal facing a
    ox = fx * r - ax
    oy = fy * r - ay
    fax = sax + ox  # the face pushed out by r, relative to a
    fay = say + oy
    fbx = sbx + ox
    fby = sby + oy
    qx = bx - ax
    qy = by - ay
    if (qx * fay - qy * fax) * (qx * fby - qy * fbx) <= 0.0:
        d_offset = d + (-r if d > 0.0 else r)
        ad = -d_offset
        bd = (qx * nx + qy * ny) - d_offset
        if ad * bd < 0.0:  # opposite signs: ad − bd ≠ 0
            return ad / (ad - bd)
        return 1.0
    if r != 0.0:
        t1 = _circle_alpha(sax, say, r, ax, ay, bx, by)
        t2 = _circle_alpha(sbx, sby, r, ax, ay, bx, by)
        return t1 if t1 < t2 else t2
    return 1.0


@kernel
def _polygon_shape_alpha(
    verts: np.ndarray,
    normals: np.ndarray,
    b: int,
    k: int,
    n: int,
    ax: float,
    ay: float,
    bx: float,
    by: float,
) -> float:
    """Polygon k of world b, of radius 0, ``verts[b, k, :n]`` and ``normals[b, k, :n]``
    in Chipmunk's order: 0 when a is inside or on it, else cpPolyShapeSegmentQuery."""
    outside = False
    for i in range(n):
        if (
            normals[b, k, i, 0] * (ax - verts[b, k, i, 0])
            + normals[b, k, i, 1] * (ay - verts[b, k, i, 1])
            > 0.0
        ):
            outside = True
            break
    if not outside:
        return 0.0
    for i in range(n):  # on an edge: its closest point is at distance 0
        j = i - 1 if i > 0 else n - 1
        px, py = verts[b, k, j, 0], verts[b, k, j, 1]
        if distance_sq_to_segment(ax, ay, px, py, verts[b, k, i, 0], verts[b, k, i, 1]) == 0.0:
            return 0.0

    alpha = 1.0
    for i in range(n):
        nx, ny = normals[b, k, i, 0], normals[b, k, i, 1]
        an = ax * nx + ay * ny
        # − (the polygon's radius 0 + the query's radius 0), as the C subtracts it
        d = an - (verts[b, k, i, 0] * nx + verts[b, k, i, 1] * ny) - 0.0
        if d < 0.0:
            continue
        bn = bx * nx + by * ny
        if an - bn < POLYGON_PARALLEL_TOLERANCE and an - bn > -POLYGON_PARALLEL_TOLERANCE:
            continue
        t = d / (an - bn)
        if t < 0.0 or t > 1.0:
            continue
        s = 1.0 - t  # cpvlerp(a, b, t) = a·(1 − t) + b·t
        dt = nx * (ay * s + by * t) - ny * (ax * s + bx * t)
        j = i - 1 if i > 0 else n - 1
        dt_min = nx * verts[b, k, j, 1] - ny * verts[b, k, j, 0]
        dt_max = nx * verts[b, k, i, 1] - ny * verts[b, k, i, 0]
        if dt_min <= dt and dt <= dt_max:
            alpha = t  # no break: a later edge that also matches wins
    return alpha


@inline_kernel
def shape_alpha(
    geometry: StaticGeometry, b: int, shape: int, ax: float, ay: float, bx: float, by: float
) -> float:
    """cpShapeSegmentQuery's alpha for a → b (radius 0) against shape ``shape`` of
    world ``b`` (numbered segments, then polygons, then circles), 1.0 when it finds
    none: 0 when a is inside or on the shape, else the shape's own segment query."""
    g = geometry
    n_segments = g.counts[b, N_SEGMENTS]
    if shape < n_segments:
        s = g.segments
        return _segment_shape_alpha(
            s[b, shape, 0],
            s[b, shape, 1],
            s[b, shape, 2],
            s[b, shape, 3],
            s[b, shape, 4],
            s[b, shape, 5],
            s[b, shape, 6],
            ax,
            ay,
            bx,
            by,
        )
    k = shape - n_segments
    n_polygons = g.counts[b, N_POLYGONS]
    if k < n_polygons:
        n = g.polygon_sizes[b, k]
        return _polygon_shape_alpha(g.polygons, g.polygon_normals, b, k, n, ax, ay, bx, by)
    i = k - n_polygons
    cx, cy, r = g.circles[b, i, 0], g.circles[b, i, 1], g.circles[b, i, 2]
    dx = ax - cx
    dy = ay - cy
    if math.sqrt(dx * dx + dy * dy) - r <= 0.0:
        return 0.0
    return _circle_alpha(cx, cy, r, ax, ay, bx, by)
