"""What the SLAM metrics cost training: ``slam-env train`` with and without them.

    .venv/bin/python -m benchmarks.bench_train_metrics [--steps 4096] [--repeats 3]
                     [--n-envs 1] [--skip-training]

Part 1 runs ``agents.learning.sb3.training.train`` with the default config
(``agents/configs/ppo_default.yaml``; no checkpoints, no evaluation, no progress bar)
for ``--steps`` env steps at a time, in turns with the SLAM metrics and without them
(:class:`agents.learning.sb3.callbacks.SlamMetricsCallback` swapped for a callback that does
nothing), in ABBA order, so that a slow spell of a shared machine hits both sides. The
same seed gives both sides the same episodes. It reports each side's steps/s in wall
time (the learning loop, as ``training_summary.json`` has it) and in the CPU time of
the process (with one env, ``--n-envs 1``, everything runs in it: on a machine that
others share, CPU time moves far less than wall time), and the share of the time spent
inside the callback.

Part 2 times the callback's per-step work alone on synthetic step infos of B sub-envs:
plain dicts (``DummyVecEnv``/``SubprocVecEnv``) and the lazy rows of a native vector
env (:class:`agents.common.info_rows.InfoRow`, read in one go), in µs of CPU per env-step.

Part 3 (``--instructions``; needs valgrind) counts with callgrind, as
``bench_instructions.py`` does, the instructions of the callback's step on a real
``ActiveSLAM-v0`` step info (B copies, as dicts and as a vector info), and of an
``ActiveSLAM-v0`` step: figures that do not depend on what else the machine runs.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.common.arguments import non_negative_int, positive_int


class _Spent:
    """Time spent in the timed callbacks' ``_on_step``, s."""

    total = 0.0


def _callback_classes() -> dict[str, type]:
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.learning.sb3.callbacks import SlamMetricsCallback

    class Timed(SlamMetricsCallback):
        def _on_step(self) -> bool:
            start = time.perf_counter()
            try:
                return super()._on_step()
            finally:
                _Spent.total += time.perf_counter() - start

    class Nothing(BaseCallback):
        def _on_step(self) -> bool:
            return True

    return {"with": Timed, "without": Nothing}


def training_rates(steps: int, repeats: int, n_envs: int) -> dict[str, Any]:
    import agents.learning.sb3.callbacks as slam_callbacks
    from agents.learning.config import load_config
    from agents.learning.sb3.training import train

    original = slam_callbacks.SlamMetricsCallback
    classes = _callback_classes()
    wall = dict.fromkeys(classes, 0.0)
    cpu = dict.fromkeys(classes, 0.0)
    done = dict.fromkeys(classes, 0)
    overrides = {
        "total_timesteps": steps,
        "n_envs": n_envs,
        "checkpoint_freq": 0,
        "eval_freq": 0,
        "progress_bar": False,
    }
    with tempfile.TemporaryDirectory() as tmp:
        cfg = load_config(out_dir=tmp, **overrides)
        train(cfg)  # warm up: imports, compiled kernels
        for repeat in range(repeats):
            # ABBA order: a drift of the machine's speed does not favour either side.
            for side in ("without", "with") if repeat % 2 == 0 else ("with", "without"):
                slam_callbacks.SlamMetricsCallback = classes[side]
                try:
                    start = time.process_time()
                    train(cfg)
                    cpu[side] += time.process_time() - start
                finally:
                    slam_callbacks.SlamMetricsCallback = original
                summary = json.loads((Path(tmp) / "training_summary.json").read_text())
                wall[side] += summary["wall_time_s"]
                done[side] += summary["timesteps"]
    return {
        "wall": {side: done[side] / wall[side] for side in classes},
        "cpu": {side: done[side] / cpu[side] for side in classes},
        "steps": done,
        "callback_share": _Spent.total / wall["with"],
    }


def _synthetic_step(b: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """A vector info with the keys and dtypes of ActiveSLAM-v0's (the ones a step
    carries besides: pose, entropy...), every sub-env reporting each."""
    keys = {
        "collision": rng.random(b) < 0.1,
        "pose_nees": rng.chisquare(3, b),
        "landmarks_known": rng.integers(0, 20, b),
        "pose": rng.random((b, 3)),
        "entropy": rng.random(b),
        "map_rmse": rng.random(b),
        "pose_error": rng.random(b),
        "diverged": np.zeros(b, dtype=bool),
    }
    info: dict[str, np.ndarray] = {}
    for key, value in keys.items():
        info[key], info[f"_{key}"] = value, np.ones(b, dtype=bool)
    return info


def step_callback(b: int) -> Any:
    """A SlamMetricsCallback of B sub-envs, ready to step without a model."""
    from types import SimpleNamespace

    from agents.learning.sb3.callbacks import SlamMetricsCallback

    env = SimpleNamespace(num_envs=b)
    callback = SlamMetricsCallback()
    callback.init_callback(SimpleNamespace(logger=None, get_env=lambda: env, num_timesteps=0))
    return callback


def per_step_costs(sizes: list[int], seconds: float = 0.5) -> list[tuple[str, int, float]]:
    """(infos, B, µs of CPU per env-step) of the callback's step (no episode ends)."""
    from agents.common.info_rows import InfoRow

    rng = np.random.default_rng(0)
    rows = []
    for b in sizes:
        info = _synthetic_step(b, rng)
        lazy = [InfoRow(info, i) for i in range(b)]
        plain = [dict(row.items()) for row in lazy]
        for kind, infos in (("dict rows", plain), ("native vector rows", lazy)):
            callback = step_callback(b)
            callback.update_locals({"infos": infos, "dones": np.zeros(b, dtype=bool)})
            calls, start = 0, time.process_time()
            while time.process_time() - start < seconds:
                callback.on_step()
                calls += 1
            per_env_step = (time.process_time() - start) / (calls * b)
            rows.append((kind, b, per_env_step * 1e6))
    return rows


_CALLBACK_CHILD = """
import gymnasium as gym
import numpy as np
import slam_env
from agents.common.info_rows import InfoRow
from benchmarks.bench_train_metrics import step_callback
b, rows, steps = {b}, {rows!r}, {steps}
env = gym.make("slam_env/ActiveSLAM-v0")
env.reset(seed=0)
info = env.step(env.action_space.sample())[4]
if rows == "dict":
    infos = [dict(info) for _ in range(b)]
else:
    vector = {{}}
    for key, value in info.items():
        if not isinstance(value, dict):
            vector[key] = np.stack([np.asarray(value)] * b)
            vector["_" + key] = np.ones(b, dtype=bool)
    infos = [InfoRow(vector, i) for i in range(b)]
callback = step_callback(b)
callback.update_locals({{"infos": infos, "dones": np.zeros(b, dtype=bool)}})
for _ in range(300 + steps):  # 300: numpy's first calls, which cost far more, are not counted
    callback.on_step()
"""


def instruction_counts(steps: int) -> tuple[float, list[tuple[str, int, float]]]:
    """Instructions of an ActiveSLAM-v0 step, and of the callback's step per env-step
    for (infos, B): each the difference of two children, 0 and ``steps`` steps."""
    from concurrent.futures import ThreadPoolExecutor

    from benchmarks.bench_instructions import CALLGRIND, count

    cases = [("dict rows", 1), ("dict rows", 2), ("native vector rows", 8)]
    cases.append(("native vector rows", 64))

    def callback_run(rows: str, b: int, n: int) -> int:
        kind = "dict" if rows == "dict rows" else "vector"
        # Run from the root, so that the child imports step_callback from this module.
        here = str(Path(__file__).resolve().parents[1])
        code = _CALLBACK_CHILD.format(b=b, rows=kind, steps=n)
        run = subprocess.run(
            [*CALLGRIND, sys.executable, "-c", code],
            capture_output=True,
            text=True,
            check=True,
            cwd=here,
        )
        return int(re.search(r"Collected : (\d+)", run.stderr).group(1))

    with ThreadPoolExecutor(max_workers=2) as pool:
        env_runs = [pool.submit(count, "slam_env/ActiveSLAM-v0", {}, 0, n, 50) for n in (0, steps)]
        runs = {
            (case, n): pool.submit(callback_run, *case, n) for case in cases for n in (0, steps)
        }
        env_step = (env_runs[1].result() - env_runs[0].result()) / steps
        per_env_step = [
            (rows, b, (runs[(rows, b), steps].result() - runs[(rows, b), 0].result()) / steps / b)
            for rows, b in cases
        ]
    return env_step, per_env_step


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--steps", type=positive_int, default=4096, help="env steps per training run"
    )
    parser.add_argument("--repeats", type=positive_int, default=3, help="runs per side")
    parser.add_argument("--n-envs", type=positive_int, default=1, help="1: everything in-process")
    parser.add_argument("--skip-training", action="store_true", help="no part 1")
    parser.add_argument(
        "--instructions",
        type=non_negative_int,
        metavar="STEPS",
        default=0,
        help="part 3 with this many steps per count (needs valgrind)",
    )
    args = parser.parse_args(argv)

    if not args.skip_training:
        r = training_rates(args.steps, args.repeats, args.n_envs)
        print(
            f"slam-env train, default config, {args.n_envs} env(s), "
            f"{args.repeats} runs x {args.steps} steps per side, in ABBA order:"
        )
        print("| SLAM metrics | env steps | steps/s (wall) | steps/s (CPU) |")
        print("|---|---:|---:|---:|")
        for side in ("without", "with"):
            print(
                f"| {side} | {r['steps'][side]:,} | {r['wall'][side]:,.0f} "
                f"| {r['cpu'][side]:,.0f} |"
            )
        wall = r["wall"]["with"] / r["wall"]["without"]
        cpu = r["cpu"]["with"] / r["cpu"]["without"]
        print(f"with / without: {wall:.3f} (wall), {cpu:.3f} (CPU); time inside the")
        print(f"callback: {100 * r['callback_share']:.2f}% of the wall time with it")
        print()
    print("The callback's work per env-step (tally of 3 keys), synthetic infos:")
    print("| infos | B | µs of CPU per env-step |")
    print("|---|---:|---:|")
    for kind, b, us in per_step_costs([1, 2, 8, 64]):
        print(f"| {kind} | {b} | {us:.2f} |")
    if args.instructions:
        env_step, rows = instruction_counts(args.instructions)
        print()
        print(f"Instructions (callgrind): an ActiveSLAM-v0 step {env_step:,.0f}; the callback:")
        print("| infos | B | instructions per env-step | share of an env step |")
        print("|---|---:|---:|---:|")
        for kind, b, n in rows:
            print(f"| {kind} | {b} | {n:,.0f} | {100 * n / env_step:.2f}% |")


if __name__ == "__main__":
    main()
