"""bench_startup's --parts takes a first step apart into parts that add up to it."""

from __future__ import annotations

import pytest

from benchmarks import bench_startup


def test_the_parts_of_a_first_step_add_up_to_it():
    parts = bench_startup.parts("slam_env/Landmarks-v0")
    total = parts.pop("total")
    assert list(parts) == [
        "gymnasium, numpy and pymunk",
        "numba and its registries",
        "the cached kernels' loading",
        "the rest (slam_env, make, reset, step)",
    ]
    assert all(value > 0 for value in parts.values())
    assert sum(parts.values()) == pytest.approx(total, rel=1e-9)
