"""The motion kernel against the plain Python loop it replaced, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.kernels.world.clearance import clearance
from slam_env.kernels.world.motion import (
    CLEARANCE_SLACK,
    MAX_MOVE_FRACTION,
    TOO_MANY_MOVES,
    drive,
    wrap_heading,
)
from slam_env.kernels.world.static_geometry import empty_geometry
from slam_env.world.layouts import LANDMARK_POST_RADIUS, Layout
from slam_env.world.static_shapes import set_world
from tests.kernels.geometry_worlds import WALL, world_layouts

RADIUS, DT, SUBSTEPS = 0.25, 0.2, 4
NO_LEAVES = np.empty(0, dtype=np.int64)  # the scratch of a call without the geometry


def with_geometry(geometry):
    """drive's last two arguments for worlds with this static geometry."""
    return tuple(geometry), np.empty(geometry.tree.shape[1], dtype=np.int64)


def reference(pose, disk, v, omega, radius=RADIUS, dt=DT, substeps=SUBSTEPS):
    """The Python loop of World.step before the kernel: (pose, flagged moves or None,
    reach). A flagged robot keeps its position and gets its final heading."""
    x, y, a = pose
    moves = abs(v) * dt / (MAX_MOVE_FRACTION * radius)
    n = substeps if moves <= substeps else math.ceil(moves)
    h = dt / n
    dth, travel = omega * h, v * h
    half_dth = 0.5 * dth
    reach = radius + abs(v) * dt
    cx, cy, clear = disk
    flagged = None
    if travel == 0.0:
        for _ in range(n):
            a += dth
    elif clear - math.hypot(x - cx, y - cy) - CLEARANCE_SLACK >= reach:
        for _ in range(n):
            mid_heading = a + half_dth
            a += dth
            x += travel * math.cos(mid_heading)
            y += travel * math.sin(mid_heading)
    else:
        flagged = []
        for _ in range(n):
            mid_heading = a + half_dth
            a += dth
            flagged.append((travel * math.cos(mid_heading), travel * math.sin(mid_heading)))
    return (x, y, (a + math.pi) % (2.0 * math.pi) - math.pi), flagged, reach


def outputs(b: int, capacity: int):
    """moves, counts, reaches, blocked, filled with values the kernel must overwrite."""
    return (
        np.full((b, capacity, 2), np.nan),
        np.full(b, -1, dtype=np.int64),
        np.full(b, np.nan),
        np.ones(b, dtype=bool),
    )


def random_robots(rng: np.random.Generator, b: int):
    poses = np.column_stack(
        [rng.uniform(0, 10, b), rng.uniform(0, 10, b), rng.uniform(-math.pi, math.pi, b)]
    )
    # Disks around the robot or elsewhere, some holding the whole reach, some not.
    near = rng.random(b) < 0.5
    centres = np.where(near[:, None], poses[:, :2] + rng.normal(0, 0.2, (b, 2)), 5.0)
    disks = np.column_stack([centres, rng.uniform(0.0, 4.0, b)])
    disks[rng.random(b) < 0.1, 2] = -math.inf  # no query yet
    speed = rng.choice([0.0, -0.0, 1e-320, 0.3, -0.7, 1.0, 2.9, -5.0], b)
    speed = np.where(rng.random(b) < 0.5, rng.uniform(-3, 3, b), speed)
    turn = np.where(rng.random(b) < 0.2, 0.0, rng.uniform(-2.0, 2.0, b))
    return poses, disks, np.column_stack([speed, turn])


@pytest.mark.parametrize("seed", range(4))
def test_drive_is_the_python_loop(seed) -> None:
    rng = np.random.default_rng(seed)
    b = 400
    poses, disks, commands = random_robots(rng, b)
    active = rng.random(b) < 0.8
    capacity = 64
    moves, counts, reaches, blocked = outputs(b, capacity)
    start, disks_before = poses.copy(), disks.copy()
    args = (RADIUS, DT, SUBSTEPS, moves, counts, reaches, blocked, None, NO_LEAVES)
    flagged = drive(poses, disks, commands, active, *args)
    assert flagged == np.count_nonzero(counts) > 0
    np.testing.assert_array_equal(disks, disks_before)
    kinds = set()
    for i in range(b):
        if not active[i]:
            assert poses[i].tolist() == start[i].tolist() and blocked[i] and counts[i] == 0
            continue
        pose, flagged, reach = reference(start[i].tolist(), disks[i].tolist(), *commands[i])
        assert not blocked[i]
        if flagged is None:
            kinds.add("turn" if commands[i, 0] * DT / SUBSTEPS == 0.0 else "free")
            assert counts[i] == 0
            assert poses[i].tolist() == list(pose), i
        else:
            kinds.add("flagged")
            assert counts[i] == len(flagged) and reaches[i] == reach
            assert moves[i, : counts[i]].tolist() == [list(m) for m in flagged]
            assert poses[i].tolist() == [start[i, 0], start[i, 1], pose[2]]
            if counts[i] > SUBSTEPS:
                kinds.add("fast")
    assert kinds == {"turn", "free", "flagged", "fast"}


def test_the_clear_disk_boundary() -> None:
    """A reach inside the disk by a hair (1e-12 m) is free, one outside it by as much is
    flagged. (Right at the boundary the kernel's hypot, the C library's, may differ from
    Python's by an ulp: that only decides whether World._settle asks pymunk, whose answer
    there is "free" either way thanks to CLEARANCE_SLACK; the pose is the same.)"""
    rng = np.random.default_rng(9)
    for _ in range(200):
        pose = [rng.uniform(1, 9), rng.uniform(1, 9), rng.uniform(-3, 3)]
        v, omega = rng.uniform(0.1, 1.0), rng.uniform(-1, 1)
        cx, cy = pose[0] + rng.normal(0, 0.3), pose[1] + rng.normal(0, 0.3)
        clear = RADIUS + v * DT + math.hypot(pose[0] - cx, pose[1] - cy) + CLEARANCE_SLACK
        for disk_radius, flags in ((clear + 1e-12, False), (clear - 1e-12, True)):
            poses = np.array([pose])
            disks = np.array([[cx, cy, disk_radius]])
            moves, counts, reaches, blocked = outputs(1, SUBSTEPS)
            args = (RADIUS, DT, SUBSTEPS, moves, counts, reaches, blocked, None, NO_LEAVES)
            drive(poses, disks, np.array([[v, omega]]), np.ones(1, bool), *args)
            expected, flagged, _ = reference(pose, (cx, cy, disk_radius), v, omega)
            assert (counts[0] > 0) == flags == (flagged is not None)
            if not flags:
                assert poses[0].tolist() == list(expected)


def test_a_reach_exactly_on_the_disk_edge_is_free() -> None:
    """Centred on the robot (a gap of exactly 0, whichever hypot), a disk whose radius
    minus CLEARANCE_SLACK is the reach to the last bit frees the step; one float less
    flags it."""
    rng = np.random.default_rng(3)
    for _ in range(100):
        pose = [rng.uniform(1, 9), rng.uniform(1, 9), rng.uniform(-3, 3)]
        v, omega = rng.uniform(0.1, 1.0), rng.uniform(-1, 1)
        reach = RADIUS + v * DT
        clear = reach + CLEARANCE_SLACK
        while clear - 0.0 - CLEARANCE_SLACK < reach:
            clear = math.nextafter(clear, math.inf)
        while math.nextafter(clear, 0.0) - 0.0 - CLEARANCE_SLACK >= reach:
            clear = math.nextafter(clear, 0.0)
        for disk_radius, flags in ((clear, False), (math.nextafter(clear, 0.0), True)):
            moves, counts, reaches, blocked = outputs(1, SUBSTEPS)
            args = (RADIUS, DT, SUBSTEPS, moves, counts, reaches, blocked, None, NO_LEAVES)
            disks = np.array([[pose[0], pose[1], disk_radius]])
            drive(np.array([pose]), disks, np.array([[v, omega]]), np.ones(1, bool), *args)
            assert (counts[0] > 0) == flags


def test_the_geometry_settles_robots_farther_from_every_shape_than_their_reach() -> None:
    """Given the static geometry, a robot whose disk does not hold its step is settled
    in the kernel by the reference's free loop, its disk now up to the nearest shape,
    when every shape lies beyond its reach by the slack; otherwise along its moves,
    checked against the shapes (the ends pymunk's queries give: test_world_batch), its
    disk as it was."""
    layout = world_layouts()[0]
    b = 400
    geometry = set_world(empty_geometry(b), 0, layout, WALL)
    for world in range(1, b):
        geometry = set_world(geometry, world, layout, WALL)
    rng = np.random.default_rng(5)
    poses, _, commands = random_robots(rng, b)
    poses[:, 0] = rng.uniform(0.3, layout.width - 0.3, b)
    poses[:, 1] = rng.uniform(0.3, layout.height - 0.3, b)
    disks = np.tile([0.0, 0.0, -math.inf], (b, 1))  # no query yet
    start, active = poses.copy(), np.ones(b, dtype=bool)
    moves, counts, reaches, blocked = outputs(b, 64)
    args = (RADIUS, DT, SUBSTEPS, moves, counts, reaches, blocked, *with_geometry(geometry))
    drive(poses, disks, commands, active, *args)
    kinds = set()
    for i in range(b):
        x, y = start[i, :2].tolist()
        v, omega = commands[i].tolist()
        clear = clearance(geometry, i, x, y)
        settled = v * DT / SUBSTEPS != 0.0 and clear - CLEARANCE_SLACK >= RADIUS + abs(v) * DT
        disk = (x, y, clear) if settled else (0.0, 0.0, -math.inf)
        pose, flagged, _ = reference(start[i].tolist(), disk, v, omega)
        assert disks[i].tolist() == list(disk), i
        assert counts[i] == 0, i  # no decision in this world is within the slack
        if flagged is None:
            assert poses[i].tolist() == list(pose), i
        else:  # the reference's heading; moved, and as far as its moves at most
            assert poses[i, 2] == pose[2], i
            travel = math.hypot(poses[i, 0] - x, poses[i, 1] - y)
            assert travel <= abs(v) * DT + 1e-12, i
            assert travel > 0.0 or blocked[i], i  # not moving: it started in contact
        kinds.add("settled" if settled else "along its moves" if flagged else "turn")
    assert kinds == {"settled", "along its moves", "turn"}


def one_post_geometry():
    """A 20 m arena with one post at its centre (10, 10), as the kernels take it."""
    layout = Layout(
        width=20.0,
        height=20.0,
        landmark_ids=(0,),
        landmark_positions=((10.0, 10.0),),
        start_pose=(5.0, 10.0, 0.0),
    )
    return set_world(empty_geometry(1), 0, layout, WALL)


def test_a_reach_clear_of_the_nearest_shape_by_exactly_the_slack_is_free() -> None:
    """Given the geometry, a step whose reach plus CLEARANCE_SLACK is the distance to the
    nearest shape, to the last bit, is settled in the kernel by the free loop, its disk
    widened; a robot one float nearer to the shape is settled along its moves, its disk
    as it was."""
    geometry = one_post_geometry()
    v, omega = 0.5, 0.3
    reach = RADIUS + v * DT

    def frees(x: float) -> bool:
        return clearance(geometry, 0, x, 10.0) - CLEARANCE_SLACK >= reach

    x = 10.0 - LANDMARK_POST_RADIUS - reach - CLEARANCE_SLACK  # left of the post
    while not frees(x):
        x = math.nextafter(x, -math.inf)
    while frees(math.nextafter(x, math.inf)):
        x = math.nextafter(x, math.inf)
    for start_x, nearer in ((x, False), (math.nextafter(x, math.inf), True)):
        moves, counts, reaches, blocked = outputs(1, SUBSTEPS)
        args = (RADIUS, DT, SUBSTEPS, moves, counts, reaches, blocked, *with_geometry(geometry))
        disks = np.array([[0.0, 0.0, -math.inf]])
        pose = np.array([[start_x, 10.0, 0.0]])
        drive(pose, disks, np.array([[v, omega]]), np.ones(1, bool), *args)
        assert counts[0] == 0 and not blocked[0]
        assert (disks[0, 2] == -math.inf) == nearer


@pytest.mark.parametrize(
    ("gap", "outcome"),
    [(2e-9, "clear"), (0.5e-9, "flagged"), (-0.5e-9, "flagged"), (-2e-9, "blocked")],
)
def test_a_move_within_the_slack_of_a_contact_is_left_to_pymunk(gap, outcome) -> None:
    """A robot driven straight at a post, its last move ending ``gap`` beyond touching
    it: the kernel settles it where its distance decides by more than the slack
    (clear: all the way; blocked: short of the end), and flags it, unmoved, with its
    moves for pymunk's queries where the distance is within the slack."""
    geometry = one_post_geometry()
    v = 0.5
    travel = v * DT / SUBSTEPS
    end = 10.0 - LANDMARK_POST_RADIUS - RADIUS - gap
    start = end - SUBSTEPS * travel
    moves, counts, reaches, blocked = outputs(1, SUBSTEPS)
    args = (RADIUS, DT, SUBSTEPS, moves, counts, reaches, blocked, *with_geometry(geometry))
    pose = np.array([[start, 10.0, 0.0]])
    flagged = drive(
        pose, np.array([[0.0, 0.0, -math.inf]]), np.array([[v, 0.0]]), np.ones(1, bool), *args
    )
    assert flagged == (outcome == "flagged") == (counts[0] == SUBSTEPS)
    if outcome == "flagged":
        assert pose[0, 0] == start
        assert moves[0, :SUBSTEPS].tolist() == [[travel, 0.0]] * SUBSTEPS
    elif outcome == "clear":
        assert pose[0, 0] == start + travel + travel + travel + travel and not blocked[0]
    else:
        assert blocked[0] and start + 3 * travel <= pose[0, 0] < end


@pytest.mark.parametrize("speed", [3.0, 1e6, 1e300, math.inf, math.nan])
def test_too_many_moves_change_nothing_and_say_how_many(speed) -> None:
    rng = np.random.default_rng(1)
    poses, disks, commands = random_robots(rng, 8)
    commands[3, 0] = speed
    before = [a.copy() for a in (poses, disks, commands)]
    moves, counts, reaches, blocked = outputs(8, SUBSTEPS)
    args = (RADIUS, DT, SUBSTEPS, moves, counts, reaches, blocked, None, NO_LEAVES)
    needed = drive(poses, disks, commands, np.ones(8, bool), *args)
    moves_per_step = abs(speed) * DT / (MAX_MOVE_FRACTION * RADIUS)
    expected = math.ceil(moves_per_step) if moves_per_step < TOO_MANY_MOVES else TOO_MANY_MOVES
    assert -needed == (TOO_MANY_MOVES if math.isnan(speed) else expected)
    for a, b in zip((poses, disks, commands), before, strict=True):
        np.testing.assert_array_equal(a, b)
    assert (counts == -1).all() and blocked.all() and np.isnan(moves).all()


def test_wrap_heading_is_pythons_expression() -> None:
    rng = np.random.default_rng(2)
    below = math.nextafter(-math.pi, -math.inf)
    angles = [0.0, -0.0, math.pi, -math.pi, below, 7.0, -7.0, 1e6, -1e6]
    angles += rng.uniform(-20, 20, 1000).tolist()
    for a in angles:
        assert wrap_heading(a) == (a + math.pi) % (2.0 * math.pi) - math.pi, a
    assert wrap_heading(below) == math.pi  # the world's wrap at round-off, kept as it was
