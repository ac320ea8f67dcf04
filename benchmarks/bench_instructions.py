"""Instructions per env step, counted by valgrind's callgrind: repeatable figures on a
shared machine, where wall-clock rates wander by tens of percent between runs.

    .venv/bin/python benchmarks/bench_instructions.py [--steps 1000]

Each env is stepped in a child process under ``valgrind --tool=callgrind`` twice, for
0 and for ``--steps`` random steps after the same warm-up; the difference divided by
``--steps`` is the cost of a step, imports and set-up cancelling out. The count is the
same whatever else the machine is doing. It is not time: code that calls many small
numpy functions runs fewer instructions per second than the pymunk queries of the raw
env, so a ratio of instructions is an upper bound on the ratio of rates that
``bench_env.py`` measures.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

from slam_env.active_slam import DEFAULT_SCAN_BEAMS

CALLGRIND = ("valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null")

# label -> (env ID, options); the raw rows are what the wrapped ones are compared with.
ENVS = {
    "CartPole-v1": ("CartPole-v1", {}),
    "Landmarks-v0": ("slam_env/Landmarks-v0", {}),
    "Landmarks-v0 with the scan": (
        "slam_env/Landmarks-v0",
        {"scan_beams": DEFAULT_SCAN_BEAMS, "bumper": True},
    ),
    "ActiveSLAM-v0 belief only": ("slam_env/ActiveSLAM-v0", {"coverage": False}),
    "ActiveSLAM-v0": ("slam_env/ActiveSLAM-v0", {}),
}

_CHILD = """
import sys
import gymnasium as gym
import slam_env
env = gym.make({env_id!r}, **{options!r})
env.action_space.seed(0)
actions = [env.action_space.sample() for _ in range({warmup} + {steps})]
env.reset(seed=0)
for action in actions:
    _, _, terminated, truncated, _ = env.step(action)
    if terminated or truncated:
        env.reset()
"""


def instructions(code: str, cwd: str | None = None) -> int:
    """Instructions of a child Python process that runs ``code`` (in ``cwd``)."""
    result = subprocess.run(
        [*CALLGRIND, sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        cwd=cwd,
    )
    found = re.search(r"Collected : (\d+)", result.stderr)
    if found is None:
        raise RuntimeError(f"no instruction count in valgrind's output:\n{result.stderr}")
    return int(found.group(1))


def count(env_id: str, options: dict, steps: int, warmup: int) -> int:
    """Instructions of a child process that makes the env and takes warmup + steps."""
    return instructions(_CHILD.format(env_id=env_id, options=options, steps=steps, warmup=warmup))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--warmup", type=int, default=200)
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error("--steps must be at least 1")
    if shutil.which("valgrind") is None:
        sys.exit("valgrind is not installed (Debian: apt install valgrind)")

    # The counts do not depend on load, so the children run side by side.
    with ThreadPoolExecutor(max_workers=os.cpu_count()) as pool:
        runs = {
            (label, steps): pool.submit(count, env_id, options, steps, args.warmup)
            for label, (env_id, options) in ENVS.items()
            for steps in (0, args.steps)
        }
        per_step = {
            label: (runs[label, args.steps].result() - runs[label, 0].result()) / args.steps
            for label in ENVS
        }

    cartpole = per_step["CartPole-v1"]
    raw = per_step["Landmarks-v0 with the scan"]
    print("| env | instructions/step | CartPole-v1 / env | raw with scan / env |")
    print("|---|---:|---:|---:|")
    for label, n in per_step.items():
        vs_raw = f"{raw / n:.2f}" if label.startswith("ActiveSLAM") else ""
        print(f"| {label} | {n:,.0f} | {cartpole / n:.3f} | {vs_raw} |")


if __name__ == "__main__":
    main()
