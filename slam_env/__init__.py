"""slam_env: Gymnasium environments for active SLAM.

Importing the package registers ``slam_env/Landmarks-v0`` (the raw sensor stream)
and ``slam_env/ActiveSLAM-v0`` (the same world behind the EKF-SLAM belief wrapper).
"""

from slam_env.config import (
    EnvConfig,
    OdometryConfig,
    RewardConfig,
    RobotConfig,
    SensorConfig,
    WorldConfig,
    make_config,
)

try:
    import gymnasium  # noqa: F401
except ImportError:  # the filter alone (slam_env.ekf) needs only numpy and numba
    pass
else:
    from slam_env.envs.registration import register_envs

    register_envs()

__all__ = [
    "EnvConfig",
    "OdometryConfig",
    "RewardConfig",
    "RobotConfig",
    "SensorConfig",
    "WorldConfig",
    "make_config",
]
__version__ = "0.2.0"
