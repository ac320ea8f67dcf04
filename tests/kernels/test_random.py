"""Box–Muller normals: exact formula, finite at the ends, and standard normal."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.kernels.base.random import normal_pair


def test_normal_pair_is_the_box_muller_transform() -> None:
    z0, z1 = normal_pair(0.3, 0.2)
    r = math.sqrt(-2.0 * math.log(0.7))
    assert z0 == pytest.approx(r * math.cos(0.4 * math.pi), rel=1e-15)
    assert z1 == pytest.approx(r * math.sin(0.4 * math.pi), rel=1e-15)


def test_normal_pair_is_finite_at_the_ends_of_the_unit_interval() -> None:
    assert normal_pair(0.0, 0.0) == (0.0, 0.0)
    z0, z1 = normal_pair(np.nextafter(1.0, 0.0), 0.999999)
    assert math.isfinite(z0) and math.isfinite(z1) and math.hypot(z0, z1) > 8.0


def test_normal_pairs_are_standard_normal() -> None:
    u = np.random.default_rng(0).random((20_000, 2))
    z = np.array([normal_pair(a, b) for a, b in u]).ravel()
    assert abs(z.mean()) < 0.02
    assert abs(z.std() - 1.0) < 0.02
    # the two of a pair are uncorrelated, and the tails have normal mass
    pairs = z.reshape(-1, 2)
    assert abs(np.corrcoef(pairs.T)[0, 1]) < 0.03
    assert abs(np.mean(np.abs(z) > 1.96) - 0.05) < 0.006
