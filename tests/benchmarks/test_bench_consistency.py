"""benchmarks/bench_consistency.py, the command behind docs/benchmarks.md's consistency tables:
a tiny run prints a row per variant asked for, and values a user can type that the env
would refuse end in argparse's usage error (exit 2) before any episode is run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

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
