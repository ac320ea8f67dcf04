"""The pieces of a stable-baselines3 training run that the step and the goal trainings
share: the training envs, the callbacks, PPO's arguments, learning and saving, closing."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from agents.common.env import ENV_ID, make_env
from agents.learning.config import TrainConfig


# ---------------------------------------------------------------------- envs
@dataclass(frozen=True)
class EnvFactory:
    """A picklable env constructor for ``SubprocVecEnv`` workers (fresh processes)."""

    env_options: dict[str, Any]
    max_steps: int | None = None
    torch_threads: int | None = None

    def __call__(self) -> gym.Env:
        if self.torch_threads is not None:
            import torch

            torch.set_num_threads(self.torch_threads)
        return make_env(self.env_options, self.max_steps)


def make_train_vec_env(cfg: TrainConfig, n_envs: int, seed: int) -> Any:
    """The SB3 ``VecEnv`` of ``n_envs`` sub-envs that ``cfg.vectorization`` names, with
    episode statistics (``Monitor``/``VecMonitor``); sub-env i is seeded ``seed + i``
    at the first reset, whichever the vectorization, so all three run the same
    episodes."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecMonitor

    if cfg.worlds is not None:
        from agents.learning.sb3.world_sampling import WorldSamplingVecEnv
        from agents.learning.worlds import WorldDistribution

        return VecMonitor(
            WorldSamplingVecEnv(
                ENV_ID,
                n_envs,
                WorldDistribution.from_mapping(cfg.worlds),
                cfg.env_options,
                groups=min(cfg.world_groups or n_envs, n_envs),
                seed=seed,
                max_episode_steps=cfg.max_episode_steps,
            )
        )
    if cfg.vectorization == "native":
        from agents.learning.sb3.vector_env import make_sb3_vec_env

        kwargs = dict(cfg.env_options)
        if cfg.max_episode_steps is not None:
            kwargs["max_episode_steps"] = cfg.max_episode_steps
        return VecMonitor(make_sb3_vec_env(ENV_ID, n_envs, seed=seed, **kwargs))
    factory = EnvFactory(dict(cfg.env_options), cfg.max_episode_steps, cfg.torch_threads)
    if cfg.vectorization == "subproc":
        vec_cls, vec_kwargs = SubprocVecEnv, {"start_method": cfg.start_method}
    else:
        vec_cls, vec_kwargs = DummyVecEnv, None
    return make_vec_env(
        factory, n_envs=n_envs, seed=seed, vec_env_cls=vec_cls, vec_env_kwargs=vec_kwargs
    )


def checkpoint_callbacks(cfg: TrainConfig, out: Path) -> list[Any]:
    """SB3's checkpoint saving every ``cfg.checkpoint_freq`` steps into
    ``out/checkpoints`` (none for 0)."""
    from stable_baselines3.common.callbacks import CheckpointCallback

    if cfg.checkpoint_freq <= 0:
        return []
    return [
        CheckpointCallback(
            save_freq=max(cfg.checkpoint_freq // cfg.n_envs, 1),
            save_path=str(out / "checkpoints"),
            name_prefix=cfg.model_name,
        )
    ]


def eval_arguments(cfg: TrainConfig, out: Path) -> dict[str, Any]:
    """SB3's ``EvalCallback`` keyword arguments from ``cfg``: ``cfg.eval_episodes``
    greedy episodes every ``cfg.eval_freq`` steps, logs and best model in ``out/eval``."""
    return {
        "n_eval_episodes": cfg.eval_episodes,
        "eval_freq": max(cfg.eval_freq // cfg.n_envs, 1),
        "log_path": str(out / "eval"),
        "best_model_save_path": str(out / "eval"),
        "deterministic": True,
        "verbose": cfg.verbose,
    }


def make_callbacks(cfg: TrainConfig, out: Path, eval_env: Any) -> list[Any]:
    from agents.learning.sb3.callbacks import SlamEvalCallback, SlamMetricsCallback

    callbacks: list[Any] = [SlamMetricsCallback(), *checkpoint_callbacks(cfg, out)]
    if cfg.eval_freq > 0:
        callbacks.append(
            SlamEvalCallback(eval_env, eval_seed=cfg.eval_seed, **eval_arguments(cfg, out))
        )
    return callbacks


# ---------------------------------------------------------------------- train
def ppo_arguments(cfg: TrainConfig, out: Path) -> dict[str, Any]:
    """stable-baselines3 PPO's keyword arguments from ``cfg`` (logs under ``out``)."""
    import torch

    p = cfg.ppo
    policy_kwargs: dict[str, Any] = {
        "net_arch": {"pi": list(p.net_arch), "vf": list(p.net_arch)},
        "activation_fn": {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[p.activation],
    }
    if cfg.decisions == "actions":  # Gaussian actions; a choice of goals is categorical
        policy_kwargs["log_std_init"] = p.log_std_init
    return {
        "learning_rate": p.learning_rate,
        "n_steps": p.n_steps,
        "batch_size": p.batch_size,
        "n_epochs": p.n_epochs,
        "gamma": p.gamma,
        "gae_lambda": p.gae_lambda,
        "clip_range": p.clip_range,
        "ent_coef": p.ent_coef,
        "vf_coef": p.vf_coef,
        "max_grad_norm": p.max_grad_norm,
        "target_kl": p.target_kl,
        "normalize_advantage": p.normalize_advantage,
        "policy_kwargs": policy_kwargs,
        "tensorboard_log": str(out / "tb") if cfg.tensorboard else None,
        "seed": cfg.seed,
        "device": "cpu",
        "verbose": cfg.verbose,
    }


def learn_and_save(
    model: Any, cfg: TrainConfig, callbacks: list[Any], path: Path
) -> tuple[float, bool]:
    """``model.learn`` as ``cfg`` says, then the policy saved at ``path``: (wall time
    of the learning in s, whether Ctrl-C stopped it; what was learnt is kept)."""
    if not cfg.tensorboard:
        model.set_logger(console_logger(cfg.verbose))
    start = time.perf_counter()
    interrupted = False
    try:
        model.learn(
            total_timesteps=cfg.total_timesteps,
            callback=callbacks,
            progress_bar=cfg.progress_bar,
            tb_log_name=cfg.model_name,
        )
    except KeyboardInterrupt:
        interrupted = True
    wall = time.perf_counter() - start
    save_policy_file(model, path)
    return wall, interrupted


def console_logger(verbose: int) -> Any:
    """An SB3 logger that prints its tables with ``verbose`` >= 1 and writes no files:
    without one, SB3 makes a new empty folder in the temp dir at every run."""
    from stable_baselines3.common.logger import HumanOutputFormat, Logger

    return Logger(None, [HumanOutputFormat(sys.stdout)] if verbose >= 1 else [])


def save_policy_file(model: Any, path: Path) -> None:
    """Save ``model`` without Adam's moment estimates: they would triple the file and
    only matter for resuming training (which then restarts the optimiser)."""
    policy = model.policy
    policy.optimizer = type(policy.optimizer)(policy.parameters(), **policy.optimizer.defaults)
    model.save(path)


def close_envs(interrupted: bool, *vec_envs: Any) -> None:
    """Close the training's VecEnvs (None: not made), quietly after a Ctrl-C."""
    for vec_env in vec_envs:
        if vec_env is not None:
            _close(vec_env, quietly=interrupted)


def _close(vec_env: Any, quietly: bool) -> None:
    """Close a VecEnv; after Ctrl-C its workers may already be gone (they get the
    SIGINT too), which must not hide the interruption."""
    try:
        vec_env.close()
    except (EOFError, BrokenPipeError, ConnectionResetError):
        if not quietly:
            raise
