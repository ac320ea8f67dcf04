"""Static-geometry queries: the compiled kernels of slam_env.kernels.world.raycast against
pymunk's public ``Space.segment_query_first``, which they reproduce bit for bit.

    .venv/bin/python -m benchmarks.bench_geometry [--queries 4000] [--repeats 5]

Per world (a default random world, the cluttered and the rooms presets), two query
sets: lines of sight from random points in the arena to landmarks within the sensor's
5 m, skipping the landmark's own post (the sensor's occlusion test), and 4 m beams in
random directions from random points (the proximity scan). Each figure is ns per query,
the best of ``--repeats`` blocks on the CPU clock (the machine is shared); the kernels
answer a whole set in one call, as a batched step would, and pymunk one query per
Python call, as the env did. The answers are checked equal before timing.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
import pymunk

from agents.common.arguments import positive_int
from slam_env.config import RobotConfig, WorldConfig
from slam_env.kernels.world.raycast import lines_of_sight, ray_fractions
from slam_env.kernels.world.static_geometry import empty_geometry
from slam_env.world.layout_generators import preset_layout, random_layout
from slam_env.world.layouts import Layout
from slam_env.world.pymunk_world import _ALL, _MOTION_FILTER, CAT_ROBOT, World
from slam_env.world.static_shapes import set_world


def best_ns(fn: Callable[[], object], n: int, repeats: int) -> float:
    fn()
    best = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        fn()
        best = min(best, time.process_time() - start)
    return best / n * 1e9


def queries(layout: Layout, n: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    W, H = layout.width, layout.height
    pts = layout.landmark_array()
    origins = rng.uniform((0.3, 0.3), (W - 0.3, H - 0.3), (20 * n, 2))
    targets = rng.integers(0, len(pts), 20 * n)
    near = np.flatnonzero(np.hypot(*(pts[targets] - origins).T) < 5.0)[:n]
    sight = np.ascontiguousarray(np.column_stack([origins[near], pts[targets[near]]]))
    headings = rng.uniform(-np.pi, np.pi, n)
    starts = origins[:n]
    ends = starts + 4.0 * np.column_stack([np.cos(headings), np.sin(headings)])
    beams = np.ascontiguousarray(np.column_stack([starts, ends]))
    return sight, targets[near].astype(np.int64), beams


def compare(name: str, layout: Layout, n: int, repeats: int, rng: np.random.Generator) -> None:
    """Print the two rows of one world."""
    g = set_world(empty_geometry(1), 0, layout, WorldConfig().wall_thickness)
    query = World(layout, RobotConfig(), 0.2, 4).space.segment_query_first
    sight, skips, beams = queries(layout, n, rng)
    post_filters = [
        pymunk.ShapeFilter(group=i + 1, mask=_ALL & ~CAT_ROBOT) for i in range(layout.n_landmarks)
    ]
    visible = np.empty(len(sight), dtype=np.bool_)
    fractions = np.empty(len(beams))
    sight_list = [((a, b), (c, d)) for a, b, c, d in sight.tolist()]
    beam_list = [((a, b), (c, d)) for a, b, c, d in beams.tolist()]
    filters = [post_filters[i] for i in skips.tolist()]

    def kernel_sight() -> None:
        lines_of_sight(g, np.zeros(len(sight), np.int64), sight, skips, visible)

    def pymunk_sight() -> list[bool]:
        pairs = zip(sight_list, filters, strict=True)
        return [query(a, b, 0.0, f) is None for (a, b), f in pairs]

    def kernel_beams() -> None:
        ray_fractions(g, np.zeros(len(beams), np.int64), beams, fractions)

    def pymunk_beams() -> list[float]:
        out = []
        for a, b in beam_list:
            hit = query(a, b, 0.0, _MOTION_FILTER)
            out.append(1.0 if hit is None else hit.alpha)
        return out

    kernel_sight()
    kernel_beams()
    assert visible.tolist() == pymunk_sight()
    assert fractions.tolist() == pymunk_beams()
    for label, mine, theirs, count in (
        ("line of sight", kernel_sight, pymunk_sight, len(sight)),
        ("4 m beam", kernel_beams, pymunk_beams, len(beams)),
    ):
        k, p = best_ns(mine, count, repeats), best_ns(theirs, count, repeats)
        print(f"| {name} | {label} | {k:,.0f} | {p:,.0f} | {p / k:.1f}× |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--queries", type=positive_int, default=4000)
    parser.add_argument("--repeats", type=positive_int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    worlds = {
        "random": random_layout(WorldConfig(), RobotConfig().radius, rng),
        "cluttered": preset_layout("cluttered", WorldConfig()),
        "rooms": preset_layout("rooms", WorldConfig()),
    }
    print("| world | query | kernel ns | pymunk ns | pymunk / kernel |")
    print("|---|---|---:|---:|---:|")
    for name, layout in worlds.items():
        compare(name, layout, args.queries, args.repeats, rng)


if __name__ == "__main__":
    main()
