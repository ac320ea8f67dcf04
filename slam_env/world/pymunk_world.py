"""The pymunk world: boundary and inner walls, convex obstacles, landmark posts and a
circular unicycle robot.

The robot is driven kinematically as a unicycle for ``dt`` seconds over ``substeps``
sub-steps (each: move v·h along the chord of the arc, i.e. at the sub-step's mean
heading, and turn by ω·h; :mod:`slam_env.kernels.world.motion` holds that arithmetic, for a
batch of one here and of B in :class:`~slam_env.world.world_batch.WorldBatch`). Before each
move a pymunk point query checks that the robot's disc is clear at the destination;
when it is not, the move is bisected down to the contact, so a collision *stops* the
translation while the rotation goes on: the robot behaves like a bumper-equipped
differential drive. It never slides sideways, because a wheeled robot cannot, and
because sideways motion is exactly what the seed's odometry model cannot describe (a
lateral slip reads as δrot1 ≈ ±π/2, and the α1·δrot1² noise of such a reading would
wreck any filter's heading). Moves are at most half the robot's radius, so no speed
tunnels through anything. One query first checks whether anything is within reach of
the whole step; in free space that is the only query, and often none is needed: each
query also bounds the clearance around its point, which settles the next moves
exactly (see :meth:`World._clearance`), and a query that finds a shape gives a point
of it, which settles blocked moves and bisection midpoints the same way (see
:meth:`World._contact`): the same answers as one query per question, far fewer
queries. The compiled kernel settles every step that needs no query (turning in
place, or the whole step inside the disk an earlier query found clear); only the
others come back to Python and pymunk (:meth:`World._settle`). A
:class:`~slam_env.world.world_batch.WorldBatch` also hands the kernel its worlds' static
geometry, from which it settles the steps itself, contacts included, making the
decisions these queries make from the distance a query would find
(:mod:`slam_env.kernels.world.clearance`), and leaves to pymunk only a distance within
round-off of a contact (:mod:`slam_env.kernels.world.motion`); a standalone world asks
pymunk, and is the reference the batch is tested against. A batched core keeps one world per
sub-env and relays it at each reset (:meth:`World.relayout`).

The static geometry lives in pymunk, which moves the robot through its public API, and
also in arrays (:mod:`slam_env.kernels.world.static_geometry`, a batch of one world) for the
compiled segment queries of line of sight and the proximity scan
(:mod:`slam_env.kernels.world.raycast`), which answer exactly as pymunk's own segment queries
would. The robot's pose is a row of floats (the world's own, or its
:class:`~slam_env.world.world_batch.WorldBatch`'s), mirrored into its body when the space is
read, so a pickled world resumes bit-identically.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import pymunk

from slam_env.config import RobotConfig
from slam_env.kernels.world import raycast
from slam_env.kernels.world.motion import (
    CLEARANCE_SLACK,
    CONTACT_BISECTIONS,
    MAX_MOVE_FRACTION,
    wrap_heading,
)
from slam_env.kernels.world.static_geometry import StaticGeometry, StaticShapes, empty_geometry
from slam_env.world.drive import Drive
from slam_env.world.layouts import LANDMARK_POST_RADIUS, Layout
from slam_env.world.static_shapes import set_world, static_shapes

__all__ = ["LANDMARK_POST_RADIUS", "MAX_MOVE_FRACTION", "World"]

CAT_ROBOT = 0b0001  # shape filter categories
CAT_WALL = 0b0010
CAT_OBSTACLE = 0b0100
CAT_POST = 0b1000
_ALL = 0xFFFFFFFF
# Queries for the robot's motion see everything but the robot itself.
_MOTION_FILTER = pymunk.ShapeFilter(mask=_ALL & ~CAT_ROBOT)
# A clearance query looks this much farther (m) than it must, so that its answer also
# settles the next few moves without a query (see World._clearance).
CLEARANCE_LOOKAHEAD = 0.5


class World:
    """A pymunk world built from a :class:`~slam_env.world.layouts.Layout`.

    Args:
        layout: the world; validated for the robot (``ValueError`` if invalid).
        robot: radius (m) and mass (kg) of the robot.
        dt: duration of one :meth:`step`, s.
        substeps: pymunk steps per :meth:`step` (more when |v| is high, see module doc).
        wall_thickness: half-thickness (segment radius) of boundary and inner walls, m.
            The boundary walls lie outside the arena: their inner face is its edge.
        validated: True when ``layout`` was already validated for this robot's radius
            and this wall thickness (:func:`~slam_env.world.layout_generators.layout_for` does
            it), to skip checking it again (about half a millisecond per world).

    Shapes: walls are static segments, obstacles static convex polygons, each landmark
    a static circle of radius :data:`LANDMARK_POST_RADIUS` (it blocks the robot and
    other landmarks' lines of sight), the robot a kinematic circle.
    """

    def __init__(
        self,
        layout: Layout,
        robot: RobotConfig,
        dt: float,
        substeps: int,
        wall_thickness: float = 0.1,
        *,
        validated: bool = False,
    ) -> None:
        if not isinstance(layout, Layout):
            raise TypeError(f"layout must be a Layout, got {type(layout).__name__}")
        if not isinstance(robot, RobotConfig):
            raise TypeError(f"robot must be a RobotConfig, got {type(robot).__name__}")
        if isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer)):
            raise TypeError(f"substeps must be an int, got {type(substeps).__name__}")
        if substeps < 1:
            raise ValueError(f"substeps must be >= 1, got {substeps}")
        for name, value in (("dt", dt), ("wall_thickness", wall_thickness)):
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
                raise TypeError(f"{name} must be a number, got {type(value).__name__}")
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        if not validated:
            layout.validate(robot.radius, wall_thickness=float(wall_thickness))

        self.robot = robot
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.wall_thickness = float(wall_thickness)
        self._h = self.dt / self.substeps  # s, one sub-step
        # The pose (x, y, θ) and the clear disk (cx, cy, d: nothing the robot can hit
        # lies closer than d to (cx, cy)) as (1, 3) rows that the motion kernel reads:
        # the world's own, or a WorldBatch's (see use_rows). _clear_disk mirrors the
        # disk as Python floats for the queries; a batch's motion kernel may replace the
        # row's disk, so _settle reads it back first.
        self._pose = np.zeros((1, 3))
        self._disk = np.zeros((1, 3))
        self._space: pymunk.Space | None = None
        self.relayout(layout)

    def relayout(self, layout: Layout) -> None:
        """Make this the world of ``layout``, the robot at its start pose: the world
        ``World(layout, …)`` would build with this robot, ``dt``, ``substeps`` and wall
        thickness, for which ``layout`` must already be valid (it is not checked).
        The pymunk shapes are reshaped in place when ``layout`` has as many walls,
        obstacles and posts as the current one (a tenth of the cost of new ones); a
        batched core relays each sub-env's world at its resets this way."""
        self.layout = layout
        positions = layout.landmark_array()
        positions.flags.writeable = False
        ids = layout.id_array()
        ids.flags.writeable = False
        self._landmark_positions = positions
        self._landmark_ids = ids
        self._landmark_points = tuple((x, y) for x, y in positions.tolist())
        listed = static_shapes(layout, self.wall_thickness)
        if not self._reshape_space(listed):
            self._build_space(listed)
        self.__dict__.pop("_geometry", None)  # the compiled queries' copy, rebuilt lazily
        self._disk[0] = (0.0, 0.0, -math.inf)
        self._clear_disk = (0.0, 0.0, -math.inf)
        # A point on a shape, the last that a query found: whatever lies closer than
        # the robot's radius to it is blocked (none yet: a point at infinity).
        self._surface = (math.inf, math.inf)
        self._blocked_at = (math.inf, math.inf)  # the last point a query found blocked
        x, y, theta = layout.start_pose
        self.place(x, y, theta)

    # ----------------------------------------------------------------- construction

    def _reshape_space(self, listed: StaticShapes) -> bool:
        """Move the static shapes onto ``listed``'s when the counts match; False (and
        nothing changed) when they do not."""
        if self._space is None or (
            len(listed.segments),
            len(listed.polygons),
            len(listed.circles),
        ) != (len(self._walls), len(self._obstacles), len(self._posts)):
            return False
        for shape, (a, b, radius) in zip(self._walls, listed.segments, strict=True):
            shape.unsafe_set_endpoints(a, b)
            shape.unsafe_set_radius(radius)
        for shape, poly in zip(self._obstacles, listed.polygons, strict=True):
            shape.unsafe_set_vertices(poly)
        for shape, (centre, radius) in zip(self._posts, listed.circles, strict=True):
            shape.unsafe_set_offset(centre)
            shape.unsafe_set_radius(radius)
        self._space.reindex_static()
        return True

    def _build_space(self, listed: StaticShapes) -> None:
        # The same shapes as the kernels' arrays: both come from static_shapes.
        space = pymunk.Space()
        static = space.static_body
        shapes: list[pymunk.Shape] = []
        wall_filter = pymunk.ShapeFilter(categories=CAT_WALL)
        for a, b, radius in listed.segments:
            s = pymunk.Segment(static, a, b, radius)
            s.filter = wall_filter
            shapes.append(s)
        obstacle_filter = pymunk.ShapeFilter(categories=CAT_OBSTACLE)
        for poly in listed.polygons:
            s = pymunk.Poly(static, poly)
            s.filter = obstacle_filter
            shapes.append(s)
        # Post i has group i + 1, so that a query filter of that group skips it, as the
        # line of sight to landmark i does (the kernels' tests ask pymunk that way).
        for i, (centre, radius) in enumerate(listed.circles):
            s = pymunk.Circle(static, radius, centre)
            s.filter = pymunk.ShapeFilter(group=i + 1, categories=CAT_POST)
            shapes.append(s)

        body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        shape = pymunk.Circle(body, self.robot.radius)
        shape.filter = pymunk.ShapeFilter(categories=CAT_ROBOT)
        space.add(*shapes, body, shape)
        n_walls, n_obstacles = len(listed.segments), len(listed.polygons)
        self._walls = shapes[:n_walls]
        self._obstacles = shapes[n_walls : n_walls + n_obstacles]
        self._posts = shapes[n_walls + n_obstacles :]
        self._space = space
        self._body = body
        self._robot_shape = shape

    @functools.cached_property
    def _drive(self) -> Drive:
        """The motion kernel's buffers for a batch of one, made at the first step (a
        world of a WorldBatch is moved by the batch's)."""
        return Drive(1, self.robot.radius, self.dt, self.substeps)

    def place(self, x: float, y: float, theta: float) -> None:
        """Set the robot's pose (x m, y m, θ rad), θ wrapped, without moving through
        the world (its contacts are the caller's to settle)."""
        self._pose[0] = (x, y, wrap_heading(theta))

    def use_rows(self, pose: np.ndarray, disk: np.ndarray) -> None:
        """Keep the pose and the clear disk in ``pose`` and ``disk`` from now on ((1, 3)
        C-contiguous rows, e.g. a WorldBatch's), which take their current values."""
        pose[0] = self._pose[0]
        disk[0] = self._disk[0]
        self._pose, self._disk = pose, disk

    # ----------------------------------------------------------------- state

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, θ) of the robot: m, m, rad with θ in [−π, π); Python floats."""
        x, y, theta = self._pose[0].tolist()
        return (x, y, theta)

    @property
    def landmark_positions(self) -> np.ndarray:
        """(N, 2) float64 landmark positions, m (read-only, layout order)."""
        return self._landmark_positions

    @property
    def landmark_ids(self) -> np.ndarray:
        """(N,) int64 landmark IDs (read-only, layout order)."""
        return self._landmark_ids

    @property
    def space(self) -> pymunk.Space:
        """The pymunk space (for drawing and debugging; don't step it directly). The
        robot's body is moved to the current pose when this is read (every query
        skips the robot, so its body only matters to whoever reads the space)."""
        x, y, theta = self.pose
        self._body.position = (x, y)
        self._body.angle = theta
        return self._space

    @property
    def robot_radius(self) -> float:
        return self.robot.radius

    def is_free(self, x: float, y: float, margin: float = 0.0) -> bool:
        """True when the robot fits at (x, y) with ``margin`` (m) to spare."""
        return self.layout.is_free(
            x, y, self.robot.radius, wall_thickness=self.wall_thickness, margin=margin
        )

    def set_pose(self, x: float, y: float, theta: float) -> None:
        """Teleport the robot (a kidnapping), at rest. ``ValueError`` if the pose is not
        finite or the robot would overlap the boundary, a wall, an obstacle or a post."""
        x, y, theta = float(x), float(y), float(theta)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(theta)):
            raise ValueError(f"set_pose needs finite numbers, got ({x}, {y}, {theta})")
        reason = self.layout.collision_reason(
            x, y, self.robot.radius, wall_thickness=self.wall_thickness
        )
        if reason is not None:
            raise ValueError(f"set_pose({x:.4g}, {y:.4g}): the robot {reason}")
        self.place(x, y, theta)

    # ----------------------------------------------------------------- dynamics

    def step(self, v: float, omega: float) -> bool:
        """Drive as a unicycle at speed ``v`` (m/s) and turn rate ``omega`` (rad/s) for
        ``dt``; return True if an obstacle, a wall or a post blocked the motion.
        ``ValueError`` (the robot unmoved) for a non-finite command, or a speed so high
        that the step would take more than
        :data:`~slam_env.world.drive.MAX_MOVES_PER_STEP` moves (or ``substeps``, if more)."""
        v = float(v)
        omega = float(omega)
        if not (math.isfinite(v) and math.isfinite(omega)):
            raise ValueError(f"step needs finite v and omega, got ({v}, {omega})")
        drive = self._drive
        commands = drive.commands
        commands[0, 0] = v
        commands[0, 1] = omega
        # The queries only: a World is the reference that a WorldBatch, which also
        # settles steps from the static geometry, is tested against.
        if drive(self._pose, self._disk, commands, np.ones(1, dtype=bool), np.zeros(1, bool), None):
            return self._settle(drive.moves[0, : drive.counts[0]], float(drive.reaches[0]))
        return False

    def _settle(self, moves: np.ndarray, reach: float) -> bool:
        """Move the robot from its position along ``moves`` ((n, 2) displacements, m:
        :func:`~slam_env.kernels.world.motion.drive` flagged this step and set the heading),
        each checked with a clearance query and, when blocked, bisected down to the
        contact; ``reach`` (m) bounds the whole step. Returns True if blocked."""
        pose = self._pose[0]
        x, y = float(pose[0]), float(pose[1])
        cx, cy, clear = self._disk[0].tolist()  # the kernel's, if it found a wider one
        self._clear_disk = (cx, cy, clear)
        blocked = False
        radius = self.robot.radius
        sx, sy = self._surface
        if math.hypot(x - sx, y - sy) + CLEARANCE_SLACK >= reach and (
            self._clearance(x, y, reach) >= reach
        ):
            # Nothing within reach of the whole step: no need to check each move.
            for dx, dy in moves.tolist():
                x += dx
                y += dy
        else:
            clearance = self._clearance
            for dx, dy in moves.tolist():
                sx, sy = self._surface
                ex, ey = x + dx, y + dy
                if (
                    math.hypot(ex - sx, ey - sy) + CLEARANCE_SLACK < radius
                    or clearance(ex, ey, radius) < radius
                ):
                    blocked = True
                    lo = self._contact(x, y, dx, dy)
                    dx, dy = lo * dx, lo * dy
                x += dx
                y += dy
        pose[0] = x
        pose[1] = y
        return blocked

    def _clearance(self, x: float, y: float, reach: float) -> float:
        """The distance from (x, y) to the nearest shape the robot can hit, exact when
        below ``reach``, otherwise only a lower bound that is at least ``reach``: it is
        below ``reach`` exactly when ``point_query_nearest((x, y), reach,
        _MOTION_FILTER)`` finds a shape. Same answers as that query, fewer queries.

        The shapes never move, and the distance to a shape changes by at most as much
        as the point moves, so if nothing is closer than d to (cx, cy), nothing is
        closer than d − |p − c| to p. Each query therefore looks
        :data:`CLEARANCE_LOOKAHEAD` farther than it must and keeps the disk it found
        empty (up to the nearest shape, or its whole radius); a point whose reach lies
        inside that disk needs no query. A query finds a shape within ``reach`` exactly
        when the nearest shape within the larger radius is closer than ``reach``.
        """
        cx, cy, clear = self._clear_disk
        bound = clear - math.hypot(x - cx, y - cy) - CLEARANCE_SLACK
        if bound >= reach:
            return bound
        radius = reach + CLEARANCE_LOOKAHEAD
        hit = self._space.point_query_nearest((x, y), radius, _MOTION_FILTER)
        if hit is None:
            clear = radius
        else:
            clear = hit.distance
            self._surface = (hit.point.x, hit.point.y)
        self._clear_disk = (x, y, clear)
        self._disk[0] = self._clear_disk
        return clear

    def _contact(self, x: float, y: float, dx: float, dy: float) -> float:
        """The longest fraction of the move (dx, dy) from (x, y) that keeps the robot
        clear, bisected to 2⁻¹² of the move; the move's end is blocked, and
        :attr:`_surface` is a point on a shape closer to it than the robot's radius.

        Each midpoint is blocked when a point query finds a shape within the robot's
        radius. Most midpoints are settled without one, from what earlier queries
        found (the same answers, fewer queries):
        - a point closer than the radius to a point on a shape is blocked: each query
          that finds a shape gives the point of it nearest to the midpoint;
        - a point inside a clear disk, by at least the radius, is clear: each query
          looks as far as the move is long, as :meth:`_clearance` does, and keeps the
          disk it found empty;
        - the last midpoint found blocked is remembered, because a robot pressed into
          a wall asks about the same point (within round-off of the contact) at every
          push: a pressed robot needs no query.
        """
        radius = self.robot.radius
        reach = radius + math.hypot(dx, dy)
        query = self._space.point_query_nearest
        sx, sy = self._surface
        bx, by = self._blocked_at
        cx, cy, clear = self._clear_disk
        lo, hi = 0.0, 1.0
        for _ in range(CONTACT_BISECTIONS):
            mid = 0.5 * (lo + hi)
            px, py = x + mid * dx, y + mid * dy
            if math.hypot(px - sx, py - sy) + CLEARANCE_SLACK < radius or (px == bx and py == by):
                hi = mid
            elif clear - math.hypot(px - cx, py - cy) - CLEARANCE_SLACK >= radius:
                lo = mid
            else:
                hit = query((px, py), reach, _MOTION_FILTER)
                if hit is None:
                    cx, cy, clear = px, py, reach
                    lo = mid
                else:
                    sx, sy = hit.point.x, hit.point.y
                    if hit.distance < radius:
                        bx, by = px, py
                        hi = mid
                    else:
                        cx, cy, clear = px, py, hit.distance
                        lo = mid
        self._surface = (sx, sy)
        self._blocked_at = (bx, by)
        self._clear_disk = (cx, cy, clear)
        self._disk[0] = self._clear_disk
        return lo

    # ----------------------------------------------------------------- line of sight

    @functools.cached_property
    def _geometry(self) -> StaticGeometry:
        """The static shapes as arrays, for the compiled segment queries: a batch of
        one, built at the first query (the batched cores keep their own)."""
        return set_world(empty_geometry(1), 0, self.layout, self.wall_thickness)

    def line_of_sight(self, origin: Any, target: Any, landmark_index: int) -> bool:
        """True when the segment origin → target (each (2,), m) is not blocked by a wall,
        an obstacle or another landmark's post; the robot and the post of landmark
        ``landmark_index`` (its row in :attr:`landmark_positions`; negative counts from
        the end) are ignored. ``IndexError`` for a row that does not exist."""
        row = range(len(self._landmark_points))[landmark_index]
        return raycast.line_of_sight(
            self._geometry,
            0,
            float(origin[0]),
            float(origin[1]),
            float(target[0]),
            float(target[1]),
            row,
        )

    def _landmark_visible_from(self, x: float, y: float, landmark_index: int) -> bool:
        """``line_of_sight((x, y), <the landmark's position>, landmark_index)`` for a
        point given as Python floats and a row in range: the env's occlusion test,
        without converting arrays at every call."""
        tx, ty = self._landmark_points[landmark_index]
        return raycast.line_of_sight(self._geometry, 0, x, y, tx, ty, landmark_index)

    def range_scan(
        self, x: float, y: float, theta: float, angles: tuple[float, ...], max_range: float
    ) -> list[float]:
        """Distances (m, from the robot's centre, at most ``max_range``) to the first
        wall, obstacle or post along each beam at ``angles`` (rad, robot frame): a
        proximity sensor that lets a policy see what the landmark map cannot."""
        beams = np.array(angles, dtype=np.float64).reshape(-1)
        out = np.empty(beams.shape[0])
        raycast.range_scan(
            self._geometry, 0, float(x), float(y), float(theta), beams, float(max_range), out
        )
        return out.tolist()

    # ----------------------------------------------------------------- pickling

    def __repr__(self) -> str:
        x, y, th = self.pose
        return (
            f"World(layout={self.layout.name!r}, landmarks={self.layout.n_landmarks}, "
            f"pose=({x:.3f}, {y:.3f}, {th:.3f}))"
        )
