"""Tests for slam_env.sensing.landmark_sensor.OdometrySensor: the true control recovers the driven
path, the noise against the α-model (odometry) and σu (velocity) with the statistics
of tests/sensing/sensor_references.py, wrapping, determinism, and the draws bit for bit."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from slam_env.config import OdometryConfig, SensorConfig
from slam_env.sensing.odometry_sensor import OdometrySensor
from slam_env.world.frames import wrap_angle
from tests.sensing.sensor_references import assert_gaussian_errors, box_muller, ref_wrap

PI = math.pi
RNG = np.random.default_rng


# ---------------------------------------------------------------- references


def ref_odometry_cov(u, a):
    r1, t, r2 = u
    return np.diag(
        [
            a[0] * r1**2 + a[1] * t**2,
            a[2] * t**2 + a[3] * (r1**2 + r2**2),
            a[0] * r2**2 + a[1] * t**2,
        ]
    )


def ref_velocity_cov(u, noise):
    sp, sth, bp, bth = noise
    return np.diag([sp**2 + bp * u[0] ** 2, sth**2 + bth * u[1] ** 2])


def apply_odometry(pose, u):
    """g of seed 000: rotate δrot1, translate δtr, rotate δrot2."""
    x, y, th = pose
    r1, t, r2 = u
    return (x + t * math.cos(th + r1), y + t * math.sin(th + r1), th + r1 + r2)


def apply_velocity(pose, u):
    """f of seed 004: translate Δp along the heading, then rotate Δθ."""
    x, y, th = pose
    dp, dth = u
    return (x + dp * math.cos(th), y + dp * math.sin(th), th + dth)


# ---------------------------------------------------------------- determinism


def test_same_seed_same_odometry():
    for model in ("odometry", "velocity"):
        sensor = OdometrySensor(OdometryConfig(motion_model=model))
        poses = [(0.1 * t, 0.05 * t * t, 0.2 * t) for t in range(20)]
        r1, r2, r3 = RNG(17), RNG(17), RNG(18)
        a = [sensor.measure(p0, p1, r1) for p0, p1 in itertools.pairwise(poses)]
        b = [sensor.measure(p0, p1, r2) for p0, p1 in itertools.pairwise(poses)]
        c = [sensor.measure(p0, p1, r3) for p0, p1 in itertools.pairwise(poses)]
        assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
        assert not all(np.array_equal(x, y) for x, y in zip(a, c, strict=True))


# ---------------------------------------------------------------- odometry

ODOMETRY_PATH = [  # (name, true control (δrot1, δtr, δrot2))
    ("straight", (0.0, 0.5, 0.0)),
    ("turning", (0.2, 0.4, 0.3)),
    ("reversing", (0.0, -0.3, 0.0)),
    ("in_place_turn", (0.0, 0.0, 1.2)),
    ("reverse_turning", (-0.1, -0.4, 0.25)),
    ("half_turn", (0.0, 0.0, 3.0)),  # noise makes δrot2 cross ±π
]

VELOCITY_PATH = [  # (name, true control (Δp, Δθ))
    ("straight", (0.5, 0.0)),
    ("turning", (0.3, 0.4)),
    ("reversing", (-0.3, 0.0)),
    ("in_place_turn", (0.0, -1.0)),
    ("standing", (0.0, 0.0)),
]


def _path(start, controls, apply):
    poses = [start]
    for _, u in controls:
        poses.append(apply(poses[-1], u))
    return poses


def test_odometry_true_control_recovers_the_driven_path():
    sensor = OdometrySensor(OdometryConfig(motion_model="odometry"))
    assert sensor.dim == 3
    poses = _path((1.0, -2.0, 2.8), ODOMETRY_PATH, apply_odometry)
    for (name, u), p0, p1 in zip(ODOMETRY_PATH, poses[:-1], poses[1:], strict=True):
        got = sensor.true_control(p0, p1)
        assert got.shape == (3,) and got.dtype == np.float64
        assert np.allclose(got, u, atol=1e-12), name
        assert np.allclose(apply_odometry(p0, got)[:2], p1[:2], atol=1e-12)


def test_velocity_true_control_recovers_the_driven_path():
    sensor = OdometrySensor(OdometryConfig(motion_model="velocity"))
    assert sensor.dim == 2
    poses = _path((1.0, -2.0, -2.8), VELOCITY_PATH, apply_velocity)
    for (name, u), p0, p1 in zip(VELOCITY_PATH, poses[:-1], poses[1:], strict=True):
        got = sensor.true_control(p0, p1)
        assert got.shape == (2,) and got.dtype == np.float64
        assert np.allclose(got, u, atol=1e-12), name


ALPHAS = (0.05, 0.01, 0.03, 0.02)


@pytest.mark.parametrize("segment", range(len(ODOMETRY_PATH)), ids=[n for n, _ in ODOMETRY_PATH])
def test_odometry_noise_matches_alpha_model(segment):
    sensor = OdometrySensor(OdometryConfig(motion_model="odometry", alphas=ALPHAS))
    assert sensor.alphas == ALPHAS
    poses = _path((1.0, -2.0, 2.8), ODOMETRY_PATH, apply_odometry)
    p0, p1 = poses[segment], poses[segment + 1]
    u = sensor.true_control(p0, p1)
    m = ref_odometry_cov(u, ALPHAS)
    assert np.allclose(sensor.noise_cov(u), m, rtol=1e-14, atol=0)
    rng = RNG(100 + segment)
    n = 20000
    draws = np.array([sensor.measure(p0, p1, rng) for _ in range(n)])
    assert np.all(draws[:, [0, 2]] >= -PI) and np.all(draws[:, [0, 2]] < PI)
    err = draws - u
    err[:, 0] = ref_wrap(err[:, 0])
    err[:, 2] = ref_wrap(err[:, 2])
    assert_gaussian_errors(err, m, f"odometry/{ODOMETRY_PATH[segment][0]}")


def test_odometry_half_turn_wraps_delta_rot2():
    sensor = OdometrySensor(OdometryConfig(motion_model="odometry", alphas=ALPHAS))
    rng = RNG(19)
    draws = np.array([sensor.measure((0, 0, 0), (0, 0, 3.0), rng) for _ in range(2000)])
    # σ(δrot2) = √(α1·9) ≈ 0.67 rad: a good share of readings cross π and wrap negative
    assert np.mean(draws[:, 2] < 0) > 0.2
    assert np.all(draws[:, 2] >= -PI) and np.all(draws[:, 2] < PI)


VELOCITY_NOISE = (0.01, 0.005, 0.02, 0.03)


@pytest.mark.parametrize("segment", range(len(VELOCITY_PATH)), ids=[n for n, _ in VELOCITY_PATH])
def test_velocity_noise_matches_sigma_u(segment):
    sensor = OdometrySensor(OdometryConfig(motion_model="velocity", velocity_noise=VELOCITY_NOISE))
    assert sensor.velocity_noise == VELOCITY_NOISE
    poses = _path((1.0, -2.0, -2.8), VELOCITY_PATH, apply_velocity)
    p0, p1 = poses[segment], poses[segment + 1]
    u = sensor.true_control(p0, p1)
    su = ref_velocity_cov(u, VELOCITY_NOISE)
    assert np.allclose(sensor.noise_cov(u), su, rtol=1e-14, atol=0)
    rng = RNG(200 + segment)
    n = 20000
    draws = np.array([sensor.measure(p0, p1, rng) for _ in range(n)])
    err = draws - u
    err[:, 1] = ref_wrap(err[:, 1])
    assert_gaussian_errors(err, su, f"velocity/{VELOCITY_PATH[segment][0]}")


def test_noise_free_odometry_is_exact_and_perturb_checks_shape():
    for model, cfg in (
        ("odometry", OdometryConfig(motion_model="odometry", alphas=(0.0, 0.0, 0.0, 0.0))),
        ("velocity", OdometryConfig(motion_model="velocity", velocity_noise=(0.0, 0.0, 0.0, 0.0))),
    ):
        sensor = OdometrySensor(cfg)
        p0, p1 = (0.3, -0.2, 1.0), (0.7, 0.1, 1.4)
        assert np.array_equal(sensor.measure(p0, p1, RNG(0)), sensor.true_control(p0, p1)), model
        with pytest.raises(ValueError):
            sensor.perturb(np.zeros(sensor.dim + 1), RNG(0))


# ---------------------------------------------------------------- the draws


@pytest.mark.parametrize("model", ["odometry", "velocity"])
def test_perturb_is_bitwise_its_documented_formula(model):
    sensor = OdometrySensor(OdometryConfig(motion_model=model))
    rng = RNG(303)
    for t in range(500):
        u = rng.normal(0.0, [1.0, 0.5, 3.0][: sensor.dim]) * rng.choice([0.0, 1e-3, 1.0])
        r1, r2 = RNG(t), RNG(t)
        out = sensor.perturb(u, r1)
        w = r2.random(4 if model == "odometry" else 2).tolist()
        e = (
            [*box_muller(w[0], w[1]), *box_muller(*w[2:])]
            if model == "odometry"
            else [*box_muller(w[0], w[1])]
        )
        std = np.sqrt(np.diagonal(sensor.noise_cov(u))).tolist()
        expected = [ui + si * ei for ui, si, ei in zip(u.tolist(), std, e, strict=False)]
        for i in sensor.angle_indices:
            expected[i] = wrap_angle(expected[i])
        assert out.dtype == np.float64 and out.tolist() == expected


def test_a_landmark_sensor_config_is_refused():
    with pytest.raises(TypeError):
        OdometrySensor(SensorConfig())  # type: ignore[arg-type]
