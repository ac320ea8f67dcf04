"""Gymnasium's and stable-baselines3's env checkers, render check on, for both IDs and
option sets where no landmark may be seen for a while (one landmark, a short sensor
range): no NaN in info, so equal runs give equal infos; reset after close works."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import (
    check_env as gym_check_env,
)
from gymnasium.utils.env_checker import check_step_determinism
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import slam_env  # noqa: F401  (registers the env IDs)


def _objects(data, found: list) -> list:
    """Every container and array inside ``data`` (an observation or an info)."""
    if isinstance(data, (dict, list, tuple, np.ndarray)):
        found.append(data)
    if isinstance(data, dict):
        for value in data.values():
            _objects(value, found)
    elif isinstance(data, (list, tuple)):
        for value in data:
            _objects(value, found)
    return found


def _returned_data_not_reused(env: gym.Env, seed: int = 123) -> None:
    """That reset and step return fresh observations and infos (no container or array
    memory shared between two calls); gymnasium 1.2, which Ray RLlib pins, lacks
    gymnasium's own ``check_returned_data_not_reused``."""
    env.action_space.seed(seed)
    calls = [env.reset(seed=seed)]
    for _ in range(2):
        obs, _, terminated, truncated, info = env.step(env.action_space.sample())
        calls.append((obs, info))
        if terminated or truncated:
            break
    calls.append(env.reset(seed=seed))
    held = [_objects(call, []) for call in calls]
    for i, first in enumerate(held):
        for second in held[i + 1 :]:
            for a in first[1:]:  # the (obs, info) tuple itself is each call's own
                for b in second[1:]:
                    shared = a is b or (
                        isinstance(a, np.ndarray)
                        and isinstance(b, np.ndarray)
                        and np.shares_memory(a, b)
                    )
                    assert not shared, f"two calls returned a shared {type(a).__name__}"


try:
    from gymnasium.utils.env_checker import check_returned_data_not_reused
except ImportError:  # gymnasium < 1.3
    check_returned_data_not_reused = _returned_data_not_reused

RAW, ACTIVE = "slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0"
SPARSE = {"n_landmarks": 1, "max_range": 1.0}
CASES = [
    (RAW, {}),
    (RAW, SPARSE),
    (RAW, {**SPARSE, "preset": "open", "scan_beams": 8, "bumper": True, "max_detections": 3}),
    (ACTIVE, {}),
    (ACTIVE, SPARSE),
    (ACTIVE, {**SPARSE, "observation": "full", "fov": 0.5}),
    (ACTIVE, {"n_landmarks": 1, "max_range": 2.0, "motion_model": "velocity"}),
    (ACTIVE, {**SPARSE, "observation": "local"}),
    (ACTIVE, {"observation": "local", "preset": "rooms", "fov": 6.28}),
]


@pytest.mark.parametrize(("env_id", "options"), CASES)
def test_both_checkers_pass_with_the_render_check(env_id, options):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(env_id, render_mode="rgb_array", **options)
        gym_check_env(env.unwrapped, skip_render_check=False, skip_close_check=False)
        # The checkers seed with 123; the worlds and first steps of seeds 0-9 too.
        for seed in range(10):
            check_step_determinism(env.unwrapped, seed=seed)
            check_returned_data_not_reused(env.unwrapped, seed=seed)
        sb3_check_env(env.unwrapped, warn=True, skip_render_check=False)
        env.close()


def _nan_in(value) -> bool:
    if isinstance(value, float):
        return math.isnan(value)
    if isinstance(value, np.ndarray) and value.dtype.kind == "f":
        return bool(np.isnan(value).any())
    if isinstance(value, dict):
        return any(_nan_in(v) for v in value.values())
    return False


# One landmark, 3 m range: circling with CIRCLE, seed 1 finds it after ~50 steps, seed
# 4 at once, seed 2 not within 100 steps.
FEW = {"n_landmarks": 1, "max_range": 3.0}
CIRCLE = np.array([1.0, 0.3], dtype=np.float32)


def test_map_rmse_is_absent_until_a_landmark_is_known():
    env = gym.make(ACTIVE, **FEW)
    _, info = env.reset(seed=1)
    known_seen = unknown_seen = False
    for _ in range(100):
        assert not _nan_in(info)
        if info["landmarks_known"]:
            known_seen = True
            assert info["map_rmse"] >= 0.0
        else:
            unknown_seen = True
            assert "map_rmse" not in info
        _, _, _, _, info = env.step(CIRCLE)
    assert known_seen and unknown_seen


def test_vector_envs_mask_map_rmse_where_a_sub_env_has_no_landmark_yet():
    """Gymnasium's vector info convention: ``_map_rmse`` marks the sub-envs that
    reported it, which are exactly those with a landmark in the belief."""
    envs = gym.make_vec(ACTIVE, num_envs=3, vectorization_mode="sync", **FEW)
    _, info = envs.reset(seed=[1, 2, 4])
    masks = []
    for _ in range(100):
        _, _, _, _, info = envs.step(np.stack([CIRCLE] * 3))
        known = info["landmarks_known"] > 0
        mask = info.get("_map_rmse", np.zeros(3, bool))
        np.testing.assert_array_equal(mask, known)
        assert np.isfinite(info.get("map_rmse", np.zeros(3))).all()
        masks.append(mask)
    masks = np.array(masks)
    assert masks[:, 2].all() and not masks[:, 1].any()
    assert not masks[0, 0] and masks[-1, 0]  # sub-env 0 finds its landmark on the way
    envs.close()
