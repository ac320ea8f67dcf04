"""Smoothing beliefs beside the filter: SLAM by incremental smoothing (iSAM2), with
the shape of :class:`~slam_env.ekf.EKFSLAM`'s API and no gymnasium or pymunk.

    from slam_env.smoothing import ISAM2SLAM
    s = ISAM2SLAM(motion_model="odometry", measurement_model="range_bearing",
                  alphas=(a1, a2, a3, a4), measurement_cov=Q, max_landmarks=N)
    s.predict(u)                 # (δrot1, δtr, δrot2), or (Δp, Δθ) for "velocity"
    res = s.update(z, ids)       # z: (k, 2), ids: (k,) ints -> UpdateResult
    s.mean, s.cov, s.state_to_id # cov: the joint marginal of the pose and the map
    s.optimize()                 # the full update: the batch optimum

GTSAM is an optional dependency (the ``gtsam`` extra): importing this package needs
only numpy; constructing an estimator without GTSAM raises
:class:`slam_env.extras.MissingExtra`. See :mod:`slam_env.smoothing.isam2` for the
graph, the options and the covariance, :mod:`slam_env.smoothing.odometry` for the
motion factors' increments and frames, :mod:`slam_env.smoothing.graph` for the GTSAM
factors.
"""

from slam_env.smoothing.isam2 import ISAM2SLAM, MOTION_FACTORS, landmark_key, pose_key
from slam_env.smoothing.keyframes import Keyframes
from slam_env.smoothing.odometry import MOTION_FLOOR, PRIOR_FLOOR

__all__ = [
    "ISAM2SLAM",
    "MOTION_FACTORS",
    "MOTION_FLOOR",
    "PRIOR_FLOOR",
    "Keyframes",
    "landmark_key",
    "pose_key",
]
