"""Fault injection for robustness studies: what goes wrong with real sensors.

Every fault is off by default and draws nothing from the env's random stream while
off, so enabling none leaves a seeded run bit-identical. Each is a field of
:class:`slam_env.config.FaultConfig`:

* ``outlier_rate``: probability per step of one spurious detection: a random
  [range, bearing] (or robot-frame point) inside the sensor's footprint reported
  with the ID of a landmark already detected earlier in the episode but not in this
  scan, a wrong data association that a χ² gate should reject.
* ``scan_dropout``: probability per step that the whole scan is lost (no detections).
* ``odometry_dropout``: probability per step that the odometry reading is lost and
  reads zero motion.
* ``odometry_bias``: a constant bias added to every odometry reading, in the motion
  model's units ((δrot1 rad, δtr m, δrot2 rad) or (Δp m, Δθ rad)).
* ``kidnap_rate``: probability per step that the robot is carried to a random free
  pose after its motion; the odometry reports only the motion it made itself.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.config import FaultConfig, SensorConfig
from slam_env.sensors import Detections


def inject_outlier(
    detections: Detections,
    seen_ids: np.ndarray,
    sensor: SensorConfig,
    rng: np.random.Generator,
) -> Detections:
    """Append one spurious detection with the ID of a landmark seen before (``seen_ids``)
    but not in this scan; unchanged if there is no such landmark."""
    candidates = np.setdiff1d(seen_ids, detections.ids)
    if candidates.size == 0:
        return detections
    lid = int(candidates[rng.integers(candidates.size)])
    r = float(rng.uniform(0.5, sensor.max_range))
    phi = float(rng.uniform(-0.5, 0.5) * min(sensor.fov, 2.0 * math.pi - 1e-9))
    if sensor.measurement_model == "range_bearing":
        z = (r, phi)
    else:
        z = (r * math.cos(phi), r * math.sin(phi))
    ids = np.append(detections.ids, lid)
    order = np.argsort(ids, kind="stable")  # keep the stream sorted by ID
    all_z = np.vstack([detections.z, z])[order]
    index = np.append(detections.index, -1)[order]  # -1: no landmark behind it
    return Detections(all_z, ids[order], index)


def drop_scan(detections: Detections) -> Detections:
    empty = np.zeros(0, dtype=np.int64)
    return Detections(np.zeros((0, 2)), empty, empty.copy())


def odometry_faults(
    control: np.ndarray, faults: FaultConfig, rng: np.random.Generator
) -> np.ndarray:
    """The odometry reading after dropout and bias (a new array)."""
    out = np.array(control, dtype=np.float64)
    if faults.odometry_dropout > 0.0 and rng.random() < faults.odometry_dropout:
        out[:] = 0.0
    if faults.odometry_bias is not None:
        out += faults.odometry_bias
    return out
