"""One episode of one agent as a record: the belief's figures step by step (from the
env's infos), the true and estimated poses, and the per-episode metrics of
:data:`METRICS`."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from slam_env.budget import MAX_MEMORY_BYTES
from slam_env.envs.registration import DEFAULT_MAX_EPISODE_STEPS

#: Per-episode metrics, in table order, with their descriptions.
METRICS: dict[str, str] = {
    "mapped_share": "share of landmarks mapped at the end",
    "final_entropy": "final belief entropy [nats]",
    "map_rmse": "final map RMSE [m]",
    "pose_rmse": "pose RMSE along the trajectory [m]",
    "mean_pose_nees": "mean pose NEES (3 dof)",
    "collisions": "steps in collision",
    "path_length": "path length [m]",
    "return": "episode return",
    "steps": "episode length [steps]",
}


POSE_DOF = 3  # x, y, θ: the pose NEES's degrees of freedom


# ---------------------------------------------------------------------- episodes
@dataclass
class EpisodeRecord:
    """One episode of one agent, step by step (index 0 is the state after reset)."""

    seed: int
    n_landmarks: int
    true_poses: np.ndarray  # (T+1, 3)
    est_poses: np.ndarray  # (T+1, 3)
    entropy: np.ndarray  # (T+1,) nats
    landmarks_known: np.ndarray  # (T+1,)
    pose_error: np.ndarray  # (T+1,) m
    pose_nees: np.ndarray  # (T+1,)
    map_rmse: np.ndarray  # (T+1,) m, nan before the first landmark
    collision: np.ndarray  # (T+1,) bool
    rewards: np.ndarray  # (T,)
    layout: Any = None  # slam_env.world.layouts.Layout of the episode
    belief: Any = None  # final slam_env.belief.overlay.BeliefOverlay
    world: str = ""  # short digest of the world (same worlds ⇔ same digests)
    frames: list[np.ndarray] = field(default_factory=list)
    detections_world: list[np.ndarray] = field(default_factory=list)

    @property
    def steps(self) -> int:
        return int(self.rewards.size)

    def metrics(self) -> dict[str, float]:
        """The per-episode metrics of :data:`METRICS`."""
        after = slice(1, None) if self.steps else slice(None)
        err = self.pose_error[after]
        nees = self.pose_nees[after]
        nees = nees[np.isfinite(nees)]
        step_len = np.hypot(*np.diff(self.true_poses[:, :2], axis=0).T)
        return {
            "mapped_share": float(self.landmarks_known[-1]) / self.n_landmarks,
            "final_entropy": float(self.entropy[-1]),
            "map_rmse": float(self.map_rmse[-1]),
            "pose_rmse": float(math.sqrt(np.mean(err**2))),
            "mean_pose_nees": float(nees.mean()) if nees.size else math.nan,
            "collisions": int(np.count_nonzero(self.collision[after])),
            "path_length": float(step_len.sum()),
            "return": float(self.rewards.sum()),
            "steps": self.steps,
        }


def _world_digest(info: dict[str, Any]) -> str:
    h = hashlib.sha1()
    h.update(np.round(np.asarray(info["landmark_positions"], np.float64), 6).tobytes())
    h.update(np.asarray(info["landmark_ids"], np.int64).tobytes())
    h.update(np.round(np.asarray(info["pose"], np.float64), 6).tobytes())
    return h.hexdigest()[:12]


#: Bytes a step of an episode costs while it runs (its info row, estimates and
#: detections: 2.8 KB measured on the default world) and once kept in its
#: EpisodeRecord (125 B measured), with room to spare.
STEP_BYTES_RUNNING = 4096


STEP_BYTES_KEPT = 256


def check_episode_memory(steps: int | None, episodes_kept: int, what: str) -> None:
    """``ValueError`` unless running an episode of ``steps`` steps (None: the envs'
    default length) while keeping the records of ``episodes_kept`` of them fits in
    :data:`slam_env.budget.MAX_MEMORY_BYTES`, before anything runs."""
    steps = DEFAULT_MAX_EPISODE_STEPS if steps is None else steps
    need = (steps + 1) * (STEP_BYTES_RUNNING + episodes_kept * STEP_BYTES_KEPT)
    if need > MAX_MEMORY_BYTES:
        raise ValueError(
            f"{what}: {episodes_kept} episode records of {steps} steps need about "
            f"{need / 2**30:.3g} GiB, over the budget of {MAX_MEMORY_BYTES / 2**30:.0f} GiB "
            "(README: Resource budget); ask for fewer episodes or steps"
        )


def episode_record(
    seed: int,
    rows: Sequence[dict[str, Any]],
    est: Sequence[np.ndarray],
    rewards: Sequence[float],
    **fields: Any,
) -> EpisodeRecord:
    """An :class:`EpisodeRecord` from an episode's infos (the reset's, then each
    step's), estimated poses and rewards; ``fields`` are its other attributes."""

    def col(key: str, dtype: Any = np.float64) -> np.ndarray:
        return np.array([r[key] for r in rows], dtype=dtype)

    def metric(key: str) -> np.ndarray:
        # The env leaves an undefined metric out of info; here it is NaN, which the
        # aggregation leaves out of the means.
        return np.array([r.get(key, math.nan) for r in rows], dtype=np.float64)

    return EpisodeRecord(
        seed=seed,
        true_poses=np.stack([r["pose"] for r in rows]).astype(np.float64),
        est_poses=np.stack(est),
        entropy=col("entropy"),
        landmarks_known=col("landmarks_known"),
        pose_error=col("pose_error"),
        pose_nees=metric("pose_nees"),
        map_rmse=metric("map_rmse"),
        collision=col("collision", bool),
        rewards=np.asarray(rewards, dtype=np.float64),
        world=_world_digest(rows[0]),
        **fields,
    )
