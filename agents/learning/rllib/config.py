"""The RLlib engine's settings and its PPO config, from the project's training config
(:mod:`agents.learning.sb3.training`) and the command line's cluster flags.

``ppo_config(config, settings)`` is RLlib's ``PPOConfig`` whose keys mean what the
stable-baselines3 path's mean: ``n_steps`` is the rollout length per sub-env (an
update's batch is ``n_steps`` × sub-envs per runner × runners), ``batch_size`` the
minibatch, ``n_epochs`` the passes over it, ``net_arch`` and ``activation`` the separate
policy and value MLPs, a state-independent log σ, no value clipping and no KL penalty,
as in stable-baselines3. ``n_envs`` is the number of sub-envs each EnvRunner steps
(``settings.num_envs_per_runner`` overrides it) and ``vectorization`` how it steps them
(``native``: one native vector env; ``dummy``: RLlib's ``sync``; ``subproc``: its
``async``). Keys RLlib cannot honour with the same meaning (``target_kl``,
``normalize_advantage: false``, ``log_std_init`` ≠ 0), and what this engine does not do
yet (``decisions: goals``, ``worlds``, ``world_groups``, the ``local`` observation), are refused by
:func:`check_rllib_config`, never ignored. The EnvRunners log the SLAM metrics of every
training episode (:func:`log_slam_metrics`). Nothing here needs Ray at import.
"""

from __future__ import annotations

import math
import socket
from dataclasses import dataclass
from typing import Any

from agents.learning.config import ConfigError, TrainConfig

#: ``vectorization`` (the config's key) → RLlib's ``gym_env_vectorize_mode``.
VECTORIZE_MODES = {"native": "vector_entry_point", "dummy": "sync", "subproc": "async"}
LEARNER_DEVICES = ("cpu", "gpu")


@dataclass(frozen=True)
class RLlibSettings:
    """Where and how widely RLlib runs (command-line flags, not the config file)."""

    address: str | None = None  # a Ray cluster's address; None: RAY_ADDRESS or local
    num_env_runners: int = 1  # EnvRunner actors (0: sample in this process)
    num_envs_per_runner: int | None = None  # None: the config's n_envs
    learner_device: str = "cpu"  # "cpu" or "gpu" (one GPU per learner)
    num_learners: int = 0  # learner actors (0: the learner runs in this process)

    def __post_init__(self) -> None:
        for name in ("num_env_runners", "num_learners"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise ValueError(f"{name} must be an int >= 0, got {v!r}")
        n = self.num_envs_per_runner
        if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
            raise ValueError(f"num_envs_per_runner must be null or an int >= 1, got {n!r}")
        if self.learner_device not in LEARNER_DEVICES:
            raise ValueError(
                f"learner_device must be one of {LEARNER_DEVICES}, got {self.learner_device!r}"
            )
        if self.address is not None and not (isinstance(self.address, str) and self.address):
            raise ValueError(f"address must be a non-empty string, got {self.address!r}")


def check_rllib_config(cfg: TrainConfig) -> None:
    """Raise :class:`ConfigError` for the PPO settings that RLlib would read differently
    (no Ray needed: a config is checked before a cluster is reached)."""
    if cfg.decisions != "actions":
        raise ConfigError(
            f"decisions: {cfg.decisions} (a policy choosing the planner's goals) is not "
            "available with --engine rllib yet: it trains the policy acting every env step"
        )
    for key in ("worlds", "world_groups"):
        if getattr(cfg, key) is not None:
            raise ConfigError(
                f"{key} (training across worlds) is not available with --engine rllib yet: "
                "set it to null"
            )
    if cfg.env_options.get("observation", "egocentric") != "egocentric":
        raise ConfigError(
            "--engine rllib trains on the flat egocentric belief only: drop "
            f"env_options.observation (got {cfg.env_options['observation']!r})"
        )
    p = cfg.ppo
    if p.target_kl is not None:
        raise ConfigError(
            "ppo.target_kl (stable-baselines3's early stop of an update) has no RLlib "
            "counterpart: set it to null for --engine rllib"
        )
    if not p.normalize_advantage:
        raise ConfigError(
            "ppo.normalize_advantage: false has no RLlib counterpart (RLlib's PPO always "
            "standardises the advantages): set it to true for --engine rllib"
        )
    if p.log_std_init != 0.0:
        raise ConfigError(
            "ppo.log_std_init must be 0.0 for --engine rllib (RLlib starts its free log σ "
            f"at 0), got {p.log_std_init!r}"
        )


def env_config(cfg: TrainConfig) -> dict[str, Any]:
    """The env options the EnvRunners make their envs with (and the episode length)."""
    options = dict(cfg.env_options)
    if cfg.max_episode_steps is not None:
        options["max_episode_steps"] = cfg.max_episode_steps
    return options


def ppo_config(cfg: TrainConfig, settings: RLlibSettings) -> Any:
    """RLlib's ``PPOConfig`` for ``cfg`` (see the module docstring for the mapping)."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    from agents.common.env import ENV_ID

    check_rllib_config(cfg)
    p = cfg.ppo
    envs_per_runner = settings.num_envs_per_runner or cfg.n_envs
    rollout = p.n_steps * envs_per_runner * max(settings.num_env_runners, 1)
    per_learner = max(rollout // max(settings.num_learners, 1), 1)
    if p.batch_size > per_learner:
        raise ConfigError(
            f"ppo.batch_size {p.batch_size} exceeds a learner's share of the rollout "
            f"({per_learner} env steps: n_steps × sub-envs per runner × runners / learners)"
        )
    gpu = settings.learner_device == "gpu"
    return (
        PPOConfig()
        .environment(ENV_ID.partition(":")[2], env_config=env_config(cfg))
        .env_runners(
            num_env_runners=settings.num_env_runners,
            num_envs_per_env_runner=envs_per_runner,
            gym_env_vectorize_mode=VECTORIZE_MODES[cfg.vectorization],
            rollout_fragment_length=p.n_steps,
            num_cpus_per_env_runner=1,
        )
        .learners(num_learners=settings.num_learners, num_gpus_per_learner=1 if gpu else 0)
        .training(
            lr=p.learning_rate,
            train_batch_size_per_learner=per_learner,
            minibatch_size=p.batch_size,
            num_epochs=p.n_epochs,
            gamma=p.gamma,
            lambda_=p.gae_lambda,
            clip_param=p.clip_range,
            entropy_coeff=p.ent_coef,
            vf_loss_coeff=p.vf_coef,
            grad_clip=p.max_grad_norm,
            grad_clip_by="global_norm",
            use_kl_loss=False,
            vf_clip_param=math.inf,
        )
        .rl_module(
            model_config=DefaultModelConfig(
                fcnet_hiddens=list(p.net_arch),
                fcnet_activation=p.activation,
                vf_share_layers=False,
                free_log_std=True,
            )
        )
        .callbacks(on_episode_end=log_slam_metrics)
        .debugging(seed=cfg.seed, log_level="ERROR" if cfg.verbose == 0 else "INFO")
    )


def log_slam_metrics(*, episode: Any, metrics_logger: Any, **_: Any) -> None:
    """RLlib's ``on_episode_end``: the episode's SLAM metrics under ``slam/`` (means
    over the episodes of an iteration; undefined, NaN, ones left out)."""
    from agents.learning.metrics import EpisodeTallies
    from agents.learning.sb3.callbacks import TRAIN_PREFIX

    infos = episode.get_infos()
    tally = EpisodeTallies(1)
    for info in infos[1:]:  # the reset's info is not a step
        tally.add_infos([info])
    for name, value in tally.finish(0, infos[-1]).items():
        if math.isfinite(value):
            metrics_logger.log_value(TRAIN_PREFIX + name, value, reduce="mean")


def check_reachable(address: str, timeout_s: float = 10.0) -> None:
    """ValueError unless a ``HOST:PORT`` address accepts a connection (Ray itself
    retries a dead address for minutes); other forms (``auto``, ``ray://…``) are left
    to Ray."""
    host, sep, port = address.rpartition(":")
    if not sep or "/" in address or not port.isdigit():
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except OSError as exc:
        raise ValueError(
            f"no Ray cluster answers at {address}: {exc.strerror or exc} (start one with "
            "'ray start --head', or leave out --address and RAY_ADDRESS for a local Ray)"
        ) from None


def check_gpus(settings: RLlibSettings) -> None:
    """ValueError unless the cluster has a GPU for each learner that asks for one."""
    import ray

    if settings.learner_device != "gpu":
        return
    needed = max(settings.num_learners, 1)
    have = ray.cluster_resources().get("GPU", 0)
    if have < needed:
        raise ValueError(
            f"--learner-device gpu needs {needed} GPU(s) in the Ray cluster, which has {have:g}"
        )
