"""World layouts: the arena, obstacles, inner walls, landmarks and start pose.

A :class:`Layout` is plain data (no pymunk): random worlds are drawn from a seed,
presets are named maps, and user worlds come from a dict or a JSON/YAML file.

- :meth:`Layout.validate` checks a layout against a robot and raises ``ValueError``
  naming the first problem found.
- :func:`random_layout` draws a world from a ``numpy.random.Generator`` (all its
  randomness), :func:`preset_layout` builds a named fixed map, :func:`layout_for`
  picks one of those (or a user world) for an :class:`~slam_env.config.EnvConfig`.
- :func:`layout_from_dict` / :func:`layout_to_dict` / :func:`load_layout` read and write
  the dict schema (JSON/YAML)::

      {"name": "demo", "width": 10, "height": 8,
       "landmarks": [{"id": 0, "x": 2, "y": 3}, ...],   # or [[x, y], ...]: IDs 0..N-1
       "obstacles": [[[x, y], [x, y], [x, y]], {"box": [cx, cy, w, h]}, ...],
       "walls": [[x0, y0, x1, y1], ...],
       "start": [x, y, theta]}

Geometry conventions: the arena is [0, width] × [0, height] and its boundary walls
lie outside it (their inner face is the arena edge). Inner walls are segments of
half-thickness ``wall_thickness`` (the pymunk segment radius). Every landmark is a
physical post of radius :data:`LANDMARK_POST_RADIUS`.
"""

from __future__ import annotations

import functools
import json
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from slam_env.config import PRESETS, EnvConfig, RobotConfig, WorldConfig

Point = tuple[float, float]

LANDMARK_POST_RADIUS = 0.1  # m, radius of the physical post at each landmark
DEFAULT_WALL_THICKNESS = WorldConfig().wall_thickness  # m, wall segment radius
START_MARGIN = 0.2  # m, free gap kept around generated start poses
PASSAGE_MARGIN = 0.4  # m, generated passages are at least 2·robot radius + this wide
MAX_OBSTACLE_TRIES = 500  # placements tried per random obstacle
MAX_START_TRIES = 2000  # placements tried for a random start pose
MAX_LANDMARK_TRIES = 2000  # candidates tried per random landmark
PRESET_NAMES = tuple(p for p in PRESETS if p != "random")

_DICT_KEYS = ("name", "width", "height", "landmarks", "obstacles", "walls", "start")
_EPS = 1e-9  # m, tolerance for geometric comparisons on user input


# --------------------------------------------------------------------------- geometry


def _segment_distance(px: float, py: float, x0: float, y0: float, x1: float, y1: float) -> float:
    """Distance (m) from point p to the segment (x0, y0)–(x1, y1)."""
    ex, ey = x1 - x0, y1 - y0
    dx, dy = px - x0, py - y0
    ee = ex * ex + ey * ey
    if ee > 0.0:
        t = (dx * ex + dy * ey) / ee
        if t >= 1.0:
            dx, dy = px - x1, py - y1
        elif t > 0.0:
            dx -= t * ex
            dy -= t * ey
    return math.hypot(dx, dy)


def _polygon_signed_distance(px: float, py: float, poly: Sequence[Point]) -> float:
    """Signed distance (m) from p to a convex counter-clockwise polygon: negative inside."""
    inside = True
    best = math.inf
    x0, y0 = poly[-1]
    for x1, y1 in poly:
        ex, ey = x1 - x0, y1 - y0
        dx, dy = px - x0, py - y0
        if ex * dy - ey * dx < 0.0:
            inside = False
        ee = ex * ex + ey * ey
        t = (dx * ex + dy * ey) / ee if ee > 0.0 else 0.0
        if t >= 1.0:
            dx, dy = px - x1, py - y1
        elif t > 0.0:
            dx -= t * ex
            dy -= t * ey
        d2 = dx * dx + dy * dy
        if d2 < best:
            best = d2
        x0, y0 = x1, y1
    best = math.sqrt(best)
    return -best if inside else best


def _bbox_distance(px: float, py: float, bbox: tuple[float, float, float, float]) -> float:
    """Distance (m) from p to a bounding box (xmin, ymin, xmax, ymax); 0 inside. A lower
    bound of the distance to anything inside the box."""
    dx = max(bbox[0] - px, 0.0, px - bbox[2])
    dy = max(bbox[1] - py, 0.0, py - bbox[3])
    return math.hypot(dx, dy)


def _signed_area(poly: Sequence[Point]) -> float:
    n = len(poly)
    s = 0.0
    for i in range(n):
        x0, y0 = poly[i]
        x1, y1 = poly[(i + 1) % n]
        s += x0 * y1 - x1 * y0
    return 0.5 * s


def _polygon_problem(poly: Sequence[Point]) -> str | None:
    """Why ``poly`` is not a usable convex obstacle (either winding), or None."""
    n = len(poly)
    if n < 3:
        return f"is degenerate: it has {n} vertices, needs at least 3"
    # Tolerances relative to the polygon's own size, measured from its first vertex: its
    # position (far from the origin in a large arena) must not make it look degenerate.
    ox, oy = poly[0]
    local = [(x - ox, y - oy) for x, y in poly]
    scale = max(max(abs(x), abs(y)) for x, y in local) or 1.0
    for i in range(n):
        (x0, y0), (x1, y1) = local[i], local[(i + 1) % n]
        if math.hypot(x1 - x0, y1 - y0) <= _EPS * scale:
            return f"is degenerate: vertex {i} repeats vertex {(i + 1) % n}"
    area = _signed_area(local)
    if abs(area) <= _EPS * scale * scale:
        return "is degenerate: it has zero area"
    sign = 1.0 if area > 0 else -1.0
    turning = 0.0
    for i in range(n):
        (x0, y0), (x1, y1), (x2, y2) = poly[i], poly[(i + 1) % n], poly[(i + 2) % n]
        ax, ay, bx, by = x1 - x0, y1 - y0, x2 - x1, y2 - y1
        cross = ax * by - ay * bx
        if sign * cross < -_EPS * math.hypot(ax, ay) * math.hypot(bx, by):
            return f"is not convex (reflex turn at vertex {(i + 1) % n})"
        turning += math.atan2(cross, ax * bx + ay * by)
    if abs(abs(turning) - 2.0 * math.pi) > 1e-6:
        return "is not convex (its edges cross each other)"
    return None


def _box(cx: float, cy: float, w: float, h: float) -> tuple[Point, ...]:
    """An axis-aligned box as a counter-clockwise polygon."""
    hw, hh = 0.5 * w, 0.5 * h
    return ((cx - hw, cy - hh), (cx + hw, cy - hh), (cx + hw, cy + hh), (cx - hw, cy + hh))


def _fmt(*values: float) -> str:
    return ", ".join(f"{v:.4g}" for v in values)


def _landmark_at(lid: int, x: float, y: float) -> str:
    """How an error message names a landmark."""
    return f"landmark ID {lid} at ({_fmt(x, y)})"


# --------------------------------------------------------------------------- type coercion


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _as_float(value: Any, what: str) -> float:
    if not _is_number(value):
        raise TypeError(f"{what} must be a number, got {type(value).__name__}")
    return float(value)


def _as_int(value: Any, what: str) -> int:
    if type(value) is int:  # the common case, already what int() would give
        return value
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{what} must be an int, got {type(value).__name__}")
    return int(value)


def _as_list(value: Any, what: str) -> list[Any]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Iterable, np.ndarray)):
        raise TypeError(f"{what} must be a sequence, got {type(value).__name__}")
    return list(value)


def _as_floats(value: Any, n: int, what: str) -> tuple[float, ...]:
    if type(value) is tuple and len(value) == n and all(type(v) is float for v in value):
        return value  # already what the coercion below makes (a generated layout's)
    items = _as_list(value, what)
    if len(items) != n:
        raise ValueError(f"{what} must have {n} numbers, got {len(items)}")
    return tuple(_as_float(v, f"{what}[{i}]") for i, v in enumerate(items))


def _as_polygon(value: Any, what: str) -> tuple[Point, ...]:
    pts = tuple(_as_floats(p, 2, f"{what} vertex {j}") for j, p in enumerate(_as_list(value, what)))
    # Normalise to counter-clockwise; degenerate shapes are left for validate().
    if len(pts) >= 3 and _signed_area(pts) < 0.0:
        pts = pts[::-1]
    return pts  # type: ignore[return-value]


# --------------------------------------------------------------------------- Layout


@dataclass(frozen=True)
class Layout:
    """A world. The arena is the rectangle [0, width] × [0, height] (m), closed by
    boundary walls that are implicit (not listed in ``walls``).

    Attributes:
        width, height: arena size, m.
        landmark_ids: (N,) distinct non-negative ints.
        landmark_positions: (N,) (x, y) points, m, in the same order as the IDs.
        obstacles: convex polygons, each a tuple of (x, y) vertices, m.
        walls: inner wall segments (x0, y0, x1, y1), m (rooms and corridors).
        start_pose: the robot's start (x, y, θ), m and rad.
        name: a label for plots and logs.

    Construction normalises the containers to tuples of Python floats/ints (numpy
    arrays and lists are accepted) and obstacle vertices to counter-clockwise order;
    a value of the wrong type raises ``TypeError``. Everything else (finiteness,
    geometry, IDs) is checked by :meth:`validate`.
    """

    width: float
    height: float
    landmark_ids: tuple[int, ...]
    landmark_positions: tuple[Point, ...]
    obstacles: tuple[tuple[Point, ...], ...] = ()
    walls: tuple[tuple[float, float, float, float], ...] = ()
    start_pose: tuple[float, float, float] = (1.0, 1.0, 0.0)
    name: str = "custom"

    def __post_init__(self) -> None:
        fields: dict[str, Any] = {
            "width": _as_float(self.width, "Layout.width"),
            "height": _as_float(self.height, "Layout.height"),
            "landmark_ids": tuple(
                _as_int(v, f"Layout.landmark_ids[{i}]")
                for i, v in enumerate(_as_list(self.landmark_ids, "Layout.landmark_ids"))
            ),
            "landmark_positions": tuple(
                _as_floats(p, 2, f"Layout.landmark_positions[{i}]")
                for i, p in enumerate(
                    _as_list(self.landmark_positions, "Layout.landmark_positions")
                )
            ),
            "obstacles": tuple(
                _as_polygon(p, f"Layout.obstacles[{k}]")
                for k, p in enumerate(_as_list(self.obstacles, "Layout.obstacles"))
            ),
            "walls": tuple(
                _as_floats(w, 4, f"Layout.walls[{k}]")
                for k, w in enumerate(_as_list(self.walls, "Layout.walls"))
            ),
            "start_pose": _as_floats(self.start_pose, 3, "Layout.start_pose"),
        }
        if not isinstance(self.name, str):
            raise TypeError(f"Layout.name must be a str, got {type(self.name).__name__}")
        for key, value in fields.items():
            object.__setattr__(self, key, value)
        # Bounding boxes (xmin, ymin, xmax, ymax) of the obstacles, for quick rejects;
        # not a dataclass field, so equality and hashing ignore it.
        object.__setattr__(
            self,
            "_obstacle_bboxes",
            tuple(
                (
                    min(x for x, _ in p),
                    min(y for _, y in p),
                    max(x for x, _ in p),
                    max(y for _, y in p),
                )
                if p
                else (math.inf, math.inf, -math.inf, -math.inf)
                for p in fields["obstacles"]
            ),
        )

    @property
    def n_landmarks(self) -> int:
        return len(self.landmark_ids)

    def landmark_array(self) -> np.ndarray:
        """(N, 2) float64 landmark positions, a fresh array."""
        return np.array(self.landmark_positions, dtype=np.float64).reshape(-1, 2)

    def id_array(self) -> np.ndarray:
        """(N,) int64 landmark IDs, a fresh array."""
        return np.array(self.landmark_ids, dtype=np.int64)

    # ----------------------------------------------------------------- collision queries

    def collision_reason(
        self,
        x: float,
        y: float,
        radius: float,
        *,
        wall_thickness: float = DEFAULT_WALL_THICKNESS,
        margin: float = 0.0,
    ) -> str | None:
        """What a disc of ``radius`` (m) at (x, y) overlaps, with ``margin`` (m) of extra
        room required: the arena boundary, an obstacle, an inner wall or a landmark post;
        None when it is free. Touching (distance exactly equal) counts as free."""
        r = radius + margin
        if not (math.isfinite(x) and math.isfinite(y)):
            return "is not finite"
        if (
            x - r < -_EPS
            or y - r < -_EPS
            or x + r > self.width + _EPS
            or y + r > self.height + _EPS
        ):
            return "overlaps the arena boundary"
        for k, (poly, bbox) in enumerate(zip(self.obstacles, self._obstacle_bboxes, strict=True)):
            if _bbox_distance(x, y, bbox) < r and _polygon_signed_distance(x, y, poly) < r - _EPS:
                return f"overlaps obstacle {k}"
        rw = r + wall_thickness
        for k, (x0, y0, x1, y1) in enumerate(self.walls):
            if _segment_distance(x, y, x0, y0, x1, y1) < rw - _EPS:
                return f"overlaps wall {k}"
        rp = r + LANDMARK_POST_RADIUS
        for lid, (lx, ly) in zip(self.landmark_ids, self.landmark_positions, strict=False):
            if math.hypot(x - lx, y - ly) < rp - _EPS:
                return f"overlaps the post of landmark ID {lid}"
        return None

    def is_free(
        self,
        x: float,
        y: float,
        radius: float,
        *,
        wall_thickness: float = DEFAULT_WALL_THICKNESS,
        margin: float = 0.0,
    ) -> bool:
        """True when a disc of ``radius`` (m) at (x, y) fits with ``margin`` to spare."""
        return (
            self.collision_reason(x, y, radius, wall_thickness=wall_thickness, margin=margin)
            is None
        )

    # ----------------------------------------------------------------- validation

    def validate(
        self,
        robot_radius: float,
        clearance: float = 0.0,
        *,
        wall_thickness: float = DEFAULT_WALL_THICKNESS,
    ) -> Layout:
        """Check the layout for a robot of ``robot_radius`` (m); return ``self``.

        Raises ``ValueError`` naming the first problem: non-finite numbers, mismatched
        ``landmark_ids``/``landmark_positions`` lengths, negative or duplicate IDs,
        degenerate or non-convex obstacles, obstacles or walls outside the arena,
        zero-length walls, a landmark outside the arena, inside an obstacle or wall, or
        closer than ``max(clearance, LANDMARK_POST_RADIUS)`` (m) to the arena boundary,
        an obstacle or a wall face, two landmark posts overlapping, and a start pose
        whose robot disc leaves the arena or overlaps an obstacle, wall or post.
        ``wall_thickness`` (m) is the inner walls' half-thickness, as in the world.
        """
        for name, value in (
            ("robot_radius", robot_radius),
            ("clearance", clearance),
            ("wall_thickness", wall_thickness),
        ):
            if not _is_number(value) or not math.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if robot_radius <= 0:
            raise ValueError(f"robot_radius must be > 0, got {robot_radius!r}")
        W, H = self.width, self.height
        if not (math.isfinite(W) and math.isfinite(H)) or W <= 0 or H <= 0:
            raise ValueError(f"arena size must be finite and > 0, got width={W}, height={H}")

        # Landmark bookkeeping.
        ids, pos = self.landmark_ids, self.landmark_positions
        if len(ids) != len(pos):
            raise ValueError(
                f"landmark_ids has {len(ids)} entries but landmark_positions has {len(pos)}"
            )
        seen: set[int] = set()
        for i, (lid, (lx, ly)) in enumerate(zip(ids, pos, strict=True)):
            if lid < 0:
                raise ValueError(f"negative landmark ID {lid} (landmark {i})")
            if lid in seen:
                raise ValueError(f"duplicate landmark ID {lid}")
            seen.add(lid)
            if not (math.isfinite(lx) and math.isfinite(ly)):
                raise ValueError(f"landmark ID {lid} has a non-finite position ({lx}, {ly})")

        # Obstacles and walls.
        for k, poly in enumerate(self.obstacles):
            if not all(math.isfinite(c) for p in poly for c in p):
                raise ValueError(f"obstacle {k} has a non-finite vertex")
            problem = _polygon_problem(poly)
            if problem is not None:
                raise ValueError(f"obstacle {k} {problem}")
            for x, y in poly:
                if not (-_EPS <= x <= W + _EPS and -_EPS <= y <= H + _EPS):
                    raise ValueError(
                        f"obstacle {k} extends outside the arena: vertex ({_fmt(x, y)}) is "
                        f"not in [0, {W:g}] × [0, {H:g}]"
                    )
        for k, (x0, y0, x1, y1) in enumerate(self.walls):
            if not all(math.isfinite(c) for c in (x0, y0, x1, y1)):
                raise ValueError(f"wall {k} has a non-finite coordinate")
            if math.hypot(x1 - x0, y1 - y0) <= _EPS:
                raise ValueError(f"wall {k} has zero length")
            for x, y in ((x0, y0), (x1, y1)):
                if not (-_EPS <= x <= W + _EPS and -_EPS <= y <= H + _EPS):
                    raise ValueError(
                        f"wall {k} extends outside the arena: end ({_fmt(x, y)}) is not in "
                        f"[0, {W:g}] × [0, {H:g}]"
                    )

        # Landmark placement.
        need = max(clearance, LANDMARK_POST_RADIUS)
        boxes = self._obstacle_bboxes
        for lid, (lx, ly) in zip(ids, pos, strict=True):
            if not (0.0 <= lx <= W and 0.0 <= ly <= H):
                raise ValueError(
                    f"{_landmark_at(lid, lx, ly)} is outside the arena [0, {W:g}] × [0, {H:g}]"
                )
            d = min(lx, W - lx, ly, H - ly)
            if d < need - _EPS:
                raise ValueError(
                    f"{_landmark_at(lid, lx, ly)} is {d:.3g} m from the arena boundary, "
                    f"closer than the clearance/post radius {need:.3g} m"
                )
            for k, (poly, bbox) in enumerate(zip(self.obstacles, boxes, strict=True)):
                if _bbox_distance(lx, ly, bbox) >= need:
                    continue
                d = _polygon_signed_distance(lx, ly, poly)
                if d < 0.0:
                    raise ValueError(f"{_landmark_at(lid, lx, ly)} is inside obstacle {k}")
                if d < need - _EPS:
                    raise ValueError(
                        f"{_landmark_at(lid, lx, ly)} is {d:.3g} m from obstacle {k}, "
                        f"closer than the clearance/post radius {need:.3g} m"
                    )
            for k, (x0, y0, x1, y1) in enumerate(self.walls):
                d = _segment_distance(lx, ly, x0, y0, x1, y1) - wall_thickness
                if d < 0.0:
                    raise ValueError(f"{_landmark_at(lid, lx, ly)} is inside wall {k}")
                if d < need - _EPS:
                    raise ValueError(
                        f"{_landmark_at(lid, lx, ly)} is {d:.3g} m from wall {k}, closer than the "
                        f"clearance/post radius {need:.3g} m"
                    )
        if len(pos) > 1:
            p = np.asarray(pos, dtype=np.float64)
            d2 = np.sum((p[:, None, :] - p[None, :, :]) ** 2, axis=-1)
            d2[np.diag_indices(len(pos))] = np.inf
            i, j = np.unravel_index(int(np.argmin(d2)), d2.shape)
            dmin = math.sqrt(float(d2[i, j]))
            if dmin < 2.0 * LANDMARK_POST_RADIUS - _EPS:
                a, b = sorted((ids[i], ids[j]))
                raise ValueError(
                    f"landmark posts of ID {a} and ID {b} overlap: {dmin:.3g} m apart, "
                    f"posts need {2.0 * LANDMARK_POST_RADIUS:.3g} m"
                )

        # Start pose.
        sx, sy, _ = self.start_pose
        if not all(math.isfinite(c) for c in self.start_pose):
            raise ValueError(f"start_pose is not finite: {self.start_pose}")
        if not (0.0 <= sx <= W and 0.0 <= sy <= H):
            raise ValueError(f"start pose ({_fmt(sx, sy)}) is outside the arena")
        reason = self.collision_reason(sx, sy, robot_radius, wall_thickness=wall_thickness)
        if reason is not None:
            raise ValueError(
                f"start pose ({_fmt(sx, sy)}) is in collision: the robot "
                f"(radius {robot_radius:g} m) {reason}"
            )
        return self


# --------------------------------------------------------------------------- dict / files


def _landmarks_from(value: Any) -> tuple[tuple[int, ...], tuple[Point, ...]]:
    items = _as_list(value, "layout 'landmarks'")
    if not items:
        return (), ()
    as_dicts = [isinstance(it, Mapping) for it in items]
    if any(as_dicts) and not all(as_dicts):
        raise ValueError(
            "layout 'landmarks' mixes {id, x, y} entries and [x, y] pairs; use one form"
        )
    if not as_dicts[0]:
        pts = tuple(
            _as_floats(p, 2, f"layout 'landmarks'[{i}]")  # type: ignore[misc]
            for i, p in enumerate(items)
        )
        return tuple(range(len(pts))), pts  # type: ignore[return-value]
    ids, pts = [], []
    for i, it in enumerate(items):
        keys = set(it)
        if keys != {"id", "x", "y"}:
            extra = sorted(map(str, keys - {"id", "x", "y"}))
            missing = sorted({"id", "x", "y"} - keys)
            raise ValueError(
                f"layout 'landmarks'[{i}] must have keys id, x, y"
                + (f"; unknown: {', '.join(extra)}" if extra else "")
                + (f"; missing: {', '.join(missing)}" if missing else "")
            )
        ids.append(_as_int(it["id"], f"layout 'landmarks'[{i}].id"))
        pts.append(
            (
                _as_float(it["x"], f"layout 'landmarks'[{i}].x"),
                _as_float(it["y"], f"layout 'landmarks'[{i}].y"),
            )
        )
    return tuple(ids), tuple(pts)


def _obstacle_from(value: Any, k: int) -> Any:
    what = f"layout 'obstacles'[{k}]"
    if isinstance(value, Mapping):
        if set(value) != {"box"}:
            unknown = sorted(map(str, set(value) - {"box"}))
            raise ValueError(
                f"{what} must be a vertex list or {{'box': [cx, cy, w, h]}}"
                + (f"; unknown keys: {', '.join(unknown)}" if unknown else "")
            )
        cx, cy, w, h = _as_floats(value["box"], 4, f"{what}.box")
        if not (w > 0 and h > 0):
            raise ValueError(f"{what}.box needs width and height > 0, got w={w}, h={h}")
        return _box(cx, cy, w, h)
    return _as_polygon(value, what)


def layout_from_dict(d: Mapping[str, Any]) -> Layout:
    """Build a :class:`Layout` from the dict schema in the module docstring. Unknown keys
    raise ``ValueError`` naming them; values of the wrong type raise ``TypeError``.
    ``width`` and ``height`` are required; ``start`` defaults to (1, 1, 0). The result is
    not yet checked against a robot: call :meth:`Layout.validate`."""
    if not isinstance(d, Mapping):
        raise TypeError(f"a layout must be a mapping, got {type(d).__name__}")
    unknown = [k for k in d if k not in _DICT_KEYS]
    if unknown:
        raise ValueError(
            f"unknown layout key(s): {', '.join(map(repr, unknown))}; valid keys: "
            f"{', '.join(_DICT_KEYS)}"
        )
    for key in ("width", "height"):
        if key not in d:
            raise ValueError(f"layout is missing {key!r}")
    ids, pts = _landmarks_from(d.get("landmarks", []))
    obstacles = tuple(
        _obstacle_from(o, k)
        for k, o in enumerate(_as_list(d.get("obstacles", []), "layout 'obstacles'"))
    )
    walls = tuple(
        _as_floats(w, 4, f"layout 'walls'[{k}]")
        for k, w in enumerate(_as_list(d.get("walls", []), "layout 'walls'"))
    )
    kwargs: dict[str, Any] = {}
    if "start" in d:
        kwargs["start_pose"] = _as_floats(d["start"], 3, "layout 'start'")
    if "name" in d:
        if not isinstance(d["name"], str):
            raise TypeError(f"layout 'name' must be a str, got {type(d['name']).__name__}")
        kwargs["name"] = d["name"]
    return Layout(
        width=_as_float(d["width"], "layout 'width'"),
        height=_as_float(d["height"], "layout 'height'"),
        landmark_ids=ids,
        landmark_positions=pts,
        obstacles=obstacles,
        walls=walls,
        **kwargs,
    )


def layout_to_dict(layout: Layout) -> dict[str, Any]:
    """The dict schema of ``layout`` (plain Python types, JSON/YAML ready), such that
    ``layout_from_dict(layout_to_dict(layout)) == layout``."""
    if not isinstance(layout, Layout):
        raise TypeError(f"expected a Layout, got {type(layout).__name__}")
    return {
        "name": layout.name,
        "width": layout.width,
        "height": layout.height,
        "landmarks": [
            {"id": i, "x": x, "y": y}
            for i, (x, y) in zip(layout.landmark_ids, layout.landmark_positions, strict=True)
        ],
        "obstacles": [[[x, y] for x, y in poly] for poly in layout.obstacles],
        "walls": [list(w) for w in layout.walls],
        "start": list(layout.start_pose),
    }


def load_layout(source: Layout | Mapping[str, Any] | str | os.PathLike[str]) -> Layout:
    """A :class:`Layout` from a Layout (returned as is), a dict (the schema of
    :func:`layout_from_dict`) or a ``.json``/``.yaml``/``.yml`` file path. A file that
    cannot be read or parsed raises ``ValueError`` naming it (and the line, when the
    parser knows it); so does a problem with its content (``TypeError`` for a value of
    the wrong type)."""
    if isinstance(source, Layout):
        return source
    if isinstance(source, Mapping):
        return layout_from_dict(source)
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(
            f"a layout must be a Layout, a dict or a file path, got {type(source).__name__}"
        )
    path = Path(source)
    name = repr(str(path))
    if path.suffix.lower() not in (".json", ".yaml", ".yml"):
        raise ValueError(f"layout file {name} must end in .json, .yaml or .yml")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ValueError(f"layout file {name} cannot be read: {reason}") from exc
    data = _parse_layout_text(text, path.suffix.lower(), name)
    if not isinstance(data, Mapping):
        raise TypeError(f"layout file {name} must hold a mapping, got {type(data).__name__}")
    try:
        return layout_from_dict(data)
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"layout file {name}: {exc}") from exc


def _parse_layout_text(text: str, suffix: str, name: str) -> Any:
    """The data of a layout file's text; ``ValueError`` naming the file and the line."""
    if suffix == ".json":
        try:
            return json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(
                f"layout file {name}, line {exc.lineno}: not valid JSON: {exc.msg}"
            ) from exc
    import yaml

    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f", line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ValueError(f"layout file {name}{where}: not valid YAML: {problem}") from exc


# --------------------------------------------------------------------------- generators


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
        if _segment_distance(x, y, x0, y0, x1, y1) - wall_thickness < need:
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
    r = _as_float(robot_radius, "robot_radius")
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
                u = rng.random(4)
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
    obstacles = tuple(_box(*b) for b in boxes)

    # Start pose.
    rs = r + START_MARGIN
    if 2.0 * rs > min(W, H):
        raise ValueError(
            f"the {W:g} × {H:g} m arena (width × height) is too small for the robot "
            f"(radius {r:g} m)"
        )
    for _ in range(MAX_START_TRIES):
        u = rng.random(3)
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
            u = rng.random(2)
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
    return layout.validate(r, cfg.clearance, wall_thickness=cfg.wall_thickness)


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
    obstacles = tuple(_box(*b) for b in boxes)
    parts = {"width": W, "height": H, "landmark_ids": (), "landmark_positions": ()}
    parts.update(obstacles=obstacles, name="cluttered")
    start = _choose_start(parts, centre, robot_radius, cfg.wall_thickness)
    keep_out = ((start[0], start[1], robot_radius + LANDMARK_POST_RADIUS + START_MARGIN),)
    pts = _halton_landmarks("cluttered", cfg, boxes, (), keep_out)
    return Layout(
        width=W,
        height=H,
        landmark_ids=tuple(range(len(pts))),
        landmark_positions=tuple(pts),
        obstacles=obstacles,
        start_pose=start,
        name="cluttered",
    )


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
    walls_t = tuple(walls)
    parts = {"width": W, "height": H, "landmark_ids": (), "landmark_positions": ()}
    parts.update(walls=walls_t, name="rooms")
    start = _choose_start(parts, (0.5 * rw, 0.5 * rh), robot_radius, t)
    keep_out = [(start[0], start[1], robot_radius + LANDMARK_POST_RADIUS + START_MARGIN)]
    # Keep doorways clear: a post there would block the passage.
    keep_out += [(x, y, door) for x, y in doors]
    pts = _halton_landmarks("rooms", cfg, (), walls_t, keep_out)
    return Layout(
        width=W,
        height=H,
        landmark_ids=tuple(range(len(pts))),
        landmark_positions=tuple(pts),
        walls=walls_t,
        start_pose=start,
        name="rooms",
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
    r = _as_float(robot_radius, "robot_radius")
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"robot_radius must be finite and > 0, got {robot_radius!r}")
    return _preset_cached(name, cfg, r)


def layout_for(config: EnvConfig, rng: np.random.Generator | None = None) -> Layout:
    """The world for ``config``: ``config.layout`` (a Layout, dict or JSON/YAML path),
    validated for the robot (landmark clearance: only the post radius), else the preset
    ``config.world.preset``, else a random world drawn from ``rng`` (required then)."""
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
