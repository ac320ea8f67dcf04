"""EKF-SLAM with known correspondences (no gymnasium, no pymunk): numpy and the
compiled kernels of :mod:`slam_env.kernels`.

    from slam_env.ekf import EKFSLAM, chi2_gate
    f = EKFSLAM(motion_model="odometry", measurement_model="range_bearing",
                alphas=(a1, a2, a3, a4), measurement_cov=Q, max_landmarks=N,
                gate=chi2_gate(0.999))
    f.predict(u)                 # (δrot1, δtr, δrot2), or (Δp, Δθ) for "velocity"
    res = f.update(z, ids)       # z: (k, 2), ids: (k,) ints -> UpdateResult
    f.mean, f.cov, f.state_to_id

See :class:`slam_env.ekf.filter.EKFSLAM` for the contract and
:mod:`slam_env.ekf.models` for the models, their Jacobians and inverse models.
"""

from slam_env.ekf.chi2 import DEFAULT_GATE, chi2_gate, chi2_ppf
from slam_env.ekf.configuration import (
    CORRECTION_MODES,
    DATA_ASSOCIATIONS,
    LINEARIZATIONS,
    kernel_config,
)
from slam_env.ekf.filter import EKFSLAM
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.ekf.results import (
    CORRECTED,
    DISCARDED,
    INITIALISED,
    REJECTED,
    TENTATIVE,
    Status,
    UpdateResult,
)

__all__ = [
    "CORRECTED",
    "CORRECTION_MODES",
    "DATA_ASSOCIATIONS",
    "DEFAULT_GATE",
    "DISCARDED",
    "EKFSLAM",
    "INITIALISED",
    "LINEARIZATIONS",
    "MEASUREMENT_MODELS",
    "MOTION_MODELS",
    "REJECTED",
    "TENTATIVE",
    "Status",
    "UpdateResult",
    "chi2_gate",
    "chi2_ppf",
    "kernel_config",
]
