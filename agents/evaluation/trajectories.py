"""An evaluation's episodes as files for the field's trajectory tools (evo): per
episode the true and the estimated trajectory in TUM format and the final map as CSV
(:mod:`slam_env.belief.trajectory_files`).

Step t (0: after the reset) has the timestamp t · dt. The episode's ``pose_rmse`` runs
over the steps after the reset, so ``evo_ape tum true.tum est.tum --t_start dt`` (the
translation part, no alignment) reports it; without ``--t_start`` evo also counts the
start, where the error is 0.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from agents.rollouts.records import EpisodeRecord
from slam_env.belief.trajectory_files import write_map_csv, write_tum

__all__ = ["episode_file_stem", "export_trajectories", "write_episode_trajectories"]


def episode_file_stem(index: int) -> str:
    """The common start of episode ``index``'s file names."""
    return f"episode_{index:03d}"


def write_episode_trajectories(
    record: EpisodeRecord, directory: str | Path, dt: float, stem: str = "episode"
) -> dict[str, Path]:
    """Write ``record``'s true and estimated trajectories (``<stem>_true.tum``,
    ``<stem>_est.tum``, step t at t · ``dt`` seconds) and its final map
    (``<stem>_map.csv``: each landmark's ID, true and estimated position) into
    ``directory``; returns the paths by kind (``true``, ``est``, ``map``)."""
    if not (isinstance(dt, (int, float)) and not isinstance(dt, bool) and dt > 0):
        raise ValueError(f"dt must be a number > 0 (seconds per step), got {dt!r}")
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    timestamps = np.arange(record.true_poses.shape[0]) * float(dt)
    files = {
        "true": write_tum(out / f"{stem}_true.tum", timestamps, record.true_poses),
        "est": write_tum(out / f"{stem}_est.tum", timestamps, record.est_poses),
    }
    layout, belief = record.layout, record.belief
    if layout is not None:
        estimated_ids = np.zeros(0, dtype=np.int64) if belief is None else belief.landmark_ids
        estimated = np.zeros((0, 2)) if belief is None else belief.landmark_means
        files["map"] = write_map_csv(
            out / f"{stem}_map.csv",
            np.asarray(layout.landmark_ids, dtype=np.int64),
            np.asarray(layout.landmark_positions, dtype=np.float64).reshape(-1, 2),
            estimated_ids,
            estimated,
        )
    return files


def _folder_name(label: str) -> str:
    """An agent's label as a folder name (``ppo:model`` → ``ppo_model``)."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", label).strip("._") or "agent"


def export_trajectories(
    records: Mapping[str, Sequence[EpisodeRecord]], directory: str | Path, dt: float
) -> dict[str, Path]:
    """Write every episode of every agent (``records``: label → episodes) with
    :func:`write_episode_trajectories` into ``directory/<agent>/`` as
    ``episode_<i>_{true,est}.tum`` and ``episode_<i>_map.csv``; returns the paths, by
    ``<agent>/episode_<i>_<kind>``."""
    folders = {label: _folder_name(label) for label in records}
    clash = sorted(name for name in set(folders.values()) if list(folders.values()).count(name) > 1)
    if clash:
        raise ValueError(f"agent labels {sorted(records)} share the folder name(s) {clash}")
    files: dict[str, Path] = {}
    for label, recs in records.items():
        for i, record in enumerate(recs):
            stem = episode_file_stem(i)
            written = write_episode_trajectories(record, Path(directory) / folders[label], dt, stem)
            files.update({f"{folders[label]}/{stem}_{kind}": p for kind, p in written.items()})
    return files
