"""RLlib policies as agents: the RLModule of a checkpoint that ``slam-env train --engine
rllib`` wrote, acting through the :class:`agents.base.Agent` interface (``rllib:PATH``).

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
import yaml

from agents.ppo import check_spaces

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


class RLlibAgent:
    """A trained RLlib RLModule with the :class:`agents.base.Agent` interface.
    Deterministic (the mode of the action distribution) unless told otherwise.

    Attributes:
        module: the torch RLModule, on the CPU, in evaluation mode.
        path: the checkpoint it was loaded from.
        config: the training config saved next to it (``<name>.yaml``), or ``None``.

    Its action depends on the observation alone, so ``evaluate`` runs its episodes
    side by side on the native vector env (:mod:`agents.vector_episodes`).
    """

    acts_on_batches = True

    def __init__(
        self,
        module: Any,
        path: Path | None = None,
        config: dict[str, Any] | None = None,
        deterministic: bool = True,
    ) -> None:
        self.module = module
        self.path = path
        self.config = config
        self.deterministic = deterministic
        self.observation_space = module.observation_space
        self.action_space = module.action_space
        self._dist_cls = module.get_inference_action_dist_cls()

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool | None = None,
    ) -> tuple[np.ndarray, Any]:
        """One action for one observation, or a (B, …) batch for a batch;
        ``deterministic=None`` uses the agent's default (``True``)."""
        import torch
        from ray.rllib.core.columns import Columns
        from ray.rllib.utils.spaces.space_utils import unsquash_action

        det = self.deterministic if deterministic is None else bool(deterministic)
        obs = np.asarray(observation, dtype=self.observation_space.dtype)
        single = obs.shape == self.observation_space.shape
        if not single and obs.shape[1:] != self.observation_space.shape:
            raise ValueError(
                f"observation of shape {obs.shape} does not fit the policy's "
                f"{self.observation_space.shape} (nor a batch of them)"
            )
        with torch.no_grad():
            out = self.module.forward_inference(
                {Columns.OBS: torch.from_numpy(obs[None] if single else obs)}
            )
            dist = self._dist_cls.from_logits(out[Columns.ACTION_DIST_INPUTS])
            if det:
                dist = dist.to_deterministic()
            actions = dist.sample().numpy()
        actions = np.stack([unsquash_action(a, self.action_space) for a in actions])
        actions = actions.astype(self.action_space.dtype, copy=False)
        return (actions[0] if single else actions), state

    def __repr__(self) -> str:
        return f"RLlibAgent(path={str(self.path)!r}, deterministic={self.deterministic})"


def load_rllib_agent(path: str | Path, env: gym.Env | None = None) -> RLlibAgent:
    """Load the policy of an RLlib checkpoint written by ``slam-env train --engine rllib``.

    With ``env``, its observation and action spaces must equal the policy's, else
    ``ValueError`` says how they differ. Raises
    :class:`agents.rllib_env.RLlibNotInstalledError` without Ray RLlib.
    """
    from agents.rllib_env import require_rllib

    require_rllib("an 'rllib:PATH' agent")
    from ray.rllib.core.rl_module.rl_module import RLModule

    module_dir = resolve_module_dir(path)
    module = RLModule.from_checkpoint(module_dir)
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
    config_file = checkpoint.with_name(checkpoint.name + ".yaml")
    config = None
    if config_file.is_file():
        with open(config_file, encoding="utf-8") as fh:
            loaded = yaml.safe_load(fh)
        config = loaded if isinstance(loaded, dict) else None
    return RLlibAgent(module, path=checkpoint, config=config)
