"""Property-based tests (hypothesis): for arbitrary valid sequences of predictions,
corrections and new landmarks the filter stays a valid Gaussian belief."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slam_env.ekf import EKFSLAM
from slam_env.ekf.models import MEASUREMENT_MODELS

MAX_LANDMARKS = 6
Q = {
    "range_bearing": np.diag([0.05**2, math.radians(2.0) ** 2]),
    "cartesian": np.diag([0.05**2, 0.05**2]),
}

angle = st.floats(-math.pi, math.pi, exclude_max=True, allow_nan=False)
odometry = st.tuples(st.floats(-0.5, 0.5), st.floats(-0.4, 0.4), st.floats(-0.5, 0.5)).map(np.array)
velocity = st.tuples(st.floats(-0.4, 0.4), st.floats(-0.5, 0.5)).map(np.array)


@st.composite
def observations(draw, measurement: str):
    """A scan: distinct IDs, each with a plausible measurement."""
    ids = draw(st.lists(st.integers(0, MAX_LANDMARKS - 1), min_size=1, max_size=4, unique=True))
    rows = []
    for _ in ids:
        if measurement == "range_bearing":
            rows.append((draw(st.floats(0.3, 8.0)), draw(angle)))
        else:
            rows.append((draw(st.floats(-6.0, 6.0)), draw(st.floats(-6.0, 6.0))))
    return np.array(rows), np.array(ids)


@st.composite
def scenarios(draw):
    motion = draw(st.sampled_from(["odometry", "velocity"]))
    measurement = draw(st.sampled_from(["range_bearing", "cartesian"]))
    correction = draw(st.sampled_from(["sequential", "batch"]))
    control = odometry if motion == "odometry" else velocity
    ops = draw(
        st.lists(
            st.one_of(
                st.tuples(st.just("predict"), control),
                st.tuples(st.just("update"), observations(measurement)),
            ),
            min_size=1,
            max_size=25,
        )
    )
    return motion, measurement, correction, ops


def _filter(motion, measurement, correction, gate=None):
    return EKFSLAM(
        motion_model=motion,
        measurement_model=measurement,
        alphas=(0.01, 0.002, 0.01, 0.002),
        control_noise=(0.01, 0.005, 0.01, 0.02),
        measurement_cov=Q[measurement],
        max_landmarks=MAX_LANDMARKS,
        initial_pose_cov=np.diag([1e-4, 1e-4, 1e-4]),
        gate=gate,
        correction=correction,
    )


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios())
def test_belief_stays_a_valid_gaussian(scenario):
    motion, measurement, correction, ops = scenario
    f = _filter(motion, measurement, correction)
    for kind, arg in ops:
        if kind == "predict":
            f.predict(arg)
        else:
            f.update(*arg)
        mean, cov = f.mean, f.cov
        assert np.isfinite(mean).all() and np.isfinite(cov).all()
        assert -math.pi <= mean[2] < math.pi
        np.testing.assert_array_equal(cov, cov.T)
        assert np.linalg.eigvalsh(cov).min() >= -1e-9 * max(1.0, np.abs(cov).max())
        assert f.n_landmarks == len(set(f.state_to_id.tolist()))


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from(["range_bearing", "cartesian"]),
    st.integers(0, 2**32 - 1),
)
def test_sequential_and_batch_agree_to_first_order_on_small_innovations(measurement, seed):
    rng = np.random.default_rng(seed)
    hm = MEASUREMENT_MODELS[measurement]
    landmarks = rng.uniform(-4.0, 4.0, size=(4, 2))
    ids = np.arange(4)
    seq = _filter("odometry", measurement, "sequential")
    batch = _filter("odometry", measurement, "batch")
    for f in (seq, batch):  # the same history: four new landmarks, then a motion
        f.update(hm.h(np.zeros(3), landmarks).reshape(-1, 2), ids)
        f.predict(np.array([0.1, 0.3, -0.05]))
    np.testing.assert_array_equal(seq.cov, batch.cov)
    before = seq.mean
    # Observations a tiny step away from the prediction: the re-linearisation between
    # sequential corrections changes the result only at second order in the innovation.
    eps = 1e-4
    z = hm.h(seq.pose, seq.landmark_means()).reshape(-1, 2)
    z = z + eps * rng.normal(size=z.shape)
    prior_scale = np.abs(seq.cov).max()
    seq.update(z, ids)
    batch.update(z, ids)
    shift = np.abs(seq.mean - before).max()
    assert shift > 0.0
    assert np.abs(seq.mean - batch.mean).max() <= 1e-2 * shift + 1e-12
    # The covariances differ only through the linearisation points: first order in
    # the mean shift (relative to the prior's scale).
    assert np.abs(seq.cov - batch.cov).max() <= 10.0 * shift * prior_scale
