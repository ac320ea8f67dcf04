"""Training a goal-choosing policy (``decisions: goals`` in a training config) and
loading one (``slam-env evaluate --agents goals:PATH``).

``slam-env train --config agents/configs/goal_explore.yaml`` runs stable-baselines3
PPO on :class:`~agents.learning.goal_env.GoalChoiceEnv` sub-envs (one per worker process with
``vectorization: subproc``, or in-process with ``dummy``), every episode in a world
drawn from the config's ``worlds``, and writes into ``out_dir``::

    <model_name>.zip          the final policy
    <model_name>.yaml         the resolved config
    training_summary.json     choices made, wall time, the shares of env stepping and updates
    checkpoints/<model_name>_<N>_steps.zip
    eval/best_model.zip, eval/evaluations.npz   (by the return, on the default world)

``total_timesteps`` counts choices; the config's ``env_options.reward_weights``
shape the reward (:class:`~agents.learning.goal_env.GoalChoiceEnv`). ``memory`` says what the
policy remembers beyond the features of the choice at hand: nothing (``features``),
the features of its last ``memory_frames`` choices (``frame_stack``, SB3's
``VecFrameStack``), or an LSTM of ``memory_units`` (``recurrent``, sb3-contrib's
``RecurrentPPO``). :func:`load_goal_agent` runs any of them with the memory it was
trained with. ``curriculum`` grows the training worlds' arenas over that share of the
training (:class:`~agents.learning.goal_env.GoalChoiceEnv`'s ``curriculum_choices``).
``imitation_choices`` starts the policy from a fixed rule's choices before PPO
(:mod:`agents.learning.goal_imitation`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.goals.choice import (
    CHOICES,
    FEATURE_BOUND,
    N_FEATURES,
    GoalChoiceAgent,
    check_hold_goals,
    choice_space,
    feature_space,
)
from agents.learning.budget import check_training_budget
from agents.learning.config import TrainConfig, write_config
from agents.learning.goal_env import GoalChoiceEnv
from agents.learning.runs import model_path as checked_model_path
from agents.learning.runs import write_summary
from agents.learning.sb3.runs import (
    checkpoint_callbacks,
    close_envs,
    eval_arguments,
    learn_and_save,
    ppo_arguments,
)
from agents.learning.worlds import WorldDistribution


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
    curriculum_choices: int = 0
    hold_goals: bool = False

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
            self.curriculum_choices,
            self.hold_goals,
        )


def train_goal_choice(cfg: TrainConfig) -> Path:
    """Train a goal-choosing PPO policy as ``cfg`` says; the path of its ``.zip``."""
    import torch
    from stable_baselines3.common.callbacks import EvalCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from agents.learning.sb3.timing import StepTimer, time_shares

    model_path = checked_model_path(cfg)
    check_goal_budget(cfg)
    torch.set_num_threads(cfg.torch_threads)
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_config(cfg, out / f"{cfg.model_name}.yaml")
    factory = GoalEnvFactory(
        dict(cfg.env_options),
        cfg.worlds,
        cfg.max_episode_steps,
        cfg.torch_threads,
        cfg.discovery_bonus,
        cfg.discovery_until,
        cfg.discovery_schedule,
        math.ceil(cfg.curriculum * cfg.total_timesteps / cfg.n_envs),  # each sub-env's part
        cfg.hold_goals,
    )
    if cfg.vectorization == "subproc":
        vec_cls, vec_kwargs = SubprocVecEnv, {"start_method": cfg.start_method}
    else:
        vec_cls, vec_kwargs = DummyVecEnv, None
    train_env = StepTimer(
        with_memory(
            make_vec_env(
                factory, cfg.n_envs, seed=cfg.seed, vec_env_cls=vec_cls, vec_env_kwargs=vec_kwargs
            ),
            cfg,
        )
    )
    eval_env = None
    interrupted = False
    try:
        model = _algorithm(cfg, train_env, out)
        model.hold_goals = cfg.hold_goals  # saved with it, for load_goal_agent
        imitation = None
        if cfg.imitation_choices:
            from agents.learning.goal_imitation import imitate

            imitation = imitate(
                model, train_env, cfg.imitation_choices, cfg.imitation_epochs, cfg.seed
            )
        stepped_before = train_env.seconds  # the teacher's choices are timed on their own
        callbacks = checkpoint_callbacks(cfg, out)
        if cfg.eval_freq > 0:
            default_world = dataclasses.replace(factory, worlds=None)
            # (in a StepTimer too: EvalCallback warns when the two envs' types differ)
            eval_env = StepTimer(
                with_memory(
                    make_vec_env(default_world, 1, seed=cfg.eval_seed, vec_env_cls=DummyVecEnv),
                    cfg,
                )
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
            **time_shares(wall, train_env.seconds - stepped_before, model.update_seconds),
            "interrupted": interrupted,
            "imitation": imitation,
            "recent_episode_return": (
                round(float(np.mean([e["r"] for e in episodes])), 4) if episodes else None
            ),
        }
        write_summary(out, summary, interrupted, model_path)
    finally:
        close_envs(interrupted, train_env, eval_env)
    return model_path


def check_goal_budget(cfg: TrainConfig) -> None:
    """The training's budget (:mod:`agents.learning.budget`) on the policy's input: the
    features, times the frames a frame stack holds; a recurrent policy's buffer keeps
    its LSTMs' states (h and c, actor and critic) each step too."""
    features = feature_space()
    if cfg.memory == "frame_stack":
        low = np.tile(features.low, cfg.memory_frames)
        features = gym.spaces.Box(low, np.tile(features.high, cfg.memory_frames))
    extra = 4 * cfg.memory_units if cfg.memory == "recurrent" else 0
    check_training_budget(cfg, features, choice_space(), extra)


def with_memory(venv: Any, cfg: TrainConfig) -> Any:
    """``venv`` with the frame stack of ``memory: frame_stack`` (else as it is)."""
    if cfg.memory != "frame_stack":
        return venv
    from stable_baselines3.common.vec_env import VecFrameStack

    return VecFrameStack(venv, cfg.memory_frames)


def _algorithm(cfg: TrainConfig, venv: Any, out: Path) -> Any:
    """PPO on the features, or sb3-contrib's RecurrentPPO for ``memory: recurrent``,
    timing its updates (:class:`~agents.learning.sb3.timing.UpdateTimer`)."""
    from agents.learning.sb3.timing import TimedPPO, UpdateTimer

    arguments = ppo_arguments(cfg, out)
    if cfg.memory != "recurrent":
        return TimedPPO("MlpPolicy", venv, **arguments)
    from sb3_contrib import RecurrentPPO

    class TimedRecurrentPPO(UpdateTimer, RecurrentPPO):
        """sb3-contrib's RecurrentPPO with :class:`UpdateTimer`."""

    arguments["policy_kwargs"]["lstm_hidden_size"] = cfg.memory_units
    return TimedRecurrentPPO("MlpLstmPolicy", venv, **arguments)


class PolicyChooser:
    """The greedy choices of a trained policy, with the memory it was trained with: the
    features of its last ``frames`` choices stacked as ``VecFrameStack`` stacks them
    (zeros before the episode's first), or its LSTM's state; :meth:`reset` at each
    episode's start (:class:`~agents.goals.choice.GoalChoiceAgent` calls it)."""

    def __init__(self, model: Any, frames: int) -> None:
        self._model = model
        self._frames = frames
        self.reset()

    def reset(self) -> None:
        from stable_baselines3.common.vec_env.stacked_observations import StackedObservations

        self._stack = StackedObservations(1, self._frames, feature_space())
        self._state: Any = None
        self._first = True

    def __call__(self, features: np.ndarray) -> int:
        obs = features[None]
        if self._first:
            obs = self._stack.reset(obs)
        else:
            obs, _ = self._stack.update(obs, np.zeros(1, dtype=bool), [{}])
        action, self._state = self._model.predict(
            obs, state=self._state, episode_start=np.array([self._first]), deterministic=True
        )
        self._first = False
        return int(action[0])


def _load_model(path: Path) -> Any:
    """The PPO or RecurrentPPO saved at ``path``."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.save_util import load_from_zip_file

    try:
        data, _, _ = load_from_zip_file(path, device="cpu", print_system_info=False)
    except ModuleNotFoundError as exc:
        raise ValueError(
            f"{path} needs the module {exc.name!r} to load (a recurrent goal policy needs "
            "sb3-contrib: pip install 'slam_env[recurrent]')"
        ) from None
    if _is_recurrent(data.get("policy_class")):
        from sb3_contrib import RecurrentPPO

        return RecurrentPPO.load(path, device="cpu")
    return PPO.load(path, device="cpu")


def _is_recurrent(policy_class: Any) -> bool:
    try:
        from sb3_contrib.common.recurrent.policies import RecurrentActorCriticPolicy
    except ImportError:  # then no policy class of it could have been unpickled
        return False
    return isinstance(policy_class, type) and issubclass(policy_class, RecurrentActorCriticPolicy)


def load_goal_agent(path: str | Path, env: gym.Env, seed: int | None = None) -> GoalChoiceAgent:
    """The :class:`GoalChoiceAgent` of the policy saved at ``path``, acting on ``env``
    (greedy choices, with the policy's memory). ``ValueError`` for a missing file or a
    policy of other spaces."""
    from agents.learning.ppo_agent import resolve_policy_path

    path = resolve_policy_path(path)
    model = _load_model(path)
    space = model.observation_space
    flat = isinstance(space, gym.spaces.Box) and len(space.shape) == 1
    frames = space.shape[0] // N_FEATURES if flat else 0
    stacked = gym.spaces.Box(-FEATURE_BOUND, FEATURE_BOUND, (frames * N_FEATURES,), np.float32)
    if frames < 1 or space != stacked or model.action_space != choice_space():
        raise ValueError(
            f"{path} is not a goal-choosing policy: it takes {space} to {model.action_space}, "
            f"not {feature_space()} (or a stack of them) to {len(CHOICES)} choices"
        )
    hold_goals = getattr(model, "hold_goals", False)  # False in files from before the key
    try:
        check_hold_goals(hold_goals)
    except TypeError as exc:  # a bad file, not a bad argument
        raise ValueError(f"{path}: {exc}") from None
    return GoalChoiceAgent(env, PolicyChooser(model, frames), seed=seed, hold_goals=hold_goals)
