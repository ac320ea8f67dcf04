"""Atomic filter calls (issue 16): whatever a call meets — ill-conditioned covariances,
absurd observations and controls, values of the wrong kind — it either completes with
a finite belief or raises ValueError/TypeError/FloatingPointError with the filter
bit for bit as it was. A fuzz over thousands of random filters, both motion and
measurement models and both correction modes (fixed seed, a few seconds)."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from slam_env.ekf import EKFSLAM

REFUSALS = (ValueError, TypeError, FloatingPointError)


def rotated(rng: np.random.Generator, eigenvalues) -> np.ndarray:
    """A symmetric matrix with the given eigenvalues in a random basis."""
    q, _ = np.linalg.qr(rng.normal(size=(len(eigenvalues), len(eigenvalues))))
    cov = q @ np.diag(eigenvalues) @ q.T
    return 0.5 * (cov + cov.T)


def magnitude(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(10.0 ** rng.uniform(lo, hi))


def random_filter(rng: np.random.Generator, linearization: str = "standard") -> EKFSLAM:
    """A filter whose covariances span up to 20 orders of magnitude."""
    while True:
        try:
            return EKFSLAM(
                motion_model=rng.choice(["odometry", "velocity"]),
                measurement_model=rng.choice(["range_bearing", "cartesian"]),
                alphas=[magnitude(rng, -8, 2) * (rng.random() < 0.9) for _ in range(4)],
                control_noise=[magnitude(rng, -8, 2) * (rng.random() < 0.9) for _ in range(4)],
                measurement_cov=rotated(rng, [magnitude(rng, -12, 6) for _ in range(2)]),
                max_landmarks=int(rng.integers(1, 6)),
                initial_pose=rng.normal(size=3) * magnitude(rng, -3, 6),
                initial_pose_cov=rotated(
                    rng, [magnitude(rng, -14, 8) * (rng.random() < 0.8) for _ in range(3)]
                ),
                gate=None if rng.random() < 0.5 else magnitude(rng, -1, 3),
                correction=rng.choice(["sequential", "batch"]),
                linearization=linearization,
            )
        except ValueError:  # e.g. Q not positive definite after rounding: draw again
            continue


def absurd_number(rng: np.random.Generator) -> float:
    kind = rng.integers(0, 6)
    if kind == 0:
        return float(rng.normal())
    if kind == 1:
        return float(rng.choice([-1.0, 1.0]) * magnitude(rng, 100, 308))
    if kind == 2:
        return float(rng.choice([-1.0, 1.0]) * magnitude(rng, -320, -100))
    if kind == 3:
        return float(rng.choice([0.0, -0.0, math.pi, -math.pi, 1e-3]))
    if kind == 4:
        return float(rng.normal() * magnitude(rng, 3, 12))
    return float(rng.choice([math.nan, math.inf, -math.inf])) if rng.random() < 0.3 else 1.0


def wrong_kind(rng: np.random.Generator, shape: tuple[int, ...]):
    """Values that are not real numbers, or not of the right shape."""
    kind = rng.integers(0, 6)
    if kind == 0:
        return np.ones(shape) + 1j
    if kind == 1:
        return np.full(shape, "1.0")
    if kind == 2:
        return np.ones(shape, dtype=bool)
    if kind == 3:
        return np.array([None] * int(np.prod(shape)), dtype=object).reshape(shape)
    if kind == 4:
        return np.ones((*shape, 2))
    return [[1.0, 2.0], [3.0]]


def random_control(rng: np.random.Generator, f: EKFSLAM):
    dim = 3 if f.motion_model == "odometry" else 2
    if rng.random() < 0.1:
        return wrong_kind(rng, (dim,))
    if rng.random() < 0.4:
        return rng.normal(size=dim) * 0.3
    return np.array([absurd_number(rng) for _ in range(dim)])


def random_observations(rng: np.random.Generator, f: EKFSLAM):
    k = int(rng.integers(0, f.max_landmarks + 2))
    ids = rng.integers(0, f.max_landmarks, size=k)
    if rng.random() < 0.8:
        ids = rng.permutation(f.max_landmarks)[: min(k, f.max_landmarks)]
        k = ids.size
    if rng.random() < 0.05:
        ids = ids.astype(float)
    if rng.random() < 0.05 and k:
        ids[0] = rng.choice([-1, f.max_landmarks])
    if rng.random() < 0.1:
        return wrong_kind(rng, (k, 2)), ids
    if rng.random() < 0.3:
        z = rng.normal(size=(k, 2)) * [3.0, 1.0]
    else:
        z = np.array([[absurd_number(rng), absurd_number(rng)] for _ in range(k)]).reshape(k, 2)
    return z, ids


def snapshot(f: EKFSLAM) -> bytes:
    """Everything in the filter's state, storage included, bit for bit."""
    arrays = (*f.belief_arrays(), f.id_to_state, np.int64(f.n_rejected))
    return b"".join(a.tobytes() for a in arrays)


@pytest.mark.parametrize("linearization", ["standard", "invariant"])
def test_every_refused_call_leaves_the_filter_bit_for_bit_as_it_was(linearization):
    rng = np.random.default_rng(16)
    outcomes: Counter[tuple[str, str]] = Counter()
    for _ in range(2000):
        f = random_filter(rng, linearization)
        for _ in range(8):
            before = snapshot(f)
            if rng.random() < 0.4:
                call, args = "predict", (random_control(rng, f),)
            else:
                call, args = "update", random_observations(rng, f)
            try:
                getattr(f, call)(*args)
            except REFUSALS as exc:  # anything else fails the test
                outcomes[call, type(exc).__name__] += 1
                assert snapshot(f) == before, (call, args, exc)
            else:
                outcomes[call, "ok"] += 1
                mean, cov, _ = f.belief_views()
                assert np.isfinite(mean).all() and np.isfinite(cov).all()
                assert (cov == cov.T).all()
    # The fuzz reached every kind of outcome, often.
    for call in ("predict", "update"):
        for kind in ("ok", "ValueError", "TypeError", "FloatingPointError"):
            assert outcomes[call, kind] >= 50, (call, kind, outcomes)


@pytest.mark.parametrize("correction", ["sequential", "batch"])
@pytest.mark.parametrize("measurement", ["range_bearing", "cartesian"])
def test_a_near_singular_sensor_and_far_landmarks_are_refused_atomically(correction, measurement):
    """Issue 16's case: a near-singular measurement covariance and far landmarks used
    to raise 'math domain error' after the mean had changed."""
    outcomes = Counter()
    rng = np.random.default_rng(3)
    for _ in range(200):
        f = EKFSLAM(
            measurement_model=measurement,
            alphas=(0.1, 0.1, 0.1, 0.1),
            measurement_cov=rotated(rng, [1e-12, magnitude(rng, -12, 2)]),
            max_landmarks=4,
            initial_pose_cov=rotated(rng, [1e-14, 1.0, 1e6]),
            correction=correction,
        )
        far = rng.normal(size=(4, 2)) * magnitude(rng, 3, 9)
        f.update(far, np.arange(4))
        f.predict((0.3, 2.0, -0.1))
        before = snapshot(f)
        try:
            f.update(far[::-1] * (1 + rng.normal(size=(4, 2)) * 1e-3), np.arange(4)[::-1])
        except FloatingPointError:
            outcomes["refused"] += 1
            assert snapshot(f) == before
        else:
            outcomes["ok"] += 1
            assert np.isfinite(f.cov).all() and np.isfinite(f.mean).all()
    # Both outcomes occur; what matters is that a refusal changed nothing.
    assert outcomes["refused"] >= 10 and outcomes["ok"] >= 10, outcomes


@pytest.mark.parametrize(
    "u", [(1e200, 1e200, 1e200), (0.0, 1e160, 0.0), (1e155, 0.0, 0.0)], ids=str
)
def test_a_prediction_whose_covariance_overflows_is_refused(u):
    f = EKFSLAM(alphas=(0.1, 0.1, 0.1, 0.1), measurement_cov=np.eye(2), max_landmarks=2)
    f.update([[2.0, 0.1]], [1])
    before = snapshot(f)
    with pytest.raises(FloatingPointError, match="overflow"):
        f.predict(u)
    assert snapshot(f) == before
