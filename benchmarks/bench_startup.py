"""Time to the first step: import, ``gym.make``, ``reset`` and the first ``step`` of a
fresh process, cold (an empty numba cache directory: every kernel compiled) and warm
(a second process on the cache the first one wrote), for both IDs and their native
vector envs, beside CartPole-v1's in the same run.

    .venv/bin/python -m benchmarks.bench_startup [--repeats 3] [--vector 8]
                     [--ids Landmarks ActiveSLAM] [--no-cold] [--installed PYTHON]
    .venv/bin/python -m benchmarks.bench_startup --parts [--repeats 5] [--ids ActiveSLAM]

Each measurement is a child process (``python -c``), so that nothing is imported or
compiled before it starts; cold children get a directory of their own as
``NUMBA_CACHE_DIR``, which the warm children then reuse. Wall and CPU seconds are the
child's own clocks; the kernels and specialisations it compiled (or loaded) are read
off numba's dispatchers. ``--installed PYTHON`` measures a fresh ``pip install`` instead
(PYTHON: the interpreter of a new virtual environment holding the wheel): its children
use the package's own cache, which the wheel's build filled, and the first of them is
the user's first step. Children read and write Python's bytecode as Python does by
default (and as ``pip install`` leaves it), whatever ``PYTHONDONTWRITEBYTECODE`` says
here: compiling the package's sources anew took about 0.3 s of every first step. The
figures that matter are the ratios against CartPole-v1, and the medians of
``--repeats`` children.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

from agents.common.arguments import non_negative_int, positive_int

IDS = {"Landmarks": "slam_env/Landmarks-v0", "ActiveSLAM": "slam_env/ActiveSLAM-v0"}
STAGES = ("import", "make", "reset", "step")

# The child: times each stage, then counts what numba compiled or loaded from its cache.
CHILD = r"""
import json, sys, time
env_id, vector = sys.argv[1], int(sys.argv[2])
wall, cpu = [time.perf_counter()], [time.process_time()]
def mark():
    wall.append(time.perf_counter()); cpu.append(time.process_time())
import gymnasium as gym
if env_id.startswith("slam_env"):
    import slam_env
mark()
if vector:
    env = gym.make_vec(env_id, num_envs=vector, vectorization_mode="vector_entry_point")
else:
    env = gym.make(env_id)
mark()
env.reset(seed=0)
mark()
env.step(env.action_space.sample())
mark()
counts = {"kernels": 0, "specialisations": 0, "compiled": 0, "loaded": 0}
if env_id.startswith("slam_env"):
    from slam_env.kernels.base.compiling import kernel_counts
    counts = kernel_counts()
print(json.dumps({
    "wall": [b - a for a, b in zip(wall, wall[1:])],
    "cpu": [b - a for a, b in zip(cpu, cpu[1:])],
    **counts,
}))
"""


# The child of --parts: a warm single env's first step, by part.
PARTS = r"""
import json, sys, time
env_id = sys.argv[1]
start = time.perf_counter()
import gymnasium, numpy, pymunk
libraries = time.perf_counter()
import numba
from numba.core import caching
from numba.core.registry import cpu_target
cpu_target.target_context.refresh()
cpu_target.typing_context.refresh()
numba_done = time.perf_counter()
loading = [0.0]
load_overload = caching.Cache.load_overload
def timed(self, *args, **kwargs):
    t = time.perf_counter()
    try:
        return load_overload(self, *args, **kwargs)
    finally:
        loading[0] += time.perf_counter() - t
caching.Cache.load_overload = timed
import slam_env
env = gymnasium.make(env_id)
env.reset(seed=0)
env.step(env.action_space.sample())
done = time.perf_counter()
print(json.dumps({
    "gymnasium, numpy and pymunk": libraries - start,
    "numba and its registries": numba_done - libraries,
    "the cached kernels' loading": loading[0],
    "the rest (slam_env, make, reset, step)": done - numba_done - loading[0],
    "total": done - start,
}))
"""


def child_environment(cache: str | None) -> dict[str, str]:
    """A child's environment variables: numba's cache in ``cache`` (None: the package's
    own), no screen, and Python's bytecode written and read as by default."""
    env = dict(os.environ, SDL_VIDEODRIVER="dummy")
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    return env


def parts(env_id: str) -> dict[str, float]:
    """One warm child's first step by part (the package's own cache)."""
    done = subprocess.run(
        [sys.executable, "-c", PARTS, env_id],
        capture_output=True, text=True, env=child_environment(None), check=True, timeout=1800,
    )  # fmt: skip
    return json.loads(done.stdout.strip().splitlines()[-1])


def child(env_id: str, vector: int, cache: str | None, python: str = sys.executable) -> dict:
    """One child's figures; ``cache`` None: the package's own cache directory."""
    done = subprocess.run(
        [python, "-c", CHILD, env_id, str(vector)],
        capture_output=True,
        text=True,
        env=child_environment(cache),
        check=True,
        timeout=1800,
        # An installed package's children start elsewhere, so as not to import the clone's.
        cwd=None if python == sys.executable else tempfile.gettempdir(),
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def median_of(runs: list[dict]) -> dict:
    out = {
        "wall": [statistics.median(r["wall"][i] for r in runs) for i in range(4)],
        "cpu": [statistics.median(r["cpu"][i] for r in runs) for i in range(4)],
    }
    for key in ("kernels", "specialisations", "compiled", "loaded"):
        out[key] = statistics.median(r[key] for r in runs)
    return out


def row(label: str, figures: dict, cartpole: dict) -> str:
    first = sum(figures["wall"])
    ratio = first / sum(cartpole["wall"])
    stages = "  ".join(f"{s} {w:7.3f}" for s, w in zip(STAGES, figures["wall"], strict=True))
    return (
        f"{label:<34} {stages}  first step {first:7.2f} s ({ratio:6.1f}× CartPole)  "
        f"cpu {sum(figures['cpu']):7.2f} s  kernels {figures['kernels']:3.0f}  "
        f"specialisations {figures['specialisations']:3.0f}  compiled {figures['compiled']:3.0f}"
        f"  loaded {figures['loaded']:3.0f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=positive_int, default=3)
    parser.add_argument("--vector", type=non_negative_int, default=8, help="0: no vector env")
    parser.add_argument("--ids", nargs="+", choices=sorted(IDS), default=sorted(IDS))
    parser.add_argument("--no-cold", action="store_true", help="warm processes only")
    parser.add_argument(
        "--installed", metavar="PYTHON", help="a fresh install's interpreter: its own cache"
    )
    parser.add_argument(
        "--parts", action="store_true", help="a warm first step taken apart, single envs"
    )
    args = parser.parse_args()
    if args.parts:
        for name in args.ids:
            parts(IDS[name])  # the cache filled, if it is not
            runs = [parts(IDS[name]) for _ in range(args.repeats)]
            print(f"{name}, warm first step by part (medians of {args.repeats}):")
            for key in runs[0]:
                print(f"  {key:<42} {statistics.median(r[key] for r in runs):6.3f} s")
        return

    cases = [(name, IDS[name], 0) for name in args.ids]
    if args.vector:
        cases += [(f"{name} vector B={args.vector}", IDS[name], args.vector) for name in args.ids]
    cartpole = median_of([child("CartPole-v1", 0, "") for _ in range(args.repeats)])
    print(row("CartPole-v1", cartpole, cartpole))
    if args.installed:
        for label, env_id, vector in cases:
            first = child(env_id, vector, None, args.installed)  # the user's first step
            print(row(f"{label}, first after install", first, cartpole), flush=True)
            later = [child(env_id, vector, None, args.installed) for _ in range(args.repeats)]
            print(row(f"{label}, warm", median_of(later), cartpole), flush=True)
        return
    with tempfile.TemporaryDirectory() as shared:
        for label, env_id, vector in cases:
            if not args.no_cold:
                colds = []
                for _ in range(args.repeats):
                    with tempfile.TemporaryDirectory() as empty:
                        colds.append(child(env_id, vector, empty))
                print(row(f"{label}, cold", median_of(colds), cartpole), flush=True)
            child(env_id, vector, shared)  # fills the shared cache, if it is not
            warm = [child(env_id, vector, shared) for _ in range(args.repeats)]
            print(row(f"{label}, warm", median_of(warm), cartpole), flush=True)


if __name__ == "__main__":
    main()
