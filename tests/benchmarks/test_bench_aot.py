"""The AOT prototype's benchmark measures what it says: the extension it builds from a
kernel's source runs without numba and writes what the JIT kernel wrote, and its
comparison catches a stage that writes anything else."""

from __future__ import annotations

import llvmlite.binding
import numpy as np
import pytest

from benchmarks import bench_aot


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    folder = tmp_path_factory.mktemp("aot")
    calls = bench_aot.record(["egocentric"], warmup=3)
    bench_aot.build(calls, folder, llvmlite.binding.get_host_cpu_name())
    return folder, calls


def test_the_extension_runs_without_numba_and_equals_the_jit_kernel(built):
    folder, calls = built
    bench_aot.save(calls, folder)
    aot = bench_aot.child("aot", folder, ["egocentric"])
    assert aot["same"] == ["egocentric"] and aot["numba"] is False
    jit = bench_aot.child("jit", folder, ["egocentric"])
    assert jit["same"] == ["egocentric"] and jit["numba"] is True


def test_a_stage_that_writes_other_bits_is_not_counted_the_same(built):
    folder, calls = built
    tampered = bench_aot.copied(calls["egocentric"]["after"])
    out = tampered[8]  # the (B, F) float32 features the stage writes
    assert out.dtype == np.float32 and out.size
    out.flat[0] = np.nextafter(out.flat[0], np.float32(np.inf))
    bench_aot.save({"egocentric": {**calls["egocentric"], "after": tampered}}, folder)
    assert bench_aot.child("aot", folder, ["egocentric"])["same"] == []


def test_copied_and_compared_through_nested_tuples():
    value = (np.arange(3.0), (np.array([np.nan]), 2))
    twin = bench_aot.copied(value)
    assert twin[0] is not value[0] and bench_aot.arrays_equal(value, twin)
    twin[1][0][0] = 1.0
    assert not bench_aot.arrays_equal(value, twin)
