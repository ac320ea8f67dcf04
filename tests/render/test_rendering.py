"""Tests for slam_env.render.renderer (pygame, headless) and slam_env.belief.overlay."""

from __future__ import annotations

import math
import os
import pickle
import subprocess
import sys

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import numpy as np
import pytest

from slam_env.belief.overlay import CHI2_2DOF_95, chi2_radius2, ellipses_points
from slam_env.render.renderer import COLORS, BeliefOverlay, Frame, Renderer, ellipse_points
from slam_env.world.layouts import Layout

FOV = 2.0 * math.pi / 3.0


@pytest.fixture
def renderer(layout):
    r = Renderer(layout, robot_radius=0.25, max_range=5.0, fov=FOV, render_mode="rgb_array")
    yield r
    r.close()


def make_frame(pose=(1.0, 1.0, 0.0), **kw) -> Frame:
    defaults = dict(
        trail=np.array([[1.0, 1.0], [1.0, 1.0]]),
        detections_world=np.zeros((0, 2)),
        detected_ids=np.zeros(0, dtype=np.int64),
        seen_mask=np.zeros(3, dtype=bool),
        collision=False,
    )
    defaults.update(kw)
    return Frame(pose=pose, **defaults)


def make_belief(**kw) -> BeliefOverlay:
    defaults = dict(
        pose=np.array([3.2, 3.1, 0.3]),
        pose_cov=np.diag([0.04, 0.02, 0.01]),
        landmark_ids=np.array([0, 1]),
        landmark_means=np.array([[2.3, 1.7], [5.4, 6.3]]),
        landmark_covs=np.array([np.diag([0.05, 0.02]), [[0.1, 0.04], [0.04, 0.08]]]),
        true_landmarks={0: (2.0, 2.0), 1: (5.0, 6.0)},
    )
    defaults.update(kw)
    return BeliefOverlay(**defaults)


def pixel(img: np.ndarray, rc: np.ndarray) -> tuple[int, int, int]:
    col, row = np.rint(rc).astype(int)
    return tuple(int(v) for v in img[row, col])


# --------------------------------------------------------------------------- ellipses
def test_chi2_radius_95_and_k_sigma():
    assert chi2_radius2(0.95) == pytest.approx(5.991, abs=1e-3)
    assert chi2_radius2(0.95) == pytest.approx(CHI2_2DOF_95)
    assert chi2_radius2(2) == pytest.approx(4.0)
    with pytest.raises(ValueError):
        chi2_radius2(0.0)


def test_ellipse_points_diagonal_cov_semi_axes():
    mean = np.array([1.0, -2.0])
    sx2, sy2 = 0.09, 0.01
    pts = ellipse_points(mean, np.diag([sx2, sy2]), 0.95, n=32)
    assert pts.shape == (32, 2)
    d = pts - mean
    assert np.max(np.abs(d[:, 0])) == pytest.approx(math.sqrt(5.991 * sx2), rel=1e-3)
    assert np.max(np.abs(d[:, 1])) == pytest.approx(math.sqrt(5.991 * sy2), rel=1e-3)
    np.testing.assert_allclose(d.mean(axis=0), 0.0, atol=1e-12)  # centred on the mean


def test_ellipse_points_lie_on_the_mahalanobis_contour():
    cov = np.array([[0.5, 0.3], [0.3, 0.4]])
    mean = np.array([3.0, 4.0])
    pts = ellipse_points(mean, cov, 0.95, n=50)
    d = pts - mean
    m2 = np.einsum("ni,ij,nj->n", d, np.linalg.inv(cov), d)
    np.testing.assert_allclose(m2, chi2_radius2(0.95), rtol=1e-9)
    # A k-sigma ellipse: radius² = k².
    d3 = ellipse_points(mean, cov, 3, n=20) - mean
    np.testing.assert_allclose(np.einsum("ni,ij,nj->n", d3, np.linalg.inv(cov), d3), 9.0)


@pytest.mark.parametrize(
    "cov",
    [
        np.zeros((2, 2)),
        np.array([[1.0, 1.0], [1.0, 1.0]]),  # rank 1
        np.array([[1.0, 1.0 + 1e-9], [1.0 + 1e-9, 1.0]]),  # slightly indefinite
        np.array([[0.2, 0.0], [0.1, 0.3]]),  # not symmetric
    ],
)
def test_ellipse_points_singular_or_psd_cov(cov):
    pts = ellipse_points(np.array([1.0, 2.0]), cov, 0.95, n=16)
    assert pts.shape == (16, 2)
    assert np.all(np.isfinite(pts))


def test_ellipse_points_symmetrises_the_cov():
    cov = np.array([[0.2, 0.0], [0.1, 0.3]])
    sym = 0.5 * (cov + cov.T)
    np.testing.assert_allclose(
        ellipse_points(np.zeros(2), cov, n=12), ellipse_points(np.zeros(2), sym, n=12)
    )


def test_ellipse_points_rank_one_is_a_segment():
    pts = ellipse_points(np.zeros(2), np.array([[1.0, 1.0], [1.0, 1.0]]), 0.95, n=16)
    np.testing.assert_allclose(pts[:, 0], pts[:, 1], atol=1e-9)  # along the (1, 1) axis
    half_len = math.sqrt(5.991 * 2.0)  # the eigenvalue along (1, 1) is 2
    assert np.max(np.linalg.norm(pts, axis=1)) == pytest.approx(half_len, rel=1e-3)


def test_ellipses_points_batch_matches_single():
    means = np.array([[0.0, 0.0], [1.0, 2.0], [3.0, 1.0]])
    covs = np.array([np.diag([0.1, 0.2]), [[0.5, 0.3], [0.3, 0.4]], np.full((2, 2), np.nan)])
    batch = ellipses_points(means, covs, 0.95, n=10)
    assert batch.shape == (3, 10, 2)
    for k in range(3):
        np.testing.assert_allclose(batch[k], ellipse_points(means[k], covs[k], 0.95, n=10))
    with pytest.raises(ValueError):
        ellipses_points(means, covs[:2])


def test_ellipse_points_non_finite_cov_collapses_to_mean():
    pts = ellipse_points(np.array([1.0, 2.0]), np.full((2, 2), np.nan), n=8)
    np.testing.assert_array_equal(pts, np.tile([1.0, 2.0], (8, 1)))


def test_belief_overlay_from_state():
    mean = np.array([1.0, 2.0, 0.1, 3.0, 4.0, 5.0, 6.0])
    cov = np.arange(49, dtype=float).reshape(7, 7)
    b = BeliefOverlay.from_state(mean, cov, [7, 3])
    np.testing.assert_array_equal(b.landmark_ids, [7, 3])
    np.testing.assert_array_equal(b.landmark_means, [[3.0, 4.0], [5.0, 6.0]])
    np.testing.assert_array_equal(b.landmark_covs[1], cov[5:7, 5:7])
    np.testing.assert_array_equal(b.pose_cov, cov[:3, :3])
    with pytest.raises(ValueError):
        BeliefOverlay.from_state(mean, cov, [7])


def test_belief_truth_lookup():
    b = make_belief(true_landmarks=None)
    np.testing.assert_array_equal(b.truth_for([1, 0], [[5, 6], [2, 2]]), [[2, 2], [5, 6]])
    assert np.all(np.isnan(b.truth_for()))
    b = make_belief(true_landmarks=np.array([[9.0, 9.0], [8.0, 8.0]]))  # rows follow ids
    np.testing.assert_array_equal(b.truth_for(), [[9, 9], [8, 8]])
    b = make_belief(true_landmarks={1: (4.0, 4.0)})
    t = b.truth_for()
    assert np.all(np.isnan(t[0])) and tuple(t[1]) == (4.0, 4.0)


# --------------------------------------------------------------------------- rgb_array
def test_rgb_array_shape_dtype_constant_and_fresh(renderer):
    a = renderer.render(make_frame((1.0, 1.0, 0.0)))
    b = renderer.render(make_frame((7.0, 6.0, 2.0), trail=np.array([[1, 1], [3, 4], [7, 6]])))
    assert a.dtype == np.uint8 and a.ndim == 3 and a.shape[2] == 3
    assert a.shape == b.shape == renderer.shape
    assert max(a.shape[:2]) == 600  # window_px is the longer side
    assert a.shape[1] > a.shape[0]  # a 10 x 8 world is wider than tall
    assert len(np.unique(a.reshape(-1, 3), axis=0)) > 5  # not one colour
    assert not np.array_equal(a, b)  # the robot moved
    assert not np.shares_memory(a, b)
    a_copy = a.copy()
    a[:] = 0  # the renderer must not hand out its own buffer
    np.testing.assert_array_equal(renderer.render(make_frame((1.0, 1.0, 0.0))), a_copy)


def test_robot_is_drawn_where_the_transform_says(renderer, layout):
    pose = (3.0, 5.0, 0.0)
    img = renderer.render(make_frame(pose))
    # Sample behind the centre (the heading line points to +x).
    behind = renderer.world_to_pixel((pose[0] - 0.12, pose[1]))
    assert pixel(img, behind) == COLORS["robot"]
    # Elsewhere the robot colour does not appear at that pixel.
    img2 = renderer.render(make_frame((8.0, 1.0, 0.0)))
    assert pixel(img2, behind) != COLORS["robot"]
    # A collision repaints it.
    img3 = renderer.render(make_frame(pose, collision=True))
    assert pixel(img3, behind) == COLORS["robot_collision"]


def test_transform_keeps_aspect_margin_and_y_up(renderer, layout):
    h, w, _ = renderer.shape
    p0 = renderer.world_to_pixel((0.0, 0.0))
    p1 = renderer.world_to_pixel((layout.width, layout.height))
    assert p0[1] > p1[1]  # y up: the top of the world is the top of the image
    assert 0 < p0[0] < p1[0] < w and 0 < p1[1] < p0[1] < h  # a margin all round
    sx = (p1[0] - p0[0]) / layout.width
    sy = (p0[1] - p1[1]) / layout.height
    assert sx == pytest.approx(sy)  # aspect ratio kept
    np.testing.assert_allclose(
        renderer.world_to_pixel(np.array([[0.0, 0.0], [10.0, 8.0]])), [p0, p1]
    )


def test_seen_landmarks_are_highlighted(renderer, layout):
    lm = renderer.world_to_pixel(layout.landmark_array())
    frame_pose = (9.0, 7.0, math.pi)  # sensor wedge well away from landmark 0
    unseen = renderer.render(make_frame(frame_pose))
    seen = renderer.render(make_frame(frame_pose, seen_mask=np.array([True, False, False])))
    assert pixel(unseen, lm[0]) == COLORS["landmark"]
    assert pixel(seen, lm[0]) == COLORS["landmark_seen"]
    assert pixel(seen, lm[2]) == COLORS["landmark"]
    # A seen_mask of the wrong length (stale layout) is ignored, not a crash.
    odd = renderer.render(make_frame(frame_pose, seen_mask=np.ones(7, dtype=bool)))
    assert pixel(odd, lm[0]) == COLORS["landmark"]


def test_detections_draw_rays(renderer):
    pose = (1.0, 4.0, 0.0)
    target = np.array([[5.0, 4.0]])
    mid = renderer.world_to_pixel((3.0, 4.0))
    without = renderer.render(make_frame(pose))
    with_ray = renderer.render(make_frame(pose, detections_world=target, detected_ids=[1]))
    assert pixel(with_ray, mid) == COLORS["ray"]
    assert pixel(without, mid) != COLORS["ray"]


def test_belief_overlay_changes_pixels(renderer):
    frame = make_frame((3.0, 3.0, 0.3), seen_mask=np.array([True, True, False]))
    plain = renderer.render(frame)
    frame.belief = make_belief()
    with_belief = renderer.render(frame)
    assert plain.shape == with_belief.shape
    changed = np.any(plain != with_belief, axis=2)
    assert changed.sum() > 100
    # The landmark-0 estimate's cross is drawn at its mean.
    lm0 = renderer.world_to_pixel((2.3, 1.7))
    assert pixel(with_belief, lm0) == COLORS["belief_landmark"]


@pytest.mark.parametrize(
    "covs",
    [
        np.zeros((2, 2, 2)),
        np.array([[[1.0, 1.0], [1.0, 1.0]], [[1e12, 0.0], [0.0, 1e12]]]),  # singular, huge
        np.full((2, 2, 2), np.nan),
    ],
)
def test_degenerate_belief_renders(renderer, covs):
    belief = make_belief(landmark_covs=covs, pose_cov=np.zeros((3, 3)), true_landmarks=None)
    img = renderer.render(make_frame(belief=belief))
    assert img.shape == renderer.shape


def test_non_finite_inputs_do_not_crash(renderer):
    frame = make_frame(
        (np.nan, 1.0, 0.0),
        trail=np.array([[1.0, 1.0], [np.nan, 2.0], [3.0, 3.0]]),
        detections_world=np.array([[np.inf, 0.0]]),
        belief=make_belief(
            pose=np.array([np.nan, 0.0, 0.0]),
            landmark_means=np.array([[np.nan, 1.0], [5.0, 6.0]]),
            true_landmarks={1: (np.inf, 2.0)},
        ),
    )
    assert renderer.render(frame).shape == renderer.shape


def test_set_layout_keeps_shape_and_redraws(renderer):
    before = renderer.render(make_frame())
    other = Layout(
        width=20,
        height=5,
        landmark_ids=(4, 9),
        landmark_positions=((3, 3), (15, 2)),
        walls=((10, 0, 10, 3),),
    )
    renderer.set_layout(other)
    after = renderer.render(make_frame(seen_mask=np.array([True, False])))
    assert after.shape == before.shape
    assert not np.array_equal(after, before)
    # The new world is fitted inside the canvas.
    corners = renderer.world_to_pixel(np.array([[0.0, 0.0], [20.0, 5.0]]))
    h, w, _ = renderer.shape
    assert np.all(corners >= 0) and np.all(corners[:, 0] <= w) and np.all(corners[:, 1] <= h)
    assert pixel(after, renderer.world_to_pixel((3, 3))) == COLORS["landmark_seen"]


def test_full_circle_fov_and_odd_window(layout):
    r = Renderer(layout, 0.3, 3.0, 2.0 * math.pi, "rgb_array", window_px=301)
    img = r.render(make_frame((5.0, 4.0, 0.0)))
    assert img.shape == r.shape
    assert img.shape[0] % 2 == 0 and img.shape[1] % 2 == 0  # even, for video encoders
    r.close()


def test_close_is_idempotent_and_render_after_close_works(renderer):
    renderer.render(make_frame())
    renderer.close()
    renderer.close()
    assert renderer.render(make_frame()).shape == renderer.shape


def test_renderer_pickles_without_pygame_objects(renderer):
    img = renderer.render(make_frame((4.0, 4.0, 1.0)))
    clone = pickle.loads(pickle.dumps(renderer))
    np.testing.assert_array_equal(clone.render(make_frame((4.0, 4.0, 1.0))), img)
    clone.close()


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(render_mode="ansi"),
        dict(render_mode="rgb_array", window_px=10),
        dict(render_mode="rgb_array", render_fps=0),
        dict(render_mode="rgb_array", max_range=0.0),
        dict(render_mode="rgb_array", fov=float("nan")),
    ],
)
def test_invalid_arguments(layout, kwargs):
    args = dict(robot_radius=0.25, max_range=5.0, fov=FOV)
    args.update(kwargs)
    with pytest.raises(ValueError):
        Renderer(layout, **args)


def test_labels_skipped_when_font_unavailable(renderer, monkeypatch):
    with_labels = renderer.render(make_frame())
    renderer.close()
    monkeypatch.setattr(renderer, "_font", False)  # as if pygame.font failed to init
    without = renderer.render(make_frame())
    assert without.shape == with_labels.shape
    assert not np.array_equal(without, with_labels)  # the ID text is gone


# --------------------------------------------------------------------------- human
def test_human_mode_headless(layout):
    r = Renderer(layout, 0.25, 5.0, FOV, "human", render_fps=1000)
    assert r.render(make_frame()) is None
    assert r.render(make_frame((2.0, 2.0, 1.0), belief=make_belief())) is None
    import pygame

    surf = pygame.display.get_surface()
    assert surf is not None and surf.get_size() == (r.shape[1], r.shape[0])
    r.close()
    r.close()
    assert not pygame.display.get_init()


# --------------------------------------------------------------------------- imports
def test_importing_rendering_does_not_import_pygame():
    code = (
        "import sys\n"
        "import slam_env.render.renderer, slam_env.belief.overlay, slam_env.render.plots\n"
        "assert 'pygame' not in sys.modules, 'pygame imported'\n"
        "assert 'matplotlib.pyplot' not in sys.modules, 'pyplot imported'\n"
        "print('ok')\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


# --------------------------------------------------------------------------- video
def test_record_video_frames(layout, tmp_path):
    import gymnasium as gym
    from gymnasium.wrappers import RecordVideo

    class Tiny(gym.Env):
        metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

        def __init__(self):
            self.render_mode = "rgb_array"
            self.observation_space = gym.spaces.Box(-1, 1, (1,), np.float32)
            self.action_space = gym.spaces.Box(-1, 1, (1,), np.float32)
            self._r = Renderer(layout, 0.25, 5.0, FOV, "rgb_array")
            self._x = 1.0

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            self._x = 1.0
            return np.zeros(1, np.float32), {}

        def step(self, action):
            self._x += 0.2
            return np.zeros(1, np.float32), 0.0, self._x > 3.0, False, {}

        def render(self):
            return self._r.render(make_frame((self._x, 2.0, 0.0)))

    env = RecordVideo(Tiny(), str(tmp_path / "videos"), episode_trigger=lambda e: True)
    env.reset(seed=0)
    done = False
    while not done:
        _, _, done, _, _ = env.step(env.action_space.sample())
    env.close()
    assert list((tmp_path / "videos").glob("*.mp4"))
