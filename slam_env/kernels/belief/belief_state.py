"""The filter's belief as the belief-side kernels read it: B worlds' means,
covariances, landmark counts and slot-to-ID maps.

Slot i of world b (i < ``n[b]``) holds the landmark ``slot_to_id[b, i]`` in rows
3 + 2i, 4 + 2i of ``x[b]`` and ``P[b]``; only the leading d = 3 + 2n[b] rows and
columns of a world are read (the rest is storage).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# The worlds in the batch that a single env, a wrapper or a standalone filter runs.
SINGLE = 1


class BeliefBatch(NamedTuple):
    """B beliefs over at most M landmarks, dmax = 3 + 2M."""

    x: np.ndarray  # (B, dmax) float64, means
    P: np.ndarray  # (B, dmax, dmax) float64, covariances
    n: np.ndarray  # (B,) int64, landmarks in each state
    slot_to_id: np.ndarray  # (B, M) int64, landmark ID of each slot
