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
(:mod:`agents.slam_callbacks`); the best model is the evaluation's best by
:data:`agents.slam_metrics.BEST_MODEL_CRITERION`.

The config and its checks are :mod:`agents.train_config`'s.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from agents.registry import ENV_ID, make_env
from agents.slam_metrics import BEST_MODEL_CRITERION
from agents.train_config import ConfigError, TrainConfig, as_train_config, write_config


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
        from agents.world_sampling import WorldDistribution, WorldSamplingVecEnv

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
        from agents.sb3_vector import make_sb3_vec_env

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


def _check_env(cfg: TrainConfig) -> str:
    """Fail here, with the env's message, rather than in a worker process; return the
    SB3 policy that takes the env's observation (``MlpPolicy`` for the flat egocentric
    belief, ``MultiInputPolicy`` for a ``Dict`` such as the local one)."""
    env = make_env(cfg.env_options, cfg.max_episode_steps)
    try:
        env.reset(seed=cfg.seed)  # e.g. a random world that cannot be laid out
        space = env.observation_space
    finally:
        env.close()
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


def _make_callbacks(cfg: TrainConfig, out: Path, eval_env: Any) -> list[Any]:
    from agents.slam_callbacks import SlamEvalCallback, SlamMetricsCallback

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


def train(config: TrainConfig | Mapping[str, Any] | str | Path | None = None) -> Path:
    """Train PPO as ``config`` says (a :class:`TrainConfig`, a mapping, a YAML path,
    or ``None`` for the defaults) and return the path of the saved ``.zip``."""
    import torch

    from agents.train_timing import StepTimer, TimedPPO, time_shares

    cfg = as_train_config(config)
    if cfg.decisions == "goals":
        from agents.goal_training import train_goal_choice

        return train_goal_choice(cfg)
    torch.set_num_threads(cfg.torch_threads)
    policy = _check_env(cfg)
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model_path = out / f"{cfg.model_name}.zip"
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
        callbacks = _make_callbacks(cfg, out, eval_env)
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
            **shares,
            "interrupted": interrupted,
            "last_eval_mean_reward": _finite(evals[0].last_mean_reward) if evals else None,
            "best_eval_mean_reward": _finite(evals[0].best_mean_reward) if evals else None,
            "last_eval_slam": _finite_map(evals[0].last_slam) if evals else None,
            "best_eval_slam": _finite_map(evals[0].best_slam) if evals else None,
            "best_model_criterion": BEST_MODEL_CRITERION,
        }
        write_summary(out, summary, interrupted, model_path)
    finally:
        close_envs(interrupted, train_env, eval_env)
    return model_path


def write_summary(out: Path, summary: dict[str, Any], interrupted: bool, model: Path) -> None:
    """``training_summary.json`` into ``out``; then, if Ctrl-C stopped the training,
    the ``KeyboardInterrupt`` that says where the policy was saved."""
    (out / "training_summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    if interrupted:
        raise KeyboardInterrupt(f"training interrupted; model saved to {model}")


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


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _finite_map(figures: Mapping[str, float] | None) -> dict[str, float | None] | None:
    return None if figures is None else {k: _finite(v) for k, v in figures.items()}
