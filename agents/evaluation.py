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
import hashlib
import io
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from scipy.stats import t as student_t

from agents.arguments import check_count
from agents.base import Agent
from agents.registry import agent_label, make_agent, make_env
from slam_env.belief.metrics import share_in_nees_band
from slam_env.budget import MAX_MEMORY_BYTES
from slam_env.envs.registration import DEFAULT_MAX_EPISODE_STEPS

#: Per-episode metrics, in table order, with their descriptions.
METRICS: dict[str, str] = {
    "mapped_share": "share of landmarks mapped at the end",
    "final_entropy": "final belief entropy [nats]",
    "map_rmse": "final map RMSE [m]",
    "pose_rmse": "pose RMSE along the trajectory [m]",
    "mean_pose_nees": "mean pose NEES (3 dof)",
    "collisions": "steps in collision",
    "path_length": "path length [m]",
    "return": "episode return",
    "steps": "episode length [steps]",
}
CONFIDENCE = 0.95
#: Per-agent figures over all its episodes at once (no confidence interval).
AGENT_METRICS: dict[str, str] = {
    "nees_in_band": "steps with the mean pose NEES in its 95% χ² band [share]",
}
POSE_DOF = 3  # x, y, θ: the pose NEES's degrees of freedom


# ---------------------------------------------------------------------- statistics
def t_quantile(p: float, dof: float) -> float:
    """The p-quantile of Student's t with ``dof`` degrees of freedom (scipy's)."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must be in (0, 1), got {p}")
    if not (dof > 0 and not math.isnan(dof)):
        raise ValueError(f"dof must be > 0, got {dof}")
    return float(student_t.ppf(p, dof))


def mean_ci(values: Sequence[float], confidence: float = CONFIDENCE) -> tuple[float, float, int]:
    """(mean, half-width of the two-sided Student-t confidence interval, n) over the
    finite values; the half-width is NaN for fewer than two values."""
    arr = np.asarray(values, dtype=np.float64).reshape(-1)
    arr = arr[np.isfinite(arr)]
    n = int(arr.size)
    if n == 0:
        return math.nan, math.nan, 0
    mean = float(arr.mean())
    if n < 2:
        return mean, math.nan, n
    sem = float(arr.std(ddof=1)) / math.sqrt(n)
    return mean, t_quantile(0.5 + 0.5 * confidence, n - 1) * sem, n


# ---------------------------------------------------------------------- episodes
@dataclass
class EpisodeRecord:
    """One episode of one agent, step by step (index 0 is the state after reset)."""

    seed: int
    n_landmarks: int
    true_poses: np.ndarray  # (T+1, 3)
    est_poses: np.ndarray  # (T+1, 3)
    entropy: np.ndarray  # (T+1,) nats
    landmarks_known: np.ndarray  # (T+1,)
    pose_error: np.ndarray  # (T+1,) m
    pose_nees: np.ndarray  # (T+1,)
    map_rmse: np.ndarray  # (T+1,) m, nan before the first landmark
    collision: np.ndarray  # (T+1,) bool
    rewards: np.ndarray  # (T,)
    layout: Any = None  # slam_env.world.layouts.Layout of the episode
    belief: Any = None  # final slam_env.belief.overlay.BeliefOverlay
    world: str = ""  # short digest of the world (same worlds ⇔ same digests)
    frames: list[np.ndarray] = field(default_factory=list)
    detections_world: list[np.ndarray] = field(default_factory=list)

    @property
    def steps(self) -> int:
        return int(self.rewards.size)

    def metrics(self) -> dict[str, float]:
        """The per-episode metrics of :data:`METRICS`."""
        after = slice(1, None) if self.steps else slice(None)
        err = self.pose_error[after]
        nees = self.pose_nees[after]
        nees = nees[np.isfinite(nees)]
        step_len = np.hypot(*np.diff(self.true_poses[:, :2], axis=0).T)
        return {
            "mapped_share": float(self.landmarks_known[-1]) / self.n_landmarks,
            "final_entropy": float(self.entropy[-1]),
            "map_rmse": float(self.map_rmse[-1]),
            "pose_rmse": float(math.sqrt(np.mean(err**2))),
            "mean_pose_nees": float(nees.mean()) if nees.size else math.nan,
            "collisions": int(np.count_nonzero(self.collision[after])),
            "path_length": float(step_len.sum()),
            "return": float(self.rewards.sum()),
            "steps": self.steps,
        }


def _world_digest(info: dict[str, Any]) -> str:
    h = hashlib.sha1()
    h.update(np.round(np.asarray(info["landmark_positions"], np.float64), 6).tobytes())
    h.update(np.asarray(info["landmark_ids"], np.int64).tobytes())
    h.update(np.round(np.asarray(info["pose"], np.float64), 6).tobytes())
    return h.hexdigest()[:12]


#: Bytes a step of an episode costs while it runs (its info row, estimates and
#: detections: 2.8 KB measured on the default world) and once kept in its
#: EpisodeRecord (125 B measured), with room to spare.
STEP_BYTES_RUNNING = 4096
STEP_BYTES_KEPT = 256


def check_episode_memory(steps: int | None, episodes_kept: int, what: str) -> None:
    """``ValueError`` unless running an episode of ``steps`` steps (None: the envs'
    default length) while keeping the records of ``episodes_kept`` of them fits in
    :data:`slam_env.budget.MAX_MEMORY_BYTES`, before anything runs."""
    steps = DEFAULT_MAX_EPISODE_STEPS if steps is None else steps
    need = (steps + 1) * (STEP_BYTES_RUNNING + episodes_kept * STEP_BYTES_KEPT)
    if need > MAX_MEMORY_BYTES:
        raise ValueError(
            f"{what}: {episodes_kept} episode records of {steps} steps need about "
            f"{need / 2**30:.3g} GiB, over the budget of {MAX_MEMORY_BYTES / 2**30:.0f} GiB "
            "(README: Resource budget); ask for fewer episodes or steps"
        )


def run_episode(
    env: gym.Env,
    agent: Agent,
    seed: int,
    *,
    deterministic: bool = True,
    render_every: int = 0,
    collect_detections: bool = False,
) -> EpisodeRecord:
    """Run one episode from ``env.reset(seed=seed)`` until it terminates or is
    truncated. ``render_every`` > 0 keeps ``env.render()`` every that many steps
    (and the last); ``collect_detections`` keeps world-frame detection points."""
    base = env.unwrapped
    obs, info = env.reset(seed=seed)
    rows: list[dict[str, Any]] = []
    est: list[np.ndarray] = []
    rewards: list[float] = []
    frames: list[np.ndarray] = []
    detections: list[np.ndarray] = []

    def record(step: int, done: bool) -> None:
        rows.append(info)
        est.append(np.asarray(base.filter.pose, dtype=np.float64).copy())
        if render_every and (step % render_every == 0 or done):
            frames.append(np.asarray(env.render()))
        if collect_detections:
            detections.append(base.render_frame().detections_world)

    record(0, False)
    state, episode_start, step = None, True, 0
    while True:
        action, state = agent.predict(
            obs, state=state, episode_start=episode_start, deterministic=deterministic
        )
        obs, reward, terminated, truncated, info = env.step(action)
        step += 1
        rewards.append(float(reward))
        episode_start = False
        done = bool(terminated or truncated)
        record(step, done)
        if done:
            break

    return episode_record(
        seed,
        rows,
        est,
        rewards,
        n_landmarks=int(base.n_landmarks),
        layout=base.layout,
        belief=base.belief_overlay(),
        frames=frames,
        detections_world=detections,
    )


def episode_record(
    seed: int,
    rows: Sequence[dict[str, Any]],
    est: Sequence[np.ndarray],
    rewards: Sequence[float],
    **fields: Any,
) -> EpisodeRecord:
    """An :class:`EpisodeRecord` from an episode's infos (the reset's, then each
    step's), estimated poses and rewards; ``fields`` are its other attributes."""

    def col(key: str, dtype: Any = np.float64) -> np.ndarray:
        return np.array([r[key] for r in rows], dtype=dtype)

    def metric(key: str) -> np.ndarray:
        # The env leaves an undefined metric out of info; here it is NaN, which the
        # aggregation leaves out of the means.
        return np.array([r.get(key, math.nan) for r in rows], dtype=np.float64)

    return EpisodeRecord(
        seed=seed,
        true_poses=np.stack([r["pose"] for r in rows]).astype(np.float64),
        est_poses=np.stack(est),
        entropy=col("entropy"),
        landmarks_known=col("landmarks_known"),
        pose_error=col("pose_error"),
        pose_nees=metric("pose_nees"),
        map_rmse=metric("map_rmse"),
        collision=col("collision", bool),
        rewards=np.asarray(rewards, dtype=np.float64),
        world=_world_digest(rows[0]),
        **fields,
    )


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


def _json_safe(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, np.generic):
        return _json_safe(value.item())
    if isinstance(value, Path):
        return str(value)
    return value


def _csv_value(value: Any) -> Any:
    if isinstance(value, (float, np.floating)):
        return "" if not math.isfinite(value) else repr(float(value))
    return value


def _write_csv(path: Path, columns: list[str], rows: Sequence[dict[str, Any]]) -> None:
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
) -> EvaluationResult:
    """Run every agent of ``agent_specs`` (specs of :func:`agents.registry.make_agent`,
    or one comma-separated string) for ``episodes`` episodes on the same seeded worlds
    (episode i: ``reset(seed=seed + i)``), write ``summary.csv``, ``episodes.csv``,
    ``results.json``, ``trajectories.png`` (episode ``plot_episode``),
    ``metrics_over_time.png`` and ``consistency.png`` into ``out_dir``, print the
    summary when ``verbose``, and return an :class:`EvaluationResult`. All agents are
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

        from tqdm.auto import tqdm

        from agents.vector_episodes import acts_on_batches, run_episodes_batched

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
    _write_csv(files["summary_csv"], summary_columns(), summary_rows)
    _write_csv(files["episodes_csv"], episode_columns(), episode_rows)
    _write_steps(files["steps_csv"], records)
    payload = {
        "settings": settings,
        "metrics": {**METRICS, **AGENT_METRICS},
        "summary": summary_rows,
        "episodes": episode_rows,
    }
    files["results_json"].write_text(
        json.dumps(_json_safe(payload), indent=2, allow_nan=False) + "\n"
    )
    files.update(_plot(records, plot_episode, out))
    result = EvaluationResult(summary_rows, episode_rows, settings, files, records)
    if verbose:
        print_summary(result)
    return result
