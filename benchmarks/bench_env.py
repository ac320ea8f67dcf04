"""Env throughput: slam_env steps per second against CartPole-v1 in the same run.

    .venv/bin/python benchmarks/bench_env.py [--steps 20000] [--repeats 3]

Every env is made with ``gym.make`` (so each carries the same standard wrappers),
stepped with pre-sampled random actions and reset when an episode ends. The repeats
take turns: each round times every env once, so a slow spell of a shared machine hits
all of them, and the best of ``--repeats`` rounds is kept for each. The figures that
matter are the ratios measured in the same run.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import gymnasium as gym

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.active_slam import DEFAULT_SCAN_BEAMS


class Timed:
    """One env with its pre-sampled actions, timed a round at a time."""

    def __init__(self, env_id: str, steps: int, **kwargs: Any) -> None:
        self.env = gym.make(env_id, **kwargs)
        self.env.action_space.seed(0)
        self.actions = [self.env.action_space.sample() for _ in range(steps)]
        self.best = float("inf")
        self.rounds = 0

    def run_round(self) -> None:
        env = self.env
        env.reset(seed=self.rounds)
        self.rounds += 1
        start = time.perf_counter()
        for action in self.actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        self.best = min(self.best, time.perf_counter() - start)

    @property
    def rate(self) -> float:
        return len(self.actions) / self.best


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--wrapped",
        action="store_true",
        help="also time slam_env/ActiveSLAM-v0 next to the raw env at 20 and 100 landmarks",
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
            # The EKF-SLAM wrapper alone (and the reward's bookkeeping), then the whole
            # registered stack, whose swept-area memory is a wrapper of its own.
            for setting, extra in (("belief only", {"coverage": False}), ("", {})):
                wrapped = Timed("slam_env/ActiveSLAM-v0", args.steps, **kw, **extra)
                label = f"{n} landmarks" + (f", {setting}" if setting else "")
                rows.append(("slam_env/ActiveSLAM-v0", label, wrapped, raw_row))

    for _ in range(args.repeats):
        for _, _, timed, _ in rows:
            timed.run_round()

    cartpole = rows[0][2].rate
    print("| env | setting | steps/s | × CartPole-v1 | × raw |\n|---|---|---:|---:|---:|")
    for name, setting, timed, raw_row in rows:
        rate = timed.rate
        vs_raw = "" if raw_row is None else f"{rate / rows[raw_row][2].rate:.2f}"
        print(f"| {name} | {setting} | {rate:,.0f} | {rate / cartpole:.3f} | {vs_raw} |")


if __name__ == "__main__":
    main()
