"""The swept-area memory's step: µs per world-step of ``CoverageGrid.step_all`` (sweep,
then features) on the default env grid (16 m arena, 0.5 m cells, the default sensor).

    .venv/bin/python -m benchmarks.bench_coverage [--worlds 64] [--steps 2000] [--repeats 3]

The B worlds follow random walks like the robots' under random actions (up to 0.2 m
a step, headings turning up to ±0.3 rad, turned back at the walls; each world starts
afresh every ``--episode`` steps), drawn before timing, so the figure is the coverage
step alone (with its one Python call per step). Each figure is the best of
``--repeats`` runs on the CPU clock (the machine is shared). To compare two versions,
run this file in turns with each on ``PYTHONPATH``: it uses the public API only.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from agents.common.arguments import positive_int
from slam_env.belief.coverage import CoverageGrid
from slam_env.config import SensorConfig

ARENA = 16.0


def random_walks(worlds: int, steps: int, rng: np.random.Generator) -> np.ndarray:
    """(steps, worlds, 3) poses."""
    poses = np.empty((steps, worlds, 3))
    pose = np.column_stack(
        [rng.uniform(1.0, ARENA - 1.0, (worlds, 2)), rng.uniform(-math.pi, math.pi, worlds)]
    )
    for t in range(steps):
        pose[:, 2] += rng.uniform(-0.3, 0.3, worlds)
        stride = rng.uniform(0.0, 0.2, worlds)
        ahead = pose[:, :2] + stride[:, None] * np.column_stack(
            [np.cos(pose[:, 2]), np.sin(pose[:, 2])]
        )
        blocked = np.any((ahead < 0.3) | (ahead > ARENA - 0.3), axis=1)
        pose[blocked, 2] += math.pi  # turn back at a wall
        pose[~blocked, :2] = ahead[~blocked]
        poses[t] = pose
    return poses


def run(grid: CoverageGrid, poses: np.ndarray, episode: int) -> float:
    """CPU seconds for the whole walk, every world reset each ``episode`` steps."""
    active = np.ones(poses.shape[1], dtype=np.bool_)
    for b in range(poses.shape[1]):
        grid.reset(b)
    start = time.process_time()
    for t, step in enumerate(poses):
        if t and t % episode == 0:
            for b in range(poses.shape[1]):
                grid.reset(b)
        grid.step_all(step, active)
    return time.process_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=positive_int, default=64)
    parser.add_argument("--steps", type=positive_int, default=2000)
    parser.add_argument("--repeats", type=positive_int, default=3)
    parser.add_argument("--episode", type=positive_int, default=500)
    args = parser.parse_args()
    poses = random_walks(args.worlds, args.steps, np.random.default_rng(0))
    grid = CoverageGrid.for_sensor(ARENA, ARENA, SensorConfig(), worlds=args.worlds)
    cells = np.floor(poses[:, :, :2] / grid.cell)
    moved = np.mean(np.any(cells[1:] != cells[:-1], axis=2))
    run(grid, poses[:10], args.episode)  # compile or load the kernels
    best = min(run(grid, poses, args.episode) for _ in range(args.repeats))
    per_step = best / (args.steps * args.worlds) * 1e6
    print(
        f"B={args.worlds} steps={args.steps}: robot cell changed on {moved:.0%} of steps; "
        f"{per_step:.3f} µs per world-step (best of {args.repeats})"
    )


if __name__ == "__main__":
    main()
