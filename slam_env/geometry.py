"""Pure geometry helpers shared by the world, the sensors and the filter."""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi
_HALF_PI = math.pi / 2.0


# The largest float below π: (a + π) % 2π − π rounds to +π for some a just below −π.
_BELOW_PI = math.nextafter(math.pi, 0.0)


def wrap_angle(angle):
    """Wrap an angle (scalar or array, rad) to [−π, π), half-open even at round-off."""
    if isinstance(angle, np.ndarray):
        return np.minimum((angle + math.pi) % TWO_PI - math.pi, _BELOW_PI)
    return wrap_float(float(angle))


def wrap_float(angle: float) -> float:
    """:func:`wrap_angle` of a Python float, without the type dispatch (for hot loops).
    Python's float ``%`` and numpy's ``remainder`` round alike, so this and the array
    form of :func:`wrap_angle` agree bit for bit."""
    wrapped = (angle + math.pi) % TWO_PI - math.pi
    # min(wrapped, _BELOW_PI) as a comparison (a builtin call costs more); NaN passes.
    return _BELOW_PI if wrapped > _BELOW_PI else wrapped


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


# Below this translation (m) the direction of motion is noise: a contact nudging a
# robot that turns in place would otherwise give any δrot1 up to ±π/2 and, through
# α1·δrot1², a heading noise of tenths of a radian for a sub-millimetre push.
MIN_ODOMETRY_TRANSLATION = 1e-3


def odometry_from_poses(
    pose0, pose1, min_translation: float = MIN_ODOMETRY_TRANSLATION
) -> tuple[float, float, float]:
    """Decompose the motion pose0 → pose1 into (δrot1, δtr, δrot2) (seed 000).

    A motion that goes backwards relative to the heading is given a negative δtr,
    so that δrot1 stays small instead of jumping to ±π: the odometry model's noise
    grows with δrot1², and reversing is not a half-turn. Below ``min_translation``
    δrot1 is set to 0, δtr is the displacement along the heading and the whole
    rotation goes into δrot2 (the sideways part, under a millimetre, is dropped).
    """
    x0, y0, th0 = pose0
    x1, y1, th1 = pose1
    dx, dy = x1 - x0, y1 - y0
    trans = math.hypot(dx, dy)
    # wrap_float(float(a)) is wrap_angle(a) for a scalar, without its type dispatch
    # (this runs at every env step).
    if trans < min_translation:
        along = dx * math.cos(th0) + dy * math.sin(th0)
        return 0.0, along, wrap_float(float(th1 - th0))
    rot1 = wrap_float(float(math.atan2(dy, dx) - th0))
    if abs(rot1) > _HALF_PI:
        rot1 = wrap_float(rot1 - math.pi)
        trans = -trans
    rot2 = wrap_float(float(th1 - th0 - rot1))
    return rot1, trans, rot2


def velocity_from_poses(pose0, pose1) -> tuple[float, float]:
    """The (Δp, Δθ) control of seed 004 for the motion pose0 → pose1: Δp is the
    displacement projected on the initial heading (signed), Δθ the wrapped turn."""
    x0, y0, th0 = pose0
    x1, y1, th1 = pose1
    dp = (x1 - x0) * math.cos(th0) + (y1 - y0) * math.sin(th0)
    return dp, wrap_angle(th1 - th0)
