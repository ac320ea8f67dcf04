"""The unicycle controller and pure pursuit (agents.planners.path_control)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.planners.path_control import ControllerParams, PathFollower, unicycle_control


def test_controller_turns_on_the_spot_toward_a_waypoint_behind():
    params = ControllerParams()
    left = unicycle_control((0.0, 0.0, 0.0), (-2.0, 0.3), params)
    right = unicycle_control((0.0, 0.0, 0.0), (-2.0, -0.3), params)
    for action in (left, right):
        assert action.dtype == np.float32 and action.shape == (2,)
        assert action[0] == 0.0  # heading error > turn_in_place: no forward motion
        assert abs(action[1]) == pytest.approx(1.0)  # saturated turn
    assert left[1] > 0.0 > right[1]
    ahead = unicycle_control((0.0, 0.0, 0.0), (3.0, 0.0), params)
    assert ahead[0] == pytest.approx(1.0) and ahead[1] == pytest.approx(0.0)
    slight = unicycle_control((0.0, 0.0, 0.0), (3.0, 0.5), params)
    assert 0.0 < slight[0] < 1.0 and slight[1] > 0.0
    gentle = unicycle_control((0.0, 0.0, 0.0), (-2.0, 0.3), ControllerParams(turn_limit=0.5))
    assert gentle[1] == pytest.approx(0.5)


def test_controller_drives_a_unicycle_to_a_waypoint_behind():
    params = ControllerParams()
    x, y, th = 0.0, 0.0, 0.0
    goal = (-2.0, 1.0)
    for step in range(60):
        v_frac, w_frac = unicycle_control((x, y, th), goal, params, stop_distance=0.0)
        if step < 3:
            assert v_frac == 0.0  # it first turns around
        v, w = v_frac * params.max_speed, w_frac * params.max_turn_rate
        x += v * params.dt * math.cos(th)
        y += v * params.dt * math.sin(th)
        th += w * params.dt
        if math.hypot(x - goal[0], y - goal[1]) < 0.1:
            break
    assert math.hypot(x - goal[0], y - goal[1]) < 0.1


def test_path_follower_tracks_an_l_shaped_path():
    params = ControllerParams()
    points = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    follower = PathFollower(points, lookahead=0.5, params=params)
    x, y, th = 0.0, 0.0, 0.0
    worst = 0.0
    for _ in range(60):
        v_frac, w_frac = follower.action((x, y, th))
        x += v_frac * params.max_speed * params.dt * math.cos(th)
        y += v_frac * params.max_speed * params.dt * math.sin(th)
        th += w_frac * params.max_turn_rate * params.dt
        off = min(abs(y) if x <= 2.0 else math.inf, abs(x - 2.0) if y >= 0.0 else math.inf)
        worst = max(worst, min(off, math.hypot(x - 2.0, y)))
    assert math.hypot(x - 2.0, y - 2.0) < 0.3
    assert worst < 0.5  # stays near the path
