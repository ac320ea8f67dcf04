"""Generated layouts: random worlds, the named presets, and the world of a config.

- :func:`random_layout` draws a world from a ``numpy.random.Generator`` (all its
  randomness), :func:`preset_layout` builds a named fixed map, :func:`layout_for`
  picks one of those (or a user world, :func:`~slam_env.world.layout_files.load_layout`) for an
  :class:`~slam_env.config.EnvConfig`.
- :func:`landmark_spacing` and :func:`landmark_capacity` say how far apart, and how
  many, the landmarks of a generated world can be.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from slam_env.config import PRESETS, EnvConfig, RobotConfig, WorldConfig
from slam_env.world.layout_files import load_layout
from slam_env.world.layouts import (
    LANDMARK_POST_RADIUS,
    Layout,
    Point,
    as_float,
    box_polygon,
    segment_distance,
)

START_MARGIN = 0.2  # m, free gap kept around generated start poses
PASSAGE_MARGIN = 0.4  # m, generated passages are at least 2·robot radius + this wide
MAX_OBSTACLE_TRIES = 500  # placements tried per random obstacle
MAX_START_TRIES = 2000  # placements tried for a random start pose
MAX_LANDMARK_TRIES = 2000  # candidates tried per random landmark
PRESET_NAMES = tuple(p for p in PRESETS if p != "random")


def _box_distance(px: float, py: float, box: tuple[float, float, float, float]) -> float:
    """Distance from p to an axis-aligned box (cx, cy, w, h); 0 inside."""
    cx, cy, w, h = box
    dx = max(abs(px - cx) - 0.5 * w, 0.0)
    dy = max(abs(py - cy) - 0.5 * h, 0.0)
    return math.hypot(dx, dy)


def _boxes_gap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> float:
    dx = max(abs(a[0] - b[0]) - 0.5 * (a[2] + b[2]), 0.0)
    dy = max(abs(a[1] - b[1]) - 0.5 * (a[3] + b[3]), 0.0)
    return math.hypot(dx, dy)


def _landmark_problem(
    x: float,
    y: float,
    boxes: Sequence[tuple[float, float, float, float]],
    walls: Sequence[tuple[float, float, float, float]],
    wall_thickness: float,
    need: float,
    placed: Sequence[Point],
    spacing: float,
    keep_out: Sequence[tuple[float, float, float]],
) -> str | None:
    """Which constraint a candidate landmark at (x, y) breaks (None: it fits). ``boxes``
    are the (cx, cy, w, h) obstacles, ``need`` the clearance from obstacles and walls;
    the caller keeps the point inside the arena."""
    for box in boxes:
        if _box_distance(x, y, box) < need:
            return "clearance"
    for x0, y0, x1, y1 in walls:
        if segment_distance(x, y, x0, y0, x1, y1) - wall_thickness < need:
            return "clearance"
    for kx, ky, kr in keep_out:
        if math.hypot(x - kx, y - ky) < kr:
            return "start"
    for px, py in placed:
        if math.hypot(x - px, y - py) < spacing:
            return "landmark_spacing"
    return None


def landmark_spacing(cfg: WorldConfig | None) -> float:
    """The least distance (m) between two landmarks: ``cfg.landmark_spacing`` in a
    generated world, the posts' diameter in any (``cfg`` None: a user's layout)."""
    if cfg is None:
        return 2.0 * LANDMARK_POST_RADIUS
    return max(cfg.landmark_spacing, 2.0 * LANDMARK_POST_RADIUS)


def _landmark_need(cfg: WorldConfig) -> float:
    return max(cfg.clearance, LANDMARK_POST_RADIUS)


def landmark_capacity(cfg: WorldConfig) -> int:
    """An upper bound on the landmarks a generated world of ``cfg`` can hold: their
    centres lie in the arena less the clearance on each side, at least the spacing
    apart, and Oler's inequality bounds such a set in a W' × H' rectangle by
    (2/√3)·W'H'/s² + (W' + H')/s + 1 points. Asking for more cannot succeed."""
    need, spacing = _landmark_need(cfg), landmark_spacing(cfg)
    w = max(cfg.width - 2.0 * need, 0.0) / spacing
    h = max(cfg.height - 2.0 * need, 0.0) / spacing
    return math.floor(2.0 / math.sqrt(3.0) * w * h + w + h + 1.0)


def random_layout(cfg: WorldConfig, robot_radius: float, rng: np.random.Generator) -> Layout:
    """Draw a world from ``rng`` (its only source of randomness): ``cfg.n_obstacles``
    axis-aligned boxes with sides in ``cfg.obstacle_size``, kept at least
    2·robot_radius + :data:`PASSAGE_MARGIN` apart and from the arena edge (so the free
    space stays connected); a start pose at least :data:`START_MARGIN` clear of
    everything; and landmarks with IDs 0..n-1 at least ``cfg.landmark_spacing`` apart
    and ``cfg.clearance`` from the walls and obstacles. Raises ``ValueError`` naming the
    constraint when the requested density cannot be placed in a bounded number of tries.
    """
    if not isinstance(cfg, WorldConfig):
        raise TypeError(f"cfg must be a WorldConfig, got {type(cfg).__name__}")
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    r = as_float(robot_radius, "robot_radius")
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"robot_radius must be finite and > 0, got {robot_radius!r}")
    W, H = cfg.width, cfg.height
    gap = 2.0 * r + PASSAGE_MARGIN
    lo, hi = cfg.obstacle_size

    # Obstacles.
    boxes: list[tuple[float, float, float, float]] = []
    if cfg.n_obstacles:
        if lo + 2.0 * gap > min(W, H):
            raise ValueError(
                f"obstacle_size min {lo:g} m plus a {gap:.3g} m passage (2·radius + "
                f"{PASSAGE_MARGIN:g} m) on each side does not fit in the {W:g} × {H:g} m "
                "arena (width × height); lower obstacle_size or radius, enlarge the arena, "
                "or set n_obstacles=0"
            )
        for k in range(cfg.n_obstacles):
            for _ in range(MAX_OBSTACLE_TRIES):
                u = rng.random(4).tolist()  # Python floats: the same values, faster sums
                w = lo + (hi - lo) * u[0]
                h = lo + (hi - lo) * u[1]
                free_x, free_y = W - 2.0 * gap - w, H - 2.0 * gap - h
                if free_x < 0.0 or free_y < 0.0:
                    continue
                box = (gap + 0.5 * w + free_x * u[2], gap + 0.5 * h + free_y * u[3], w, h)
                if all(_boxes_gap(box, b) >= gap for b in boxes):
                    boxes.append((float(box[0]), float(box[1]), float(w), float(h)))
                    break
            else:
                raise ValueError(
                    f"could not place obstacle {k + 1} of n_obstacles={cfg.n_obstacles} in "
                    f"{MAX_OBSTACLE_TRIES} tries: obstacles of {lo:g}–{hi:g} m need "
                    f"{gap:.3g} m passages (2·radius + {PASSAGE_MARGIN:g} m) between them "
                    "and the walls; lower n_obstacles, obstacle_size or radius, or enlarge "
                    "the arena (width, height)"
                )
    obstacles = tuple(box_polygon(*b) for b in boxes)

    # Start pose.
    rs = r + START_MARGIN
    if 2.0 * rs > min(W, H):
        raise ValueError(
            f"the {W:g} × {H:g} m arena (width × height) is too small for the robot "
            f"(radius {r:g} m)"
        )
    for _ in range(MAX_START_TRIES):
        u = rng.random(3).tolist()
        sx, sy = rs + (W - 2.0 * rs) * u[0], rs + (H - 2.0 * rs) * u[1]
        if all(_box_distance(sx, sy, b) >= rs for b in boxes):
            start = (float(sx), float(sy), float(math.pi * (2.0 * u[2] - 1.0)))
            break
    else:
        raise ValueError(
            f"could not find a collision-free start pose in {MAX_START_TRIES} tries: "
            "the obstacles cover the arena; lower n_obstacles or obstacle_size, or enlarge "
            "the arena (width, height)"
        )

    # Landmarks.
    need = _landmark_need(cfg)
    spacing = landmark_spacing(cfg)
    if 2.0 * need >= min(W, H):
        raise ValueError(
            f"clearance {need:g} m leaves no room for landmarks in the {W:g} × {H:g} m "
            "arena (width × height)"
        )
    keep_out = ((start[0], start[1], r + LANDMARK_POST_RADIUS + START_MARGIN),)
    placed: list[Point] = []
    for k in range(cfg.n_landmarks):
        rejected = {"clearance": 0, "landmark_spacing": 0, "start": 0}
        for _ in range(MAX_LANDMARK_TRIES):
            u = rng.random(2).tolist()
            x, y = need + (W - 2.0 * need) * u[0], need + (H - 2.0 * need) * u[1]
            why = _landmark_problem(x, y, boxes, (), 0.0, need, placed, spacing, keep_out)
            if why is None:
                placed.append((float(x), float(y)))
                break
            rejected[why] += 1
        else:
            worst = max(rejected, key=lambda key: rejected[key])
            detail = {
                "landmark_spacing": f"landmark_spacing={cfg.landmark_spacing:g} m",
                "clearance": f"clearance={cfg.clearance:g} m from walls and obstacles",
                "start": "the keep-out zone around the start pose (radius + "
                f"{LANDMARK_POST_RADIUS + START_MARGIN:g} m)",
            }[worst]
            raise ValueError(
                f"could not place landmark {k + 1} of n_landmarks={cfg.n_landmarks} in "
                f"{MAX_LANDMARK_TRIES} tries, mostly rejected by {detail}; lower "
                f"n_landmarks or landmark_spacing, or enlarge the arena (width, height)"
            )
    layout = Layout(
        width=W,
        height=H,
        landmark_ids=tuple(range(len(placed))),
        landmark_positions=tuple(placed),
        obstacles=obstacles,
        walls=(),
        start_pose=start,
        name="random",
    )
    # Valid by construction for this robot and cfg's clearance and wall thickness (the
    # tests hold every layout drawn over the configurations to Layout.validate): not
    # checked again at every reset, where it would cost a fifth of the world's draw.
    return layout


def _frac(k: int, d: int) -> float:
    """A deterministic value in [-1, 1): the additive recurrence k·α_d mod 1 (low
    discrepancy), used for the presets' fixed 'jitter'."""
    alpha = (0.6180339887498949, 0.7548776662466927, 0.5698402909980532)[d % 3]
    return 2.0 * (((k + 1) * alpha) % 1.0) - 1.0


def _halton(i: int, base: int) -> float:
    f, x = 1.0, 0.0
    while i > 0:
        f /= base
        x += f * (i % base)
        i //= base
    return x


def _choose_start(
    layout_parts: dict[str, Any], preferred: Point, robot_radius: float, wall_thickness: float
) -> tuple[float, float, float]:
    """The free point (with START_MARGIN) nearest to ``preferred`` on a 0.25 m lattice."""
    probe = Layout(start_pose=(0.0, 0.0, 0.0), **layout_parts)
    W, H = probe.width, probe.height
    step = 0.25
    px, py = preferred
    cands = [(px, py)] + [
        (i * step, j * step)
        for i in range(1, math.floor(W / step))
        for j in range(1, math.floor(H / step))
    ]
    cands.sort(key=lambda p: ((p[0] - px) ** 2 + (p[1] - py) ** 2, p[0], p[1]))
    for x, y in cands:
        if probe.is_free(x, y, robot_radius, wall_thickness=wall_thickness, margin=START_MARGIN):
            return (float(x), float(y), 0.0)
    raise ValueError(
        f"preset {probe.name!r}: no collision-free start pose for the robot (radius "
        f"{robot_radius:g} m) in the {W:g} × {H:g} m arena (width × height)"
    )


def _halton_landmarks(
    name: str,
    cfg: WorldConfig,
    boxes: Sequence[tuple[float, float, float, float]],
    walls: tuple[tuple[float, float, float, float], ...],
    keep_out: Sequence[tuple[float, float, float]],
) -> list[Point]:
    """``cfg.n_landmarks`` points of the Halton(2, 3) sequence that satisfy the clearance,
    spacing and keep-out constraints (deterministic, evenly spread)."""
    W, H = cfg.width, cfg.height
    need, spacing = _landmark_need(cfg), landmark_spacing(cfg)
    placed: list[Point] = []
    rejected = {"clearance": 0, "landmark_spacing": 0, "start": 0}
    for i in range(1, 200 * cfg.n_landmarks + 1000):
        x = need + (W - 2.0 * need) * _halton(i, 2)
        y = need + (H - 2.0 * need) * _halton(i, 3)
        why = _landmark_problem(
            x, y, boxes, walls, cfg.wall_thickness, need, placed, spacing, keep_out
        )
        if why is None:
            placed.append((x, y))
            if len(placed) == cfg.n_landmarks:
                return placed
        else:
            rejected[why] += 1
    worst = max(rejected, key=lambda key: rejected[key])
    raise ValueError(
        f"preset {name!r}: only {len(placed)} of n_landmarks={cfg.n_landmarks} landmarks fit "
        f"in the {W:g} × {H:g} m arena (mostly rejected by {worst}); lower n_landmarks or "
        f"landmark_spacing, or enlarge the arena"
    )


def _furnished(
    name: str,
    cfg: WorldConfig,
    robot_radius: float,
    preferred_start: Point,
    boxes: Sequence[tuple[float, float, float, float]] = (),
    walls: tuple[tuple[float, float, float, float], ...] = (),
    keep_out: tuple[tuple[float, float, float], ...] = (),
) -> Layout:
    """Preset ``name`` from its obstacle ``boxes`` (cx, cy, w, h) and inner ``walls``:
    the free start nearest ``preferred_start``, then the Halton landmarks clear of the
    start and of the ``keep_out`` discs (x, y, radius)."""
    parts = {
        "width": cfg.width,
        "height": cfg.height,
        "landmark_ids": (),
        "landmark_positions": (),
        "obstacles": tuple(box_polygon(*b) for b in boxes),
        "walls": walls,
        "name": name,
    }
    start = _choose_start(parts, preferred_start, robot_radius, cfg.wall_thickness)
    around_start = (start[0], start[1], robot_radius + LANDMARK_POST_RADIUS + START_MARGIN)
    pts = _halton_landmarks(name, cfg, boxes, walls, (around_start, *keep_out))
    parts.update(landmark_ids=tuple(range(len(pts))), landmark_positions=tuple(pts))
    return Layout(start_pose=start, **parts)  # type: ignore[arg-type]


def _open_preset(cfg: WorldConfig, robot_radius: float) -> Layout:
    W, H, n = cfg.width, cfg.height, cfg.n_landmarks
    need = _landmark_need(cfg)
    cols = max(1, round(math.sqrt(n * W / H)))
    rows = math.ceil(n / cols)
    cw, ch = W / cols, H / rows
    cells = rows * cols
    pts: list[Point] = []
    for k in range(n):
        c = (k * cells) // n  # spread the n landmarks over the cells
        row, col = divmod(c, cols)
        x = (col + 0.5) * cw + 0.25 * cw * _frac(k, 0)
        y = (row + 0.5) * ch + 0.25 * ch * _frac(k, 1)
        pts.append((min(max(x, need), W - need), min(max(y, need), H - need)))
    spacing = landmark_spacing(cfg)
    for i in range(n):
        for j in range(i):
            if math.dist(pts[i], pts[j]) < spacing:
                raise ValueError(
                    f"preset 'open': n_landmarks={n} on a {cols}×{rows} grid in the "
                    f"{W:g} × {H:g} m arena breaks landmark_spacing={cfg.landmark_spacing:g} m"
                )
    parts = {
        "width": W,
        "height": H,
        "landmark_ids": tuple(range(n)),
        "landmark_positions": tuple(pts),
        "name": "open",
    }
    start = _choose_start(parts, (0.5 * W, 0.5 * H), robot_radius, cfg.wall_thickness)
    return Layout(start_pose=start, **parts)  # type: ignore[arg-type]


def _cluttered_preset(cfg: WorldConfig, robot_radius: float) -> Layout:
    W, H = cfg.width, cfg.height
    gap = 2.0 * robot_radius + PASSAGE_MARGIN
    lo, hi = cfg.obstacle_size
    pitch = 3.0  # m, target spacing of the obstacle lattice
    inner_w, inner_h = W - 2.0 * gap, H - 2.0 * gap
    nx = max(1, round(inner_w / pitch))
    ny = max(1, round(inner_h / pitch))
    if inner_w / nx - gap < lo:
        nx = math.floor(inner_w / (lo + gap))
    if inner_h / ny - gap < lo:
        ny = math.floor(inner_h / (lo + gap))
    if nx < 1 or ny < 1:
        raise ValueError(
            f"preset 'cluttered': the {W:g} × {H:g} m arena (width × height) is too small "
            f"for obstacles of {lo:g} m (obstacle_size) with {gap:.3g} m passages (2·radius "
            f"+ {PASSAGE_MARGIN:g} m)"
        )
    cw, ch = inner_w / nx, inner_h / ny
    boxes: list[tuple[float, float, float, float]] = []
    k = 0
    for j in range(ny):
        for i in range(nx):
            w = min(lo + (hi - lo) * 0.5 * (1.0 + _frac(k, 0)), cw - gap)
            h = min(lo + (hi - lo) * 0.5 * (1.0 + _frac(k, 1)), ch - gap)
            slack_x, slack_y = 0.5 * (cw - gap - w), 0.5 * (ch - gap - h)
            cx = gap + (i + 0.5) * cw + slack_x * _frac(k, 2)
            cy = gap + (j + 0.5) * ch + slack_y * _frac(k + 7, 2)
            boxes.append((cx, cy, w, h))
            k += 1
    # Leave the lattice cell nearest the arena centre empty for the start.
    centre = (0.5 * W, 0.5 * H)
    boxes.pop(min(range(len(boxes)), key=lambda m: math.dist(centre, boxes[m][:2])))
    return _furnished("cluttered", cfg, robot_radius, centre, boxes=boxes)


def _rooms_preset(cfg: WorldConfig, robot_radius: float) -> Layout:
    W, H, t = cfg.width, cfg.height, cfg.wall_thickness
    door = 2.0 * (robot_radius + t) + 2.0 * PASSAGE_MARGIN  # m, gap between wall ends
    nx = max(2, round(W / 7.0))
    ny = max(2, round(H / 7.0))
    rw, rh = W / nx, H / ny
    if min(rw, rh) < 2.0 * door + 2.0 * t:
        raise ValueError(
            f"preset 'rooms': the {W:g} × {H:g} m arena (width × height) is too small for "
            f"{nx}×{ny} rooms with {door:.3g} m doors (2·(radius + wall_thickness) + "
            f"{2.0 * PASSAGE_MARGIN:g} m)"
        )
    walls: list[tuple[float, float, float, float]] = []
    doors: list[Point] = []
    k = 0

    def wall_with_door(a: float, b: float, fixed: float, vertical: bool) -> None:
        nonlocal k
        # Doors alternate between 1/3 and 2/3 of each span, so routes zig-zag.
        frac = (1.0 / 3.0, 2.0 / 3.0)[k % 2]
        k += 1
        lo_end = a + t + 0.5 * door
        hi_end = b - t - 0.5 * door
        dc = min(max(a + frac * (b - a), lo_end), hi_end)
        for s0, s1 in ((a, dc - 0.5 * door), (dc + 0.5 * door, b)):
            walls.append((fixed, s0, fixed, s1) if vertical else (s0, fixed, s1, fixed))
        doors.append((fixed, dc) if vertical else (dc, fixed))

    for i in range(1, nx):  # vertical walls, one door per room they separate
        for j in range(ny):
            wall_with_door(j * rh, (j + 1) * rh, i * rw, vertical=True)
    for j in range(1, ny):  # horizontal walls
        for i in range(nx):
            wall_with_door(i * rw, (i + 1) * rw, j * rh, vertical=False)
    # Keep doorways clear: a post there would block the passage.
    keep_out = tuple((x, y, door) for x, y in doors)
    return _furnished(
        "rooms", cfg, robot_radius, (0.5 * rw, 0.5 * rh), walls=tuple(walls), keep_out=keep_out
    )


@functools.lru_cache(maxsize=32)
def _preset_cached(name: str, cfg: WorldConfig, robot_radius: float) -> Layout:
    builder = {"open": _open_preset, "cluttered": _cluttered_preset, "rooms": _rooms_preset}
    layout = builder[name](cfg, robot_radius)
    return layout.validate(robot_radius, cfg.clearance, wall_thickness=cfg.wall_thickness)


def preset_layout(
    name: str, cfg: WorldConfig, robot_radius: float = RobotConfig().radius
) -> Layout:
    """A named fixed map sized from ``cfg.width``/``cfg.height`` with ``cfg.n_landmarks``
    landmarks (IDs 0..n-1), deterministic (no randomness), valid for ``robot_radius``:

    - ``"open"``: no obstacles, landmarks on a jittered grid;
    - ``"cluttered"``: a lattice of boxes (sides from ``cfg.obstacle_size``) with
      passages of at least 2·robot_radius + :data:`PASSAGE_MARGIN`;
    - ``"rooms"``: inner walls splitting the arena into rooms joined by doors.

    Raises ``ValueError`` when the arena cannot hold the map or its landmarks."""
    if not isinstance(cfg, WorldConfig):
        raise TypeError(f"cfg must be a WorldConfig, got {type(cfg).__name__}")
    if name not in PRESET_NAMES:
        raise ValueError(f"unknown preset {name!r}; presets: {', '.join(PRESET_NAMES)}")
    r = as_float(robot_radius, "robot_radius")
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"robot_radius must be finite and > 0, got {robot_radius!r}")
    return _preset_cached(name, cfg, r)


def layout_for(config: EnvConfig, rng: np.random.Generator | None = None) -> Layout:
    """The world for ``config``: ``config.layout`` (a Layout, dict or JSON/YAML path),
    validated for the robot (landmark clearance: only the post radius), else the preset
    ``config.world.preset``, else a random world drawn from ``rng`` (required then):
    valid for the robot and the wall thickness in every case."""
    if not isinstance(config, EnvConfig):
        raise TypeError(f"config must be an EnvConfig, got {type(config).__name__}")
    if config.layout is not None:
        layout = load_layout(config.layout)
        return layout.validate(config.robot.radius, wall_thickness=config.world.wall_thickness)
    if config.world.preset != "random":
        return preset_layout(config.world.preset, config.world, config.robot.radius)
    if rng is None:
        raise ValueError("a random world (preset='random') needs an rng")
    return random_layout(config.world, config.robot.radius, rng)
