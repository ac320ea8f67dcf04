"""EKF-SLAM filter step cost: slam_env.ekf.EKFSLAM against the dense textbook filter.

    .venv/bin/python benchmarks/bench_filter.py [--quick] [--correction batch]
                     [--sizes 10 20 50 100 200] [--threads 1] [--clock wall|cpu]

One *step* is one prediction and one update with 5 observations of known landmarks
(range-bearing, odometry motion), with N landmarks in the state. The same steps run
on the dense textbook EKF-SLAM of ``tests/ekf/dense_reference.py`` (full G, R, H,
K = ΣHᵀS⁻¹ and the Joseph form as (I−KH)Σ(I−KH)ᵀ + KQKᵀ), loaded by file path, and
the *floor* is the time to merely copy Σ five times (``np.copyto`` into a ready
buffer): the memory traffic no correction that touches all of Σ can avoid.
BLAS runs single-threaded by default (``--threads``), so that both filters get the
same single core and the ratio means the same thing on any machine. Each figure is
the best of ``--repeats`` short timed blocks: on a shared machine noise only adds
time, and short blocks are the likeliest to run undisturbed.

Targets: at N = 200 at least 30× faster than dense and within 3× of the floor; at
N = 20 at least 3× faster than dense (where per-call overhead, not Σ, dominates).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
ALPHAS = (0.01, 0.005, 0.01, 0.005)
RANGE_STD, BEARING_STD = 0.05, 0.0175


def load_dense_reference() -> Any:
    name = "slam_env_tests_ekf_dense_reference"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            name, ROOT / "tests" / "ekf" / "dense_reference.py"
        )
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def best_time(fn: Any, block: float, repeats: int, clock: Any = time.perf_counter) -> float:
    """Seconds per call of ``fn``: the best of ``repeats`` blocks of ~``block`` s."""
    fn()  # warm up
    start = time.perf_counter()
    fn()
    once = max(time.perf_counter() - start, 1e-7)
    calls = max(1, int(block / once))
    best = float("inf")
    for _ in range(repeats):
        start = clock()
        for _ in range(calls):
            fn()
        best = min(best, (clock() - start) / calls)
    return best


def make_filters(n: int, correction: str) -> tuple[Any, Any, Any]:
    """Our filter and the dense one with the same n landmarks in the state, and a
    ``step(filter)`` that alternates a move forward and back with 5 observations."""
    import numpy as np

    from slam_env.ekf import EKFSLAM
    from slam_env.ekf.models import odometry_motion, range_bearing_h

    dense_reference = load_dense_reference()
    rng = np.random.default_rng(n)
    landmarks = rng.uniform(-10.0, 10.0, size=(n, 2))
    Q = np.diag([RANGE_STD**2, BEARING_STD**2])
    prior = np.diag([1e-3, 1e-3, 1e-4])
    ours = EKFSLAM(
        alphas=ALPHAS,
        measurement_cov=Q,
        max_landmarks=n,
        initial_pose_cov=prior,
        correction=correction,
    )
    dense = dense_reference.DenseEKFSLAM(
        "odometry",
        "range_bearing",
        Q,
        alphas=ALPHAS,
        initial_pose_cov=prior,
        correction=correction,
    )
    pose0 = np.zeros(3)
    z_all = range_bearing_h(pose0, landmarks)
    for f in (ours, dense):
        f.update(z_all, np.arange(n))
    ids = rng.choice(n, size=5, replace=False)
    forward, back = (0.01, 0.05, -0.01), (0.01, -0.05, -0.01)
    pose1 = odometry_motion(pose0, forward)
    z1 = range_bearing_h(pose1, landmarks[ids]) + rng.normal(size=(5, 2)) * [RANGE_STD, 0.01]
    z0 = range_bearing_h(odometry_motion(pose1, back), landmarks[ids])

    def two_steps(f: Any) -> None:
        f.predict(forward)
        f.update(z1, ids)
        f.predict(back)
        f.update(z0, ids)

    return ours, dense, two_steps


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short timings (a smoke run)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 20, 50, 100, 200])
    parser.add_argument("--correction", choices=["sequential", "batch"], default="sequential")
    parser.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument(
        "--clock",
        choices=sorted(CLOCKS),
        default="wall",
        help="wall time, or this process's CPU time (steadier on a busy shared machine)",
    )
    args = parser.parse_args(argv)
    # BLAS reads these when numpy is first imported, hence the late imports below.
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = str(args.threads)
    import numpy as np

    block = 0.01 if args.quick else 0.02
    repeats = args.repeats or (5 if args.quick else 40)

    rows = []
    for n in args.sizes:
        ours, dense, two_steps = make_filters(n, args.correction)
        # Sanity: both filters hold the same belief after the same steps.
        for f in (ours, dense):
            two_steps(f)
        gap = max(np.abs(ours.mean - dense.mean).max(), np.abs(ours.cov - dense.cov).max())
        clock = CLOCKS[args.clock]
        t_ours = best_time(lambda f=ours, step=two_steps: step(f), block, repeats, clock) / 2
        dense_repeats = repeats if n <= 50 else max(3, repeats // 4)
        t_dense = best_time(lambda f=dense, step=two_steps: step(f), block, dense_repeats, clock)
        t_dense /= 2
        d = 3 + 2 * n
        P = ours.cov
        buf = np.empty_like(P)

        def five_copies(P: Any = P, buf: Any = buf) -> None:
            for _ in range(5):
                np.copyto(buf, P)

        t_floor = best_time(five_copies, block, repeats, clock)
        rows.append((n, d, t_ours, t_dense, t_floor, gap))

    print(
        f"EKF-SLAM step = 1 predict + 5 corrections of known landmarks "
        f"({args.correction}, odometry + range-bearing), BLAS threads = {args.threads}, "
        f"{args.clock} clock\n"
    )
    print(
        "| N | dim | EKFSLAM µs | dense µs | dense / EKFSLAM | floor µs (5 × copy Σ) "
        "| EKFSLAM / floor | max |Δ| vs dense |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n, d, t_ours, t_dense, t_floor, gap in rows:
        print(
            f"| {n} | {d} | {t_ours * 1e6:.1f} | {t_dense * 1e6:.1f} | {t_dense / t_ours:.1f}× "
            f"| {t_floor * 1e6:.1f} | {t_ours / t_floor:.1f}× | {gap:.1e} |"
        )


if __name__ == "__main__":
    main()
