"""FilterBatch, the filters of a native vector env's sub-envs: each row is the filter
the single env would run, bit for bit, whatever the size of the updates (its
workspaces start small and grow on the first update that needs more), with known IDs
and with the filter's own association."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.ekf import EKFSLAM
from slam_env.ekf.batch import FilterBatch
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.kernels.ekf.associated_update import workspaces_fit
from slam_env.kernels.ekf.association import association_workspace_sizes
from slam_env.kernels.ekf.filter import update_workspace_size

Q = np.diag([0.03**2, math.radians(0.5) ** 2])


@pytest.mark.parametrize("association", ["known", "jcbb"])
def test_each_row_is_the_single_filter_as_the_updates_grow(association):
    """Two worlds, 30 landmarks, scans of up to 30 detections (the workspaces start
    with room for 8): every row stays equal to an EKFSLAM fed the same data."""
    rng = np.random.default_rng(3)
    B, M = 2, 30
    template = EKFSLAM(
        alphas=(0.002, 0.001, 0.002, 0.001),
        measurement_cov=Q,
        max_landmarks=M,
        data_association=association,
        new_landmark_sightings=2 if association == "jcbb" else 1,
    )
    batch = FilterBatch(B, template, max_observations=M)
    singles = [template.copy() for _ in range(B)]
    xs, ys = np.meshgrid(np.arange(6) * 2.5 - 6.0, np.arange(5) * 2.5 - 5.0)
    truth = np.stack([xs.ravel(), ys.ravel()], axis=1)
    poses = np.zeros((B, 3))
    for b in range(B):
        batch.reset(b, poses[b])
    hm, mm = MEASUREMENT_MODELS["range_bearing"], MOTION_MODELS["odometry"]
    everyone = np.ones(B, dtype=bool)
    largest = 0
    for step in range(25):
        for b in range(B):
            u = np.array([0.1, 0.3, -0.05])
            poses[b] = mm.motion(poses[b], u)
            batch.u[b] = u
            singles[b].predict(u)
        batch.predict(everyone)
        for b in range(B):
            k = min(M, 4 + 2 * step + b)  # more each step, past the initial room
            ids = rng.permutation(M)[:k]
            z = hm.h(poses[b], truth[ids]) + rng.normal(size=(k, 2)) * [0.01, 0.002]
            batch.z[b, :k], batch.ids[b, :k], batch.counts[b] = z, ids, k
            expected = singles[b].update(z, ids if association == "known" else None)
            largest = max(largest, k)
            if b == 0:
                expected_0 = expected
        batch.update(everyone)
        assert (batch.error == 0).all()
        k0 = batch.counts[0]
        np.testing.assert_array_equal(batch.status[0, :k0], expected_0.status)
        for b in range(B):
            np.testing.assert_array_equal(batch.filter(b).mean, singles[b].mean)
            np.testing.assert_array_equal(batch.filter(b).cov, singles[b].cov)
    assert largest == M and batch._room == M


def test_a_correction_needs_each_of_its_workspaces_to_fit() -> None:
    """The update's scratch and, where the filters associate, both of the
    association's: one too small refuses the call."""
    m, k, d = 5, 3, 4
    dmax = 3 + 2 * m
    counts, mask = np.array([k]), np.ones(1, dtype=bool)
    floats, ints = association_workspace_sizes(m, k)
    update_size = update_workspace_size(dmax, k)

    def fits(update: int, f: int, i: int, associates: bool) -> bool:
        spaces = (np.empty(update), np.empty(f), np.empty(i, dtype=np.int64))
        return workspaces_fit(dmax, counts, mask, d, spaces, associates)

    assert fits(update_size, floats, ints, True)
    assert not fits(update_size, floats - 1, ints, True)
    assert not fits(update_size, floats, ints - 1, True)
    assert not fits(update_size - 1, floats, ints, True)
    assert fits(update_size, 0, 0, False)
    assert not fits(update_size - 1, 0, 0, False)
