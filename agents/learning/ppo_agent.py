"""Trained PPO policies as agents: load a stable-baselines3 ``.zip`` and act with it."""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import yaml

from slam_env.extras import require

# Loading for inference only: the training schedules are replaced by constants, so a
# model saved with another Python/SB3 version (whose pickled lambdas may not load)
# still predicts.
_INFERENCE_OBJECTS = {
    "learning_rate": 0.0,
    "lr_schedule": lambda _: 0.0,
    "clip_range": lambda _: 0.0,
}


def resolve_policy_path(path: str | Path) -> Path:
    """The ``.zip`` file that ``path`` names (``.zip`` may be left off, as in SB3).
    Raises ``ValueError`` if there is none."""
    p = Path(path).expanduser()
    if p.is_file():
        return p
    with_zip = p.with_name(p.name + ".zip")
    if p.suffix != ".zip" and with_zip.is_file():
        return with_zip
    raise ValueError(f"PPO policy file not found: {p}")


def _describe(space: gym.Space) -> str:
    if isinstance(space, gym.spaces.Box):
        return f"Box(shape={space.shape}, dtype={space.dtype})"
    return repr(space)


def check_spaces(
    policy_obs: gym.Space,
    policy_act: gym.Space,
    env_obs: gym.Space,
    env_act: gym.Space,
    source: str = "the policy",
) -> None:
    """Raise ``ValueError`` if a policy's spaces differ from an env's, saying which."""
    problems = []
    if policy_obs != env_obs:
        problems.append(f"observation space {_describe(policy_obs)} != env's {_describe(env_obs)}")
    if policy_act != env_act:
        problems.append(f"action space {_describe(policy_act)} != env's {_describe(env_act)}")
    if problems:
        raise ValueError(
            f"{source} does not fit this env: {'; '.join(problems)}. Evaluate it with the "
            "env options it was trained with (see the config YAML saved next to it)."
        )


class PPOAgent:
    """A trained PPO policy with the :class:`agents.common.base.Agent` interface.
    Deterministic (the mean action) unless told otherwise.

    Attributes:
        model: the ``stable_baselines3.PPO`` model (or an RLlib policy with its
            ``predict``, :class:`agents.learning.rllib.agent.RLlibPolicy`).
        path: the file it was loaded from.
        config: the training config saved next to it (``<name>.yaml``), or ``None``.

    Its action depends on the observation alone, so ``evaluate`` runs its episodes
    side by side on the native vector env (:mod:`agents.rollouts.vector_episodes`).
    """

    acts_on_batches = True

    def __init__(
        self,
        model: Any,
        path: Path | None = None,
        config: dict[str, Any] | None = None,
        deterministic: bool = True,
    ) -> None:
        self.model = model
        self.path = path
        self.config = config
        self.deterministic = deterministic
        self.observation_space = model.observation_space
        self.action_space = model.action_space

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool | None = None,
    ) -> tuple[np.ndarray, Any]:
        """``deterministic=None`` uses the agent's default (``True``)."""
        det = self.deterministic if deterministic is None else bool(deterministic)
        return self.model.predict(
            observation, state=state, episode_start=episode_start, deterministic=det
        )

    def __repr__(self) -> str:
        return f"PPOAgent(path={str(self.path)!r}, deterministic={self.deterministic})"


def load_ppo_agent(path: str | Path, env: gym.Env | None = None) -> PPOAgent:
    """Load a PPO ``.zip`` saved by ``slam-env train`` (or any SB3 PPO model).

    With ``env``, its observation and action spaces must equal the policy's, else
    ``ValueError`` says how they differ. The model runs on the CPU.
    """
    require("agents", "a PPO policy")
    from stable_baselines3 import PPO

    file = resolve_policy_path(path)
    try:
        model = PPO.load(file, device="cpu", custom_objects=_INFERENCE_OBJECTS)
    except (zipfile.BadZipFile, KeyError, ValueError, EOFError) as exc:
        raise ValueError(f"{file} is not a stable-baselines3 PPO model: {exc}") from exc
    if env is not None:
        check_spaces(
            model.observation_space,
            model.action_space,
            env.observation_space,
            env.action_space,
            source=f"PPO policy {file}",
        )
    return PPOAgent(model, path=file, config=saved_config(file.with_suffix(".yaml")))


def saved_config(config_file: Path) -> dict[str, Any] | None:
    """The training config saved next to a policy (``<name>.yaml``), or ``None``."""
    if not config_file.is_file():
        return None
    with open(config_file, encoding="utf-8") as fh:
        loaded = yaml.safe_load(fh)
    return loaded if isinstance(loaded, dict) else None
