"""Fault injection: outliers, dropouts, odometry bias and kidnapping."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401
from slam_env.belief.metrics import nees_band
from slam_env.sensing.raw_observation import unpack_detections
from tests.belief.test_wrappers import _smooth_actions
from tests.streams import rollout_digest

RAW = "slam_env/Landmarks-v0"
ACTIVE = "slam_env/ActiveSLAM-v0"


def test_faults_off_leave_the_stream_unchanged():
    off = {"outlier_rate": 0.0, "scan_dropout": 0.0, "odometry_dropout": 0.0, "kidnap_rate": 0.0}
    assert rollout_digest(RAW, seed=3, steps=200, **off) == rollout_digest(RAW, seed=3, steps=200)
    assert rollout_digest(RAW, seed=3, steps=200, outlier_rate=0.5) != rollout_digest(
        RAW, seed=3, steps=200
    )


def test_scan_and_odometry_dropouts_happen_at_their_rate():
    env = gym.make(RAW, scan_dropout=0.3, odometry_dropout=0.2, fov=2 * math.pi, max_range=30.0)
    env.reset(seed=0)
    empty, zero_odometry, n = 0, 0, 2000
    for _ in range(n):
        obs, *_ = env.step(np.array([0.5, 0.3], dtype=np.float32))
        empty += not obs["mask"].any()  # an all-seeing sensor: empty only when dropped
        zero_odometry += not obs["odometry"].any()
    for count, rate in ((empty, 0.3), (zero_odometry, 0.2)):
        assert abs(count / n - rate) < 4 * math.sqrt(rate * (1 - rate) / n)


def test_odometry_bias_is_added_to_every_reading():
    bias = (0.0, 0.02, -0.01)
    env = gym.make(RAW, odometry_bias=bias, alphas=(0.0, 0.0, 0.0, 0.0))
    env.reset(seed=1)
    for _ in range(50):
        obs, *_, info = env.step(np.array([0.8, 0.4], dtype=np.float32))
        np.testing.assert_allclose(obs["odometry"], info["odometry_true"] + bias, atol=1e-6)


def test_spurious_detections_carry_ids_seen_before():
    env = gym.make(RAW, outlier_rate=1.0, fov=math.pi / 2)
    _, info = env.reset(seed=2)
    seen_before = info["seen"].copy()
    spurious = 0
    for _ in range(200):
        obs, *_, info = env.step(np.array([0.6, 0.2], dtype=np.float32))
        _, ids = unpack_detections(obs)
        assert np.all(np.diff(ids) > 0)  # still one detection per ID, sorted
        # A detection of a landmark the sensor cannot see from the true pose is spurious.
        x, y, th = info["pose"]
        truth = info["landmark_positions"][np.searchsorted(info["landmark_ids"], ids)]
        bearing = np.arctan2(truth[:, 1] - y, truth[:, 0] - x) - th
        bearing = (bearing + np.pi) % (2 * np.pi) - np.pi
        invisible = (np.hypot(truth[:, 0] - x, truth[:, 1] - y) > 5.0) | (
            np.abs(bearing) > math.pi / 4
        )
        assert seen_before[ids[invisible]].all()  # only IDs already in the map
        spurious += int(invisible.any())
        seen_before |= info["seen"]
    assert spurious > 100


def _consistency(runs: int, steps: int, **options) -> tuple[float, int]:
    nees = np.zeros((runs, steps))
    rejected = 0
    for run in range(runs):
        env = gym.make(ACTIVE, **options)
        env.reset(seed=2000 + run)
        for t, a in enumerate(_smooth_actions(np.random.default_rng(2000 + run), steps)):
            *_, info = env.step(a)
            nees[run, t] = info["pose_nees"]
        rejected += info["rejected"]
    lo, hi = nees_band(dof=3, runs=runs)
    average = nees.mean(axis=0)
    return float(np.mean((average >= lo) & (average <= hi))), rejected


def test_the_gate_rejects_outliers_and_the_filter_stays_consistent():
    inside, rejected = _consistency(30, 150, outlier_rate=0.2)
    assert rejected > 100
    assert inside >= 0.9
    # Without the gate the same outliers ruin the belief: the test can tell.
    inside_ungated, _ = _consistency(30, 150, outlier_rate=0.2, gate=None)
    assert inside_ungated < 0.5


def test_kidnapping_is_reported_as_divergence_not_nan():
    env = gym.make(ACTIVE, kidnap_rate=0.01)
    obs, _ = env.reset(seed=4)
    kidnapped = diverged_after = 0
    for a in _smooth_actions(np.random.default_rng(4), 1500):
        obs, reward, terminated, truncated, info = env.step(a)
        assert env.observation_space.contains(obs) and math.isfinite(reward)
        assert np.isfinite(info["entropy"])
        if info["kidnapped"]:
            kidnapped += 1
        elif kidnapped and info["diverged"]:
            diverged_after += 1
        if terminated or truncated:
            obs, _ = env.reset()
            kidnapped = 0
    assert diverged_after > 0


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"outlier_rate": 1.5}, "outlier_rate"),
        ({"kidnap_rate": -0.1}, "kidnap_rate"),
        ({"odometry_bias": (0.1, 0.2)}, "odometry_bias"),
        ({"scan_dropout": float("nan")}, "scan_dropout"),
    ],
)
def test_invalid_fault_options_raise(options, match):
    with pytest.raises(ValueError, match=match):
        gym.make(RAW, **options)
