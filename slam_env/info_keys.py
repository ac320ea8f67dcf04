"""The ``info`` keys of both IDs, once: name, meaning, unit and when each is there.

The cores build their stacked (vector) infos in this order and a single env's info is
a row of it (:func:`info_row`); the wrappers report the belief's keys under the same
names; the env pages of the docs are generated from these tables, and the tests check
that every env reports exactly the keys its table says, when it says.

An undefined metric is absent, never NaN (equal runs give equal infos, and no made-up
value slips into an average); a vector env marks the sub-envs that report a key in
``info["_key"]``, as Gymnasium does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "ACTIVE_INFO",
    "ALWAYS",
    "BELIEF_INFO",
    "RAW_INFO",
    "InfoKey",
    "info_row",
    "names",
]

ALWAYS = "always"


@dataclass(frozen=True)
class InfoKey:
    """One key of ``info``: its ``name``, what it holds (``meaning``), its ``unit``
    (empty for counts, IDs and flags) and ``when`` it is there."""

    name: str
    meaning: str
    unit: str = ""
    when: str = ALWAYS


RAW_INFO: tuple[InfoKey, ...] = (
    InfoKey("pose", "the true pose (x, y, θ), (3,)", "m, m, rad"),
    InfoKey("landmark_positions", "the true landmark positions, (N, 2), in layout order", "m"),
    InfoKey("landmark_ids", "the landmark IDs of those rows, (N,)"),
    InfoKey("collision", "the robot was in contact with a wall, an obstacle or a post"),
    InfoKey("seen", "landmark ID i detected so far this episode, (M,) for the M ID slots"),
    InfoKey(
        "odometry_true",
        "the noise-free control of the step: (δrot1, δtr, δrot2), or (Δp, Δθ) with "
        "motion_model='velocity'",
        "rad, m, rad or m, rad",
    ),
    InfoKey(
        "reward_terms",
        "the raw env's scripting reward by term: new_landmarks (the bonus per first "
        "detection), collision (the penalty)",
    ),
    InfoKey("kidnapped", "the kidnap fault carried the robot away this step", when="a fault is on"),
    InfoKey(
        "detection_ids",
        "the true landmark ID of each detection row, −1 for clutter and padding, (D,)",
        when="report_ids=False, or clutter_rate > 0",
    ),
)

BELIEF_INFO: tuple[InfoKey, ...] = (
    InfoKey("pose_error", "distance from the estimated to the true position", "m"),
    InfoKey("heading_error", "|estimated − true heading|, wrapped", "rad"),
    InfoKey(
        "map_rmse",
        "RMS distance of the mapped landmarks from their true positions",
        "m",
        when="a landmark is in the belief",
    ),
    InfoKey(
        "pose_nees",
        "the pose's normalised estimation error squared (3 dof)",
        when="it is defined: finite (a pose covariance singular along the error has none)",
    ),
    InfoKey("landmarks_known", "landmarks in the belief"),
    InfoKey("rejected", "observations the χ² gate refused this episode"),
    InfoKey("entropy", "the belief's entropy over the pose and every landmark slot", "nats"),
    InfoKey("pose_std", "√trace of the position covariance", "m"),
    InfoKey("belief_clipped", "the belief left the observation's bounds"),
    InfoKey("consecutive_rejections", "observations of known landmarks refused in a row"),
    InfoKey(
        "diverged",
        "the filter has lost track: the belief was clipped, a prediction or correction "
        "failed numerically, or the gate refused DIVERGENCE_REJECTIONS observations in a row",
    ),
)

# ActiveSLAM-v0's own, after the belief's.
_ACTIVE_ONLY: tuple[InfoKey, ...] = (
    InfoKey(
        "swept_fraction",
        "share of the arena the landmark sensor has swept this episode",
        when="coverage=True",
    ),
    InfoKey(
        "reward_terms",
        "the active-SLAM reward by term (information_gain, pose_uncertainty, collision, "
        "step, coverage)",
    ),
    InfoKey(
        "association",
        "this step's associations judged against the truth: correct, wrong, missed, and "
        "the map's duplicated landmarks",
        when="data_association is not 'known'",
    ),
    InfoKey(
        "association_episode",
        "the same, summed over the episode",
        when="data_association is not 'known'",
    ),
)

ACTIVE_INFO: tuple[InfoKey, ...] = (
    *(key for key in RAW_INFO if key.name != "reward_terms"),
    InfoKey(
        "raw_reward_terms", "the raw env's reward_terms (the active-SLAM reward replaces them)"
    ),
    *BELIEF_INFO,
    *_ACTIVE_ONLY,
)


def names(table: tuple[InfoKey, ...]) -> tuple[str, ...]:
    """The keys of a table, in its order."""
    return tuple(key.name for key in table)


def info_row(stacked: dict[str, Any], masks: dict[str, np.ndarray], index: int) -> dict[str, Any]:
    """Sub-env ``index``'s info from a stacked one (``(B, …)`` arrays, nested dicts of
    them) and the masks of the keys that not every sub-env reports: a key whose mask is
    False for ``index`` is left out, a ``(B,)`` entry becomes the Python scalar it
    holds, a row of a larger array a view of the (fresh) stacked copy."""
    out: dict[str, Any] = {}
    for key, value in stacked.items():
        mask = masks.get(key)
        if mask is not None and not mask[index]:
            continue
        if isinstance(value, dict):
            out[key] = info_row(value, {}, index)
        elif value.ndim == 1:
            out[key] = value.item(index)
        else:
            out[key] = value[index]
    return out
