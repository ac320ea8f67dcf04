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

# Tries at drawing a free pose for a kidnapping before giving up on it for the step.
KIDNAP_TRIES = 100


def corrupt_scan(
    ids: list[int],
    z: list[tuple[float, float]],
    seen: np.ndarray,
    faults: FaultConfig,
    sensor: SensorConfig,
    rng: np.random.Generator,
) -> tuple[list[int], list[tuple[float, float]]]:
    """The scan (IDs ascending, measurements) after the scan dropout and the spurious
    detection. ``seen`` (M,) bool marks the IDs detected earlier in the episode."""
    if faults.scan_dropout > 0.0 and rng.random() < faults.scan_dropout:
        return [], []
    if faults.outlier_rate > 0.0 and rng.random() < faults.outlier_rate:
        candidates = np.flatnonzero(seen)
        candidates = candidates[~np.isin(candidates, ids)]
        if candidates.size:
            lid = int(candidates[rng.integers(candidates.size)])
            r = float(rng.uniform(0.5, sensor.max_range))
            phi = float(rng.uniform(-0.5, 0.5) * min(sensor.fov, 2.0 * math.pi - 1e-9))
            if sensor.measurement_model == "range_bearing":
                spurious = (r, phi)
            else:
                spurious = (r * math.cos(phi), r * math.sin(phi))
            rows = sorted([*zip(ids, z, strict=True), (lid, spurious)])
            ids = [i for i, _ in rows]
            z = [m for _, m in rows]
    return ids, z


def corrupt_odometry(
    control: tuple[float, ...], faults: FaultConfig, rng: np.random.Generator
) -> tuple[float, ...]:
    """The odometry reading after the dropout and the bias."""
    if faults.odometry_dropout > 0.0 and rng.random() < faults.odometry_dropout:
        control = (0.0,) * len(control)
    if faults.odometry_bias is not None:
        control = tuple(u + b for u, b in zip(control, faults.odometry_bias, strict=True))
    return control


def kidnap_pose(world, rng: np.random.Generator) -> tuple[float, float, float] | None:
    """A random collision-free pose in the world's arena, or None if none was found."""
    layout = world.layout
    r = world.robot_radius
    for _ in range(KIDNAP_TRIES):
        x = float(rng.uniform(r, layout.width - r))
        y = float(rng.uniform(r, layout.height - r))
        if world.is_free(x, y, margin=0.05):
            return x, y, float(rng.uniform(-math.pi, math.pi))
    return None
