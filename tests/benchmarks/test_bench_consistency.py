"""benchmarks/bench_consistency.py, the command behind docs/benchmarks.md's consistency tables:
a tiny run prints a row per variant asked for, and values a user can type that the env
would refuse end in argparse's usage error (exit 2) before any episode is run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from benchmarks import bench_consistency, consistency_episodes
from slam_env import extras

ROOT = Path(__file__).resolve().parents[2]


def bench(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "benchmarks.bench_consistency", *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )


def test_a_tiny_run_prints_every_variant_asked_for() -> None:
    variants = ["known/standard", "known/fej", "ideal", "jcbb2w/oc"]
    done = bench("--runs", "2", "--steps", "30", "--clutter", "0.1", "--variants", *variants)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert "2 runs × 30 steps" in lines[0] and "clutter 0.1" in lines[0]
    rows = {line.split()[0]: line.split() for line in lines[4:]}
    assert list(rows) == variants
    for name, cells in rows.items():
        band = float(cells[1].rstrip("%"))
        nees_mean, ekf, best, ratio = map(float, cells[2:6])
        assert 0.0 <= band <= 100.0 and nees_mean > 0.0
        assert ratio == pytest.approx(ekf / best, abs=0.006), name
        associates = name.startswith("jcbb")
        assert (cells[6] != "-") == associates, name  # association columns only there
        assert float(cells[10]) > 0.0, name  # ms per step


def test_the_smoother_row_is_printed_beside_the_filters() -> None:
    variants = ["known/standard", "known/isam2"]
    done = bench("--runs", "2", "--steps", "25", "--variants", *variants)
    assert done.returncode == 0, done.stderr
    rows = {line.split()[0]: line.split() for line in done.stdout.splitlines()[4:]}
    assert list(rows) == variants
    cells = rows["known/isam2"]
    band = float(cells[1].rstrip("%"))
    nees_mean, rmse, best, ratio = map(float, cells[2:6])
    assert 0.0 <= band <= 100.0 and 0.0 < nees_mean < 1e3
    assert 0.0 < rmse < 1.0 and ratio == pytest.approx(rmse / best, abs=0.006)
    assert cells[6:10] == ["-"] * 4  # it is told the IDs
    assert 0.0 < float(cells[10]) < 1e3
    assert rows["known/standard"][4] == cells[4]  # the same data: the same optimum


def test_the_smoothers_map_is_the_truth_on_a_noise_free_run() -> None:
    # (almost) no odometry or measurement noise: the map must land on the truth
    options = {"alphas": (1e-12,) * 4, "range_std": 1e-6, "bearing_std": 1e-6}
    with gym.make(consistency_episodes.ENV_ID, max_episode_steps=40, **options) as env:
        recording = consistency_episodes.record_episode(env, seed=3, steps=40)
    run = bench_consistency.run_smoother(recording)
    assert len(run.landmarks) > 0 and run.rmse < 1e-4
    assert np.isfinite(run.nees).all() and run.poses.shape == (41, 3)
    np.testing.assert_allclose(run.poses[-1], recording.true_poses[-1], atol=1e-4)


def test_the_smoother_row_without_gtsam_is_a_one_line_usage_error(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(extras.EXTRAS, "gtsam", ("no_such_module_gtsam",))
    with pytest.raises(SystemExit) as exit_:
        bench_consistency.parse_args(["--variants", "known/oc", "known/isam2"])
    assert exit_.value.code == 2
    message = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--variants known/isam2 needs the 'gtsam' extra" in message
    assert "pip install 'slam_env[gtsam]'" in message


def test_the_default_rows_leave_the_smoother_out() -> None:
    args, env = bench_consistency.parse_args(["--runs", "1", "--steps", "5"])
    env.close()
    assert "known/isam2" in bench_consistency.ROWS
    assert "known/isam2" not in args.variants and "ideal" in args.variants


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--clutter", "2"], "clutter_rate must be in [0, 1]"),
        (["--clutter", "nan"], "clutter_rate must be finite"),
        (["--odometry-scale", "inf"], "must be finite"),
        (["--odometry-scale", "1e300"], "exceeds the budget"),
        (["--odometry-scale", "0"], "--odometry-scale must be > 0"),
        (["--seed", "-1"], "argument --seed: must be >= 0"),
        (["--runs", "0"], "argument --runs: must be >= 1"),
        (["--variants", "known/exact"], "unknown variants"),
    ],
)
def test_values_the_env_refuses_are_usage_errors(args: list[str], message: str) -> None:
    done = bench("--runs", "1", "--steps", "5", *args)
    assert done.returncode == 2 and done.stdout == ""
    assert "Traceback" not in done.stderr and message in done.stderr
