"""JCBB's search grows with the square of the pairings a scan can have: a scan or an
env that could need more than ``MAX_PAIRINGS`` is refused at once, naming the options,
and the kernel never pairs more (issue #48, item 1: a ring of 1,000 landmarks in view,
IDs hidden, took over 70 s a step)."""

from __future__ import annotations

import math
import time

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.ekf import EKFSLAM
from slam_env.ekf.models import MEASUREMENT_MODELS
from slam_env.kernels.ekf.association import MAX_PAIRINGS, most_pairings

ACTIVE = "slam_env/ActiveSLAM-v0"
H = MEASUREMENT_MODELS["range_bearing"].h


def _ring(n: int, radius: float) -> dict:
    """A layout of n landmarks on a circle around the start."""
    angles = 2 * math.pi * np.arange(n) / n
    centre = radius + 2.0
    return {
        "width": 2 * centre,
        "height": 2 * centre,
        "start": [centre, centre, 0.0],
        "landmarks": [
            {"id": i, "x": centre + radius * math.cos(a), "y": centre + radius * math.sin(a)}
            for i, a in enumerate(angles.tolist())
        ],
    }


def _mapped(m: int) -> tuple[EKFSLAM, np.ndarray]:
    """A JCBB filter that has mapped m landmarks, and a scan of them all."""
    f = EKFSLAM(
        alphas=(0.0,) * 4,
        measurement_cov=np.diag([0.01**2, 0.001**2]),
        max_landmarks=m,
        data_association="jcbb",
    )
    truth = np.stack([np.arange(m) * 0.5 + 1.0, np.full(m, 2.0)], axis=1)
    scan = H(np.zeros(3), truth)
    f.update(scan)
    return f, scan


def test_a_ring_of_landmarks_in_view_is_refused_up_front() -> None:
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"data_association='jcbb'.*max_range") as refused:
        gym.make(
            ACTIVE,
            layout=_ring(1000, 30.0),
            fov=2 * math.pi,
            max_range=33.0,
            report_ids=False,
            data_association="jcbb",
        )
    assert time.perf_counter() - start < 1.0
    assert f"at most {MAX_PAIRINGS}" in str(refused.value) and "min(1000, 1000)" in str(
        refused.value
    )


def test_the_env_admits_jcbb_up_to_the_limit() -> None:
    env = gym.make(
        ACTIVE,
        layout=_ring(MAX_PAIRINGS, 10.0),
        fov=2 * math.pi,
        max_range=13.0,
        report_ids=False,
        data_association="jcbb",
    )
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    env.close()


def test_the_filter_refuses_a_scan_beyond_the_limit_and_changes_nothing() -> None:
    f, scan = _mapped(MAX_PAIRINGS + 1)
    mean, cov = f.mean, f.cov
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"pairs at most 64 .*min\(65, 65\)"):
        f.update(scan)
    assert time.perf_counter() - start < 0.1
    np.testing.assert_array_equal(f.mean, mean)
    np.testing.assert_array_equal(f.cov, cov)
    result = f.update(scan[:MAX_PAIRINGS])  # as many rows as pairings allowed: runs
    assert (result.ids >= 0).sum() == MAX_PAIRINGS


def test_the_kernel_never_pairs_more() -> None:
    assert most_pairings(1000, 1000) == MAX_PAIRINGS
    assert most_pairings(10, 1000) == 10 and most_pairings(1000, 3) == 3
