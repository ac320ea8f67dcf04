"""The belief wrapper's ``diverged`` flag on scripted detections (issue 17).

The robot stands still at its start pose, so the filter's belief stays put, and each
step hands the filter chosen detections: a landmark's exact range and bearing (a
correction the gate accepts) or its range 3 m too long (60σ: rejected).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.envs.landmarks import LandmarksEnv
from slam_env.kernels.belief.divergence import DIVERGENCE_REJECTIONS

LAYOUT = {
    "width": 10.0,
    "height": 8.0,
    "landmarks": [
        {"id": 0, "x": 3.0, "y": 4.0},
        {"id": 1, "x": 4.0, "y": 5.5},
        {"id": 2, "x": 4.5, "y": 3.0},
    ],
    "start": [1.0, 4.0, 0.0],
}
GOOD, BAD = 0.0, 3.0  # range offsets, m


class ScriptedDetections(gym.Wrapper):
    """Holds the robot still and replaces each observation's detections with
    ``script[t]``: (landmark ID, range offset) pairs, measured from the true pose."""

    def __init__(self, env: LandmarksEnv, script: list[list[tuple[int, float]]]) -> None:
        super().__init__(env)
        self.script = script

    def reset(self, **kwargs: Any):
        obs, info = self.env.reset(**kwargs)
        self.t = 0
        return self._scripted(obs, info), info

    def step(self, action: Any):
        obs, reward, terminated, truncated, info = self.env.step(np.zeros(2, np.float32))
        self.t += 1
        return self._scripted(obs, info), reward, terminated, truncated, info

    def _scripted(self, obs: dict[str, np.ndarray], info: dict[str, Any]):
        x, y, theta = info["pose"]
        truth = dict(zip(info["landmark_ids"].tolist(), info["landmark_positions"], strict=True))
        obs = {k: v.copy() for k, v in obs.items()}
        obs["odometry"][:] = 0.0
        obs["detections"][:] = 0.0
        obs["ids"][:] = -1.0
        obs["mask"][:] = 0.0
        for row, (lid, offset) in enumerate(self.script[self.t]):
            mx, my = truth[lid]
            r = math.hypot(mx - x, my - y) + offset
            phi = math.atan2(my - y, mx - x) - theta
            obs["detections"][2 * row : 2 * row + 2] = (r, phi)
            obs["ids"][row] = lid
            obs["mask"][row] = 1.0
        return obs


def run(script: list[list[tuple[int, float]]]) -> list[dict[str, Any]]:
    """The wrapper's infos from reset through every scripted step."""
    env = EKFSLAMWrapper(ScriptedDetections(LandmarksEnv(layout=LAYOUT), script))
    _, info = env.reset(seed=0)
    infos = [info]
    for _ in script[1:]:
        infos.append(env.step(np.zeros(2, np.float32))[-1])
    return infos


def test_the_threshold_is_ten_rejections_in_a_row():
    assert DIVERGENCE_REJECTIONS == 10


def test_diverged_on_exactly_the_tenth_rejection_in_a_row_and_reset_by_a_correction():
    script = [[(0, GOOD)]] + [[(0, BAD)]] * 10 + [[(0, GOOD)], [(0, BAD)]]
    infos = run(script)
    counts = [info["consecutive_rejections"] for info in infos]
    assert counts == [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 0, 1]
    assert [info["diverged"] for info in infos] == [False] * 10 + [True, False, False]
    assert [info["rejected"] for info in infos] == [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 10, 11]
    assert not any(info["belief_clipped"] for info in infos)


def test_rejections_count_per_observation_in_the_order_given():
    start = [[(0, GOOD), (1, GOOD)]]
    # Four steps of two rejections each, then one more pair: 8, then 10 in a row.
    infos = run(start + [[(0, BAD), (1, BAD)]] * 5 + [[(0, BAD), (1, GOOD)], [(1, GOOD), (0, BAD)]])
    counts = [info["consecutive_rejections"] for info in infos]
    assert counts == [0, 2, 4, 6, 8, 10, 0, 1]
    assert [info["diverged"] for info in infos] == [False] * 5 + [True, False, False]


def test_neither_silence_nor_a_new_landmark_resets_the_count():
    script = [[(0, GOOD)]] + [[(0, BAD)]] * 8 + [[], [(2, GOOD)], [(0, BAD)]]
    infos = run(script)
    assert [info["consecutive_rejections"] for info in infos][-4:] == [8, 8, 8, 9]
    assert infos[-2]["landmarks_known"] == 2  # landmark 2 was initialised
    assert not any(info["diverged"] for info in infos)
    infos = run([*script, [(0, BAD)]])
    assert infos[-1]["consecutive_rejections"] == 10 and infos[-1]["diverged"]


def test_reset_clears_the_count():
    env = EKFSLAMWrapper(
        ScriptedDetections(LandmarksEnv(layout=LAYOUT), [[(0, GOOD)]] + [[(0, BAD)]] * 12)
    )
    env.reset(seed=0)
    for _ in range(12):
        info = env.step(np.zeros(2, np.float32))[-1]
    assert info["diverged"] and info["consecutive_rejections"] == 12
    _, info = env.reset(seed=0)
    assert info["consecutive_rejections"] == 0 and not info["diverged"] and info["rejected"] == 0


def test_a_numerical_failure_sets_diverged_until_the_next_reset(monkeypatch):
    script = [[(0, GOOD)]] + [[(0, GOOD)]] * 4
    env = EKFSLAMWrapper(ScriptedDetections(LandmarksEnv(layout=LAYOUT), script))
    _, info = env.reset(seed=0)
    assert not info["diverged"]
    mean_before = env.filter.mean

    def breaks(z, ids):
        raise FloatingPointError("the state covariance is no longer positive semi-definite")

    with monkeypatch.context() as patch:
        patch.setattr(env.filter, "update", breaks)
        info = env.step(np.zeros(2, np.float32))[-1]
    assert info["diverged"] and info["consecutive_rejections"] == 0
    assert not info["belief_clipped"]
    np.testing.assert_array_equal(env.filter.mean, mean_before)  # nothing applied
    info = env.step(np.zeros(2, np.float32))[-1]  # the update works again: still diverged
    assert info["diverged"]
    _, info = env.reset(seed=0)
    assert not info["diverged"]


@pytest.mark.parametrize("observation", ["egocentric", "full"])
def test_a_belief_outside_the_observation_bounds_is_diverged(observation):
    # A new landmark initialised 10⁶ m away: the belief leaves its bounds.
    script = [[(0, GOOD)], [(1, 1e6)], [(0, GOOD)]]
    env = EKFSLAMWrapper(ScriptedDetections(LandmarksEnv(layout=LAYOUT), script), observation)
    env.reset(seed=0)
    obs, _, _, _, info = env.step(np.zeros(2, np.float32))
    assert info["belief_clipped"] and info["diverged"]
    assert info["consecutive_rejections"] == 0
    assert env.observation_space.contains(obs)
