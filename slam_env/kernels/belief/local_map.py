"""The count-independent ("local") belief encoding of B worlds: robot features, the K
nearest known landmarks in the estimated robot frame and an egocentric local map
(layout: :class:`slam_env.belief.local_encoding.LocalEncoding`), float32, clipped; and the
memory of the obstacles the proximity scan has hit, which the map shows."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel, inline_kernel

# Channels of the local map, in order.
UNSWEPT, OBSTACLE, OUTSIDE, LANDMARK = 0, 1, 2, 3
MAP_CHANNELS = 4
# Sub-samples per local-map cell side (each is looked up in the arena grids).
SUBSAMPLES = 2


class LocalParams(NamedTuple):
    """What fixes the features (passed to :func:`encode_local` unpacked)."""

    scales: np.ndarray  # (7,) float64: width, height (m, the arena), max_range (m, the
    # scale of robot-frame positions), position and heading std scales (σ → tanh(σ/s)),
    # landmarks in the world (for the mapped share), local map cell side (m)
    cell: float  # m, the side of a cell of the arena grids (coverage and obstacles)
    pad: int  # always-swept cells around the coverage grid
    rel_bound: float  # |robot-frame coordinate / max_range| beyond which a belief clips
    robot_bounds: np.ndarray  # (2, 8) float64: the robot features' low and high rows


@inline_kernel
def _tanh_std(variance: float, scale: float) -> float:
    """tanh(σ / scale), a negative variance (round-off) read as 0; NaN stays NaN."""
    return math.tanh(math.sqrt(0.0 if variance < 0.0 else variance) / scale)


@inline_kernel
def _bounded(v: float, low: float, high: float) -> tuple[float, bool]:
    """v clipped into [low, high] (NaN read as 0), and whether it had to be."""
    if low <= v <= high:
        return v, False
    return min(max(0.0 if math.isnan(v) else v, low), high), True


@borrowing_kernel
def mark_scan_hits(
    x: np.ndarray,
    scan: np.ndarray,
    beam_angles: np.ndarray,
    reach: float,
    cell: float,
    obstacles: np.ndarray,
    active: np.ndarray,
) -> None:
    """Mark in ``obstacles[b]`` ((B, ny, nx) bool, cell ``cell`` m, row i at
    y ∈ [i·cell, (i+1)·cell)) the cell just behind each beam's hit, seen from world
    b's estimated pose ``x[b, :3]``: beam k at ``beam_angles[k]`` (rad, robot frame)
    read ``scan[b, k]`` (the free fraction of ``reach`` m; 1 is no hit). A hit outside
    the arena (a wall, or a diverged pose) or from a non-finite pose is not marked."""
    ny, nx = obstacles.shape[1], obstacles.shape[2]
    behind = 0.25 * cell  # the hit lies on the surface: look just behind it
    for b in range(x.shape[0]):
        if not active[b]:
            continue
        px, py, theta = x[b, 0], x[b, 1], x[b, 2]
        if not (math.isfinite(px) and math.isfinite(py) and math.isfinite(theta)):
            continue
        for k in range(beam_angles.shape[0]):
            free = scan[b, k]
            if not free < 1.0:
                continue
            d = free * reach + behind
            a = theta + beam_angles[k]
            hx, hy = px + d * math.cos(a), py + d * math.sin(a)
            if 0.0 <= hx < nx * cell and 0.0 <= hy < ny * cell:
                obstacles[b, int(hy / cell), int(hx / cell)] = True


@borrowing_kernel
def encode_local(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    slot_to_id: np.ndarray,
    scales: np.ndarray,
    cell: float,
    pad: int,
    rel_bound: float,
    robot_bounds: np.ndarray,
    swept: np.ndarray,
    obstacles: np.ndarray,
    robot: np.ndarray,
    landmarks: np.ndarray,
    local_map: np.ndarray,
    clipped: np.ndarray,
    active: np.ndarray,
    dist: np.ndarray,
    order: np.ndarray,
) -> None:
    """World b's features (the belief, then the :class:`LocalParams` unpacked, then the
    grids): ``swept`` (B, ny + 2·pad, nx + 2·pad) bool, the coverage grid with its
    always-swept border; ``obstacles`` (B, ny, nx) bool, from :func:`mark_scan_hits`.
    Outputs (float32): ``robot`` (B, 8), ``landmarks`` (B, 4K), ``local_map``
    (B, C·S·S) with C = :data:`MAP_CHANNELS`, S the map side in cells, row-major
    (channel, row along the robot's left, column along its heading); ``clipped`` (B,)
    bool: the belief left the bounds (or held a NaN) and was clipped onto them.
    ``dist`` (M,) float64 and ``order`` (M,) int64: scratch, M ≥ the slots (≥ 1)."""
    width, height, max_range, position_scale, heading_scale, total, map_cell = scales
    k_max = landmarks.shape[1] // 4
    side = round(math.sqrt(local_map.shape[1] // MAP_CHANNELS))
    ny, nx = obstacles.shape[1], obstacles.shape[2]
    share = 1.0 / (SUBSAMPLES * SUBSAMPLES)
    for b in range(x.shape[0]):
        if not active[b]:
            continue
        px, py, theta = x[b, 0], x[b, 1], x[b, 2]
        c, s = math.cos(theta), math.sin(theta)
        out_of_bounds = False
        feats = (
            _tanh_std(P[b, 0, 0], position_scale),
            _tanh_std(P[b, 1, 1], position_scale),
            _tanh_std(P[b, 2, 2], heading_scale),
            c,
            s,
            px / width,
            py / height,
            n[b] / total,
        )
        for i in range(8):
            v, cut = _bounded(feats[i], robot_bounds[0, i], robot_bounds[1, i])
            out_of_bounds |= cut
            robot[b, i] = np.float32(v)

        # The K nearest known landmarks, nearest first (ties: the earlier state slot).
        count = n[b]
        for i in range(count):
            row = 3 + 2 * i
            dx, dy = x[b, row] - px, x[b, row + 1] - py
            d = dx * dx + dy * dy
            dist[i] = math.inf if math.isnan(d) else d
            order[i] = i
        taken = min(count, k_max)
        for j in range(taken):  # a partial selection sort: K is small
            best = j
            for i in range(j + 1, count):
                if dist[order[i]] < dist[order[best]]:
                    best = i
            order[j], order[best] = order[best], order[j]
        landmarks[b, :] = 0.0
        ck, sk = c / max_range, s / max_range
        for j in range(taken):
            row = 3 + 2 * order[j]
            dx, dy = x[b, row] - px, x[b, row + 1] - py
            fx, cut_x = _bounded(dx * ck + dy * sk, -rel_bound, rel_bound)
            fy, cut_y = _bounded(dy * ck - dx * sk, -rel_bound, rel_bound)
            sigma, cut_s = _bounded(
                _tanh_std(P[b, row, row] + P[b, row + 1, row + 1], position_scale), 0.0, 1.0
            )
            out_of_bounds |= cut_x | cut_y | cut_s
            landmarks[b, 4 * j] = 1.0
            landmarks[b, 4 * j + 1] = np.float32(fx)
            landmarks[b, 4 * j + 2] = np.float32(fy)
            landmarks[b, 4 * j + 3] = np.float32(sigma)
        clipped[b] = out_of_bounds

        local_map[b, :] = 0.0
        if not (math.isfinite(px) and math.isfinite(py) and math.isfinite(theta)):
            continue  # a diverged pose: an empty map (the flag says why)
        plane = side * side
        half = 0.5 * side * map_cell
        for r in range(side):
            for q in range(side):
                unswept = 0.0
                outside = 0.0
                hit = 0.0
                for u in range(SUBSAMPLES):
                    for v in range(SUBSAMPLES):
                        # Robot frame: forward along the columns, left along the rows.
                        fx = (q + (v + 0.5) / SUBSAMPLES) * map_cell - half
                        fy = (r + (u + 0.5) / SUBSAMPLES) * map_cell - half
                        wx = px + c * fx - s * fy
                        wy = py + s * fx + c * fy
                        if not (0.0 <= wx < nx * cell and 0.0 <= wy < ny * cell):
                            outside += share
                            continue
                        i, j = int(wy / cell), int(wx / cell)
                        if not swept[b, i + pad, j + pad]:
                            unswept += share
                        if obstacles[b, i, j]:
                            hit = 1.0
                at = r * side + q
                local_map[b, UNSWEPT * plane + at] = np.float32(unswept)
                local_map[b, OBSTACLE * plane + at] = np.float32(hit)
                local_map[b, OUTSIDE * plane + at] = np.float32(outside)
        # Each known landmark in its cell: 0.25 + 0.75·tanh(σ/scale), the largest wins.
        inv = 1.0 / map_cell
        for i in range(count):
            row = 3 + 2 * i
            dx, dy = x[b, row] - px, x[b, row + 1] - py
            fq = (dx * c + dy * s + half) * inv
            fr = (dy * c - dx * s + half) * inv
            if not (0.0 <= fq < side and 0.0 <= fr < side):  # NaN too
                continue
            sigma = _tanh_std(P[b, row, row] + P[b, row + 1, row + 1], position_scale)
            mark = 0.25 + 0.75 * (1.0 if math.isnan(sigma) else sigma)
            at = LANDMARK * plane + int(fr) * side + int(fq)
            if mark > local_map[b, at]:
                local_map[b, at] = np.float32(mark)
