"""The raw observation of ``slam_env/Landmarks-v0``: its space and bounds, and the
valid detections of one observation."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from slam_env.config import EnvConfig
from slam_env.kernels.stream.observe import RawParams

__all__ = [
    "detection_reach",
    "odometry_translation_bound",
    "raw_observation_space",
    "unpack_detections",
]

# Headroom of the odometry translation bound over the largest physical motion of a
# step: the noise is proportional to the motion, so a reading beyond this is a >10σ event.
ODOMETRY_TRANSLATION_HEADROOM = 4.0
# Detections are clipped to the sensor's range plus this many range standard deviations.
RANGE_HEADROOM_STD = 6.0


def odometry_translation_bound(config: EnvConfig) -> float:
    """The bound (m) of the odometry's translation reading (δtr or Δp)."""
    return ODOMETRY_TRANSLATION_HEADROOM * config.robot.max_speed * config.dt + 1.0


def detection_reach(config: EnvConfig) -> float:
    """The bound (m) of a detection's range (or robot-frame coordinates)."""
    sensor = config.sensor
    return sensor.max_range + RANGE_HEADROOM_STD * max(sensor.range_std, sensor.cartesian_std)


def raw_observation_space(
    config: EnvConfig, n_slots: int, max_detections: int
) -> tuple[spaces.Dict, RawParams]:
    """The raw observation space of one sub-env, and the bounds its values are clipped
    to with the reward's constants (see :class:`slam_env.envs.landmarks.LandmarksEnv`)."""
    trans_bound = odometry_translation_bound(config)
    if config.odometry.motion_model == "odometry":
        odo_high = np.array([math.pi, trans_bound, math.pi], dtype=np.float32)
    else:
        odo_high = np.array([trans_bound, math.pi], dtype=np.float32)
    sensor = config.sensor
    reach = detection_reach(config)
    if sensor.measurement_model == "range_bearing":
        det_low = np.array([0.0, -math.pi], dtype=np.float32)
        det_high = np.array([reach, math.pi], dtype=np.float32)
    else:
        det_low = np.full(2, -reach, dtype=np.float32)
        det_high = np.full(2, reach, dtype=np.float32)
    d = max_detections
    obs_spaces = {
        "odometry": spaces.Box(-odo_high, odo_high, dtype=np.float32),
        "detections": spaces.Box(np.tile(det_low, d), np.tile(det_high, d), dtype=np.float32),
        "ids": spaces.Box(-1.0, float(n_slots - 1), (d,), np.float32),
        "mask": spaces.Box(0.0, 1.0, (d,), np.float32),
    }
    if sensor.scan_beams:
        obs_spaces["scan"] = spaces.Box(0.0, 1.0, (sensor.scan_beams,), np.float32)
    if sensor.bumper:
        obs_spaces["bumper"] = spaces.Box(0.0, 1.0, (1,), np.float32)
    params = RawParams(
        (-odo_high).astype(np.float64),
        odo_high.astype(np.float64),
        det_low.astype(np.float64),
        det_high.astype(np.float64),
        float(config.reward.new_landmark_bonus),
        float(config.reward.collision_penalty),
        bool(sensor.report_ids),
    )
    return spaces.Dict(obs_spaces), params


def unpack_detections(obs: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The valid detections of a raw observation: ``z`` (k, 2) float64 and ``ids`` (k,)
    int64, in the observation's order (ascending ID)."""
    valid = obs["mask"] > 0.5
    k = int(np.count_nonzero(valid))
    if valid[:k].all():  # the env's layout: detections first, then padding
        z = obs["detections"][: 2 * k].reshape(k, 2).astype(np.float64)
        return z, obs["ids"][:k].astype(np.int64)
    z = obs["detections"].reshape(-1, 2)[valid].astype(np.float64)
    return z, obs["ids"][valid].astype(np.int64)
