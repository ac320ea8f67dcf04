"""slam_env's IDs in Ray RLlib, by their plain names, on every worker of a cluster.

RLlib's EnvRunners are fresh processes (on any node) that never ``import slam_env``,
so ``gym.make("slam_env/ActiveSLAM-v0")`` fails there with ``NamespaceNotFound``.
:func:`register_rllib_envs` registers each ID with Ray's env registry
(``ray.tune.register_env``), which the cluster shares: a worker that meets the plain
ID calls :func:`make_rllib_env`, which imports ``slam_env`` first. RLlib asks the
creator for a single env (its ``sync``/``async`` vectorisation) or, with
``gym_env_vectorize_mode="vector_entry_point"``, for ``num_envs`` sub-envs at once, and
then gets slam_env's native vector env: one call steps every sub-env of the runner.

    from agents.learning.rllib.env import register_rllib_envs
    register_rllib_envs()  # after or before ray.init()
    config = PPOConfig().environment("slam_env/ActiveSLAM-v0", env_config={"n_landmarks": 8})
"""

from __future__ import annotations

import functools
import importlib.util
from collections.abc import Mapping
from typing import Any

import gymnasium as gym

#: The IDs registered with Ray (those ``import slam_env`` registers with Gymnasium).
RLLIB_ENV_IDS = ("slam_env/ActiveSLAM-v0", "slam_env/Landmarks-v0")
#: The key under which RLlib passes the sub-env count to a vector env's creator.
NUM_ENVS_KEY = "num_envs"
#: How to install what the RLlib engine needs (named in the error when it is missing).
RLLIB_INSTALL = "pip install -e '.[rllib]'"


class RLlibNotInstalledError(ImportError, ValueError):
    """Ray RLlib is not installed. An ``ImportError``, and a ``ValueError`` so that the
    command line reports it on one line (status 2) like its other set-up errors."""


def require_rllib(what: str) -> None:
    """Raise :class:`RLlibNotInstalledError` naming the extra unless ``ray.rllib`` can be
    imported; ``what`` says what needed it (e.g. ``"--engine rllib"``)."""
    try:
        found = importlib.util.find_spec("ray.rllib") is not None
    except (ImportError, ValueError):  # no ``ray`` package, or a broken one
        found = False
    if not found:
        raise RLlibNotInstalledError(
            f"{what} needs Ray RLlib, which is not installed: {RLLIB_INSTALL} "
            "(in its own virtual environment: Ray pins gymnasium, see the README)"
        )


def make_rllib_env(env_id: str, env_config: Mapping[str, Any]) -> gym.Env | gym.vector.VectorEnv:
    """The env ``env_id`` with the keyword options ``env_config`` (an RLlib
    ``EnvContext``): the native vector env of ``num_envs`` sub-envs when RLlib passes
    ``num_envs`` (its ``vector_entry_point`` mode), else the single env."""
    import slam_env  # noqa: F401  (registers the IDs in this worker's Gymnasium)

    options = dict(env_config)
    num_envs = options.pop(NUM_ENVS_KEY, None)
    if num_envs is None:
        return gym.make(env_id, **options)
    return gym.make_vec(
        env_id, num_envs=int(num_envs), vectorization_mode="vector_entry_point", **options
    )


def register_rllib_envs() -> None:
    """Register :data:`RLLIB_ENV_IDS` with Ray's env registry (idempotent)."""
    from ray.tune.registry import register_env

    for env_id in RLLIB_ENV_IDS:
        register_env(env_id, functools.partial(make_rllib_env, env_id))
