"""iSAM2 SLAM (slam_env.smoothing.ISAM2SLAM): time per step, its growth over a long
episode, and map accuracy against the batch least-squares optimum.

    .venv-gtsam/bin/python -m benchmarks.bench_smoothing [--steps 500] [--long-steps 2000]
        [--runs 3] [--seed 0] [--odometry-scales 1 4] [--motion-factor between]
        [--relinearize-threshold 0.02] [--relinearize-skip 1] [--keyframes K] [--window N]
        [--repeats 3] [--skip-timing] [--skip-env] [--skip-association]
        [--skip-growth] [--skip-accuracy]

The data is ``slam_env/Landmarks-v0`` on the default world (20 landmarks), driven by
``consistency_episodes``' ``TourDriver`` (a tour of the landmarks from the true pose and
back home, round again), recorded once per seed; every estimator gets the same
readings, the labelled detections with their IDs, noise-matched (the env's own α1..α4
and Q, the true start with zero covariance).

* Timing: one *step* is ``predict(u)`` and ``update(z, ids)`` (``update`` every step,
  with or without detections) on a ``--steps`` episode (seed ``--seed``), timed step by
  step in this process's CPU time (``time.process_time``: on a shared machine the wall
  clock counts the neighbours too), each step's time the least over ``--repeats``
  runs; the mean and median per step, the same with the belief read as the env would
  read it (``mean`` and ``cov`` after each update), and ``EKFSLAM`` on the same data
  for scale.
* Env: ``ActiveSLAM-v0``'s whole step (``env.step``, CPU time) with ``belief="ekf"`` and
  ``belief="isam2"`` (the options given), the same tour on the same seed (it steers by
  the true pose): what the smoothing belief costs a user of the env, the joint
  marginal that every observation needs included.
* Association: ``ActiveSLAM-v0`` with hidden IDs (``report_ids=False``), NN and JCBB
  on each belief (on the smoothing one they associate against its joint marginal),
  ``--runs`` seeds of ``--steps`` steps on the tour: the association's scores against
  the truth (``info["association_episode"]``) and the final map RMSE.
* Growth: a ``--long-steps`` episode with the options given (by default no keyframes,
  no window), timed the same way; the mean step time over the first and the last
  hundred steps and their ratio, with the pose variables and landmarks at the end.
* Accuracy: ``--runs`` seeds at each of ``--odometry-scales`` (a factor on the env's
  α1..α4: 4 is four times the odometry variance): the final map RMSE against the truth
  of the incremental estimate (no full update), of the same after ``optimize()`` (the
  full update), of the EKF, and of ``references.smoother.smooth`` (the batch optimum,
  started from the incremental estimate), and the ratios to the batch optimum.

Targets (issue #49): ≤ 2 ms a step on average on the 500-step episode; ≤ 3× from the
first to the last hundred steps of the 2,000-step one; incremental map RMSE within
1.02× of the batch optimum's.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from typing import Any

from agents.common.arguments import non_negative_int, positive_int  # argparse only

ACTIVE_ID = "slam_env/ActiveSLAM-v0"


def estimator_kwargs(recording: Any, args: argparse.Namespace) -> dict[str, Any]:
    """ISAM2SLAM's arguments for one recorded episode: the noise-matched models
    (``bench_consistency.smoother_kwargs``) and the options."""
    from benchmarks.bench_consistency import smoother_kwargs

    return {
        **smoother_kwargs(recording),
        "motion_factor": args.motion_factor,
        "relinearize_threshold": args.relinearize_threshold,
        "relinearize_skip": args.relinearize_skip,
        "keyframes": args.keyframes,
        "window": args.window,
    }


def labelled(recording: Any) -> list[tuple[Any, Any]]:
    """Each step's detections the env labelled (ID ≥ 0)."""
    return [(z[ids >= 0], ids[ids >= 0]) for z, ids in recording.detections]


def run_timed(belief: Any, recording: Any, read: bool) -> Any:
    """CPU seconds of each step (predict, update, and ``mean``/``cov`` when ``read``)."""
    import numpy as np

    controls = recording.episode.controls
    detections = labelled(recording)
    seconds = np.empty(len(controls))
    clock = time.process_time
    for t, (u, (z, ids)) in enumerate(zip(controls, detections, strict=True)):
        start = clock()
        belief.predict(u)
        belief.update(z, ids)
        if read:
            belief.mean  # noqa: B018 - the read is what is timed
            belief.cov  # noqa: B018
        seconds[t] = clock() - start
    return seconds


def least(make: Any, recording: Any, read: bool, repeats: int) -> Any:
    """Each step's least CPU time over ``repeats`` runs of fresh ``make()`` beliefs."""
    import numpy as np

    return np.min([run_timed(make(), recording, read) for _ in range(repeats)], axis=0)


def record(seed: int, steps: int, scale: float) -> Any:
    import gymnasium as gym

    from benchmarks.consistency_episodes import ENV_ID, env_options, record_episode

    with gym.make(ENV_ID, max_episode_steps=steps, **env_options(scale, 0.0)) as env:
        return record_episode(env, seed, steps)


def timing(args: argparse.Namespace) -> None:
    import numpy as np

    from benchmarks.bench_consistency import filter_kwargs
    from slam_env.ekf import EKFSLAM
    from slam_env.smoothing import ISAM2SLAM

    rec = record(args.seed, args.steps, 1.0)
    T = rec.episode.n_steps
    print(f"timing: {T} steps, {rec.n_landmarks} landmarks, seed {args.seed}")
    rows = []
    for name, make, read in (
        ("ISAM2SLAM", lambda: ISAM2SLAM(**estimator_kwargs(rec, args)), False),
        ("ISAM2SLAM + mean/cov read", lambda: ISAM2SLAM(**estimator_kwargs(rec, args)), True),
        ("EKFSLAM", lambda: EKFSLAM(**filter_kwargs(rec)), False),
    ):
        make().update(np.empty((0, 2)), np.empty(0, dtype=np.int64))  # warm any compile
        seconds = least(make, rec, read, args.repeats)
        rows.append((name, 1e3 * seconds.mean(), 1e3 * np.median(seconds), 1e3 * seconds.max()))
    print(f"  {'':28s} {'mean ms':>8s} {'median':>8s} {'max':>8s}")
    for name, mean, median, worst in rows:
        print(f"  {name:28s} {mean:8.3f} {median:8.3f} {worst:8.3f}")


def env_timing(args: argparse.Namespace) -> None:
    """``ActiveSLAM-v0``'s step on each belief, driven by the same tour (it steers by
    the true pose, so both beliefs see the same actions and worlds)."""
    import gymnasium as gym
    import numpy as np

    import slam_env  # noqa: F401  (registers the env IDs)

    print(f"env: {ACTIVE_ID}'s step, {args.steps} steps, seed {args.seed}, least of {args.repeats}")
    rows = {}
    for belief in ("ekf", "isam2"):
        runs = []
        for _ in range(args.repeats):
            options = {} if belief == "ekf" else _smoothing_options(args)
            env = gym.make(ACTIVE_ID, max_episode_steps=args.steps, belief=belief, **options)
            seconds, info = tour(env, args.seed, args.steps)
            runs.append(seconds)
            env.close()
        rows[belief] = (np.min(runs, axis=0), info["landmarks_known"])
    print(f"  {'belief':8s} {'mean ms':>8s} {'median':>8s} {'last 100':>9s} {'landmarks':>10s}")
    for belief, (seconds, known) in rows.items():
        print(
            f"  {belief:8s} {1e3 * seconds.mean():8.3f} {1e3 * np.median(seconds):8.3f} "
            f"{1e3 * seconds[-100:].mean():9.3f} {known:10d}"
        )
    ratio = rows["isam2"][0].mean() / rows["ekf"][0].mean()
    print(f"  isam2 / ekf: {ratio:.1f}x")


def association(args: argparse.Namespace) -> None:
    """Hidden IDs in ``ActiveSLAM-v0``: the filter's NN and JCBB on each belief (on the
    smoothing belief they run against its joint marginal), the same tour and seeds;
    the association's scores summed over the episodes and the mean final map RMSE."""
    import gymnasium as gym
    import numpy as np

    import slam_env  # noqa: F401  (registers the env IDs)
    from slam_env.kernels.ekf.association_score import SCORE_NAMES

    seeds = range(args.seed, args.seed + args.runs)
    print(f"association: hidden IDs, {args.runs} runs × {args.steps} steps (seeds {seeds.start}..)")
    print(f"  {'association':18s} {'belief':7s} " + " ".join(f"{n:>10s}" for n in SCORE_NAMES)
          + f" {'map RMSE':>9s}")  # fmt: skip
    for method in ("nearest_neighbor", "jcbb"):
        for belief in ("ekf", "isam2"):
            options = {} if belief == "ekf" else _smoothing_options(args)
            env = gym.make(
                ACTIVE_ID, max_episode_steps=args.steps, belief=belief, report_ids=False,
                data_association=method, **options,
            )  # fmt: skip
            scores, rmse = np.zeros(len(SCORE_NAMES), dtype=np.int64), []
            for seed in seeds:
                _, info = tour(env, seed, args.steps)
                scores += [info["association_episode"][n] for n in SCORE_NAMES]
                rmse.append(info.get("map_rmse", np.nan))
            env.close()
            print(f"  {method:18s} {belief:7s} " + " ".join(f"{v:10d}" for v in scores)
                  + f" {np.nanmean(rmse):9.4f}")  # fmt: skip


def tour(env: Any, seed: int, steps: int) -> tuple[Any, dict[str, Any]]:
    """One episode of ``ActiveSLAM-v0`` ``env`` reset with ``seed``, driven by
    ``TourDriver`` on the true pose for up to ``steps`` steps: each step's CPU time
    (``env.step`` alone) and the last info. The driver ticks off landmarks by the raw
    core's true detections (the belief observation does not carry them, and with
    hidden IDs the raw one would not say which landmark was seen)."""
    import numpy as np

    from benchmarks.consistency_episodes import TourDriver

    _, info = env.reset(seed=seed)
    driver = TourDriver(env)
    raw = env.unwrapped._core.raw
    seconds = []
    for _ in range(steps):
        action = driver.act(np.asarray(info["pose"], dtype=np.float64))
        start = time.process_time()
        _, _, terminated, truncated, info = env.step(action)
        seconds.append(time.process_time() - start)
        k = int(raw.det_count[0])
        driver.observe(raw.det_z[0, :k].copy(), raw.det_ids[0, :k].copy())
        if terminated or truncated:
            break
    return np.array(seconds), info


def _smoothing_options(args: argparse.Namespace) -> dict[str, Any]:
    return {
        "smoothing_relinearize_threshold": args.relinearize_threshold,
        "smoothing_relinearize_skip": args.relinearize_skip,
        "smoothing_keyframes": args.keyframes,
        "smoothing_window": args.window,
    }


def growth(args: argparse.Namespace) -> None:
    from slam_env.smoothing import ISAM2SLAM

    rec = record(args.seed, args.long_steps, 1.0)
    T = rec.episode.n_steps
    beliefs = []

    def make() -> ISAM2SLAM:
        beliefs.append(ISAM2SLAM(**estimator_kwargs(rec, args)))
        return beliefs[-1]

    seconds = least(make, rec, False, args.repeats)
    belief = beliefs[-1]
    first, last = seconds[:100].mean(), seconds[-100:].mean()
    print(
        f"growth: {T} steps: first 100 {1e3 * first:.3f} ms/step, last 100 "
        f"{1e3 * last:.3f} ms/step, ratio {last / first:.2f} ({belief.n_poses} poses, "
        f"{belief.n_landmarks} landmarks, whole episode {seconds.sum():.1f} s)"
    )


def accuracy(args: argparse.Namespace) -> None:
    import numpy as np

    from benchmarks.bench_consistency import filter_kwargs
    from references.smoother import smooth
    from slam_env.belief.metrics import map_rmse
    from slam_env.ekf import EKFSLAM
    from slam_env.smoothing import ISAM2SLAM

    print(f"accuracy: {args.runs} runs × {args.steps} steps, final map RMSE (m)")
    print(
        f"  {'scale':>5s} {'seed':>4s} {'iSAM2':>8s} {'+full':>8s} {'EKF':>8s} {'batch':>8s} "
        f"{'iSAM2/LS':>8s} {'full/LS':>8s} {'EKF/LS':>8s}"
    )
    for scale in args.odometry_scales:
        ratios = []
        for r in range(args.runs):
            seed = args.seed + r
            rec = record(seed, args.steps, scale)
            belief = ISAM2SLAM(**estimator_kwargs(rec, args))
            ekf = EKFSLAM(**filter_kwargs(rec))
            for u, (z, ids) in zip(rec.episode.controls, labelled(rec), strict=True):
                belief.predict(u)
                belief.update(z, ids)
                ekf.predict(u)
                if len(ids):
                    ekf.update(z, ids)

            def rmse(ids: Any, means: Any, truth: dict = rec.truth) -> float:
                return map_rmse(means, np.array([truth[int(i)] for i in ids]).reshape(-1, 2))

            incremental = rmse(belief.state_to_id, belief.landmark_means())
            ekf_rmse = rmse(ekf.state_to_id, ekf.landmark_means())
            # The batch optimum, started from the smoother's own trajectory and map.
            _, poses = belief.trajectory()
            start = None
            marks = dict(zip(belief.state_to_id.tolist(), belief.landmark_means(), strict=True))
            if args.keyframes is None and args.window is None:
                start = poses
            best = smooth(rec.episode, start, marks)
            batch = rmse(best.landmark_ids, best.landmarks)
            belief.optimize()
            full = rmse(belief.state_to_id, belief.landmark_means())
            ratios.append((incremental / batch, full / batch, ekf_rmse / batch))
            print(
                f"  {scale:5g} {seed:4d} {incremental:8.4f} {full:8.4f} {ekf_rmse:8.4f} "
                f"{batch:8.4f} {ratios[-1][0]:8.4f} {ratios[-1][1]:8.4f} {ratios[-1][2]:8.4f}"
            )
        mean = np.mean(ratios, axis=0)
        print(
            f"  {scale:5g} {'mean':>4s} {'':8s} {'':8s} {'':8s} {'':8s} "
            f"{mean[0]:8.4f} {mean[1]:8.4f} {mean[2]:8.4f}"
        )


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=positive_int, default=500, help="steps per episode")
    parser.add_argument(
        "--long-steps", type=positive_int, default=2000, help="steps of the growth episode"
    )
    parser.add_argument("--runs", type=positive_int, default=3, help="seeds per noise scale")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="the first seed")
    parser.add_argument(
        "--odometry-scales", type=float, nargs="+", default=[1.0, 4.0], help="factors on α1..α4"
    )
    parser.add_argument("--motion-factor", choices=("reference", "between"), default="between")
    parser.add_argument("--relinearize-threshold", type=float, default=0.02)
    parser.add_argument("--relinearize-skip", type=positive_int, default=1)
    parser.add_argument("--keyframes", type=positive_int, default=None, help="every K steps")
    parser.add_argument("--window", type=positive_int, default=None, help="keep N poses")
    parser.add_argument(
        "--repeats", type=positive_int, default=3, help="timed runs (each step's least)"
    )
    parser.add_argument("--skip-timing", action="store_true")
    parser.add_argument("--skip-growth", action="store_true")
    parser.add_argument("--skip-env", action="store_true", help="no ActiveSLAM-v0 step timing")
    parser.add_argument(
        "--skip-association", action="store_true", help="no hidden-ID runs of ActiveSLAM-v0"
    )
    parser.add_argument("--skip-accuracy", action="store_true")
    args = parser.parse_args(argv)
    for scale in args.odometry_scales:
        if not 0.0 < scale < float("inf"):
            parser.error(f"--odometry-scales must be > 0 and finite, got {scale}")
    if not 0.0 <= args.relinearize_threshold < float("inf"):
        parser.error(f"--relinearize-threshold must be >= 0, got {args.relinearize_threshold}")
    if args.long_steps < 200 and not args.skip_growth:
        parser.error("--long-steps must be >= 200 (a first and a last hundred)")
    return args


def main(argv: Sequence[str] | None = None) -> None:
    args = parse_args(argv)
    from slam_env.extras import MissingExtra, require

    try:
        require("gtsam", "benchmarks.bench_smoothing")
    except MissingExtra as err:
        raise SystemExit(str(err)) from None
    if not args.skip_timing:
        timing(args)
    if not args.skip_env:
        env_timing(args)
    if not args.skip_association:
        association(args)
    if not args.skip_growth:
        growth(args)
    if not args.skip_accuracy:
        accuracy(args)


if __name__ == "__main__":
    main()
