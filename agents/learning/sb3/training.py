"""PPO training on ``slam_env/ActiveSLAM-v0`` (egocentric belief observation).

``train(config)`` runs stable-baselines3 PPO on ``n_envs`` sub-envs (by default the
native vector env, which steps them all in one call; ``vectorization`` picks worker
processes or in-process single envs instead), with a progress bar, TensorBoard logs,
periodic checkpoints and periodic evaluation on a separately seeded env, and writes
into ``config.out_dir``::

    <model_name>.zip            the final policy (load it with ``ppo:PATH``)
    <model_name>.yaml           the resolved config it was trained with
    training_summary.json       steps, wall time, env steps/s, the shares of the wall
                                time in env stepping and in gradient updates,
                                last/best evaluation
    checkpoints/<model_name>_<N>_steps.zip
    eval/best_model.zip, eval/evaluations.npz
    tb/<model_name>_1/          TensorBoard logs (``tensorboard --logdir OUT/tb``)

Besides SB3's own scalars, TensorBoard gets the SLAM metrics of the training episodes
under ``slam/`` and of the evaluation episodes under ``slam_eval/``
(:mod:`agents.learning.sb3.callbacks`); the best model is the evaluation's best by
:data:`agents.learning.metrics.BEST_MODEL_CRITERION`.

The config and its checks are :mod:`agents.learning.config`'s.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from agents.learning.config import TrainConfig, as_train_config, write_config
from agents.learning.metrics import BEST_MODEL_CRITERION
from agents.learning.runs import (
    check_train_env,
    finite,
    finite_map,
    sampler_threads,
    write_summary,
)
from agents.learning.runs import model_path as checked_model_path
from agents.learning.sb3.goal_training import train_goal_choice
from agents.learning.sb3.runs import (
    close_envs,
    learn_and_save,
    make_callbacks,
    make_train_vec_env,
    ppo_arguments,
)


def train(config: TrainConfig | Mapping[str, Any] | str | Path | None = None) -> Path:
    """Train PPO as ``config`` says (a :class:`TrainConfig`, a mapping, a YAML path,
    or ``None`` for the defaults) and return the path of the saved ``.zip``."""
    import torch

    from agents.learning.sb3.timing import StepTimer, TimedPPO, time_shares

    cfg = as_train_config(config)
    if cfg.decisions == "goals":
        return train_goal_choice(cfg)
    model_path = checked_model_path(cfg)
    policy = check_train_env(cfg)
    torch.set_num_threads(cfg.torch_threads)
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_config(cfg, out / f"{cfg.model_name}.yaml")

    train_env = StepTimer(make_train_vec_env(cfg, cfg.n_envs, cfg.seed))
    eval_env = None
    interrupted = False
    try:
        if cfg.eval_freq > 0:
            # One in-process sub-env: the same held-out episodes for every vectorization.
            # The default world (with the training's options), for every vectorization
            # and world distribution.
            eval_cfg = dataclasses.replace(
                cfg,
                vectorization="native" if cfg.vectorization == "native" else "dummy",
                worlds=None,
            )
            eval_env = make_train_vec_env(eval_cfg, 1, cfg.eval_seed)
        model = TimedPPO(policy, train_env, **ppo_arguments(cfg, out))
        callbacks = make_callbacks(cfg, out, eval_env)
        wall, interrupted = learn_and_save(model, cfg, callbacks, model_path)
        shares = time_shares(wall, train_env.seconds, model.update_seconds)
        evals = [c for c in callbacks if hasattr(c, "best_slam")]
        summary = {
            "model": str(model_path),
            "timesteps": int(model.num_timesteps),
            "wall_time_s": round(wall, 3),
            "env_steps_per_s": round(model.num_timesteps / wall, 1) if wall > 0 else None,
            "n_envs": cfg.n_envs,
            "vectorization": cfg.vectorization,
            "sampler_threads": sampler_threads(cfg.vectorization, cfg.n_envs, train_env),
            "torch_threads": cfg.torch_threads,
            **shares,
            "interrupted": interrupted,
            "last_eval_mean_reward": finite(evals[0].last_mean_reward) if evals else None,
            "best_eval_mean_reward": finite(evals[0].best_mean_reward) if evals else None,
            "last_eval_slam": finite_map(evals[0].last_slam) if evals else None,
            "best_eval_slam": finite_map(evals[0].best_slam) if evals else None,
            "best_model_criterion": BEST_MODEL_CRITERION,
        }
        write_summary(out, summary, interrupted, model_path)
    finally:
        close_envs(interrupted, train_env, eval_env)
    return model_path
