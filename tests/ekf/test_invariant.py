"""``linearization="invariant"``, the right-invariant EKF: EKFSLAM against the dense
textbook filter of ``references/invariant_ekf.py`` to 1e-9 over 100 steps for every
motion × measurement × correction combination (gate rejections and new landmarks
included), its covariance the invariant one mapped by J_r, and its defining property:
variance along the unobservable global rotation is never corrected."""

from __future__ import annotations

import numpy as np
import pytest

from references import invariant_ekf
from slam_env.ekf import EKFSLAM
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from tests.ekf.test_filter_reference import ALPHAS, COMBOS, CONTROL_NOISE, Q, run_against_dense
from tests.ekf.test_linearization import _random_control, _rotation_direction


@pytest.mark.parametrize(("motion", "measurement", "correction"), COMBOS)
def test_it_is_the_dense_right_invariant_ekf_to_1e_9_over_100_steps(
    motion, measurement, correction
):
    counts = run_against_dense(
        None, motion, measurement, correction, seed=3, steps=100,
        reference=invariant_ekf.InvariantEKFSLAM, linearization="invariant",
    )  # fmt: skip
    assert counts["initialised"] == 12 and counts["corrected"] > 150 and counts["rejected"] >= 5


@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_its_covariance_is_the_invariant_one_mapped_by_the_retraction_jacobian(correction):
    """Σ = J_r P J_rᵀ: the dense filter's P is recovered from EKFSLAM's cov, and J_r is
    far from the identity (the map matters)."""
    rng = np.random.default_rng(2)
    truth = rng.uniform(-5, 5, size=(6, 2))
    pose0, cov0 = np.array([2.0, -1.0, 0.3]), np.diag([0.01, 0.02, 0.003])
    kwargs = dict(alphas=ALPHAS, measurement_cov=Q["range_bearing"], initial_pose=pose0,
                  initial_pose_cov=cov0, correction=correction)  # fmt: skip
    f = EKFSLAM(max_landmarks=6, linearization="invariant", **kwargs)
    ref = invariant_ekf.InvariantEKFSLAM("odometry", "range_bearing", **kwargs)
    hm, mm, pose = MEASUREMENT_MODELS["range_bearing"], MOTION_MODELS["odometry"], pose0
    for _ in range(20):
        u = _random_control(rng, "odometry")
        pose = mm.motion(pose, u)
        f.predict(u)
        ref.predict(u)
        ids = rng.permutation(6)[:3]
        z = hm.h(pose, truth[ids]) + rng.normal(size=(3, 2)) * 0.02
        f.update(z, ids)
        ref.update(z, ids)
    Jr_inv = np.linalg.inv(invariant_ekf.retraction_jacobian(f.mean))
    np.testing.assert_allclose(Jr_inv @ f.cov @ Jr_inv.T, ref.P, rtol=0, atol=1e-9)
    assert np.abs(invariant_ekf.retraction_jacobian(f.mean) - np.eye(f.mean.size)).max() > 1.0


@pytest.mark.parametrize("motion", ["odometry", "velocity"])
@pytest.mark.parametrize("measurement", ["range_bearing", "cartesian"])
@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_it_never_learns_the_global_rotation(motion, measurement, correction):
    """F = I, H N = 0 and L N_pose = N_landmark for the constant unobservable
    directions N of the invariant error: two filters on the same data, one started
    with Σ₀ and one with Σ₀ + c n nᵀ (n the rotation about the origin at the prior),
    keep the same means and differ by exactly c n nᵀ, n at the *current* estimate,
    through predictions, corrections and new landmarks."""
    rng = np.random.default_rng(7)
    truth = rng.uniform(-5, 5, size=(12, 2))
    pose0, cov0, c = np.array([0.7, -0.4, 0.3]), np.diag([0.01, 0.02, 0.003]), 0.01
    n0 = _rotation_direction(pose0, [])
    mm, hm = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]

    def make(cov: np.ndarray) -> EKFSLAM:
        return EKFSLAM(
            motion_model=motion, measurement_model=measurement, alphas=ALPHAS,
            control_noise=CONTROL_NOISE, measurement_cov=Q[measurement], max_landmarks=12,
            initial_pose=pose0, initial_pose_cov=cov, linearization="invariant",
            correction=correction,
        )  # fmt: skip

    a, b = make(cov0), make(cov0 + c * np.outer(n0, n0))
    pose, worst = pose0.copy(), 0.0
    for _ in range(40):
        u = _random_control(rng, motion)
        pose = mm.motion(pose, u)
        ids = rng.permutation(12)[: rng.integers(0, 6)]
        z = hm.h(pose, truth[ids]) + rng.normal(size=(ids.size, 2)) * 0.03
        for f in (a, b):
            f.predict(u)
            f.update(z, ids)
        np.testing.assert_allclose(b.mean, a.mean, rtol=0, atol=1e-9)
        mean = a.mean
        n = _rotation_direction(mean[:3], list(mean[3:].reshape(-1, 2)))
        worst = max(worst, float(np.abs(b.cov - a.cov - c * np.outer(n, n)).max()))
    assert a.n_landmarks >= 10
    assert worst < 1e-9


def test_an_update_whose_transport_would_overflow_is_refused_bit_for_bit():
    """The retraction rotates every point about the origin: at 1e170 m from it, the
    correction's rounding moves the pose by ~1e154 m, and carrying Σ to the new mean
    would overflow. The update is refused (FloatingPointError) with the filter
    exactly as it was; the standard EKF, whose step is additive, takes the same data."""
    kwargs = dict(
        motion_model="velocity", measurement_model="cartesian", control_noise=(0.01, 0.01, 0, 0),
        measurement_cov=np.eye(2) * 1e-4, max_landmarks=2, initial_pose=(1e170, 0.0, 0.0),
        initial_pose_cov=np.diag([1e-4, 1e-4, 1e-2]),
    )  # fmt: skip
    for linearization in ("standard", "invariant"):
        f = EKFSLAM(linearization=linearization, **kwargs)
        f.update(np.array([[1.0, 0.0]]), [0])
        f.predict((0.0, 0.1))
        mean, cov = f.mean, f.cov
        if linearization == "standard":
            f.update(np.array([[1.0, 0.05]]), [0])
            assert np.isfinite(f.cov).all()
            continue
        with pytest.raises(FloatingPointError, match="exceed"):
            f.update(np.array([[1.0, 0.05]]), [0])
        np.testing.assert_array_equal(f.mean, mean)
        np.testing.assert_array_equal(f.cov, cov)
