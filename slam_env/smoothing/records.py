"""The codes of :class:`~slam_env.smoothing.isam2.ISAM2SLAM`'s record of its iSAM2
updates (numpy only): each update is a tuple of arrays, its factors and new values
by kind, with their numbers one after another in a flat payload."""

from __future__ import annotations

__all__ = ["FACTOR_SIZES", "MEASURE", "MOTION", "POINT", "POSE", "PRIOR", "VALUE_SIZES"]

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
