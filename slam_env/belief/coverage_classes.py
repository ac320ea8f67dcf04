"""The classes behind the incremental coverage features: each offset from the robot's
cell gets a ring and a fine bearing bin of the world frame, such that under every
heading bin a class lies in one region, the one the grid's region codes give it.

With F = lcm(heading_bins, 2·sectors) fine bins a turn, every heading and every sector
edge falls on a fine-bin edge, so under heading bin h the sector of fine bin f is, in
integers, ``((f − h·F/heading_bins + F/(2·sectors)) mod F) // (F/sectors)``
(:func:`sector_of_fine_bin`). Nothing here rests on that being the floating-point
truth: each offset's bin is the one (of the bin its bearing rounds down to and the two
beside it) that reproduces ``codes`` for every heading bin, and a grid where some
offset has none, or whose F is too large, gets no classes: its features come from a
scan of every cell (:mod:`slam_env.kernels.belief.coverage`).
"""

from __future__ import annotations

import math

import numpy as np

# Fine bins a turn at the most: each world keeps two prefix sums of F + 1 counts per
# ring, and a newly swept cell updates up to F of them.
MAX_FINE_BINS = 4096


def fine_bins(heading_bins: int, sectors: int) -> int:
    """F: the fewest equal bearing bins a turn whose edges hold every heading bin's
    sector edges."""
    return math.lcm(heading_bins, 2 * sectors)


def class_counts_shape(heading_bins: int, sectors: int, rings: int) -> tuple[int, int, int]:
    """The shape of one world's class counts: (all and unswept, rings, F + 1 prefix
    sums)."""
    return 2, rings, fine_bins(heading_bins, sectors) + 1


def sector_of_fine_bin(fine: np.ndarray, h: int, heading_bins: int, sectors: int) -> np.ndarray:
    """The sector that fine bin(s) ``fine`` fall in under heading bin ``h`` (int64)."""
    bins = fine_bins(heading_bins, sectors)
    turned = (fine - h * (bins // heading_bins) + bins // (2 * sectors)) % bins
    return turned // (bins // sectors)


def offset_classes(codes: np.ndarray, heading_bins: int, sectors: int) -> np.ndarray | None:
    """(2ny − 1, 2nx − 1) int64: each offset's class as its slot in a world's ring-wise
    prefix sums, ring·(F + 1) + fine bin + 1, for ``codes`` ((heading_bins, 2ny − 1,
    2nx − 1), 2·region + 1 per heading bin and offset, region = ring·sectors + sector);
    None where F exceeds :data:`MAX_FINE_BINS` or no class reproduces some offset's
    codes under every heading bin."""
    bins = fine_bins(heading_bins, sectors)
    if bins > MAX_FINE_BINS:
        return None
    oy, ox = codes.shape[1:]
    di = np.arange(oy)[:, None] - (oy - 1) // 2
    dj = np.arange(ox)[None, :] - (ox - 1) // 2
    # A first guess only: the candidates are checked against the codes. The robot's own
    # cell (atan2(0, 0) = 0) counts at bearing 0, as the codes have it.
    bearing = np.arctan2(di, dj) % (2.0 * math.pi)
    guess = np.floor(bearing * (bins / (2.0 * math.pi))).astype(np.int64)
    ring = (codes[0].astype(np.int64) // 2) // sectors
    chosen = np.full(codes.shape[1:], -1, dtype=np.int64)
    for shift in (0, -1, 1):
        candidate = (guess + shift) % bins
        fits = chosen < 0
        for h in range(heading_bins):
            sector = sector_of_fine_bin(candidate, h, heading_bins, sectors)
            fits &= codes[h] == 2 * (ring * sectors + sector) + 1
        chosen[fits] = candidate[fits]
    if np.any(chosen < 0):
        return None
    return ring * (bins + 1) + chosen + 1
