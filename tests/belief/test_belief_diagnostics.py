"""The belief wrapper's per-step diagnostics against the truth, recomputed here from
the filter's belief with numpy (issue 17)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.envs.landmarks import LandmarksEnv

ENV_ID = "slam_env/ActiveSLAM-v0"


def expected_diagnostics(f, info) -> dict[str, float]:
    mean, cov = f.mean, f.cov
    tx, ty, tth = info["pose"]
    dx, dy = mean[0] - tx, mean[1] - ty
    dth = math.remainder(mean[2] - tth, 2 * math.pi)
    err = np.array([dx, dy, dth])
    nees = 0.0 if not err.any() else float(err @ np.linalg.solve(cov[:3, :3], err))
    out = {
        "pose_error": math.sqrt(dx * dx + dy * dy),
        "heading_error": abs(dth),
        "pose_nees": nees,
        "pose_std": math.sqrt(cov[0, 0] + cov[1, 1]),
        "landmarks_known": len(f.state_to_id),
    }
    truth = dict(zip(info["landmark_ids"].tolist(), info["landmark_positions"], strict=True))
    if f.n_landmarks:
        true_map = np.array([truth[i] for i in f.state_to_id.tolist()])
        squared = np.sum((f.landmark_means() - true_map) ** 2, axis=1)
        out["map_rmse"] = math.sqrt(squared.mean())
    return out


@pytest.mark.parametrize(
    "options",
    [{}, {"motion_model": "velocity", "measurement_model": "cartesian", "correction": "batch"}],
)
def test_diagnostics_along_a_run(options):
    env = gym.make(ENV_ID, **options)
    _, info = env.reset(seed=8)
    truth_info = dict(info)
    f = env.unwrapped.filter
    rng = np.random.default_rng(8)
    seen_landmarks = False
    for step in range(120):
        expected = expected_diagnostics(f, truth_info)
        # Two ways of solving with a near-singular pose covariance (a start pose known
        # exactly, one step of the velocity model) agree only as well as it is conditioned.
        conditioning = np.linalg.cond(f.cov[:3, :3])
        for key, value in expected.items():
            if key == "pose_nees" and conditioning > 1e12:
                # Singular to working precision: the NEES is undefined (absent), or a
                # huge positive value from round-off.
                assert key not in info or 0.0 <= info[key] < math.inf, (step, info[key])
                continue
            rel = 1e-12 * conditioning if key == "pose_nees" else 1e-9
            assert info[key] == pytest.approx(value, rel=max(rel, 1e-9), abs=1e-12), (step, key)
        if "map_rmse" not in expected:
            assert "map_rmse" not in info  # undefined before the first landmark: absent
        else:
            seen_landmarks = True
        assert info["rejected"] == f.n_rejected
        action = np.array([0.9, rng.uniform(-0.7, 0.7)], np.float32)
        _, _, terminated, truncated, info = env.step(action)
        truth_info = info
        assert not (terminated or truncated)
    assert seen_landmarks and info["pose_error"] > 0.01 and info["heading_error"] > 1e-4


def test_heading_error_is_the_wrapped_difference():
    """A belief heading of +179° against a true −179° is 2° off, not 358°."""
    env = gym.make(
        ENV_ID,
        layout={
            "width": 10.0,
            "height": 10.0,
            "landmarks": [{"id": 0, "x": 5.0, "y": 5.0}],
            "start": [2.0, 2.0, math.radians(-179.0)],
        },
    )
    env.reset(seed=0)
    f = env.unwrapped.filter
    f.reset(initial_pose=(2.0, 2.0, math.radians(179.0)))
    *_, info = env.step(np.zeros(2, np.float32))
    assert info["heading_error"] == pytest.approx(math.radians(2.0), rel=1e-6)


def test_a_position_variance_below_zero_from_round_off_reads_as_zero():
    """A start pose covariance a hair below zero (within the filter's round-off
    allowance) gives pose_std 0, not NaN."""
    env = EKFSLAMWrapper(
        LandmarksEnv(n_landmarks=3), initial_pose_cov=np.diag([-1e-13, -1e-13, 0.0])
    )
    _, info = env.reset(seed=0)
    assert env.filter.pose_cov[0, 0] + env.filter.pose_cov[1, 1] < 0.0
    assert info["pose_std"] == 0.0
