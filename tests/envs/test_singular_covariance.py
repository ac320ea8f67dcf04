"""A pose covariance that is singular (or beyond float64's resolution) never puts a
non-finite value into ``info`` or the observation: its NEES is undefined, and absent
like every undefined metric (issue #48, item 3: the velocity model's first step, zero
alphas, sensor noise of 1e-150)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.config import OdometryConfig
from slam_env.envs.landmarks import LandmarksEnv

ACTIVE = "slam_env/ActiveSLAM-v0"
FORWARD = np.array([0.8, 0.0], dtype=np.float32)  # straight: no turn, no heading noise
SINGULAR = {
    "velocity": {"motion_model": "velocity"},
    "velocity-no-noise": {"motion_model": "velocity", "velocity_noise": (0.0, 0.0, 0.0, 0.0)},
    "zero-alphas": {"alphas": (0.0, 0.0, 0.0, 0.0)},
    "tiny-sensor-noise": {"range_std": 1e-150, "bearing_std": 1e-150, "alphas": (0.0,) * 4},
}


def _numbers(value, where="info"):
    """(where, number) of every float in a nested info or observation."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _numbers(item, f"{where}[{key!r}]")
    elif isinstance(value, np.ndarray) and value.dtype.kind == "f":
        for item in value.ravel().tolist():
            yield where, item
    elif isinstance(value, float):
        yield where, value


def _assert_finite(obs, info) -> None:
    for where, number in (*_numbers(obs, "obs"), *_numbers(info)):
        assert math.isfinite(number), f"{where} = {number}"
    nees = info.get("pose_nees")
    assert nees is None or nees >= 0.0


@pytest.mark.parametrize("options", SINGULAR.values(), ids=SINGULAR)
@pytest.mark.parametrize("observation", ["egocentric", "full"])
def test_no_non_finite_value_in_info_or_observation(options, observation) -> None:
    env = gym.make(ACTIVE, observation=observation, max_range=8.0, fov=6.28, **options)
    obs, info = env.reset(seed=3)
    _assert_finite(obs, info)
    for _ in range(20):
        obs, _, _, _, info = env.step(FORWARD)
        _assert_finite(obs, info)
    env.close()


@pytest.mark.parametrize("options", SINGULAR.values(), ids=SINGULAR)
def test_the_vector_env_masks_an_undefined_nees(options) -> None:
    venv = gym.make_vec(ACTIVE, num_envs=2, vectorization_mode="vector_entry_point", **options)
    venv.reset(seed=3)
    for _ in range(5):
        _, _, _, _, info = venv.step(np.tile(FORWARD, (2, 1)))
        if "pose_nees" not in info:
            continue  # as Gymnasium leaves out a key no sub-env reports
        nees, defined = info["pose_nees"], info["_pose_nees"]
        assert np.isfinite(nees).all()
        assert (nees[~defined] == 0.0).all()  # Gymnasium's value where a sub-env has none
    venv.close()


@pytest.mark.parametrize("options", SINGULAR.values(), ids=SINGULAR)
def test_the_wrapper_over_the_raw_env_leaves_an_undefined_nees_out(options) -> None:
    env = EKFSLAMWrapper(LandmarksEnv(max_range=8.0, fov=6.28, **options))
    obs, info = env.reset(seed=3)
    _assert_finite(obs, info)
    for _ in range(20):
        obs, _, _, _, info = env.step(FORWARD)
        _assert_finite(obs, info)


def test_the_velocity_model_has_control_noise_by_default() -> None:
    sigma_p, sigma_theta, beta_p, _ = OdometryConfig().velocity_noise
    assert sigma_p > 0.0 and sigma_theta > 0.0
    # Near the odometry model's default noise on a straight step at the default speed.
    step = 1.0 * 0.2  # max_speed · dt, m
    _, a2, a3, _ = OdometryConfig().alphas
    along = math.sqrt(sigma_p**2 + beta_p * step**2)
    assert along == pytest.approx(math.sqrt(a3) * step, rel=0.15)
    assert sigma_theta == pytest.approx(math.sqrt(2 * a2) * step, rel=0.25)
