"""The movie's frame (estimated path, strip of figures and legend) and the same colours
and symbols in the movie and the plots."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from matplotlib.colors import to_hex

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.belief.overlay import ELLIPSE_FILL_ALPHA, LEGEND_LABELS, BeliefOverlay
from slam_env.render.plots import plot_episode
from slam_env.render.renderer import COLORS, Frame, Renderer

FOV = 2.0 * math.pi / 3.0


def belief(**kw) -> BeliefOverlay:
    fields = dict(
        pose=np.array([8.0, 6.0, 0.0]),
        pose_cov=np.diag([0.04, 0.02, 0.01]),
        landmark_ids=np.array([0, 1]),
        landmark_means=np.array([[2.3, 1.7], [5.4, 6.3]]),
        landmark_covs=np.array([np.diag([0.05, 0.02]), np.diag([0.08, 0.08])]),
    )
    fields.update(kw)
    return BeliefOverlay(**fields)


@pytest.fixture
def renderer(layout):
    r = Renderer(layout, robot_radius=0.25, max_range=2.0, fov=FOV, render_mode="rgb_array")
    yield r
    r.close()


def has_color(pixels: np.ndarray, color) -> bool:
    return bool(np.any(np.all(pixels.reshape(-1, 3) == np.array(color), axis=1)))


def test_the_estimated_path_is_drawn_dashed(renderer):
    path = np.stack([np.linspace(1.0, 9.0, 80), np.full(80, 7.0)], axis=1)
    img = renderer.render(Frame(pose=(1.0, 1.0, -1.0), belief=belief(trail=path)))
    row = round(float(renderer.world_to_pixel((0.0, 7.0))[1]))
    c0, c1 = renderer.world_to_pixel([(1.5, 7.0), (8.5, 7.0)])[:, 0].round().astype(int)
    line = img[row, c0:c1]
    on = np.all(line == COLORS["belief_pose"], axis=1)
    assert 0.3 < on.mean() < 0.9  # dashes and gaps
    assert np.count_nonzero(np.diff(on.astype(int)) == 1) >= 10  # many dashes


def test_the_strip_shows_the_step_and_the_live_figures(renderer):
    h_map = renderer.map_height_px
    frame = Frame(pose=(1.0, 1.0, 0.0), step=3, belief=belief(figures={"entropy": 1.0}))
    a = renderer.render(frame)
    frame.step = 4
    b = renderer.render(frame)
    frame.belief.figures = {"entropy": 2.0, "map_rmse": 0.1, "pose_nees": math.nan}
    c = renderer.render(frame)
    np.testing.assert_array_equal(a[:h_map], b[:h_map])  # the map is the same...
    assert np.any(a[h_map:] != b[h_map:])  # ...the step counter is not
    assert np.any(b[h_map:] != c[h_map:])  # nor are the figures
    assert renderer.height_px - h_map - renderer.strip_px in (0, 1)  # 1: rounded to even


def test_the_legend_shows_every_symbol_in_its_colour(renderer):
    strip = renderer.render(Frame(pose=(1.0, 1.0, 0.0)))[renderer.map_height_px :]
    for name in ("robot", "belief_pose", "landmark", "landmark_seen", "belief_landmark", "ray"):
        assert has_color(strip, COLORS[name]), name
    assert has_color(strip, COLORS["fov"])  # the visible region's glyph


def test_ellipses_are_filled_and_outlined_in_the_movie(renderer):
    frame = Frame(pose=(1.0, 1.0, -1.0))
    plain = renderer.render(frame)
    frame.belief = belief(landmark_covs=np.array([np.diag([0.05, 0.02]), np.diag([0.3, 0.3])]))
    img = renderer.render(frame)
    # Inside landmark 1's 95% ellipse (radius √(5.99 · 0.3) ≈ 1.3 m), off its cross.
    c, r = renderer.world_to_pixel((5.4 + 0.8, 6.3)).round().astype(int)
    assert np.any(img[r, c] != plain[r, c])  # tinted
    edge = renderer.world_to_pixel((5.4 + math.sqrt(5.991 * 0.3), 6.3)).round().astype(int)
    near = img[edge[1] - 2 : edge[1] + 3, edge[0] - 2 : edge[0] + 3]
    assert has_color(near, COLORS["belief_landmark"])


def test_active_slam_renders_its_estimated_path_and_figures():
    env = gym.make("slam_env/ActiveSLAM-v0", render_mode="rgb_array", n_landmarks=6)
    env.reset(seed=2)
    for _ in range(5):
        _, _, _, _, info = env.step(np.array([1.0, 0.3], dtype=np.float32))
    img = env.render()
    unwrapped = env.unwrapped
    frame = unwrapped.render_frame()
    overlay = frame.belief
    assert overlay.trail.shape == (6, 2)  # the reset and five steps
    np.testing.assert_array_equal(overlay.trail[-1], unwrapped.filter.pose[:2])
    assert overlay.figures == {
        k: info[k] for k in ("entropy", "map_rmse", "pose_nees") if k in info
    }
    assert "entropy" in overlay.figures and "pose_nees" in overlay.figures
    assert frame.step == 5 and frame.visible_region.shape[1] == 2
    assert frame.trail.shape == (6, 2)  # the true path beside it
    assert img.shape == unwrapped._renderer.shape
    env.reset(seed=3)
    assert unwrapped.render_frame().belief.trail.shape == (1, 2)  # a new episode
    env.close()


def test_the_plots_use_the_movie_colours_and_words(layout):
    trajectory = np.array([[1.0, 1.0, 0.0], [3.0, 2.0, 0.5], [5.0, 4.0, 1.0]])
    fig = plot_episode(layout, trajectory, np.array([[2.0, 2.0]]), trajectory + 0.1, belief())
    ax = fig.axes[0]
    by_label = dict(zip(*reversed(ax.get_legend_handles_labels()), strict=True))
    assert to_hex(by_label[LEGEND_LABELS["truth"]].get_color()) == to_hex(
        np.array(COLORS["trail"]) / 255
    )
    assert to_hex(by_label[LEGEND_LABELS["estimate"]].get_color()) == to_hex(
        np.array(COLORS["belief_pose"]) / 255
    )
    estimates = by_label[LEGEND_LABELS["belief_landmark"]]
    assert to_hex(estimates.get_facecolor()[0]) == to_hex(np.array(COLORS["belief_landmark"]) / 255)
    landmarks = by_label[LEGEND_LABELS["landmark"]].get_facecolor()
    # Landmarks 0 and 1 are in the belief (seen), landmark 2 is not: grey, as in the movie.
    expected = [COLORS["landmark_seen"], COLORS["landmark_seen"], COLORS["landmark"]]
    assert [to_hex(c) for c in landmarks] == [to_hex(np.array(c) / 255) for c in expected]
    # The 95% ellipses: a translucent fill and an opaque edge line.
    fills = [p for p in ax.patches if p.get_alpha() == ELLIPSE_FILL_ALPHA]
    assert len(fills) == 3  # two landmarks and the pose
    assert all(ax.get_xlabel().endswith("[m]") for ax in fig.axes)
