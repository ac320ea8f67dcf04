"""Every benchmark refuses a count out of range as a usage error (exit 2, the flag
named, no traceback) before it runs anything: the counts go through the argparse types
of ``agents.common.arguments``, which ``slam-env`` uses too."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from agents.common.arguments import int_at_least, non_negative_int, positive_int

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"

# One count per benchmark that once crashed, divided by zero or printed inf for it.
BAD_COUNTS = {
    "bench_agents.py": ["--searches", "0"],
    "bench_choice_distillation.py": ["--epochs", "0"],
    "bench_choice_oracle.py": ["--samples", "0"],
    "bench_consistency.py": ["--steps", "0"],
    "bench_coverage.py": ["--steps", "-1"],
    "bench_env.py": ["--repeats", "0"],
    "bench_filter.py": ["--sizes", "10", "0"],
    "bench_geometry.py": ["--queries", "0"],
    "bench_instructions.py": ["--steps", "0"],
    "bench_rllib.py": ["--n-envs", "0"],
    "bench_train.py": ["--steps", "0"],
    "bench_train_metrics.py": ["--instructions", "-1"],
}


def test_every_benchmark_is_listed():
    assert sorted(BAD_COUNTS) == sorted(p.name for p in BENCHMARKS.glob("bench_*.py"))


@pytest.mark.parametrize(("script", "args"), sorted(BAD_COUNTS.items()))
def test_a_count_out_of_range_is_a_usage_error(script, args):
    done = subprocess.run(
        [sys.executable, str(BENCHMARKS / script), *args],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and done.stdout == ""
    assert "Traceback" not in done.stderr
    assert f"argument {args[0]}: must be >= " in done.stderr


def test_the_count_types():
    assert positive_int("3") == 3 and non_negative_int("0") == 0 and int_at_least(-2)("-2") == -2
    for parse, text, message in [
        (positive_int, "0", "must be >= 1, got 0"),
        (non_negative_int, "-1", "must be >= 0, got -1"),
        (positive_int, "2.5", "expected an integer, got '2.5'"),
        (positive_int, "", "expected an integer, got ''"),
    ]:
        with pytest.raises(argparse.ArgumentTypeError, match=message):
            parse(text)
