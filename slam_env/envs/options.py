"""What the envs do with their options before anything is built: check the names, make
the config, check it against the resource budget (:mod:`slam_env.budget`), and build the
batched core, for B sub-envs (the single envs are B = 1 of the same call)."""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Mapping
from typing import Any

from slam_env.budget import check_budget, smoother_updates, world_size
from slam_env.config import EnvConfig, check_option_names, make_config, with_defaults
from slam_env.core.active import ActiveCore
from slam_env.core.active_options import ACTIVE_SLAM_DEFAULTS, ActiveSLAMOptions
from slam_env.core.raw import RawCore

__all__ = [
    "ACTIVE_ARGUMENTS",
    "ENV_ARGUMENTS",
    "active_config",
    "active_core",
    "check_active_options",
    "options_signature",
    "raw_core",
]

# The envs' own arguments besides the config options (for the list of valid names).
ENV_ARGUMENTS = ("config", "render_mode")
ACTIVE_ARGUMENTS = ENV_ARGUMENTS + ActiveSLAMOptions.argument_names()


def raw_core(num_envs: int, options: Mapping[str, Any], owner: str) -> RawCore:
    """The raw core of ``num_envs`` sub-envs of ``slam_env/Landmarks-v0`` with
    ``options`` (the config's, flat or nested, or a whole ``config``), checked first
    for all of its sub-envs together; an unknown name is refused as Python refuses it
    for the function ``owner``."""
    check_option_names(options, ENV_ARGUMENTS, owner)
    options = dict(options)
    config = make_config(options.pop("config", None), **options)
    # Everything that scales work or memory, for all the sub-envs, before it is built.
    check_budget(config, world_size(config), num_envs=num_envs)
    return RawCore(config, num_envs)


def active_core(num_envs: int, options: Mapping[str, Any], owner: str) -> ActiveCore:
    """The active-SLAM core of ``num_envs`` sub-envs of ``slam_env/ActiveSLAM-v0`` with
    ``options``: its own (:class:`ActiveSLAMOptions`) and the world's, checked first (an
    unknown name as Python refuses it for the function ``owner``)."""
    active, config = check_active_options(num_envs, options, owner)
    return ActiveCore(config, num_envs, active, max_updates=smoother_updates(num_envs))


def check_active_options(
    num_envs: int, options: Mapping[str, Any], owner: str = "ActiveSLAMEnv.__init__"
) -> tuple[ActiveSLAMOptions, EnvConfig]:
    """``options`` of ``num_envs`` sub-envs of ``slam_env/ActiveSLAM-v0`` checked as
    making the env checks them (the option table, the budget), nothing built: its own
    options and the world's config. ``TypeError`` for an unknown name (as Python
    refuses it for the function ``owner``), ``ValueError`` for a bad value."""
    env_options = dict(options)
    own = {k: env_options.pop(k) for k in ActiveSLAMOptions.argument_names() if k in options}
    active = ActiveSLAMOptions(**own)
    check_option_names(env_options, ACTIVE_ARGUMENTS, owner)
    return active, active_config(active, env_options, num_envs)


def options_signature(init: Any, table: type) -> inspect.Signature:
    """``init``'s signature with the fields of the option ``table`` as keyword-only
    parameters (their defaults), before its ``**options``: what ``help()`` shows."""
    params = list(inspect.signature(init).parameters.values())
    rest = params.pop()  # **options: the world's
    params += [
        inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, default=f.default)
        for f in dataclasses.fields(table)
        if f.init
    ]
    return inspect.Signature([*params, rest])


def active_config(
    options: ActiveSLAMOptions, env_options: Mapping[str, Any], num_envs: int
) -> EnvConfig:
    """The world's config of ``ActiveSLAM-v0`` from its options (flat or nested, with
    :data:`ACTIVE_SLAM_DEFAULTS`), checked with ``options`` against the resource budget
    for ``num_envs`` sub-envs before anything is built."""
    env_options = with_defaults(env_options, ACTIVE_SLAM_DEFAULTS)
    config = make_config(env_options.pop("config", None), **env_options)
    check_budget(
        config,
        world_size(config),
        belief=options.observation,
        coverage=options.coverage,
        filter_alphas=options.filter_alphas,
        filter_control_noise=options.filter_control_noise,
        filter_measurement_cov=options.filter_measurement_cov,
        reward_weights=vars(options.weights),
        num_envs=num_envs,
        association=options.data_association != "known",
        jcbb=options.data_association == "jcbb",
    )
    options.check_against(config)
    return config
