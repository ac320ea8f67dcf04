"""Training a goal-choosing policy (``decisions: goals`` in a training config) and
loading one (``slam-env evaluate --agents goals:PATH``).

``slam-env train --config agents/configs/goal_explore.yaml`` runs stable-baselines3
PPO on :class:`~agents.goal_env.GoalChoiceEnv` sub-envs (one per worker process with
``vectorization: subproc``, or in-process with ``dummy``), every episode in a world
drawn from the config's ``worlds``, and writes into ``out_dir``::

    <model_name>.zip          the final policy
    <model_name>.yaml         the resolved config
    training_summary.json     choices made, wall time, the shares of env stepping and updates
    checkpoints/<model_name>_<N>_steps.zip
    eval/best_model.zip, eval/evaluations.npz   (by the return, on the default world)

``total_timesteps`` counts choices; the config's ``env_options.reward_weights``
shape the reward (:class:`~agents.goal_env.GoalChoiceEnv`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.goal_choice import CHOICES, GoalChoiceAgent, choice_space, feature_space
from agents.goal_env import GoalChoiceEnv
from agents.training import (
    TrainConfig,
    _write_yaml,
    checkpoint_callbacks,
    close_envs,
    eval_arguments,
    learn_and_save,
    ppo_arguments,
    write_summary,
)
from agents.world_sampling import WorldDistribution


@dataclass(frozen=True)
class GoalEnvFactory:
    """A picklable :class:`GoalChoiceEnv` constructor for worker processes."""

    env_options: dict[str, Any]
    worlds: dict[str, Any] | None
    max_steps: int | None
    torch_threads: int
    discovery_bonus: float = 0.0
    discovery_until: float = 1.0
    discovery_schedule: str = "flat"

    def __call__(self) -> gym.Env:
        import torch

        torch.set_num_threads(self.torch_threads)
        worlds = None if self.worlds is None else WorldDistribution.from_mapping(self.worlds)
        return GoalChoiceEnv(
            self.env_options,
            worlds,
            self.max_steps,
            self.discovery_bonus,
            self.discovery_until,
            self.discovery_schedule,
        )


def train_goal_choice(cfg: TrainConfig) -> Path:
    """Train a goal-choosing PPO policy as ``cfg`` says; the path of its ``.zip``."""
    import torch
    from stable_baselines3.common.callbacks import EvalCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from agents.train_timing import StepTimer, TimedPPO, time_shares

    torch.set_num_threads(cfg.torch_threads)
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model_path = out / f"{cfg.model_name}.zip"
    _write_yaml(cfg, out / f"{cfg.model_name}.yaml")
    factory = GoalEnvFactory(
        dict(cfg.env_options),
        cfg.worlds,
        cfg.max_episode_steps,
        cfg.torch_threads,
        cfg.discovery_bonus,
        cfg.discovery_until,
        cfg.discovery_schedule,
    )
    if cfg.vectorization == "subproc":
        vec_cls, vec_kwargs = SubprocVecEnv, {"start_method": cfg.start_method}
    else:
        vec_cls, vec_kwargs = DummyVecEnv, None
    train_env = StepTimer(
        make_vec_env(
            factory, cfg.n_envs, seed=cfg.seed, vec_env_cls=vec_cls, vec_env_kwargs=vec_kwargs
        )
    )
    eval_env = None
    interrupted = False
    try:
        model = TimedPPO("MlpPolicy", train_env, **ppo_arguments(cfg, out))
        callbacks = checkpoint_callbacks(cfg, out)
        if cfg.eval_freq > 0:
            default_world = dataclasses.replace(factory, worlds=None)
            # (in a StepTimer too: EvalCallback warns when the two envs' types differ)
            eval_env = StepTimer(
                make_vec_env(default_world, 1, seed=cfg.eval_seed, vec_env_cls=DummyVecEnv)
            )
            callbacks.append(EvalCallback(eval_env, **eval_arguments(cfg, out)))
        wall, interrupted = learn_and_save(model, cfg, callbacks, model_path)
        episodes = list(model.ep_info_buffer or ())  # None if stopped before the first rollout
        summary = {
            "model": str(model_path),
            "choices": int(model.num_timesteps),
            "wall_time_s": round(wall, 3),
            "choices_per_s": round(model.num_timesteps / wall, 1) if wall > 0 else None,
            "n_envs": cfg.n_envs,
            "vectorization": cfg.vectorization,
            **time_shares(wall, train_env.seconds, model.update_seconds),
            "interrupted": interrupted,
            "recent_episode_return": (
                round(float(np.mean([e["r"] for e in episodes])), 4) if episodes else None
            ),
        }
        write_summary(out, summary, interrupted, model_path)
    finally:
        close_envs(interrupted, train_env, eval_env)
    return model_path


def load_goal_agent(path: str | Path, env: gym.Env, seed: int | None = None) -> GoalChoiceAgent:
    """The :class:`GoalChoiceAgent` of the policy saved at ``path``, acting on ``env``
    (greedy choices). ``ValueError`` for a missing file or a policy of other spaces."""
    from stable_baselines3 import PPO

    from agents.ppo import resolve_policy_path

    path = resolve_policy_path(path)
    model = PPO.load(path, device="cpu")
    expected = (feature_space(), choice_space())
    if (model.observation_space, model.action_space) != expected:
        raise ValueError(
            f"{path} is not a goal-choosing policy: it takes {model.observation_space} to "
            f"{model.action_space}, not {expected[0]} to {len(CHOICES)} choices"
        )

    def choose(features: np.ndarray) -> int:
        action, _ = model.predict(features, deterministic=True)
        return int(action)

    return GoalChoiceAgent(env, choose, seed=seed)
