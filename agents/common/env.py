"""The env every agent acts on: ``slam_env/ActiveSLAM-v0``, made with its options."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from agents.common.arguments import check_count

#: The env every agent acts on; the ``module:`` prefix imports ``slam_env`` (which
#: registers it) in a fresh process, such as a ``SubprocVecEnv`` worker.
ENV_ID = "slam_env:slam_env/ActiveSLAM-v0"


def make_env(
    env_options: dict[str, Any] | None = None,
    max_steps: int | None = None,
    render_mode: str | None = None,
) -> gym.Env:
    """``gym.make`` the active-SLAM env with ``env_options`` (keyword options of
    :class:`slam_env.envs.active_slam.ActiveSLAMEnv`) and an optional episode length.

    Raises ``ValueError`` naming the bad option (the env raises ``TypeError`` for
    unknown options; a command line reports both the same way).
    """
    options = dict(env_options or {})
    for reserved in ("render_mode", "max_episode_steps"):
        if reserved in options:
            raise ValueError(f"env option {reserved!r} is set by the caller, not in env_options")
    kwargs: dict[str, Any] = {}
    if max_steps is not None:
        check_count("max_steps", max_steps, 1)
        kwargs["max_episode_steps"] = max_steps
    try:
        return gym.make(ENV_ID, render_mode=render_mode, **kwargs, **options)
    except TypeError as exc:
        raise ValueError(f"bad env options {options}: {exc}") from exc


def check_env_options(env_options: dict[str, Any] | None, num_envs: int = 1) -> None:
    """``ValueError`` naming the first bad option, as :func:`make_env` would raise it for
    ``num_envs`` sub-envs (the option table, the budget), without building anything."""
    from slam_env.envs.options import check_active_options

    options = dict(env_options or {})
    try:
        check_active_options(num_envs, options)
    except TypeError as exc:
        raise ValueError(f"bad env options {options}: {exc}") from exc
