"""PPO training on ``slam_env/ActiveSLAM-v0`` with Ray RLlib (``slam-env train --engine
rllib``), from the same config as the stable-baselines3 path (:mod:`agents.learning.sb3.training`).

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

The config keys mean what they mean for stable-baselines3 (:mod:`agents.learning.rllib.config`
maps them, and refuses what RLlib cannot honour). TensorBoard gets RLlib's results
(``env_runners/…``, ``learners/…``) and the SLAM metrics of the training episodes under
``slam/`` and of the periodic evaluations, on the ``eval_seed`` worlds through the
evaluator of ``slam-env evaluate``, under ``slam_eval/``.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from agents.learning.config import TrainConfig, as_train_config, write_config
from agents.learning.rllib.config import RLlibSettings, check_gpus, check_reachable, ppo_config
from agents.learning.rllib.env import require_rllib
from agents.learning.runs import check_train_env, finite_map


# ---------------------------------------------------------------------- train
def train_rllib(
    config: TrainConfig | Mapping[str, Any] | str | Path | None = None,
    settings: RLlibSettings | None = None,
) -> Path:
    """Train PPO with RLlib as ``config`` says (a :class:`TrainConfig`, a mapping, a
    YAML path, or ``None`` for the defaults) on the cluster ``settings`` names, and
    return the path of the final checkpoint. Raises
    :class:`agents.learning.rllib.env.RLlibNotInstalledError` without Ray RLlib."""
    require_rllib("--engine rllib")
    import ray
    import torch

    from agents.learning.rllib.env import register_rllib_envs

    cfg = as_train_config(config)
    settings = settings or RLlibSettings()
    algo_config = ppo_config(cfg, settings)  # refuses what RLlib cannot honour, first
    address = settings.address or os.environ.get("RAY_ADDRESS") or None
    if not ray.is_initialized() and address is not None:
        check_reachable(address)
    torch.set_num_threads(cfg.torch_threads)
    check_train_env(cfg)

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
        write_config(cfg, out / f"{cfg.model_name}.yaml")
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
        stop_algorithm(algo)
    return final


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

    from agents.learning.sb3.callbacks import TRAIN_PREFIX

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


def stop_algorithm(algo: Any) -> None:
    """Stop an RLlib algorithm (its EnvRunners and learners), and remove the log folder
    that Ray's Trainable made for it under ~/ray_results if the run left it empty."""
    logdir = Path(algo.logdir)
    algo.stop()
    with contextlib.suppress(OSError):  # not empty (or gone): leave it
        logdir.rmdir()


class _Evaluator:
    """The periodic evaluation: ``eval_episodes`` episodes on the ``eval_seed`` worlds
    (the same at every evaluation) with the evaluator of ``slam-env evaluate``; their
    mean metrics under ``slam_eval/``, the best checkpoint (by
    :data:`agents.learning.metrics.BEST_MODEL_CRITERION`) in ``eval/best_model``."""

    def __init__(self, cfg: TrainConfig, out: Path) -> None:
        self.cfg = cfg
        self.folder = out / "eval"
        self.history: list[dict[str, float]] = []
        self.best: dict[str, float] | None = None

    def evaluate(self, algo: Any, steps: int, writer: Any) -> None:
        from agents.learning.metrics import evaluation_score
        from agents.learning.ppo_agent import PPOAgent
        from agents.learning.rllib.agent import RLlibPolicy
        from agents.rollouts.records import METRICS
        from agents.rollouts.vector_episodes import run_episodes_batched

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
        from agents.learning.metrics import BEST_MODEL_CRITERION

        return {
            "last_eval_slam": finite_map(self.history[-1] if self.history else None),
            "best_eval_slam": finite_map(self.best),
            "best_model_criterion": BEST_MODEL_CRITERION,
        }
