"""Monte Carlo consistency of the noise-matched filter (NEES / NIS, seed 004).

Each run simulates the robot from the filter's own noise model: the true motion
follows u_true, the odometry reading is u_true + ε with ε ~ N(0, M(u_true)) (or
N(0, Σu)), and every landmark in range is measured with noise N(0, Q). Over 50 runs
the pose NEES averaged across runs must lie in its two-sided 95% χ² band (3 dof:
[2.36, 3.72]) on at least 90% of the 100 steps, and so must the average NIS of
the corrections made at each step (2 dof per observation; see the test for which).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.ekf import EKFSLAM, chi2_ppf
from slam_env.ekf.models import (
    MEASUREMENT_MODELS,
    MOTION_MODELS,
    odometry_action_cov,
    velocity_control_cov,
)
from slam_env.world.frames import odometry_from_poses, wrap_angle

RUNS, STEPS = 50, 100
ALPHAS = (0.002, 0.001, 0.002, 0.001)
ALPHAS_DEFAULT = (0.005, 0.002, 0.01, 0.001)  # the env's odometry noise
CONTROL_NOISE = (0.005, 0.003, 0.002, 0.01)
Q = {
    "range_bearing": np.diag([0.05**2, math.radians(1.5) ** 2]),
    "cartesian": np.diag([0.05**2, 0.05**2]),
}
P0 = np.diag([0.02**2, 0.02**2, 0.01**2])
MAX_RANGE = 5.0
# Ten landmarks around a circle of radius 4 m centred on (0, 4): the robot's path.
_angles = np.linspace(0.0, 2.0 * math.pi, 10, endpoint=False)
LANDMARKS = np.stack(
    [
        (4.0 + 2.0 * (-1) ** np.arange(10)) * np.cos(_angles),
        4.0 + (4.0 + 2.0 * (-1) ** np.arange(10)) * np.sin(_angles),
    ],
    axis=1,
)


def run_once(seed, motion, measurement, correction):
    """One simulated run: (NEES per step, list of the NIS values at each step)."""
    rng = np.random.default_rng(seed)
    mm, hm = MOTION_MODELS[motion], MEASUREMENT_MODELS[measurement]
    if motion == "odometry":
        u_true = np.array([0.05, 0.4, 0.05])  # a 4 m radius circle
        noise_cov = odometry_action_cov(u_true, ALPHAS)
    else:
        u_true = np.array([0.4, 0.1])
        noise_cov = velocity_control_cov(u_true, CONTROL_NOISE)
    chol_u = np.linalg.cholesky(noise_cov)
    chol_q = np.linalg.cholesky(Q[measurement])
    true_pose = rng.multivariate_normal(np.zeros(3), P0)  # the prior is honest
    f = EKFSLAM(
        motion_model=motion,
        measurement_model=measurement,
        alphas=ALPHAS,
        control_noise=CONTROL_NOISE,
        measurement_cov=Q[measurement],
        max_landmarks=len(LANDMARKS),
        initial_pose=(0.0, 0.0, 0.0),
        initial_pose_cov=P0,
        correction=correction,
    )

    def sense():
        ids = np.flatnonzero(np.hypot(*(LANDMARKS - true_pose[:2]).T) < MAX_RANGE)
        ids = rng.permutation(ids)
        z = hm.h(true_pose, LANDMARKS[ids]).reshape(-1, 2)
        z += rng.normal(size=z.shape) @ chol_q.T
        if hm.angular[1]:
            z[:, 1] = wrap_angle(z[:, 1])
        return z, ids

    f.update(*sense())
    nees, nis = np.empty(STEPS), []
    for t in range(STEPS):
        true_pose = mm.motion(true_pose, u_true)
        f.predict(u_true + chol_u @ rng.normal(size=u_true.size))
        res = f.update(*sense())
        nis.append(res.nis[res.corrected])
        err = true_pose - f.pose
        err[2] = wrap_angle(err[2])
        nees[t] = err @ np.linalg.solve(f.pose_cov, err)
    return nees, nis


@pytest.mark.parametrize(
    ("motion", "measurement", "correction"),
    [
        ("odometry", "range_bearing", "sequential"),
        ("odometry", "range_bearing", "batch"),
        ("velocity", "cartesian", "sequential"),
        ("odometry", "cartesian", "batch"),
        ("velocity", "range_bearing", "sequential"),
    ],
)
def test_noise_matched_filter_is_consistent(motion, measurement, correction):
    runs = [run_once(1000 + r, motion, measurement, correction) for r in range(RUNS)]
    nees = np.array([r[0] for r in runs])  # (runs, steps)
    lo, hi = chi2_ppf(0.025, 3 * RUNS) / RUNS, chi2_ppf(0.975, 3 * RUNS) / RUNS
    assert (round(lo, 2), round(hi, 2)) == (2.36, 3.72)
    average = nees.mean(axis=0)
    inside = np.mean((average >= lo) & (average <= hi))
    assert inside >= 0.9, f"average NEES inside [{lo:.2f}, {hi:.2f}] on {inside:.0%} of steps"

    # Sequential innovations are white: every correction's NIS is an independent
    # χ²(2) sample. In batch mode the observations of one step share the predicted
    # pose error, so their individual NIS are correlated: take one per run.
    nis_inside = []
    for t in range(STEPS):
        if correction == "sequential":
            values = np.concatenate([r[1][t] for r in runs])
        else:
            values = np.array([r[1][t][0] for r in runs])
        count = values.size
        assert count >= RUNS  # every run corrects at least one landmark per step
        lo_t = chi2_ppf(0.025, 2 * count) / count
        hi_t = chi2_ppf(0.975, 2 * count) / count
        nis_inside.append(lo_t <= values.mean() <= hi_t)
    assert np.mean(nis_inside) >= 0.9, f"average NIS inside its band on {np.mean(nis_inside):.0%}"


def arc_end(speed: float, turn: float) -> np.ndarray:
    """Where a robot at the origin ends after a step along an arc (as the world moves
    it): ``speed`` m along the arc while the heading turns by ``turn`` rad."""
    if turn == 0.0:
        return np.array([speed, 0.0, 0.0])
    radius = speed / turn
    return np.array([radius * math.sin(turn), radius * (1.0 - math.cos(turn)), turn])


@pytest.mark.parametrize(
    ("speed", "turn"),
    [
        (-0.001, 0.3),  # under 1 mm: the reading drops the 0.15 mm sideways part
        (-0.004, 0.3),  # backing off 4 mm while turning at the full rate
        (0.004, 0.3),
        (-0.01, 0.09),
    ],
)
def test_a_small_motion_from_a_known_pose_is_consistent(speed, turn):
    """One prediction from an exactly known pose (P = 0), with the env's odometry
    reading of the true arc: seed 000's V M Vᵀ alone gives such steps a sideways
    variance of δtr²·var(δrot1) (≈ 1e-13 m² under 1 mm), so that the error of the
    reading's noise (var(δtr)·var(δrot1)) or its dropped sub-millimetre sideways part
    gave NEES of 10² to 10¹² on average; with the filter's two sideways terms the NEES
    is at most χ²(3)'s (about 2: the dropped part's ±1 mm spread is a bound, so the
    filter is a little conservative on such steps)."""
    rng = np.random.default_rng(7)
    truth = arc_end(speed, turn)
    u_true = np.array(odometry_from_poses(np.zeros(3), truth))
    std = np.sqrt(np.diag(odometry_action_cov(u_true, ALPHAS_DEFAULT)))
    nees = np.empty(2000)
    for k in range(nees.size):
        f = EKFSLAM(
            alphas=ALPHAS_DEFAULT,
            measurement_cov=Q["range_bearing"],
            initial_pose=(0.0, 0.0, 0.0),
            max_landmarks=1,
        )
        f.predict(u_true + std * rng.normal(size=3))
        err = truth - f.pose
        err[2] = wrap_angle(err[2])
        nees[k] = err @ np.linalg.solve(f.pose_cov, err)
    assert nees.mean() <= chi2_ppf(0.975, 3 * nees.size) / nees.size
    assert nees.max() < 50.0, f"the worst of {nees.size} NEES is {nees.max():.3g}"
