"""Robustness: reproducibility across processes and vector envs, bad input on the
wrapped env, fault injection, and a long soak run (marked slow)."""

from __future__ import annotations

import math
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import slam_env.envs.active_slam
import slam_env.envs.landmarks
from tests.streams import digest

ENV_ID = "slam_env/ActiveSLAM-v0"
SHORT = {"max_episode_steps": 40, "n_landmarks": 8}  # episodes end inside the test


def _vector_digest(mode: str, autoreset: str, steps: int = 120) -> str:
    envs = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode=mode,
        vector_kwargs={"autoreset_mode": AutoresetMode(autoreset)},
        **SHORT,
    )
    rng = np.random.default_rng(0)
    record = [envs.reset(seed=[3, 4])]
    for _ in range(steps):
        actions = rng.uniform(-1, 1, (2, 2)).astype(np.float32)
        record.append(envs.step(actions))
    envs.close()
    return digest(record)


@pytest.mark.parametrize("autoreset", ["NextStep", "SameStep"])
def test_sync_and_async_vector_envs_give_the_same_stream(autoreset):
    assert _vector_digest("sync", autoreset) == _vector_digest("async", autoreset)


def test_vector_stream_is_the_same_in_another_process():
    code = (
        "from tests.envs.test_robustness import _vector_digest\n"
        "print(_vector_digest('sync', 'NextStep'))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == _vector_digest("sync", "NextStep")


def test_vector_sub_env_matches_a_single_env():
    """Env i of a vector env seeded [s0, s1] runs exactly like a single env seeded s_i,
    episode after episode (autoreset continues each env's own random stream)."""
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1, 1, (100, 2, 2)).astype(np.float32)
    envs = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP},
        **SHORT,
    )
    vec_obs = [envs.reset(seed=[5, 6])[0]]
    vec_obs += [envs.step(a)[0] for a in actions]
    envs.close()
    for i, seed in enumerate((5, 6)):
        env = gym.make(ENV_ID, **SHORT)
        single = [env.reset(seed=seed)[0]]
        for a in actions[:, i]:
            obs, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:  # SAME_STEP: the reset observation replaces it
                obs, _ = env.reset()
            single.append(obs)
        np.testing.assert_array_equal(np.stack(single), np.stack([o[i] for o in vec_obs]))


def test_sb3_dummy_and_subproc_vec_envs_agree():
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    streams = []
    for cls in (DummyVecEnv, SubprocVecEnv):
        venv = make_vec_env(
            f"slam_env:{ENV_ID}", n_envs=2, seed=11, vec_env_cls=cls, env_kwargs=SHORT
        )
        rng = np.random.default_rng(2)
        record = [venv.reset()]
        for _ in range(90):
            obs, rewards, dones, _ = venv.step(rng.uniform(-1, 1, (2, 2)).astype(np.float32))
            # DummyVecEnv keeps rewards in float32, SubprocVecEnv in float64.
            record.append((obs, rewards.astype(np.float32), dones))
        venv.close()
        streams.append(digest(record))
    assert streams[0] == streams[1]


@pytest.mark.parametrize(
    "make",
    [slam_env.envs.landmarks.LandmarksEnv, slam_env.envs.active_slam.ActiveSLAMEnv],
    ids=["raw", "active"],
)
def test_step_before_reset_and_lifecycle_after_close(make):
    """As in Gymnasium's own envs: close releases the renderer and keeps the episode;
    step, reset and render (which reopens the renderer) work after it."""
    env = make(render_mode="rgb_array")
    with pytest.raises(gym.error.ResetNeeded):
        env.step(np.zeros(2))
    twin = make(render_mode="rgb_array")
    env.reset(seed=0)
    twin.reset(seed=0)
    first = env.render()
    raw = env.unwrapped
    assert raw._renderer is not None
    env.close()
    assert raw._renderer is None
    env.close()  # idempotent
    a = np.array([0.5, 0.1], dtype=np.float32)
    assert digest([env.step(a)]) == digest([twin.step(a)])
    assert env.render().shape == first.shape and raw._renderer is not None
    env.close()
    assert digest([env.reset(seed=4)]) == digest([twin.reset(seed=4)])
    assert digest([env.step(a)]) == digest([twin.step(a)])
    twin.close()
    env.close()


@pytest.mark.parametrize(
    ("action", "error"),
    [(np.array([np.nan, 0.0]), ValueError), (np.zeros(5), ValueError), ("go", TypeError)],
)
def test_bad_actions_on_the_wrapped_env_do_not_corrupt_it(action, error):
    env = gym.make(ENV_ID)
    twin = gym.make(ENV_ID)
    env.reset(seed=2)
    twin.reset(seed=2)
    with pytest.raises(error):
        env.unwrapped.step(action)
    a = np.array([0.5, 0.1], dtype=np.float32)
    assert digest([env.step(a) for _ in range(20)]) == digest([twin.step(a) for _ in range(20)])


def rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * 4096 / 2**20


@pytest.mark.slow
def test_soak_one_million_steps_no_nan_no_leak():
    """1,000,000 random steps across resets: every observation finite and inside the
    space, and the resident memory flat after the first episodes."""
    env = gym.make(ENV_ID)
    env.action_space.seed(0)
    actions = np.random.default_rng(0).uniform(-1, 1, (10_000, 2)).astype(np.float32)
    env.reset(seed=0)
    space = env.observation_space
    baseline = None
    for step in range(1_000_000):
        obs, reward, terminated, truncated, info = env.step(actions[step % 10_000])
        if step % 50 == 0:  # `contains` is slower than a step: sample it
            assert space.contains(obs)
        assert np.isfinite(obs).all() and math.isfinite(reward)
        assert not info["belief_clipped"]
        if terminated or truncated:
            env.reset()
        if step == 20_000:
            baseline = rss_mb()
    growth = rss_mb() - baseline
    print(f"soak: RSS {baseline:.1f} MiB after 40 episodes, growth {growth:+.1f} MiB after 2,000")
    assert growth < 20.0


@pytest.mark.slow
def test_soak_native_vector_env_one_million_env_steps_no_nan_no_leak():
    """The native vector env, 64 worlds × 15,625 steps (1,000,000 env-steps, each
    world through ~30 autoresets): observations finite and inside the space, rewards
    finite, no belief clipped, and the resident memory flat after the first episodes."""
    num_envs, steps = 64, 15_625
    envs = gym.make_vec(ENV_ID, num_envs=num_envs, vectorization_mode="vector_entry_point")
    actions = np.random.default_rng(0).uniform(-1, 1, (500, num_envs, 2)).astype(np.float32)
    envs.reset(seed=0)
    space = envs.observation_space
    baseline = None
    episodes = 0
    for step in range(steps):
        obs, rewards, terminated, truncated, info = envs.step(actions[step % 500])
        if step % 50 == 0:
            assert space.contains(obs)
        assert np.isfinite(obs).all() and np.isfinite(rewards).all()
        assert not np.any(info.get("belief_clipped", False))
        episodes += int(np.count_nonzero(terminated | truncated))
        if step == 4_000:  # the allocator settles over the first 8 episodes
            baseline = rss_mb()
    envs.close()
    growth = rss_mb() - baseline
    print(f"vector soak: {episodes} episodes, RSS growth {growth:+.1f} MiB after the first 8")
    assert episodes >= num_envs * (steps // 500 - 1)  # every world went through its resets
    assert growth < 20.0
