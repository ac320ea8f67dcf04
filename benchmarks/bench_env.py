"""Env throughput: slam_env steps per second against CartPole-v1 in the same run.

    .venv/bin/python -m benchmarks.bench_env [--steps 20000] [--repeats 3]
                     [--wrapped] [--vector 8 64 256] [--vector-ids Landmarks ActiveSLAM]
                     [--vector-steps 600] [--threads 1 2]

Every single env is made with ``gym.make`` (so each carries the same standard
wrappers), every native vector env with ``gym.make_vec(..., "vector_entry_point")``
beside CartPole-v1's own vector env at the same number of sub-envs; all are stepped
with pre-sampled random actions (an episode that ends is reset: by the loop for a
single env, by the vector env itself otherwise). A vector env's rate counts env-steps
(sub-envs × vector steps) per second. The repeats take turns: each round times every
env once, so a slow spell of a shared machine hits all of them, and the best of
``--repeats`` rounds is kept for each (and the median reported beside it, with the
CPU time of the process, all its threads, per env-step of the median round). The figures
that matter are the ratios measured in the same run, against CartPole-v1's single env;
"× ref" compares a row with the one it is measured against: a wrapped env with the raw
env it wraps, a native vector env on T > 1 threads (``num_threads``) with the same
one on a single thread.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from typing import Any

import gymnasium as gym

import slam_env  # noqa: F401  (registers the env IDs)
from agents.common.arguments import positive_int
from slam_env.envs.active_slam import DEFAULT_SCAN_BEAMS

VECTOR_IDS = {"Landmarks": "slam_env/Landmarks-v0", "ActiveSLAM": "slam_env/ActiveSLAM-v0"}


class Timed:
    """One single env with its pre-sampled actions, timed a round at a time; its rate
    is env-steps per second."""

    num_envs = 1

    def __init__(self, env_id: str, steps: int, **kwargs: Any) -> None:
        self.env = self._make(env_id, **kwargs)
        self.env.action_space.seed(0)
        self.actions = [self.env.action_space.sample() for _ in range(steps)]
        self.times: list[float] = []
        self.cpu: list[float] = []  # the process's CPU seconds a round, every thread's
        self.rounds = 0

    def _make(self, env_id: str, **kwargs: Any) -> Any:
        return gym.make(env_id, **kwargs)

    def _step_all(self) -> None:
        """Every action once (an episode that ends is reset by the loop)."""
        env = self.env
        for action in self.actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()

    def run_round(self) -> None:
        self.env.reset(seed=self.rounds)
        self.rounds += 1
        start, cpu = time.perf_counter(), time.process_time()
        self._step_all()
        self.times.append(time.perf_counter() - start)
        self.cpu.append(time.process_time() - cpu)

    @property
    def rate(self) -> float:
        """Env-steps per second of the best round."""
        return len(self.actions) * self.num_envs / min(self.times)

    @property
    def median_rate(self) -> float:
        """Env-steps per second of the median round."""
        return len(self.actions) * self.num_envs / statistics.median(self.times)

    @property
    def cpu_per_step(self) -> float:
        """CPU µs an env-step (every thread of the process), of the median round."""
        return 1e6 * statistics.median(self.cpu) / (len(self.actions) * self.num_envs)


class TimedVector(Timed):
    """A native vector env of ``num_envs`` sub-envs, stepped ``steps`` vector steps a
    round (each sub-env through its resets, as the single envs go through theirs)."""

    def __init__(self, env_id: str, steps: int, num_envs: int, **kwargs: Any) -> None:
        self.num_envs = num_envs
        super().__init__(env_id, steps, **kwargs)

    def _make(self, env_id: str, **kwargs: Any) -> Any:
        return gym.make_vec(
            env_id, num_envs=self.num_envs, vectorization_mode="vector_entry_point", **kwargs
        )

    def _step_all(self) -> None:
        """Every action once (the vector env resets its sub-envs itself)."""
        env = self.env
        for action in self.actions:
            env.step(action)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=positive_int, default=20_000)
    parser.add_argument("--repeats", type=positive_int, default=3)
    parser.add_argument(
        "--wrapped",
        action="store_true",
        help="also time slam_env/ActiveSLAM-v0 next to the raw env at 20 and 100 landmarks",
    )
    parser.add_argument(
        "--vector",
        type=positive_int,
        nargs="*",
        default=[8, 64, 256],
        help="sub-env counts of the native vector envs (none: no vector rows)",
    )
    parser.add_argument(
        "--vector-ids", nargs="*", choices=sorted(VECTOR_IDS), default=sorted(VECTOR_IDS)
    )
    parser.add_argument(
        "--vector-steps",
        type=positive_int,
        default=600,
        help="vector steps a round (default 600: past the 500-step episodes, so the "
        "resets are paid as in the single-env rows)",
    )
    parser.add_argument(
        "--threads",
        type=positive_int,
        nargs="+",
        default=[1, 2],
        help="the native vector envs' num_threads, a row each (at most B; default 1 2)",
    )
    args = parser.parse_args(argv)

    # (label, setting, timed env, index of the row it is compared with or None)
    rows: list[tuple[str, str, Timed, int | None]] = [
        ("CartPole-v1", "", Timed("CartPole-v1", args.steps), None),
        (
            "slam_env/Landmarks-v0",
            "20 landmarks, 6 obstacles",
            Timed("slam_env/Landmarks-v0", args.steps),
            None,
        ),
        ("slam_env/ActiveSLAM-v0", "20 landmarks", Timed("slam_env/ActiveSLAM-v0", args.steps), 1),
    ]
    if args.wrapped:
        # The wrapper is compared with the raw env it wraps: the same world and the
        # same sensors, the proximity scan and bumper that ActiveSLAM-v0 turns on.
        for n in (20, 100):
            side = 16.0 * math.sqrt(n / 20)  # the same landmark density
            kw = {"n_landmarks": n, "width": side, "height": side}
            raw = Timed(
                "slam_env/Landmarks-v0",
                args.steps,
                scan_beams=DEFAULT_SCAN_BEAMS,
                bumper=True,
                **kw,
            )
            rows.append(("slam_env/Landmarks-v0", f"{n} landmarks, with the scan", raw, None))
            raw_row = len(rows) - 1
            for setting, extra in (("belief only", {"coverage": False}), ("", {})):
                wrapped = Timed("slam_env/ActiveSLAM-v0", args.steps, **kw, **extra)
                label = f"{n} landmarks" + (f", {setting}" if setting else "")
                rows.append(("slam_env/ActiveSLAM-v0", label, wrapped, raw_row))
    for b in args.vector:
        cartpole = TimedVector("CartPole-v1", args.vector_steps, b)
        rows.append(("CartPole-v1", f"vector, B = {b}", cartpole, None))
        for name in args.vector_ids:
            single_thread = None
            for t in sorted({min(t, b) for t in args.threads}):
                timed = TimedVector(VECTOR_IDS[name], args.vector_steps, b, num_threads=t)
                label = f"native vector, B = {b}, T = {t}"
                rows.append((VECTOR_IDS[name], label, timed, single_thread))
                if t == 1:
                    single_thread = len(rows) - 1

    for _ in range(args.repeats):
        for _, _, timed, _ in rows:
            timed.run_round()

    cartpole_rate = rows[0][2].rate
    print(
        "| env | setting | steps/s | median steps/s | CPU µs/step | × CartPole-v1 | × ref |\n"
        "|---|---|---:|---:|---:|---:|---:|"
    )
    for name, setting, timed, ref_row in rows:
        rate, median = timed.rate, timed.median_rate
        vs_ref = "" if ref_row is None else f"{rate / rows[ref_row][2].rate:.2f}"
        print(
            f"| {name} | {setting} | {rate:,.0f} | {median:,.0f} | {timed.cpu_per_step:.2f} | "
            f"{rate / cartpole_rate:.3f} | {vs_ref} |"
        )


if __name__ == "__main__":
    main()
