"""Instructions per env step, counted by valgrind's callgrind: repeatable figures on a
shared machine, where wall-clock rates wander by tens of percent between runs.

    .venv/bin/python -m benchmarks.bench_instructions [--steps 250] [--warmup 100]

Each env is stepped in a child process under ``valgrind --tool=callgrind``: ``--warmup``
random steps, then ``--steps`` more inside one ``sys.call_tracing`` call, and callgrind
counts only what runs inside that call (``--collect-atstart=no
--toggle-collect=sys_call_tracing``), so imports, set-up and warm-up are left out
whatever they cost. (``sys.call_tracing``, a debuggers' hook that runs a function as
it is when no tracer is set, because nothing in a step calls it: callgrind toggles its
count at every entry and exit of the named function, so one that a step also called
would switch the count off inside.) (Counting a whole run and subtracting one without the steps, as
this benchmark did before, left the start-up's own variation of millions of
instructions in the figures of the single envs: a third of CartPole-v1's.) A native
vector env of B sub-envs takes ``--steps`` vector steps, and its figure is per
env-step. With the defaults the counted steps of the slam envs hold no episode end
(their episodes last 500 steps), so these are the costs of a step alone; a reset costs
a few ms, paid once per episode (``bench_env.py``'s rates include it). The count is the
same whatever else the machine is doing. It is not time: code that calls many small
functions runs fewer instructions per second than tight compiled loops, so a ratio of
instructions and the ratio of rates that ``bench_env.py`` measures differ.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

from agents.common.arguments import positive_int
from slam_env.envs.active_slam import DEFAULT_SCAN_BEAMS

# Count only inside sys.call_tracing, which the child calls once, around the counted
# steps (a C function of CPython's, so callgrind can name it).
CALLGRIND = (
    "valgrind",
    "--tool=callgrind",
    "--callgrind-out-file=/dev/null",
    "--collect-atstart=no",
    "--toggle-collect=sys_call_tracing",
)

# label -> (env ID, options, sub-envs or 0 for a single env); the raw rows are what
# the wrapped ones are compared with.
ENVS = {
    "CartPole-v1": ("CartPole-v1", {}, 0),
    "Landmarks-v0": ("slam_env/Landmarks-v0", {}, 0),
    "Landmarks-v0 with the scan": (
        "slam_env/Landmarks-v0",
        {"scan_beams": DEFAULT_SCAN_BEAMS, "bumper": True},
        0,
    ),
    "ActiveSLAM-v0 belief only": ("slam_env/ActiveSLAM-v0", {"coverage": False}, 0),
    "ActiveSLAM-v0": ("slam_env/ActiveSLAM-v0", {}, 0),
    "CartPole-v1 vector, B = 64": ("CartPole-v1", {}, 64),
    "Landmarks-v0 native vector, B = 64": ("slam_env/Landmarks-v0", {}, 64),
    "ActiveSLAM-v0 native vector, B = 64": ("slam_env/ActiveSLAM-v0", {}, 64),
}

_CHILD = """
import sys
import gymnasium as gym
import slam_env
env = gym.make({env_id!r}, **{options!r})
env.action_space.seed(0)
actions = [env.action_space.sample() for _ in range({warmup} + {steps})]
env.reset(seed=0)
def step(_, action):
    _, _, terminated, truncated, _ = env.step(action)
    if terminated or truncated:
        env.reset()
for action in actions[:{warmup}]:
    step(None, action)
sys.call_tracing(lambda: [step(None, action) for action in actions[{warmup}:]], ())
"""

# A native vector env resets its sub-envs itself.
_VECTOR_CHILD = """
import sys
import gymnasium as gym
import slam_env
env = gym.make_vec({env_id!r}, num_envs={num_envs}, vectorization_mode="vector_entry_point",
                   **{options!r})
env.action_space.seed(0)
actions = [env.action_space.sample() for _ in range({warmup} + {steps})]
env.reset(seed=0)
def step(_, action):
    env.step(action)
for action in actions[:{warmup}]:
    step(None, action)
sys.call_tracing(lambda: [step(None, action) for action in actions[{warmup}:]], ())
"""


def child_code(env_id: str, options: dict, num_envs: int, steps: int, warmup: int) -> str:
    """The child's program: make the env and take warmup + steps (vector steps of
    ``num_envs`` sub-envs, or single-env steps if 0), the last ``steps`` inside
    ``sys.call_tracing``."""
    child = _VECTOR_CHILD if num_envs else _CHILD
    return child.format(
        env_id=env_id, options=options, num_envs=num_envs, steps=steps, warmup=warmup
    )


# numba compiles for the CPU it sees, and valgrind shows the child another CPU than
# the machine's: without a fixed target, every child would find numba's cache keyed to
# the other CPU and compile its kernels again, and two children running side by side
# would race to write them. The counts are of kernels compiled for a generic x86-64.
CHILD_ENV = {**os.environ, "NUMBA_CPU_NAME": "generic"}


def count(env_id: str, options: dict, num_envs: int, steps: int, warmup: int) -> int:
    """Instructions of the child's counted steps (:func:`child_code`) under callgrind."""
    code = child_code(env_id, options, num_envs, steps, warmup)
    result = subprocess.run(
        [*CALLGRIND, sys.executable, "-c", code],
        env=CHILD_ENV,
        capture_output=True,
        text=True,
        check=True,
    )
    found = re.search(r"Collected : (\d+)", result.stderr)
    if found is None:
        raise RuntimeError(f"no instruction count in valgrind's output:\n{result.stderr}")
    if int(found.group(1)) == 0:  # a Python built without its symbols
        raise RuntimeError(
            "callgrind counted nothing: it did not find CPython's sys_call_tracing "
            f"(is {sys.executable} stripped of its symbols?)"
        )
    return int(found.group(1))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=positive_int, default=250)
    parser.add_argument("--warmup", type=positive_int, default=100)
    parser.add_argument(
        "--only",
        nargs="+",
        choices=list(ENVS),
        default=list(ENVS),
        metavar="ROW",
        help="count these rows only (each takes minutes under valgrind)",
    )
    args = parser.parse_args(argv)
    envs = {label: ENVS[label] for label in args.only}
    if shutil.which("valgrind") is None:
        sys.exit("valgrind is not installed (Debian: apt install valgrind)")

    # Each env once without valgrind first, so that every kernel it runs is in numba's
    # cache (for the generic CPU of CHILD_ENV) before any child is counted.
    for env_id, options, b in envs.values():
        code = child_code(env_id, options, b, args.steps, args.warmup)
        subprocess.run([sys.executable, "-c", code], check=True, env=CHILD_ENV)
    # The counts do not depend on load, so the children run side by side.
    with ThreadPoolExecutor(max_workers=os.cpu_count()) as pool:
        runs = {
            label: pool.submit(count, env_id, options, b, args.steps, args.warmup)
            for label, (env_id, options, b) in envs.items()
        }
        per_step = {
            label: runs[label].result() / (args.steps * max(b, 1))
            for label, (_, _, b) in envs.items()
        }

    # The ratios need their reference rows; a row left out leaves its column blank.
    cartpole = per_step.get("CartPole-v1")
    raw = per_step.get("Landmarks-v0 with the scan")
    print("| env | instructions/env-step | CartPole-v1 / env | raw with scan / env |")
    print("|---|---:|---:|---:|")
    for label, n in per_step.items():
        vs_cartpole = f"{cartpole / n:.3f}" if cartpole else ""
        vs_raw = f"{raw / n:.2f}" if raw and label.startswith("ActiveSLAM") else ""
        print(f"| {label} | {n:,.0f} | {vs_cartpole} | {vs_raw} |")


if __name__ == "__main__":
    main()
