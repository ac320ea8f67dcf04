"""Swept-area coverage of B worlds: mark the sensor's footprint swept from each
world's estimated pose, count the new cells, and summarise the unswept share per
sector and ring around the robot (the rules: :class:`slam_env.belief.coverage.CoverageGrid`,
which builds the tables once).

The summary is incremental where the grid allows it. Each world keeps its arena cells
counted by class (ring, fine bearing bin of the world frame) around the robot's cell,
all and unswept, as prefix sums over the fine bins ring by ring: the region of any
heading bin is a run of fine bins, so its count is two lookups. The counts are rebuilt
only when the robot's cell changes (or a world's grid was reset or edited); a cell the
sweep adds moves out of the unswept counts at once. A grid whose classes would not
reproduce its region codes exactly (:mod:`slam_env.belief.coverage_classes`) scans every cell
each step instead (:func:`_features_at`), as the tests' reference does."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from slam_env.kernels.base.compiling import kernel

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
    classes: np.ndarray  # (2ny − 1, 2nx − 1) int64: the slot ring·(fine + 1) + bin + 1
    # of every offset's class in a world's ring-wise prefix sums, ``fine`` bins a turn;
    # (0, 0) for a grid that scans every cell instead
    footprint_classes: np.ndarray  # (heading_bins, K) int64 ((0, 0) when scanning): the
    # slot of each footprint entry's class, 0 for an entry outside the offsets' window
    # (it lies in the always-swept border, so it is never newly swept)


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
    footprint_classes: np.ndarray,
    nx: int,
    swept: np.ndarray,
    unswept: np.ndarray,
    i: int,
    j: int,
    h: int,
) -> int:
    """Mark the footprint of heading bin h from cell (i, j) in ``swept`` (one world's
    flattened padded grid); return how many cells it newly swept. Each of them leaves
    ``unswept``, a world's prefix sums of its unswept cells by class ((rings, fine + 1),
    see :func:`_count_classes`; (rings, 0) for a grid that scans instead)."""
    # The window's corner sits at padded (i, j): the robot's cell is (i + pad, j + pad).
    corner = i * (nx + 2 * pad) + j
    width = unswept.shape[1]
    new = 0
    for k in range(footprint_sizes[h]):
        cell = corner + footprints[h, k]
        if not swept[cell]:
            swept[cell] = True
            new += 1
            if width:
                # A class's cells count in every sum from its slot to the ring's end.
                ring, first = divmod(footprint_classes[h, k], width)
                for f in range(first, width):
                    unswept[ring, f] -= 1
    return new


@kernel
def _count_classes(
    pad: int, classes: np.ndarray, swept: np.ndarray, i: int, j: int, counts: np.ndarray
) -> None:
    """``counts`` ((2, rings, fine + 1) int64): per ring, the prefix sums over the fine
    bins of the arena cells (``counts[0]``) and of the unswept ones (``counts[1]``) by
    class around cell (i, j): ``counts[·, r, f]`` counts the classes of ring r before
    fine bin f. ``swept`` is one world's flattened padded grid."""
    ny = (classes.shape[0] + 1) // 2
    nx = (classes.shape[1] + 1) // 2
    stride = nx + 2 * pad
    rings, width = counts.shape[1], counts.shape[2]
    # Each cell counts at its class's slot, one past its fine bin; the sums below carry
    # it to the later slots. (One-dimensional views and row slices: about twice as
    # fast as indexing the 3-D counts.)
    arena = counts[0].reshape(rings * width)
    unswept = counts[1].reshape(rings * width)
    arena[:] = 0
    unswept[:] = 0
    for r in range(ny):
        # Row views from the first cell on; the loop reads the row's nx cells.
        class_row = classes[ny - 1 - i + r, nx - 1 - j :]
        grid_row = swept[(r + pad) * stride + pad :]
        for c in range(nx):
            slot = class_row[c]
            arena[slot] += 1
            if not grid_row[c]:
                unswept[slot] += 1
    for r in range(rings):
        # Summed in locals: through the array, each add would wait on the last store.
        all_before = unswept_before = 0
        for f in range(width):
            all_before += counts[0, r, f]
            unswept_before += counts[1, r, f]
            counts[0, r, f] = all_before
            counts[1, r, f] = unswept_before


@kernel
def _features_of_classes(heading_bins: int, counts: np.ndarray, h: int, out: np.ndarray) -> None:
    """``out[1:]`` (rings·sectors,): the unswept share per region (0 for a region with
    no arena cell) for heading bin h, from a world's class counts ``counts`` ((2, rings,
    fine + 1), see :func:`_count_classes`)."""
    rings = counts.shape[1]
    fine = counts.shape[2] - 1
    sectors = (out.shape[0] - 1) // rings
    span = fine // sectors
    # Sector 0 is centred on the heading, h·fine/heading_bins bins round the turn;
    # each sector is the run of ``span`` fine bins from ``start``, wrapping at ``fine``.
    start = (h * (fine // heading_bins) - span // 2) % fine
    for s in range(sectors):
        end = start + span
        for r in range(rings):
            if end <= fine:
                arena = counts[0, r, end] - counts[0, r, start]
                unswept = counts[1, r, end] - counts[1, r, start]
            else:
                arena = counts[0, r, fine] - counts[0, r, start] + counts[0, r, end - fine]
                unswept = counts[1, r, fine] - counts[1, r, start] + counts[1, r, end - fine]
            out[1 + r * sectors + s] = unswept / max(arena, 1)
        start = end - fine if end >= fine else end


@kernel
def _features_at(
    pad: int,
    codes: np.ndarray,
    swept: np.ndarray,
    i: int,
    j: int,
    counts: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[1:]``: the unswept share per region (0 for a region with no arena cell)
    from cell (i, j), ``codes`` of its heading bin, by a scan of every cell; ``counts``
    scratch. The reference of the class counts, and what a grid without them runs."""
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
    classes: np.ndarray,
    footprint_classes: np.ndarray,
    swept: np.ndarray,
    n_swept: np.ndarray,
    held: np.ndarray,
    class_counts: np.ndarray,
    poses: np.ndarray,
    sweep: bool,
    new_cells: np.ndarray,
    features: np.ndarray,
    counts: np.ndarray,
    active: np.ndarray,
) -> None:
    """One step of B worlds' coverage (the :class:`CoverageTables` first, then the
    state): if ``sweep``, sweep world b's footprint from the pose (x, y, θ) in the
    first three columns of ``poses[b]`` (a belief's means ``x`` will do) into
    ``swept[b]`` ((B, padded cells) bool, flattened), ``new_cells[b]`` the cells it
    added to ``n_swept[b]``; then ``features[b]`` ((B, 1 + F) float64): the swept
    fraction, then the unswept share per sector and ring around the pose.

    ``class_counts[b]`` ((B, 2, rings, fine + 1) int64; (B, 2, rings, 0) for a grid
    without ``classes``) holds world b's class counts (:func:`_count_classes`) around
    the cell ``held[b]`` ((B,) int64, row·nx + column; −1: none, to be counted afresh,
    as after a reset or an edit of ``swept[b]``). ``counts``: (2·F,) int64 scratch."""
    nx = (codes.shape[2] + 1) // 2
    size = nx * ((codes.shape[1] + 1) // 2)
    scanning = class_counts.shape[3] == 0
    for b in range(poses.shape[0]):
        if not active[b]:
            continue
        i, j = cell_of(cell, codes, poses[b, 0], poses[b, 1])
        h = heading_bin(heading_bins, poses[b, 2])
        if sweep:
            new_cells[b] = _sweep_at(
                pad, footprints, footprint_sizes, footprint_classes, nx, swept[b],
                class_counts[b, 1], i, j, h,
            )  # fmt: skip
            n_swept[b] += new_cells[b]
        features[b, 0] = n_swept[b] / size
        if scanning:
            _features_at(pad, codes[h], swept[b], i, j, counts, features[b])
            continue
        if held[b] != i * nx + j:
            # The sweep above took its cells off counts about another cell: recounted.
            _count_classes(pad, classes, swept[b], i, j, class_counts[b])
            held[b] = i * nx + j
        _features_of_classes(heading_bins, class_counts[b], h, features[b])
