"""PROVISIONAL static geometry (the geometry engineer's exact version replaces it)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam_env.kernels import kernel


class Geometry(NamedTuple):
    segments: np.ndarray  # (B, S, 5) ax, ay, bx, by, radius
    n_segments: np.ndarray  # (B,)
    polygons: np.ndarray  # (B, P, V, 2) counter-clockwise
    polygon_sizes: np.ndarray  # (B, P)
    n_polygons: np.ndarray  # (B,)
    circles: np.ndarray  # (B, C, 3) cx, cy, r
    n_circles: np.ndarray  # (B,)


def empty_geometry(num_envs: int) -> Geometry:
    z = np.zeros(num_envs, dtype=np.int64)
    return Geometry(
        np.zeros((num_envs, 0, 5)),
        z.copy(),
        np.zeros((num_envs, 0, 0, 2)),
        np.zeros((num_envs, 0), dtype=np.int64),
        z.copy(),
        np.zeros((num_envs, 0, 3)),
        z.copy(),
    )


def set_world(geometry: Geometry, b: int, layout, wall_thickness: float, post_radius: float):
    t = wall_thickness
    W, H = layout.width, layout.height
    corners = ((-t, -t), (W + t, -t), (W + t, H + t), (-t, H + t))
    segs = [(*corners[i], *corners[(i + 1) % 4], t) for i in range(4)]
    segs += [(*w, t) for w in layout.walls]
    polys = [list(p) for p in layout.obstacles]
    circs = [(x, y, post_radius) for x, y in layout.landmark_positions]
    B = geometry.n_segments.shape[0]
    S = max(geometry.segments.shape[1], len(segs))
    P = max(geometry.polygons.shape[1], len(polys))
    V = max(geometry.polygons.shape[2], max((len(p) for p in polys), default=0))
    C = max(geometry.circles.shape[1], len(circs))
    g = geometry
    if (g.segments.shape[1], g.polygons.shape[1], g.polygons.shape[2], g.circles.shape[1]) != (
        S,
        P,
        V,
        C,
    ):
        seg = np.zeros((B, S, 5))
        seg[:, : g.segments.shape[1]] = g.segments
        pol = np.zeros((B, P, V, 2))
        pol[:, : g.polygons.shape[1], : g.polygons.shape[2]] = g.polygons
        psz = np.zeros((B, P), dtype=np.int64)
        psz[:, : g.polygon_sizes.shape[1]] = g.polygon_sizes
        cir = np.zeros((B, C, 3))
        cir[:, : g.circles.shape[1]] = g.circles
        g = Geometry(seg, g.n_segments, pol, psz, g.n_polygons, cir, g.n_circles)
    g.segments[b, : len(segs)] = segs
    g.n_segments[b] = len(segs)
    for k, p in enumerate(polys):
        g.polygons[b, k, : len(p)] = p
        g.polygon_sizes[b, k] = len(p)
    g.n_polygons[b] = len(polys)
    g.circles[b, : len(circs)] = circs
    g.n_circles[b] = len(circs)
    return g


@kernel
def _ray_circle(ax, ay, dx, dy, cx, cy, r) -> float:
    fx, fy = ax - cx, ay - cy
    a = dx * dx + dy * dy
    bq = fx * dx + fy * dy
    c = fx * fx + fy * fy - r * r
    if c <= 0.0:
        return 0.0
    disc = bq * bq - a * c
    if disc < 0.0 or a == 0.0:
        return 2.0
    t = (-bq - math.sqrt(disc)) / a
    return t if 0.0 <= t <= 1.0 else 2.0


@kernel
def _ray_segment(ax, ay, dx, dy, px, py, qx, qy) -> float:
    ex, ey = qx - px, qy - py
    den = dx * ey - dy * ex
    if den == 0.0:
        return 2.0
    wx, wy = px - ax, py - ay
    t = (wx * ey - wy * ex) / den
    s = (wx * dy - wy * dx) / den
    if 0.0 <= t <= 1.0 and 0.0 <= s <= 1.0:
        return t
    return 2.0


@kernel
def _first_hit(g, b, ax, ay, bx, by, skip) -> float:
    dx, dy = bx - ax, by - ay
    best = 2.0
    for k in range(g.n_segments[b]):
        px, py, qx, qy, r = g.segments[b, k]
        best = min(best, _ray_circle(ax, ay, dx, dy, px, py, r))
        best = min(best, _ray_circle(ax, ay, dx, dy, qx, qy, r))
        ex, ey = qx - px, qy - py
        n = math.hypot(ex, ey)
        if n > 0.0:
            nx, ny = -ey / n * r, ex / n * r
            best = min(best, _ray_segment(ax, ay, dx, dy, px + nx, py + ny, qx + nx, qy + ny))
            best = min(best, _ray_segment(ax, ay, dx, dy, px - nx, py - ny, qx - nx, qy - ny))
    for k in range(g.n_polygons[b]):
        m = g.polygon_sizes[b, k]
        inside = True
        for v in range(m):
            px, py = g.polygons[b, k, v]
            qx, qy = g.polygons[b, k, (v + 1) % m]
            if (qx - px) * (ay - py) - (qy - py) * (ax - px) < 0.0:
                inside = False
            best = min(best, _ray_segment(ax, ay, dx, dy, px, py, qx, qy))
        if inside:
            best = 0.0
    for k in range(g.n_circles[b]):
        if k == skip:
            continue
        best = min(
            best,
            _ray_circle(ax, ay, dx, dy, g.circles[b, k, 0], g.circles[b, k, 1], g.circles[b, k, 2]),
        )
    return best


@kernel
def line_of_sight(g, b, ax, ay, bx, by, skip) -> bool:
    return _first_hit(g, b, ax, ay, bx, by, skip) > 1.0


@kernel
def ray_fraction(g, b, ax, ay, bx, by) -> float:
    return min(_first_hit(g, b, ax, ay, bx, by, -1), 1.0)
