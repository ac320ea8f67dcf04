"""Pygame rendering of the world, the robot, its sensor and (optionally) a SLAM belief.

This is the only module that uses pygame, and it imports it lazily (inside methods),
so ``import slam_env.render.renderer`` — and the env — work where pygame is unusable.

The env hands the :class:`Renderer` a :class:`Frame` (plain data) every time it is
asked to render; the EKF wrapper adds a :class:`BeliefOverlay`. A frame is the map
(the world, the sensor's visible region, the true and estimated paths, the robot, the
detections, the belief with its 95% ellipses) above a strip with the step, the
landmarks seen, the belief's live figures, a 1 m scale bar and a legend. The colours
and symbols are those of the plots (:data:`slam_env.belief.overlay.PALETTE`).

``"rgb_array"`` mode draws off-screen (headless, no display needed) and returns a fresh
(H, W, 3) uint8 array whose shape never changes for the renderer's life, even when the
world does (``set_layout``), as :class:`gymnasium.wrappers.RecordVideo` needs.
``"human"`` mode opens a window on the first render and ticks a clock at ``render_fps``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from slam_env.belief.overlay import (
    CHI2_2DOF_95,
    ELLIPSE_FILL_ALPHA,
    LEGEND_LABELS,
    PALETTE,
    BeliefOverlay,
    ellipse_points,
    ellipses_points,
)
from slam_env.extras import require
from slam_env.world.layouts import Layout

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

#: RGB colours of every drawn element (the tests sample some of them): the shared
#: palette under the names the movie uses.
COLORS: dict[str, tuple[int, int, int]] = {
    "background": (222, 222, 222),  # outside the arena, and the strip below the map
    "floor": PALETTE["floor"],
    "wall": PALETTE["wall"],
    "obstacle": PALETTE["obstacle"],
    "obstacle_edge": PALETTE["obstacle_edge"],
    "landmark": PALETTE["landmark"],  # never detected
    "landmark_seen": PALETTE["landmark_seen"],  # detected at least once
    "landmark_edge": PALETTE["landmark_edge"],
    "detected_ring": PALETTE["detection"],  # detected in this frame
    "label": PALETTE["label"],
    "robot": PALETTE["truth"],
    "robot_collision": (220, 40, 40),
    "robot_edge": PALETTE["truth_edge"],
    "heading": (10, 10, 10),
    "fov": PALETTE["visible"],  # drawn translucent
    "range": PALETTE["visible_edge"],
    "ray": PALETTE["detection"],
    "trail": PALETTE["truth"],
    "belief_pose": PALETTE["estimate"],
    "belief_landmark": PALETTE["belief_landmark"],
    "truth_link": PALETTE["truth_link"],
}
FOV_ALPHA = 70  # 0..255, opacity of the sensor's visible region
ELLIPSE_ALPHA = round(255 * ELLIPSE_FILL_ALPHA)

#: The belief's live figures shown in the strip: (label, unit, format) by name.
FIGURE_FORMATS: dict[str, tuple[str, str, str]] = {
    "entropy": ("entropy", "nats", "{:.1f}"),
    "map_rmse": ("map RMSE", "m", "{:.3f}"),
    "pose_nees": ("pose NEES", "", "{:.2f}"),
}

_CLIP_PX = 20_000.0  # clamp pixel coordinates: a huge covariance must not overflow pygame
_LABEL_CACHE_MAX = 1024
_ELLIPSE_N = 40  # points per drawn ellipse
_STRIP_ROWS = 5  # status, figures, three rows of legend
_LEGEND_COLUMNS = 2
_DASH_PX = (9.0, 6.0)  # on, off: the estimated path's dashes


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
        visible_region: (K, 2) polygon, m, of what the landmark sensor sees, clipped by
            what occludes it (:func:`slam_env.render.visibility.visible_region`); ``None``
            draws the unclipped field of view.
        step: steps since the reset, shown in the strip; ``None``: not shown.
    """

    pose: tuple[float, float, float]
    trail: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    detections_world: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    detected_ids: np.ndarray = field(default_factory=lambda: np.zeros((0,), dtype=np.int64))
    seen_mask: np.ndarray | None = None
    collision: bool = False
    belief: BeliefOverlay | None = None
    visible_region: np.ndarray | None = None
    step: int | None = None


def _import_pygame() -> Any:
    """Import pygame on first use (and without its banner on stdout)."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    require("render", "rendering")
    import pygame

    return pygame


def _finite_rows(points: Any) -> np.ndarray:
    """(k, 2) float rows of ``points`` with every coordinate finite."""
    arr = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return arr[np.all(np.isfinite(arr), axis=1)]


def _dashes(points: np.ndarray, on: float, off: float) -> list[np.ndarray]:
    """The dashes ((m, 2) each) of a dashed polyline through ``points`` (n, 2), px: the
    pattern runs on across vertices, so that short steps still read as a dashed line."""
    step = np.hypot(*np.diff(points, axis=0).T)
    keep = np.concatenate([[True], step > 0.0])  # a robot standing still adds no length
    points = points[keep]
    along = np.concatenate([[0.0], np.cumsum(step[step > 0.0])])
    dashes = []
    for start in np.arange(0.0, along[-1], on + off):
        stop = min(start + on, along[-1])
        t = np.concatenate([[start], along[(along > start) & (along < stop)], [stop]])
        xs = np.interp(t, along, points[:, 0])
        ys = np.interp(t, along, points[:, 1])
        dashes.append(np.stack([xs, ys], axis=1))
    return dashes


class Renderer:
    """Draws :class:`Frame` s of one world with pygame.

    Args:
        layout: the world to draw (walls, obstacles, landmarks); see :meth:`set_layout`.
        robot_radius: m.
        max_range: sensor range, m (the FOV wedge's radius).
        fov: full sensor opening angle, rad, centred on the heading (≥ 2π: a disc).
        render_mode: ``"rgb_array"`` or ``"human"``.
        window_px: length of the map's longer side, px; below the map, a strip holds
            the figures and the legend. The canvas keeps the first layout's aspect
            ratio (rounded to even sizes, for video encoders) and then never changes
            size; a later layout is fitted into the map's part of it.
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
        self.font_px = max(12, round(self.window_px / 32))
        self.row_px = self.font_px
        self.strip_px = _STRIP_ROWS * self.row_px + 8

        longer = max(layout.width, layout.height)
        usable = self.window_px - 2 * self.margin_px
        w = round(usable * layout.width / longer) + 2 * self.margin_px
        h = round(usable * layout.height / longer) + 2 * self.margin_px
        self.width_px = w + (w % 2)
        self.map_height_px = h
        self.height_px = h + self.strip_px + ((h + self.strip_px) % 2)

        # pygame objects, created lazily and dropped by close() / pickling.
        self._canvas: Any = None
        self._background: Any = None
        self._layer: Any = None  # translucent fills (visible region, ellipses)
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
        its size; the new world is fitted into the map's part, centred, aspect kept."""
        self.layout = layout
        sx = (self.width_px - 2 * self.margin_px) / layout.width
        sy = (self.map_height_px - 2 * self.margin_px) / layout.height
        self.scale = min(sx, sy)  # px per m
        self._ox = 0.5 * (self.width_px - layout.width * self.scale)
        self._oy = 0.5 * (self.map_height_px - layout.height * self.scale)
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
        if self._layer is None:
            self._layer = pygame.Surface((self.width_px, self.height_px), pygame.SRCALPHA)
        if self._background is None:
            self._background = self._draw_background()

    def _get_font(self) -> Any:
        if self._font is None:
            try:
                pygame = _import_pygame()

                pygame.font.init()
                self._font = pygame.font.Font(None, self.font_px)
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
        """The static part of the frame: floor, boundary and inner walls, obstacles,
        and the legend in the strip."""
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
        self._draw_legend(bg)
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

        if pose_ok:
            self._draw_sensor(canvas, pose, frame.visible_region)
        self._draw_trail(canvas, frame.trail)
        if frame.belief is not None and frame.belief.trail is not None:
            self._draw_estimated_trail(canvas, frame.belief.trail)
        self._draw_landmarks(canvas, frame.seen_mask, frame.detected_ids)
        if pose_ok:
            self._draw_detections(canvas, pose, frame.detections_world)
        if frame.belief is not None:
            self._draw_belief_ellipses(canvas, frame.belief)
        if pose_ok:
            self._draw_robot(canvas, pose, bool(frame.collision))
        if frame.belief is not None:
            self._draw_belief(canvas, frame.belief)
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

    def _draw_estimated_trail(self, canvas: Any, trail: Any) -> None:
        """The estimated path, dashed, in the estimate's colour."""
        pygame = _import_pygame()

        pts = _finite_rows(trail)
        if pts.shape[0] < 2:
            return
        pix = np.clip(self.world_to_pixel(pts), -_CLIP_PX, _CLIP_PX)
        for dash in _dashes(pix, *_DASH_PX):
            points = [(int(c), int(r)) for c, r in np.rint(dash)]
            if len(points) >= 2:
                pygame.draw.lines(canvas, COLORS["belief_pose"], False, points, width=2)

    def _wedge_outline(self, pose: np.ndarray) -> list[tuple[int, int]] | None:
        """The unclipped field of view's outline in px; None all around."""
        if self.fov >= 2.0 * math.pi - 1e-9:
            return None
        x, y, theta = pose
        n_arc = max(8, int(64 * self.fov / (2.0 * math.pi)))
        ang = theta + np.linspace(-0.5 * self.fov, 0.5 * self.fov, n_arc)
        arc = np.stack([x + self.max_range * np.cos(ang), y + self.max_range * np.sin(ang)], 1)
        return [self._px([(x, y)])[0], *self._px(arc)]

    def _draw_sensor(self, canvas: Any, pose: np.ndarray, region: Any) -> None:
        """The sensor's visible region (``region``, m) translucent with its outline, or
        the unclipped field of view when no region is given."""
        pygame = _import_pygame()

        centre = self._px([pose[:2]])[0]
        r_px = max(1, round(self.max_range * self.scale))
        outline = None
        if region is not None:
            pts = _finite_rows(region)
            outline = self._px(pts) if pts.shape[0] >= 3 else None
        else:
            outline = self._wedge_outline(pose)
        layer = self._layer
        layer.fill((0, 0, 0, 0))
        rgba = (*COLORS["fov"], FOV_ALPHA)
        if outline is None and region is None:
            pygame.draw.circle(layer, rgba, centre, r_px)
        elif outline is not None:
            pygame.draw.polygon(layer, rgba, outline)
        canvas.set_clip(self._arena_rect(pygame))  # the region stays inside the arena
        canvas.blit(layer, (0, 0))
        if outline is None and region is None:
            pygame.draw.circle(canvas, COLORS["range"], centre, r_px, width=1)
        elif outline is not None:
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

    def _belief_rings(self, belief: BeliefOverlay) -> list[tuple[Any, tuple[int, int, int]]]:
        """The 95% ellipses of a belief in px with their colours: each landmark's, then
        the pose's (x, y) block."""
        means = np.asarray(belief.landmark_means, dtype=np.float64).reshape(-1, 2)
        covs = np.asarray(belief.landmark_covs, dtype=np.float64).reshape(-1, 2, 2)
        n = min(np.asarray(belief.landmark_ids).size, means.shape[0], covs.shape[0])
        means, covs = means[:n], covs[:n]
        ok = np.all(np.isfinite(means), axis=1) & np.all(np.isfinite(covs), axis=(1, 2))
        rings = []
        if ok.any():
            pts = ellipses_points(means[ok], covs[ok], 0.95, n=_ELLIPSE_N)
            for ring in pts:
                rings.append((self._px(ring), COLORS["belief_landmark"]))
        pose = np.asarray(belief.pose, dtype=np.float64).reshape(3)
        pcov = np.asarray(belief.pose_cov, dtype=np.float64).reshape(3, 3)[:2, :2]
        if np.all(np.isfinite(pose)) and np.all(np.isfinite(pcov)):
            ring = ellipse_points(pose[:2], pcov, 0.95, n=_ELLIPSE_N)
            rings.append((self._px(ring), COLORS["belief_pose"]))
        return rings

    def _draw_belief_ellipses(self, canvas: Any, belief: BeliefOverlay) -> None:
        """95% ellipses: a translucent fill and a 2 px edge, so that they show at a
        glance even when they are small."""
        pygame = _import_pygame()

        rings = self._belief_rings(belief)
        if not rings:
            return
        layer = self._layer
        layer.fill((0, 0, 0, 0))
        for ring, color in rings:
            pygame.draw.polygon(layer, (*color, ELLIPSE_ALPHA), ring)
        canvas.blit(layer, (0, 0))
        for ring, color in rings:
            pygame.draw.lines(canvas, color, True, ring, width=2)

    def _draw_belief(self, canvas: Any, belief: BeliefOverlay) -> None:
        """The landmark estimates (crosses, linked to the truth) and the estimated pose
        (a ring with its heading)."""
        pygame = _import_pygame()

        ids = np.asarray(belief.landmark_ids).reshape(-1)
        means = np.asarray(belief.landmark_means, dtype=np.float64).reshape(-1, 2)
        n = min(ids.size, means.shape[0])
        means = means[:n]
        truth = belief.truth_for(self._landmark_ids, self._landmarks)
        arm = self._len_px(0.12, minimum=3)
        centres = self._px(means) if n else []
        truth_px = self._px(truth) if n else []
        for k in range(n):
            if not np.all(np.isfinite(means[k])):
                continue
            c, row = centres[k]
            if k < truth.shape[0] and np.all(np.isfinite(truth[k])):
                pygame.draw.line(canvas, COLORS["truth_link"], (c, row), truth_px[k], width=1)
            self._cross(canvas, (c, row), arm, COLORS["belief_landmark"])

        pose = np.asarray(belief.pose, dtype=np.float64).reshape(3)
        if np.all(np.isfinite(pose)):
            rr = self._len_px(self.robot_radius, minimum=3)
            centre = self._px([pose[:2]])[0]
            heading = np.array([math.cos(pose[2]), math.sin(pose[2])])
            tip = self._px([pose[:2] + 1.4 * self.robot_radius * heading])[0]
            pygame.draw.circle(canvas, COLORS["belief_pose"], centre, rr, width=2)
            pygame.draw.line(canvas, COLORS["belief_pose"], centre, tip, width=2)

    @staticmethod
    def _cross(canvas: Any, centre: tuple[int, int], arm: int, color: Any) -> None:
        pygame = _import_pygame()

        c, row = centre
        pygame.draw.line(canvas, color, (c - arm, row - arm), (c + arm, row + arm), width=2)
        pygame.draw.line(canvas, color, (c - arm, row + arm), (c + arm, row - arm), width=2)

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

    # ------------------------------------------------------------------ the strip
    def _row_top(self, row: int) -> int:
        return self.map_height_px + 2 + row * self.row_px

    def _draw_status(self, canvas: Any, frame: Frame) -> None:
        """The strip's first rows: step, landmarks seen, collision; the live figures."""
        n = self._landmarks.shape[0]
        seen = 0
        if frame.seen_mask is not None:
            mask = np.asarray(frame.seen_mask, dtype=bool).reshape(-1)
            seen = int(mask.sum()) if mask.size == n else 0
        parts = [] if frame.step is None else [f"step {int(frame.step)}"]
        parts.append(f"seen {seen}/{n}")
        if frame.collision:
            parts.append("collision")
        self._blit_text(canvas, "   ".join(parts), self.margin_px, self._row_top(0))
        figures = frame.belief.figures if frame.belief is not None else None
        if figures:
            self._blit_text(canvas, _format_figures(figures), self.margin_px, self._row_top(1))

    def _blit_text(self, canvas: Any, text: str, x: int, top: int) -> int:
        """Draw ``text`` at (x, top); return its width (0 without fonts)."""
        surf = self._text(text, COLORS["label"])
        if surf is None:
            return 0
        canvas.blit(surf, (x, top))
        return surf.get_width()

    def _draw_legend(self, surface: Any) -> None:
        """A 1 m scale bar and the key to the symbols, in the strip (static)."""
        pygame = _import_pygame()

        # The scale bar, right-aligned on the first row.
        bar = max(4, round(self.scale))
        right = self.width_px - self.margin_px
        mid = self._row_top(0) + self.row_px // 2
        label = self._text("1 m", COLORS["label"])
        text_w = label.get_width() + 4 if label is not None else 0
        x0 = right - text_w - bar
        pygame.draw.line(surface, COLORS["label"], (x0, mid), (x0 + bar, mid), width=2)
        for x in (x0, x0 + bar):
            pygame.draw.line(surface, COLORS["label"], (x, mid - 3), (x, mid + 3), width=1)
        if label is not None:
            surface.blit(label, (right - label.get_width(), mid - label.get_height() // 2))

        glyph = 2 * self.font_px
        column = (self.width_px - 2 * self.margin_px) // _LEGEND_COLUMNS
        for k, kind in enumerate(_LEGEND):
            row, col = divmod(k, _LEGEND_COLUMNS)
            left = self.margin_px + col * column
            top = self._row_top(2 + row)
            centre = (left + glyph // 2, top + self.row_px // 2)
            self._draw_glyph(surface, kind, centre, glyph)
            self._blit_text(surface, LEGEND_LABELS[kind], left + glyph + 6, top)

    def _draw_glyph(self, surface: Any, kind: str, centre: tuple[int, int], size: int) -> None:
        pygame = _import_pygame()

        c, row = centre
        half = size // 2
        r = max(3, self.font_px // 4)
        if kind == "truth":
            pygame.draw.line(surface, COLORS["trail"], (c - half, row), (c - r, row), width=2)
            pygame.draw.circle(surface, COLORS["robot"], (c + r, row), r + 1)
            pygame.draw.circle(surface, COLORS["robot_edge"], (c + r, row), r + 1, width=1)
        elif kind == "estimate":
            for x in (c - half, c - half + 7):
                pygame.draw.line(surface, COLORS["belief_pose"], (x, row), (x + 4, row), width=2)
            pygame.draw.circle(surface, COLORS["belief_pose"], (c + r, row), r + 1, width=2)
        elif kind == "landmark":
            pygame.draw.circle(surface, COLORS["landmark"], (c - r - 1, row), r)
            pygame.draw.circle(surface, COLORS["landmark_seen"], (c + r + 1, row), r)
            for x in (c - r - 1, c + r + 1):
                pygame.draw.circle(surface, COLORS["landmark_edge"], (x, row), r, width=1)
        elif kind == "belief_landmark":
            rect = pygame.Rect(0, 0, size - 2, self.font_px - 2)
            rect.center = centre
            pygame.draw.ellipse(surface, COLORS["belief_landmark"], rect, width=2)
            self._cross(surface, centre, r - 1, COLORS["belief_landmark"])
        elif kind == "detection":
            pygame.draw.line(surface, COLORS["ray"], (c - half, row), (c + half - 3, row), width=1)
            pygame.draw.circle(surface, COLORS["ray"], (c + half - 3, row), 2)
        elif kind == "visible":
            points = [(c - half, row), (c + half, row - half // 2), (c + half, row + half // 2)]
            pygame.draw.polygon(surface, COLORS["fov"], points)
            pygame.draw.polygon(surface, COLORS["range"], points, width=1)

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
        self._layer = None
        self._labels = {}
        self._font = None

    def __getstate__(self) -> dict[str, Any]:
        # pygame objects do not pickle: drop them (they are rebuilt lazily).
        state = self.__dict__.copy()
        for key in ("_window", "_clock", "_canvas", "_background", "_layer", "_font"):
            state[key] = None
        state["_labels"] = {}
        return state


#: The legend's glyphs (see ``Renderer._draw_glyph``), in reading order, two to a row.
_LEGEND = ("truth", "estimate", "landmark", "belief_landmark", "detection", "visible")


def _format_figures(figures: Any) -> str:
    """The live figures as one line, with their units; non-finite ones as "–"."""
    parts = []
    for name, value in figures.items():
        label, unit, fmt = FIGURE_FORMATS.get(name, (name, "", "{:.4g}"))
        v = float(value)
        shown = fmt.format(v) if math.isfinite(v) else "–"
        parts.append(f"{label} {shown} {unit}".rstrip())
    return "   ".join(parts)
