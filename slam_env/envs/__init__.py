"""The Gymnasium envs: the single envs (:mod:`.landmarks`, :mod:`.active_slam`, sub-env 0
of a batched core, :mod:`.single`), the native vector envs (:mod:`.vector`), what they do
with their options before anything is built (:mod:`.options`), actions and registration.

The names below are imported on first use (PEP 562), so that ``import slam_env``, which
registers the IDs, and ``gym.make`` of one ID load only what that ID runs.
"""

import importlib
from typing import Any

_HOMES = {
    "ActiveSLAMEnv": "slam_env.envs.active_slam",
    "ActiveSLAMVectorEnv": "slam_env.envs.vector",
    "DEFAULT_MAX_EPISODE_STEPS": "slam_env.envs.registration",
    "DISCRETE_PRIMITIVES": "slam_env.envs.actions",
    "LandmarksEnv": "slam_env.envs.landmarks",
    "LandmarksVectorEnv": "slam_env.envs.vector",
    "register_envs": "slam_env.envs.registration",
}

__all__ = sorted(_HOMES)


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_HOMES[name]), name)


def __dir__() -> list[str]:
    return __all__
