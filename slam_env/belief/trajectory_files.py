"""Trajectories and maps as files for the field's tools: TUM trajectory files
(``timestamp x y z qx qy qz qw``, one pose a line), which evo (``evo_ape``,
``evo_rpe``, ``evo_traj``) and most SLAM benchmarks read, and the map as CSV.

The robot is planar: z = 0 and the orientation is the rotation by the heading θ about
z, the unit quaternion (qx, qy, qz, qw) = (0, 0, sin(θ/2), cos(θ/2)). Numbers are
written with 17 significant digits, so that they read back as the very floats.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

from slam_env.ekf.checks import real_array

__all__ = ["TUM_HEADER", "planar_tum_rows", "write_map_csv", "write_tum"]

#: The comment line opening a TUM file (evo and the TUM tools skip lines starting with #).
TUM_HEADER = "timestamp x y z qx qy qz qw"

#: The columns of the map CSV, one row per landmark.
MAP_COLUMNS = ("id", "true_x", "true_y", "est_x", "est_y")


def _finite_array(value: Any, shape: tuple[int | None, ...], name: str) -> np.ndarray:
    """``value`` as a float64 array of ``shape`` (None: any length), all finite;
    ``TypeError``/``ValueError`` naming ``name`` otherwise (real numbers only, as the
    filter's own inputs: :func:`slam_env.ekf.checks.real_array`)."""
    array = real_array(value, name)
    if array.ndim != len(shape) or any(
        want is not None and got != want for got, want in zip(array.shape, shape, strict=True)
    ):
        wanted = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {wanted}, got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name} must be finite")
    return array


def planar_tum_rows(timestamps: Any, poses: Any) -> np.ndarray:
    """The TUM rows (n, 8) of planar ``poses`` (n, 3) of (x, y, θ), m and rad, at
    ``timestamps`` (n,), s, strictly increasing: ``t x y 0 0 0 sin(θ/2) cos(θ/2)``."""
    poses = _finite_array(poses, (None, 3), "poses")
    stamps = _finite_array(timestamps, (poses.shape[0],), "timestamps")
    if stamps.size > 1 and not (np.diff(stamps) > 0).all():
        raise ValueError("timestamps must be strictly increasing")
    half = 0.5 * poses[:, 2]
    rows = np.zeros((poses.shape[0], 8))
    rows[:, 0] = stamps
    rows[:, 1:3] = poses[:, :2]
    rows[:, 6] = np.sin(half)  # qz
    rows[:, 7] = np.cos(half)  # qw
    return rows


def write_tum(path: str | Path, timestamps: Any, poses: Any) -> Path:
    """Write planar ``poses`` (n, 3) at ``timestamps`` (n,) as the TUM trajectory file
    ``path`` (see :func:`planar_tum_rows`); returns the path. Everything is checked
    before the file is opened."""
    rows = planar_tum_rows(timestamps, poses)
    path = Path(path)
    np.savetxt(path, rows, fmt="%.17g", delimiter=" ", header=TUM_HEADER)
    return path


def write_map_csv(
    path: str | Path,
    true_ids: Any,
    true_positions: Any,
    estimated_ids: Any,
    estimated_positions: Any,
) -> Path:
    """Write the map as CSV (columns :data:`MAP_COLUMNS`), one row per landmark, in ID
    order: each true landmark (``true_ids`` (n,), ``true_positions`` (n, 2), m) with
    its estimate (``estimated_ids`` (k,), ``estimated_positions`` (k, 2), m, matched
    by ID), an empty estimate where it was never mapped, and an empty truth for an
    estimate of no true landmark (a track of the filter's own data association);
    returns the path."""
    truth = _finite_array(true_positions, (None, 2), "true_positions")
    estimate = _finite_array(estimated_positions, (None, 2), "estimated_positions")
    true_by_id = dict(zip(_ids(true_ids, truth.shape[0], "true_ids"), truth, strict=True))
    est_by_id = dict(
        zip(_ids(estimated_ids, estimate.shape[0], "estimated_ids"), estimate, strict=True)
    )
    path = Path(path)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(MAP_COLUMNS)
        for lid in sorted(true_by_id.keys() | est_by_id.keys()):
            writer.writerow([lid, *_cells(true_by_id.get(lid)), *_cells(est_by_id.get(lid))])
    return path


def _ids(value: Any, n: int, name: str) -> list[int]:
    ids = np.asarray(value)
    if ids.shape != (n,) or (n and not np.issubdtype(ids.dtype, np.integer)):
        raise ValueError(f"{name} must be {n} integers (one per position), got {ids!r}")
    listed = ids.astype(np.int64).tolist()
    if len(set(listed)) != n:
        raise ValueError(f"{name} must not repeat an ID, got {listed}")
    return listed


def _cells(xy: np.ndarray | None) -> list[str]:
    return ["", ""] if xy is None else [repr(float(xy[0])), repr(float(xy[1]))]
