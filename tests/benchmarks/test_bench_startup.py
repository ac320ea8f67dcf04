"""bench_startup: --parts takes a first step apart into parts that add up to it; the
children run as Python runs by default."""

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


def test_children_cache_bytecode_as_python_does_by_default(monkeypatch):
    # A machine that sets PYTHONDONTWRITEBYTECODE (as CI's may) would otherwise have
    # every child compile the package's sources anew, which no installed user pays.
    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/elsewhere")
    own = bench_startup.child_environment(None)
    assert "PYTHONDONTWRITEBYTECODE" not in own and "NUMBA_CACHE_DIR" not in own
    assert own["SDL_VIDEODRIVER"] == "dummy"
    assert bench_startup.child_environment("/empty")["NUMBA_CACHE_DIR"] == "/empty"
