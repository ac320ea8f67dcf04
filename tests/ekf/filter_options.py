"""A valid set of :class:`~slam_env.ekf.EKFSLAM` options, shared by the tests that
change one of them (configuration errors, input errors)."""

from __future__ import annotations

import math

import numpy as np

Q = np.diag([0.05**2, math.radians(1.0) ** 2])
GOOD = dict(
    motion_model="odometry",
    measurement_model="range_bearing",
    alphas=(0.01, 0.01, 0.01, 0.01),
    control_noise=(0.01, 0.01, 0.0, 0.0),
    measurement_cov=Q,
    max_landmarks=5,
    initial_pose=(0.0, 0.0, 0.0),
    initial_pose_cov=np.diag([0.01, 0.01, 0.001]),
    gate=None,
    correction="sequential",
)


def with_(**changes):
    return {**GOOD, **changes}
