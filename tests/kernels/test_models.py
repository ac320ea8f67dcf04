"""The scalar model kernels against the plain formulas of the seeds and the geometry
helpers (the array forms in slam_env.ekf.models are tested in tests/ekf/test_models.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from references import dense_ekf
from slam_env.kernels.base import models as km
from slam_env.world.frames import wrap_float


def test_wrap_angle_is_the_geometry_helper_bit_for_bit():
    rng = np.random.default_rng(0)
    edge = math.nextafter(-math.pi, -4.0)
    turn = 2 * math.pi
    values = [
        *rng.uniform(-50, 50, 1000),
        *rng.uniform(-1.5 * turn, 1.5 * turn, 3000),  # the branches that skip the remainder
        *(math.nextafter(v, t) for v in (-3 * math.pi, math.pi) for t in (-10.0, 10.0)),
        *(math.nextafter(-math.pi, t) for t in (-10.0, 10.0)),
        math.pi,
        -math.pi,
        3 * math.pi,
        -3 * math.pi,
        0.0,
        -0.0,
        1e300,
        -1e300,
        edge,
        3.3,
    ]
    for a in values:
        wrapped = km.wrap_angle(a)
        assert wrapped == wrap_float(a) and math.copysign(1, wrapped) == math.copysign(
            1, wrap_float(a)
        )
        assert -math.pi <= wrapped < math.pi


def test_noise_variances_follow_the_seeds_bit_for_bit():
    rng = np.random.default_rng(1)
    for _ in range(200):
        r1, t, r2, a1, a2, a3, a4 = rng.normal(size=7).tolist()
        assert km.odometry_variances(r1, t, r2, a1, a2, a3, a4) == (
            a1 * (r1 * r1) + a2 * (t * t),
            a3 * (t * t) + a4 * ((r1 * r1) + (r2 * r2)),
            a1 * (r2 * r2) + a2 * (t * t),
        )
        dp, dth, sp, sth, bp, bth = rng.normal(size=6).tolist()
        assert km.velocity_variances(dp, dth, sp, sth, bp, bth) == (
            sp * sp + bp * dp * dp,
            sth * sth + bth * dth * dth,
        )


@pytest.mark.parametrize(
    ("model", "u"), [(km.ODOMETRY, (0.2, 3.0, -0.1)), (km.VELOCITY, (3.0, 0.2, 9.9))]
)
def test_motion_predict_is_the_model_its_jacobians_and_its_noise(model, u):
    """The next pose, G = [[1, 0, a], [0, 1, b], [0, 0, 1]] and R_x = J M Jᵀ (J = V or B),
    against the seed formulas written out here (the velocity model ignores u[2]), plus
    the odometry model's sideways terms of the dense reference."""
    x, y, th = 1.0, 2.0, 0.5
    noise = (0.1, 0.2, 0.3, 0.4)
    nx, ny, nth, a, b, *R = km.motion_predict(model, x, y, th, *u, *noise)
    if model == km.ODOMETRY:
        h, trans = th + u[0], u[1]
        c, s = math.cos(h), math.sin(h)
        pose = (x + trans * c, y + trans * s, wrap_float(h + u[2]))
        G = (-trans * s, trans * c)
        J = np.array([[-trans * s, c, 0], [trans * c, s, 0], [1, 0, 1]])
        M = np.diag(km.odometry_variances(*u, *noise))
        extra = dense_ekf.odometry_sideways_noise(th, u, noise)
    else:
        c, s = math.cos(th), math.sin(th)
        pose = (x + u[0] * c, y + u[0] * s, wrap_float(th + u[1]))
        G = (-u[0] * s, u[0] * c)
        J = np.array([[c, 0], [s, 0], [0, 1]])
        M = np.diag(km.velocity_variances(u[0], u[1], *noise))
        extra = np.zeros((3, 3))
    np.testing.assert_allclose((nx, ny, nth), pose, rtol=0, atol=1e-15)
    np.testing.assert_allclose((a, b), G, rtol=0, atol=1e-15)
    expected = (J @ M @ J.T + extra)[np.triu_indices(3)]
    np.testing.assert_allclose(R, expected, rtol=1e-14, atol=1e-15)


def test_a_landmark_on_the_robot_is_singular_for_range_bearing_only():
    assert km.singular(km.RANGE_BEARING, 1.0, 2.0, 1.0, 2.0)
    assert not km.singular(km.RANGE_BEARING, 1.0, 2.0, 1.0, 2.5)
    assert not km.singular(km.CARTESIAN, 1.0, 2.0, 1.0, 2.0)
    assert all(math.isnan(v) for v in km.jacobian(km.RANGE_BEARING, 1.0, 2.0, 0.3, 1.0, 2.0))
    assert all(math.isfinite(v) for v in km.jacobian(km.CARTESIAN, 1.0, 2.0, 0.3, 1.0, 2.0))


def test_the_bearing_innovation_is_wrapped_and_the_cartesian_one_is_not():
    assert km.innovation(km.RANGE_BEARING, 2.0, 3.1, 1.5, -3.1) == pytest.approx(
        (0.5, 6.2 - 2 * math.pi)
    )
    assert km.innovation(km.CARTESIAN, 2.0, 3.1, 1.5, -3.1) == pytest.approx((0.5, 6.2))


@pytest.mark.parametrize("model", [km.RANGE_BEARING, km.CARTESIAN])
def test_measurement_many_is_the_scalar_functions_point_by_point(model):
    rng = np.random.default_rng(2)
    pose = (0.3, -0.4, 2.0)
    points = rng.normal(size=(6, 2)) * 3
    points[0] = pose[:2]  # singular for range-bearing
    for what, width, fn in [
        (km.H, 2, lambda p: km.observe(model, *pose, *p)),
        (km.H_JACOBIAN, 10, lambda p: km.jacobian(model, *pose, *p)),
        (km.H_INVERSE, 2, lambda p: km.inverse(model, *pose, *p)),
        (km.H_INVERSE_JACOBIAN, 6, lambda p: km.inverse_jacobian(model, pose[2], *p)),
        (km.H_SINGULAR, 1, lambda p: (float(km.singular(model, pose[0], pose[1], *p)),)),
    ]:
        out = np.full((6, width), 7.0)
        km.measurement_many(what, model, *pose, points, out)
        for i in range(6):
            np.testing.assert_array_equal(out[i], fn(points[i]))
