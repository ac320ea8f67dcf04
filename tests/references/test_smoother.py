"""The batch least-squares smoother of references/smoother.py, the yardstick of the
consistency benchmark: exact on noise-free data, better than its initialisation on
noisy data, a stationary point, and an analytic Jacobian that matches finite
differences."""

from __future__ import annotations

import numpy as np
import pytest

from references.smoother import (
    Episode,
    SmootherProblem,
    dead_reckoning,
    first_sightings,
    smooth,
)
from slam_env.belief.metrics import map_rmse
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS

ALPHAS = (0.005, 0.002, 0.01, 0.001)
VELOCITY_NOISE = (0.01, 0.005, 0.01, 0.02)
Q = {"range_bearing": np.diag([0.05**2, 0.0175**2]), "cartesian": np.eye(2) * 0.05**2}
LANDMARKS = np.array([[x + 0.3, y + 0.1] for x in (-3.0, 0.0, 3.0) for y in (-1.0, 2.0, 5.0)])
MODELS = [("odometry", "range_bearing"), ("velocity", "cartesian")]


def true_controls(motion: str, steps: int) -> np.ndarray:
    """A loop and a bit: turning while driving, a turn on the spot, a reverse."""
    controls = np.empty((steps, 3 if motion == "odometry" else 2))
    for t in range(steps):
        turn = 0.1 if t % 40 < 30 else -0.05
        dist = 0.0 if t == 17 else (-0.1 if t == 33 else 0.2)
        controls[t] = (turn / 2, dist, turn / 2) if motion == "odometry" else (dist, turn)
    return controls


def synthetic_episode(
    motion: str, measurement: str, steps: int, rng: np.random.Generator | None
) -> tuple[Episode, np.ndarray]:
    """An episode whose truth follows the models exactly, and its true poses; noisy
    readings drawn from the models' own noise when ``rng`` is given."""
    params = ALPHAS if motion == "odometry" else VELOCITY_NOISE
    motion_model, sensor = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]
    controls = true_controls(motion, steps)
    poses = np.empty((steps + 1, 3))
    poses[0] = (0.0, -2.0, 0.3)
    readings = controls.copy()
    step_of, ids, zs = [], [], []
    for t in range(1, steps + 1):
        poses[t] = motion_model.motion(poses[t - 1], controls[t - 1])
        if rng is not None:
            std = np.sqrt(np.diag(motion_model.noise_cov(controls[t - 1], params)))
            readings[t - 1] += std * rng.standard_normal(std.shape)
        z = sensor.h(poses[t], LANDMARKS)
        rel = LANDMARKS - poses[t, :2]
        ahead = np.hypot(*rel.T) < 4.5
        for j in np.flatnonzero(ahead):
            noise = 0.0 if rng is None else np.linalg.cholesky(Q[measurement]) @ rng.normal(size=2)
            step_of.append(t)
            ids.append(10 + j)  # IDs need not start at 0
            zs.append(z[j] + noise)
    episode = Episode(
        start_pose=poses[0].copy(),
        controls=readings,
        steps=np.array(step_of, dtype=np.int64),
        ids=np.array(ids, dtype=np.int64),
        z=np.array(zs),
        motion_model=motion,
        motion_params=params,
        measurement_model=measurement,
        measurement_cov=Q[measurement],
    )
    return episode, poses


def truth_of(ids: np.ndarray) -> np.ndarray:
    """The true positions of landmarks ``ids`` (L, 2)."""
    return LANDMARKS[np.asarray(ids) - 10]


@pytest.mark.parametrize(
    ("motion", "measurement", "solver"), [(*m, "sparse_lm") for m in MODELS] + [(*MODELS[0], "trf")]
)
def test_noise_free_data_gives_the_truth(motion: str, measurement: str, solver: str) -> None:
    episode, poses = synthetic_episode(motion, measurement, 60, rng=None)
    rng = np.random.default_rng(1)
    start = poses + rng.normal(scale=0.05, size=poses.shape)
    start[0] = poses[0]
    ids = np.unique(episode.ids)
    marks = {int(i): LANDMARKS[int(i) - 10] + rng.normal(scale=0.2, size=2) for i in ids}
    result = smooth(episode, start, marks, solver=solver, tolerance=1e-12)
    assert result.success
    np.testing.assert_array_equal(result.landmark_ids, ids)
    np.testing.assert_allclose(result.landmarks, LANDMARKS[ids - 10], rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.poses[:, :2], poses[:, :2], rtol=0, atol=1e-8)
    heading = np.angle(np.exp(1j * (result.poses[:, 2] - poses[:, 2])))
    np.testing.assert_allclose(heading, 0.0, atol=1e-8)
    assert result.cost < 1e-12 < result.initial_cost


def test_noisy_data_beats_dead_reckoning_at_a_minimum() -> None:
    episode, _ = synthetic_episode("odometry", "range_bearing", 120, np.random.default_rng(7))
    ids, start = first_sightings(episode, dead_reckoning(episode))
    result = smooth(episode)
    assert result.success
    # scipy's own least squares, started there, stays there.
    marks = dict(zip(result.landmark_ids.tolist(), result.landmarks, strict=True))
    check = smooth(episode, result.poses, marks, solver="trf")
    np.testing.assert_allclose(check.landmarks, result.landmarks, atol=1e-7)
    assert check.cost == pytest.approx(result.cost, rel=1e-9)
    smoothed = map_rmse(result.landmarks, truth_of(result.landmark_ids))
    assert smoothed < 0.5 * map_rmse(start, truth_of(ids))
    problem = SmootherProblem(episode)
    v = problem.pack(result.poses, result.landmarks)
    # A stationary point: the gradient Jᵀr vanishes (against the size of its terms)...
    J, r = problem.jacobian(v), problem.residuals(v)
    scale = abs(J).T @ abs(r)
    assert np.max(np.abs(J.T @ r)) < 1e-6 * np.max(scale)
    assert result.cost == pytest.approx(problem.cost(v), rel=1e-12)
    no_step = smooth(episode, result.poses, marks, max_nfev=1)
    assert no_step.cost == no_step.initial_cost == pytest.approx(result.cost, rel=1e-12)
    assert 0.5 < 2.0 * result.cost / result.redundancy < 2.0  # χ²/dof about 1
    # ...and a minimum: no small step anywhere lowers the cost.
    rng = np.random.default_rng(3)
    for _ in range(20):
        step = rng.normal(scale=1e-3, size=v.shape)
        assert problem.cost(v + step) > result.cost
        assert problem.cost(v - step) > result.cost


@pytest.mark.parametrize(("motion", "measurement"), MODELS)
def test_jacobian_matches_finite_differences(motion: str, measurement: str) -> None:
    episode, poses = synthetic_episode(motion, measurement, 25, np.random.default_rng(5))
    problem = SmootherProblem(episode)
    rng = np.random.default_rng(2)
    marks = LANDMARKS[problem.landmark_ids - 10] + rng.normal(
        scale=0.1, size=(len(problem.landmark_ids), 2)
    )
    v = problem.pack(poses + rng.normal(scale=0.05, size=poses.shape), marks)
    J = problem.jacobian(v).toarray()
    h = 1e-6
    numeric = np.empty_like(J)
    for i in range(v.shape[0]):
        dv = np.zeros_like(v)
        dv[i] = h
        numeric[:, i] = (problem.residuals(v + dv) - problem.residuals(v - dv)) / (2 * h)
    np.testing.assert_allclose(J, numeric, rtol=1e-5, atol=1e-5 * np.abs(J).max())
    assert J.shape == (3 * 25 + 2 * len(episode.ids), 3 * 25 + 2 * len(problem.landmark_ids))


def test_bad_input_is_refused() -> None:
    episode, _ = synthetic_episode("odometry", "range_bearing", 10, None)
    with pytest.raises(ValueError, match="solver"):
        smooth(episode, solver="lm")
    with pytest.raises(ValueError, match="initial_poses"):
        smooth(episode, np.zeros((5, 3)))
    no_q = Episode(episode.start_pose, episode.controls, episode.steps, episode.ids, episode.z)
    with pytest.raises(ValueError, match="measurement_cov"):
        SmootherProblem(no_q)
