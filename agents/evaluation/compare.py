"""Compare agents on the same seeded worlds: metrics, confidence intervals, plots.

``evaluate(["random", "infogain", "ppo:run/model.zip"], episodes=20, seed=0)`` runs
every agent for ``episodes`` episodes; episode ``i`` starts with
``reset(seed=seed + i)`` for every agent, so they all face the same worlds and start
poses. Per episode it records (columns of ``episodes.csv``):

| metric            | meaning                                                              |
|-------------------|----------------------------------------------------------------------|
| ``mapped_share``  | landmarks in the belief at the end / landmarks in the world            |
| ``final_entropy`` | belief entropy at the end, nats (over pose and every landmark slot)   |
| ``map_rmse``      | final RMS landmark position error over the mapped landmarks, m        |
| ``pose_rmse``     | √(mean over steps of the position error²), m                          |
| ``mean_pose_nees``| mean pose NEES over steps (3 dof: 3 for a consistent filter)          |
| ``collisions``    | steps spent in contact                                                 |
| ``path_length``   | distance actually driven (from the true poses), m                     |
| ``return``        | sum of the active-SLAM reward                                          |
| ``steps``         | episode length                                                         |

Step averages run over the steps after ``reset`` (at reset the pose is known exactly).
``summary.csv`` holds, per agent, each metric's mean and the half-width of its 95%
confidence interval (Student t, n − 1 dof; empty for one episode); episodes where a
metric is undefined (``map_rmse`` with nothing mapped) are left out of its mean, and
``<metric>_n`` says how many counted. It also holds ``nees_in_band``: the share of
steps at which the pose NEES averaged over the agent's episodes lies inside its 95% χ²
band for that many episodes (about 0.95 for a consistent filter; see
:func:`slam_env.belief.metrics.share_in_nees_band`). ``steps.csv.gz`` holds every step (belief
entropy, landmarks known, errors, NEES, collision, true and estimated pose);
``results.json`` holds the summary and episode tables and the settings;
``trajectories.png`` shows each agent's trajectory and final belief (95% ellipses) in
one episode, ``metrics_over_time.png`` the entropy, share mapped and pose error over
time (mean ± std over episodes), ``consistency.png`` the pose NEES averaged over the
episodes inside its 95% χ² band, and the map RMSE, over time.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.common.arguments import check_count
from agents.common.base import Agent
from agents.common.env import make_env
from agents.evaluation.statistics import CONFIDENCE, mean_ci
from agents.evaluation.trajectories import export_trajectories
from agents.registry import agent_label, make_agent
from agents.rollouts.episodes import run_episode
from agents.rollouts.records import METRICS, POSE_DOF, EpisodeRecord, check_episode_memory
from slam_env.belief.metrics import share_in_nees_band

#: Per-agent figures over all its episodes at once (no confidence interval).
AGENT_METRICS: dict[str, str] = {
    "nees_in_band": "steps with the mean pose NEES in its 95% χ² band [share]",
}


# ---------------------------------------------------------------------- evaluate
@dataclass
class EvaluationResult:
    """What :func:`evaluate` measured and wrote."""

    summary: list[dict[str, Any]]  # one row per agent
    episodes: list[dict[str, Any]]  # one row per (agent, episode)
    settings: dict[str, Any]
    files: dict[str, Path]  # name -> written path
    records: dict[str, list[EpisodeRecord]] = field(repr=False, default_factory=dict)


def summarize(
    label: str, spec: str, rows: Sequence[dict[str, Any]], records: Sequence[EpisodeRecord]
) -> dict[str, Any]:
    """One summary row: mean, 95% CI half-width and count of every metric, then the
    :data:`AGENT_METRICS` of the agent's episode ``records``."""
    out: dict[str, Any] = {"agent": label, "spec": spec, "episodes": len(rows)}
    for name in METRICS:
        mean, half, n = mean_ci([r[name] for r in rows])
        out[f"{name}_mean"] = mean
        out[f"{name}_ci95"] = half
        out[f"{name}_n"] = n
    out["nees_in_band"] = share_in_nees_band([r.pose_nees for r in records], POSE_DOF, CONFIDENCE)
    return out


def summary_columns() -> list[str]:
    cols = ["agent", "spec", "episodes"]
    for name in METRICS:
        cols += [f"{name}_mean", f"{name}_ci95", f"{name}_n"]
    return cols + list(AGENT_METRICS)


def episode_columns() -> list[str]:
    return ["agent", "spec", "episode", "seed", "world", *METRICS]


STEP_COLUMNS = [
    "agent",
    "episode",
    "seed",
    "step",
    "reward",
    "entropy",
    "landmarks_known",
    "pose_error",
    "pose_nees",
    "map_rmse",
    "collision",
    "x",
    "y",
    "theta",
    "est_x",
    "est_y",
    "est_theta",
]


def _write_steps(path: Path, records: dict[str, list[EpisodeRecord]]) -> None:
    """Every step of every episode (step 0: after reset, reward empty) as gzipped CSV."""
    with (
        open(path, "wb") as raw,
        gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as gz,
        io.TextIOWrapper(gz, encoding="utf-8", newline="") as fh,
    ):
        writer = csv.writer(fh)
        writer.writerow(STEP_COLUMNS)
        for label, recs in records.items():
            for i, r in enumerate(recs):
                rewards = np.concatenate([[math.nan], r.rewards])
                for t in range(r.true_poses.shape[0]):
                    row = [
                        label,
                        i,
                        r.seed,
                        t,
                        rewards[t],
                        r.entropy[t],
                        int(r.landmarks_known[t]),
                        r.pose_error[t],
                        r.pose_nees[t],
                        r.map_rmse[t],
                        int(r.collision[t]),
                        *r.true_poses[t],
                        *r.est_poses[t],
                    ]
                    writer.writerow([_csv_value(v) for v in row])


def json_safe(value: Any) -> Any:
    """``value`` as JSON takes it: numpy scalars as Python values, tuples as lists, paths
    as strings, a non-finite float as None (null)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.generic):
        return json_safe(value.item())
    if isinstance(value, Path):
        return str(value)
    return value


def _csv_value(value: Any) -> Any:
    if isinstance(value, (float, np.floating)):
        return "" if not math.isfinite(value) else repr(float(value))
    return value


def write_csv(path: Path, columns: list[str], rows: Sequence[dict[str, Any]]) -> None:
    """``rows`` (dicts) into the CSV file ``path``, in the order of ``columns``; a
    non-finite float is an empty cell."""
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({c: _csv_value(row[c]) for c in columns})


def _cell(mean: float, half: float) -> str:
    if not math.isfinite(mean):
        return "–"
    if math.isfinite(half):
        return f"{mean:.4g} ± {half:.2g}"
    return f"{mean:.4g}"


def format_summary(result: EvaluationResult) -> Any:
    """The summary as a ``rich.table.Table``: one row per metric, one column per
    agent, cells "mean ± 95% CI half-width"."""
    from rich.markup import escape
    from rich.table import Table

    s = result.settings
    table = Table(
        title=f"{s['episodes']} episodes per agent, seeds {s['seed']}–"
        f"{s['seed'] + s['episodes'] - 1} (mean ± 95% CI)"
    )
    table.add_column("metric", style="bold")
    for row in result.summary:
        table.add_column(escape(row["agent"]), justify="right")
    for name in METRICS:  # the CSV's names; results.json spells them out
        cells = [_cell(row[f"{name}_mean"], row[f"{name}_ci95"]) for row in result.summary]
        table.add_row(name, *cells)
    for name in AGENT_METRICS:
        table.add_row(name, *(_cell(row[name], math.nan) for row in result.summary))
    return table


def print_summary(result: EvaluationResult, console: Any = None) -> None:
    from rich.console import Console

    (console or Console()).print(format_summary(result))


def consistency_series(records: Sequence[EpisodeRecord]) -> dict[str, list[np.ndarray]]:
    """The per-step pose NEES and map RMSE of episodes, as
    :func:`slam_env.render.plots.plot_consistency` takes them."""
    return {"pose_nees": [r.pose_nees for r in records], "map_rmse": [r.map_rmse for r in records]}


def _plot(records: dict[str, list[EpisodeRecord]], plot_index: int, out: Path) -> dict[str, Path]:
    from slam_env.render.plots import (
        plot_consistency,
        plot_metrics_over_time,
        plot_trajectories_grid,
    )

    files: dict[str, Path] = {}
    per_agent = {}
    for label, recs in records.items():
        r = recs[plot_index]
        per_agent[label] = (r.layout, r.true_poses, r.belief, r.est_poses)
    path = out / "trajectories.png"
    fig = plot_trajectories_grid(
        per_agent, path, title=f"episode {plot_index} (seed {recs[plot_index].seed})"
    )
    fig.clear()
    files["trajectories_png"] = path
    series = {
        label: {
            "entropy [nats]": [r.entropy for r in recs],
            "landmarks mapped [share]": [r.landmarks_known / r.n_landmarks for r in recs],
            "pose error [m]": [r.pose_error for r in recs],
        }
        for label, recs in records.items()
    }
    path = out / "metrics_over_time.png"
    plot_metrics_over_time(series, path, title="mean ± std over episodes").clear()
    files["metrics_png"] = path
    path = out / "consistency.png"
    consistency = {label: consistency_series(recs) for label, recs in records.items()}
    plot_consistency(consistency, path, dof=POSE_DOF, confidence=CONFIDENCE).clear()
    files["consistency_png"] = path
    return files


def evaluate(
    agent_specs: Sequence[str] | str,
    episodes: int = 20,
    seed: int = 0,
    env_options: dict[str, Any] | None = None,
    out_dir: str | Path = "eval",
    *,
    max_steps: int | None = None,
    plot_episode: int = 0,
    progress: bool = True,
    verbose: bool = True,
    agent_factory: Callable[[str, gym.Env, int], Agent] | None = None,
    trajectories_dir: str | Path | None = None,
) -> EvaluationResult:
    """Run every agent of ``agent_specs`` (specs of :func:`agents.registry.make_agent`,
    or one comma-separated string) for ``episodes`` episodes on the same seeded worlds
    (episode i: ``reset(seed=seed + i)``), write ``summary.csv``, ``episodes.csv``,
    ``results.json``, ``trajectories.png`` (episode ``plot_episode``),
    ``metrics_over_time.png`` and ``consistency.png`` into ``out_dir``, print the
    summary when ``verbose``, and return an :class:`EvaluationResult`. With
    ``trajectories_dir``, every episode's true and estimated trajectories (TUM files,
    which evo reads) and final map (CSV) go there too
    (:func:`agents.evaluation.trajectories.export_trajectories`). All agents are
    built (and PPO files checked against the env) before anything runs."""
    from agents.registry import parse_agent_specs

    specs = parse_agent_specs(agent_specs) if isinstance(agent_specs, str) else list(agent_specs)
    if not specs:
        raise ValueError("no agent to evaluate")
    parse_agent_specs(",".join(specs))  # rejects empty and duplicate specs
    check_count("episodes", episodes, 1)
    check_count("seed", seed, 0)
    if not 0 <= plot_episode < episodes:
        raise ValueError(f"plot_episode must be in [0, {episodes}), got {plot_episode}")
    check_episode_memory(max_steps, len(specs) * episodes, "evaluate")
    factory = agent_factory or make_agent

    envs: dict[str, gym.Env] = {}
    agents: dict[str, Agent] = {}
    try:
        for spec in specs:
            label = agent_label(spec)
            envs[label] = make_env(env_options, max_steps)
            agents[label] = factory(spec, envs[label], seed)
        dt = envs[label].unwrapped.config.dt  # s per step, the same for every agent's env

        from tqdm.auto import tqdm

        from agents.rollouts.vector_episodes import acts_on_batches, run_episodes_batched

        records: dict[str, list[EpisodeRecord]] = {label: [] for label in agents}
        bar = tqdm(
            total=len(agents) * episodes, desc="evaluate", unit="episode", disable=not progress
        )
        seeds = [seed + i for i in range(episodes)]
        with bar:
            for label, agent in agents.items():
                bar.set_postfix_str(label)
                if acts_on_batches(agent):  # side by side on the native vector env
                    records[label] = run_episodes_batched(agent, seeds, env_options, max_steps)
                    bar.update(episodes)
                    continue
                for episode_seed in seeds:
                    records[label].append(run_episode(envs[label], agent, episode_seed))
                    bar.update()
    finally:
        for env in envs.values():
            env.close()

    episode_rows: list[dict[str, Any]] = []
    summary_rows: list[dict[str, Any]] = []
    for spec, (label, recs) in zip(specs, records.items(), strict=True):
        rows = []
        for i, rec in enumerate(recs):
            row = {"agent": label, "spec": spec, "episode": i, "seed": rec.seed, "world": rec.world}
            row.update(rec.metrics())
            rows.append(row)
        episode_rows += rows
        summary_rows.append(summarize(label, spec, rows, recs))

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    settings = {
        "agents": specs,
        "episodes": episodes,
        "seed": seed,
        "seeds": seeds,
        "env_options": dict(env_options or {}),
        "max_steps": max_steps,
        "confidence": CONFIDENCE,
        "plot_episode": plot_episode,
    }
    files = {
        "summary_csv": out / "summary.csv",
        "episodes_csv": out / "episodes.csv",
        "steps_csv": out / "steps.csv.gz",
        "results_json": out / "results.json",
    }
    write_csv(files["summary_csv"], summary_columns(), summary_rows)
    write_csv(files["episodes_csv"], episode_columns(), episode_rows)
    _write_steps(files["steps_csv"], records)
    payload = {
        "settings": settings,
        "metrics": {**METRICS, **AGENT_METRICS},
        "summary": summary_rows,
        "episodes": episode_rows,
    }
    files["results_json"].write_text(
        json.dumps(json_safe(payload), indent=2, allow_nan=False) + "\n"
    )
    files.update(_plot(records, plot_episode, out))
    if trajectories_dir is not None:
        export_trajectories(records, trajectories_dir, dt)
        files["trajectories_dir"] = Path(trajectories_dir)
    result = EvaluationResult(summary_rows, episode_rows, settings, files, records)
    if verbose:
        print_summary(result)
    return result
