"""JCBB's cost per scan at its worst: the step time of ``EKFSLAM(data_association="jcbb")``
with m landmarks all in view and m observations, for m up to the pairings a scan may
have (:data:`slam_env.kernels.ekf.association.MAX_PAIRINGS`, what the filter and the
env's budget admit).

    .venv/bin/python -m benchmarks.bench_jcbb [--pairings 16 32 64] [--repeats 3]

The landmarks stand on a grid 0.3 m apart and the pose is uncertain by more than that
(σ 1 m, 0.2 rad) when the scan comes, so that every observation is individually
compatible with many landmarks; every other one is displaced by ~7 cm (far beyond the
sensor's noise), so that no hypothesis pairs them all and the bound prunes little:
the hardest scans found (the search's own limit is
:data:`~slam_env.kernels.ekf.association.MAX_NODES` hypotheses of up to m pairings).
Reports the best of ``--repeats`` updates (each on a fresh copy of the same filter),
and for m beyond the limit the time its refusal takes.

Target: the largest admitted scan (m = MAX_PAIRINGS) within about a second a step.
"""

from __future__ import annotations

import argparse
import math
import time

from agents.common.arguments import positive_int  # argparse only: no numpy yet

SPACING = 0.3  # m between landmarks: well inside the pose's uncertainty


def _grid(m: int):
    import numpy as np

    side = math.ceil(math.sqrt(m))
    ij = np.array([(i, j) for i in range(side) for j in range(side)][:m], dtype=float)
    return 2.0 + ij * SPACING  # ahead of and beside the robot at the origin


def _filter(m: int):
    """A filter that has mapped the m landmarks of the grid from an exact pose, then
    moved 0.5 m with its pose made uncertain by σ 1 m along and 0.2 rad, and the scan
    it sees there."""
    import numpy as np

    from slam_env.ekf import EKFSLAM
    from slam_env.ekf.models import MEASUREMENT_MODELS

    h = MEASUREMENT_MODELS["range_bearing"].h
    q = np.diag([0.02**2, math.radians(0.3) ** 2])
    alphas = (0.0, 0.16, 4.0, 0.0)  # M = diag(α2, α3, α2)·δtr² on a straight move
    f = EKFSLAM(alphas=alphas, measurement_cov=q, max_landmarks=m, data_association="jcbb")
    f.update(h(np.zeros(3), _grid(m)))  # every landmark started
    f.predict((0.0, 0.5, 0.0))
    seen = _grid(m)
    seen[::2] += np.random.default_rng(0).normal(size=seen[::2].shape) * 0.07
    return f, h(np.array([0.5, 0.0, 0.0]), seen)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairings", type=positive_int, nargs="+", default=[16, 32, 64])
    parser.add_argument("--repeats", type=positive_int, default=3)
    args = parser.parse_args()

    from slam_env.kernels.ekf.association import MAX_PAIRINGS

    for m in args.pairings:
        if m > MAX_PAIRINGS:
            f, scan = _filter(m)
            start = time.perf_counter()
            try:
                f.update(scan)
            except ValueError:
                print(f"m = {m:4d}: refused in {1e3 * (time.perf_counter() - start):.2f} ms")
            continue
        best = math.inf
        for _ in range(args.repeats):
            f, scan = _filter(m)
            start = time.perf_counter()
            f.update(scan)
            best = min(best, time.perf_counter() - start)
        print(f"m = {m:4d}: {best:.3f} s a scan")


if __name__ == "__main__":
    main()
