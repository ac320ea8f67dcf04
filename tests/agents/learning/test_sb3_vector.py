"""The SB3 adapter of the native vector envs, against SB3's own DummyVecEnv."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

from agents.common.info_rows import InfoRow
from agents.learning.sb3.vector_env import SB3VectorEnv, make_sb3_vec_env
from tests.streams import assert_same

ENV_ID = "slam_env/Landmarks-v0"


def _plain(info: Any) -> Any:
    if isinstance(info, dict | InfoRow):
        return {k: _plain(v) for k, v in info.items()}
    if isinstance(info, list):
        return [_plain(v) for v in info]
    return info


@pytest.mark.parametrize("options", [{}, {"action_type": "discrete", "scan_beams": 4}])
def test_rollouts_equal_dummy_vec_env_for_the_same_seeds(options: dict) -> None:
    n, episode = 3, 40
    ours = make_sb3_vec_env(ENV_ID, n_envs=n, seed=7, max_episode_steps=episode, **options)
    dummy = DummyVecEnv(
        [lambda: gym.make(ENV_ID, max_episode_steps=episode, **options) for _ in range(n)]
    )
    dummy.seed(7)
    assert_same(ours.reset(), dummy.reset(), "reset")
    assert_same(_plain(ours.reset_infos), _plain(dummy.reset_infos), "reset infos")
    dummy.action_space.seed(1)
    finished = 0
    for t in range(130):
        actions = np.stack([dummy.action_space.sample() for _ in range(n)])
        a = ours.step(actions)
        b = dummy.step(actions)
        assert_same(a[0], b[0], f"obs {t}")
        assert a[1].dtype == b[1].dtype and np.array_equal(a[1], b[1]), t
        assert np.array_equal(a[2], b[2]), t
        for i in range(n):
            assert_same(_plain(a[3][i]), _plain(b[3][i]), f"info {t} {i}")
        assert_same(_plain(ours.reset_infos), _plain(dummy.reset_infos), f"reset infos {t}")
        finished += int(a[2].sum())
    assert finished == 3 * n  # every env crossed three resets, truncated
    assert ours.step(actions)[3][0]["TimeLimit.truncated"] is False


def test_info_rows_read_lazily_and_copy_to_plain_dicts() -> None:
    venv = make_sb3_vec_env(ENV_ID, n_envs=2, seed=0)
    venv.reset()
    _, _, _, infos = venv.step(np.zeros((2, 2), dtype=np.float32))
    row = infos[1]
    assert set(row) >= {"pose", "seen", "reward_terms", "TimeLimit.truncated"}
    pose = row["pose"]
    pose[0] = 1e9  # a fresh array: the vector info is untouched
    assert row["pose"][0] != 1e9
    row["episode"] = {"r": 1.0}
    plain = row.copy()
    assert type(plain) is dict and plain["episode"] == {"r": 1.0}
    del row["seen"]
    assert "seen" not in row
    with pytest.raises(KeyError):
        row["no such key"]


def test_info_rows_get_as_their_plain_dicts_do() -> None:
    venv = make_sb3_vec_env(ENV_ID, n_envs=2, seed=0)
    venv.reset()
    _, _, _, infos = venv.step(np.zeros((2, 2), dtype=np.float32))
    row = infos[0]
    row["episode"] = {"r": 2.0}  # written: the row's own
    del row["collision"]  # deleted: gone, though the vector info has it
    plain = row.copy()
    assert len(row) == len(plain) and "episode" in plain and "collision" not in plain
    for key in [*plain, "collision", "_pose", "no such key", "terminal_observation"]:
        assert _same(row.get(key, "default"), plain.get(key, "default")), key
    assert row.get("no such key") is None


def _same(a, b) -> bool:
    if isinstance(a, dict) or isinstance(b, dict):
        return type(a) is type(b) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b


def test_ppo_learns_on_the_native_vector_env() -> None:
    venv = VecMonitor(make_sb3_vec_env(ENV_ID, n_envs=4, seed=0, max_episode_steps=20))
    model = PPO("MultiInputPolicy", venv, n_steps=16, batch_size=32, n_epochs=1, seed=0)
    model.learn(128)
    assert model.num_timesteps == 128
    assert len(model.ep_info_buffer) >= 4  # VecMonitor saw the episodes end


def test_only_same_step_vector_envs_are_adapted() -> None:
    with pytest.raises(ValueError, match="SAME_STEP"):
        SB3VectorEnv(gym.make_vec(ENV_ID, num_envs=2))


def test_the_training_reports_the_threads_that_step_its_sub_envs():
    from stable_baselines3.common.vec_env import VecMonitor

    from agents.learning.runs import sampler_threads
    from agents.learning.sb3.vector_env import make_sb3_vec_env

    venv = VecMonitor(make_sb3_vec_env("slam_env/Landmarks-v0", 3, seed=0, num_threads=2))
    try:
        assert sampler_threads("native", 3, venv) == 2
    finally:
        venv.close()
    assert sampler_threads("subproc", 6, object()) == 6  # a process a sub-env
    assert sampler_threads("dummy", 6, object()) == 1
