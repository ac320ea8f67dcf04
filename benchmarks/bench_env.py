"""Env throughput: slam_env steps per second against CartPole-v1 in the same run.

    .venv/bin/python benchmarks/bench_env.py [--steps 20000] [--repeats 3]

Every env is made with ``gym.make`` (so each carries the same standard wrappers),
stepped with pre-sampled random actions and reset when an episode ends. The best of
``--repeats`` timings is kept for each env, which damps the noise of a shared machine.
The figure that matters is the ratio to CartPole measured in the same run.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

import gymnasium as gym

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.active_slam import DEFAULT_SCAN_BEAMS


def steps_per_second(env_id: str, steps: int, repeats: int, **kwargs: Any) -> float:
    env = gym.make(env_id, **kwargs)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]
    best = float("inf")
    for repeat in range(repeats):
        env.reset(seed=repeat)
        start = time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        best = min(best, time.perf_counter() - start)
    env.close()
    return steps / best


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

    cartpole = steps_per_second("CartPole-v1", args.steps, args.repeats)
    rows = [("CartPole-v1", "", cartpole)]
    raw20 = steps_per_second("slam_env/Landmarks-v0", args.steps, args.repeats)
    rows.append(("slam_env/Landmarks-v0", "20 landmarks, 6 obstacles", raw20))
    if args.wrapped:
        # The wrapper is compared with the raw env it wraps: the same world and the
        # same sensors, the proximity scan that ActiveSLAM-v0 turns on included.
        for n in (20, 100):
            side = 16.0 * math.sqrt(n / 20)  # the same landmark density
            kw = {"n_landmarks": n, "width": side, "height": side}
            raw = steps_per_second(
                "slam_env/Landmarks-v0",
                args.steps,
                args.repeats,
                scan_beams=DEFAULT_SCAN_BEAMS,
                **kw,
            )
            rows.append(("slam_env/Landmarks-v0", f"{n} landmarks, with the scan", raw))
            # The EKF-SLAM wrapper alone (and the reward's bookkeeping), then the whole
            # registered stack, whose swept-area memory is a wrapper of its own.
            for setting, extra in (("belief only, ", {"coverage": False}), ("", {})):
                wrapped = steps_per_second(
                    "slam_env/ActiveSLAM-v0", args.steps, args.repeats, **kw, **extra
                )
                label = f"{n} landmarks, {setting}{wrapped / raw:.2f}× raw"
                rows.append(("slam_env/ActiveSLAM-v0", label, wrapped))

    print("| env | setting | steps/s | × CartPole-v1 |\n|---|---|---:|---:|")
    for name, setting, rate in rows:
        print(f"| {name} | {setting} | {rate:,.0f} | {rate / cartpole:.3f} |")


if __name__ == "__main__":
    main()
