"""Static matplotlib plots: an episode on its map, metrics over time, agents side by side.

No pyplot and no global state: every function builds a :class:`matplotlib.figure.Figure`
on an Agg canvas (headless), returns it, and writes a PNG when given a ``path``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Polygon, Rectangle

from slam_env.layouts import Layout
from slam_env.overlay import BeliefOverlay, ellipse_points

__all__ = [
    "draw_belief",
    "draw_world",
    "mean_and_band",
    "plot_episode",
    "plot_metrics_over_time",
    "plot_trajectories_grid",
]

_COLORS = {
    "floor": "#fafaf6",
    "wall": "#2d2d2d",
    "obstacle": "#808080",
    "landmark": "#eb9614",
    "truth": "#1f5fd0",
    "estimate": "#be1ea0",
    "belief_landmark": "#7828c8",
    "truth_link": "#9b7dc0",
    "detection": "#1eaa3c",
}


def _new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, layout="constrained")
    fig.get_layout_engine().set(h_pad=0.1)  # room above the title
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: str | Path | None, dpi: int) -> None:
    if path is None:
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)


def _points(data: Any) -> np.ndarray:
    """(M, 2) finite points from an (M, 2) array or a list of (k, 2) arrays / points."""
    if data is None:
        return np.zeros((0, 2))
    if isinstance(data, np.ndarray):
        arr = data.astype(np.float64).reshape(-1, 2)
    else:
        parts = [np.asarray(d, dtype=np.float64).reshape(-1, 2) for d in data]
        arr = np.concatenate(parts, axis=0) if parts else np.zeros((0, 2))
    return arr[np.all(np.isfinite(arr), axis=1)]


def draw_world(ax: Any, layout: Layout, *, label_landmarks: bool = True) -> None:
    """Draw the arena, inner walls, obstacles and landmarks (with IDs) on ``ax``."""
    ax.add_patch(
        Rectangle(
            (0.0, 0.0),
            layout.width,
            layout.height,
            facecolor=_COLORS["floor"],
            edgecolor=_COLORS["wall"],
            linewidth=2.5,
            zorder=0,
        )
    )
    for poly in layout.obstacles:
        pts = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
        ax.add_patch(
            Polygon(pts, closed=True, facecolor=_COLORS["obstacle"], edgecolor="#464646", zorder=1)
        )
    for x0, y0, x1, y1 in layout.walls:
        ax.plot([x0, x1], [y0, y1], color=_COLORS["wall"], linewidth=2.5, solid_capstyle="round")
    lm = layout.landmark_array()
    if lm.shape[0]:
        ax.scatter(
            lm[:, 0],
            lm[:, 1],
            s=36,
            marker="o",
            facecolor=_COLORS["landmark"],
            edgecolor="black",
            linewidths=0.6,
            zorder=3,
            label="landmarks",
        )
        if label_landmarks:
            for i, (x, y) in zip(layout.landmark_ids, lm, strict=True):
                ax.annotate(
                    str(i),
                    (x, y),
                    xytext=(3, 3),
                    textcoords="offset points",
                    fontsize=7,
                    zorder=4,
                )
    pad = 0.03 * max(layout.width, layout.height)
    ax.set_xlim(-pad, layout.width + pad)
    ax.set_ylim(-pad, layout.height + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def draw_belief(ax: Any, belief: BeliefOverlay, layout: Layout | None = None) -> None:
    """Draw a belief: estimated pose with its 95% position ellipse, each estimated
    landmark with its 95% ellipse and a thin line to its true position (from
    ``belief.true_landmarks``, else from ``layout``)."""
    ids = np.asarray(belief.landmark_ids).reshape(-1)
    means = np.asarray(belief.landmark_means, dtype=np.float64).reshape(-1, 2)
    covs = np.asarray(belief.landmark_covs, dtype=np.float64).reshape(-1, 2, 2)
    n = min(ids.size, means.shape[0], covs.shape[0])
    if layout is not None:
        truth = belief.truth_for(layout.id_array(), layout.landmark_array())
    else:
        truth = belief.truth_for()
    for k in range(n):
        m = means[k]
        if not np.all(np.isfinite(m)):
            continue
        if np.all(np.isfinite(truth[k])):
            ax.plot(
                [m[0], truth[k, 0]],
                [m[1], truth[k, 1]],
                color=_COLORS["truth_link"],
                linewidth=0.8,
                zorder=5,
            )
        if np.all(np.isfinite(covs[k])):
            e = ellipse_points(m, covs[k], 0.95, n=64)
            ax.fill(
                e[:, 0],
                e[:, 1],
                facecolor=_COLORS["belief_landmark"],
                alpha=0.15,
                edgecolor=_COLORS["belief_landmark"],
                linewidth=0.9,
                zorder=5,
            )
    if n:
        ok = np.all(np.isfinite(means[:n]), axis=1)
        ax.scatter(
            means[:n][ok, 0],
            means[:n][ok, 1],
            marker="x",
            s=30,
            color=_COLORS["belief_landmark"],
            zorder=6,
            label="landmark estimates (95%)",
        )
    pose = np.asarray(belief.pose, dtype=np.float64).reshape(3)
    pcov = np.asarray(belief.pose_cov, dtype=np.float64).reshape(3, 3)[:2, :2]
    if np.all(np.isfinite(pose)):
        if np.all(np.isfinite(pcov)):
            e = ellipse_points(pose[:2], pcov, 0.95, n=64)
            ax.fill(
                e[:, 0],
                e[:, 1],
                facecolor=_COLORS["estimate"],
                alpha=0.15,
                edgecolor=_COLORS["estimate"],
                linewidth=1.0,
                zorder=6,
            )
        ax.plot(
            pose[0],
            pose[1],
            marker="D",
            markersize=5,
            color=_COLORS["estimate"],
            linestyle="none",
            zorder=7,
            label="estimated pose (95%)",
        )


def _plot_path(ax: Any, traj: Any, color: str, label: str, style: str) -> None:
    arr = np.asarray(traj, dtype=np.float64)
    if arr.size == 0:
        return
    arr = arr.reshape(arr.shape[0], -1)
    if arr.shape[1] < 2:
        raise ValueError(f"a trajectory needs (T, 2) or (T, 3) rows, got shape {arr.shape}")
    ax.plot(arr[:, 0], arr[:, 1], style, color=color, linewidth=1.4, label=label, zorder=4)
    ax.plot(arr[0, 0], arr[0, 1], "o", color=color, markersize=5, zorder=4)
    end = arr[-1]
    if arr.shape[1] >= 3 and np.all(np.isfinite(end[:3])):
        ax.plot(
            end[0],
            end[1],
            marker=(3, 0, np.degrees(end[2]) - 90.0),
            markersize=9,
            color=color,
            zorder=4,
        )


def plot_episode(
    layout: Layout,
    trajectory: Any,
    detections_world: Any = None,
    estimated_trajectory: Any = None,
    belief: BeliefOverlay | None = None,
    title: str = "",
    path: str | Path | None = None,
    ax: Any = None,
    *,
    dpi: int = 120,
) -> Figure:
    """One episode on its map.

    Args:
        layout: the world (walls, obstacles, landmarks with IDs).
        trajectory: (T, 3) true poses (x, y, θ) (or (T, 2) positions).
        detections_world: world-frame detection points: an (M, 2) array or a list of
            per-step (k, 2) arrays; optional.
        estimated_trajectory: (T, 3) estimated poses, drawn dashed; optional.
        belief: the final belief, drawn with 95% ellipses; optional.
        title: the axes title.
        path: where to write a PNG; None writes nothing.
        ax: draw into this axes instead of a new figure.
        dpi: resolution of the PNG.

    Returns:
        The figure (``ax.figure`` when ``ax`` is given).
    """
    if ax is None:
        aspect = layout.height / layout.width
        fig = _new_figure((6.0, max(2.5, min(12.0, 6.0 * aspect)) + 0.4))
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    draw_world(ax, layout)
    pts = _points(detections_world)
    if pts.shape[0]:
        ax.scatter(
            pts[:, 0],
            pts[:, 1],
            s=6,
            color=_COLORS["detection"],
            alpha=0.5,
            linewidths=0,
            zorder=2,
            label="detections",
        )
    _plot_path(ax, trajectory, _COLORS["truth"], "true trajectory", "-")
    if estimated_trajectory is not None:
        _plot_path(ax, estimated_trajectory, _COLORS["estimate"], "estimated trajectory", "--")
    if belief is not None:
        draw_belief(ax, belief, layout)
    if title:
        ax.set_title(title, fontsize=10)
    # Below the map, so that it never hides landmarks in a corner.
    ax.figure.legend(
        *ax.get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=7
    )
    _save(fig, path, dpi)
    return fig


def _episodes(values: Any) -> list[np.ndarray]:
    """A metric's data as a list of 1-D per-episode arrays."""
    if isinstance(values, np.ndarray):
        if values.ndim <= 1:
            return [values.astype(np.float64).reshape(-1)]
        return [row.astype(np.float64).reshape(-1) for row in values.reshape(values.shape[0], -1)]
    values = list(values)
    if values and all(np.ndim(v) == 0 for v in values):  # a plain list of numbers
        return [np.asarray(values, dtype=np.float64)]
    return [np.asarray(v, dtype=np.float64).reshape(-1) for v in values]


def mean_and_band(episodes: Sequence[Any], band: str = "std") -> tuple[np.ndarray, np.ndarray]:
    """Per-step mean and band half-width across episodes of possibly different lengths
    (a step averages the episodes that reached it; NaNs are ignored).

    ``band``: ``"std"`` (standard deviation), ``"sem"`` (standard error) or ``"none"``.
    Returns two (T_max,) arrays.
    """
    if band not in ("std", "sem", "none"):
        raise ValueError(f"band must be 'std', 'sem' or 'none', got {band!r}")
    eps = [np.asarray(e, dtype=np.float64).reshape(-1) for e in episodes]
    t_max = max((e.size for e in eps), default=0)
    data = np.full((len(eps), t_max), np.nan)
    for i, e in enumerate(eps):
        data[i, : e.size] = e
    valid = np.isfinite(data)
    count = valid.sum(axis=0)
    filled = np.where(valid, data, 0.0)
    safe = np.maximum(count, 1)
    mean = np.where(count > 0, filled.sum(axis=0) / safe, np.nan)
    dev = np.where(valid, data - mean, 0.0)
    std = np.where(count > 0, np.sqrt((dev**2).sum(axis=0) / safe), np.nan)
    if band == "std":
        half = std
    elif band == "sem":
        half = np.where(count > 0, std / np.sqrt(safe), np.nan)
    else:
        half = np.zeros_like(mean)
    return mean, half


def plot_metrics_over_time(
    series: Mapping[str, Mapping[str, Any]],
    path: str | Path | None = None,
    *,
    title: str | None = None,
    band: str = "std",
    xlabel: str = "step",
    dpi: int = 120,
) -> Figure:
    """Metrics over time, one subplot per metric, one line per agent: the mean across
    episodes with a shaded ± ``band`` (``"std"``, ``"sem"`` or ``"none"``).

    Args:
        series: ``{agent_name: {metric_name: data}}``; ``data`` is one (T,) array, an
            (E, T) array, or a list of per-episode (T_e,) arrays (lengths may differ).
        path: where to write a PNG; None writes nothing.
    """
    if not series:
        raise ValueError("series is empty: nothing to plot")
    metrics: list[str] = []
    for per_metric in series.values():
        for name in per_metric:
            if name not in metrics:
                metrics.append(name)
    if not metrics:
        raise ValueError("no metric in series")
    fig = _new_figure((7.0, 2.2 * len(metrics) + 0.6))
    axes = fig.subplots(len(metrics), 1, sharex=True, squeeze=False)[:, 0]
    for j, (agent, per_metric) in enumerate(series.items()):
        color = f"C{j % 10}"
        for ax, name in zip(axes, metrics, strict=True):
            if name not in per_metric:
                continue
            mean, half = mean_and_band(_episodes(per_metric[name]), band)
            t = np.arange(mean.size)
            ax.plot(t, mean, color=color, linewidth=1.5, label=agent)
            if band != "none" and mean.size:
                ax.fill_between(t, mean - half, mean + half, color=color, alpha=0.2, linewidth=0)
    for ax, name in zip(axes, metrics, strict=True):
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    axes[0].legend(fontsize=7, loc="best")
    if title:
        fig.suptitle(title)
    _save(fig, path, dpi)
    return fig


def plot_trajectories_grid(
    per_agent: Mapping[str, Sequence[Any]],
    path: str | Path | None = None,
    *,
    ncols: int | None = None,
    title: str | None = None,
    dpi: int = 120,
) -> Figure:
    """One panel per agent: its world, its true trajectory and its final belief.

    Args:
        per_agent: ``{agent_name: (layout, trajectory, belief_or_None)}``; an optional
            4th item is the estimated trajectory.
        path: where to write a PNG; None writes nothing.
        ncols: panels per row (default: up to 3).
    """
    if not per_agent:
        raise ValueError("per_agent is empty: nothing to plot")
    n = len(per_agent)
    ncols = min(n, 3) if ncols is None else max(1, int(ncols))
    nrows = -(-n // ncols)
    fig = _new_figure((4.2 * ncols, 4.0 * nrows + 0.4))
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax, (name, item) in zip(axes, per_agent.items(), strict=False):
        if len(item) not in (3, 4):
            raise ValueError(
                f"per_agent[{name!r}] must be (layout, trajectory, belief[, estimated]),"
                f" got {len(item)} items"
            )
        layout, traj, belief = item[0], item[1], item[2]
        est = item[3] if len(item) == 4 else None
        plot_episode(layout, traj, estimated_trajectory=est, belief=belief, title=name, ax=ax)
    for ax in axes[n:]:
        ax.set_axis_off()
    if title:
        fig.suptitle(title)
    _save(fig, path, dpi)
    return fig
