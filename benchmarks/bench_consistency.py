"""Filter consistency and map accuracy against the batch least-squares optimum.

    .venv/bin/python -m benchmarks.bench_consistency [--runs 30] [--steps 500]
        [--odometry-scale 1] [--seed 0] [--variants known/standard ideal jcbb/fej ...]
        [--clutter 0]
    .venv/bin/python -m benchmarks.bench_consistency --variants known/oc known/isam2 ideal
    .venv/bin/python -m benchmarks.bench_consistency --scenario ukfm-slam2d
        [--runs 100] [--steps 2500] [--seed 0]

``--scenario ukfm-slam2d`` is the field's benchmark instead, ukfm's ``slam2d``
setting (:mod:`benchmarks.ukfm_slam2d`), for every linearisation; the rest of this
docstring is about the default scenario, ``env``.

The settings docs/benchmarks.md records: the defaults, ``--odometry-scale 4 --steps 1000``,
``--odometry-scale 16 --steps 1000`` and ``--clutter 0.1``. A run of the defaults, every
row, takes about 30 s on two shared cores (env 4–7 s, filters ~12 s of which the
dense ideal EKF ~6 s, smoother 7–13 s); the 1,000-step ones 1–4 minutes.

Monte Carlo over the env's own noise: episode r is ``slam_env/Landmarks-v0`` (the raw
stream: odometry readings, detections with IDs, the truth in ``info``) reset with seed
``--seed + r`` on the default world (a new random world per seed), driven by
:class:`~benchmarks.consistency_episodes.TourDriver`, which reads only the truth and
never the noise, so every variant gets the same data
(:mod:`benchmarks.consistency_episodes`). ``--odometry-scale`` multiplies the env's α1..α4
(the reading's variances; the filters are told the same, noise-matched).

Each episode's recorded data is fed to every EKF-SLAM variant of ``--variants``
(:data:`VARIANTS`: a name and the ``EKFSLAM`` keyword arguments that make it, on top of
:func:`filter_kwargs`, the noise-matched filter the env's ActiveSLAM wrapper builds:
true start pose, zero initial covariance, χ² gate ``DEFAULT_GATE``) and to the batch
least-squares smoother (references/smoother.py), started from the known-ID standard
filter's filtered trajectory and final map. Variants whose ``data_association`` is not
``"known"`` get the detections with every ID hidden (−1); the others, and the smoother,
only the detections the env labelled (ID ≥ 0: clutter, where the env has it, is left
out).

The row ``known/isam2`` (:data:`SMOOTHER`, asked for by name: it needs the ``gtsam``
extra) is the smoothing belief, :class:`slam_env.smoothing.ISAM2SLAM` with its defaults,
on the same data and told the same (the filter's keyword arguments less the gate): a
``predict`` and an ``update`` every step (a pose variable per step, as the batch
smoother has), its pose NEES from ``pose_cov``, the current pose's block of its joint
marginal covariance (past poses integrated out).

The row ``ideal`` (:data:`IDEAL`) is the yardstick of the ``in band`` column: the
"ideal EKF" of Huang, Mourikis & Roumeliotis ("Analysis and improvement of the
consistency of extended Kalman filter based SLAM", ICRA 2008), the known-ID filter
with every Jacobian evaluated at the truth (G and V at the true pose the step starts
from, H at the true pose and landmark, L and W of a new landmark at the true pose)
while its means come from its estimates (references/ideal_ekf.py, :func:`run_ideal`).
It cannot run on a robot (it reads the truth), but it shows how consistent an EKF
linearisation can be on the same data: the NEES a filter can hope for, as ``LS RMSE``
is the map error it can hope for.

The table:

* ``in band``: the share of steps 1..T whose pose NEES averaged over the runs lies in
  the two-sided 95% χ² band (3·runs dof, divided by runs; slam_env.belief.metrics);
* ``mean NEES``: the pose NEES averaged over runs and steps (3 for a consistent filter);
* ``map RMSE``: the final map RMSE (m) over the landmarks in the belief's map, mean
  over runs; ``LS RMSE``: the batch smoother's on the same runs; ``ratio``: the two's.
  A run in which a belief refuses a call (``FloatingPointError``) is left out of its
  row and counted;
* ``ms/step``: the belief's CPU time (``time.process_time``: on a shared machine the
  wall clock counts the neighbours too) over the runs, per step: predict, update and
  the reads the NEES and the map take.

For the variants that associate, ``correct`` is the share of the detections given to
the right landmark (or correctly starting one, or clutter left out), and ``wrong``,
``missed``, ``dup`` the counts over all runs of wrong associations, missed ones and
duplicated landmarks, judged by ActiveSLAM-v0's own rules
(:mod:`slam_env.kernels.ekf.association_score`); their map RMSE pairs each filter landmark
with the true landmark that started it.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

import slam_env  # noqa: F401  (registers the env IDs)
from agents.common.arguments import non_negative_int, positive_int
from benchmarks import ukfm_slam2d
from benchmarks.consistency_episodes import ENV_ID, Recording, env_options, record_episode
from references.ideal_ekf import IdealEKF
from references.smoother import smooth
from slam_env.belief.metrics import map_rmse, nees, nees_band, pose_error, share_in_nees_band
from slam_env.ekf import DEFAULT_GATE, EKFSLAM, LINEARIZATIONS, UpdateResult
from slam_env.extras import MissingExtra, require
from slam_env.kernels.ekf.association_score import SCORE_NAMES, score_association

# A variant: the EKFSLAM keyword arguments that make it (on top of filter_kwargs), an
# association's by each linearisation.
# "jcbb2": JCBB with a new landmark started on its second sighting (against clutter).
# "jcbbw": JCBB with a wide (loop-closing) pairing withheld until its landmark has been
# paired that way in WIDE_PAIRING_SCANS consecutive scans; "jcbb2w" both.
WIDE_PAIRING_SCANS = 3
ASSOCIATIONS: dict[str, dict[str, Any]] = {
    "known": {},
    "nn": {"data_association": "nearest_neighbor"},
    "jcbb": {"data_association": "jcbb"},
    "jcbbw": {"data_association": "jcbb", "wide_pairing_scans": WIDE_PAIRING_SCANS},
    "jcbb2": {"data_association": "jcbb", "new_landmark_sightings": 2},
    "jcbb2w": {
        "data_association": "jcbb",
        "new_landmark_sightings": 2,
        "wide_pairing_scans": WIDE_PAIRING_SCANS,
    },
}
VARIANTS: dict[str, dict[str, Any]] = {
    f"{name}/{linearization}": {**kwargs, "linearization": linearization}
    for name, kwargs in ASSOCIATIONS.items()
    for linearization in LINEARIZATIONS
}
# The variant whose filtered trajectory and map start the smoother.
BASELINE = "known/standard"
# The row of the ideal EKF (references/ideal_ekf.py, every Jacobian at the truth).
IDEAL = "ideal"
# The row of the smoothing belief (slam_env.smoothing.ISAM2SLAM; the gtsam extra).
SMOOTHER = "known/isam2"

# --------------------------------------------------------------------------- filters


def filter_kwargs(recording: Recording) -> dict[str, Any]:
    """The noise-matched filter ActiveSLAM-v0 builds for this episode's env."""
    ep = recording.episode
    noise = "alphas" if ep.motion_model == "odometry" else "control_noise"
    return {
        "motion_model": ep.motion_model,
        "measurement_model": ep.measurement_model,
        noise: ep.motion_params,
        "measurement_cov": ep.measurement_cov,
        "max_landmarks": recording.n_slots,
        "initial_pose": ep.start_pose,
        "initial_pose_cov": np.zeros((3, 3)),
        "gate": DEFAULT_GATE,
    }


def smoother_kwargs(recording: Recording) -> dict[str, Any]:
    """``ISAM2SLAM``'s noise-matched arguments: :func:`filter_kwargs` less the gate (the
    smoother gates nothing)."""
    kwargs = filter_kwargs(recording)
    kwargs.pop("gate")
    return kwargs


def hides_ids(kwargs: dict[str, Any]) -> bool:
    """Whether the variant associates by itself (it then gets no IDs)."""
    return kwargs.get("data_association", "known") != "known"


# The rows the table can have, in its order: the smoother and the ideal EKF after the
# known-ID filters; every row but the smoother's by default (it needs an extra).
ROWS = (
    *(name for name in VARIANTS if not hides_ids(VARIANTS[name])),
    SMOOTHER,
    IDEAL,
    *(name for name in VARIANTS if hides_ids(VARIANTS[name])),
)
DEFAULT_ROWS = tuple(name for name in ROWS if name != SMOOTHER)


@dataclass
class FilterRun:
    """One variant on one episode: the pose NEES per step (T,), the filtered poses
    (T+1, 3), the final map RMSE (m), the final map (ID → (2,); filter-owned IDs for
    an associating variant), and its association scores (:data:`SCORE_NAMES`; zeros
    for a variant told the IDs)."""

    nees: np.ndarray
    poses: np.ndarray
    rmse: float
    landmarks: dict[int, np.ndarray]
    scores: np.ndarray


def score(
    result: Any, true_ids: np.ndarray, n_before: int, slot_truth: np.ndarray, episode: np.ndarray
) -> None:
    """Score one update of an associating variant against the truth with the env's
    own rules (:func:`slam_env.kernels.ekf.association_score.score_association`): the
    counts go to ``episode`` (1, 4), the truth of each landmark it started to
    ``slot_truth`` (1, M)."""
    k = len(true_ids)
    score_association(
        result.ids.reshape(1, k), result.status.reshape(1, k), true_ids.reshape(1, k),
        np.array([k]), np.array([n_before]), slot_truth, np.ones(1, dtype=np.bool_),
        np.zeros((1, len(SCORE_NAMES)), dtype=np.int64), episode,
    )  # fmt: skip


def follow(
    recording: Recording,
    belief: Any,
    step: Callable[[int, np.ndarray, np.ndarray], UpdateResult | None],
    hide: bool,
) -> FilterRun:
    """Drive ``belief`` over the recorded episode: ``step(t, z, ids)`` predicts and
    updates it with step t's control and detections (all of them when ``hide``, else
    the labelled ones) and returns the update's result (None without detections).
    ``belief`` is an :class:`EKFSLAM`, an :class:`IdealEKF` or an ``ISAM2SLAM``."""
    T = recording.episode.n_steps
    nees_t = np.empty(T)
    poses = np.empty((T + 1, 3))
    poses[0] = belief.pose
    slot_truth = np.full((1, max(belief.max_landmarks, 1)), -1, dtype=np.int64)
    scores = np.zeros((1, len(SCORE_NAMES)), dtype=np.int64)
    for t in range(1, T + 1):
        z, ids = recording.detections[t - 1]
        if not hide:
            z, ids = z[ids >= 0], ids[ids >= 0]
        n_before = belief.n_landmarks
        result = step(t, z, ids)
        if hide and result is not None:
            score(result, ids, n_before, slot_truth, scores)
        poses[t] = belief.pose
        nees_t[t - 1] = nees(pose_error(belief.pose, recording.true_poses[t]), belief.pose_cov)
    means = belief.landmark_means()
    landmarks = {int(i): means[k] for k, i in enumerate(belief.state_to_id.tolist())}
    # Each filter landmark against its true one (for an associating filter: the one
    # whose detection started it; none for clutter).
    owner = {i: int(slot_truth[0, i]) for i in landmarks} if hide else {i: i for i in landmarks}
    mine = [i for i in landmarks if owner[i] >= 0]
    rmse = map_rmse(
        np.array([landmarks[i] for i in mine]).reshape(-1, 2),
        np.array([recording.truth[owner[i]] for i in mine]).reshape(-1, 2),
    )
    return FilterRun(nees_t, poses, rmse, landmarks, scores[0])


def run_filter(recording: Recording, kwargs: dict[str, Any]) -> FilterRun:
    """One variant over the recorded episode."""
    f = EKFSLAM(**{**filter_kwargs(recording), **kwargs})
    hide = hides_ids(kwargs)
    controls = recording.episode.controls

    def step(t: int, z: np.ndarray, ids: np.ndarray) -> UpdateResult | None:
        f.predict(controls[t - 1])
        return f.update(z, None if hide else ids) if len(ids) else None

    return follow(recording, f, step, hide)


def run_ideal(recording: Recording) -> FilterRun:
    """The ideal EKF over the recorded episode, known IDs, every Jacobian at the truth:
    G and V at the true pose the step starts from, H at the true pose and landmark, L
    and W at the true pose."""
    f = IdealEKF(**filter_kwargs(recording))
    controls, true_poses = recording.episode.controls, recording.true_poses

    def step(t: int, z: np.ndarray, ids: np.ndarray) -> UpdateResult | None:
        f.predict(controls[t - 1], at_pose=true_poses[t - 1])
        if not len(ids):
            return None
        return f.update(z, ids, at_pose=true_poses[t], at_landmarks=recording.truth)

    return follow(recording, f, step, hide=False)


def run_smoother(recording: Recording) -> FilterRun:
    """The smoothing belief (``ISAM2SLAM``, its defaults) over the recorded episode,
    known IDs, noise-matched as the filters; an update every step, with or without
    detections, so that every step has its pose variable."""
    from slam_env.smoothing import ISAM2SLAM  # the gtsam extra, checked in parse_args

    belief = ISAM2SLAM(**smoother_kwargs(recording))
    controls = recording.episode.controls

    def step(t: int, z: np.ndarray, ids: np.ndarray) -> UpdateResult:
        belief.predict(controls[t - 1])
        return belief.update(z, ids)

    return follow(recording, belief, step, hide=False)


def run_row(recording: Recording, name: str) -> FilterRun:
    """The belief of row ``name`` (:data:`ROWS`) over the recorded episode."""
    if name == IDEAL:
        return run_ideal(recording)
    if name == SMOOTHER:
        return run_smoother(recording)
    return run_filter(recording, VARIANTS[name])


# --------------------------------------------------------------------------- main


@dataclass
class Tally:
    """What one variant collected: per run it completed (``runs``, indices into the
    episodes), the pose NEES per step and the final map RMSE; ``failures`` counts the
    runs in which the belief refused a call (``FloatingPointError``); ``seconds`` and
    ``steps``: the CPU time it took and the steps it ran, over every run."""

    runs: list[int] = field(default_factory=list)
    nees: list[np.ndarray] = field(default_factory=list)
    rmse: list[float] = field(default_factory=list)
    scores: np.ndarray = field(default_factory=lambda: np.zeros(len(SCORE_NAMES), np.int64))
    failures: int = 0
    seconds: float = 0.0
    steps: int = 0


@dataclass
class SmootherTally:
    """The smoother's final map RMSE, 2·cost/dof and convergence, per episode."""

    rmse: list[float] = field(default_factory=list)
    chi2_per_dof: list[float] = field(default_factory=list)
    converged: list[bool] = field(default_factory=list)
    seen: list[float] = field(default_factory=list)  # share of the landmarks seen


def evaluate(
    env: gym.Env, args: argparse.Namespace, rows: Sequence[str]
) -> tuple[dict[str, Tally], SmootherTally, dict[str, float]]:
    """Every episode (on ``env``) through the filter of every row (:data:`ROWS`) and the
    smoother; also the seconds spent on the env and driver, the filters and the smoother."""
    tallies = {name: Tally() for name in rows}
    ls = SmootherTally()
    clock = {"env": 0.0, "filters": 0.0, "smoother": 0.0}
    for r in range(args.runs):
        start = time.perf_counter()
        recording = record_episode(env, args.seed + r, args.steps)
        clock["env"] += time.perf_counter() - start
        start = time.perf_counter()
        runs: dict[str, FilterRun] = {}
        for name in dict.fromkeys([BASELINE, *rows]):
            cpu = time.process_time()
            try:
                runs[name] = run_row(recording, name)
            except FloatingPointError:
                if name in tallies:
                    tallies[name].failures += 1
            if name in tallies:
                tallies[name].seconds += time.process_time() - cpu
                tallies[name].steps += recording.episode.n_steps
        for name, run in runs.items():
            if name in tallies:
                tallies[name].runs.append(r)
                tallies[name].nees.append(run.nees)
                tallies[name].rmse.append(run.rmse)
                tallies[name].scores += run.scores
        clock["filters"] += time.perf_counter() - start
        start = time.perf_counter()
        base = runs.get(BASELINE)
        fit = smooth(
            recording.episode,
            None if base is None else base.poses,
            None if base is None else base.landmarks,
        )
        clock["smoother"] += time.perf_counter() - start
        truth = np.array([recording.truth[i] for i in fit.landmark_ids.tolist()])
        ls.rmse.append(map_rmse(fit.landmarks, truth.reshape(-1, 2)))
        ls.chi2_per_dof.append(2.0 * fit.cost / max(fit.redundancy, 1))
        ls.converged.append(fit.success)
        ls.seen.append(len(fit.landmark_ids) / recording.n_landmarks)
    return tallies, ls, clock


def print_table(
    args: argparse.Namespace,
    tallies: dict[str, Tally],
    ls: SmootherTally,
    clock: dict[str, float],
) -> None:
    lower, upper = nees_band(3, args.runs)
    print(
        f"{ENV_ID}, default world: {args.runs} runs × {args.steps} steps, odometry α × "
        f"{args.odometry_scale:g}, clutter {args.clutter:g}, "
        f"seeds {args.seed}..{args.seed + args.runs - 1}; landmarks seen "
        f"{100 * np.mean(ls.seen):.0f}%; 95% band of the averaged pose NEES "
        f"[{lower:.2f}, {upper:.2f}]"
    )
    print(
        f"time: env + driver {clock['env']:.1f} s, filters {clock['filters']:.1f} s, "
        f"smoother {clock['smoother']:.1f} s; smoother 2·cost/dof "
        f"{np.mean(ls.chi2_per_dof):.3f} (1 when the noise models hold), "
        f"{ls.converged.count(False)} fits not converged"
    )
    w = max([16, *(len(name) + 2 for name in tallies)])
    header = (
        f"{'variant':<{w}}{'in band':>9}{'mean NEES':>11}{'map RMSE':>10}{'LS RMSE':>9}"
        f"{'ratio':>7}{'correct':>9}{'wrong':>7}{'missed':>8}{'dup':>5}{'ms/step':>9}"
    )
    print(header)
    print("-" * len(header))
    for name, tally in tallies.items():
        band = share_in_nees_band(tally.nees, dof=3, first_step=0)
        values = np.concatenate(tally.nees) if tally.nees else np.array([math.nan])
        mean_nees = (
            float(np.mean(values[np.isfinite(values)])) if np.isfinite(values).any() else math.nan
        )
        ekf = float(np.mean(tally.rmse)) if tally.rmse else math.nan
        ms = 1e3 * tally.seconds / max(tally.steps, 1)
        best = float(np.mean([ls.rmse[r] for r in tally.runs])) if tally.runs else math.nan
        note = f"  ({tally.failures} runs failed, left out)" if tally.failures else ""
        correct, wrong, missed, dup = tally.scores.tolist()
        if name in VARIANTS and hides_ids(VARIANTS[name]):
            share = correct / max(correct + wrong + missed, 1)
            association = f"{100 * share:>8.2f}%{wrong:>7}{missed:>8}{dup:>5}"
        else:
            association = f"{'-':>9}{'-':>7}{'-':>8}{'-':>5}"
        print(
            f"{name:<{w}}{100 * band:>8.1f}%{mean_nees:>11.2f}{ekf:>10.4f}"
            f"{best:>9.4f}{ekf / best:>7.2f}{association}{ms:>9.3f}{note}"
        )


SCENARIOS = ("env", "ukfm-slam2d")
# runs and steps by default, per scenario
DEFAULT_LENGTHS = {"env": (30, 500), "ukfm-slam2d": (ukfm_slam2d.RUNS, ukfm_slam2d.STEPS)}


def parse_args(argv: Sequence[str] | None = None) -> tuple[argparse.Namespace, gym.Env | None]:
    """The arguments, and the env the episodes run on (None for ``ukfm-slam2d``)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--scenario", choices=SCENARIOS, default="env",
        help="the env's default world (env), or ukfm's slam2d setting",
    )  # fmt: skip
    parser.add_argument(
        "--runs", type=positive_int, default=None, help="Monte Carlo episodes (30; ukfm 100)"
    )
    parser.add_argument(
        "--steps", type=positive_int, default=None, help="steps per episode (500; ukfm 2500)"
    )
    parser.add_argument("--odometry-scale", type=float, default=1.0, help="multiplies α1..α4")
    parser.add_argument(
        "--seed", type=non_negative_int, default=0, help="episode r is reset with seed + r"
    )
    parser.add_argument(
        "--variants",
        nargs="+",
        default=list(DEFAULT_ROWS),
        help=f"any of {', '.join(ROWS)} (default all but {SMOOTHER}, which needs gtsam)",
    )
    parser.add_argument("--clutter", type=float, default=0.0, help="the env's clutter_rate")
    args = parser.parse_args(argv)
    runs, steps = DEFAULT_LENGTHS[args.scenario]
    args.runs = runs if args.runs is None else args.runs
    args.steps = steps if args.steps is None else args.steps
    if args.scenario == "ukfm-slam2d":
        if args.steps < 2:
            parser.error(f"--steps must be >= 2 for ukfm-slam2d, got {args.steps}")
        env_only = [
            flag
            for flag, value, default in (
                ("--odometry-scale", args.odometry_scale, 1.0),
                ("--clutter", args.clutter, 0.0),
                ("--variants", args.variants, list(DEFAULT_ROWS)),
            )
            if value != default
        ]
        if env_only:
            parser.error(f"{', '.join(env_only)}: not options of --scenario ukfm-slam2d")
        return args, None
    if not args.odometry_scale > 0.0:
        parser.error(f"--odometry-scale must be > 0, got {args.odometry_scale}")
    unknown = [v for v in args.variants if v not in ROWS]
    if unknown:
        parser.error(f"unknown variants {unknown}; choose from {list(ROWS)}")
    if SMOOTHER in args.variants:
        try:
            require("gtsam", f"--variants {SMOOTHER}")
        except MissingExtra as err:
            parser.error(str(err))
    try:  # the env's own checks (ranges, the noise budget), before any episode is run
        env = gym.make(
            ENV_ID, max_episode_steps=args.steps, **env_options(args.odometry_scale, args.clutter)
        )
    except ValueError as err:
        parser.error(f"--odometry-scale {args.odometry_scale}, --clutter {args.clutter}: {err}")
    return args, env


def main(argv: Sequence[str] | None = None) -> None:
    args, env = parse_args(argv)
    if env is None:
        ukfm_slam2d.print_table(args.runs, args.steps, args.seed)
        return
    with env:
        print_table(args, *evaluate(env, args, args.variants))


if __name__ == "__main__":
    main()
