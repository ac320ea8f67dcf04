"""The ideal EKF of references/ideal_ekf.py, the consistency benchmark's yardstick:
linearised at its own estimates it is EKFSLAM; linearised elsewhere its covariance is
the one EKFSLAM has with its mean at those points, while its mean moves from its own
estimate; fed noise-free data and the truth it tracks the truth."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest

from references.ideal_ekf import IdealEKF
from slam_env.ekf import CORRECTED, DEFAULT_GATE, EKFSLAM, INITIALISED, REJECTED
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from tests.ekf.test_filter_reference import assert_same_belief
from tests.references.test_smoother import ALPHAS, LANDMARKS, VELOCITY_NOISE, Q, synthetic_episode

MODELS = list(itertools.product(["odometry", "velocity"], ["range_bearing", "cartesian"]))
IDS = 10 + np.arange(len(LANDMARKS))  # synthetic_episode's landmark IDs
TRUTH = dict(zip(IDS.tolist(), LANDMARKS, strict=True))


def options(motion: str, measurement: str, **extra: Any) -> dict[str, Any]:
    """The keyword arguments both filters take (EKFSLAM's names)."""
    return {
        "motion_model": motion,
        "measurement_model": measurement,
        "alphas": ALPHAS,
        "control_noise": VELOCITY_NOISE,
        "measurement_cov": Q[measurement],
        "max_landmarks": int(IDS.max()) + 1,
        "gate": DEFAULT_GATE,
        **extra,
    }


def same_result(a: Any, b: Any) -> None:
    np.testing.assert_array_equal(a.ids, b.ids)
    np.testing.assert_array_equal(a.status, b.status)
    np.testing.assert_allclose(a.nis, b.nis, rtol=1e-9)  # NaN where NaN


@pytest.mark.parametrize(("motion", "measurement"), MODELS)
def test_at_its_own_estimates_it_is_ekfslam(motion: str, measurement: str) -> None:
    episode, _ = synthetic_episode(motion, measurement, 50, np.random.default_rng(3))
    kw = options(
        motion,
        measurement,
        initial_pose=episode.start_pose,
        initial_pose_cov=np.diag([0.01, 0.02, 0.004]),
    )
    ideal, ekf = IdealEKF(**kw), EKFSLAM(**kw)
    statuses, started = [], []
    for t, u in enumerate(episode.controls, start=1):
        ideal.predict(u)
        ekf.predict(u)
        assert_same_belief(ideal, ekf, atol=1e-10)
        z, ids = episode.detections_at(t)
        if t == 20:
            z = z + np.array([0.8, 0.3])  # outliers: the gate rejects them
        result = ideal.update(z, ids)
        same_result(result, ekf.update(z, ids))
        assert_same_belief(ideal, ekf, atol=1e-10)
        statuses.extend(result.status.tolist())
        started.extend([t] * int(result.initialised.sum()))
    assert ideal.n_rejected == ekf.n_rejected > 0
    assert statuses.count(CORRECTED) > 100
    assert statuses.count(INITIALISED) == ideal.n_landmarks >= 5
    assert max(started) > min(started) + 5  # landmarks added to a correlated map too
    assert ideal.pose_cov.shape == (3, 3)
    np.testing.assert_array_equal(ideal.pose_cov, ideal.cov[:3, :3])
    np.testing.assert_array_equal(ideal.pose, ideal.mean[:3])
    np.testing.assert_allclose(ideal.landmark_means(), ekf.landmark_means(), atol=1e-10)


@pytest.mark.parametrize(("motion", "measurement"), MODELS)
def test_at_the_truth_on_noise_free_data_it_tracks_the_truth(motion: str, measurement: str) -> None:
    episode, poses = synthetic_episode(motion, measurement, 50, rng=None)
    kw = options(motion, measurement, initial_pose=poses[0])
    ideal, ekf = IdealEKF(**kw), EKFSLAM(**kw)
    for t, u in enumerate(episode.controls, start=1):
        ideal.predict(u, at_pose=poses[t - 1])
        ekf.predict(u)
        z, ids = episode.detections_at(t)
        result = ideal.update(z, ids, at_pose=poses[t], at_landmarks=TRUTH)
        ekf.update(z, ids)
        assert not result.rejected.any()
        heading = np.angle(np.exp(1j * (ideal.pose[2] - poses[t, 2])))
        np.testing.assert_allclose([*ideal.pose[:2], heading], [*poses[t, :2], 0.0], atol=1e-9)
        # The estimate is the truth, so the truth is where EKFSLAM linearises too.
        assert_same_belief(ideal, ekf, atol=1e-9)
    np.testing.assert_allclose(ideal.landmark_means(), LANDMARKS[ideal.state_to_id - 10], atol=1e-9)


@pytest.mark.parametrize(("motion", "measurement"), MODELS)
def test_its_jacobians_are_the_models_at_the_given_points(motion: str, measurement: str) -> None:
    """Filter A's estimate is off the points it is given; filter B's estimate is at
    them (and B linearises at its estimate, as EKFSLAM there). A's covariance is B's
    and EKFSLAM's after every call (G, V, L, W and H at the points), A's mean moves
    from its own estimate (with an observation it predicts exactly, it does not move),
    and a filter linearised at A's estimate ends with another covariance."""
    mm, hm = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]
    point = np.array([0.2, -0.1, 0.4])
    estimate = point + np.array([0.15, -0.1, 0.06])
    prior = {"initial_pose_cov": np.diag([0.02, 0.03, 0.005])}
    a = IdealEKF(**options(motion, measurement, initial_pose=estimate, **prior))
    b = IdealEKF(**options(motion, measurement, initial_pose=point, **prior))
    ekf = EKFSLAM(**options(motion, measurement, initial_pose=point, **prior))
    own = EKFSLAM(**options(motion, measurement, initial_pose=estimate, **prior))
    z0, lid = np.array([[2.0, 0.3]]), [12]
    a.update(z0, lid, at_pose=b.pose)
    for f in (b, ekf, own):
        f.update(z0, lid)
    np.testing.assert_allclose(a.landmark_means()[0], hm.inverse(estimate, z0[0]), atol=1e-12)
    u = np.array([0.1, 0.5, -0.2]) if motion == "odometry" else np.array([0.5, -0.2])
    a.predict(u, at_pose=b.pose)
    for f in (b, ekf, own):
        f.predict(u)
    np.testing.assert_allclose(a.pose, mm.motion(estimate, u), atol=1e-12)
    before = a.mean
    z1 = hm.h(a.pose, a.landmark_means()[0])[None]
    result = a.update(z1, lid, at_pose=b.pose, at_landmarks={12: b.landmark_means()[0]})
    assert result.status.tolist() == [CORRECTED] and result.nis[0] == pytest.approx(0.0, abs=1e-20)
    np.testing.assert_allclose(a.mean, before, atol=1e-12)
    for f in (b, ekf, own):
        assert f.update(z1, lid).status.tolist() == [CORRECTED]
    assert np.abs(b.mean - before).max() > 0.01
    np.testing.assert_allclose(a.cov, b.cov, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.cov, ekf.cov, rtol=0, atol=1e-10)
    assert np.abs(a.cov - own.cov).max() > 1e-4


def test_a_landmark_on_the_robot_is_rejected() -> None:
    """Range-bearing cannot be linearised with the landmark's point on the robot's."""
    f = IdealEKF(**options("odometry", "range_bearing"))
    np.testing.assert_array_equal(f.mean, [0.0, 0.0, 0.0])  # EKFSLAM's default prior
    f.update([[2.0, 0.0]], [0])  # the lowest ID
    before = f.mean, f.cov
    result = f.update([[2.0, 0.0]], [0], at_pose=[1.0, 1.0, 0.0], at_landmarks={0: [1.0, 1.0]})
    assert result.status.tolist() == [REJECTED] and np.isnan(result.nis[0])
    assert f.n_rejected == 1
    np.testing.assert_array_equal(f.mean, before[0])
    np.testing.assert_array_equal(f.cov, before[1])


def test_bad_input_is_refused_and_changes_nothing() -> None:
    with pytest.raises(ValueError, match="motion_model"):
        IdealEKF(**options("bicycle", "range_bearing"))
    with pytest.raises(ValueError, match="control_noise"):
        IdealEKF(**options("velocity", "cartesian", control_noise=None))
    f = IdealEKF(**options("odometry", "range_bearing"))
    f.update([[2.0, 0.0], [3.0, 1.0]], [11, 12])
    before = f.mean, f.cov, f.state_to_id
    bad_calls = [
        (ValueError, "u must have shape", lambda: f.predict([0.1, 0.2])),
        (ValueError, "at_pose", lambda: f.predict([0.1, 0.2, 0.0], at_pose=[0.0, 0.0])),
        (ValueError, "ids must have shape", lambda: f.update([[2.0, 0.0]], [11, 12])),
        (ValueError, "negative", lambda: f.update([[2.0, 0.0]], [-1])),
        (ValueError, "capacity", lambda: f.update([[2.0, 0.0]], [f.max_landmarks])),
        (ValueError, "duplicate", lambda: f.update([[2.0, 0.0], [2.0, 0.1]], [13, 13])),
        (ValueError, "finite", lambda: f.update([[np.nan, 0.0]], [13])),
        (ValueError, "at_pose", lambda: f.update([[2.0, 0.0]], [13], at_pose=[0.0])),
        (
            ValueError,
            r"\[12\]",
            lambda: f.update([[2.0, 0.0], [1.0, 0.0]], [11, 12], at_landmarks={11: [2.0, 0.0]}),
        ),
    ]
    for error, match, call in bad_calls:
        with pytest.raises(error, match=match):
            call()
        np.testing.assert_array_equal(f.mean, before[0])
        np.testing.assert_array_equal(f.cov, before[1])
        np.testing.assert_array_equal(f.state_to_id, before[2])
