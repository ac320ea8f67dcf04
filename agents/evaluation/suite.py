"""Evaluation suites: a fixed, documented set of world settings × seeds on which agents
are compared by how fast and how well they map (``slam-env evaluate --suite NAME``).

One world is not enough to tell good explorers apart: on the default world both
planners map every landmark within 500 steps. A suite runs every agent on several
settings (presets, arena sizes, landmark counts, sensors), each for the same seeds,
with an episode length that scales with the arena
(:func:`agents.common.episode_length.episode_length`: 500 steps at 16 m), and reports
the metrics of :mod:`agents.rollouts.suite_metrics` per setting and agent.

The ``default`` suite (3 seeds per setting, seeds 10000–10002, never used in training):

| setting       | env options                                  | steps |
|---------------|----------------------------------------------|------:|
| default       | (a random 16 m world, 20 landmarks)          |   500 |
| open          | ``preset=open``                              |   500 |
| cluttered     | ``preset=cluttered``                         |   500 |
| rooms         | ``preset=rooms``                             |   500 |
| arena_8m      | ``width=height=8, n_landmarks=10, n_obstacles=2`` | 250 |
| arena_32m     | ``width=height=32``                          |  1000 |
| landmarks_10  | ``n_landmarks=10``                           |   500 |
| landmarks_60  | ``n_landmarks=60``                           |   500 |
| short_range   | ``max_range=2.5`` (m)                        |   500 |
| sensor_360    | ``fov=2π``                                   |   500 |

``smoke`` is two small settings × one seed of 30 steps, for tests. ``--episodes N``
(``run_suite(episodes=N)``) runs N seeds per setting instead, ``--seed S`` from S, and
``--settings a,b`` only those settings (to split a long suite between processes).

Files written into ``out_dir``: ``suite.csv`` (one row per setting and agent: each
metric's mean over the seeds and, for the steps-to metrics, the share of episodes
that reached the share), ``suite_episodes.csv`` (one row per episode), ``suite.md``
(the table, the best agent per setting in bold, and the head-to-head counts),
``results.json`` (settings and both tables), ``suite_steps_to_90.png`` and
``suite_final_entropy.png``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym

from agents.common.arguments import check_count
from agents.common.base import Agent
from agents.common.env import make_env
from agents.common.episode_length import REFERENCE_ARENA, episode_length
from agents.evaluation.compare import json_safe, write_csv
from agents.evaluation.statistics import mean_ci
from agents.registry import agent_label, make_agent, parse_agent_specs
from agents.rollouts.episodes import run_episode
from agents.rollouts.records import EpisodeRecord, check_episode_memory
from agents.rollouts.suite_metrics import MAPPED_SHARES, SUITE_METRICS, suite_metrics
from slam_env.config import BELIEFS

#: Seeds of the suites' episodes (training draws its worlds from other generators).
SUITE_SEED = 10_000


@dataclass(frozen=True)
class SuiteSetting:
    """One world setting of a suite: its env options, episodes and their length."""

    name: str
    env_options: dict[str, Any] = field(default_factory=dict)
    episodes: int = 3
    max_steps: int | None = None  # None: episode_length of the arena

    @property
    def steps(self) -> int:
        if self.max_steps is not None:
            return self.max_steps
        opts = self.env_options
        return episode_length(
            opts.get("width", REFERENCE_ARENA), opts.get("height", REFERENCE_ARENA)
        )


def _default_suite() -> list[SuiteSetting]:
    return [
        SuiteSetting("default"),
        SuiteSetting("open", {"preset": "open"}),
        SuiteSetting("cluttered", {"preset": "cluttered"}),
        SuiteSetting("rooms", {"preset": "rooms"}),
        SuiteSetting(
            "arena_8m", {"width": 8.0, "height": 8.0, "n_landmarks": 10, "n_obstacles": 2}
        ),
        SuiteSetting("arena_32m", {"width": 32.0, "height": 32.0}),
        SuiteSetting("landmarks_10", {"n_landmarks": 10}),
        SuiteSetting("landmarks_60", {"n_landmarks": 60}),
        SuiteSetting("short_range", {"max_range": 2.5}),
        SuiteSetting("sensor_360", {"fov": 2.0 * math.pi}),
    ]


def _smoke_suite() -> list[SuiteSetting]:
    return [
        SuiteSetting("default", episodes=1, max_steps=30),
        SuiteSetting("rooms", {"preset": "rooms", "n_landmarks": 6}, episodes=1, max_steps=30),
    ]


SUITES: dict[str, Callable[[], list[SuiteSetting]]] = {
    "default": _default_suite,
    "smoke": _smoke_suite,
}


def chosen_settings(suite: str, names: Sequence[str] | None) -> list[SuiteSetting]:
    """The settings of ``suite`` named in ``names`` (all when None), in the suite's
    order; ``ValueError`` for a name the suite does not have, or none at all."""
    settings = suite_settings(suite)
    if names is None:
        return settings
    if isinstance(names, str):
        raise TypeError("settings must be a sequence of setting names, not a str")
    known = [s.name for s in settings]
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(
            f"suite {suite!r} has no setting {', '.join(map(repr, unknown))}; "
            f"its settings: {', '.join(known)}"
        )
    if not names:
        raise ValueError(f"no settings given; suite {suite!r} has {', '.join(known)}")
    return [s for s in settings if s.name in names]


def suite_settings(name: str) -> list[SuiteSetting]:
    """The settings of suite ``name`` (``ValueError`` naming the suites otherwise)."""
    if name not in SUITES:
        raise ValueError(f"unknown suite {name!r}; suites: {', '.join(SUITES)}")
    return SUITES[name]()


def agent_observation(spec: str) -> str | None:
    """The ``observation`` option an agent needs: a policy trained on the ``local``
    observation says so by its space; other agents read the filter (None: any)."""
    spec = spec.strip()
    if not (spec == "ppo" or spec.startswith("ppo:")):
        return None
    from agents.learning.ppo_agent import load_ppo_agent
    from agents.registry import SHIPPED_POLICY

    agent = load_ppo_agent(SHIPPED_POLICY if spec == "ppo" else spec[4:].strip())
    keys = getattr(agent.observation_space, "spaces", {})
    return "local" if "local_map" in keys else None


@dataclass
class SuiteResult:
    """What :func:`run_suite` measured and wrote."""

    rows: list[dict[str, Any]]  # one per (setting, agent): means over the episodes
    episodes: list[dict[str, Any]]  # one per (setting, agent, episode)
    files: dict[str, Path]
    markdown: str


def _run_agent(
    spec: str, setting: SuiteSetting, seeds: list[int], observation: str | None
) -> list[EpisodeRecord]:
    from agents.rollouts.vector_episodes import acts_on_batches, run_episodes_batched

    options = dict(setting.env_options)
    if observation is not None:
        options["observation"] = observation
    env: gym.Env = make_env(options, setting.steps)
    try:
        agent: Agent = make_agent(spec, env, seeds[0])
        if acts_on_batches(agent):
            return run_episodes_batched(agent, seeds, options, setting.steps)
        return [run_episode(env, agent, s) for s in seeds]
    finally:
        env.close()


def run_suite(
    agent_specs: Sequence[str] | str,
    suite: str = "default",
    out_dir: str | Path = "out/suite",
    *,
    episodes: int | None = None,
    seed: int | None = None,
    settings: Sequence[str] | None = None,
    belief: str = "ekf",
    progress: bool = True,
    verbose: bool = True,
) -> SuiteResult:
    """Run every agent on every setting of ``suite`` (episode i of a setting:
    ``reset(seed=seed + i)`` for every agent; None: :data:`SUITE_SEED`), write the files
    of the module docstring into ``out_dir`` and return them with the tables.
    ``episodes``: per setting, instead of the suite's own count (3 seeds tell agents
    apart only where they differ by more than their scatter between worlds).
    ``settings``: only these of the suite's settings (by name, run in the suite's order),
    to split a long suite between processes. ``belief``: ActiveSLAM-v0's belief in
    every setting (``"isam2"``: the smoothing belief; the agents are the same)."""
    specs = parse_agent_specs(agent_specs) if isinstance(agent_specs, str) else list(agent_specs)
    parse_agent_specs(",".join(specs))
    settings = chosen_settings(suite, settings)
    if belief not in BELIEFS:
        raise ValueError(f"belief must be one of {BELIEFS}, got {belief!r}")
    if belief != "ekf":
        settings = [
            dataclasses.replace(s, env_options={**s.env_options, "belief": belief})
            for s in settings
        ]
    if episodes is not None:
        check_count("episodes", episodes, 1)
        settings = [dataclasses.replace(s, episodes=episodes) for s in settings]
    if seed is None:
        seed = SUITE_SEED
    check_count("seed", seed, 0)
    for setting in settings:  # one agent's records of a setting are kept at a time
        check_episode_memory(setting.steps, setting.episodes, f"suite setting {setting.name}")
    observations = {spec: agent_observation(spec) for spec in specs}  # checks PPO files
    _check_fits(specs, settings, observations)
    from tqdm.auto import tqdm

    total = sum(s.episodes for s in settings) * len(specs)
    episode_rows: list[dict[str, Any]] = []
    rows: list[dict[str, Any]] = []
    with tqdm(total=total, desc=f"suite {suite}", unit="episode", disable=not progress) as bar:
        for setting in settings:
            seeds = [seed + i for i in range(setting.episodes)]
            for spec in specs:
                label = agent_label(spec)
                bar.set_postfix_str(f"{setting.name}: {label}")
                records = _run_agent(spec, setting, seeds, observations[spec])
                per_episode = []
                for rec in records:
                    m = suite_metrics(rec)
                    per_episode.append(m)
                    episode_rows.append(
                        {"setting": setting.name, "agent": label, "seed": rec.seed, **m}
                    )
                rows.append(_aggregate(setting, label, per_episode))
                bar.update(len(records))

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = {
        "suite_csv": out / "suite.csv",
        "suite_episodes_csv": out / "suite_episodes.csv",
        "suite_md": out / "suite.md",
        "results_json": out / "results.json",
    }
    write_csv(files["suite_csv"], list(rows[0]), rows)
    write_csv(files["suite_episodes_csv"], list(episode_rows[0]), episode_rows)
    markdown = suite_markdown(rows, [agent_label(s) for s in specs], suite, belief)
    files["suite_md"].write_text(markdown)
    payload = {
        "suite": suite,
        "belief": belief,
        "agents": specs,
        "seed": seed,
        "settings": [
            {"name": s.name, "env_options": s.env_options, "episodes": s.episodes, "steps": s.steps}
            for s in settings
        ],
        "metrics": SUITE_METRICS,
        "rows": rows,
        "episodes": episode_rows,
    }
    files["results_json"].write_text(
        json.dumps(json_safe(payload), indent=2, allow_nan=False) + "\n"
    )
    files.update(_plot(rows, out))
    if verbose:
        print(markdown)
    return SuiteResult(rows, episode_rows, files, markdown)


def _check_fits(
    specs: Sequence[str], settings: Sequence[SuiteSetting], observations: dict[str, str | None]
) -> None:
    """``ValueError`` naming the agent and the setting, before anything runs, where a
    policy's spaces do not fit a setting's env (an egocentric policy is tied to its
    landmark count)."""
    for spec in specs:
        if not (spec == "ppo" or spec.startswith("ppo:")) or observations[spec] == "local":
            continue
        for setting in settings:
            env = make_env(setting.env_options, setting.steps)
            try:
                make_agent(spec, env)
            except ValueError as exc:
                raise ValueError(
                    f"agent {spec!r} cannot run the suite's setting {setting.name!r} "
                    f"({exc}); a policy trained on observation='local' runs on every setting"
                ) from None
            finally:
                env.close()


def _aggregate(setting: SuiteSetting, label: str, episodes: list[dict[str, float]]) -> dict:
    row: dict[str, Any] = {
        "setting": setting.name,
        "agent": label,
        "episodes": len(episodes),
        "steps": setting.steps,
    }
    for name in SUITE_METRICS:
        row[name] = mean_ci([e[name] for e in episodes])[0]
    for share in MAPPED_SHARES:
        key = f"reached_{round(100 * share)}"
        row[key] = mean_ci([e[key] for e in episodes])[0]
    return row


# Lower is better for these; the table marks each setting's best agent on them.
_LOWER_IS_BETTER = ("steps_to_90", "final_entropy")
_COLUMNS = (
    ("mapped_share", "mapped", "{:.2f}"),
    ("steps_to_50", "→50%", "{:.0f}"),
    ("steps_to_90", "→90%", "{:.0f}"),
    ("steps_to_100", "→100%", "{:.0f}"),
    ("entropy_auc", "H AUC/step", "{:.1f}"),
    ("final_entropy", "final H", "{:.1f}"),
    ("collisions_per_100", "coll./100", "{:.1f}"),
    ("map_rmse", "RMSE [m]", "{:.3f}"),
)


def _fmt(value: float, pattern: str, censored: bool = False) -> str:
    if not math.isfinite(value):
        return "–"
    return pattern.format(value) + ("*" if censored else "")


def suite_markdown(
    rows: Sequence[dict[str, Any]], labels: Sequence[str], suite: str, belief: str = "ekf"
) -> str:
    """The suite's table (Markdown): a row per setting and agent; per setting the
    best agent on steps to 90% and on final entropy in bold; a steps-to value marked
    * where some episode never got there (counted as the episode length). Then, per
    pair of agents, the settings where the first beats the second on both."""
    lines = [
        f"Suite `{suite}`"
        + ("" if belief == "ekf" else f" on the `{belief}` belief")
        + ": mean over the seeds of each setting; lower is better but for "
        "'mapped'. * : some episodes never reached the share (counted at the episode length).",
        "",
        "| setting | agent | " + " | ".join(title for _, title, _ in _COLUMNS) + " |",
        "|---|---|" + "---:|" * len(_COLUMNS),
    ]
    by_setting: dict[str, list[dict[str, Any]]] = {}
    for row in rows:
        by_setting.setdefault(row["setting"], []).append(row)
    for setting, group in by_setting.items():
        best = {
            name: min(r[name] for r in group if math.isfinite(r[name])) for name in _LOWER_IS_BETTER
        }
        for row in group:
            cells = []
            for name, _, pattern in _COLUMNS:
                reached = row.get(f"reached_{name.rsplit('_', 1)[-1]}", 1.0)
                text = _fmt(row[name], pattern, name.startswith("steps_to") and reached < 1.0)
                tied = all(r[name] == best.get(name) for r in group)  # nothing to tell
                if name in best and row[name] == best[name] and not tied:
                    text = f"**{text}**"
                cells.append(text)
            lines.append(f"| {setting} | {row['agent']} | " + " | ".join(cells) + " |")
    lines += ["", _head_to_head(by_setting, labels), ""]
    return "\n".join(lines)


def _head_to_head(by_setting: dict[str, list[dict[str, Any]]], labels: Sequence[str]) -> str:
    """Per ordered pair of agents: in how many settings the first needs fewer steps to
    90% and ends with a lower entropy than the second."""
    n = len(by_setting)
    lines = [
        f"Head to head over the {n} settings: settings where the row's agent beats the "
        "column's (fewer steps to 90% / lower final entropy).",
        "",
        "| agent | " + " | ".join(labels) + " |",
        "|---|" + "---:|" * len(labels),
    ]
    for a in labels:
        cells = []
        for b in labels:
            if a == b:
                cells.append("–")
                continue
            wins = [0, 0]
            for group in by_setting.values():
                ra = next(r for r in group if r["agent"] == a)
                rb = next(r for r in group if r["agent"] == b)
                wins[0] += ra["steps_to_90"] < rb["steps_to_90"]
                wins[1] += ra["final_entropy"] < rb["final_entropy"]
            cells.append(f"{wins[0]} / {wins[1]}")
        lines.append(f"| {a} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _plot(rows: Sequence[dict[str, Any]], out: Path) -> dict[str, Path]:
    from slam_env.render.plots import plot_grouped_bars

    files = {}
    for name, title in (
        ("steps_to_90", "steps to map 90% of the landmarks (episode length if never)"),
        ("final_entropy", "final belief entropy [nats]"),
    ):
        values: dict[str, dict[str, float]] = {}
        for row in rows:
            values.setdefault(row["setting"], {})[row["agent"]] = row[name]
        path = out / f"suite_{name}.png"
        plot_grouped_bars(values, path, title=title).clear()
        files[f"{name}_png"] = path
    return files
