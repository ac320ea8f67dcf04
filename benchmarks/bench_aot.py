"""A prototype of the kernels compiled ahead of time: the stages of an ``ActiveSLAM-v0``
step built into one extension module by numba's own AOT compiler (``numba.pycc``),
from the same kernel sources, and timed against the JIT kernels on their warm cache.

    .venv/bin/python -m benchmarks.bench_aot [--stages egocentric motion stream filter
                     outputs] [--repeats 3] [--calls 2000]

It records each stage's inputs and outputs at one call of a real episode (the default
world, seed 0, after ``--warmup`` random steps), builds the extension in a temporary
folder (for a generic x86-64, as a wheel would ship it), then runs, in fresh child
processes, the recorded calls of every stage once: with the extension (numba never
imported) and with the JIT kernels loaded from their cache. Each child says whether
every stage wrote what the JIT kernel wrote at the recorded call, bit for bit. Last,
the stages' steady per-call times, both builds side by side in one process.

This is a measurement, not a build of the package: the package still ships numba's
cache (docs/benchmarks.md, "Time to the first step").
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from agents.common.arguments import non_negative_int, positive_int

# stage -> (the module that calls its kernel, the kernel's name there)
STAGES = {
    "egocentric": ("slam_env.belief.encodings", "encode_egocentric"),
    "motion": ("slam_env.world.drive", "drive"),
    "stream": ("slam_env.core.raw", "raw_step"),
    "filter": ("slam_env.core.active", "filter_step"),
    "outputs": ("slam_env.core.active", "belief_outputs"),
}
MODULE = "slam_env_aot_prototype"


def copied(value: Any) -> Any:
    """``value`` with every array in it (also in nested tuples) copied."""
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, tuple):
        return (
            type(value)(*map(copied, value))
            if hasattr(value, "_fields")
            else tuple(map(copied, value))
        )
    return value


def arrays_equal(a: Any, b: Any) -> bool:
    """Whether ``a`` and ``b`` hold the same arrays bit for bit (NaN equal to NaN)."""
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if isinstance(a, tuple):
        return len(a) == len(b) and all(arrays_equal(x, y) for x, y in zip(a, b, strict=True))
    return a == b or (a != a and b != b)


def record(stages: list[str], warmup: int) -> dict[str, dict[str, Any]]:
    """Each stage's arguments before and after its first call past ``warmup`` steps
    of a seeded random episode, its result, and its kernel's signature."""
    import gymnasium as gym

    import slam_env  # noqa: F401  (registers the IDs)

    calls: dict[str, dict[str, Any]] = {}
    counting = {"live": False}

    def spy(stage: str, kernel: Any) -> Any:
        def call(*args: Any) -> Any:
            if not counting["live"] or stage in calls:
                return kernel(*args)
            before = copied(args)
            result = kernel(*args)
            calls[stage] = {"before": before, "after": copied(args), "result": result}
            return result

        return call

    originals = {}
    for stage in stages:
        module_name, name = STAGES[stage]
        module = importlib.import_module(module_name)
        originals[stage] = (module, name, getattr(module, name))
        setattr(module, name, spy(stage, getattr(module, name)))
    try:
        env = gym.make("slam_env/ActiveSLAM-v0")
        env.action_space.seed(0)
        env.reset(seed=0)
        for step in range(warmup + 50):
            counting["live"] = step >= warmup
            env.step(env.action_space.sample())
            if len(calls) == len(stages):
                break
        env.close()
    finally:
        for module, name, kernel in originals.values():
            setattr(module, name, kernel)
    missing = [s for s in stages if s not in calls]
    if missing:
        raise RuntimeError(f"no call of {missing} in the recorded steps")
    for stage in stages:
        kernel = originals[stage][2]
        types = tuple(kernel.typeof_pyval(arg) for arg in calls[stage]["before"])
        # The specialisation the recorded call ran.
        (calls[stage]["signature"],) = (s for s in kernel.nopython_signatures if s.args == types)
        calls[stage]["module"] = kernel.py_func.__module__
    return calls


def build(calls: dict[str, dict[str, Any]], folder: Path, cpu: str = "") -> float:
    """The extension :data:`MODULE` of the recorded stages, in ``folder``, for the CPU
    ``cpu`` (LLVM's name; "": a generic one of the machine's family); seconds."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numba.pycc's pending deprecation
        from numba.pycc import CC

    cc = CC(MODULE)
    cc.output_dir = str(folder)
    cc.verbose = False
    cc.target_cpu = cpu
    for stage, call in calls.items():
        kernel = getattr(importlib.import_module(call["module"]), STAGES[stage][1])
        cc.export(stage, call["signature"])(kernel.py_func)
    start = time.perf_counter()
    cc.compile()
    return time.perf_counter() - start


def save(calls: dict[str, dict[str, Any]], folder: Path) -> None:
    """The recorded calls into ``folder``/calls.pkl for the children: arrays and
    results only, no numba type (unpickling one would import numba)."""
    kept = {s: {k: c[k] for k in ("before", "after", "result")} for s, c in calls.items()}
    with open(folder / "calls.pkl", "wb") as f:
        pickle.dump(kept, f)


# A fresh process: import what runs the stages, run each recorded call once, compare.
CHILD = r"""
import time
start = time.perf_counter()
import importlib, json, pickle, sys
from typing import Any
import numpy as np
{helpers}
mode, folder, stages = sys.argv[1], sys.argv[2], sys.argv[3].split(",")
imported = time.perf_counter()
if mode == "aot":
    sys.path.insert(0, folder)
    built = importlib.import_module("{module}")
    kernels = [getattr(built, stage) for stage in stages]
else:
    kernels = [getattr(importlib.import_module(m), name) for m, name in {where}]
loaded = time.perf_counter()
with open(folder + "/calls.pkl", "rb") as f:
    calls = pickle.load(f)
first, same = 0.0, []
for stage, kernel in zip(stages, kernels):
    args = copied(calls[stage]["before"])
    t = time.perf_counter()
    result = kernel(*args)
    first += time.perf_counter() - t
    if arrays_equal(args, calls[stage]["after"]) and result == calls[stage]["result"]:
        same.append(stage)
print(json.dumps({{"numpy": imported - start, "load": loaded - imported, "first": first,
                  "same": same, "numba": "numba" in sys.modules}}))
"""


def child_source(stages: list[str]) -> str:
    """:data:`CHILD` for ``stages``, with the comparison's helpers written in (importing
    this module would import numba's argument types)."""
    helpers = inspect.getsource(copied) + "\n" + inspect.getsource(arrays_equal)
    where = [STAGES[stage] for stage in stages]
    return CHILD.format(module=MODULE, helpers=helpers, where=where)


def child(mode: str, folder: Path, stages: list[str]) -> dict[str, Any]:
    import json

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.getcwd(), *sys.path]))
    done = subprocess.run(
        [sys.executable, "-c", child_source(stages), mode, str(folder), ",".join(stages)],
        capture_output=True,
        text=True,
        check=True,
        env=env,
        timeout=600,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def per_call(kernel: Any, call: dict[str, Any], calls: int) -> float:
    """Median µs of ``calls`` calls on fresh copies of the recorded arguments, in 5
    rounds; the copying is timed apart and taken off."""
    rounds = []
    for _ in range(5):
        copies = [copied(call["before"]) for _ in range(calls)]
        start = time.perf_counter()
        for args in copies:
            kernel(*args)
        rounds.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(rounds)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stages", nargs="+", choices=list(STAGES), default=list(STAGES))
    parser.add_argument("--repeats", type=positive_int, default=3, help="children per build")
    parser.add_argument("--calls", type=positive_int, default=2000, help="timed calls a stage")
    parser.add_argument(
        "--cpu",
        choices=["generic", "host"],
        default="generic",
        help="the extension's target: a generic x86-64 (a wheel's), or this machine's CPU",
    )
    parser.add_argument("--warmup", type=non_negative_int, default=20, help="steps before")
    args = parser.parse_args(argv)
    stages = list(dict.fromkeys(args.stages))
    calls = record(stages, args.warmup)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cpu = ""
        if args.cpu == "host":
            import llvmlite.binding

            cpu = llvmlite.binding.get_host_cpu_name()
        seconds = build(calls, folder, cpu)
        save(calls, folder)
        print(
            f"built {MODULE} ({', '.join(stages)}) for {cpu or 'a generic CPU'} in {seconds:.1f} s"
        )
        runs: dict[str, list[dict[str, Any]]] = {"aot": [], "jit": []}
        for _ in range(args.repeats):  # taking turns
            for mode in runs:
                runs[mode].append(child(mode, folder, stages))
        print(
            "| fresh process | numpy | load the stages | first call of each | numba imported "
            "| stages bit for bit |"
        )
        print("|---|---:|---:|---:|---|---|")
        for mode, label in (("aot", "extension (AOT)"), ("jit", "JIT, warm cache")):
            r = runs[mode]
            med = {k: statistics.median(x[k] for x in r) for k in ("numpy", "load", "first")}
            print(
                f"| {label} | {med['numpy']:.3f} s | {med['load']:.3f} s | {med['first']:.4f} s "
                f"| {'yes' if any(x['numba'] for x in r) else 'no'} "
                f"| {', '.join(s for s in stages if all(s in x['same'] for x in r)) or 'none'} |"
            )
        sys.path.insert(0, tmp)
        built = importlib.import_module(MODULE)
        print("\n| stage | JIT µs/call | AOT µs/call | AOT / JIT |")
        print("|---|---:|---:|---:|")
        for stage in stages:
            jit = getattr(importlib.import_module(STAGES[stage][0]), STAGES[stage][1])
            t_jit = per_call(jit, calls[stage], args.calls)
            t_aot = per_call(getattr(built, stage), calls[stage], args.calls)
            print(f"| {stage} | {t_jit:.2f} | {t_aot:.2f} | {t_aot / t_jit:.2f} |")


if __name__ == "__main__":
    main()
