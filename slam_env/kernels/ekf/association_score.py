"""How well B filters associated their observations, judged against the truth the
simulator knows: what ``ActiveSLAM-v0`` reports in ``info`` when its filter chooses the
landmarks itself.

Each filter landmark (slot) is identified with the true landmark of the detection that
started it (``slot_truth``, -1 for one started from clutter). An observation of true
landmark t (-1: clutter) is

* correct: given to a filter landmark of t; or starting (or held as the tentative
  sighting of) a landmark for a t not yet in the map; or, for clutter, discarded or
  held as tentative;
* wrong: given to (or starting) a landmark that is not t's (clutter given to anything);
* missed: a detection of a true landmark that was discarded, or, for a t already in the
  map, that started a second filter landmark or was held as tentative.

``duplicated``: the filter landmarks beyond the first for each true landmark.
"""

from __future__ import annotations

import numpy as np

from slam_env.kernels.base.compiling import kernel
from slam_env.kernels.ekf.codes import CORRECTED, DISCARDED, INITIALISED, REJECTED, TENTATIVE

# Columns of the counts.
CORRECT, WRONG, MISSED, DUPLICATED = 0, 1, 2, 3
SCORE_NAMES = ("correct", "wrong", "missed", "duplicated")


@kernel
def score_association(
    assigned: np.ndarray,
    status: np.ndarray,
    true_ids: np.ndarray,
    counts: np.ndarray,
    n_before: np.ndarray,
    slot_truth: np.ndarray,
    active: np.ndarray,
    step: np.ndarray,
    episode: np.ndarray,
) -> None:
    """Score each active world's update: observation j (of ``counts[b]``) given to
    filter landmark ``assigned[b, j]`` with ``status[b, j]``, truly of ``true_ids[b, j]``;
    ``n_before[b]`` the landmarks in the map before the update. Records the truth of
    the landmarks it started in ``slot_truth`` (B, M), writes the step's correct,
    wrong and missed counts and the map's duplicated landmarks into ``step`` (B, 4)
    int64 and adds them (the duplicates replaced) to ``episode`` (B, 4)."""
    for b in range(assigned.shape[0]):
        if not active[b]:
            continue
        for c in range(3):
            step[b, c] = 0
        n0 = n_before[b]
        for j in range(counts[b]):
            t = true_ids[b, j]
            a = assigned[b, j]
            st = status[b, j]
            if st in (CORRECTED, REJECTED):
                step[b, CORRECT if t >= 0 and slot_truth[b, a] == t else WRONG] += 1
            elif st in (INITIALISED, TENTATIVE):
                known = False
                for i in range(n0):
                    known = known or (t >= 0 and slot_truth[b, i] == t)
                if st == INITIALISED:
                    slot_truth[b, a] = t
                    step[b, WRONG if t < 0 else MISSED if known else CORRECT] += 1
                else:
                    step[b, MISSED if known else CORRECT] += 1
            elif st == DISCARDED:
                step[b, CORRECT if t < 0 else MISSED] += 1
        duplicated = 0
        for i in range(slot_truth.shape[1]):  # unused slots hold -1
            t = slot_truth[b, i]
            if t < 0:
                continue
            for h in range(i):
                if slot_truth[b, h] == t:
                    duplicated += 1
                    break
        step[b, DUPLICATED] = duplicated
        for c in range(3):
            episode[b, c] += step[b, c]
        episode[b, DUPLICATED] = duplicated
