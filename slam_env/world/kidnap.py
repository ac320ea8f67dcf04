"""Fault injection for robustness studies: what goes wrong with real sensors.

Every fault is off by default and draws nothing from the env's random stream while
off, so enabling none leaves a seeded run bit-identical. Each is a field of
:class:`slam_env.config.FaultConfig`:

* ``outlier_rate``: probability per step of one spurious detection: a random
  [range, bearing] (or robot-frame point) inside the sensor's footprint reported
  with the ID of a landmark already detected earlier in the episode but not in this
  scan, a wrong data association that a χ² gate should reject.
* ``clutter_rate``: probability per step of one detection of no landmark at all: a
  random [range, bearing] (or robot-frame point) inside the footprint, ID −1; a filter
  told the IDs leaves it out, one that associates must keep it out of its map.
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

# Tries at drawing a free pose for a kidnapping before giving up on it for the step.
KIDNAP_TRIES = 100


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
