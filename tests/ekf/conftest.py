"""Fixtures of the EKF-SLAM tests: the dense textbook reference and small helpers."""

from __future__ import annotations

import numpy as np
import pytest

from references import dense_ekf


@pytest.fixture(scope="session")
def dense_reference():
    """The module holding ``DenseEKFSLAM`` and its status codes."""
    return dense_ekf


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
