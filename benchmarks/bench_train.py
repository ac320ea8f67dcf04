"""``slam-env train`` throughput: the native vector env against worker processes.

    .venv/bin/python -m benchmarks.bench_train [--steps 20000] [--repeats 2]

Runs ``slam-env train`` (the default config, ``agents/configs/ppo_default.yaml``, with
no checkpoints, evaluation or progress bar) in a fresh process per run, for the same
number of env steps and the same PPO settings in every mode, the modes taking turns
(``--repeats`` rounds) so that a slow spell of a shared machine hits all of them. Each
row gives the env steps/s of the learning loop and the shares of its wall time spent
stepping the envs and in PPO's gradient updates, as ``training_summary.json`` has
them (means over the repeats). The native rows with more sub-envs keep the rollout as
many env steps long (``n_steps`` scaled down), so that PPO's batch is the same; the
last row also takes every other PPO setting in which ``agents/configs/ppo_fast.yaml``
differs from the default config (its minibatch and MLP).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

from agents.common.arguments import positive_int
from agents.learning.config import DEFAULT_CONFIG_PATH, load_config

FAST_CONFIG = DEFAULT_CONFIG_PATH.with_name("ppo_fast.yaml")


def _fast_mode() -> tuple[str, int, dict]:
    """ppo_fast.yaml's mode: its sub-envs and the PPO settings it changes (but
    ``n_steps``, which every row scales to the same rollout)."""
    fast, default = load_config(FAST_CONFIG), load_config()
    changed = {
        f.name: getattr(fast.ppo, f.name)
        for f in dataclasses.fields(fast.ppo)
        if f.name != "n_steps" and getattr(fast.ppo, f.name) != getattr(default.ppo, f.name)
    }
    return "native", fast.n_envs, changed


FAST_MODE = _fast_mode()

# label -> (vectorization, n_envs, PPO settings other than the default config's)
MODES = {
    "subproc, 2 workers (before)": ("subproc", 2, {}),
    "native, 2 sub-envs": ("native", 2, {}),
    "native, 16 sub-envs": ("native", 16, {}),
    "native, 64 sub-envs": ("native", 64, {}),
    f"native, {FAST_MODE[1]} sub-envs, ppo_fast.yaml": FAST_MODE,
}


def run(mode: str, n_envs: int, ppo: dict, steps: int, rollout: int, out: Path) -> dict:
    """One ``slam-env train`` in a child process; its ``training_summary.json``."""
    cfg = load_config()
    config = {
        "total_timesteps": steps,
        "n_envs": n_envs,
        "vectorization": mode,
        "env_options": cfg.env_options,
        "checkpoint_freq": 0,
        "eval_freq": 0,
        "progress_bar": False,
        "out_dir": str(out),
        "ppo": {"n_steps": rollout // n_envs, **ppo},
    }
    path = out.with_suffix(".yaml")
    path.write_text(yaml.safe_dump(config))
    subprocess.run(
        [sys.executable, "-m", "agents", "train", "--config", str(path)],
        check=True,
        capture_output=True,
    )
    return json.loads((out / "training_summary.json").read_text())


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=positive_int, default=20_000, help="env steps per run")
    parser.add_argument("--repeats", type=positive_int, default=2, help="runs per mode")
    args = parser.parse_args(argv)
    default = load_config()
    rollout = default.ppo.n_steps * default.n_envs  # env steps per PPO update
    results: dict[str, list[dict]] = {label: [] for label in MODES}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            for k, (label, (mode, n_envs, ppo)) in enumerate(MODES.items()):
                out = Path(tmp) / f"mode{k}_{r}"
                results[label].append(run(mode, n_envs, ppo, args.steps, rollout, out))
    p = default.ppo
    print(
        f"slam-env train, default config, {args.steps:,} env steps per run, PPO updates on "
        f"rollouts of {rollout} env steps ({p.n_epochs} epochs, minibatch {p.batch_size}, "
        f"MLP {p.net_arch} but for ppo_fast.yaml's row); "
        f"means of {args.repeats} runs per mode, taking turns:"
    )
    print("| mode | env steps/s | × subproc | env stepping | gradient updates | rest |")
    print("|---|---:|---:|---:|---:|---:|")
    base = None
    for label, runs in results.items():
        rate = sum(s["timesteps"] for s in runs) / sum(s["wall_time_s"] for s in runs)
        base = rate if base is None else base
        shares = [
            sum(s[key] for s in runs) / len(runs)
            for key in ("env_step_share", "gradient_updates_share", "other_share")
        ]
        print(
            f"| {label} | {rate:,.0f} | {rate / base:.2f} | {100 * shares[0]:.0f}% "
            f"| {100 * shares[1]:.0f}% | {100 * shares[2]:.0f}% |"
        )


if __name__ == "__main__":
    main()
