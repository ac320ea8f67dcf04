"""The training's budget: the limits on the options that scale a training's memory and
CPU use, checked before anything is built (as :mod:`slam_env.budget` checks the env's).

* the rollout buffer: at most :data:`MAX_ROLLOUT_BYTES` (2 GiB): ``n_envs`` ×
  ``ppo.n_steps`` × (observation + action + :data:`PER_STEP_FLOATS`) float32, ×
  :data:`ROLLOUT_COPIES`;
* the policy's parameters: at most :data:`MAX_POLICY_PARAMETERS` (50 million), the
  actor's and the critic's ``ppo.net_arch`` MLPs on the flattened observation;
* ``torch_threads``: at most the machine's CPUs
  (:func:`agents.learning.config.max_torch_threads`, checked with the config).

Each refusal is a :class:`~agents.learning.config.ConfigError` that names the options.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import gymnasium as gym

from agents.learning.config import ConfigError, TrainConfig

#: What SB3's rollout buffer may hold, over all the sub-envs.
MAX_ROLLOUT_BYTES = 2 * 2**30
#: Floats per step besides the observation and the action: reward, return, episode
#: start, value, log-probability, advantage.
PER_STEP_FLOATS = 6
#: The buffer's arrays and their flattened copies while the policy is updated.
ROLLOUT_COPIES = 2
#: Weights of the actor and the critic; each is held four times (the weights, their
#: gradients and Adam's two moments): 800 MB of float32 at the limit.
MAX_POLICY_PARAMETERS = 50_000_000


def _action_floats(space: gym.Space) -> tuple[int, int]:
    """(floats an action takes in the buffer, outputs of the actor's head)."""
    if isinstance(space, gym.spaces.Discrete):
        return 1, int(space.n)
    return gym.spaces.flatdim(space), gym.spaces.flatdim(space)


def rollout_bytes(
    n_envs: int, n_steps: int, observation: gym.Space, action: gym.Space, extra: int = 0
) -> int:
    """Bytes of the rollout buffer of ``n_envs`` × ``n_steps`` steps (``extra`` floats
    per step more, e.g. a recurrent policy's states)."""
    floats = gym.spaces.flatdim(observation) + _action_floats(action)[0] + PER_STEP_FLOATS
    return n_envs * n_steps * (floats + extra) * 4 * ROLLOUT_COPIES


def policy_parameters(net_arch: Sequence[int], observation: gym.Space, action: gym.Space) -> int:
    """Weights of the actor (``net_arch``, then its head, and the Gaussian's log σ)
    and of the critic (``net_arch``, then the value), on the flattened observation."""
    outputs = _action_floats(action)[1]
    sizes = [gym.spaces.flatdim(observation), *net_arch]
    body = sum((a + 1) * b for a, b in itertools.pairwise(sizes))
    log_std = 0 if isinstance(action, gym.spaces.Discrete) else outputs
    return 2 * body + (sizes[-1] + 1) * (outputs + 1) + log_std


def check_training_budget(
    cfg: TrainConfig, observation: gym.Space, action: gym.Space, extra: int = 0
) -> None:
    """``ConfigError`` naming the options where ``cfg``'s training on these spaces would
    exceed the budget (see the module)."""
    n_envs, n_steps = cfg.n_envs, cfg.ppo.n_steps
    size = rollout_bytes(n_envs, n_steps, observation, action, extra)
    if size > MAX_ROLLOUT_BYTES:
        floats = gym.spaces.flatdim(observation)
        raise ConfigError(
            f"rollout buffer = n_envs {n_envs} × ppo.n_steps {n_steps} × ({floats} observation "
            f"+ {size // (n_envs * n_steps * 4 * ROLLOUT_COPIES) - floats} more) floats = "
            f"{size / 2**30:.3g} GiB exceeds the budget of {MAX_ROLLOUT_BYTES / 2**30:g} GiB; "
            "lower n_envs or ppo.n_steps"
        )
    weights = policy_parameters(cfg.ppo.net_arch, observation, action)
    if weights > MAX_POLICY_PARAMETERS:
        raise ConfigError(
            f"policy parameters = {weights} (ppo.net_arch {cfg.ppo.net_arch} on "
            f"{gym.spaces.flatdim(observation)} observation floats) exceed the budget of "
            f"{MAX_POLICY_PARAMETERS}; use smaller layers"
        )
