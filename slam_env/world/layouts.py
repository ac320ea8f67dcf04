"""World layouts: the arena, obstacles, inner walls, landmarks and start pose.

A :class:`Layout` is plain data (no pymunk). :meth:`Layout.validate` checks a layout
against a robot and raises ``ValueError`` naming the first problem found;
:meth:`Layout.collision_reason` and :meth:`Layout.is_free` say whether a disc fits at a
point. Layouts are made in :mod:`slam_env.world.layout_generators` (random worlds drawn from a
seed, the named presets, and :func:`~slam_env.world.layout_generators.layout_for`, which picks
the world of an :class:`~slam_env.config.EnvConfig`) and read and written in
:mod:`slam_env.world.layout_files` (the dict schema, JSON/YAML files).

Geometry conventions: the arena is [0, width] × [0, height] and its boundary walls
lie outside it (their inner face is the arena edge). Inner walls are segments of
half-thickness ``wall_thickness`` (the pymunk segment radius). Every landmark is a
physical post of radius :data:`LANDMARK_POST_RADIUS`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import chain
from typing import Any

import numpy as np

from slam_env.config import WorldConfig

Point = tuple[float, float]

LANDMARK_POST_RADIUS = 0.1  # m, radius of the physical post at each landmark
DEFAULT_WALL_THICKNESS = WorldConfig().wall_thickness  # m, wall segment radius

_EPS = 1e-9  # m, tolerance for geometric comparisons on user input


# --------------------------------------------------------------------------- geometry


def segment_distance(px: float, py: float, x0: float, y0: float, x1: float, y1: float) -> float:
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


def box_polygon(cx: float, cy: float, w: float, h: float) -> tuple[Point, ...]:
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


def as_float(value: Any, what: str) -> float:
    if not _is_number(value):
        raise TypeError(f"{what} must be a number, got {type(value).__name__}")
    return float(value)


def as_int(value: Any, what: str) -> int:
    if type(value) is int:  # the common case, already what int() would give
        return value
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{what} must be an int, got {type(value).__name__}")
    return int(value)


def as_list(value: Any, what: str) -> list[Any]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Iterable, np.ndarray)):
        raise TypeError(f"{what} must be a sequence, got {type(value).__name__}")
    return list(value)


def as_floats(value: Any, n: int, what: str) -> tuple[float, ...]:
    if type(value) is tuple and len(value) == n and set(map(type, value)) == {float}:
        return value  # already what the coercion below makes (a generated layout's)
    items = as_list(value, what)
    if len(items) != n:
        raise ValueError(f"{what} must have {n} numbers, got {len(items)}")
    return tuple(as_float(v, f"{what}[{i}]") for i, v in enumerate(items))


def _float_rows(value: Any, n: int) -> bool:
    """Whether ``value`` is already a tuple of ``n``-tuples of Python floats (a generated
    layout's), which the coercion would return as it is; checked in C, not per item."""
    return (
        type(value) is tuple
        and set(map(type, value)) <= {tuple}
        and set(map(len, value)) <= {n}
        and set(map(type, chain.from_iterable(value))) <= {float}
    )


def as_float_rows(value: Any, n: int, what: str) -> tuple[tuple[float, ...], ...]:
    """``value`` as a tuple of ``n``-tuples of floats (row i named ``what[i]`` in an
    error)."""
    if _float_rows(value, n):
        return value
    return tuple(as_floats(p, n, f"{what}[{i}]") for i, p in enumerate(as_list(value, what)))


def as_polygon(value: Any, what: str) -> tuple[Point, ...]:
    if _float_rows(value, 2):
        pts = value
    else:
        pts = tuple(
            as_floats(p, 2, f"{what} vertex {j}") for j, p in enumerate(as_list(value, what))
        )
    # Normalise to counter-clockwise; degenerate shapes are left for validate().
    if len(pts) >= 3 and _signed_area(pts) < 0.0:
        pts = pts[::-1]
    return pts  # type: ignore[return-value]


def _bbox(polygon: tuple[Point, ...]) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of ``polygon`` (empty: an inverted infinite box)."""
    if not polygon:
        return (math.inf, math.inf, -math.inf, -math.inf)
    xs, ys = zip(*polygon, strict=True)
    return (min(xs), min(ys), max(xs), max(ys))


def _as_ids(value: Any) -> tuple[int, ...]:
    if type(value) is tuple and set(map(type, value)) <= {int}:
        return value  # already what the coercion makes
    return tuple(
        as_int(v, f"Layout.landmark_ids[{i}]")
        for i, v in enumerate(as_list(value, "Layout.landmark_ids"))
    )


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
            "width": as_float(self.width, "Layout.width"),
            "height": as_float(self.height, "Layout.height"),
            "landmark_ids": _as_ids(self.landmark_ids),
            "landmark_positions": as_float_rows(
                self.landmark_positions, 2, "Layout.landmark_positions"
            ),
            "obstacles": tuple(
                as_polygon(p, f"Layout.obstacles[{k}]")
                for k, p in enumerate(as_list(self.obstacles, "Layout.obstacles"))
            ),
            "walls": as_float_rows(self.walls, 4, "Layout.walls"),
            "start_pose": as_floats(self.start_pose, 3, "Layout.start_pose"),
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
            tuple(_bbox(p) for p in fields["obstacles"]),
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
            if segment_distance(x, y, x0, y0, x1, y1) < rw - _EPS:
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
                d = segment_distance(lx, ly, x0, y0, x1, y1) - wall_thickness
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
