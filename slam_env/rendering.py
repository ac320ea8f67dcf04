"""Pygame rendering of the world, the robot, its sensor and (optionally) a SLAM belief.

This is the only module that uses pygame, and it imports it lazily (inside methods),
so ``import slam_env.rendering`` — and the env — work where pygame is unusable.

The env hands the :class:`Renderer` a :class:`Frame` (plain data) every time it is
asked to render; the EKF wrapper adds a :class:`BeliefOverlay`. ``"rgb_array"`` mode
draws off-screen (headless, no display needed) and returns a fresh (H, W, 3) uint8
array whose shape never changes for the renderer's life, even when the world does
(``set_layout``), as :class:`gymnasium.wrappers.RecordVideo` needs. ``"human"`` mode
opens a window on the first render and ticks a clock at ``render_fps``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from slam_env.layouts import Layout
from slam_env.overlay import CHI2_2DOF_95, BeliefOverlay, ellipse_points, ellipses_points

__all__ = [
    "CHI2_2DOF_95",
    "COLORS",
    "RENDER_MODES",
    "BeliefOverlay",
    "Frame",
    "Renderer",
    "ellipse_points",
]

RENDER_MODES = ("human", "rgb_array")

#: RGB colours of every drawn element (the tests sample some of them).
COLORS: dict[str, tuple[int, int, int]] = {
    "background": (222, 222, 222),  # outside the arena
    "floor": (250, 250, 246),
    "wall": (45, 45, 45),
    "obstacle": (128, 128, 128),
    "obstacle_edge": (70, 70, 70),
    "landmark": (165, 165, 165),  # never detected
    "landmark_seen": (235, 150, 20),  # detected at least once
    "landmark_edge": (40, 40, 40),
    "detected_ring": (30, 170, 60),  # detected in this frame
    "label": (25, 25, 25),
    "robot": (40, 110, 220),
    "robot_collision": (220, 40, 40),
    "robot_edge": (15, 40, 90),
    "heading": (10, 10, 10),
    "fov": (255, 215, 70),  # drawn translucent
    "range": (205, 165, 30),
    "ray": (30, 170, 60),
    "trail": (120, 170, 240),
    "belief_pose": (190, 30, 160),
    "belief_landmark": (120, 40, 200),
    "truth_link": (150, 110, 190),
}
FOV_ALPHA = 60  # 0..255, opacity of the sensor wedge

_CLIP_PX = 20_000.0  # clamp pixel coordinates: a huge covariance must not overflow pygame
_LABEL_CACHE_MAX = 1024
_ELLIPSE_N = 40  # points per drawn ellipse


@dataclass
class Frame:
    """Everything drawn in one frame (plain data, built by the env).

    Attributes:
        pose: true robot pose (x, y, θ), m and rad.
        trail: (T, 2) past true positions, m, oldest first.
        detections_world: (k, 2) world-frame points of the current detections, m.
        detected_ids: (k,) landmark IDs of those detections.
        seen_mask: (N,) bool, in layout order: landmarks detected at least once.
        collision: whether the robot is in contact with a wall or an obstacle.
        belief: an optional SLAM belief to draw on top.
    """

    pose: tuple[float, float, float]
    trail: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    detections_world: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    detected_ids: np.ndarray = field(default_factory=lambda: np.zeros((0,), dtype=np.int64))
    seen_mask: np.ndarray | None = None
    collision: bool = False
    belief: BeliefOverlay | None = None


def _import_pygame() -> Any:
    """Import pygame on first use (and without its banner on stdout)."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import pygame
    except ImportError as exc:  # pragma: no cover - pygame is a declared dependency
        raise ImportError("rendering needs pygame: pip install pygame") from exc
    return pygame


def _finite_rows(points: Any) -> np.ndarray:
    """(k, 2) float rows of ``points`` with every coordinate finite."""
    arr = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return arr[np.all(np.isfinite(arr), axis=1)]


class Renderer:
    """Draws :class:`Frame` s of one world with pygame.

    Args:
        layout: the world to draw (walls, obstacles, landmarks); see :meth:`set_layout`.
        robot_radius: m.
        max_range: sensor range, m (the FOV wedge's radius).
        fov: full sensor opening angle, rad, centred on the heading (≥ 2π: a disc).
        render_mode: ``"rgb_array"`` or ``"human"``.
        window_px: length of the canvas's longer side, px. The canvas keeps the first
            layout's aspect ratio (rounded to even sizes, for video encoders) and then
            never changes size; a later layout is fitted into it.
        render_fps: frames per second of the ``"human"`` window's clock.

    The world → pixel transform keeps the aspect ratio, leaves a margin, and puts y up.
    """

    def __init__(
        self,
        layout: Layout,
        robot_radius: float,
        max_range: float,
        fov: float,
        render_mode: str,
        window_px: int = 600,
        render_fps: int = 30,
    ) -> None:
        if render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode must be one of {RENDER_MODES}, got {render_mode!r}")
        if int(window_px) < 64:
            raise ValueError(f"window_px must be >= 64, got {window_px}")
        if int(render_fps) < 1:
            raise ValueError(f"render_fps must be >= 1, got {render_fps}")
        for name, value in (("robot_radius", robot_radius), ("max_range", max_range)):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value}")
        if not (math.isfinite(fov) and fov > 0):
            raise ValueError(f"fov must be a finite angle > 0, got {fov}")
        self.render_mode = render_mode
        self.robot_radius = float(robot_radius)
        self.max_range = float(max_range)
        self.fov = float(fov)
        self.render_fps = int(render_fps)
        self.window_px = int(window_px)
        self.margin_px = max(8, round(0.03 * self.window_px))

        longer = max(layout.width, layout.height)
        usable = self.window_px - 2 * self.margin_px
        w = round(usable * layout.width / longer) + 2 * self.margin_px
        h = round(usable * layout.height / longer) + 2 * self.margin_px
        self.width_px = w + (w % 2)
        self.height_px = h + (h % 2)

        # pygame objects, created lazily and dropped by close() / pickling.
        self._canvas: Any = None
        self._background: Any = None
        self._fov_layer: Any = None
        self._window: Any = None
        self._clock: Any = None
        self._font: Any = None  # None: not tried yet; False: unavailable
        self._labels: dict[tuple[str, tuple[int, int, int]], Any] = {}
        self.set_layout(layout)

    # ------------------------------------------------------------------ geometry
    @property
    def shape(self) -> tuple[int, int, int]:
        """(H, W, 3), the shape of every ``"rgb_array"`` frame."""
        return (self.height_px, self.width_px, 3)

    def set_layout(self, layout: Layout) -> None:
        """Draw ``layout`` from now on (the world can change at reset). The canvas keeps
        its size; the new world is fitted into it, centred, aspect ratio kept."""
        self.layout = layout
        sx = (self.width_px - 2 * self.margin_px) / layout.width
        sy = (self.height_px - 2 * self.margin_px) / layout.height
        self.scale = min(sx, sy)  # px per m
        self._ox = 0.5 * (self.width_px - layout.width * self.scale)
        self._oy = 0.5 * (self.height_px - layout.height * self.scale)
        self._landmarks = layout.landmark_array()
        self._landmark_ids = layout.id_array()
        self._id_to_index = {int(i): k for k, i in enumerate(self._landmark_ids)}
        self._background = None  # rebuilt on the next render

    def world_to_pixel(self, points: Any) -> np.ndarray:
        """World points (..., 2) in m → pixel coordinates (..., 2) (column, row), float.
        Row 0 is the top of the image; world y grows upwards."""
        p = np.asarray(points, dtype=np.float64)
        out = np.empty(p.shape)
        out[..., 0] = self._ox + p[..., 0] * self.scale
        out[..., 1] = self._oy + (self.layout.height - p[..., 1]) * self.scale
        return out

    def _px(self, points: Any) -> list[tuple[int, int]]:
        pix = np.rint(self.world_to_pixel(points)).reshape(-1, 2)
        # Callers skip non-finite points; this only keeps int() from failing on them.
        pix = np.clip(np.nan_to_num(pix, nan=0.0), -_CLIP_PX, _CLIP_PX)
        return [(int(c), int(r)) for c, r in pix]

    def _len_px(self, metres: float, minimum: int = 1) -> int:
        return max(minimum, round(metres * self.scale))

    # ------------------------------------------------------------------ pygame state
    def _ensure_surfaces(self) -> None:
        pygame = _import_pygame()

        if self._canvas is None:
            self._canvas = pygame.Surface((self.width_px, self.height_px))
        if self._fov_layer is None:
            self._fov_layer = pygame.Surface((self.width_px, self.height_px), pygame.SRCALPHA)
        if self._background is None:
            self._background = self._draw_background()

    def _get_font(self) -> Any:
        if self._font is None:
            try:
                pygame = _import_pygame()

                pygame.font.init()
                self._font = pygame.font.Font(None, max(12, round(self.window_px / 40)))
            except Exception:  # no font module or no font file: draw without labels
                self._font = False
        return self._font or None

    def _text(self, text: str, color: tuple[int, int, int]) -> Any:
        """A cached text surface, or None when fonts are unavailable."""
        font = self._get_font()
        if font is None:
            return None
        key = (text, color)
        surf = self._labels.get(key)
        if surf is None:
            if len(self._labels) >= _LABEL_CACHE_MAX:
                self._labels.clear()
            try:
                surf = font.render(text, True, color)
            except Exception:
                return None
            self._labels[key] = surf
        return surf

    def _draw_background(self) -> Any:
        """The static part of the frame: floor, boundary and inner walls, obstacles."""
        pygame = _import_pygame()

        bg = pygame.Surface((self.width_px, self.height_px))
        bg.fill(COLORS["background"])
        lay = self.layout
        corners = self._px([(0, 0), (lay.width, 0), (lay.width, lay.height), (0, lay.height)])
        pygame.draw.polygon(bg, COLORS["floor"], corners)
        for poly in lay.obstacles:
            pts = self._px(_finite_rows(poly))
            if len(pts) >= 3:
                pygame.draw.polygon(bg, COLORS["obstacle"], pts)
                pygame.draw.polygon(bg, COLORS["obstacle_edge"], pts, width=1)
        wall_w = self._len_px(0.1, minimum=2)
        pygame.draw.lines(bg, COLORS["wall"], True, corners, width=wall_w)
        for x0, y0, x1, y1 in lay.walls:
            a, b = self._px([(x0, y0), (x1, y1)])
            pygame.draw.line(bg, COLORS["wall"], a, b, width=wall_w)
            for end in (a, b):  # round caps
                pygame.draw.circle(bg, COLORS["wall"], end, max(1, wall_w // 2))
        return bg

    # ------------------------------------------------------------------ drawing
    def render(self, frame: Frame) -> np.ndarray | None:
        """Draw ``frame``. ``"rgb_array"``: return a fresh (H, W, 3) uint8 array;
        ``"human"``: show it in the window, wait for the clock, return None."""
        pygame = _import_pygame()

        self._ensure_surfaces()
        canvas = self._canvas
        canvas.blit(self._background, (0, 0))
        pose = np.asarray(frame.pose, dtype=np.float64).reshape(3)
        pose_ok = bool(np.all(np.isfinite(pose)))

        self._draw_trail(canvas, frame.trail)
        if pose_ok:
            self._draw_sensor(canvas, pose)
        self._draw_landmarks(canvas, frame.seen_mask, frame.detected_ids)
        if pose_ok:
            self._draw_detections(canvas, pose, frame.detections_world)
        if frame.belief is not None:
            self._draw_belief(canvas, frame.belief)
        if pose_ok:
            self._draw_robot(canvas, pose, bool(frame.collision))
        self._draw_status(canvas, frame)

        if self.render_mode == "human":
            if self._window is None:
                pygame.display.init()
                self._window = pygame.display.set_mode((self.width_px, self.height_px))
                pygame.display.set_caption("slam_env")
                self._clock = pygame.time.Clock()
            pygame.event.pump()
            self._window.blit(canvas, (0, 0))
            pygame.display.flip()
            self._clock.tick(self.render_fps)
            return None
        buf = bytearray(pygame.image.tobytes(canvas, "RGB"))
        return np.frombuffer(buf, dtype=np.uint8).reshape(self.height_px, self.width_px, 3)

    def _draw_trail(self, canvas: Any, trail: Any) -> None:
        pygame = _import_pygame()

        if trail is None:
            return
        pts = _finite_rows(trail)
        if pts.shape[0] >= 2:
            pygame.draw.lines(canvas, COLORS["trail"], False, self._px(pts), width=2)

    def _draw_sensor(self, canvas: Any, pose: np.ndarray) -> None:
        pygame = _import_pygame()

        x, y, theta = pose
        r_px = self.max_range * self.scale
        centre = self._px([(x, y)])[0]
        full = self.fov >= 2.0 * math.pi - 1e-9
        if full:
            outline = None
        else:
            n_arc = max(8, int(64 * self.fov / (2.0 * math.pi)))
            ang = theta + np.linspace(-0.5 * self.fov, 0.5 * self.fov, n_arc)
            arc = np.stack([x + self.max_range * np.cos(ang), y + self.max_range * np.sin(ang)], 1)
            outline = [centre, *self._px(arc)]
        # Translucent wedge: fill only its bounding box on the alpha layer, then blit.
        rect = pygame.Rect(0, 0, int(2 * r_px) + 4, int(2 * r_px) + 4)
        rect.center = centre
        arena = self._arena_rect(pygame)
        rect = rect.clip(arena)
        if rect.width > 0 and rect.height > 0:
            layer = self._fov_layer
            layer.fill((0, 0, 0, 0), rect)
            rgba = (*COLORS["fov"], FOV_ALPHA)
            if full:
                pygame.draw.circle(layer, rgba, centre, max(1, round(r_px)))
            else:
                pygame.draw.polygon(layer, rgba, outline)
            canvas.blit(layer, rect.topleft, area=rect)
        canvas.set_clip(arena)  # the wedge stays inside the arena
        if full:
            pygame.draw.circle(canvas, COLORS["range"], centre, max(1, round(r_px)), width=1)
        else:
            pygame.draw.lines(canvas, COLORS["range"], True, outline, width=1)
        canvas.set_clip(None)

    def _arena_rect(self, pygame: Any) -> Any:
        (c0, r0), (c1, r1) = self._px([(0.0, self.layout.height), (self.layout.width, 0.0)])
        return pygame.Rect(c0, r0, c1 - c0 + 1, r1 - r0 + 1)

    def _draw_landmarks(self, canvas: Any, seen_mask: Any, detected_ids: Any) -> None:
        pygame = _import_pygame()

        n = self._landmarks.shape[0]
        if n == 0:
            return
        seen = np.zeros(n, dtype=bool)
        if seen_mask is not None:
            mask = np.asarray(seen_mask, dtype=bool).reshape(-1)
            if mask.size == n:
                seen = mask
        detected = set()
        if detected_ids is not None:
            for i in np.asarray(detected_ids).reshape(-1):
                k = self._id_to_index.get(int(i))
                if k is not None:
                    detected.add(k)
        r = self._len_px(0.12, minimum=3)
        for k, (c, row) in enumerate(self._px(self._landmarks)):
            color = COLORS["landmark_seen"] if seen[k] else COLORS["landmark"]
            if k in detected:
                pygame.draw.circle(canvas, COLORS["detected_ring"], (c, row), r + 3, width=2)
            pygame.draw.circle(canvas, color, (c, row), r)
            pygame.draw.circle(canvas, COLORS["landmark_edge"], (c, row), r, width=1)
            label = self._text(str(int(self._landmark_ids[k])), COLORS["label"])
            if label is not None:
                canvas.blit(label, (c + r + 1, row - r - label.get_height() + 2))

    def _draw_detections(self, canvas: Any, pose: np.ndarray, detections: Any) -> None:
        pygame = _import_pygame()

        if detections is None:
            return
        pts = _finite_rows(detections)
        if pts.shape[0] == 0:
            return
        centre = self._px([pose[:2]])[0]
        for p in self._px(pts):
            pygame.draw.line(canvas, COLORS["ray"], centre, p, width=1)
            pygame.draw.circle(canvas, COLORS["ray"], p, 2)

    def _draw_ellipse(self, canvas: Any, mean: Any, cov: Any, color: tuple[int, int, int]) -> None:
        pygame = _import_pygame()

        mean = np.asarray(mean, dtype=np.float64).reshape(2)
        cov = np.asarray(cov, dtype=np.float64).reshape(2, 2)
        if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))):
            return
        pts = ellipse_points(mean, cov, 0.95, n=_ELLIPSE_N)
        pygame.draw.lines(canvas, color, True, self._px(pts), width=1)

    def _draw_belief(self, canvas: Any, belief: BeliefOverlay) -> None:
        pygame = _import_pygame()

        ids = np.asarray(belief.landmark_ids).reshape(-1)
        means = np.asarray(belief.landmark_means, dtype=np.float64).reshape(-1, 2)
        covs = np.asarray(belief.landmark_covs, dtype=np.float64).reshape(-1, 2, 2)
        n = min(ids.size, means.shape[0], covs.shape[0])
        means, covs = means[:n], covs[:n]
        truth = belief.truth_for(self._landmark_ids, self._landmarks)
        arm = self._len_px(0.12, minimum=3)
        ok_cov = np.all(np.isfinite(covs), axis=(1, 2))
        rings = self._px(ellipses_points(means, covs, 0.95, n=_ELLIPSE_N)) if n else []
        centres = self._px(means) if n else []
        truth_px = self._px(truth) if n else []
        for k in range(n):
            m = means[k]
            if not np.all(np.isfinite(m)):
                continue
            c, row = centres[k]
            if k < truth.shape[0] and np.all(np.isfinite(truth[k])):
                pygame.draw.line(canvas, COLORS["truth_link"], (c, row), truth_px[k], width=1)
            if ok_cov[k]:
                ring = rings[k * _ELLIPSE_N : (k + 1) * _ELLIPSE_N]
                pygame.draw.lines(canvas, COLORS["belief_landmark"], True, ring, width=1)
            col = COLORS["belief_landmark"]
            pygame.draw.line(canvas, col, (c - arm, row - arm), (c + arm, row + arm), width=2)
            pygame.draw.line(canvas, col, (c - arm, row + arm), (c + arm, row - arm), width=2)

        pose = np.asarray(belief.pose, dtype=np.float64).reshape(3)
        if np.all(np.isfinite(pose)):
            pcov = np.asarray(belief.pose_cov, dtype=np.float64).reshape(3, 3)[:2, :2]
            self._draw_ellipse(canvas, pose[:2], pcov, COLORS["belief_pose"])
            rr = self._len_px(self.robot_radius, minimum=3)
            centre = self._px([pose[:2]])[0]
            tip = self._px(
                [
                    pose[:2]
                    + 1.4 * self.robot_radius * np.array([math.cos(pose[2]), math.sin(pose[2])])
                ]
            )[0]
            pygame.draw.circle(canvas, COLORS["belief_pose"], centre, rr, width=2)
            pygame.draw.line(canvas, COLORS["belief_pose"], centre, tip, width=2)

    def _draw_robot(self, canvas: Any, pose: np.ndarray, collision: bool) -> None:
        pygame = _import_pygame()

        x, y, theta = pose
        rr = self._len_px(self.robot_radius, minimum=3)
        centre = self._px([(x, y)])[0]
        fill = COLORS["robot_collision"] if collision else COLORS["robot"]
        pygame.draw.circle(canvas, fill, centre, rr)
        pygame.draw.circle(canvas, COLORS["robot_edge"], centre, rr, width=2)
        tip = self._px(
            [(x + self.robot_radius * math.cos(theta), y + self.robot_radius * math.sin(theta))]
        )[0]
        pygame.draw.line(canvas, COLORS["heading"], centre, tip, width=max(2, rr // 5))

    def _draw_status(self, canvas: Any, frame: Frame) -> None:
        n = self._landmarks.shape[0]
        seen = 0
        if frame.seen_mask is not None:
            mask = np.asarray(frame.seen_mask, dtype=bool).reshape(-1)
            seen = int(mask.sum()) if mask.size == n else 0
        text = f"seen {seen}/{n}"
        if frame.collision:
            text += "  collision"
        surf = self._text(text, COLORS["label"])
        if surf is not None:
            canvas.blit(surf, (4, 2))

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """Close the window (``"human"``) and drop every pygame object. Idempotent;
        a later :meth:`render` starts afresh."""
        if self._window is not None:
            try:
                pygame = _import_pygame()

                pygame.display.quit()
            except Exception:
                pass
        self._window = None
        self._clock = None
        self._canvas = None
        self._background = None
        self._fov_layer = None
        self._labels = {}
        self._font = None

    def __getstate__(self) -> dict[str, Any]:
        # pygame objects do not pickle: drop them (they are rebuilt lazily).
        state = self.__dict__.copy()
        for key in ("_window", "_clock", "_canvas", "_background", "_fov_layer", "_font"):
            state[key] = None
        state["_labels"] = {}
        return state
