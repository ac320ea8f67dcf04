"""The robots' unicycle motion over one step, for B worlds in one call.

A robot driven at speed v (m/s) and turn rate ω (rad/s) for ``dt`` seconds moves in
n = max(substeps, ⌈|v|·dt / (MAX_MOVE_FRACTION·radius)⌉) moves: each turns by ω·h
(h = dt / n) and travels v·h along the chord of the arc, at the move's mean heading
(the midpoint rule). Moves no longer than half the robot's radius cannot jump over
anything: the thinnest obstacle (a post or a wall) plus the robot is wider.

:func:`drive` settles every robot that needs no clearance query (turning in place, or
the whole step inside the disk that an earlier query found free). Given the worlds'
static geometry it settles the others too, from the distance to the nearest shape
that pymunk's ``point_query_nearest`` finds (:mod:`.clearance`, exact to round-off):
a step whose reach clears every shape moves freely, and the others move along their
moves, each checked and a blocked one bisected to the contact, as
:meth:`slam_env.world.pymunk_world.World._settle` does with pymunk's queries. Every decision there
is the comparison of a distance with the robot's radius; where the kernel's distance
lies within :data:`CLEARANCE_SLACK` of it (round-off could tell it apart from
pymunk's), the robot is flagged with its moves and the caller settles it with
pymunk's queries. So the positions are pymunk's, bit for bit
(``tests/world/test_world_batch.py``), and pymunk is asked about one world-step in tens of
thousands. A world without the geometry (a standalone :class:`~slam_env.world.pymunk_world.World`,
the reference) is flagged wherever its disk does not hold its step.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel, inline_kernel
from slam_env.kernels.world.clearance import clearance, clearance_among
from slam_env.kernels.world.raycast import near_leaves
from slam_env.kernels.world.static_geometry import StaticGeometry

MAX_MOVE_FRACTION = 0.5  # longest single move, in robot radii (no tunnelling)
# Slack (m) for round-off when a move is settled from an earlier query's answer; the
# distances involved are exact to ~1e-15 m.
CLEARANCE_SLACK = 1e-9
# What drive reports for a command whose move count is not even a number (|v|·dt
# overflows): more than any buffer can hold.
TOO_MANY_MOVES = 2**62
# Bisections of a blocked move: it stops within 2⁻¹² of its length of the contact.
CONTACT_BISECTIONS = 12
# What _settle_moves reports: every move settled (clear or blocked), or a distance
# within the slack of the robot's radius, which only pymunk's query can decide.
SETTLED_CLEAR, SETTLED_BLOCKED, UNDECIDED = 0, 1, 2
# How much farther than a step's reach (m) _settle_moves looks for the shapes it checks:
# one farther away is farther than the slack from touching the robot at any move.
NEAR_LOOKAHEAD = 1e-6

_PI = math.pi
_TWO_PI = 2.0 * math.pi


@inline_kernel
def wrap_heading(theta: float) -> float:
    """The world's heading (rad) wrapped to [−π, π) by Python's float ``%`` (the sign of
    the divisor); at round-off it can give +π, unlike :func:`slam_env.kernels.base.angles.wrap`,
    and the worlds' recorded streams depend on it bit for bit."""
    return (theta + _PI) % _TWO_PI - _PI


@inline_kernel
def move_count(speed: float, dt: float, radius: float, substeps: int) -> float:
    """max(substeps, |v|·dt / (MAX_MOVE_FRACTION·radius)) before rounding up: the moves a
    step at ``speed`` (m/s) takes, as a float (NaN or inf for absurd commands)."""
    moves = abs(speed) * dt / (MAX_MOVE_FRACTION * radius)
    return substeps if moves <= substeps else moves


@inline_kernel
def _blocked_at(
    geometry: StaticGeometry,
    b: int,
    x: float,
    y: float,
    radius: float,
    leaves: np.ndarray,
    count: int,
) -> int:
    """Whether the robot at (x, y) overlaps one of the shapes of the first ``count``
    ``leaves``, as pymunk's query would say (its distance below ``radius``): 1 or 0, or
    :data:`UNDECIDED` where the kernel's distance (exact to round-off) lies within the
    slack of ``radius``."""
    clear = clearance_among(geometry, b, x, y, leaves, count)
    if clear < radius - CLEARANCE_SLACK:
        return 1
    if clear >= radius + CLEARANCE_SLACK:
        return 0
    return UNDECIDED


@inline_kernel
def _settle_moves(
    geometry: StaticGeometry,
    b: int,
    x: float,
    y: float,
    moves: np.ndarray,
    n: int,
    radius: float,
    reach: float,
    leaves: np.ndarray,
) -> tuple[int, float, float]:
    """World b's robot moved from (x, y) along ``moves[:n]``, each move checked and,
    when blocked, bisected down to the contact, as
    :meth:`slam_env.world.pymunk_world.World._settle` does with pymunk's queries: the same
    decisions, so the same arithmetic and the same end. Returns :data:`SETTLED_CLEAR`
    or :data:`SETTLED_BLOCKED` and the end, or :data:`UNDECIDED` (with the start)
    where a decision is too close to call for the kernel's distance. Only the shapes
    whose boxes lie within ``reach`` (and :data:`NEAR_LOOKAHEAD`) are checked, listed
    once in ``leaves`` (scratch as long as the tree): every move ends within
    ``reach − radius`` of the start, so no other shape comes near deciding."""
    count = near_leaves(geometry, b, x, y, reach + NEAR_LOOKAHEAD, leaves)
    if clearance_among(geometry, b, x, y, leaves, count) >= reach + CLEARANCE_SLACK:
        for k in range(n):  # nothing within reach of the whole step
            x += moves[k, 0]
            y += moves[k, 1]
        return SETTLED_CLEAR, x, y
    x0, y0 = x, y
    blocked = False
    for k in range(n):
        dx, dy = moves[k, 0], moves[k, 1]
        hit = _blocked_at(geometry, b, x + dx, y + dy, radius, leaves, count)
        if hit == UNDECIDED:
            return UNDECIDED, x0, y0
        if hit:
            blocked = True
            lo, hi = 0.0, 1.0
            for _ in range(CONTACT_BISECTIONS):
                mid = 0.5 * (lo + hi)
                hit = _blocked_at(geometry, b, x + mid * dx, y + mid * dy, radius, leaves, count)
                if hit == UNDECIDED:
                    return UNDECIDED, x0, y0
                if hit:
                    hi = mid
                else:
                    lo = mid
            dx, dy = lo * dx, lo * dy
        x += dx
        y += dy
    return (SETTLED_BLOCKED if blocked else SETTLED_CLEAR), x, y


@borrowing_kernel
def drive(
    poses: np.ndarray,
    disks: np.ndarray,
    commands: np.ndarray,
    active: np.ndarray,
    radius: float,
    dt: float,
    substeps: int,
    moves: np.ndarray,
    counts: np.ndarray,
    reaches: np.ndarray,
    blocked: np.ndarray,
    geometry_fields: tuple | None,
    leaves: np.ndarray,
) -> int:
    """Drive each ``active`` robot b for ``dt`` s at ``commands[b] = (v, ω)``.

    Args:
        poses: (B, 3) (x, y, θ) m, m, rad; updated in place (see below).
        disks: (B, 3) each robot's clear disk (cx, cy, d): nothing it can hit lies
            closer than d to (cx, cy). Replaced by the disk up to the nearest shape
            where the geometry shows that one clears a step the old disk did not.
        commands: (B, 2) speed (m/s) and turn rate (rad/s), finite.
        active: (B,) bool, the robots that move.
        radius: the robots' radius, m. dt: the step, s. substeps: the fewest moves.
        moves: (B, M, 2) out: the displacements (m) of a flagged robot's moves.
        counts: (B,) int64 out: a flagged robot's number of moves, else 0.
        reaches: (B,) out: a flagged robot's reach radius + |v|·dt (m): nothing within
            it of its start can block any of its moves.
        blocked: (B,) bool out: whether each active robot's step ended in a contact
            (False for a flagged robot: the caller's to set).
        geometry_fields: the worlds' :class:`~slam_env.kernels.world.static_geometry.StaticGeometry`
            as a plain tuple, or None (a world that has only pymunk's queries).
        leaves: (T,) int64 scratch, at least as long as the geometry's tree.

    An unflagged robot's pose is final (given the geometry, ``blocked[b]`` too). A
    flagged one (moving, its reach not inside its clear disk, and not settled from the
    geometry) has its final heading (the rotation goes on when a contact stops the
    translation) but keeps its position, for the caller to move along ``moves[b, :n]``
    with clearance queries.

    Returns the number of flagged robots; or, when some active robot needs more than M
    moves, minus the most moves one needs (at most :data:`TOO_MANY_MOVES`), having
    changed nothing: the caller grows ``moves`` (or refuses the command) and calls
    again.
    """
    capacity = moves.shape[1]
    needed = 0
    for b in range(poses.shape[0]):
        if active[b]:
            n = move_count(commands[b, 0], dt, radius, substeps)
            if not n <= capacity:  # NaN too
                needed = max(needed, math.ceil(n) if n < TOO_MANY_MOVES else TOO_MANY_MOVES)
    if needed:
        return -needed
    flagged = 0
    for b in range(poses.shape[0]):
        counts[b] = 0
        if not active[b]:
            continue
        blocked[b] = False
        v, omega = commands[b, 0], commands[b, 1]
        n = math.ceil(move_count(v, dt, radius, substeps))
        h = dt / n
        turn, travel = omega * h, v * h
        half_turn = 0.5 * turn
        x, y, heading = poses[b, 0], poses[b, 1], poses[b, 2]
        moving = travel != 0.0
        free = True
        if moving:
            reach = radius + abs(v) * dt
            gap = math.hypot(x - disks[b, 0], y - disks[b, 1])
            free = disks[b, 2] - gap - CLEARANCE_SLACK >= reach
            if not free and geometry_fields is not None:
                # The distance to the nearest shape, as a query would find it: clear
                # by the slack, the step is free (so a query would say), else flagged.
                clear = clearance(StaticGeometry(*geometry_fields), b, x, y)
                if clear - CLEARANCE_SLACK >= reach:
                    free = True
                    disks[b, 0], disks[b, 1], disks[b, 2] = x, y, clear
            if not free:
                counts[b] = n
                reaches[b] = reach
                flagged += 1
        for k in range(n):
            mid_heading = heading + half_turn
            heading += turn
            if moving:
                dx, dy = travel * math.cos(mid_heading), travel * math.sin(mid_heading)
                if free:
                    x += dx
                    y += dy
                else:
                    moves[b, k, 0] = dx
                    moves[b, k, 1] = dy
        if counts[b] and geometry_fields is not None:
            # Settled here where the kernel's distances decide every move as pymunk's
            # queries would; only a decision within the slack is left to them.
            settled, x, y = _settle_moves(
                StaticGeometry(*geometry_fields), b, x, y, moves[b], n, radius, reaches[b],
                leaves,
            )  # fmt: skip
            if settled != UNDECIDED:
                counts[b] = 0
                blocked[b] = settled == SETTLED_BLOCKED
                flagged -= 1
        poses[b, 0] = x
        poses[b, 1] = y
        poses[b, 2] = wrap_heading(heading)
    return flagged
