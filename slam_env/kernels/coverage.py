"""Swept-area coverage of B worlds: mark the sensor's footprint swept from each
world's estimated pose, count the new cells, and summarise the unswept share per
sector and ring around the robot (the rules: :class:`slam_env.coverage.CoverageGrid`,
which builds the tables once)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam_env.kernels import kernel

TWO_PI = 2.0 * math.pi


class CoverageTables(NamedTuple):
    """The grid's geometry, shared by the B worlds (ny × nx cells, padded by ``pad``
    always-swept cells on every side so that a footprint never needs clipping);
    the kernels take it unpacked, its fields first."""

    cell: float  # m, the cell side
    heading_bins: int  # directions the heading is rounded to
    pad: int  # cells of padding
    footprints: np.ndarray  # (heading_bins, K) int64: the footprint per heading bin,
    # as offsets into the flattened padded grid from the corner of the robot's
    # (2·pad + 1)² window; row h holds footprint_sizes[h] of them
    footprint_sizes: np.ndarray  # (heading_bins,) int64
    codes: np.ndarray  # (heading_bins, 2ny − 1, 2nx − 1) unsigned: 2·region + 1 of
    # every offset (row, column) − (ny − 1, nx − 1) from the robot's cell


@kernel
def cell_of(cell: float, codes: np.ndarray, x: float, y: float) -> tuple[int, int]:
    """(row, column) of the cell holding (x, y), clamped into the grid of ``codes``
    (a NaN coordinate: the first cell)."""
    ny = (codes.shape[1] + 1) // 2
    nx = (codes.shape[2] + 1) // 2
    # Clamped before the floor, which an infinity would overflow.
    i = 0 if y != y else math.floor(min(max(y / cell, 0.0), ny - 1.0))
    j = 0 if x != x else math.floor(min(max(x / cell, 0.0), nx - 1.0))
    return i, j


@kernel
def heading_bin(heading_bins: int, theta: float) -> int:
    """The heading bin nearest to θ (NaN or infinite: bin 0)."""
    if not math.isfinite(theta):
        return 0
    return round(theta % TWO_PI * (heading_bins / TWO_PI)) % heading_bins


@kernel
def _sweep_at(
    pad: int,
    footprints: np.ndarray,
    footprint_sizes: np.ndarray,
    nx: int,
    swept: np.ndarray,
    i: int,
    j: int,
    h: int,
) -> int:
    """Mark the footprint of heading bin h from cell (i, j) in ``swept`` (one world's
    flattened padded grid); return how many cells it newly swept."""
    # The window's corner sits at padded (i, j): the robot's cell is (i + pad, j + pad).
    corner = i * (nx + 2 * pad) + j
    new = 0
    for k in range(footprint_sizes[h]):
        cell = corner + footprints[h, k]
        if not swept[cell]:
            swept[cell] = True
            new += 1
    return new


@kernel
def _features_at(
    pad: int,
    codes: np.ndarray,
    swept: np.ndarray,
    n_swept: int,
    i: int,
    j: int,
    counts: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out`` (1 + F,): the swept fraction, then the unswept share per region (0 for a
    region with no arena cell) from cell (i, j), ``codes`` of its heading bin;
    ``counts`` scratch."""
    ny = (codes.shape[0] + 1) // 2
    nx = (codes.shape[1] + 1) // 2
    stride = nx + 2 * pad
    counts[:] = 0
    for r in range(ny):
        code_row = ny - 1 - i + r
        grid_row = (r + pad) * stride + pad
        for c in range(nx):
            # 2·region + 1 less the swept flag: each (region, swept) pair has a code.
            code = np.int64(codes[code_row, nx - 1 - j + c])
            counts[code - np.int64(swept[grid_row + c])] += 1
    out[0] = n_swept / (nx * ny)
    for k in range(counts.shape[0] // 2):
        unswept = counts[2 * k + 1]
        out[1 + k] = unswept / max(counts[2 * k] + unswept, 1)


@kernel
def coverage_step(
    cell: float,
    heading_bins: int,
    pad: int,
    footprints: np.ndarray,
    footprint_sizes: np.ndarray,
    codes: np.ndarray,
    swept: np.ndarray,
    n_swept: np.ndarray,
    poses: np.ndarray,
    sweep: bool,
    new_cells: np.ndarray,
    features: np.ndarray,
    active: np.ndarray,
) -> None:
    """One step of B worlds' coverage (the :class:`CoverageTables` first, then the
    state): if ``sweep``, sweep world b's footprint from the pose (x, y, θ) in the
    first three columns of ``poses[b]`` (a belief's means ``x`` will do) into
    ``swept[b]`` ((B, padded cells) bool, flattened), ``new_cells[b]`` the cells it
    added to ``n_swept[b]``; then ``features[b]`` ((B, 1 + F) float64): the swept
    fraction, then the unswept share per sector and ring around the pose."""
    nx = (codes.shape[2] + 1) // 2
    counts = np.empty(2 * (features.shape[1] - 1), dtype=np.int64)
    for b in range(poses.shape[0]):
        if not active[b]:
            continue
        i, j = cell_of(cell, codes, poses[b, 0], poses[b, 1])
        h = heading_bin(heading_bins, poses[b, 2])
        if sweep:
            new_cells[b] = _sweep_at(pad, footprints, footprint_sizes, nx, swept[b], i, j, h)
            n_swept[b] += new_cells[b]
        _features_at(pad, codes[h], swept[b], n_swept[b], i, j, counts, features[b])
