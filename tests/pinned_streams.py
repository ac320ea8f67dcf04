"""Hashes of 1,000-step streams of both env IDs, single and native vector, under option
sets of every kind, pinned in ``tests/pinned_streams.json`` so that a change meant to
keep behaviour (a move, a speed-up) shows at once if it did not.

Kernels compiled for another CPU may round a reassociated sum differently, so the file
holds one set of pins per CPU (``by_cpu``), each taken from the code before the
redesign (970af96); the ActiveSLAM sets were taken again when the odometry model's
prediction gained its two sideways terms (a change of behaviour, docs/filter.md).
``python -m tests.pinned_streams --write`` records the current
code's hashes for this machine's CPU; with ``--only NAME...`` it re-pins those option
sets alone and drops them from the other CPUs' pins (do it only when a change of
behaviour is meant, and say so in the commit). Another CPU's pins are recomputed here
by compiling for it, ``NUMBA_CPU_NAME=znver3 NUMBA_CPU_FEATURES="" NUMBA_CACHE_DIR=DIR``
before the same command (an empty feature list takes LLVM's own for that CPU): that
reproduced every znver3 pin on a znver5 machine. Pinned: znver3, znver5 and rocketlake
(whose pins, taken on a rocketlake machine, equal znver3's in every set). The test
``tests/test_pinned_streams.py`` holds the code to the pins of the CPU it runs on.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import platform
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import slam_env  # noqa: F401  (registers the env IDs)
from tests.streams import _feed

PIN_FILE = Path(__file__).with_name("pinned_streams.json")
LANDMARKS = "slam_env/Landmarks-v0"
ACTIVE = "slam_env/ActiveSLAM-v0"
STEPS = 1000
EPISODE = 300  # short episodes, so that the streams cross resets
NUM_ENVS = 3

# name: (env ID, options). Faults, hidden IDs with JCBB, FEJ, the local observation,
# the velocity/cartesian models and discrete actions, on both IDs where they apply.
OPTION_SETS: dict[str, tuple[str, dict[str, Any]]] = {
    "landmarks-default": (LANDMARKS, {}),
    "landmarks-faults": (
        LANDMARKS,
        {
            "outlier_rate": 0.3,
            "clutter_rate": 0.2,
            "scan_dropout": 0.1,
            "odometry_dropout": 0.1,
            "kidnap_rate": 0.02,
            "odometry_bias": (0.01, 0.0, -0.01),
            "scan_beams": 8,
            "bumper": True,
        },
    ),
    "landmarks-velocity-cartesian-discrete": (
        LANDMARKS,
        {"motion_model": "velocity", "measurement_model": "cartesian", "action_type": "discrete"},
    ),
    "landmarks-hidden-ids-rooms": (LANDMARKS, {"report_ids": False, "preset": "rooms"}),
    "active-default": (ACTIVE, {}),
    "active-faults-full": (
        ACTIVE,
        {"observation": "full", "n_landmarks": 8, "outlier_rate": 0.2, "kidnap_rate": 0.01},
    ),
    "active-hidden-ids-jcbb": (
        ACTIVE,
        {
            "report_ids": False,
            "data_association": "jcbb",
            "new_landmark_sightings": 2,
            "wide_pairing_scans": 2,
            "n_landmarks": 12,
        },
    ),
    "active-hidden-ids-nn-batch": (
        ACTIVE,
        {"report_ids": False, "data_association": "nearest_neighbor", "correction": "batch"},
    ),
    "active-fej": (ACTIVE, {"linearization": "fej", "alphas": (0.02, 0.008, 0.04, 0.004)}),
    "active-oc-coverage-reward": (
        ACTIVE,
        {"linearization": "oc", "reward_weights": {"coverage": 1.0}, "preset": "cluttered"},
    ),
    "active-local": (ACTIVE, {"observation": "local", "n_landmarks": 10, "clutter_rate": 0.1}),
    "active-velocity-cartesian-discrete": (
        ACTIVE,
        {
            "motion_model": "velocity",
            "measurement_model": "cartesian",
            "action_type": "discrete",
            "velocity_noise": (0.01, 0.01, 0.01, 0.02),
        },
    ),
}


def single_digest(env_id: str, options: dict[str, Any], seed: int = 7) -> str:
    """The hash of a seeded single env's stream: reset, then STEPS seeded random
    actions, resetting (without a seed) where an episode ends."""
    env = gym.make(env_id, max_episode_steps=EPISODE, **options)
    env.action_space.seed(seed)
    h = hashlib.sha256()
    _feed(h, env.reset(seed=seed))
    for _ in range(STEPS):
        step = env.step(env.action_space.sample())
        _feed(h, step)
        if step[2] or step[3]:
            _feed(h, env.reset())
    env.close()
    return h.hexdigest()


def vector_digest(env_id: str, options: dict[str, Any], seed: int = 7) -> str:
    """The hash of a seeded native vector env's stream of NUM_ENVS sub-envs."""
    venv = gym.make_vec(
        env_id,
        num_envs=NUM_ENVS,
        vectorization_mode="vector_entry_point",
        max_episode_steps=EPISODE,
        **options,
    )
    venv.action_space.seed(seed)
    h = hashlib.sha256()
    _feed(h, venv.reset(seed=seed))
    for _ in range(STEPS):
        _feed(h, venv.step(venv.action_space.sample()))
    venv.close()
    return h.hexdigest()


def machine() -> dict[str, str]:
    """What the hashes depend on beyond the code: the CPU the kernels are compiled for
    (a reassociated sum vectorises by its width) and the numerical libraries."""
    import llvmlite.binding as llvm
    import numba

    return {
        "cpu": numba.config.CPU_NAME or llvm.get_host_cpu_name(),
        "machine": platform.machine(),
        "numpy": np.__version__,
        "numba": numba.__version__,
    }


def current(names: list[str] | None = None) -> dict[str, dict[str, str]]:
    return {
        name: {
            "single": single_digest(env_id, options),
            "vector": vector_digest(env_id, options),
        }
        for name, (env_id, options) in OPTION_SETS.items()
        if names is None or name in names
    }


def pins_for(cpu: str) -> dict[str, dict[str, str]] | None:
    """The pinned hashes for kernels compiled for ``cpu`` (by option set), or None."""
    entry = json.loads(PIN_FILE.read_text())["by_cpu"].get(cpu)
    return None if entry is None else entry["streams"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="record the current hashes")
    parser.add_argument("--only", nargs="+", choices=sorted(OPTION_SETS), help="these sets")
    args = parser.parse_args()
    here = machine()
    streams = current(args.only)
    print(json.dumps({"machine": here, "streams": streams}, indent=2, sort_keys=True))
    if args.write:
        pins = json.loads(PIN_FILE.read_text()) if PIN_FILE.exists() else {"by_cpu": {}}
        own = pins["by_cpu"].setdefault(here["cpu"], {"machine": here, "streams": {}})
        own["machine"] = here
        own["streams"].update(streams)
        for cpu, entry in pins["by_cpu"].items():
            if cpu != here["cpu"]:
                for name in streams:
                    entry["streams"].pop(name, None)
        PIN_FILE.write_text(json.dumps(pins, indent=2, sort_keys=True) + "\n")


if __name__ == "__main__":
    main()
