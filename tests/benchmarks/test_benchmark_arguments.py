"""Every benchmark and experiment refuses a count out of range as a usage error (exit 2, the flag
named, no traceback) before it runs anything: the counts go through the argparse types
of ``agents.common.arguments``, which ``slam-env`` uses too."""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pytest

from agents.common.arguments import int_at_least, non_negative_int, positive_int

ROOT = Path(__file__).resolve().parents[2]

# One count per benchmark that once crashed, divided by zero or printed inf for it.
BAD_COUNTS = {
    "benchmarks.bench_agents": ["--searches", "0"],
    "benchmarks.bench_aot": ["--calls", "0"],
    "benchmarks.bench_consistency": ["--steps", "0"],
    "benchmarks.bench_coverage": ["--steps", "-1"],
    "benchmarks.bench_env": ["--repeats", "0"],
    "benchmarks.bench_filter": ["--sizes", "10", "0"],
    "benchmarks.bench_geometry": ["--queries", "0"],
    "benchmarks.bench_instructions": ["--steps", "0"],
    "benchmarks.bench_jcbb": ["--repeats", "0"],
    "benchmarks.bench_rllib": ["--n-envs", "0"],
    "benchmarks.bench_smoothing": ["--steps", "0"],
    "benchmarks.bench_startup": ["--repeats", "0"],
    "benchmarks.bench_train": ["--steps", "0"],
    "benchmarks.bench_train_metrics": ["--instructions", "-1"],
    "experiments.choice_distillation": ["--epochs", "0"],
    "experiments.choice_oracle": ["--samples", "0"],
}


def test_every_benchmark_and_experiment_is_listed():
    scripts = [*ROOT.glob("benchmarks/bench_*.py"), *ROOT.glob("experiments/[!_]*.py")]
    assert sorted(BAD_COUNTS) == sorted(f"{p.parent.name}.{p.stem}" for p in scripts)


@pytest.mark.parametrize(("module", "args"), sorted(BAD_COUNTS.items()))
def test_a_count_out_of_range_is_a_usage_error(module, args):
    done = subprocess.run(
        [sys.executable, "-m", module, *args],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
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
