"""Motion and measurement models: Jacobians against central finite differences,
inverse models against the forward ones, fast paths against the vectorised ones."""

from __future__ import annotations

import math

import numpy as np
import pytest

from references import dense_ekf
from slam_env.ekf import models
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.world.frames import wrap_angle

EPS = 1e-6
TOL = 1e-6


def central_difference(f, x0, angular=()):
    """∂f/∂x at x0 by central differences; output components listed in ``angular``
    are angles, whose differences are wrapped (an output crossing ±π is not a jump)."""
    x0 = np.asarray(x0, dtype=float)
    cols = []
    for i in range(x0.size):
        e = np.zeros_like(x0)
        e[i] = EPS
        diff = np.asarray(f(x0 + e), float) - np.asarray(f(x0 - e), float)
        for a in angular:
            diff[a] = wrap_angle(diff[a])
        cols.append(diff / (2.0 * EPS))
    return np.stack(cols, axis=-1)


def random_pose(rng):
    return np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-math.pi, math.pi)])


def random_landmark(rng, pose):
    # 0.5 m to 6 m from the robot, any direction.
    r, a = rng.uniform(0.5, 6.0), rng.uniform(-math.pi, math.pi)
    return pose[:2] + r * np.array([math.cos(a), math.sin(a)])


def random_control(rng, name):
    if name == "odometry":
        return np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)])
    return np.array([rng.uniform(-1, 1), rng.uniform(-1, 1)])


# --------------------------------------------------------------------------- motion


@pytest.mark.parametrize("name", ["odometry", "velocity"])
def test_motion_jacobians_match_finite_differences(name):
    mm = MOTION_MODELS[name]
    rng = np.random.default_rng(1)
    for _ in range(50):
        pose, u = random_pose(rng), random_control(rng, name)
        G, J = mm.jacobians(pose, u)
        assert G.shape == (3, 3)
        assert J.shape == (3, mm.control_dim)
        fd_pose = central_difference(lambda p, u=u: mm.motion(p, u), pose, angular=(2,))
        fd_u = central_difference(lambda v, pose=pose: mm.motion(pose, v), u, angular=(2,))
        np.testing.assert_allclose(G, fd_pose, rtol=0, atol=TOL)
        np.testing.assert_allclose(J, fd_u, rtol=0, atol=TOL)


@pytest.mark.parametrize("name", ["odometry", "velocity"])
def test_scalar_motion_linearise_equals_the_model(name):
    mm = MOTION_MODELS[name]
    params = (0.1, 0.2, 0.3, 0.4)
    rng = np.random.default_rng(8)
    for _ in range(30):
        pose, u = random_pose(rng), random_control(rng, name)
        nx, ny, nth, a, b, r = mm.linearise(*pose.tolist(), u.tolist(), params)
        G, J = mm.jacobians(pose, u)
        Rx = J @ mm.noise_cov(u, params) @ J.T
        if name == "odometry":
            Rx += dense_ekf.odometry_sideways_noise(pose[2], u, params)
        np.testing.assert_allclose(mm.pose_noise(pose, u, params), Rx, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose([nx, ny, nth], mm.motion(pose, u), rtol=0, atol=1e-14)
        np.testing.assert_allclose(G, [[1, 0, a], [0, 1, b], [0, 0, 1]], rtol=0, atol=1e-14)
        upper = Rx[np.triu_indices(3)]
        np.testing.assert_allclose(r, upper, rtol=1e-12, atol=1e-15)


def test_motion_models_follow_the_seed_equations():
    pose = np.array([1.0, 2.0, 0.5])
    g = models.odometry_motion(pose, (0.2, 3.0, -0.1))
    np.testing.assert_allclose(
        g, [1.0 + 3.0 * math.cos(0.7), 2.0 + 3.0 * math.sin(0.7), 0.6], rtol=0, atol=1e-15
    )
    f = models.velocity_motion(pose, (3.0, 0.2))
    np.testing.assert_allclose(
        f, [1.0 + 3.0 * math.cos(0.5), 2.0 + 3.0 * math.sin(0.5), 0.7], rtol=0, atol=1e-15
    )
    # The heading is wrapped to [−π, π).
    assert models.odometry_motion((0, 0, 3.0), (0.1, 0.0, 0.2))[2] == pytest.approx(
        3.3 - 2 * math.pi
    )
    assert models.velocity_motion((0, 0, -3.0), (0.0, -0.3))[2] == pytest.approx(2 * math.pi - 3.3)


def test_noise_covariances():
    M = models.odometry_action_cov((0.2, 3.0, -0.1), (0.1, 0.2, 0.3, 0.4))
    np.testing.assert_allclose(
        M,
        np.diag([0.1 * 0.04 + 0.2 * 9, 0.3 * 9 + 0.4 * (0.04 + 0.01), 0.1 * 0.01 + 0.2 * 9]),
    )
    Su = models.velocity_control_cov((2.0, -0.5), (0.1, 0.2, 0.3, 0.4))
    np.testing.assert_allclose(Su, np.diag([0.01 + 0.3 * 4, 0.04 + 0.4 * 0.25]))


# --------------------------------------------------------------------------- measurement


@pytest.mark.parametrize("name", ["range_bearing", "cartesian"])
def test_measurement_jacobians_match_finite_differences(name):
    hm = MEASUREMENT_MODELS[name]
    angular = tuple(i for i, a in enumerate(hm.angular) if a)
    rng = np.random.default_rng(2)
    for _ in range(50):
        pose = random_pose(rng)
        m = random_landmark(rng, pose)
        Hx, Hm = hm.jacobians(pose, m)
        assert Hx.shape == (2, 3) and Hm.shape == (2, 2)
        fd_x = central_difference(lambda p, m=m: hm.h(p, m), pose, angular)
        fd_m = central_difference(lambda q, pose=pose: hm.h(pose, q), m, angular)
        np.testing.assert_allclose(Hx, fd_x, rtol=0, atol=TOL)
        np.testing.assert_allclose(Hm, fd_m, rtol=0, atol=TOL)


@pytest.mark.parametrize("name", ["range_bearing", "cartesian"])
def test_inverse_jacobians_match_finite_differences(name):
    hm = MEASUREMENT_MODELS[name]
    rng = np.random.default_rng(3)
    for _ in range(50):
        pose = random_pose(rng)
        z = hm.h(pose, random_landmark(rng, pose))
        L, W = hm.inverse_jacobians(pose, z)
        assert L.shape == (2, 3) and W.shape == (2, 2)
        fd_x = central_difference(lambda p, z=z: hm.inverse(p, z), pose)
        fd_z = central_difference(lambda v, pose=pose: hm.inverse(pose, v), z)
        np.testing.assert_allclose(L, fd_x, rtol=0, atol=TOL)
        np.testing.assert_allclose(W, fd_z, rtol=0, atol=TOL)


@pytest.mark.parametrize("name", ["range_bearing", "cartesian"])
def test_inverse_of_h_is_the_landmark(name):
    hm = MEASUREMENT_MODELS[name]
    rng = np.random.default_rng(4)
    for _ in range(20):
        pose = random_pose(rng)
        m = np.stack([random_landmark(rng, pose) for _ in range(7)])
        np.testing.assert_allclose(hm.inverse(pose, hm.h(pose, m)), m, rtol=0, atol=1e-12)
        # and the other way round: h(h⁻¹(z)) = z
        z = hm.h(pose, m)
        np.testing.assert_allclose(hm.h(pose, hm.inverse(pose, z)), z, rtol=0, atol=1e-12)


def test_range_bearing_follows_the_seed():
    z = models.range_bearing_h((1.0, 1.0, math.pi / 2), (4.0, 5.0))
    np.testing.assert_allclose(z, [5.0, math.atan2(4.0, 3.0) - math.pi / 2], atol=1e-15)
    # φ is wrapped to [−π, π)
    zs = models.range_bearing_h((0.0, 0.0, 3.0), [[-1.0, -0.1], [1.0, 0.0]])
    assert np.all(zs[:, 1] >= -math.pi) and np.all(zs[:, 1] < math.pi)
    np.testing.assert_allclose(zs[1], [1.0, -3.0], atol=1e-15)


def test_cartesian_is_the_landmark_in_the_robot_frame():
    # Robot at (1, 1) facing +y: a landmark 2 m ahead is at (2, 0) in its frame.
    np.testing.assert_allclose(
        models.cartesian_h((1.0, 1.0, math.pi / 2), (1.0, 3.0)), [2.0, 0.0], atol=1e-15
    )


@pytest.mark.parametrize("name", ["range_bearing", "cartesian"])
def test_vectorised_models_equal_one_at_a_time(name):
    hm = MEASUREMENT_MODELS[name]
    rng = np.random.default_rng(5)
    pose = random_pose(rng)
    m = np.stack([random_landmark(rng, pose) for _ in range(6)])
    z = hm.h(pose, m)
    Hx, Hm = hm.jacobians(pose, m)
    L, W = hm.inverse_jacobians(pose, z)
    assert z.shape == (6, 2) and Hx.shape == (6, 2, 3) and Hm.shape == (6, 2, 2)
    assert L.shape == (6, 2, 3) and W.shape == (6, 2, 2)
    for i in range(6):
        np.testing.assert_array_equal(z[i], hm.h(pose, m[i]))
        np.testing.assert_array_equal(Hx[i], hm.jacobians(pose, m[i])[0])
        np.testing.assert_array_equal(Hm[i], hm.jacobians(pose, m[i])[1])
        np.testing.assert_array_equal(L[i], hm.inverse_jacobians(pose, z[i])[0])
        np.testing.assert_array_equal(W[i], hm.inverse_jacobians(pose, z[i])[1])


@pytest.mark.parametrize("name", ["range_bearing", "cartesian"])
def test_scalar_linearise_equals_the_vectorised_model(name):
    hm = MEASUREMENT_MODELS[name]
    rng = np.random.default_rng(6)
    for _ in range(30):
        pose = random_pose(rng)
        m = random_landmark(rng, pose)
        zh0, zh1, row0, row1 = hm.linearise(*pose.tolist(), *m.tolist())
        Hx, Hm = hm.jacobians(pose, m)
        np.testing.assert_allclose([zh0, zh1], hm.h(pose, m), rtol=0, atol=1e-14)
        np.testing.assert_allclose(np.array([row0, row1]), np.hstack([Hx, Hm]), atol=1e-14)


def test_singular_geometry_is_flagged():
    pose = np.array([1.0, 2.0, 0.3])
    m = np.array([[1.0, 2.0], [1.5, 2.0]])
    np.testing.assert_array_equal(models.range_bearing_singular(pose, m), [True, False])
    np.testing.assert_array_equal(models.cartesian_singular(pose, m), [False, False])
    with pytest.raises(ZeroDivisionError):
        models.range_bearing_linearise(1.0, 2.0, 0.3, 1.0, 2.0)
