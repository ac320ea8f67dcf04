"""Static matplotlib plots: an episode on its map, metrics over time, agents side by side.

No pyplot and no global state: every function builds a :class:`matplotlib.figure.Figure`
on an Agg canvas (headless), returns it, and writes a PNG when given a ``path``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from slam_env.belief.metrics import averaged_nees, nees_bands
from slam_env.belief.overlay import (
    ELLIPSE_FILL_ALPHA,
    LEGEND_LABELS,
    PALETTE,
    BeliefOverlay,
    ellipse_points,
)
from slam_env.extras import require
from slam_env.world.layouts import Layout

require("render", "slam_env.render.plots")  # one line, not matplotlib's traceback

from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Polygon, Rectangle  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

__all__ = [
    "draw_belief",
    "draw_world",
    "mean_and_band",
    "plot_consistency",
    "plot_episode",
    "plot_grouped_bars",
    "plot_metrics_over_time",
    "plot_trajectories_grid",
]


def _hex(rgb: tuple[int, int, int]) -> str:
    return "#{:02x}{:02x}{:02x}".format(*rgb)


#: The shared palette (:data:`slam_env.belief.overlay.PALETTE`) as matplotlib colours.
_COLORS = {name: _hex(rgb) for name, rgb in PALETTE.items()}
_ELLIPSE_EDGE_WIDTH = 1.6  # pt: a 95% ellipse shows even when it is small
_ROBOT_MARKER_PT = 9.0


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


def draw_world(
    ax: Any, layout: Layout, *, label_landmarks: bool = True, seen_ids: Any = None
) -> None:
    """Draw the arena, inner walls, obstacles and landmarks (with IDs) on ``ax``; with
    ``seen_ids``, the landmarks not among them are grey (never seen), as in the movie."""
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
            Polygon(
                pts,
                closed=True,
                facecolor=_COLORS["obstacle"],
                edgecolor=_COLORS["obstacle_edge"],
                zorder=1,
            )
        )
    for x0, y0, x1, y1 in layout.walls:
        ax.plot([x0, x1], [y0, y1], color=_COLORS["wall"], linewidth=2.5, solid_capstyle="round")
    lm = layout.landmark_array()
    if lm.shape[0]:
        seen = np.ones(lm.shape[0], dtype=bool)
        if seen_ids is not None:
            seen = np.isin(layout.id_array(), np.asarray(seen_ids, dtype=np.int64).reshape(-1))
        colors = np.where(seen, _COLORS["landmark_seen"], _COLORS["landmark"])
        ax.scatter(
            lm[:, 0],
            lm[:, 1],
            s=36,
            marker="o",
            c=list(colors),
            edgecolor=_COLORS["landmark_edge"],
            linewidths=0.6,
            zorder=3,
            label=LEGEND_LABELS["landmark"],
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
            _fill_ellipse(ax, e, _COLORS["belief_landmark"], zorder=5)
    if n:
        ok = np.all(np.isfinite(means[:n]), axis=1)
        ax.scatter(
            means[:n][ok, 0],
            means[:n][ok, 1],
            marker="x",
            s=30,
            color=_COLORS["belief_landmark"],
            zorder=6,
            label=LEGEND_LABELS["belief_landmark"],
        )
    pose = np.asarray(belief.pose, dtype=np.float64).reshape(3)
    pcov = np.asarray(belief.pose_cov, dtype=np.float64).reshape(3, 3)[:2, :2]
    if np.all(np.isfinite(pose)):
        if np.all(np.isfinite(pcov)):
            e = ellipse_points(pose[:2], pcov, 0.95, n=64)
            _fill_ellipse(ax, e, _COLORS["estimate"], zorder=6)
        _robot_marker(ax, pose, "estimate", label=LEGEND_LABELS["estimated_pose"])


def _fill_ellipse(ax: Any, points: np.ndarray, color: str, zorder: int) -> None:
    """A 95% ellipse as in the movie: a translucent fill inside an opaque edge."""
    ax.fill(
        points[:, 0],
        points[:, 1],
        facecolor=color,
        alpha=ELLIPSE_FILL_ALPHA,
        edgecolor="none",
        zorder=zorder,
    )
    closed = np.vstack([points, points[:1]])
    ax.plot(closed[:, 0], closed[:, 1], color=color, linewidth=_ELLIPSE_EDGE_WIDTH, zorder=zorder)


def _robot_marker(ax: Any, pose: np.ndarray, kind: str, label: str | None = None) -> None:
    """A robot as in the movie: the true one a blue disc, the estimated one a ring, each
    with a heading tick when the pose has a heading."""
    x, y = float(pose[0]), float(pose[1])
    color = _COLORS[kind]
    truth = kind == "truth"
    ax.plot(
        x,
        y,
        marker="o",
        markersize=_ROBOT_MARKER_PT,
        linestyle="none",
        markerfacecolor=color if truth else "none",
        markeredgecolor=_COLORS["truth_edge"] if truth else color,
        markeredgewidth=1.6,
        zorder=8 if truth else 9,
        label=label,
    )
    if pose.size >= 3 and math.isfinite(float(pose[2])):
        # The tick is drawn in points, so that it has the marker's size at any zoom.
        angle = float(pose[2])
        tick = _ROBOT_MARKER_PT * (0.5 if truth else 0.9)
        ax.annotate(
            "",
            xy=(x, y),
            xytext=(tick * math.cos(angle), tick * math.sin(angle)),
            textcoords="offset points",
            arrowprops={"arrowstyle": "-", "color": "black" if truth else color, "lw": 1.6},
            zorder=9,
        )


def _plot_path(ax: Any, traj: Any, kind: str, style: str, *, end_marker: bool = True) -> None:
    """A trajectory ((T, 2) or (T, 3)) in the colour of ``kind`` with a dot at its start
    and, when ``end_marker``, the robot's symbol at its end."""
    arr = np.asarray(traj, dtype=np.float64)
    if arr.size == 0:
        return
    arr = arr.reshape(arr.shape[0], -1)
    if arr.shape[1] < 2:
        raise ValueError(f"a trajectory needs (T, 2) or (T, 3) rows, got shape {arr.shape}")
    color = _COLORS[kind]
    ax.plot(
        arr[:, 0], arr[:, 1], style, color=color, linewidth=1.4, label=LEGEND_LABELS[kind], zorder=4
    )
    ax.plot(arr[0, 0], arr[0, 1], "o", color=color, markersize=4, zorder=4)
    end = arr[-1]
    if end_marker and np.all(np.isfinite(end)):
        _robot_marker(ax, end, kind)


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
    legend: bool = True,
    dpi: int = 120,
) -> Figure:
    """One episode on its map.

    Args:
        layout: the world (walls, obstacles, landmarks with IDs).
        trajectory: (T, 3) true poses (x, y, θ) (or (T, 2) positions).
        detections_world: world-frame detection points: an (M, 2) array or a list of
            per-step (k, 2) arrays; optional.
        estimated_trajectory: (T, 3) estimated poses, drawn dashed; optional.
        belief: the final belief, drawn with 95% ellipses; optional. Landmarks it
            lacks are drawn grey (never seen).
        title: the axes title.
        path: where to write a PNG; None writes nothing.
        ax: draw into this axes instead of a new figure.
        legend: add the figure's legend (below the map).
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
    draw_world(ax, layout, seen_ids=None if belief is None else belief.landmark_ids)
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
            label=LEGEND_LABELS["detection"],
        )
    _plot_path(ax, trajectory, "truth", "-")
    if estimated_trajectory is not None:
        # The belief, when given, draws the estimated pose with its ellipse.
        _plot_path(ax, estimated_trajectory, "estimate", "--", end_marker=belief is None)
    if belief is not None:
        draw_belief(ax, belief, layout)
    if title:
        ax.set_title(title, fontsize=10)
    if legend:
        _map_legend(fig, [ax])
    _save(fig, path, dpi)
    return fig


def _map_legend(fig: Figure, axes: Sequence[Any]) -> None:
    """One legend for the maps on ``axes`` (each label once), below them, so that it
    never hides landmarks in a corner."""
    entries: dict[str, Any] = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    if entries:
        fig.legend(
            list(entries.values()), list(entries), loc="outside lower center", ncol=3, fontsize=8
        )


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
    xlabel: str = "time [steps]",
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


def plot_consistency(
    series: Mapping[str, Mapping[str, Any]],
    path: str | Path | None = None,
    *,
    dof: int = 3,
    confidence: float = 0.95,
    title: str | None = None,
    dpi: int = 120,
) -> Figure:
    """Filter consistency over time, one line per agent: above, the pose NEES averaged
    over the episodes (log scale) inside its two-sided ``confidence`` χ² band for that
    many episodes (:func:`slam_env.belief.metrics.nees_band`; ``dof`` 3 for x, y, θ), with the
    expected value ``dof``; below, the map RMSE (mean ± std over the episodes).

    Args:
        series: ``{agent_name: {"pose_nees": episodes, "map_rmse": episodes}}``, each a
            list of per-episode (T_e,) arrays (step 0: the reset, left out of the NEES
            panel since its pose is exact) or an (E, T) array.
        path: where to write a PNG; None writes nothing.

    The band is shaded once when every agent averages the same number of episodes at
    every step, and drawn as dotted lines in each agent's colour otherwise.
    """
    if not series:
        raise ValueError("series is empty: nothing to plot")
    fig = _new_figure((7.0, 5.6))
    nees_ax, rmse_ax = fig.subplots(2, 1, sharex=True)
    bands = []
    for j, (agent, per_metric) in enumerate(series.items()):
        color = f"C{j % 10}"
        mean, runs = averaged_nees(_episodes(per_metric["pose_nees"]))
        t = np.arange(1, mean.size)
        nees_ax.plot(t, mean[1:], color=color, linewidth=1.3, label=agent)
        bands.append((color, runs[1:], nees_bands(dof, runs[1:], confidence)))
        rmse, half = mean_and_band(_episodes(per_metric["map_rmse"]), "std")
        t = np.arange(rmse.size)
        rmse_ax.plot(t, rmse, color=color, linewidth=1.3, label=agent)
        rmse_ax.fill_between(t, rmse - half, rmse + half, color=color, alpha=0.2, linewidth=0)
    share = f"{round(100 * confidence)}%"
    first_runs = bands[0][1]
    if all(np.array_equal(runs, first_runs) for _, runs, _ in bands):
        lower, upper = bands[0][2]
        n = int(first_runs.max(initial=0))
        nees_ax.fill_between(
            np.arange(1, lower.size + 1),
            lower,
            upper,
            color="0.6",
            alpha=0.3,
            linewidth=0,
            label=f"{share} χ² band for {n} episode{'s' if n != 1 else ''}",
        )
    else:
        for color, _, (lower, upper) in bands:
            t = np.arange(1, lower.size + 1)
            nees_ax.plot(t, lower, ":", color=color, linewidth=1.0)
            nees_ax.plot(t, upper, ":", color=color, linewidth=1.0)
        nees_ax.plot([], [], ":", color="0.4", label=f"{share} χ² band (per agent's episodes)")
    nees_ax.axhline(dof, color="black", linestyle="--", linewidth=0.8, label=f"expected ({dof})")
    nees_ax.set_yscale("log")
    nees_ax.yaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    nees_ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    nees_ax.yaxis.set_minor_formatter(NullFormatter())
    nees_ax.set_ylabel("mean pose NEES [–]")
    rmse_ax.set_ylabel("map RMSE [m] (mean ± std)")
    rmse_ax.set_xlabel("time [steps]")
    for ax in (nees_ax, rmse_ax):
        ax.grid(True, alpha=0.3)
    # Below the panels, so that it hides no data.
    fig.legend(*nees_ax.get_legend_handles_labels(), loc="outside lower center", ncol=4, fontsize=8)
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
        plot_episode(
            layout, traj, estimated_trajectory=est, belief=belief, title=name, ax=ax, legend=False
        )
    _map_legend(fig, axes[:n])
    for ax in axes[n:]:
        ax.set_axis_off()
    if title:
        fig.suptitle(title)
    _save(fig, path, dpi)
    return fig


def plot_grouped_bars(
    values: Mapping[str, Mapping[str, float]],
    path: str | Path | None = None,
    *,
    title: str = "",
    dpi: int = 110,
) -> Figure:
    """One group of bars per key of ``values`` (e.g. a suite's settings), one bar per
    inner key (e.g. the agents, in the order of the first group); a NaN is no bar."""
    groups = list(values)
    series = list(next(iter(values.values()), {}))
    fig = _new_figure((max(6.0, 0.9 * len(groups) * max(len(series), 1) ** 0.5 + 2.0), 3.6))
    ax = fig.add_subplot()
    width = 0.8 / max(len(series), 1)
    x = np.arange(len(groups))
    for k, name in enumerate(series):
        heights = [values[g].get(name, math.nan) for g in groups]
        ax.bar(x + (k - 0.5 * (len(series) - 1)) * width, heights, width, label=name)
    ax.set_xticks(x, groups, rotation=30, ha="right")
    ax.set_title(title)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize="small", ncols=max(len(series), 1))
    _save(fig, path, dpi)
    return fig
