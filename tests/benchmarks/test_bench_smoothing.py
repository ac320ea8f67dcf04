"""benchmarks/bench_smoothing.py: a tiny run prints its five sections, and a count a
user can type that makes no sense is argparse's usage error (exit 2)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def bench(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "benchmarks.bench_smoothing", *args],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )


def test_a_tiny_run_prints_every_section():
    pytest.importorskip("gtsam", reason="the benchmark measures ISAM2SLAM, which needs GTSAM")
    done = bench(
        "--steps", "40", "--long-steps", "200", "--runs", "1", "--repeats", "1",
        "--odometry-scales", "1",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    out = done.stdout
    assert "timing: 40 steps" in out and "ISAM2SLAM + mean/cov read" in out
    assert "env: slam_env/ActiveSLAM-v0's step, 40 steps" in out and "isam2 / ekf:" in out
    assert "association: hidden IDs, 1 runs × 40 steps" in out and "jcbb" in out
    assert "growth: 200 steps" in out and "ratio" in out
    assert "accuracy: 1 runs × 40 steps" in out and " mean " in out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--runs", "0"], "argument --runs: must be >= 1"),
        (["--long-steps", "150"], "--long-steps must be >= 200"),
        (["--odometry-scales", "0"], "--odometry-scales must be > 0"),
        (["--motion-factor", "exact"], "invalid choice"),
    ],
)
def test_bad_counts_are_usage_errors(args, message):
    done = bench(*args)
    assert done.returncode == 2 and done.stdout == ""
    assert message in done.stderr
