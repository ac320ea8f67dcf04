"""The codes of :class:`~slam_env.smoothing.isam2.ISAM2SLAM`'s record of its iSAM2
updates (numpy only), and :func:`update_op`, which makes one: each update is a tuple
of arrays, its factors and new values by kind, with their numbers one after another
in a flat payload."""

from __future__ import annotations

import numpy as np

__all__ = [
    "FACTOR_SIZES", "MEASURE", "MOTION", "POINT", "POSE", "PRIOR", "VALUE_SIZES", "update_op",
]  # fmt: skip

# The factors' kinds: a prior on the start pose, a motion factor between two poses, a
# measurement of a landmark from a pose.
PRIOR, MOTION, MEASURE = 0, 1, 2
# The values' kinds.
POSE, POINT = 0, 1
# The numbers each kind takes in a payload: the prior's pose (3) and world-frame
# covariance (9); the motion factor's increment D (3) and its covariance P (9); the
# measurement z (2). A pose (x, y, θ), a point (x, y).
FACTOR_SIZES = {PRIOR: 12, MOTION: 12, MEASURE: 2}
VALUE_SIZES = {POSE: 3, POINT: 2}


def update_op(
    fkinds: list[int],
    fkeys: list[tuple[int, int]],
    fdata: list[np.ndarray],
    vkinds: list[int],
    vkeys: list[int],
    vdata: list[np.ndarray],
    stamped: tuple[int, ...],
    now: float,
) -> tuple:
    """One iSAM2 update as the record keeps it: a tuple of arrays (Python's garbage
    collector leaves such tuples alone, where a tuple per factor would be walked at
    every collection): the factors' kinds ``(m,) int8``, keys ``(m, 2) uint64`` and
    payloads (flat float64, see :data:`FACTOR_SIZES`), the
    new values' kinds, keys and numbers, and with a window the keys stamped ``now``."""
    return (
        "update",
        np.array(fkinds, dtype=np.int8),
        np.array(fkeys, dtype=np.uint64).reshape(-1, 2),
        np.concatenate([np.ravel(d) for d in fdata]).astype(np.float64),
        np.array(vkinds, dtype=np.int8),
        np.array(vkeys, dtype=np.uint64),
        np.concatenate([np.ravel(d) for d in vdata]) if vdata else np.empty(0),
        np.array(stamped, dtype=np.uint64),
        now,
    )
