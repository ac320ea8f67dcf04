"""The workspaces of an update grow with the rows of a scan, not with their square:
what grows so (the stacked innovation covariance, JCBB's factor of S_H) is sized by
the observations an update can apply or pair, at most the landmark slots (issue #48,
item 4: 5,000 rows into a filter of 10 landmarks asked for 7.45 GiB)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from slam_env.ekf import EKFSLAM
from slam_env.kernels.ekf import association
from slam_env.kernels.ekf.associated_update import correction_workspaces

ROWS = 5_000
SLOTS = 10


def _scan(rows: int, rng: np.random.Generator) -> np.ndarray:
    """Range-bearing rows around the robot: a few landmarks, seen over and over."""
    ranges = rng.uniform(1.0, 5.0, rows)
    bearings = rng.uniform(-np.pi, np.pi, rows)
    return np.stack([ranges, bearings], axis=1)


@pytest.mark.parametrize("association_name", ["nearest_neighbor", "jcbb"])
@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_thousands_of_rows_into_a_small_filter_take_little_memory(
    association_name, correction
) -> None:
    f = EKFSLAM(
        alphas=(0.0, 0.0, 0.0, 0.0),
        measurement_cov=np.diag([0.01, 0.001]),
        max_landmarks=SLOTS,
        data_association=association_name,
        correction=correction,
    )
    z = _scan(ROWS, np.random.default_rng(0))
    tracemalloc.start()
    first = f.update(z)  # starts the landmarks
    second = f.update(z)  # pairs the rows with them
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 64 * 2**20, f"{peak / 2**20:.0f} MiB"
    assert f.n_landmarks == SLOTS
    assert first.status.shape == second.status.shape == (ROWS,)
    assert (second.ids >= 0).sum() <= SLOTS  # one pairing per landmark at most


def test_the_workspaces_grow_linearly_in_the_rows() -> None:
    dmax = 3 + 2 * SLOTS

    def entries(rows: int) -> int:
        return sum(w.size for w in correction_workspaces(dmax, SLOTS, rows, True))

    assert entries(2 * ROWS) < 2.01 * entries(ROWS)
    assert association.most_pairings(SLOTS, ROWS) == SLOTS
