"""stable-baselines3 callbacks that log the SLAM metrics of :mod:`agents.learning.metrics`.

* :class:`SlamMetricsCallback`: the metrics of every training episode that ends,
  under ``slam/`` (TensorBoard shows their mean over the episodes that ended since the
  last log dump, i.e. in the last rollout).
* :class:`SlamEvalCallback`: stable-baselines3's ``EvalCallback`` on held-out worlds
  (the same ``eval_seed`` worlds at every evaluation, so that evaluations compare like
  with like) that also logs the evaluation episodes' metrics under ``slam_eval/``,
  adds them to ``evaluations.npz`` (``slam_<metric>``, one row per evaluation) and
  keeps ``best_model.zip`` by :data:`agents.learning.metrics.BEST_MODEL_CRITERION` rather
  than by the return, which a training config shapes for learning.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback
from stable_baselines3.common.logger import Logger

from agents.common.info_rows import InfoRow
from agents.learning.metrics import (
    OPTIONAL_STEP_KEYS,
    SLAM_METRICS,
    STEP_KEYS,
    EpisodeTallies,
    evaluation_score,
    mean_metrics,
)

TRAIN_PREFIX = "slam/"
EVAL_PREFIX = "slam_eval/"


def record_metrics(logger: Logger, prefix: str, metrics: Mapping[str, float]) -> None:
    """Add one episode's metrics to the means the logger writes at its next dump
    (undefined, NaN, ones are left out rather than spoil the mean)."""
    for name, value in metrics.items():
        if math.isfinite(value):
            logger.record_mean(prefix + name, value)


def vector_columns(
    infos: Sequence[Mapping[str, Any]], finished: Sequence[int], keys: Sequence[str]
) -> tuple[list[np.ndarray], list[np.ndarray]] | None:
    """The (B,) column of each of ``keys`` over one step's infos, when these are lazy
    views of one vector info (:class:`agents.learning.sb3.vector_env.SB3VectorEnv`'s): the rows of
    the sub-envs that go on are read from its arrays in one go, those of the sub-envs
    that ``finished`` (their episodes' last infos) as they are. With the columns, the
    ``_key`` masks saying which of the going sub-envs reported each required key
    (the :data:`agents.learning.metrics.OPTIONAL_STEP_KEYS` are NaN where unreported).
    None for other infos."""
    going = [i for i in range(len(infos)) if i not in finished] if finished else range(len(infos))
    if not going:
        return None
    first = infos[going[0]]
    if type(first) is not InfoRow:
        return None
    vector = first.vector_info
    # Every going row must read this vector info at its own index (a wrapper may
    # replace any row, or join the infos of several vector envs).
    if not all(
        type(infos[i]) is InfoRow and infos[i].vector_info is vector and infos[i].index == i
        for i in going
    ):
        return None
    required = [key for key in keys if key not in OPTIONAL_STEP_KEYS]
    if len(vector[f"_{required[0]}"]) != len(infos):  # the rows of several vector envs
        return None
    columns = [_column(vector, key, len(infos)) for key in keys]
    if not finished:
        return columns, [vector[f"_{key}"] for key in required]
    columns = [np.array(column) for column in columns]  # fresh: rows are written
    for i in finished:
        for column, key in zip(columns, keys, strict=True):
            column[i] = infos[i].get(key, math.nan) if key in OPTIONAL_STEP_KEYS else infos[i][key]
    return columns, [vector[f"_{key}"][going] for key in required]


def _column(vector: Mapping[str, Any], key: str, num_envs: int) -> np.ndarray:
    """``key``'s (B,) column of a vector info: an optional key NaN where unreported,
    a required one the info's own array."""
    if key not in OPTIONAL_STEP_KEYS:
        return vector[key]
    if key not in vector:
        return np.full(num_envs, math.nan)
    return np.where(vector[f"_{key}"], vector[key], math.nan)


class SlamMetricsCallback(BaseCallback):
    """Logs the SLAM metrics of the training episodes under ``prefix``, from the step
    infos: three keys per step (in one go for a native vector env's infos), the rest
    at an episode's end. The cost is a few thousand instructions a step (see
    ``benchmarks/bench_train_metrics.py``)."""

    def __init__(self, prefix: str = TRAIN_PREFIX, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.prefix = prefix
        self.episodes = 0  # episodes logged so far
        self._tallies = EpisodeTallies(0)
        self._reported: list[np.ndarray] = []  # masks of the columns read in one go

    def _init_callback(self) -> None:
        self._tallies = EpisodeTallies(self.training_env.num_envs)

    def _on_step(self) -> bool:
        infos = self.locals["infos"]
        dones = self.locals["dones"].tolist()  # one numpy call: cheaper than .any()
        finished = [i for i, done in enumerate(dones) if done] if True in dones else []
        read = vector_columns(infos, finished, STEP_KEYS)
        if read is None:
            self._tallies.add_infos(infos)
        else:
            self._tallies.add(*read[0])
            self._reported += read[1]
        if finished:
            self._check_reported()
        for i in finished:
            record_metrics(self.logger, self.prefix, self._tallies.finish(i, infos[i]))
            self.episodes += 1
        return True

    def _check_reported(self) -> None:
        """The columns read in one go must have been reported by every sub-env (they
        are checked together, at episode ends: a numpy call a step would cost more
        than the reading)."""
        if self._reported and not np.concatenate(self._reported).all():
            raise ValueError(
                f"the training env's infos lack {STEP_KEYS} for some sub-envs: the SLAM "
                "metrics need slam_env/ActiveSLAM-v0's infos"
            )
        self._reported.clear()


class SlamEvalCallback(EvalCallback):
    """``EvalCallback`` on the ``eval_seed`` worlds, with the SLAM metrics and the best
    model kept by them (see the module's docstring). Other arguments are
    ``EvalCallback``'s; ``best_model_save_path`` receives ``best_model.zip``.

    After each evaluation, :attr:`last_slam` holds its mean metrics (and
    ``timesteps``), :attr:`best_slam` those of the best evaluation so far."""

    def __init__(
        self,
        eval_env: Any,
        *,
        eval_seed: int,
        best_model_save_path: str | None = None,
        **kwargs: Any,
    ) -> None:
        # The base class would keep the best model by return: it gets no path.
        super().__init__(eval_env, best_model_save_path=None, **kwargs)
        self.eval_seed = eval_seed
        self.best_slam_path = best_model_save_path
        self.last_slam: dict[str, float] | None = None
        self.best_slam: dict[str, float] | None = None
        self._best_score: tuple[float, float] | None = None
        self._tallies = self._new_tallies()
        self._episodes: list[dict[str, float]] = []
        self._history: list[list[dict[str, float]]] = []  # per evaluation, per episode

    def _init_callback(self) -> None:
        with warnings.catch_warnings():
            # A vector training env beside an in-process eval env is intended.
            warnings.filterwarnings("ignore", message="Training and eval env are not")
            super()._init_callback()
        if self.best_slam_path is not None:
            os.makedirs(self.best_slam_path, exist_ok=True)

    def _log_success_callback(self, locals_: dict[str, Any], globals_: dict[str, Any]) -> None:
        super()._log_success_callback(locals_, globals_)
        info, index = locals_["info"], locals_["i"]
        tallies = self._tallies[index]  # evaluate_policy hands over one sub-env at a time
        tallies.add_infos([info])
        if locals_["done"]:
            metrics = tallies.finish(0, info)
            self._episodes.append(metrics)
            # Recorded now, they are written with the evaluation's other figures.
            record_metrics(self.logger, EVAL_PREFIX, metrics)

    def _on_step(self) -> bool:
        evaluating = self.eval_freq > 0 and self.n_calls % self.eval_freq == 0
        if evaluating:
            self.eval_env.seed(self.eval_seed)
            self._tallies = self._new_tallies()
            self._episodes = []
        keep_going = super()._on_step()
        if evaluating:
            self._judge()
        return keep_going

    def _new_tallies(self) -> list[EpisodeTallies]:
        return [EpisodeTallies(1) for _ in range(self.eval_env.num_envs)]

    def _judge(self) -> None:
        """Keep the evaluation's figures, and the model if it is the best so far."""
        means = mean_metrics(self._episodes)
        self.last_slam = {"timesteps": float(self.num_timesteps), **means}
        self._history.append(self._episodes)
        score = evaluation_score(means)
        if self._best_score is None or score > self._best_score:
            self._best_score = score
            self.best_slam = self.last_slam
            if self.best_slam_path is not None:
                self.model.save(os.path.join(self.best_slam_path, "best_model"))
        if self.log_path is not None:
            per_episode = {
                f"slam_{name}": np.array([[ep[name] for ep in eps] for eps in self._history])
                for name in SLAM_METRICS
            }
            np.savez(
                self.log_path,
                timesteps=self.evaluations_timesteps,
                results=self.evaluations_results,
                ep_lengths=self.evaluations_length,
                **per_episode,
            )
