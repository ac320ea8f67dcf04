"""PPO training on ``slam_env/ActiveSLAM-v0`` with Ray RLlib (``slam-env train --engine
rllib``), from the same config as the stable-baselines3 path (:mod:`agents.training`).

``train_rllib(config, settings)`` connects to a Ray cluster (``settings.address``, else
``RAY_ADDRESS``, else a Ray started for the run on this machine), spreads the rollouts
over ``settings.num_env_runners`` EnvRunners (each stepping its sub-envs through the
native vector env: RLlib's ``gym_env_vectorize_mode="vector_entry_point"``), updates
the policy on the learner(s) (CPU or GPU) and writes into ``config.out_dir``::

    <model_name>/               the final algorithm checkpoint (load it with ``rllib:PATH``)
    <model_name>.yaml           the resolved config it was trained with
    training_summary.json       steps, wall time, env steps/s, last/best evaluation
    checkpoints/<model_name>_<N>_steps/
    eval/best_model/, eval/evaluations.npz
    tb/<model_name>_1/          TensorBoard logs (``tensorboard --logdir OUT/tb``)

The config keys mean what they mean for stable-baselines3: ``n_steps`` is the rollout
length per sub-env (an update's batch is ``n_steps`` × sub-envs per runner × runners),
``batch_size`` the minibatch, ``n_epochs`` the passes over it, ``net_arch`` and
``activation`` the separate policy and value MLPs, a state-independent log σ, no value
clipping and no KL penalty, as in stable-baselines3. ``n_envs`` is the number of
sub-envs each EnvRunner steps (``settings.num_envs_per_runner`` overrides it) and
``vectorization`` how it steps them (``native``: one native vector env; ``dummy``:
RLlib's ``sync``; ``subproc``: its ``async``). Keys RLlib cannot honour with the same
meaning (``target_kl``, ``normalize_advantage: false``, ``log_std_init`` ≠ 0) are
refused, never ignored. TensorBoard gets RLlib's results (``env_runners/…``,
``learners/…``) and the SLAM metrics of the training episodes under ``slam/`` and of
the periodic evaluations, on the ``eval_seed`` worlds through the evaluator of
``slam-env evaluate``, under ``slam_eval/``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import socket
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.rllib_env import require_rllib
from agents.training import (
    ConfigError,
    TrainConfig,
    _check_env,
    _finite_map,
    _write_yaml,
    as_train_config,
)

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

    from agents.registry import ENV_ID

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
    from agents.slam_callbacks import TRAIN_PREFIX
    from agents.slam_metrics import EpisodeTallies

    infos = episode.get_infos()
    tally = EpisodeTallies(1)
    for info in infos[1:]:  # the reset's info is not a step
        tally.add_infos([info])
    for name, value in tally.finish(0, infos[-1]).items():
        if math.isfinite(value):
            metrics_logger.log_value(TRAIN_PREFIX + name, value, reduce="mean")


# ---------------------------------------------------------------------- train
def train_rllib(
    config: TrainConfig | Mapping[str, Any] | str | Path | None = None,
    settings: RLlibSettings | None = None,
) -> Path:
    """Train PPO with RLlib as ``config`` says (a :class:`TrainConfig`, a mapping, a
    YAML path, or ``None`` for the defaults) on the cluster ``settings`` names, and
    return the path of the final checkpoint. Raises
    :class:`agents.rllib_env.RLlibNotInstalledError` without Ray RLlib."""
    require_rllib("--engine rllib")
    import ray
    import torch

    from agents.rllib_env import register_rllib_envs

    cfg = as_train_config(config)
    settings = settings or RLlibSettings()
    algo_config = ppo_config(cfg, settings)  # refuses what RLlib cannot honour, first
    address = settings.address or os.environ.get("RAY_ADDRESS") or None
    if not ray.is_initialized() and address is not None:
        check_reachable(address)
    torch.set_num_threads(cfg.torch_threads)
    _check_env(cfg)

    connected_here = not ray.is_initialized()
    if connected_here:
        # address None: a Ray started for this run.
        try:
            ray.init(address=address, include_dashboard=False, log_to_driver=cfg.verbose > 0)
        except ConnectionError as exc:
            raise ConnectionError(
                f"{exc}. A cluster with token authentication (Ray's default for "
                "'ray start --head') needs RAY_AUTH_MODE=token here and its token in "
                "~/.ray/auth_token"
            ) from exc
    try:
        check_gpus(settings)
        # Nothing is written before the cluster is reached and fits.
        out = Path(cfg.out_dir)
        out.mkdir(parents=True, exist_ok=True)
        _write_yaml(cfg, out / f"{cfg.model_name}.yaml")
        register_rllib_envs()
        return _train(cfg, settings, algo_config, out)
    finally:
        if connected_here:
            ray.shutdown()


def _train(cfg: TrainConfig, settings: RLlibSettings, algo_config: Any, out: Path) -> Path:
    from torch.utils.tensorboard import SummaryWriter
    from tqdm import tqdm

    algo = algo_config.build_algo()
    writer = (
        SummaryWriter(str(_next_run_dir(out / "tb", cfg.model_name))) if cfg.tensorboard else None
    )
    evaluator = _Evaluator(cfg, out) if cfg.eval_freq > 0 else None
    bar = tqdm(total=cfg.total_timesteps, unit="step", disable=not cfg.progress_bar)
    final = out / cfg.model_name
    steps, interrupted = 0, False
    try:
        placement = _env_runner_placement(algo)
        start = time.perf_counter()
        try:
            while steps < cfg.total_timesteps:
                result = algo.train()
                before, steps = steps, _env_steps(result)
                bar.update(steps - before)
                if writer is not None:
                    _log_scalars(writer, _slam_at_top(result), steps)
                if cfg.verbose > 0:
                    print(f"iteration {result['training_iteration']}: {steps} env steps")
                if _crossed(before, steps, cfg.checkpoint_freq):
                    algo.save_to_path(str(out / "checkpoints" / f"{cfg.model_name}_{steps}_steps"))
                if evaluator is not None and _crossed(before, steps, cfg.eval_freq):
                    evaluator.evaluate(algo, steps, writer)
        except KeyboardInterrupt:
            interrupted = True  # keep what was learnt so far
        wall = time.perf_counter() - start
        algo.save_to_path(str(final.resolve()))
        summary = {
            "model": str(final),
            "engine": "rllib",
            "timesteps": steps,
            "wall_time_s": round(wall, 3),
            "env_steps_per_s": round(steps / wall, 1) if wall > 0 else None,
            "n_envs": (settings.num_envs_per_runner or cfg.n_envs)
            * max(settings.num_env_runners, 1),
            "num_env_runners": settings.num_env_runners,
            "num_envs_per_runner": settings.num_envs_per_runner or cfg.n_envs,
            "vectorization": cfg.vectorization,
            "learner_device": settings.learner_device,
            "num_learners": settings.num_learners,
            "env_runners": placement,
            "env_step_share": None,  # RLlib steps the envs in other processes
            "interrupted": interrupted,
            **(evaluator.summary() if evaluator is not None else _NO_EVAL),
        }
        (out / "training_summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        if interrupted:
            raise KeyboardInterrupt(f"training interrupted; checkpoint saved to {final}")
    finally:
        bar.close()
        if writer is not None:
            writer.close()
        logdir = Path(algo.logdir)
        algo.stop()
        _remove_if_empty(logdir)
    return final


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


def _env_runner_placement(algo: Any) -> list[dict[str, str]]:
    """Each remote EnvRunner's Ray node and the class of the env it steps (the
    EnvRunner of this process when there are none)."""

    def where(runner: Any) -> dict[str, str]:
        import ray

        return {
            "node_id": ray.get_runtime_context().get_node_id(),
            "env": type(runner.env.unwrapped).__name__,
        }

    remote = algo.env_runner_group.num_remote_env_runners() > 0
    return algo.env_runner_group.foreach_env_runner(where, local_env_runner=not remote)


_NO_EVAL: dict[str, Any] = {
    "last_eval_slam": None,
    "best_eval_slam": None,
    "best_model_criterion": None,
}


def _env_steps(result: Mapping[str, Any]) -> int:
    """The env steps sampled so far, from an RLlib result."""
    from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_ENV_STEPS_SAMPLED_LIFETIME

    return int(result[ENV_RUNNER_RESULTS][NUM_ENV_STEPS_SAMPLED_LIFETIME])


def _slam_at_top(result: Mapping[str, Any]) -> dict[str, Any]:
    """``result`` for TensorBoard: the EnvRunners' SLAM metrics at its top, as
    ``slam/…`` (where the stable-baselines3 path logs them) rather than under
    ``env_runners/``, and without the config (hyperparameters are no curves)."""
    from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS

    from agents.slam_callbacks import TRAIN_PREFIX

    runners: dict[str, Any] = {}
    slam: dict[str, Any] = {}
    for key, value in result.get(ENV_RUNNER_RESULTS, {}).items():
        if key == TRAIN_PREFIX.rstrip("/") and isinstance(value, Mapping):
            slam.update(value)
        elif key.startswith(TRAIN_PREFIX):
            slam[key[len(TRAIN_PREFIX) :]] = value
        else:
            runners[key] = value
    top = {k: v for k, v in result.items() if k != "config"}
    top[ENV_RUNNER_RESULTS] = runners
    top[TRAIN_PREFIX.rstrip("/")] = slam
    return top


def _crossed(before: int, after: int, every: int) -> bool:
    """Whether a multiple of ``every`` (> 0) lies in ``(before, after]``."""
    return every > 0 and after // every > before // every


def _next_run_dir(root: Path, name: str) -> Path:
    """``root/<name>_<k>`` with the first free k ≥ 1, as stable-baselines3 names runs."""
    k = 1
    while (root / f"{name}_{k}").exists():
        k += 1
    return root / f"{name}_{k}"


def _log_scalars(writer: Any, result: Mapping[str, Any], step: int, prefix: str = "") -> None:
    """Every finite number of a nested RLlib result as a TensorBoard scalar."""
    for key, value in result.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            _log_scalars(writer, value, step, name + "/")
        elif (
            isinstance(value, (int, float, np.number))
            and not isinstance(value, bool)
            and math.isfinite(value)
        ):
            writer.add_scalar(name, float(value), step)


def _remove_if_empty(folder: Path) -> None:
    """Ray's Trainable makes a log folder under ~/ray_results that this run leaves empty."""
    with contextlib.suppress(OSError):  # not empty (or gone): leave it
        folder.rmdir()


class _Evaluator:
    """The periodic evaluation: ``eval_episodes`` episodes on the ``eval_seed`` worlds
    (the same at every evaluation) with the evaluator of ``slam-env evaluate``; their
    mean metrics under ``slam_eval/``, the best checkpoint (by
    :data:`agents.slam_metrics.BEST_MODEL_CRITERION`) in ``eval/best_model``."""

    def __init__(self, cfg: TrainConfig, out: Path) -> None:
        self.cfg = cfg
        self.folder = out / "eval"
        self.history: list[dict[str, float]] = []
        self.best: dict[str, float] | None = None

    def evaluate(self, algo: Any, steps: int, writer: Any) -> None:
        from agents.evaluation import METRICS
        from agents.ppo import PPOAgent
        from agents.rllib_agent import RLlibPolicy
        from agents.slam_metrics import evaluation_score
        from agents.vector_episodes import run_episodes_batched

        module = algo.get_module()
        module.eval()
        seeds = [self.cfg.eval_seed + i for i in range(self.cfg.eval_episodes)]
        records = run_episodes_batched(
            PPOAgent(RLlibPolicy(module)), seeds, self.cfg.env_options, self.cfg.max_episode_steps
        )
        module.train()
        per_episode = [r.metrics() for r in records]
        means = {
            name: float(np.nanmean([m[name] for m in per_episode]))
            if any(math.isfinite(m[name]) for m in per_episode)
            else math.nan
            for name in METRICS
        }
        figures = {"timesteps": float(steps), **means}
        self.history.append(figures)
        if writer is not None:
            _log_scalars(writer, {"slam_eval": means}, steps)
        if self.best is None or evaluation_score(means) > evaluation_score(self.best):
            self.best = figures
            algo.save_to_path(str((self.folder / "best_model").resolve()))
        self.folder.mkdir(parents=True, exist_ok=True)
        np.savez(
            self.folder / "evaluations.npz",
            timesteps=np.array([h["timesteps"] for h in self.history]),
            **{f"slam_{name}": np.array([h[name] for h in self.history]) for name in METRICS},
        )

    def summary(self) -> dict[str, Any]:
        from agents.slam_metrics import BEST_MODEL_CRITERION

        return {
            "last_eval_slam": _finite_map(self.history[-1] if self.history else None),
            "best_eval_slam": _finite_map(self.best),
            "best_model_criterion": BEST_MODEL_CRITERION,
        }
