"""Tests for slam_env.render.plots (matplotlib Agg, no pyplot)."""

from __future__ import annotations

import math

import imageio.v3 as iio
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from slam_env.belief.overlay import BeliefOverlay
from slam_env.render.plots import (
    mean_and_band,
    plot_episode,
    plot_metrics_over_time,
    plot_trajectories_grid,
)


@pytest.fixture
def trajectory() -> np.ndarray:
    t = np.linspace(0, 1, 40)
    return np.stack([1 + 6 * t, 1 + 5 * t**2, np.full_like(t, 0.6)], axis=1)


@pytest.fixture
def belief() -> BeliefOverlay:
    return BeliefOverlay(
        pose=np.array([7.1, 5.9, 0.6]),
        pose_cov=np.diag([0.05, 0.03, 0.01]),
        landmark_ids=np.array([0, 1]),
        landmark_means=np.array([[2.2, 1.8], [5.3, 6.2]]),
        landmark_covs=np.array([np.diag([0.04, 0.02]), np.zeros((2, 2))]),  # one singular
    )


def read_png(path) -> np.ndarray:
    assert path.exists() and path.stat().st_size > 1000
    return iio.imread(path)


def test_plot_episode_writes_png(layout, trajectory, belief, tmp_path):
    path = tmp_path / "sub" / "episode.png"
    dets = [np.array([[2.0, 2.1], [5.1, 5.9]]), np.zeros((0, 2)), np.array([[8.0, 3.0]])]
    fig = plot_episode(
        layout,
        trajectory,
        detections_world=dets,
        estimated_trajectory=trajectory + 0.1,
        belief=belief,
        title="ep 0",
        path=path,
        dpi=80,
    )
    assert isinstance(fig, Figure)
    img = read_png(path)
    w_in, h_in = fig.get_size_inches()
    assert img.shape[:2] == (round(h_in * 80), round(w_in * 80))
    assert img.shape[2] in (3, 4) and img.dtype == np.uint8
    ax = fig.axes[0]
    assert ax.get_title() == "ep 0"
    assert {t.get_text() for t in ax.texts} >= {"0", "1", "2"}  # landmark IDs
    labels = [h.get_label() for h in ax.get_legend_handles_labels()[0]]
    assert "true trajectory" in labels and "estimated trajectory" in labels
    assert "detections" in labels
    x_lo, x_hi = ax.get_xlim()
    assert x_lo < 0 < layout.width < x_hi


def test_belief_changes_the_plot(layout, trajectory, belief, tmp_path):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    plot_episode(layout, trajectory, path=a, dpi=60)
    plot_episode(layout, trajectory, belief=belief, path=b, dpi=60)
    ia, ib = read_png(a), read_png(b)
    assert ia.shape == ib.shape
    assert np.any(ia != ib)


def test_plot_episode_without_path_into_given_axes(layout, trajectory):
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    out = plot_episode(layout, trajectory[:, :2], detections_world=np.zeros((0, 2)), ax=ax)
    assert out is fig
    assert len(ax.lines) >= 2  # inner wall + trajectory


def test_mean_and_band_ragged():
    mean, half = mean_and_band([np.array([1.0, 2.0, 3.0]), np.array([3.0, 4.0])], "std")
    np.testing.assert_allclose(mean, [2.0, 3.0, 3.0])
    np.testing.assert_allclose(half, [1.0, 1.0, 0.0])
    _, sem = mean_and_band([[1.0, 2.0], [3.0, 4.0]], "sem")
    np.testing.assert_allclose(sem, [1.0 / math.sqrt(2)] * 2)
    mean, _ = mean_and_band([[np.nan, 1.0], [2.0, 3.0]])
    np.testing.assert_allclose(mean, [2.0, 2.0])
    with pytest.raises(ValueError):
        mean_and_band([[1.0]], "iqr")


def test_plot_metrics_over_time(tmp_path):
    rng = np.random.default_rng(0)
    series = {
        "random": {
            "pose_error": [rng.random(50), rng.random(40)],
            "landmarks_seen": np.cumsum(rng.random((3, 50)), axis=1),
        },
        "frontier": {"pose_error": rng.random(50)},
    }
    path = tmp_path / "metrics.png"
    fig = plot_metrics_over_time(series, path, title="eval")
    img = read_png(path)
    assert img.ndim == 3 and img.shape[2] in (3, 4)
    assert len(fig.axes) == 2
    assert [ax.get_ylabel() for ax in fig.axes] == ["pose_error", "landmarks_seen"]
    pose_ax, seen_ax = fig.axes
    assert [ln.get_label() for ln in pose_ax.lines] == ["random", "frontier"]
    assert [ln.get_label() for ln in seen_ax.lines] == ["random"]
    mean_line = seen_ax.lines[0].get_ydata()
    np.testing.assert_allclose(mean_line, series["random"]["landmarks_seen"].mean(axis=0))
    assert len(pose_ax.collections) == 2  # one band per agent


def test_plot_metrics_rejects_empty():
    with pytest.raises(ValueError):
        plot_metrics_over_time({})


def test_plot_trajectories_grid(layout, trajectory, belief, tmp_path):
    per_agent = {
        "random": (layout, trajectory, None),
        "frontier": (layout, trajectory[::-1], belief),
        "ppo": (layout, trajectory, belief, trajectory + 0.05),
        "greedy": (layout, trajectory, None),
    }
    path = tmp_path / "grid.png"
    fig = plot_trajectories_grid(per_agent, path, ncols=2, dpi=50)
    img = read_png(path)
    w_in, h_in = fig.get_size_inches()
    assert img.shape[:2] == (round(h_in * 50), round(w_in * 50))
    assert [ax.get_title() for ax in fig.axes] == list(per_agent)
    with pytest.raises(ValueError):
        plot_trajectories_grid({"bad": (layout, trajectory)})


def test_grid_hides_spare_panels(layout, trajectory):
    fig = plot_trajectories_grid({n: (layout, trajectory, None) for n in "abcd"})
    assert len(fig.axes) == 6  # 2 x 3
    assert sum(ax.axison for ax in fig.axes) == 4
