"""Driving a unicycle along a path: :func:`unicycle_control` maps (estimated pose,
waypoint) to an action in [−1, 1]², :class:`PathFollower` runs it along a path with a
look-ahead point (pure pursuit)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from slam_env.world.frames import wrap_angle


@dataclass(frozen=True)
class ControllerParams:
    """Gains and limits of :func:`unicycle_control`.

    Attributes:
        max_speed: m/s at action 1.0 (the env's ``robot.max_speed``).
        max_turn_rate: rad/s at action 1.0 (the env's ``robot.max_turn_rate``).
        heading_gain: 1/s, commanded turn rate per rad of heading error.
        turn_in_place: rad, heading error above which the robot stops and turns.
        cruise: fraction of ``max_speed`` used when aligned (0, 1].
        turn_limit: fraction of ``max_turn_rate`` never exceeded (0, 1]: odometry
            noise grows with the square of each step's rotation, so gentle turns
            cost the heading estimate less per radian.
        dt: s, one env step (speeds are capped to reach, not overshoot, the goal).
    """

    max_speed: float = 1.0
    max_turn_rate: float = 1.5
    heading_gain: float = 2.5
    turn_in_place: float = math.radians(60.0)
    cruise: float = 1.0
    turn_limit: float = 1.0
    dt: float = 0.2

    def __post_init__(self) -> None:
        for name in ("max_speed", "max_turn_rate", "heading_gain", "turn_in_place", "dt"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"ControllerParams.{name} must be finite and > 0, got {value}")
        for name in ("cruise", "turn_limit"):
            value = getattr(self, name)
            if not 0.0 < value <= 1.0:
                raise ValueError(f"ControllerParams.{name} must be in (0, 1], got {value}")


def unicycle_control(
    pose: Sequence[float],
    waypoint: Sequence[float],
    params: ControllerParams | None = None,
    *,
    stop_distance: float | None = None,
) -> np.ndarray:
    """Action (speed, turn) fractions in [−1, 1] (float32 (2,)) that drive a unicycle
    at ``pose`` (x, y, θ) toward ``waypoint`` (x, y).

    The turn rate is proportional to the heading error e (saturated); the speed is
    ``cruise·cos²(e)``, zero when |e| exceeds ``turn_in_place`` (turn on the spot),
    and, when ``stop_distance`` (m) is given, capped so that the robot does not run
    past the point ``stop_distance`` short of the waypoint.
    """
    p = params or ControllerParams()
    dx = float(waypoint[0]) - float(pose[0])
    dy = float(waypoint[1]) - float(pose[1])
    dist = math.hypot(dx, dy)
    if dist < 1e-9:
        return np.zeros(2, dtype=np.float32)
    err = wrap_angle(math.atan2(dy, dx) - float(pose[2]))
    turn = max(-p.turn_limit, min(p.turn_limit, p.heading_gain * err / p.max_turn_rate))
    speed = 0.0 if abs(err) > p.turn_in_place else p.cruise * math.cos(err) ** 2
    if stop_distance is not None:
        room = max(dist - stop_distance, 0.0)
        speed = min(speed, room / (p.max_speed * p.dt))
    return np.array([speed, turn], dtype=np.float32)


class PathFollower:
    """Pure pursuit along a polyline with :func:`unicycle_control`.

    Args:
        points: (k, 2) the path in world coordinates (m), start to goal.
        lookahead: m, distance along the path of the point the robot steers at.
        params: the controller.
    """

    def __init__(
        self,
        points: np.ndarray,
        lookahead: float = 0.6,
        params: ControllerParams | None = None,
    ) -> None:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if not len(pts):
            raise ValueError("a path needs at least one point")
        self.points = pts
        seg = np.hypot(*np.diff(pts, axis=0).T) if len(pts) > 1 else np.zeros(0)
        self.arc = np.concatenate([[0.0], np.cumsum(seg)])  # (k,) arc length, m
        self.lookahead = float(lookahead)
        self.params = params or ControllerParams()
        self._index = 0  # the path point closest to the robot so far (monotone)

    @property
    def goal(self) -> np.ndarray:
        return self.points[-1].copy()

    def progress(self, position: Sequence[float]) -> tuple[float, float]:
        """Update the closest path point (searching forward) and return
        (distance from the path (m), arc length left to the goal (m))."""
        window = self.points[self._index : self._index + 12]
        d = np.hypot(window[:, 0] - position[0], window[:, 1] - position[1])
        k = int(np.argmin(d))
        self._index += k
        return float(d[k]), float(self.arc[-1] - self.arc[self._index])

    def target(self) -> np.ndarray:
        """The look-ahead point: ``lookahead`` m further along the path."""
        want = self.arc[self._index] + self.lookahead
        k = int(np.searchsorted(self.arc, want))
        return self.points[min(k, len(self.points) - 1)].copy()

    def action(self, pose: Sequence[float]) -> np.ndarray:
        """The action toward the look-ahead point; slows down to stop at the goal."""
        self.progress(pose)
        return unicycle_control(pose, self.target(), self.params, stop_distance=0.0)
