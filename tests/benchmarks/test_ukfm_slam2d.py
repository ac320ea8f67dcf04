"""benchmarks/ukfm_slam2d.py, ukfm's slam2d setting: the simulation is that setting
(the drive around, the landmark ring, the sensor's range window, the noise levels), a tiny
run through ``bench_consistency --scenario ukfm-slam2d`` prints a row per
linearisation, and the env's own options are refused with that scenario."""

from __future__ import annotations

import math

import numpy as np

from benchmarks import ukfm_slam2d as ukfm
from tests.benchmarks.test_bench_consistency import bench


def test_the_simulation_is_ukfms_setting():
    sim = ukfm.simulate(np.random.default_rng(0), 2500)
    # The truth: from (0, 0, 0), each second v along the heading, then a turn of ω.
    np.testing.assert_array_equal(sim.poses[0], [0.0, 0.0, 0.0])
    steps = np.diff(sim.poses[:, :2], axis=0)
    headings = sim.poses[:-1, 2]
    np.testing.assert_allclose(steps[:, 0], ukfm.SPEED * np.cos(headings), atol=1e-12)
    np.testing.assert_allclose(steps[:, 1], ukfm.SPEED * np.sin(headings), atol=1e-12)
    np.testing.assert_allclose(np.diff(sim.poses[:, 2]), ukfm.TURN_RATE, atol=1e-12)
    radius = ukfm.SPEED / ukfm.TURN_RATE
    centre = np.array([0.0, radius])
    marks = ukfm.landmarks()
    assert marks.shape == (20, 2)
    np.testing.assert_allclose(np.hypot(*(marks - centre).T), radius + 3.0, atol=1e-12)
    # The odometry's noise: σ_v = 0.05 v/√2, σ_ω = 0.05 v √2 · 2, at 1 Hz.
    errors = sim.controls - [ukfm.SPEED, ukfm.TURN_RATE]
    assert abs(errors[:, 0].std() / (0.05 * 0.25 / math.sqrt(2)) - 1) < 0.05
    assert abs(errors[:, 1].std() / (0.05 * 0.25 * math.sqrt(2) * 2) - 1) < 0.05
    # Every landmark seen lies in (1, 5) m, in the robot frame, with σ 0.1 m.
    residuals = []
    for pose, ids, z in zip(sim.poses, sim.ids, sim.z, strict=True):
        ranges = np.hypot(*(marks - pose[:2]).T)
        np.testing.assert_array_equal(ids, np.flatnonzero((ranges > 1) & (ranges < 5)))
        c, s = math.cos(pose[2]), math.sin(pose[2])
        residuals.append(z - (marks[ids] - pose[:2]) @ np.array([[c, -s], [s, c]]))
    residuals = np.concatenate(residuals)
    assert len(residuals) > 2500 and abs(residuals.std() / 0.1 - 1) < 0.05


def test_a_tiny_run_prints_every_linearization():
    done = bench("--scenario", "ukfm-slam2d", "--runs", "1", "--steps", "60")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "1 runs × 60 timestamps" in lines[0]
    rows = {line.split()[0]: line.split() for line in lines[3:]}
    assert list(rows) == ["standard", "fej", "oc", "invariant"]
    for cells in rows.values():
        assert all(float(v) > 0 and math.isfinite(float(v)) for v in cells[1:5])
    assert rows["standard"][5:] == ["EKF", "3.02", "0.67", "2.88", "2.56"]
    assert rows["invariant"][5:] == ["IEKF", "2.51", "0.55", "1.01", "1.17"]


def test_the_envs_options_are_refused_with_it():
    done = bench("--scenario", "ukfm-slam2d", "--runs", "1", "--odometry-scale", "4")
    assert done.returncode == 2 and done.stdout == ""
    assert "--odometry-scale: not options of --scenario ukfm-slam2d" in done.stderr
