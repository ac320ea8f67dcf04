"""Pure geometry helpers shared by the world, the sensors and the filter."""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base import angles
from slam_env.kernels.stream import odometry
from slam_env.kernels.stream.odometry import MIN_ODOMETRY_TRANSLATION

TWO_PI = 2.0 * math.pi


def wrap_angle(angle):
    """Wrap an angle (scalar or array, rad) to [−π, π), half-open even at round-off."""
    if isinstance(angle, np.ndarray):
        flat = np.ascontiguousarray(angle, dtype=np.float64).ravel()
        out = np.empty_like(flat)
        angles.wrap_array(flat, out)
        return out.reshape(angle.shape)
    return angles.wrap(float(angle))


def wrap_float(angle: float) -> float:
    """:func:`wrap_angle` of a Python float (the compiled function itself)."""
    return angles.wrap(angle)


def rotation(theta: float) -> np.ndarray:
    """R(θ), the 2×2 rotation from the robot frame to the world frame."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def world_to_robot(pose, points: np.ndarray) -> np.ndarray:
    """Points (k, 2) in the world frame expressed in the robot frame: R(θ)ᵀ(p − t)."""
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    dx = points[..., 0] - x
    dy = points[..., 1] - y
    return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)


def robot_to_world(pose, points: np.ndarray) -> np.ndarray:
    """Points (k, 2) in the robot frame expressed in the world frame: R(θ)p + t."""
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    px = points[..., 0]
    py = points[..., 1]
    return np.stack([c * px - s * py + x, s * px + c * py + y], axis=-1)


def odometry_from_poses(
    pose0, pose1, min_translation: float = MIN_ODOMETRY_TRANSLATION
) -> tuple[float, float, float]:
    """Decompose the motion pose0 → pose1 into (δrot1, δtr, δrot2) (seed 000); see
    :func:`slam_env.kernels.stream.odometry.odometry_from_poses`."""
    x0, y0, th0 = (float(v) for v in pose0[:3])
    x1, y1, th1 = (float(v) for v in pose1[:3])
    return odometry.odometry_from_poses(x0, y0, th0, x1, y1, th1, float(min_translation))


def velocity_from_poses(pose0, pose1) -> tuple[float, float]:
    """The (Δp, Δθ) control of seed 004 for the motion pose0 → pose1: Δp is the
    displacement projected on the initial heading (signed), Δθ the wrapped turn."""
    x0, y0, th0 = (float(v) for v in pose0[:3])
    x1, y1, th1 = (float(v) for v in pose1[:3])
    return odometry.velocity_from_poses(x0, y0, th0, x1, y1, th1)
