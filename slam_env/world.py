"""The pymunk world: boundary and inner walls, convex obstacles, landmark posts and a
circular unicycle robot.

The robot is a dynamic body with an infinite moment of inertia: contacts never spin
it, its heading is whatever the controller integrates. Each env step drives it as a
unicycle for ``dt`` seconds over ``substeps`` fixed pymunk steps:

1. its velocity is set to v·(cos θ, sin θ) (minus the part pushing into a contact
   left over from the previous step) and its angular velocity to ω;
2. before each pymunk step a force is set such that pymunk's velocity integration
   lands on v·(cos θ', sin θ'), θ' being the heading after that step's rotation. The
   contact solver then removes what pushes into a wall or an obstacle, so the next
   position update follows the solved velocity: the robot stops or slides, and in
   free space it follows the discretised unicycle exactly.

Chipmunk integrates positions *before* solving contacts, which is why the velocity is
shaped through the force (velocity integration happens before the solver) instead of
being overwritten before each step (which would push the robot into walls by v·h per
step). Substeps are split further when |v|·h would exceed half the robot radius, so
the robot never tunnels through a wall, an obstacle or a post.

The last pymunk step of an env step runs without positional error correction, so no
hidden solver state (chipmunk's bias velocity, which pymunk cannot pickle) survives an
env step: pickling a :class:`World` between steps resumes bit-identically.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pymunk
from pymunk._chipmunk_cffi import ffi as _ffi
from pymunk._chipmunk_cffi import lib as _cp  # direct calls in the per-step hot path

from slam_env.config import RobotConfig
from slam_env.layouts import LANDMARK_POST_RADIUS, Layout

__all__ = ["LANDMARK_POST_RADIUS", "World"]

CONTACT_SLOP = 0.005  # m, overlap tolerated before positional correction pushes back
CORRECTION_PER_STEP = 0.5  # fraction of the overlap (beyond slop) removed per pymunk step
MAX_TRAVEL_FRACTION = 0.5  # most robot travel per pymunk step, in robot radii
SOLVER_ITERATIONS = 10  # pymunk contact solver iterations per step
HASH_CELL = 1.0  # m, spatial hash cell size (about the robot's size)
MIN_HASH_COUNT = 64  # spatial hash table size: max(this, 2 × shapes); cleared every step

ROBOT_COLLISION_TYPE = 1
CAT_ROBOT = 0b0001  # shape filter categories
CAT_WALL = 0b0010
CAT_OBSTACLE = 0b0100
CAT_POST = 0b1000
_ALL = 0xFFFFFFFF
_PI = math.pi
_TWO_PI = 2.0 * math.pi
_NULL = _ffi.NULL


def _mark_contact(arbiter: pymunk.Arbiter, space: pymunk.Space, flag: list[bool]) -> None:
    """pre_solve callback for the robot's contacts: record that it touched something."""
    flag[0] = True


def _collect_normal(arbiter: pymunk.Arbiter, normals: list[tuple[float, float]]) -> None:
    n = arbiter.normal  # points from the robot (shape a of its own arbiters) outwards
    normals.append((n.x, n.y))


class World:
    """A pymunk world built from a :class:`~slam_env.layouts.Layout`.

    Args:
        layout: the world; validated for the robot (``ValueError`` if invalid).
        robot: radius (m) and mass (kg) of the robot.
        dt: duration of one :meth:`step`, s.
        substeps: pymunk steps per :meth:`step` (more when |v| is high, see module doc).
        wall_thickness: half-thickness (segment radius) of boundary and inner walls, m.
            The boundary walls lie outside the arena: their inner face is its edge.

    Shapes: walls are static segments, obstacles static convex polygons, each landmark
    a static circle of radius :data:`LANDMARK_POST_RADIUS` (it blocks the robot and
    other landmarks' lines of sight), the robot a frictionless dynamic circle.
    """

    def __init__(
        self,
        layout: Layout,
        robot: RobotConfig,
        dt: float,
        substeps: int,
        wall_thickness: float = 0.1,
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
        layout.validate(robot.radius, wall_thickness=float(wall_thickness))

        self.layout = layout
        self.robot = robot
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.wall_thickness = float(wall_thickness)
        self._h = self.dt / self.substeps  # s, pymunk step
        self._max_travel = MAX_TRAVEL_FRACTION * robot.radius  # m per pymunk step
        self._fast_speed = self._max_travel / self._h  # m/s above which steps are split

        positions = layout.landmark_array()
        positions.flags.writeable = False
        ids = layout.id_array()
        ids.flags.writeable = False
        self._landmark_positions = positions
        self._landmark_ids = ids
        # One query filter per landmark: its post has group i + 1, so the query skips
        # it; the mask skips the robot.
        self._los_filters = tuple(
            pymunk.ShapeFilter(group=i + 1, categories=_ALL, mask=_ALL & ~CAT_ROBOT)
            for i in range(layout.n_landmarks)
        )
        self._build_space()
        x, y, theta = layout.start_pose
        self._place(x, y, theta)

    # ----------------------------------------------------------------- construction

    def _build_space(self) -> None:
        layout, t = self.layout, self.wall_thickness
        space = pymunk.Space()
        space.gravity = (0.0, 0.0)
        space.damping = 1.0
        space.iterations = SOLVER_ITERATIONS
        space.collision_slop = CONTACT_SLOP
        static = space.static_body
        shapes: list[pymunk.Shape] = []

        W, H = layout.width, layout.height
        # Boundary walls sit outside the arena so their inner face is its edge.
        corners = ((-t, -t), (W + t, -t), (W + t, H + t), (-t, H + t))
        for i in range(4):
            shapes.append(pymunk.Segment(static, corners[i], corners[(i + 1) % 4], t))
        for x0, y0, x1, y1 in layout.walls:
            shapes.append(pymunk.Segment(static, (x0, y0), (x1, y1), t))
        wall_filter = pymunk.ShapeFilter(categories=CAT_WALL)
        for s in shapes:
            s.filter = wall_filter
        obstacle_filter = pymunk.ShapeFilter(categories=CAT_OBSTACLE)
        for poly in layout.obstacles:
            s = pymunk.Poly(static, poly)
            s.filter = obstacle_filter
            shapes.append(s)
        for i, (x, y) in enumerate(layout.landmark_positions):
            s = pymunk.Circle(static, LANDMARK_POST_RADIUS, (x, y))
            s.filter = pymunk.ShapeFilter(group=i + 1, categories=CAT_POST)
            shapes.append(s)
        for s in shapes:
            s.friction = 0.0
            s.elasticity = 0.0

        body = pymunk.Body(self.robot.mass, math.inf)
        shape = pymunk.Circle(body, self.robot.radius)
        shape.friction = 0.0
        shape.elasticity = 0.0
        shape.collision_type = ROBOT_COLLISION_TYPE
        shape.filter = pymunk.ShapeFilter(categories=CAT_ROBOT)
        space.add(*shapes, body, shape)
        self._hash_count = max(MIN_HASH_COUNT, 2 * len(shapes))
        space.use_spatial_hash(HASH_CELL, self._hash_count)

        self._space = space
        self._body = body
        self._robot_shape = shape
        # Unit normals (from the robot outwards) of its contacts after the last step:
        # the first pymunk step of the next command must not push into them, since
        # chipmunk moves bodies before it solves contacts. Kept here (not read back
        # from pymunk) so that a pickled world resumes identically.
        self._contact_normals: tuple[tuple[float, float], ...] = ()
        self._connect()

    def _connect(self) -> None:
        """(Re)attach the contact callback and cache the raw chipmunk handles."""
        self._contact_flag = [False]
        self._space.on_collision(
            ROBOT_COLLISION_TYPE, None, pre_solve=_mark_contact, data=self._contact_flag
        )
        self._cp_space = self._space._space
        self._cp_body = self._body._body
        self._set_bias(self._h)

    def _set_bias(self, h: float) -> None:
        # Chipmunk removes a fraction 1 − bias^h of the overlap per step of length h.
        self._bias = (1.0 - CORRECTION_PER_STEP) ** (1.0 / h)
        self._space.collision_bias = self._bias

    def _place(self, x: float, y: float, theta: float) -> None:
        body = self._body
        body.position = (x, y)
        body.angle = (theta + _PI) % _TWO_PI - _PI
        body.velocity = (0.0, 0.0)
        body.angular_velocity = 0.0
        body.force = (0.0, 0.0)
        self._space.reindex_shapes_for_body(body)
        self._contact_normals = ()

    # ----------------------------------------------------------------- state

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, θ) of the robot: m, m, rad with θ in [−π, π); Python floats."""
        p = _cp.cpBodyGetPosition(self._cp_body)
        return (p.x, p.y, _cp.cpBodyGetAngle(self._cp_body))

    @property
    def velocity(self) -> tuple[float, float]:
        """The robot's (vx, vy), m/s, after the last contact solve."""
        v = _cp.cpBodyGetVelocity(self._cp_body)
        return (v.x, v.y)

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
        """The pymunk space (for drawing and debugging; don't step it directly)."""
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
        self._place(x, y, theta)

    # ----------------------------------------------------------------- dynamics

    def step(self, v: float, omega: float) -> bool:
        """Drive as a unicycle at speed ``v`` (m/s) and turn rate ``omega`` (rad/s) for
        ``dt``; return True if the robot touched anything (wall, obstacle, post)."""
        v = float(v)
        omega = float(omega)
        if not (math.isfinite(v) and math.isfinite(omega)):
            raise ValueError(f"step needs finite v and omega, got ({v}, {omega})")
        bb, sp = self._cp_body, self._cp_space
        n, h = self.substeps, self._h
        if abs(v) > self._fast_speed:  # split further: never tunnel
            n = math.ceil(abs(v) * self.dt / self._max_travel)
            h = self.dt / n
            self._set_bias(h)
        cos, sin = math.cos, math.sin
        a = _cp.cpBodyGetAngle(bb)
        vx, vy = v * cos(a), v * sin(a)
        for nx, ny in self._contact_normals:
            # Don't push into what the robot already touches (see _contact_normals).
            into = vx * nx + vy * ny
            if into > 0.0:
                vx -= into * nx
                vy -= into * ny
        flag = self._contact_flag
        flag[0] = False
        _cp.cpBodySetAngularVelocity(bb, omega)
        _cp.cpBodySetVelocity(bb, (vx, vy))
        k = self.robot.mass / h
        dth = omega * h
        last = n - 1
        for i in range(n):
            a += dth  # the heading after this step's rotation (chipmunk: a + ω·h)
            cur = _cp.cpBodyGetVelocity(bb)
            _cp.cpBodySetForce(bb, ((v * cos(a) - cur.x) * k, (v * sin(a) - cur.y) * k))
            if i == last:
                _cp.cpSpaceSetCollisionBias(sp, 1.0)  # no positional correction: see doc
            _cp.cpSpaceStep(sp, h)
        _cp.cpSpaceSetCollisionBias(sp, self._bias)
        if h != self._h:
            self._set_bias(self._h)
        a = _cp.cpBodyGetAngle(bb)
        if not -_PI <= a < _PI:
            _cp.cpBodySetAngle(bb, (a + _PI) % _TWO_PI - _PI)
        touched = flag[0]
        if touched:
            normals: list[tuple[float, float]] = []
            self._body.each_arbiter(_collect_normal, normals)
            self._contact_normals = tuple(normals)
        elif self._contact_normals:
            self._contact_normals = ()
        return touched

    # ----------------------------------------------------------------- line of sight

    def line_of_sight(self, origin: Any, target: Any, landmark_index: int) -> bool:
        """True when the segment origin → target (each (2,), m) is not blocked by a wall,
        an obstacle or another landmark's post; the robot and the post of landmark
        ``landmark_index`` (its row in :attr:`landmark_positions`) are ignored."""
        hit = _cp.cpSpaceSegmentQueryFirst(
            self._cp_space,
            (float(origin[0]), float(origin[1])),
            (float(target[0]), float(target[1])),
            0.0,
            self._los_filters[landmark_index],
            _NULL,
        )
        return hit == _NULL

    # ----------------------------------------------------------------- pickling

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        for key in ("_cp_space", "_cp_body", "_contact_flag"):
            state.pop(key)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        # The index is not pickled: rebuild it exactly as __init__ did (see _build_space).
        self._space.use_spatial_hash(HASH_CELL, self._hash_count)
        self._connect()

    def __repr__(self) -> str:
        x, y, th = self.pose
        return (
            f"World(layout={self.layout.name!r}, landmarks={self.layout.n_landmarks}, "
            f"pose=({x:.3f}, {y:.3f}, {th:.3f}))"
        )
