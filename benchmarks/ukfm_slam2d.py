"""The field's 2D SLAM consistency benchmark, in the setting of ukfm's ``slam2d``
(Brossard, Barrau & Bonnabel, github.com/CAOR-MINES-ParisTech/ukfm:
python/benchmarks/slam2d.py, python/ukfm/model/slam2d.py). It is simulated here with
our own code, with no env, and run by

    .venv/bin/python -m benchmarks.bench_consistency --scenario ukfm-slam2d [--runs 100]
        [--steps 2500] [--seed 0]

The setting, as ukfm's:

* odometry at 1 Hz, the robot driven at v = 0.25 m/s and ω = 1.5 °/s (each second
  v dt along the heading, then a turn of ω dt: round and round a circle of radius
  about v/ω ≈ 9.55 m), started at (0, 0, 0) and known exactly (zero initial
  covariance);
* the odometry read with noise σ_v = 0.05 v/√2 on the speed and σ_ω = 0.05 v √2 · 2
  on the turn rate, each step. The filters take it as the (Δp, Δθ) model of seed 004,
  control_noise = (σ_v dt, σ_ω dt, 0, 0): ukfm's f moves, then turns;
* 20 landmarks evenly spaced on a circle 3 m outside the robot's, each measured in the
  robot frame (``measurement_model="cartesian"``) with σ = 0.1 m per axis, whenever it
  lies between 1 m and 5 m;
* 2,500 timestamps (2,499 steps). Each step predicts, corrects with the known
  landmarks in view in one batch (ukfm stacks them), then starts the new ones. There is
  no gate, and the IDs are known.

Each row is a ``linearization`` of :class:`slam_env.ekf.EKFSLAM`. It gets the heading
and position RMSE over all runs and steps, and the mean NEES per degree of freedom of
the heading (e_θ²/Σ_θθ) and of the position (e_pᵀ Σ_pp⁻¹ e_p / 2), as ukfm computes them
(from step 10 on). ukfm's published figures (docs/_sources/auto_benchmark/slam2d.rst.txt,
100 runs) are printed beside them: its EKF and its IEKF, which is this right-invariant
EKF.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slam_env.ekf import EKFSLAM, LINEARIZATIONS

DT = 1.0  # s, 1 Hz odometry
SPEED = 0.25  # m/s
TURN_RATE = math.radians(1.5)  # rad/s
SPEED_STD = 0.05 * SPEED / math.sqrt(2.0)
TURN_RATE_STD = 0.05 * SPEED * math.sqrt(2.0) * 2.0
MEASUREMENT_STD = 0.1  # m, per axis
N_LANDMARKS = 20
MIN_RANGE, MAX_RANGE = 1.0, 5.0  # m
NEES_FROM = 10  # ukfm's first step of its NEES
RUNS, STEPS = 100, 2500

# ukfm's published results (100 runs): heading RMSE (deg), position RMSE (m), mean NEES
# per dof of the heading and of the position.
PUBLISHED = {
    "standard": ("EKF", 3.02, 0.67, 2.88, 2.56),
    "invariant": ("IEKF", 2.51, 0.55, 1.01, 1.17),
}


def landmarks() -> np.ndarray:
    """(20, 2): evenly spaced on the circle of radius v/ω + 3 about (0, v/ω), the centre
    of the continuous drive's circle."""
    radius = SPEED / TURN_RATE
    angles = 2.0 * np.pi * np.arange(N_LANDMARKS) / N_LANDMARKS
    ring = radius + MIN_RANGE + 2.0
    return np.stack([ring * np.cos(angles), ring * np.sin(angles) + radius], axis=1)


@dataclass
class Simulation:
    """One run: the true poses (T, 3), the odometry read (T−1, 2) as (Δp, Δθ), and at
    each timestamp the IDs in view and their measurements in the robot frame."""

    poses: np.ndarray
    controls: np.ndarray
    ids: list[np.ndarray]
    z: list[np.ndarray]


def simulate(rng: np.random.Generator, steps: int) -> Simulation:
    """The true circle driven without noise, the odometry read with it, the landmarks
    in range measured with it."""
    marks = landmarks()
    poses = np.zeros((steps, 3))
    for n in range(1, steps):  # translate, then turn (ukfm's f)
        x, y, th = poses[n - 1]
        poses[n] = (x + SPEED * DT * math.cos(th), y + SPEED * DT * math.sin(th),
                    th + TURN_RATE * DT)  # fmt: skip
    noise = rng.standard_normal((steps - 1, 2)) * [SPEED_STD, TURN_RATE_STD]
    controls = (np.array([SPEED, TURN_RATE]) + noise) * DT
    ids, zs = [], []
    for pose in poses:
        offsets = marks - pose[:2]
        ranges = np.hypot(offsets[:, 0], offsets[:, 1])
        seen = np.flatnonzero((ranges > MIN_RANGE) & (ranges < MAX_RANGE))
        c, s = math.cos(pose[2]), math.sin(pose[2])
        local = offsets[seen] @ np.array([[c, -s], [s, c]])  # R(θ)ᵀ (m − p), row-wise
        ids.append(seen)
        zs.append(local + rng.standard_normal(local.shape) * MEASUREMENT_STD)
    return Simulation(poses, controls, ids, zs)


def make_filter(linearization: str) -> EKFSLAM:
    return EKFSLAM(
        motion_model="velocity",
        measurement_model="cartesian",
        control_noise=(SPEED_STD * DT, TURN_RATE_STD * DT, 0.0, 0.0),
        measurement_cov=MEASUREMENT_STD**2 * np.eye(2),
        max_landmarks=N_LANDMARKS,
        initial_pose=(0.0, 0.0, 0.0),
        initial_pose_cov=np.zeros((3, 3)),
        gate=None,
        correction="batch",
        linearization=linearization,
    )


def run_filter(sim: Simulation, linearization: str) -> np.ndarray:
    """(T, 4) per timestamp: heading error, the position error's squared norm, heading
    NEES and position NEES per dof (NaN before the first step; the NEES NaN before
    step NEES_FROM, as ukfm's: the position covariance of the first step is singular,
    its heading noise not yet turned into position)."""
    f = make_filter(linearization)
    out = np.full((len(sim.poses), 4), np.nan)
    for n in range(1, len(sim.poses)):
        f.predict(sim.controls[n - 1])
        if len(sim.ids[n]):
            f.update(sim.z[n], sim.ids[n])
        pose, cov = f.pose, f.pose_cov
        e_th = math.remainder(pose[2] - sim.poses[n, 2], 2.0 * math.pi)
        e_p = pose[:2] - sim.poses[n, :2]
        out[n, :2] = e_th, e_p @ e_p
        if n >= NEES_FROM:
            out[n, 2] = e_th**2 / cov[2, 2]
            out[n, 3] = 0.5 * e_p @ np.linalg.solve(cov[:2, :2], e_p)
    return out


def evaluate(runs: int, steps: int, seed: int, names: tuple[str, ...] = LINEARIZATIONS):
    """Run r is simulated with ``np.random.default_rng(seed + r)``; returns
    {linearization: (runs, T, 4)} (see :func:`run_filter`)."""
    results: dict[str, list[np.ndarray]] = {name: [] for name in names}
    for r in range(runs):
        sim = simulate(np.random.default_rng(seed + r), steps)
        for name in names:
            results[name].append(run_filter(sim, name))
    return {name: np.array(v) for name, v in results.items()}


def summary(per_step: np.ndarray) -> tuple[float, float, float, float]:
    """Heading RMSE (deg), position RMSE (m), mean heading NEES and mean position NEES
    per dof (steps NEES_FROM on)."""
    body = per_step[:, 1:]
    nees = per_step[:, NEES_FROM:]
    return (
        math.degrees(math.sqrt(np.mean(body[..., 0] ** 2))),
        math.sqrt(np.mean(body[..., 1])),
        float(np.mean(nees[..., 2])),
        float(np.mean(nees[..., 3])),
    )


def print_table(runs: int, steps: int, seed: int) -> None:
    results = evaluate(runs, steps, seed)
    print(
        f"ukfm slam2d: {runs} runs × {steps} timestamps at {1 / DT:g} Hz, v {SPEED} m/s, "
        f"ω {math.degrees(TURN_RATE):g} °/s, σ_v {SPEED_STD:.4f} m/s, "
        f"σ_ω {TURN_RATE_STD:.4f} rad/s, {N_LANDMARKS} landmarks seen in "
        f"({MIN_RANGE:g}, {MAX_RANGE:g}) m with σ {MEASUREMENT_STD} m (cartesian), "
        f"batch corrections, seeds {seed}..{seed + runs - 1}"
    )
    header = (
        f"{'linearization':<15}{'RMSE θ (°)':>11}{'RMSE p (m)':>11}{'NEES θ':>8}{'NEES p':>8}"
        f"   ukfm (100 runs): RMSE θ, p, NEES θ, p"
    )
    print(header)
    print("-" * len(header))
    for name, per_step in results.items():
        rot, pos, nees_rot, nees_pos = summary(per_step)
        theirs = ""
        if name in PUBLISHED:
            label, *values = PUBLISHED[name]
            theirs = f"   {label:<5}" + "".join(f"{v:>6.2f}" for v in values)
        print(f"{name:<15}{rot:>11.2f}{pos:>11.3f}{nees_rot:>8.2f}{nees_pos:>8.2f}{theirs}")
