"""The demo: the best shipped agent explores the default world once.

``demo()`` writes into ``out_dir``:

* ``demo.gif``: the episode as rendered by the env (``rgb_array``): the true and
  estimated paths, the sensor's visible region, the belief with 95% ellipses, the step,
  the live entropy, map RMSE and NEES, and a legend (see :mod:`slam_env.render.renderer`),
  subsampled to at most ``gif_max_frames`` frames so that the file stays a few MB;
* ``final_map.png``: the world, the true and estimated trajectories, the detections
  and the final belief with 95% ellipses;
* ``demo_consistency.png``: the pose NEES over time inside its 95% χ² band for one
  episode, and the map RMSE over time;
* ``demo_metrics.json``: the episode's metrics (those of :mod:`agents.evaluation.compare`, and
  the share of steps with the NEES inside its band), which it also prints.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from agents.common.arguments import check_count
from agents.common.env import make_env
from agents.evaluation.compare import AGENT_METRICS, consistency_series, json_safe
from agents.evaluation.statistics import CONFIDENCE
from agents.registry import SHIPPED_POLICY, agent_label, make_agent
from agents.rollouts.episodes import run_episode
from agents.rollouts.records import METRICS, POSE_DOF, check_episode_memory

#: The agent the demo runs by default: the best shipped agent. ``lookahead`` (the
#: shipped goal-choosing policy with a lookahead from the belief) beats both heuristics
#: on the default world's four targets and over most of the suite (README).
DEFAULT_AGENT = "lookahead"
#: Used instead of ``DEFAULT_AGENT = "ppo"`` while no policy is shipped.
BEST_HEURISTIC = "frontier"
DEFAULT_GIF_MAX_FRAMES = 251  # every 2nd step of a 500-step episode: ~1-2 MB
DEFAULT_GIF_FPS = 10


def default_agent_spec() -> str:
    """``DEFAULT_AGENT``, or ``BEST_HEURISTIC`` if that is the shipped PPO policy and
    none is shipped."""
    if DEFAULT_AGENT == "ppo" and not SHIPPED_POLICY.is_file():
        return BEST_HEURISTIC
    return DEFAULT_AGENT


def _policy_file(spec: str) -> Path | None:
    if spec == "ppo":
        return SHIPPED_POLICY
    if spec.startswith("ppo:"):
        from agents.learning.ppo_agent import resolve_policy_path

        return resolve_policy_path(spec[4:].strip())
    return None


def _trained_env(spec: str) -> tuple[dict[str, Any] | None, int | None]:
    """The env options and episode length a PPO policy was trained with, from the
    config YAML saved next to it; ``(None, None)`` otherwise."""
    file = _policy_file(spec)
    if file is None:
        return None, None
    cfg_file = file.with_suffix(".yaml")
    if not cfg_file.is_file():
        return None, None
    with open(cfg_file, encoding="utf-8") as fh:
        cfg = yaml.safe_load(fh) or {}
    if not isinstance(cfg, dict):
        return None, None
    return cfg.get("env_options") or {}, cfg.get("max_episode_steps")


@dataclass
class DemoResult:
    spec: str
    seed: int
    metrics: dict[str, float]
    files: dict[str, Path]


def write_gif(frames: list[np.ndarray], path: Path, fps: int = DEFAULT_GIF_FPS) -> None:
    """An endlessly looping GIF of (H, W, 3) uint8 frames."""
    import imageio.v3 as iio

    if not frames:
        raise ValueError("no frames to write")
    iio.imwrite(path, np.stack(frames), extension=".gif", duration=1000.0 / fps, loop=0)


def demo(
    agent_spec: str | None = None,
    seed: int = 0,
    out_dir: str | Path = "demo",
    *,
    gif: bool = True,
    max_steps: int | None = None,
    env_options: dict[str, Any] | None = None,
    gif_max_frames: int = DEFAULT_GIF_MAX_FRAMES,
    fps: int = DEFAULT_GIF_FPS,
    verbose: bool = True,
) -> DemoResult:
    """Run ``agent_spec`` (default :func:`default_agent_spec`) for one episode on the
    default world (``env_options`` overrides it; a PPO policy gets the options it was
    trained with unless they are given) from ``reset(seed=seed)``, write the GIF (unless
    ``gif=False``), the final map, the consistency plot and the metrics, print the
    metrics when ``verbose``."""
    spec = (agent_spec or default_agent_spec()).strip()
    check_count("seed", seed, 0)
    if gif_max_frames < 2:
        raise ValueError(f"gif_max_frames must be >= 2, got {gif_max_frames}")
    if env_options is None:
        trained_options, trained_steps = _trained_env(spec)
        env_options = trained_options
        if max_steps is None:
            max_steps = trained_steps

    check_episode_memory(max_steps, 1, "demo")
    env = make_env(env_options, max_steps, render_mode="rgb_array" if gif else None)
    try:
        agent = make_agent(spec, env, seed=seed)
        horizon = env.spec.max_episode_steps if env.spec is not None else None
        render_every = max(1, math.ceil((horizon or 500) / (gif_max_frames - 1))) if gif else 0
        record = run_episode(env, agent, seed, render_every=render_every, collect_detections=True)
    finally:
        env.close()

    from slam_env.belief.metrics import share_in_nees_band
    from slam_env.render.plots import plot_consistency, plot_episode

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    label = agent_label(spec)
    metrics = record.metrics()
    metrics["nees_in_band"] = share_in_nees_band([record.pose_nees], POSE_DOF, CONFIDENCE)
    files: dict[str, Path] = {}
    if gif:
        files["gif"] = out / "demo.gif"
        write_gif(record.frames, files["gif"], fps=fps)
    files["map_png"] = out / "final_map.png"
    title = (
        f"{label}, seed {seed}: {metrics['mapped_share']:.0%} mapped, "
        f"map RMSE {metrics['map_rmse']:.3f} m"
    )
    plot_episode(
        record.layout,
        record.true_poses,
        detections_world=record.detections_world,
        estimated_trajectory=record.est_poses,
        belief=record.belief,
        title=title,
        path=files["map_png"],
    ).clear()
    files["consistency_png"] = out / "demo_consistency.png"
    plot_consistency(
        {label: consistency_series([record])},
        files["consistency_png"],
        dof=POSE_DOF,
        confidence=CONFIDENCE,
        title=f"{label}, seed {seed}",
    ).clear()
    files["metrics_json"] = out / "demo_metrics.json"
    payload = {"agent": spec, "seed": seed, "env_options": env_options or {}, "metrics": metrics}
    files["metrics_json"].write_text(
        json.dumps(json_safe(payload), indent=2, allow_nan=False) + "\n"
    )
    result = DemoResult(spec, seed, metrics, files)
    if verbose:
        print_demo(result)
    return result


def print_demo(result: DemoResult, console: Any = None) -> None:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=f"demo: {agent_label(result.spec)}, seed {result.seed}")
    table.add_column("metric", style="bold")
    table.add_column("value", justify="right")
    table.add_column("meaning")
    for name, description in {**METRICS, **AGENT_METRICS}.items():
        value = result.metrics[name]
        shown = "–" if not math.isfinite(value) else f"{value:.4g}"
        table.add_row(name, shown, escape(description))
    console = console or Console()
    console.print(table)
    for name, path in result.files.items():
        console.print(f"{name}: {escape(str(path))}")
