"""Per-episode SLAM metrics of training episodes, from the env's step infos.

Any training engine sees the episodes of B sub-envs of ``slam_env/ActiveSLAM-v0`` as
streams of step infos. The metrics below need an episode's last info and a few running
figures: :class:`EpisodeTallies` keeps those for the B sub-envs side by side in
arrays, from three keys of each step info (:data:`STEP_KEYS`; an engine that has them
as (B,) arrays already, as a vector env's info does, passes them without touching the
rows), and :meth:`EpisodeTallies.finish` turns an episode's last info and its tally
into the metrics. All of it is plain Python and numpy, free of any engine;
:mod:`agents.learning.sb3.callbacks` logs them from stable-baselines3.

| metric                    | meaning                                                        |
|---------------------------|----------------------------------------------------------------|
| ``mapped_share``          | landmarks in the belief at the end / landmarks in the world    |
| ``steps_to_90pct_mapped`` | steps until 90% of the landmarks were in the belief (NaN: never) |
| ``reached_90pct_mapped``  | 1 when 90% of the landmarks were mapped, else 0                |
| ``final_entropy``         | belief entropy at the end, nats                                |
| ``map_rmse``              | map RMSE at the end, m (NaN: nothing mapped)                   |
| ``mean_pose_nees``        | mean pose NEES over the steps (3 for a consistent filter)      |
| ``collisions``            | steps spent in contact                                         |
| ``diverged``              | 1 when the filter reported divergence at the last step, else 0 |

As in :mod:`agents.evaluation.compare`, step figures run over the steps taken (not the reset)
and the NEES mean over its finite values.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

#: The metrics of :meth:`EpisodeTallies.finish`, in logging order, with their meaning.
SLAM_METRICS: dict[str, str] = {
    "mapped_share": "share of landmarks mapped at the end",
    "steps_to_90pct_mapped": "steps until 90% of the landmarks were mapped",
    "reached_90pct_mapped": "1 if 90% of the landmarks were mapped, else 0",
    "final_entropy": "final belief entropy [nats]",
    "map_rmse": "final map RMSE [m]",
    "mean_pose_nees": "mean pose NEES over the steps (3 dof)",
    "collisions": "steps in collision",
    "diverged": "1 if the filter had diverged at the end, else 0",
}
MAPPED_TARGET = 0.9  # the share of landmarks whose mapping time is measured

#: How evaluations are ranked (see :func:`evaluation_score`).
BEST_MODEL_CRITERION = (
    "the highest mean share of landmarks mapped; on a tie, the lowest mean final entropy"
)


#: The keys of a step info that a tally reads (the rest only at an episode's end).
STEP_KEYS = ("collision", "pose_nees", "landmarks_known")
#: Those that the env leaves out where they are undefined (a covariance gone
#: non-finite): read as NaN, which the tally does not average.
OPTIONAL_STEP_KEYS = ("pose_nees",)


class EpisodeTallies:
    """The running figures of the current episodes of B sub-envs that their last info
    does not hold: steps, steps in contact, the sum and count of the finite pose
    NEES, and the step at which each number of landmarks was first in the belief
    (which never drops one).

    A step's values are only kept, by :meth:`add_infos` (row by row) or :meth:`add`
    (columns); they are counted in one numpy pass over up to ``block`` steps, when
    the block is full or an episode ends, because a numpy call costs as much as
    keeping a few hundred values."""

    def __init__(self, num_envs: int, block: int = 256) -> None:
        b = int(num_envs)
        self.num_envs = b
        self.block = int(block)
        self.steps = np.zeros(b, dtype=np.int64)
        self.collisions = np.zeros(b, dtype=np.int64)
        self.nees_sum = np.zeros(b)
        self.nees_count = np.zeros(b, dtype=np.int64)
        self.known = np.zeros(b, dtype=np.int64)
        # first_step_with[i, k - 1]: the step at which k landmarks were first known
        self.first_step_with = np.zeros((b, 0), dtype=np.int64)
        self._kept = 0  # steps kept, not counted yet
        self._values: tuple[list[Any], list[Any], list[Any]] = ([], [], [])  # row by row
        self._columns: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add_infos(self, infos: Sequence[Mapping[str, Any]]) -> None:
        """One step of every sub-env from its step info (B of them, in order; reads
        the :data:`STEP_KEYS` only)."""
        if self._columns:
            self._count()
        collision, nees, known = self._values
        for info in infos:
            collision.append(info["collision"])
            nees.append(info.get("pose_nees", math.nan))
            known.append(info["landmarks_known"])
        self._kept += 1
        if self._kept >= self.block:
            self._count()

    def add(
        self, collision: np.ndarray, pose_nees: np.ndarray, landmarks_known: np.ndarray
    ) -> None:
        """One step of every sub-env from the :data:`STEP_KEYS` columns of their step
        infos, (B,) arrays (bool, float, int; NaN for an undefined NEES), as a vector
        env's info holds them."""
        if self._values[0]:
            self._count()
        self._columns.append((collision, pose_nees, landmarks_known))
        self._kept += 1
        if self._kept >= self.block:
            self._count()

    def _count(self) -> None:
        """Fold the kept steps, (T, B) per key, into the figures."""
        if not self._kept:
            return
        b = self.num_envs
        if self._columns:  # T steps of (B,) arrays
            kept = zip(*self._columns, strict=True)
            self._columns = []
        else:  # T·B values, row by row
            kept = self._values
            self._values = ([], [], [])
        collision, nees, known = (np.array(values).reshape(-1, b) for values in kept)
        self._kept = 0
        before = self.steps.copy()
        self.steps += collision.shape[0]
        self.collisions += np.count_nonzero(collision, axis=0)
        finite = np.isfinite(nees)
        self.nees_sum += np.where(finite, nees, 0.0).sum(axis=0)
        self.nees_count += np.count_nonzero(finite, axis=0)
        most = known.max(axis=0)
        grew = np.flatnonzero(most > self.known).tolist()
        if not grew:
            return
        if most.max() > self.first_step_with.shape[1]:
            wider = np.zeros((self.num_envs, int(most.max()) + 8), dtype=np.int64)
            wider[:, : self.first_step_with.shape[1]] = self.first_step_with
            self.first_step_with = wider
        for env in grew:
            counts = np.arange(self.known[env] + 1, most[env] + 1)
            # Within an episode the count never falls: the first step with k is a search.
            first = np.searchsorted(known[:, env], counts, side="left")
            self.first_step_with[env, counts - 1] = before[env] + first + 1
            self.known[env] = most[env]

    def finish(self, index: int, final_info: Mapping[str, Any]) -> dict[str, float]:
        """The :data:`SLAM_METRICS` of sub-env ``index``'s episode from its last
        step's info (reads ``landmark_ids``, ``landmarks_known``, ``entropy``,
        ``map_rmse``, ``diverged``), that last step already added; then starts its
        next episode. Undefined metrics are NaN."""
        self._count()
        n_landmarks = len(final_info["landmark_ids"])
        target = math.ceil(MAPPED_TARGET * n_landmarks - 1e-9)
        reached = 0 < target <= self.known[index]
        count = int(self.nees_count[index])
        metrics = {
            "mapped_share": int(final_info["landmarks_known"]) / n_landmarks
            if n_landmarks
            else math.nan,
            "steps_to_90pct_mapped": float(self.first_step_with[index, target - 1])
            if reached
            else math.nan,
            "reached_90pct_mapped": float(reached),
            "final_entropy": float(final_info["entropy"]),
            "map_rmse": float(final_info.get("map_rmse", math.nan)),
            "mean_pose_nees": float(self.nees_sum[index]) / count if count else math.nan,
            "collisions": float(self.collisions[index]),
            "diverged": float(bool(final_info["diverged"])),
        }
        for figures in (self.steps, self.collisions, self.nees_sum, self.nees_count, self.known):
            figures[index] = 0
        self.first_step_with[index] = 0
        return metrics


def mean_metrics(episodes: Iterable[Mapping[str, float]]) -> dict[str, float]:
    """Each metric's mean over episodes, over its finite values (NaN if none)."""
    totals = dict.fromkeys(SLAM_METRICS, 0.0)
    counts = dict.fromkeys(SLAM_METRICS, 0)
    for metrics in episodes:
        for name in SLAM_METRICS:
            value = metrics[name]
            if math.isfinite(value):
                totals[name] += value
                counts[name] += 1
    return {n: totals[n] / counts[n] if counts[n] else math.nan for n in SLAM_METRICS}


def evaluation_score(means: Mapping[str, float]) -> tuple[float, float]:
    """The rank of an evaluation by its :func:`mean_metrics` (greater is better), as
    :data:`BEST_MODEL_CRITERION` says; a NaN figure ranks last."""
    mapped = means["mapped_share"]
    entropy = means["final_entropy"]
    return (
        round(mapped, 9) if math.isfinite(mapped) else -math.inf,  # equal shares tie
        -entropy if math.isfinite(entropy) else -math.inf,
    )
