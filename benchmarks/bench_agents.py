"""The planning agents' cost: their distance-field search, and whole episodes.

    .venv/bin/python -m benchmarks.bench_agents [--episodes 3] [--searches 20] [--repeats 2]

1. ``dijkstra`` on the default world's planning grid (16 m arena, 0.25 m cells, the
   frontier agent's obstacle-proximity costs, from the robot's start): the compiled
   search (:mod:`agents.planners.search_kernel`) against the plain Python one it replaced
   (``references/dijkstra.py``), side by side, ms per search.
2. Exploration episodes of the default world (500 steps, seeds 0..) for ``frontier``,
   ``infogain`` and the shipped ``goals`` policy: seconds per episode, and the same
   episodes' time with the Python search patched in (the agents' results are the same
   bit for bit either way: checked here).

Each figure is the best of ``--repeats`` on the CPU clock (the machine is shared); the
episodes' after one untimed pass, which loads what the agents need.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from unittest import mock

import numpy as np

import agents.planners.frontier
import agents.planners.infogain
from agents.common.arguments import positive_int
from agents.common.env import make_env
from agents.planners.exploration_memory import ExplorationMemory
from agents.planners.grid_search import dijkstra
from agents.registry import make_agent
from agents.rollouts.episodes import run_episode
from references.dijkstra import reference_dijkstra

AGENTS = ("frontier", "infogain", "goals")


def best_of(repeats: int, fn: Callable[[], object]) -> tuple[float, object]:
    """(least CPU seconds of ``repeats`` calls of fn, its last result)."""
    best, out = float("inf"), None
    for _ in range(repeats):
        start = time.process_time()
        out = fn()
        best = min(best, time.process_time() - start)
    return best, out


def default_grid() -> tuple[np.ndarray, np.ndarray, float, tuple[int, int]]:
    """(passable, cell_cost, resolution, start cell) of the planning grid the
    heuristic agents build (with their default parameters) at the start of a
    default-world episode."""
    env = make_env({}, 500)
    env.reset(seed=0)
    base = env.unwrapped
    mem = ExplorationMemory(base.layout, base.config)
    x, y, _ = base.filter.pose
    start = mem.grid.cell_of(float(x), float(y))
    env.close()
    return mem.free, mem.cell_cost, float(mem.grid.resolution), start


def search_times(searches: int, repeats: int) -> tuple[float, float]:
    """ms per search: (compiled, Python), each checked equal to the other."""
    free, cost, res, start = default_grid()
    dijkstra(free, [start], resolution=res, cell_cost=cost)  # compile (or load the cache)

    def run(search: Callable) -> object:
        for _ in range(searches):
            out = search(free, [start], resolution=res, cell_cost=cost)
        return out

    fast, (d1, p1) = best_of(repeats, lambda: run(dijkstra))
    slow, (d2, p2) = best_of(repeats, lambda: run(reference_dijkstra))
    if not (np.array_equal(d1, d2) and np.array_equal(p1, p2)):
        raise AssertionError("the compiled search differs from the Python one")
    return 1e3 * fast / searches, 1e3 * slow / searches


def episode_time(spec: str, episodes: int, repeats: int, python_search: bool) -> tuple[float, list]:
    """(CPU seconds per default-world episode, the episodes' true poses and entropies
    as bytes, to compare)."""
    env = make_env({}, 500)

    def run() -> list:
        runs = []
        for seed in range(episodes):
            rec = run_episode(env, make_agent(spec, env, seed), seed)
            runs.append((rec.true_poses.tobytes(), rec.entropy.tobytes()))
        return runs

    patches = [
        mock.patch.object(m, "dijkstra", reference_dijkstra)
        for m in (agents.planners.frontier, agents.planners.infogain)
    ]
    if python_search:
        for p in patches:
            p.start()
    try:
        # One untimed pass first: the first episode of a process imports and loads
        # what the agents need (torch and the policy for goals).
        run()
        seconds, metrics = best_of(repeats, run)
    finally:
        if python_search:
            for p in patches:
                p.stop()
    env.close()
    return seconds / episodes, metrics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=positive_int, default=3)
    parser.add_argument("--searches", type=positive_int, default=20)
    parser.add_argument("--repeats", type=positive_int, default=2)
    args = parser.parse_args()

    fast, slow = search_times(args.searches, args.repeats)
    print(
        f"dijkstra, default world's planning grid: compiled {fast:.2f} ms, "
        f"Python {slow:.2f} ms per search ({slow / fast:.1f}x)"
    )
    print(
        f"\n{args.episodes} default-world episodes of 500 steps, "
        f"CPU s per episode (best of {args.repeats})"
    )
    print(f"{'agent':10s} {'compiled':>9s} {'Python':>8s} {'ratio':>6s}")
    for spec in AGENTS:
        t_fast, m_fast = episode_time(spec, args.episodes, args.repeats, python_search=False)
        t_slow, m_slow = episode_time(spec, args.episodes, args.repeats, python_search=True)
        if m_fast != m_slow:
            raise AssertionError(f"{spec}: the episodes differ between the two searches")
        print(f"{spec:10s} {t_fast:9.3f} {t_slow:8.3f} {t_slow / t_fast:5.1f}x")


if __name__ == "__main__":
    main()
