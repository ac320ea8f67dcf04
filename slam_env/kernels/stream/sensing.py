"""The landmark sensor and the proximity scan of B worlds.

One scan of one world, in this order (see :class:`slam_env.sensing.landmark_sensor.LandmarkSensor`
for the model):

1. *Range and field of view*, in ascending landmark-ID order: the true range
   ``r ≤ max_range`` and the true bearing ``|φ| ≤ fov / 2`` (both inclusive; a full
   circle sees all around).
2. *Detection probability*: the j-th landmark in ID order is kept when its uniform
   ``u[j] < p`` (not read when p = 1), so the draws do not depend on the row order.
3. *Occlusion*: the line of sight from the robot to the landmark, blocked by walls,
   obstacles and other landmarks' posts (exact geometry,
   :mod:`slam_env.kernels.world.static_geometry`).
4. *max_detections*: the nearest ones are kept (true range, ties by ID), still in ID
   order.
5. *Noise*: detection j gets the normal pair of uniforms ``2j, 2j + 1`` (Box–Muller),
   scaled by the standard deviations; none is drawn when they are both zero.

A scan consumes :func:`scan_uniforms` uniforms, whatever it finds, so that a step
always consumes the same number from each sub-env's stream.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from slam_env.kernels.base.angles import wrap
from slam_env.kernels.base.compiling import borrowing_kernel, kernel
from slam_env.kernels.base.models import CARTESIAN, RANGE_BEARING, observe, range_bearing_observe
from slam_env.kernels.base.random import normal_pair
from slam_env.kernels.world.raycast import (
    beam_segments,
    near_leaves,
    segment_fractions,
    sight_lines,
)
from slam_env.kernels.world.static_geometry import StaticGeometry


class SensorParams(NamedTuple):
    """The landmark sensor's constants, as the kernels take them."""

    max_range: float  # m
    half_fov: float  # rad, half the opening angle
    all_around: bool  # the field of view is a full circle
    detection_prob: float  # in (0, 1]
    max_detections: int  # rows of the padded output, D
    cartesian: bool  # z = R(θ)ᵀ(m − t) instead of [r, φ]
    std0: float  # σr (m), or σz (m) for the cartesian model
    std1: float  # σφ (rad), or σz (m)


class SensingScratch(NamedTuple):
    """The sensing kernels' workspaces, allocated by the caller (:func:`sensing_scratch`)
    so that the kernels allocate nothing and can borrow their arrays (see
    :func:`slam_env.kernels.base.compiling.borrowing_kernel`)."""

    rows: np.ndarray  # (N,) int64: landmark rows in view
    found: np.ndarray  # (N, 3): their true range and noise-free measurement
    targets: np.ndarray  # (N, 2): their positions, the sight lines' ends
    clear: np.ndarray  # (N,) bool: the sight lines not blocked
    leaves: np.ndarray  # (tree width,) int64: the shapes near the robot
    depths: np.ndarray  # (tree width,) int64: the tree search's (raycast._tree_fraction)
    segments: np.ndarray  # (beams, 4): the beams as segments


def sensing_scratch(n_landmarks: int, tree_width: int, beams: int) -> tuple:
    """A :class:`SensingScratch`, as a plain tuple, for worlds of ``n_landmarks``
    landmark rows, static geometry trees ``tree_width`` wide and ``beams`` beams."""
    return tuple(
        SensingScratch(
            rows=np.empty(n_landmarks, dtype=np.int64),
            found=np.empty((n_landmarks, 3)),
            targets=np.empty((n_landmarks, 2)),
            clear=np.empty(n_landmarks, dtype=np.bool_),
            leaves=np.empty(tree_width, dtype=np.int64),
            depths=np.empty(tree_width, dtype=np.int64),
            segments=np.empty((beams, 4)),
        )
    )


def scan_uniforms(n_landmarks: int, max_detections: int) -> int:
    """Uniforms one scan consumes: one per landmark (detection probability), then two
    per output row (the noise of one detection)."""
    return n_landmarks + 2 * max_detections


@kernel
def in_view(
    x: float,
    y: float,
    theta: float,
    landmarks: np.ndarray,
    id_order: np.ndarray,
    params: SensorParams,
    uniforms: np.ndarray,
    rows: np.ndarray,
    found: np.ndarray,
) -> int:
    """Steps 1 and 2 for the pose (x, y, θ): the rows of the landmarks in range, in
    view and detected, in ID order, into ``rows``, with their true range and their
    noise-free measurement (r, z0, z1) into ``found``; returns how many."""
    p = params.detection_prob
    model = CARTESIAN if params.cartesian else RANGE_BEARING
    k = 0
    for j in range(id_order.shape[0]):
        i = id_order[j]
        mx, my = landmarks[i, 0], landmarks[i, 1]
        # Visibility on the true range and bearing, the measurement the model's h.
        r, phi = range_bearing_observe(x, y, theta, mx, my)
        if not r <= params.max_range:
            continue
        if not params.all_around and not (-params.half_fov <= phi <= params.half_fov):
            continue
        if p < 1.0 and not uniforms[j] < p:
            continue
        z0, z1 = observe(model, x, y, theta, mx, my)
        rows[k] = i
        found[k, 0] = r
        found[k, 1] = z0
        found[k, 2] = z1
        k += 1
    return k


@kernel
def _keep(rows: np.ndarray, found: np.ndarray, j: int, k: int) -> None:
    """Move candidate j to position k (k ≤ j): compaction in place."""
    rows[k] = rows[j]
    for c in range(found.shape[1]):
        found[k, c] = found[j, c]


@kernel
def _nearest_first_rank(found: np.ndarray, k: int, j: int) -> int:
    """How many of the k candidates come before candidate j by (range, ID order)."""
    r = found[j, 0]
    rank = 0
    for m in range(k):
        if found[m, 0] < r or (found[m, 0] == r and m < j):
            rank += 1
    return rank


@kernel
def emit_detections(
    rows: np.ndarray,
    found: np.ndarray,
    k: int,
    params: SensorParams,
    uniforms: np.ndarray,
    ids: np.ndarray,
    out_z: np.ndarray,
    out_ids: np.ndarray,
    out_rows: np.ndarray,
) -> int:
    """Steps 4 and 5: the detections of the k visible candidates into the outputs (D
    rows, ID order); returns the count."""
    limit = params.max_detections
    noisy = params.std0 > 0.0 or params.std1 > 0.0
    n = 0
    for j in range(k):
        if k > limit and _nearest_first_rank(found, k, j) >= limit:
            continue
        e0, e1 = 0.0, 0.0
        if noisy:
            e0, e1 = normal_pair(uniforms[2 * n], uniforms[2 * n + 1])
        out_z[n, 0] = found[j, 1] + e0 * params.std0
        # The noisy bearing is wrapped again; the noisy range is not clipped at 0
        # (that would bias it).
        z1 = found[j, 2] + e1 * params.std1
        out_z[n, 1] = z1 if params.cartesian else wrap(z1)
        out_rows[n] = rows[j]
        out_ids[n] = ids[rows[j]]
        n += 1
    return n


@borrowing_kernel
def sense_landmarks(
    poses: np.ndarray,
    landmarks: np.ndarray,
    landmark_ids: np.ndarray,
    id_order: np.ndarray,
    geometry_fields: tuple,
    params_fields: tuple,
    uniforms: np.ndarray,
    offset: int,
    active: np.ndarray,
    out_z: np.ndarray,
    out_ids: np.ndarray,
    out_rows: np.ndarray,
    out_count: np.ndarray,
    scratch: tuple,
) -> None:
    """One scan of each active world b from ``poses[b]``.

    Args:
        poses: (B, 3) true poses (x, y, θ).
        landmarks: (B, N, 2) landmark positions; landmark_ids (B, N) their IDs;
            id_order (B, N) the rows in ascending ID order (stable).
        geometry_fields: the fields of the B worlds' :class:`StaticGeometry` (post i of
            world b is landmark row i), as a plain tuple (see :mod:`slam_env.kernels`).
        params_fields: the fields of the :class:`SensorParams`, a plain tuple.
        uniforms: (B, W) this step's uniforms; the scan reads columns
            ``offset : offset + scan_uniforms(N, D)``.
        active: (B,) the worlds to scan; the others' outputs are left as they are.
        out_z: (B, D, 2) measurements; out_ids (B, D) IDs; out_rows (B, D) landmark
            rows; out_count (B,) detections per world, first in each row block.
        scratch: a :class:`SensingScratch` (:func:`sensing_scratch`), a plain tuple.
    """
    geometry = StaticGeometry(*geometry_fields)
    params = SensorParams(*params_fields)
    n_rows = landmarks.shape[1]
    rows, found, targets, clear, leaves, _, _ = scratch
    for b in range(poses.shape[0]):
        if not active[b]:
            continue
        x, y, theta = poses[b, 0], poses[b, 1], poses[b, 2]
        u = uniforms[b, offset:]
        k = in_view(x, y, theta, landmarks[b], id_order[b], params, u, rows, found)
        if k:  # every sight line at once, against the shapes within the range
            near = near_leaves(geometry, b, x, y, params.max_range, leaves)
            for j in range(k):
                targets[j, 0] = landmarks[b, rows[j], 0]
                targets[j, 1] = landmarks[b, rows[j], 1]
            sight_lines(geometry, b, leaves, near, x, y, targets, rows, k, clear)
        visible = 0
        for j in range(k):
            if clear[j]:
                _keep(rows, found, j, visible)
                visible += 1
        out_count[b] = emit_detections(
            rows,
            found,
            visible,
            params,
            u[n_rows:],
            landmark_ids[b],
            out_z[b],
            out_ids[b],
            out_rows[b],
        )


@borrowing_kernel
def proximity_scan(
    poses: np.ndarray,
    geometry_fields: tuple,
    beam_angles: np.ndarray,
    reach: float,
    active: np.ndarray,
    out: np.ndarray,
    scratch: tuple,
) -> None:
    """The free fraction of each beam, in [0, 1]: out (B, beams) float32, beam k at
    ``beam_angles[k]`` (rad, robot frame) from the robot's centre, ``reach`` m long,
    stopped by the first wall, obstacle or post (``geometry_fields``: the fields of the
    :class:`StaticGeometry`, a plain tuple; ``scratch``: a :class:`SensingScratch`)."""
    geometry = StaticGeometry(*geometry_fields)
    _, _, _, _, leaves, depths, segments = scratch
    for b in range(poses.shape[0]):
        if not active[b]:
            continue
        x, y, theta = poses[b, 0], poses[b, 1], poses[b, 2]
        count = near_leaves(geometry, b, x, y, reach, leaves)  # once for all beams
        beam_segments(x, y, theta, beam_angles, reach, segments)
        segment_fractions(geometry, b, leaves, count, segments, out[b], depths)
