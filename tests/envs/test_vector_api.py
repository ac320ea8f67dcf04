"""Gymnasium's vector API on the native vector envs of both IDs, checked as Gymnasium's
own env test suite checks its envs (``tests/envs/test_envs.py``): the frames of the
single env and the render modes."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.envs.vector import SlamVectorEnv

LANDMARKS = "slam_env/Landmarks-v0"
ACTIVE = "slam_env/ActiveSLAM-v0"
IDS = [LANDMARKS, ACTIVE]


def native(env_id: str, num_envs: int, **kwargs: Any) -> SlamVectorEnv:
    return gym.make_vec(
        env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs
    )


# ---------------------------------------------------------------------- render
@pytest.mark.parametrize("env_id", IDS)
def test_a_sub_env_frame_is_the_single_env_frame(env_id: str) -> None:
    """Pixel for pixel, for the frames of 150 steps that cross an episode end (the
    step counter, the live figures, the estimated path, the occluded wedge)."""
    b, seed, episode = 2, 3, 100
    venv = native(env_id, b, render_mode="rgb_array", max_episode_steps=episode)
    singles = [gym.make(env_id, render_mode="rgb_array", max_episode_steps=episode)]
    singles.append(gym.make(env_id, render_mode="rgb_array", max_episode_steps=episode))
    venv.reset(seed=seed)
    for i, env in enumerate(singles):
        env.reset(seed=seed + i)
    venv.action_space.seed(seed)
    done = [False] * b
    checked = 0
    for t in range(151):
        if t:
            actions = venv.action_space.sample()
            venv.step(actions)
            for i, env in enumerate(singles):
                if done[i]:
                    env.reset()
                    done[i] = False
                else:
                    _, _, terminated, truncated, _ = env.step(actions[i])
                    done[i] = terminated or truncated
        if t in (0, 1, 60, episode, episode + 1, 150):
            frames = venv.render()
            assert isinstance(frames, tuple) and len(frames) == b
            for i, env in enumerate(singles):
                np.testing.assert_array_equal(frames[i], env.render(), f"t={t} sub-env {i}")
            checked += 1
    assert checked == 6


def _check_rendered(frame: Any) -> None:
    assert isinstance(frame, np.ndarray) and frame.dtype == np.uint8
    assert frame.ndim == 3 and frame.shape[2] == 3


@pytest.mark.parametrize("env_id", IDS)
def test_every_render_mode(env_id: str) -> None:
    """As Gymnasium's test_render_modes: each declared mode renders after the reset
    and after a step (``"human"`` into a window, returning None); the vector env
    returns a frame per sub-env, and None (with a warning) without a render mode."""
    for mode in gym.make(env_id).metadata["render_modes"]:
        env = gym.make(env_id, render_mode=mode)
        env.reset(seed=0)
        for _ in range(2):
            rendered = env.render()
            if mode == "human":
                assert rendered is None
            else:
                _check_rendered(rendered)
            env.step(env.action_space.sample())
        env.close()
    assert native(env_id, 2).metadata["render_modes"] == ["rgb_array"]
    venv = native(env_id, 2, render_mode="rgb_array")
    with pytest.raises(ResetNeeded):
        venv.render()
    venv.reset(seed=0)
    for _ in range(2):
        frames = venv.render()
        assert isinstance(frames, tuple) and len(frames) == 2
        for frame in frames:
            _check_rendered(frame)
        venv.step(venv.action_space.sample())
    venv.close()
    assert len(venv.render()) == 2  # as the single env: close releases, render reopens
    plain = native(env_id, 2)
    plain.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert plain.render() is None
    with pytest.raises(ValueError, match="render_mode"):
        native(env_id, 2, render_mode="human")
