"""The odometry between two pose variables of the smoothing graph, and the frames its
covariance is written in (numpy and the models' compiled scalar functions only).

A motion factor joins pose variables ``x_a`` and ``x_b`` with the *increment* ``D``,
the pose ``x_b`` in the frame of ``x_a`` that the controls predict (``D = g(0, u)``
for one control; the composition of the controls' increments for several), and the
covariance ``P`` of its error in the same coordinates as the batch smoother's motion
factor (``references/smoother.py``): the components ``(R(θ_a)ᵀ(t_b − t_a), θ_b − θ_a)``
of the relative pose less those of ``D``. For one control ``P = R_t + MOTION_FLOOR·I``,
with ``R_t`` the filter's own ``R_x`` (``V M Vᵀ`` for the odometry model, ``B Σu Bᵀ``
for the velocity model) evaluated at heading 0; several controls compose as the
filter's prediction does, started at the identity with zero covariance:
``D ← D ⊕ g(0, u)``, ``P ← G P Gᵀ + R_x(D, u) + MOTION_FLOOR·I`` (the floor is
isotropic, so it reads the same in every frame). That is first-order exact: ``P`` is
the linearised marginal of the intermediate poses a keyframe leaves out.

Frames: GTSAM perturbs a ``Pose2`` on the right, ``x ⊕ ξ = x·Exp(ξ)``, with
``ξ = (ξx, ξy, ξθ)`` in the pose's own frame; the filter's state perturbs ``(x, y, θ)``
in the world. To first order the world perturbation is ``T(θ) ξ`` with
``T(θ) = blockdiag(R(θ), 1)`` (:func:`frame_jacobian`), which is how covariances move
between the two.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base import models as km
from slam_env.kernels.base.models import wrap_angle

__all__ = [
    "MOTION_FLOOR",
    "PRIOR_FLOOR",
    "compose",
    "compose_pose",
    "frame_jacobian",
    "propagate",
]

# Variance (m², rad²) added to the diagonal of every step's motion covariance, as the
# batch smoother does (references/smoother.py's MOTION_FLOOR, the same value; a test
# holds them equal): where the model has no noise (the sideways direction of a turn on
# the spot, a stop) the factor would be a hard constraint and its information infinite.
MOTION_FLOOR = 1e-8
# Variance added to the diagonal of the start pose's covariance for its prior factor.
# A zero covariance (a known start) would be a hard constraint, which iSAM2's Cholesky
# factorisation cannot take; 1e-12 (a 1 µm, 1 µrad standard deviation) is four orders
# below MOTION_FLOOR, so the start moves less than 1e-4 of any pull on it (the batch
# smoother holds it fixed; the test holds the two to 1e-6 m), and its information
# (1e12) stays within a few orders of the stiffest motion factor's (1e8), far from
# float64's limits in the factorisation.
PRIOR_FLOOR = 1e-12


def frame_jacobian(theta: float) -> np.ndarray:
    """T(θ) = blockdiag(R(θ), 1) (3×3): the world perturbation of a pose at heading θ
    per unit of GTSAM's ``Pose2`` tangent (x, y, θ in the pose's frame)."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def compose(
    motion_code: int,
    params: tuple[float, float, float, float],
    increment: tuple[float, float, float],
    cov: np.ndarray,
    u: tuple[float, float, float],
) -> tuple[tuple[float, float, float], np.ndarray]:
    """``(D ⊕ g(0, u), G P Gᵀ + R_x + MOTION_FLOOR·I)``: the increment ``D`` and its
    covariance ``P`` (3×3, see the module's docstring) after one more control ``u``
    (three floats; the velocity model's third is unused). A fresh ``P``."""
    x, y, th = increment
    out = km.motion_predict(motion_code, x, y, th, u[0], u[1], u[2], *params)
    nx, ny, nth, a, b, r00, r01, r02, r11, r12, r22 = out
    G = np.array([[1.0, 0.0, a], [0.0, 1.0, b], [0.0, 0.0, 1.0]])
    R = np.array([[r00, r01, r02], [r01, r11, r12], [r02, r12, r22]])
    P = G @ cov @ G.T + R
    P[0, 0] += MOTION_FLOOR
    P[1, 1] += MOTION_FLOOR
    P[2, 2] += MOTION_FLOOR
    return (nx, ny, nth), 0.5 * (P + P.T)


def compose_pose(pose: np.ndarray, increment: tuple[float, float, float]) -> np.ndarray:
    """``pose ⊕ D``: (3,) the pose the increment ``D`` (in the frame of ``pose``)
    leads to, heading wrapped to [−π, π)."""
    x, y, th = (float(v) for v in pose)
    dx, dy, dth = increment
    c, s = math.cos(th), math.sin(th)
    return np.array([x + c * dx - s * dy, y + s * dx + c * dy, wrap_angle(th + dth)])


def propagate(
    cov: np.ndarray, theta: float, increment: tuple[float, float, float], P: np.ndarray
) -> np.ndarray:
    """The covariance of ``[pose ⊕ D, map]`` from that of ``[pose, map]``
    (``cov: (d, d)``, pose first, world frame; ``theta`` the pose's heading), ``D``
    having covariance ``P`` in the frame of the pose: ``F Σ Fᵀ + T P Tᵀ`` on the pose
    block, ``F Σ_pm`` across, with ``F = ∂(pose ⊕ D)/∂pose`` and ``T = T(θ)``. The
    filter's prediction, over several steps at once. A fresh array."""
    dx, dy, _ = increment
    c, s = math.cos(theta), math.sin(theta)
    F = np.array([[1.0, 0.0, -s * dx - c * dy], [0.0, 1.0, c * dx - s * dy], [0.0, 0.0, 1.0]])
    out = cov.copy()
    out[:3, :] = F @ out[:3, :]
    out[:, :3] = out[:, :3] @ F.T
    T = frame_jacobian(theta)
    out[:3, :3] += T @ P @ T.T
    return 0.5 * (out + out.T)
