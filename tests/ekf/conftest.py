"""Fixtures of the EKF-SLAM tests: the dense textbook reference and small helpers.

The reference is loaded from its file path (``dense_reference.py`` next to this file),
so it works under any pytest import mode and with pytest-xdist; the benchmark loads
it the same way.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest


def load_dense_reference():
    """The ``dense_reference`` module, imported by file path (idempotent)."""
    name = "slam_env_tests_ekf_dense_reference"
    if name not in sys.modules:
        path = Path(__file__).with_name("dense_reference.py")
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


@pytest.fixture(scope="session")
def dense_reference():
    """The module holding ``DenseEKFSLAM`` and its status codes."""
    return load_dense_reference()


def snapshot(f) -> dict:
    """Everything observable about a filter, for 'unchanged after a failed call'."""
    return {
        "mean": f.mean,
        "cov": f.cov,
        "state_to_id": f.state_to_id,
        "id_to_state": f.id_to_state,
        "n_rejected": f.n_rejected,
        "n_landmarks": f.n_landmarks,
    }


def assert_same_snapshot(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


@pytest.fixture
def take_snapshot():
    return snapshot


@pytest.fixture
def same_snapshot():
    return assert_same_snapshot
