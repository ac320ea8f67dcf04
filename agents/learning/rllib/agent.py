"""RLlib policies as agents: the RLModule of a checkpoint that ``slam-env train --engine
rllib`` wrote, acting through the :class:`agents.common.base.Agent` interface (``rllib:PATH``)
as a :class:`agents.learning.ppo_agent.PPOAgent` does.

Only the module is restored (no Ray cluster, no env runners): ``PATH`` is the
algorithm checkpoint folder (``OUT/<model_name>``, ``OUT/checkpoints/…``,
``OUT/eval/best_model``) or the RLModule folder inside it. The action is what RLlib's
env runners send the env: the action distribution's mode (or a sample), mapped from
[-1, 1] onto the action space's bounds as RLlib's default ``normalize_actions`` does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.learning.ppo_agent import PPOAgent, check_spaces, saved_config

#: Where an algorithm checkpoint keeps the trained RLModule (RLlib's layout).
MODULE_SUBDIR = Path("learner_group") / "learner" / "rl_module" / "default_policy"


def resolve_module_dir(path: str | Path) -> Path:
    """The RLModule checkpoint folder that ``path`` names (an algorithm checkpoint or
    the module folder itself). Raises ``ValueError`` if there is none."""
    p = Path(path).expanduser()
    if not p.is_dir():
        raise ValueError(f"RLlib checkpoint folder not found: {p}")
    for candidate in (p / MODULE_SUBDIR, p):
        if (candidate / "class_and_ctor_args.pkl").is_file() and (
            candidate / "module_state.pkl"
        ).is_file():
            return candidate
    raise ValueError(
        f"{p} is not an RLlib checkpoint: no RLModule in it (expected {MODULE_SUBDIR}/)"
    )


class RLlibPolicy:
    """A trained RLlib RLModule with stable-baselines3's ``predict``, so that
    :class:`agents.learning.ppo_agent.PPOAgent` serves it as it serves a stable-baselines3 model
    (and ``evaluate`` runs its episodes side by side on the native vector env).

    Attributes:
        module: the torch RLModule, on the CPU, in evaluation mode.
    """

    def __init__(self, module: Any) -> None:
        self.module = module
        self.observation_space = module.observation_space
        self.action_space = module.action_space
        self._dist_cls = module.get_inference_action_dist_cls()

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, Any]:
        """The action for one observation, or a (B, …) batch of them for a batch."""
        import torch
        from ray.rllib.core.columns import Columns
        from ray.rllib.utils.spaces.space_utils import unsquash_action

        obs = np.asarray(observation, dtype=self.observation_space.dtype)
        single = obs.shape == self.observation_space.shape
        if not single and obs.shape[1:] != self.observation_space.shape:
            raise ValueError(
                f"observation of shape {obs.shape} does not fit the policy's "
                f"{self.observation_space.shape} (nor a batch of them)"
            )
        batch = torch.from_numpy(obs[None] if single else obs)
        with torch.no_grad():
            out = self.module.forward_inference({Columns.OBS: batch})
            dist = self._dist_cls.from_logits(out[Columns.ACTION_DIST_INPUTS])
            if deterministic:
                dist = dist.to_deterministic()
            actions = dist.sample().numpy()
        actions = np.stack([unsquash_action(a, self.action_space) for a in actions])
        actions = actions.astype(self.action_space.dtype, copy=False)
        return (actions[0] if single else actions), state


def load_rllib_agent(path: str | Path, env: gym.Env | None = None) -> PPOAgent:
    """Load the policy of an RLlib checkpoint written by ``slam-env train --engine
    rllib``: a :class:`agents.learning.ppo_agent.PPOAgent` over its :class:`RLlibPolicy`, with the
    training config saved next to the checkpoint (``<name>.yaml``).

    With ``env``, its observation and action spaces must equal the policy's, else
    ``ValueError`` says how they differ. Raises
    :class:`agents.learning.rllib.env.RLlibNotInstalledError` without Ray RLlib.
    """
    from agents.learning.rllib.env import require_rllib

    require_rllib("an 'rllib:PATH' agent")
    from ray.rllib.core.rl_module.rl_module import RLModule

    module = RLModule.from_checkpoint(resolve_module_dir(path))
    module.eval()
    if env is not None:
        check_spaces(
            module.observation_space,
            module.action_space,
            env.observation_space,
            env.action_space,
            source=f"RLlib policy {path}",
        )
    checkpoint = Path(path).expanduser()
    config = saved_config(checkpoint.with_name(checkpoint.name + ".yaml"))
    return PPOAgent(RLlibPolicy(module), path=checkpoint, config=config)
