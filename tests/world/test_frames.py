"""Pure geometry: angle wrapping and the odometry decomposition."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from slam_env.world.frames import (
    MIN_ODOMETRY_TRANSLATION,
    odometry_from_poses,
    robot_to_world,
    velocity_from_poses,
    world_to_robot,
    wrap_angle,
    wrap_float,
)

PI = math.pi
finite = st.floats(-1e3, 1e3, allow_nan=False)


def test_wrap_is_half_open_even_at_the_float_edge():
    # (a + π) % 2π − π rounds some inputs just below −π up to +π.
    below = np.nextafter(-PI, -4.0) - np.arange(8) * 1e-16
    wrapped = wrap_angle(below.copy())
    assert np.all(wrapped >= -PI) and np.all(wrapped < PI)
    for a in below.tolist():
        assert -PI <= wrap_angle(a) < PI
    assert wrap_angle(PI) == -PI


def test_scalar_wraps_are_bitwise_the_array_wrap():
    # The sensors wrap Python floats one by one; the stream must not depend on that.
    rng = np.random.default_rng(0)
    a = np.concatenate(
        [
            rng.uniform(-20.0, 20.0, 200_000),
            PI + rng.normal(0.0, 1e-12, 20_000),
            -PI + rng.normal(0.0, 1e-12, 20_000),
            np.nextafter(-PI, -4.0) - np.arange(8) * 1e-16,
            [PI, -PI, 0.0, -0.0, 2 * PI, -2 * PI, 1e-300, -1e-300],
        ]
    )
    expected = wrap_angle(a)
    assert np.array([wrap_float(v) for v in a.tolist()]).tobytes() == expected.tobytes()
    assert np.array([wrap_angle(v) for v in a]).tobytes() == expected.tobytes()


@given(finite)
def test_wrap_keeps_the_angle_on_the_circle(a):
    w = wrap_angle(a)
    assert -PI <= w < PI
    assert math.cos(w) == pytest.approx(math.cos(a), abs=1e-9)
    assert math.sin(w) == pytest.approx(math.sin(a), abs=1e-9)


def _apply_odometry(pose, u):
    x, y, th = pose
    r1, t, r2 = u
    return x + t * math.cos(th + r1), y + t * math.sin(th + r1), wrap_angle(th + r1 + r2)


@given(finite, finite, st.floats(-PI, PI), st.floats(-2, 2), st.floats(-2, 2), st.floats(-3, 3))
def test_odometry_decomposition_reproduces_the_motion(x, y, th, dx, dy, dth):
    pose0 = (x, y, th)
    pose1 = (x + dx, y + dy, wrap_angle(th + dth))
    u = odometry_from_poses(pose0, pose1)
    assert abs(u[0]) <= PI / 2  # reversing is a negative δtr, not a half-turn
    if math.hypot(dx, dy) >= MIN_ODOMETRY_TRANSLATION:
        got = _apply_odometry(pose0, u)
        assert got[0] == pytest.approx(pose1[0], abs=1e-9)
        assert got[1] == pytest.approx(pose1[1], abs=1e-9)
        assert wrap_angle(got[2] - pose1[2]) == pytest.approx(0.0, abs=1e-9)


def test_reversing_gives_negative_translation():
    r1, t, r2 = odometry_from_poses((0.0, 0.0, 0.0), (-0.3, 0.0, 0.0))
    assert (r1, t, r2) == pytest.approx((0.0, -0.3, 0.0))


def test_sub_millimetre_push_does_not_invent_a_direction():
    # Turning in place while a contact nudges the robot sideways by 0.5 mm.
    r1, t, r2 = odometry_from_poses((0.0, 0.0, 0.0), (0.0, 5e-4, 0.3))
    assert r1 == 0.0 and t == 0.0 and r2 == pytest.approx(0.3)


def test_velocity_control_projects_on_the_heading():
    dp, dth = velocity_from_poses((1.0, 1.0, PI / 2), (1.0, 1.5, PI / 2 + 0.1))
    assert dp == pytest.approx(0.5) and dth == pytest.approx(0.1)


@given(finite, finite, st.floats(-PI, PI), finite, finite)
def test_frame_transforms_are_inverse(x, y, th, px, py):
    pose = (x, y, th)
    p = np.array([[px, py]])
    back = robot_to_world(pose, world_to_robot(pose, p))
    np.testing.assert_allclose(back, p, atol=1e-9)
