"""The filter's belief as the belief-side kernels read it: B worlds' means,
covariances, landmark counts and slot-to-ID maps.

Slot i of world b (i < ``n[b]``) holds the landmark ``slot_to_id[b, i]`` in rows
3 + 2i, 4 + 2i of ``x[b]`` and ``P[b]``; only the leading d = 3 + 2n[b] rows and
columns of a world are read (the rest is storage).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    from slam_env.ekf import EKFSLAM

# The worlds in the batch that a single env, a wrapper or a standalone filter runs.
SINGLE = 1


class BeliefBatch(NamedTuple):
    """B beliefs over at most M landmarks, dmax = 3 + 2M."""

    x: np.ndarray  # (B, dmax) float64, means
    P: np.ndarray  # (B, dmax, dmax) float64, covariances
    n: np.ndarray  # (B,) int64, landmarks in each state
    slot_to_id: np.ndarray  # (B, M) int64, landmark ID of each slot


def filter_belief(f: EKFSLAM) -> BeliefBatch:
    """One :class:`slam_env.ekf.EKFSLAM`'s live belief as a batch of one: its storage
    itself, which is a batch of one (nothing copied). Call it again after the filter
    is unpickled or copied (that one has storage of its own)."""
    return BeliefBatch(f._xb, f._Pb, f._nb, f._slot_to_id_b)
