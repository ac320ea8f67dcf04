"""The sensors on their own, for users' own worlds (the landmark sensor with IDs, noisy
odometry), and the raw observation of the envs' stream."""

from slam_env.sensing.landmark_sensor import Detections, LandmarkSensor
from slam_env.sensing.odometry_sensor import OdometrySensor
from slam_env.sensing.raw_observation import unpack_detections

__all__ = ["Detections", "LandmarkSensor", "OdometrySensor", "unpack_detections"]
