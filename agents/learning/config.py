"""The training config of ``slam-env train``: its keys (:class:`TrainConfig`,
:class:`PPOParams`), their checks, and reading and writing it as YAML.

The config comes from a YAML file (``agents/configs/ppo_default.yaml`` holds every
key with its default); unknown keys and wrong types are a :class:`ConfigError` that
names the key, never ignored. :mod:`agents.learning.sb3.training` runs it.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

DEFAULT_CONFIG_PATH = Path(__file__).resolve().parents[1] / "configs" / "ppo_default.yaml"
START_METHODS = (None, "fork", "forkserver", "spawn")
#: How the training envs are stepped: ``native`` one vector env stepping every sub-env
#  in one call (:mod:`agents.learning.sb3.vector_env`), ``subproc`` one single env per
# worker process
#: (SB3's ``SubprocVecEnv``), ``dummy`` single envs one after the other in-process.
VECTORIZATIONS = ("native", "subproc", "dummy")
#: What the policy decides: ``actions`` the robot's action every env step (on the
#: env's observation), ``goals`` the planner's next goal (:mod:`agents.goals.choice`).
DECISIONS = ("actions", "goals")
#: What a goal-choosing policy remembers beyond its features (``memory``): nothing,
#: the features of its last ``memory_frames`` choices, or an LSTM's state (sb3-contrib).
MEMORIES = ("features", "frame_stack", "recurrent")
MAX_MEMORY_FRAMES = 64
MAX_MEMORY_UNITS = 1024
#: At most this many teacher's choices (they are held in memory) and fitting passes.
MAX_IMITATION_CHOICES = 1_000_000
MAX_IMITATION_EPOCHS = 1000
ACTIVATIONS = ("tanh", "relu")


def max_torch_threads() -> int:
    """The most ``torch_threads`` a training may ask for: the machine's CPUs (more only
    make the threads wait for each other; a huge count exhausts the machine)."""
    return os.cpu_count() or 1


class ConfigError(ValueError):
    """A training config that cannot be used (unknown key, wrong type, bad value)."""


# ---------------------------------------------------------------------- config
@dataclass
class PPOParams:
    """stable-baselines3 PPO hyperparameters (see ``stable_baselines3.PPO``)."""

    learning_rate: float = 3.0e-4
    n_steps: int = 1024  # rollout length per env
    batch_size: int = 256
    n_epochs: int = 5
    gamma: float = 0.995
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    target_kl: float | None = None
    normalize_advantage: bool = True
    net_arch: list[int] = field(default_factory=lambda: [128, 128])  # pi and vf MLPs
    activation: str = "tanh"
    log_std_init: float = 0.0  # initial log σ of the Gaussian actions (σ = 1 at 0)


@dataclass
class TrainConfig:
    """Everything ``train`` needs. Frequencies count env steps (all envs together)."""

    decisions: str = "actions"  # one of DECISIONS
    total_timesteps: int = 1_000_000  # policy steps: env steps, or choices of goals
    # decisions: goals: reward per landmark the belief gains, beside the env's reward
    # (agents.learning.goal_env.GoalChoiceEnv); 0 for decisions: actions.
    discovery_bonus: float = 0.0
    discovery_until: float = 1.0  # the share of the landmarks whose discovery earns it
    # decisions: goals: "flat" or "remaining" (the bonus times the share of the episode
    # left; agents.learning.goal_env.GoalChoiceEnv); "flat" for decisions: actions.
    discovery_schedule: str = "flat"
    # decisions: goals: one of MEMORIES ("features" for decisions: actions); the choices
    # a frame stack holds, and the LSTM's hidden units of a recurrent policy.
    memory: str = "features"
    memory_frames: int = 4
    memory_units: int = 64
    # decisions: goals: the share of the training over which the arena sizes drawn grow
    # from the smallest of worlds.arena_sizes to all of them (0: all from the start).
    curriculum: float = 0.0
    # decisions: goals: choices a fixed rule makes first (on top of total_timesteps),
    # and the passes that fit the policy to them before PPO (agents.learning.goal_imitation).
    imitation_choices: int = 0
    imitation_epochs: int = 10
    # decisions: goals: a choice holds while its goal stands, the policy asked only
    # when the goal is reached or moves (agents.goals.choice.GoalChoiceAgent).
    hold_goals: bool = False
    n_envs: int = 2  # sub-envs stepped together (worker processes for "subproc")
    vectorization: str = "native"  # one of VECTORIZATIONS
    seed: int = 0
    env_options: dict[str, Any] = field(default_factory=dict)  # ActiveSLAMEnv options
    max_episode_steps: int | None = None  # None: the registered 500
    torch_threads: int = 1  # torch.set_num_threads per process
    start_method: str | None = None  # "subproc" workers' start method; None: SB3's default
    progress_bar: bool = True
    tensorboard: bool = True
    out_dir: str = "runs/ppo"
    model_name: str = "ppo_active_slam"
    checkpoint_freq: int = 100_000  # 0: no checkpoints
    eval_freq: int = 100_000  # 0: no periodic evaluation
    eval_episodes: int = 5
    eval_seed: int = 1_000_000  # the eval env's worlds: the same at every evaluation
    verbose: int = 0  # SB3 verbosity
    # Training across worlds (agents.learning.worlds.WorldDistribution's fields): every
    # episode draws its setting; None: every episode in the env_options' world.
    worlds: dict[str, Any] | None = None
    world_groups: int | None = None  # native vector envs the sub-envs are split into
    ppo: PPOParams = field(default_factory=PPOParams)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _check(ok: bool, name: str, value: Any, expected: str) -> None:
    if not ok:
        raise ConfigError(f"config key {name!r} must be {expected}, got {value!r}")


def _validate_ppo(p: PPOParams) -> None:
    for name in ("learning_rate", "clip_range", "max_grad_norm"):
        v = getattr(p, name)
        _check(_is_number(v) and v > 0, f"ppo.{name}", v, "a number > 0")
    for name in ("gamma", "gae_lambda"):
        v = getattr(p, name)
        _check(_is_number(v) and 0 < v <= 1, f"ppo.{name}", v, "a number in (0, 1]")
    for name in ("ent_coef", "vf_coef"):
        v = getattr(p, name)
        _check(_is_number(v) and v >= 0, f"ppo.{name}", v, "a number >= 0")
    _check(_is_int(p.n_steps) and p.n_steps >= 2, "ppo.n_steps", p.n_steps, "an int >= 2")
    _check(
        _is_int(p.batch_size) and p.batch_size >= 2, "ppo.batch_size", p.batch_size, "an int >= 2"
    )
    _check(_is_int(p.n_epochs) and p.n_epochs >= 1, "ppo.n_epochs", p.n_epochs, "an int >= 1")
    _check(
        p.target_kl is None or (_is_number(p.target_kl) and p.target_kl > 0),
        "ppo.target_kl",
        p.target_kl,
        "null or a number > 0",
    )
    _check(
        isinstance(p.normalize_advantage, bool),
        "ppo.normalize_advantage",
        p.normalize_advantage,
        "true or false",
    )
    _check(
        isinstance(p.net_arch, list)
        and len(p.net_arch) >= 1
        and all(_is_int(n) and n >= 1 for n in p.net_arch),
        "ppo.net_arch",
        p.net_arch,
        "a non-empty list of layer sizes",
    )
    _check(p.activation in ACTIVATIONS, "ppo.activation", p.activation, f"one of {ACTIVATIONS}")
    _check(
        _is_number(p.log_std_init) and math.isfinite(p.log_std_init),
        "ppo.log_std_init",
        p.log_std_init,
        "a finite number",
    )


def _validate_memory(cfg: TrainConfig) -> None:
    _check(cfg.memory in MEMORIES, "memory", cfg.memory, f"one of {MEMORIES}")
    if cfg.decisions != "goals":
        expected = "'features' unless decisions is goals"
        _check(cfg.memory == "features", "memory", cfg.memory, expected)
    for name, top in (("memory_frames", MAX_MEMORY_FRAMES), ("memory_units", MAX_MEMORY_UNITS)):
        v = getattr(cfg, name)
        _check(_is_int(v) and 1 <= v <= top, name, v, f"an int in [1, {top}]")
    if cfg.memory == "recurrent":
        try:
            import sb3_contrib  # noqa: F401
        except ImportError:
            raise ConfigError(
                "config key 'memory': 'recurrent' needs sb3-contrib "
                "(pip install 'slam_env[recurrent]')"
            ) from None


def _validate_curriculum(cfg: TrainConfig) -> None:
    c = cfg.curriculum
    _check(_is_number(c) and 0 <= c <= 1, "curriculum", c, "a number in [0, 1]")
    if c > 0:
        sizes = cfg.worlds.get("arena_sizes") if isinstance(cfg.worlds, dict) else None
        expected = "0 unless decisions is goals and worlds has arena_sizes to grow"
        _check(cfg.decisions == "goals" and bool(sizes), "curriculum", c, expected)


def _validate_imitation(cfg: TrainConfig) -> None:
    n, top = cfg.imitation_choices, MAX_IMITATION_CHOICES
    _check(_is_int(n) and 0 <= n <= top, "imitation_choices", n, f"an int in [0, {top}]")
    epochs, top = cfg.imitation_epochs, MAX_IMITATION_EPOCHS
    expected = f"an int in [1, {top}]"
    _check(_is_int(epochs) and 1 <= epochs <= top, "imitation_epochs", epochs, expected)
    if n:
        ok = cfg.decisions == "goals" and cfg.memory == "features"
        expected = "0 unless decisions is goals and memory is features"
        _check(ok, "imitation_choices", n, expected)


def _validate_hold_goals(cfg: TrainConfig) -> None:
    _check(isinstance(cfg.hold_goals, bool), "hold_goals", cfg.hold_goals, "true or false")
    if cfg.hold_goals:
        expected = "false unless decisions is goals"
        _check(cfg.decisions == "goals", "hold_goals", cfg.hold_goals, expected)


def validate_config(cfg: TrainConfig) -> TrainConfig:
    """Check every field's type and range; raise :class:`ConfigError` naming the key."""
    for name in ("total_timesteps", "n_envs", "torch_threads", "eval_episodes"):
        v = getattr(cfg, name)
        _check(_is_int(v) and v >= 1, name, v, "an int >= 1")
    cpus = max_torch_threads()
    expected = f"an int in [1, {cpus}] (this machine's CPUs)"
    _check(cfg.torch_threads <= cpus, "torch_threads", cfg.torch_threads, expected)
    for name in ("seed", "eval_seed", "checkpoint_freq", "eval_freq", "verbose"):
        v = getattr(cfg, name)
        _check(_is_int(v) and v >= 0, name, v, "an int >= 0")
    _check(cfg.decisions in DECISIONS, "decisions", cfg.decisions, f"one of {DECISIONS}")
    bonus, until = cfg.discovery_bonus, cfg.discovery_until
    if cfg.decisions == "goals":
        from agents.learning.goal_env import check_discovery  # (seconds to import: goals only)

        try:
            check_discovery(bonus, until, cfg.discovery_schedule)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
    else:
        expected = "0 unless decisions is goals"
        _check(_is_number(bonus) and bonus == 0.0, "discovery_bonus", bonus, expected)
        expected = "1 unless decisions is goals"
        _check(_is_number(until) and until == 1.0, "discovery_until", until, expected)
        expected = "'flat' unless decisions is goals"
        schedule = cfg.discovery_schedule
        _check(schedule == "flat", "discovery_schedule", schedule, expected)
    _validate_memory(cfg)
    _validate_curriculum(cfg)
    _validate_imitation(cfg)
    _validate_hold_goals(cfg)
    _check(isinstance(cfg.env_options, dict), "env_options", cfg.env_options, "a mapping")
    _check(
        cfg.max_episode_steps is None
        or (_is_int(cfg.max_episode_steps) and cfg.max_episode_steps >= 1),
        "max_episode_steps",
        cfg.max_episode_steps,
        "null or an int >= 1",
    )
    _check(
        cfg.vectorization in VECTORIZATIONS,
        "vectorization",
        cfg.vectorization,
        f"one of {VECTORIZATIONS}",
    )
    _check(cfg.start_method in START_METHODS, "start_method", cfg.start_method, str(START_METHODS))
    for name in ("progress_bar", "tensorboard"):
        v = getattr(cfg, name)
        _check(isinstance(v, bool), name, v, "true or false")
    _check(isinstance(cfg.out_dir, str) and cfg.out_dir != "", "out_dir", cfg.out_dir, "a path")
    _check(
        isinstance(cfg.model_name, str) and cfg.model_name != "" and "/" not in cfg.model_name,
        "model_name",
        cfg.model_name,
        "a file name without '/'",
    )
    _check(
        cfg.worlds is None or isinstance(cfg.worlds, dict),
        "worlds",
        cfg.worlds,
        "null or a mapping",
    )
    if cfg.worlds is not None:
        from agents.learning.worlds import WorldDistribution

        try:
            WorldDistribution.from_mapping(cfg.worlds)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        if cfg.decisions == "actions":
            _check(cfg.vectorization == "native", "vectorization", cfg.vectorization, "native")
    if cfg.decisions == "goals":
        # One choice spans a varying number of env steps, so its envs step one by one.
        expected = "subproc or dummy (a choice spans a varying number of env steps)"
        _check(cfg.vectorization != "native", "vectorization", cfg.vectorization, expected)
    _check(
        cfg.world_groups is None
        or (
            _is_int(cfg.world_groups)
            and cfg.world_groups >= 1
            and cfg.n_envs % cfg.world_groups == 0
        ),
        "world_groups",
        cfg.world_groups,
        "null or an int >= 1 that divides n_envs",
    )
    _check(isinstance(cfg.ppo, PPOParams), "ppo", cfg.ppo, "a mapping of PPO hyperparameters")
    _validate_ppo(cfg.ppo)
    if cfg.worlds is not None:
        _validate_world_settings(cfg)
    return cfg


def _validate_world_settings(cfg: TrainConfig) -> None:
    """Every setting ``worlds`` may draw runs with ``env_options`` (on a native vector
    env of a group's sub-envs, or a single env for goals), or a :class:`ConfigError`."""
    from agents.common.env import check_env_options
    from agents.learning.worlds import WorldDistribution

    native = cfg.decisions == "actions"
    group = cfg.n_envs // (cfg.world_groups or cfg.n_envs) if native else 1
    try:
        check_env_options(cfg.env_options, group)
    except ValueError as exc:
        raise ConfigError(f"config key 'env_options': {exc}") from None
    try:
        WorldDistribution.from_mapping(cfg.worlds).check(cfg.env_options, group)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def _from_mapping(cls: type, data: Mapping[str, Any], where: str) -> dict[str, Any]:
    valid = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - valid)
    if unknown:
        raise ConfigError(
            f"unknown {where} key(s) {unknown}; valid keys: {', '.join(sorted(valid))}"
        )
    return dict(data)


def config_from_dict(data: Mapping[str, Any] | None) -> TrainConfig:
    """A validated :class:`TrainConfig` from a (possibly partial) nested mapping."""
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"a training config must be a mapping, got {type(data).__name__}")
    top = _from_mapping(TrainConfig, data, "config")
    ppo = top.pop("ppo", None) or {}
    if not isinstance(ppo, Mapping):
        raise ConfigError(f"config key 'ppo' must be a mapping, got {ppo!r}")
    params = PPOParams(**_from_mapping(PPOParams, ppo, "ppo"))
    if top.get("env_options") is None:
        top.pop("env_options", None)
    return validate_config(TrainConfig(**top, ppo=params))


def load_config(path: str | Path | None = None, **overrides: Any) -> TrainConfig:
    """Read a YAML config (default: ``ppo_default.yaml``) and apply top-level
    ``overrides`` (``None`` values are ignored, as from unset CLI flags)."""
    path = DEFAULT_CONFIG_PATH if path is None else Path(path)
    if not path.is_file():
        raise ConfigError(f"config file not found: {path}")
    try:
        with open(path, encoding="utf-8") as fh:
            data = yaml.safe_load(fh)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path} is not valid YAML: {exc}") from exc
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a training config must be a mapping at the top level")
    data.update({k: v for k, v in overrides.items() if v is not None})
    return config_from_dict(data)


def as_train_config(config: TrainConfig | Mapping[str, Any] | str | Path | None) -> TrainConfig:
    """A validated config from a :class:`TrainConfig`, a mapping, a YAML path, or
    ``None`` (the defaults)."""
    if isinstance(config, TrainConfig):
        return validate_config(config)
    if isinstance(config, Mapping):
        return config_from_dict(config)
    return load_config(config)


def config_to_dict(cfg: TrainConfig) -> dict[str, Any]:
    return dataclasses.asdict(cfg)


def write_config(cfg: TrainConfig, path: Path) -> None:
    """``cfg`` as the YAML file beside a trained policy (``--config`` reads it back)."""
    header = (
        "# Resolved training config of the policy next to this file "
        "(slam-env train --config THIS_FILE reproduces it).\n"
    )
    path.write_text(header + yaml.safe_dump(config_to_dict(cfg), sort_keys=False))
