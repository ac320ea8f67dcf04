"""The codes every filter kernel shares (:mod:`slam_env.kernels.ekf.filter`,
:mod:`.corrections`, :mod:`.new_landmarks`, :mod:`.association`,
:mod:`.association_score`) and the Python side reads back (:mod:`slam_env.ekf.filter`):
the columns of the per-world configuration, the modes, the per-observation statuses and
the per-world error codes. Constants only, nothing compiled.

Configuration, per world
    params (B, 12) float64         :data:`NOISE` (α1..α4 for odometry, σp, σθ, βp, βθ for
                                   velocity), :data:`Q00`, :data:`Q01`, :data:`Q11` (the
                                   measurement covariance) and :data:`GATE` (the χ²
                                   threshold; ``inf`` accepts everything), then the
                                   association's :data:`MATCH_GATE`, :data:`NEW_GATE`
                                   :data:`SIGHTINGS` and :data:`WIDE_SCANS` (see
                                   :mod:`.association`)
    modes (B, 5) int64             :data:`MOTION` (``ODOMETRY``/``VELOCITY`` of
                                   :mod:`slam_env.kernels.base.models`), :data:`MEASUREMENT`
                                   (``RANGE_BEARING``/``CARTESIAN``), :data:`CORRECTION`
                                   (:data:`SEQUENTIAL`/:data:`BATCH`),
                                   :data:`ASSOCIATION` (:data:`KNOWN`,
                                   :data:`NEAREST_NEIGHBOR`, :data:`JCBB`) and
                                   :data:`LINEARIZATION` (:data:`STANDARD`/:data:`FEJ`/
                                   :data:`OC`/:data:`INVARIANT`)
"""

from __future__ import annotations

import numpy as np

# params columns
NOISE, Q00, Q01, Q11, GATE = 0, 4, 5, 6, 7
MATCH_GATE, NEW_GATE, SIGHTINGS, WIDE_SCANS = 8, 9, 10, 11  # the association's
# modes columns, and the codes of each mode
MOTION, MEASUREMENT, CORRECTION, ASSOCIATION, LINEARIZATION = 0, 1, 2, 3, 4
SEQUENTIAL, BATCH = 0, 1
KNOWN, NEAREST_NEIGHBOR, JCBB = 0, 1, 2
STANDARD, FEJ, OC, INVARIANT = 0, 1, 2, 3

# Per-observation status (slam_env.ekf.Status), and UNUSED for padding, worlds not
# touched and worlds whose update failed. DISCARDED: an observation the association
# gave to no landmark (ID DISCARD_ID); TENTATIVE: one it holds as a possible new
# landmark until a second sighting confirms it (ID TENTATIVE_ID).
CORRECTED, INITIALISED, REJECTED, DISCARDED, TENTATIVE, UNUSED = 0, 1, 2, 3, 4, -1
DISCARD_ID, TENTATIVE_ID = -1, -2

# Per-world error codes.
OK = 0
BAD_INPUT = 1  # a control or measurement not finite, or a count outside [0, D]
BAD_ID = 2  # a landmark ID outside [0, M) (-1, -2 allowed where the filter associates)
DUPLICATE_ID = 3  # the same landmark ID twice in one update
SMALL_WORKSPACE = 4  # work has fewer than update_workspace_size(dmax, D) entries
NOT_POSITIVE_DEFINITE = 5  # S (or the Joseph factor's I − WᵀW) is not positive definite
NOT_FINITE = 6  # a non-finite intermediate (gain, mean step, new landmark)
OVERFLOW = 7  # a variance or covariance would exceed COV_LIMIT (or the mean overflow)
ERROR_NAMES = (
    "ok",
    "bad input",
    "landmark id out of range",
    "duplicate landmark id",
    "workspace too small",
    "not positive definite",
    "not finite",
    "overflow",
)

SINGULAR = -1  # internal: the landmark is where h cannot be linearised

# Entries of P are kept at most this large: with P positive semi-definite up to
# rounding, every sum the update forms then stays far from float64's 1.8e308.
COV_LIMIT = 1e300
FLOAT_MAX = float(np.finfo(np.float64).max)
