"""What a training run does whatever its engine (stable-baselines3 or RLlib): check the
env its config makes before any worker starts, and write the run's summary."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym

from agents.common.env import make_env
from agents.learning.budget import check_training_budget
from agents.learning.config import ConfigError, TrainConfig


def check_train_env(cfg: TrainConfig) -> str:
    """Fail here, with the env's message, rather than in a worker process; return the
    SB3 policy that takes the env's observation (``MlpPolicy`` for the flat egocentric
    belief, ``MultiInputPolicy`` for a ``Dict`` such as the local one)."""
    env = make_env(cfg.env_options, cfg.max_episode_steps)
    try:
        env.reset(seed=cfg.seed)  # e.g. a random world that cannot be laid out
        space = env.observation_space
    finally:
        env.close()
    check_training_budget(cfg, space, env.action_space)
    local = cfg.env_options.get("observation") == "local"
    if cfg.worlds is not None and not local:
        raise ConfigError(
            "training across worlds needs env_options.observation: local (the one "
            "observation whose size does not depend on the world)"
        )
    if isinstance(space, gym.spaces.Dict) and not local:
        raise ConfigError(
            "PPO trains on the flat egocentric belief or the local observation, not on "
            "the full covariance: set env_options.observation to egocentric or local"
        )
    return "MultiInputPolicy" if local else "MlpPolicy"


def model_path(cfg: TrainConfig) -> Path:
    """Where the policy is saved, ``OUT/<model_name>.zip``; ``ConfigError`` before
    anything runs where that or its config's path is taken by something not a file
    (SB3 would save beside a folder there, and the run would name the folder)."""
    path = Path(cfg.out_dir) / f"{cfg.model_name}.zip"
    for taken in (path, path.with_suffix(".yaml")):
        if taken.exists() and not taken.is_file():
            raise ConfigError(
                f"{str(taken)!r} exists and is not a file: the training writes its "
                "policy there; remove it, or choose another --out or model_name"
            )
    return path


def write_summary(out: Path, summary: dict[str, Any], interrupted: bool, model: Path) -> None:
    """``training_summary.json`` into ``out``; then, if Ctrl-C stopped the training,
    the ``KeyboardInterrupt`` that says where the policy was saved."""
    (out / "training_summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    if interrupted:
        raise KeyboardInterrupt(f"training interrupted; model saved to {model}")


def sampler_threads(vectorization: str, n_envs: int, vec_env: Any) -> int:
    """How many threads (the native vector env's ``num_threads``) or processes
    (``subproc``: one a sub-env) step the training's sub-envs; 1 for ``dummy``."""
    if vectorization == "subproc":
        return n_envs
    while hasattr(vec_env, "venv"):  # SB3's wrappers, then the native vector env itself
        vec_env = vec_env.venv
    return int(getattr(vec_env, "num_threads", 1))


def finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def finite_map(figures: Mapping[str, float] | None) -> dict[str, float | None] | None:
    return None if figures is None else {k: finite(v) for k, v in figures.items()}
