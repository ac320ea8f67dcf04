"""When the smoothing belief gives a step a pose variable: every k steps, or once the
robot has moved or turned far enough (:class:`Keyframes`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from slam_env.ekf import checks


@dataclass(frozen=True)
class Keyframes:
    """When a step gets a pose variable: every ``every`` steps, or once the robot has
    moved ``distance`` m or turned ``angle`` rad (the odometry composed since the last
    keyframe), whichever comes first; ``None`` disables a criterion, and at least one
    must be set. A step that sees a new landmark is always a keyframe."""

    every: int | None = None
    distance: float | None = None
    angle: float | None = None

    def __post_init__(self) -> None:
        if self.every is not None:
            if isinstance(self.every, (bool, np.bool_)) or not isinstance(
                self.every, (int, np.integer)
            ):
                raise TypeError(f"keyframes.every must be an int, got {type(self.every).__name__}")
            if self.every < 1:
                raise ValueError(f"keyframes.every must be >= 1, got {self.every}")
            object.__setattr__(self, "every", int(self.every))
        for name in ("distance", "angle"):
            value = getattr(self, name)
            if value is not None:
                value = checks.number(value, f"keyframes.{name}")
                if value <= 0.0:
                    raise ValueError(f"keyframes.{name} must be > 0, got {value}")
                object.__setattr__(self, name, value)
        if self.every is None and self.distance is None and self.angle is None:
            raise ValueError("keyframes needs at least one of every, distance, angle")

    def due(self, steps: int, increment: tuple[float, float, float]) -> bool:
        """Whether ``steps`` steps of odometry ``increment`` since the last keyframe
        make this step one."""
        dx, dy, dth = increment
        return (
            (self.every is not None and steps >= self.every)
            or (self.distance is not None and math.hypot(dx, dy) >= self.distance)
            or (self.angle is not None and abs(dth) >= self.angle)
        )


def keyframes_of(value: Any) -> Keyframes | None:
    if value is None or isinstance(value, Keyframes):
        return value
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(
            f"keyframes must be None, an int or a Keyframes, got {type(value).__name__}"
        )
    return Keyframes(every=int(value))
