"""The metrics that separate good explorers, from one episode's record: how fast the
landmarks are mapped (steps to 50, 90 and 100% of them, censored at the episode's
length), how fast the uncertainty falls (the area under the entropy curve, per step),
how safely (collisions per 100 steps) and how well (final entropy, map RMSE)."""

from __future__ import annotations

import math

import numpy as np

from agents.rollouts.records import EpisodeRecord

#: The shares of the landmarks whose mapping time is measured.
MAPPED_SHARES = (0.5, 0.9, 1.0)

#: Per-episode suite metrics, in table order, with their meaning.
SUITE_METRICS: dict[str, str] = {
    "mapped_share": "share of the landmarks mapped at the end",
    "steps_to_50": "steps until 50% of the landmarks are mapped (episode length if never)",
    "steps_to_90": "steps until 90% of the landmarks are mapped (episode length if never)",
    "steps_to_100": "steps until every landmark is mapped (episode length if never)",
    "entropy_auc": "area under the belief-entropy curve / steps [nats]",
    "final_entropy": "belief entropy at the end [nats]",
    "collisions_per_100": "steps in collision per 100 steps",
    "map_rmse": "final map RMSE over the mapped landmarks [m]",
}


def landmarks_needed(n_landmarks: int, share: float) -> int:
    """Landmarks in the belief that make ``share`` of ``n_landmarks`` (at least one)."""
    return max(math.ceil(share * n_landmarks - 1e-9), 1)


def steps_to_share(known: np.ndarray, n_landmarks: int, share: float) -> tuple[int, bool]:
    """The first step at which ``known`` (landmarks in the belief after each step, step
    0 after reset) reaches :func:`landmarks_needed` for ``share`` of ``n_landmarks``, and
    whether it did; never reached: the episode's length, False (censored)."""
    reached = np.flatnonzero(known >= landmarks_needed(n_landmarks, share))
    if reached.size:
        return int(reached[0]), True
    return int(known.size - 1), False


def suite_metrics(record: EpisodeRecord) -> dict[str, float]:
    """The :data:`SUITE_METRICS` of one episode, and ``reached_<p>`` (1 or 0) beside
    each ``steps_to_<p>``."""
    steps = max(record.steps, 1)
    out: dict[str, float] = {
        "mapped_share": float(record.landmarks_known[-1]) / record.n_landmarks,
    }
    for share in MAPPED_SHARES:
        name = f"steps_to_{round(100 * share)}"
        value, reached = steps_to_share(record.landmarks_known, record.n_landmarks, share)
        out[name] = float(value)
        out[f"reached_{round(100 * share)}"] = float(reached)
    # The trapezoid rule over steps 0..T, divided by T: the mean entropy of the episode.
    entropy = record.entropy
    out["entropy_auc"] = (
        float(np.trapezoid(entropy) / steps) if entropy.size > 1 else float(entropy[0])
    )
    out["final_entropy"] = float(entropy[-1])
    out["collisions_per_100"] = 100.0 * np.count_nonzero(record.collision[1:]) / steps
    out["map_rmse"] = float(record.map_rmse[-1])
    return out
