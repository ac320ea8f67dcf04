"""Kernels compiled without numba's reference counting (``borrowing_kernel``): the
EKF's step and the envs' step run that way, and a kernel that would allocate cannot be
declared so."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from slam_env.kernels.base.compiling import borrowing_kernel
from slam_env.kernels.belief import active_step, divergence, egocentric, full_belief, local_map
from slam_env.kernels.ekf import corrections as ekf_correction
from slam_env.kernels.ekf import filter as ekf
from slam_env.kernels.ekf import new_landmarks as ekf_landmarks
from slam_env.kernels.stream import raw_step, sensing
from slam_env.kernels.world import motion

EKF_STEP = (
    ekf.predict,
    ekf.predict_one,
    ekf.update,
    ekf.update_one,
    ekf_correction.add_observation,  # (correct_group is inlined into update)
    ekf_landmarks.new_landmarks,
    ekf_correction.apply_factors,
    ekf_landmarks.commit_new_landmarks,
)

# Every kernel call of a single env's step (and of the vector envs' steps).
ENV_STEP = (
    motion.drive,
    raw_step.raw_step,
    raw_step.sense_and_observe,
    sensing.sense_landmarks,
    sensing.proximity_scan,
    active_step.filter_step,
    active_step.belief_outputs,
    active_step.step_reward,
    egocentric.encode_egocentric,
    full_belief.encode_full,
    local_map.mark_scan_hits,
    local_map.encode_local,
    divergence.diverged,
)


@pytest.mark.parametrize("dispatcher", EKF_STEP + ENV_STEP, ids=lambda d: d.__name__)
def test_the_steps_are_compiled_without_reference_counting(dispatcher) -> None:
    # With counting, each array a call is passed costs an atomic increment and
    # decrement (a quarter of EKFSLAM's step at N = 20, docs/benchmarks.md "Filter step"), and
    # each array passed from Python a new wrapper (about 80 ns: 3.4 µs of the 43
    # arrays of raw_step's call).
    assert dispatcher.targetoptions.get("_nrt") is False


@borrowing_kernel
def _allocates(n: int) -> float:
    return np.empty(n).sum()


def test_a_borrowing_kernel_that_allocates_is_refused_when_compiled() -> None:
    with pytest.raises(numba.core.errors.TypingError, match="empty"):
        _allocates(3)


@borrowing_kernel
def _halve_rows(a: np.ndarray, rows: int) -> None:
    for i in range(rows):
        row = a[i]  # a view of the caller's array, not counted
        for j in range(row.shape[0]):
            row[j] *= 0.5


def test_a_borrowing_kernel_writes_through_views_of_the_callers_arrays() -> None:
    a = np.arange(12.0).reshape(3, 4)
    _halve_rows(a, 2)
    np.testing.assert_array_equal(
        a, np.concatenate([np.arange(8.0) / 2, np.arange(8.0, 12)]).reshape(3, 4)
    )
