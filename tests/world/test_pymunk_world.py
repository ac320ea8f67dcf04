"""The pymunk world: contacts, unicycle kinematics, the motion's queries against plain
ones, determinism, pickling and relaid worlds (its sight queries: test_world_sight.py)."""

from __future__ import annotations

import copy
import math
import os
import pickle
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from slam_env.config import RobotConfig, WorldConfig
from slam_env.world.layout_generators import preset_layout, random_layout
from slam_env.world.layouts import Layout, _polygon_signed_distance, segment_distance
from slam_env.world.pymunk_world import (
    _MOTION_FILTER,
    CONTACT_BISECTIONS,
    LANDMARK_POST_RADIUS,
    World,
)
from tests.world.world_samples import (
    DT,
    ROBOT,
    SUBSTEPS,
    CountingSpace,
    R,
    T,
    arena,
    pymunk_sees,
    world,
)

H = DT / SUBSTEPS
# The robot never enters anything: round-off is all the overlap there can be.
MAX_OVERLAP = 1e-9
# A blocked move stops within 2⁻¹² of a move's length (≤ r/2) of the contact.
STOP = 1e-4


# ----------------------------------------------------------------------------- contacts


@pytest.mark.parametrize("angle_deg", [-60, -30, 0, 30, 60])
def test_driving_into_the_boundary_stops_and_reports_collision(angle_deg) -> None:
    w = world()
    w.set_pose(8.0, 5.0, math.radians(angle_deg))
    limit = 10.0 - R  # the robot's centre when touching the right boundary
    touched = []
    for _ in range(60):
        touched.append(w.step(ROBOT.max_speed, 0.0))
        x, y, _th = w.pose
        assert x <= limit + MAX_OVERLAP  # never through, never into the wall
        assert R - MAX_OVERLAP <= y <= 10.0 - R + MAX_OVERLAP
    assert not touched[0]  # 1.75 m away at first
    assert all(touched[-10:])
    assert w.pose[0] == pytest.approx(limit, abs=STOP)


@pytest.mark.parametrize("angle_deg", [-20, 0, 20])
def test_driving_into_an_inner_wall_never_crosses_it(angle_deg) -> None:
    w = world(arena(walls=((5.0, 0.0, 5.0, 9.0),)))  # no way around it in 50 steps
    w.set_pose(2.0, 2.5, math.radians(angle_deg))
    face = 5.0 - T - R
    collided = False
    for _ in range(50):
        collided |= w.step(ROBOT.max_speed, 0.0)
        assert w.pose[0] <= face + MAX_OVERLAP
    assert collided
    assert w.pose[0] == pytest.approx(face, abs=STOP)


@pytest.mark.parametrize(
    "start", [(3.0, 6.5, 0.0), (6.5, 3.5, math.pi / 2), (8.0, 4.5, -math.pi / 2)]
)
def test_obstacles_and_posts_stop_the_robot(start) -> None:
    """Head-on into the box (from the left), into the box (from below), into post 10."""
    w = world()
    w.set_pose(*start)
    for _ in range(40):
        w.step(ROBOT.max_speed, 0.0)
        x, y, _ = w.pose
        overlap_box = R - _box_distance(x, y)
        overlap_post = R + LANDMARK_POST_RADIUS - math.hypot(x - 8.0, y - 2.0)
        assert max(overlap_box, overlap_post) <= MAX_OVERLAP
    assert max(overlap_box, overlap_post) >= -STOP  # stopped at the contact
    assert w.step(0.5, 0.0)  # still blocked


def _box_distance(x: float, y: float) -> float:
    dx = max(6.0 - x, 0.0, x - 7.0)
    dy = max(6.0 - y, 0.0, y - 7.0)
    return math.hypot(dx, dy)


def test_no_tunnelling_at_high_speed() -> None:
    fast = RobotConfig(max_speed=25.0)  # 5 m per env step, 20× the robot radius
    w = world(robot=fast)
    w.set_pose(2.0, 2.5, 0.0)
    assert w.step(fast.max_speed, 0.0)  # the swept move hits the wall in one step
    assert w.pose[0] == pytest.approx(5.0 - T - R, abs=STOP)
    w.set_pose(2.0, 2.5, math.pi)  # and the other way, into the boundary
    assert w.step(fast.max_speed, 0.0)
    assert w.pose[0] == pytest.approx(R, abs=STOP)


def test_a_wall_stops_the_robot_it_does_not_slide() -> None:
    # A wheeled robot cannot move sideways: at an angle to the wall it stops too.
    w = world()
    angle = math.radians(30)
    w.set_pose(9.0, 3.0, angle)
    touched = [w.step(ROBOT.max_speed, 0.0) for _ in range(20)]
    assert all(touched[-12:])
    x, y, th = w.pose
    assert x == pytest.approx(10.0 - R, abs=STOP)
    assert th == pytest.approx(angle)  # contacts never turn the robot
    assert w.step(ROBOT.max_speed, 0.0)
    assert w.pose[:2] == pytest.approx((x, y), abs=1e-12)
    # Turning in place at the wall is free; backing away is not held back.
    assert not w.step(0.0, 1.0)
    w.set_pose(x, y, angle)
    assert not w.step(-ROBOT.max_speed, 0.0)
    back = ROBOT.max_speed * DT
    assert w.pose[:2] == pytest.approx(
        (x - back * math.cos(angle), y - back * math.sin(angle)), abs=1e-9
    )


def test_stuck_in_a_corner() -> None:
    w = world()
    w.set_pose(1.0, 1.0, math.radians(-135))
    for _ in range(20):
        assert w.pose[0] >= R - MAX_OVERLAP and w.pose[1] >= R - MAX_OVERLAP
        w.step(ROBOT.max_speed, 0.0)
    assert w.pose[:2] == pytest.approx((R, R), abs=STOP)


def _overlap(layout: Layout, x: float, y: float) -> float:
    """How deep (m) the robot disc at (x, y) is inside anything (negative: clear)."""
    o = max(R - x, R - y, x + R - layout.width, y + R - layout.height)
    for poly in layout.obstacles:
        o = max(o, R - _polygon_signed_distance(x, y, poly))
    for wall in layout.walls:
        o = max(o, R + T - segment_distance(x, y, *wall))
    for lx, ly in layout.landmark_positions:
        o = max(o, R + LANDMARK_POST_RADIUS - math.hypot(x - lx, y - ly))
    return o


@pytest.mark.parametrize("which", ["random", "cluttered", "rooms"])
def test_never_inside_anything(which) -> None:
    cfg = WorldConfig()
    if which == "random":
        layout = random_layout(cfg, R, np.random.default_rng(11))
    else:
        layout = preset_layout(which, cfg)
    w = World(layout, ROBOT, DT, SUBSTEPS, T)
    rng = np.random.default_rng(5)
    contacts = 0
    for i in range(600):
        v = 1.0 if i % 30 < 25 else float(rng.uniform(-1.0, 1.0))
        om = float(rng.uniform(-1.5, 1.5)) if i % 30 >= 25 else float(rng.uniform(-0.2, 0.2))
        touched = w.step(v, om)
        contacts += touched
        overlap = _overlap(layout, *w.pose[:2])
        assert overlap <= MAX_OVERLAP
        if overlap > 1e-9:
            assert touched
    assert contacts > 100


# ----------------------------------------------------------------------------- kinematics


def test_straight_line_matches_unicycle() -> None:
    w = world()
    theta = 1.0
    w.set_pose(2.0, 5.0, theta)
    for k in range(1, 8):
        assert not w.step(0.7, 0.0)
        x, y, th = w.pose
        assert x == pytest.approx(2.0 + 0.7 * DT * k * math.cos(theta), abs=1e-12)
        assert y == pytest.approx(5.0 + 0.7 * DT * k * math.sin(theta), abs=1e-12)
        assert th == theta
    w.step(-0.5, 0.0)  # reversing
    assert w.pose[0] == pytest.approx(2.0 + (7 * 0.7 - 0.5) * DT * math.cos(theta), abs=1e-12)


def test_turning_in_place_matches_unicycle_and_wraps() -> None:
    w = world()
    w.set_pose(3.0, 6.0, 0.0)
    theta = 0.0
    for _ in range(40):
        assert not w.step(0.0, 1.5)
        theta += 1.5 * DT
        x, y, th = w.pose
        assert (x, y) == (3.0, 6.0)
        assert -math.pi <= th < math.pi
        assert math.cos(th) == pytest.approx(math.cos(theta), abs=1e-12)
        assert math.sin(th) == pytest.approx(math.sin(theta), abs=1e-12)
    assert all(type(c) is float for c in w.pose)


def test_arc_matches_the_substep_midpoint_unicycle() -> None:
    w = world()
    x, y, th = 3.0, 5.5, -0.3
    w.set_pose(x, y, th)
    v, om = 0.8, 0.9
    for _ in range(5):
        w.step(v, om)
        for _ in range(SUBSTEPS):
            x += v * H * math.cos(th + 0.5 * om * H)
            y += v * H * math.sin(th + 0.5 * om * H)
            th += om * H
        assert w.pose == pytest.approx((x, y, th), abs=1e-12)
    # Chords at the mean heading stay within O(h²) of the exact arc.
    r = v / om
    th0, th1 = -0.3, -0.3 + om * 5 * DT
    exact = (3.0 + r * (math.sin(th1) - math.sin(th0)), 5.5 - r * (math.cos(th1) - math.cos(th0)))
    assert w.pose[:2] == pytest.approx(exact, abs=2e-3)


def test_step_rejects_non_finite_commands() -> None:
    w = world()
    with pytest.raises(ValueError, match="finite"):
        w.step(math.nan, 0.0)
    with pytest.raises(ValueError, match="finite"):
        w.step(0.0, math.inf)
    w.step(np.float32(0.5), np.float64(0.1))  # numpy scalars are fine


def test_landmark_arrays() -> None:
    w = world()
    assert w.landmark_positions.dtype == np.float64 and w.landmark_positions.shape == (3, 2)
    assert w.landmark_ids.dtype == np.int64
    assert w.landmark_ids.tolist() == [10, 11, 12]
    with pytest.raises(ValueError):
        w.landmark_positions[0, 0] = 1.0
    with pytest.raises(ValueError):
        w.landmark_ids[0] = 1


# ----------------------------------------------------------------------------- set_pose


@pytest.mark.parametrize(
    ("pose", "match"),
    [
        ((6.5, 6.5, 0.0), "overlaps obstacle 0"),
        ((5.8, 6.5, 0.0), "overlaps obstacle 0"),
        ((5.2, 2.0, 0.0), "overlaps wall 0"),
        ((8.2, 2.2, 0.0), "post of landmark ID 10"),
        ((0.1, 5.0, 0.0), "arena boundary"),
        ((12.0, 5.0, 0.0), "arena boundary"),
        ((math.nan, 5.0, 0.0), "finite"),
    ],
)
def test_set_pose_into_collision_raises(pose, match) -> None:
    w = world()
    before = w.pose
    with pytest.raises(ValueError, match=match):
        w.set_pose(*pose)
    assert w.pose == before


def test_set_pose_teleports_at_rest() -> None:
    w = world()
    for _ in range(3):
        w.step(1.0, 0.5)
    w.set_pose(4.0, 8.0, 7.0)
    assert w.pose == pytest.approx((4.0, 8.0, 7.0 - 2 * math.pi))
    w.step(0.0, 0.0)
    assert w.pose == pytest.approx((4.0, 8.0, 7.0 - 2 * math.pi))
    assert w.is_free(4.0, 8.0) and not w.is_free(6.5, 6.5)


def test_constructor_checks() -> None:
    with pytest.raises(ValueError, match=r"start pose .* overlaps obstacle 0"):
        world(arena(start_pose=(6.5, 6.5, 0.0)))
    with pytest.raises(TypeError, match="layout"):
        World({"width": 10}, ROBOT, DT, SUBSTEPS)
    with pytest.raises(ValueError, match="substeps"):
        World(arena(), ROBOT, DT, 0)
    with pytest.raises(ValueError, match="dt"):
        World(arena(), ROBOT, -0.1, 4)


# ----------------------------------------------------------------------------- determinism


def drive(w: World, n: int, seed: int) -> list:
    """A long run that keeps hitting things: mostly full speed ahead, random turns."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        v = 1.0 if i % 25 < 20 else float(rng.uniform(-1.0, 1.0))
        om = float(rng.uniform(-1.5, 1.5)) if i % 25 >= 20 else 0.05
        out.append((w.step(v, om), w.pose))
    return out


def test_two_fresh_worlds_are_bit_identical() -> None:
    layout = random_layout(WorldConfig(), R, np.random.default_rng(0))
    a = drive(World(layout, ROBOT, DT, SUBSTEPS), 300, seed=1)
    b = drive(World(layout, ROBOT, DT, SUBSTEPS), 300, seed=1)
    assert a == b
    assert sum(c for c, _ in a) > 20  # the run did exercise contacts


_SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from slam_env.config import RobotConfig, WorldConfig
    from slam_env.world.layout_generators import preset_layout
    from slam_env.world.pymunk_world import World
    w = World(preset_layout("cluttered", WorldConfig()), RobotConfig(), 0.2, 4)
    rng = np.random.default_rng(3)
    for i in range(200):
        w.step(1.0 if i % 10 < 7 else -0.5, float(rng.uniform(-1.5, 1.5)))
    print(repr(w.pose))
    """
)


def test_bit_identical_across_processes() -> None:
    outs = []
    for hashseed in ("1", "2"):
        env = dict(os.environ, PYTHONHASHSEED=hashseed)
        res = subprocess.run(
            [sys.executable, "-c", _SCRIPT], capture_output=True, text=True, env=env, check=True
        )
        outs.append(res.stdout.strip())
    w = World(preset_layout("cluttered", WorldConfig()), RobotConfig(), 0.2, 4)
    rng = np.random.default_rng(3)
    for i in range(200):
        w.step(1.0 if i % 10 < 7 else -0.5, float(rng.uniform(-1.5, 1.5)))
    assert outs[0] == outs[1] == repr(w.pose)


@pytest.mark.parametrize("name", ["open", "cluttered", "rooms"])
def test_pickle_mid_run_continues_identically(name) -> None:
    w = World(preset_layout(name, WorldConfig()), ROBOT, DT, SUBSTEPS)
    checked_in_contact = 0
    for k in range(8):
        touched = drive(w, 30, seed=k)[-1][0]
        clone = pickle.loads(pickle.dumps(w)) if k % 2 else copy.deepcopy(w)
        assert clone.pose == w.pose
        a = drive(w, 40, seed=100 + k)
        b = drive(clone, 40, seed=100 + k)
        assert a == b
        checked_in_contact += touched
    assert checked_in_contact >= 2  # some copies were taken while pressed into a wall


def test_pickle_keeps_line_of_sight_and_collision_reporting() -> None:
    w = world()
    w.set_pose(9.0, 5.0, 0.0)
    for _ in range(5):
        w.step(1.0, 0.0)
    clone = pickle.loads(pickle.dumps(w))
    assert clone.step(1.0, 0.0) and w.step(1.0, 0.0)
    assert not clone.line_of_sight((2.0, 2.5), clone.landmark_positions[0], 0)
    assert clone.line_of_sight((7.5, 4.0), clone.landmark_positions[0], 0)


# ----------------------------------------------------------------------------- fast paths
# World.step answers its point queries from earlier answers where it can (clearance
# disks, bisection bounds); these tests hold it to what the plain queries would say.


def reference_step(w: World, v: float, omega: float) -> tuple[bool, tuple[float, float, float]]:
    """World.step written with one plain point query per question (the definition):
    returns (blocked, new pose) without moving ``w``."""
    query = w.space.point_query_nearest
    x, y, a = w.pose
    n = max(SUBSTEPS, math.ceil(abs(v) * DT / (0.5 * R)))
    h = DT / n
    dth, travel = omega * h, v * h
    free = v == 0.0 or query((x, y), R + abs(v) * DT, _MOTION_FILTER) is None
    blocked = False
    for _ in range(n):
        mid_heading = a + 0.5 * dth
        a += dth
        if travel == 0.0:
            continue
        dx, dy = travel * math.cos(mid_heading), travel * math.sin(mid_heading)
        if not free and query((x + dx, y + dy), R, _MOTION_FILTER) is not None:
            blocked = True
            lo, hi = 0.0, 1.0
            for _ in range(CONTACT_BISECTIONS):
                mid = 0.5 * (lo + hi)
                if query((x + mid * dx, y + mid * dy), R, _MOTION_FILTER) is None:
                    lo = mid
                else:
                    hi = mid
            dx, dy = lo * dx, lo * dy
        x += dx
        y += dy
    return blocked, (x, y, (a + math.pi) % (2 * math.pi) - math.pi)


@pytest.mark.parametrize("which", ["random", "cluttered", "rooms"])
def test_step_is_bit_identical_to_plain_queries(which) -> None:
    layout = (
        random_layout(WorldConfig(n_obstacles=10), R, np.random.default_rng(4))
        if which == "random"
        else preset_layout(which, WorldConfig())
    )
    w = World(layout, ROBOT, DT, SUBSTEPS, T)
    rng = np.random.default_rng(5)
    n_blocked = 0
    for i in range(1500):
        # long pushes into things, reversing, turning in place, fast moves
        v = 1.0 if i % 40 < 30 else float(rng.choice([-0.7, 0.0, 3.0, rng.uniform(-1, 1)]))
        omega = float(rng.uniform(-1.5, 1.5)) if i % 5 else 0.0
        expected = reference_step(w, v, omega)
        assert (w.step(v, omega), w.pose) == expected, f"step {i}"
        n_blocked += expected[0]
    assert n_blocked > 50  # the bisection was exercised


@pytest.mark.parametrize("start, wall_x", [((1.0, 2.5, math.pi), 0.0), ((9.0, 2.5, 0.0), 10.0)])
def test_a_robot_pressed_into_a_wall_needs_no_query(start, wall_x) -> None:
    # Each query that finds a shape keeps a point of it: what lies closer than the
    # robot's radius to that point is blocked without asking again.
    w = world()
    w.set_pose(*start)  # facing a boundary wall
    while not w.step(1.0, 0.0):
        pass
    counting = CountingSpace(w._space)
    w._space = counting
    pressed = [w.step(1.0, 0.0) for _ in range(20)]
    assert all(pressed) and counting.queries == 0
    assert abs(w.pose[0] - wall_x) == pytest.approx(R, abs=STOP)
    w.step(-1.0, 0.0)  # backing off is checked, and free
    assert counting.queries > 0 and abs(w.pose[0] - wall_x) > R + 0.1


def test_clearance_answers_like_a_point_query() -> None:
    w = World(preset_layout("cluttered", WorldConfig()), ROBOT, DT, SUBSTEPS, T)
    rng = np.random.default_rng(6)
    x, y = w.pose[:2]
    for _ in range(3000):
        # a random walk, so that consecutive points share clearance disks
        x = min(max(x + rng.normal(0, 0.1), 0.3), w.layout.width - 0.3)
        y = min(max(y + rng.normal(0, 0.1), 0.3), w.layout.height - 0.3)
        reach = float(rng.uniform(0.05, 0.6))
        hit = w.space.point_query_nearest((x, y), reach, _MOTION_FILTER)
        clearance = w._clearance(x, y, reach)
        assert (clearance < reach) == (hit is not None)
        if hit is not None:
            assert clearance == hit.distance


def test_space_shows_the_robot_at_its_pose() -> None:
    w = world()
    for _ in range(7):
        w.step(1.0, 0.5)
    body = next(b for b in w.space.bodies if b.body_type == b.KINEMATIC)
    assert (body.position.x, body.position.y, body.angle) == w.pose
    w.set_pose(3.0, 3.0, 1.0)
    assert w.space is not None  # reading the space brings the body up to date
    assert (body.position.x, body.position.y, body.angle) == (3.0, 3.0, 1.0)
    clone = pickle.loads(pickle.dumps(w))
    body = next(b for b in clone.space.bodies if b.body_type == b.KINEMATIC)
    assert (body.position.x, body.position.y, body.angle) == clone.pose


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_queries_work_on_copies(how) -> None:
    """A copied world's occlusion test, scan and clearance answer like pymunk's queries
    on the copy's own space."""
    w = World(preset_layout("cluttered", WorldConfig()), ROBOT, DT, SUBSTEPS, T)
    clone = pickle.loads(pickle.dumps(w)) if how == "pickle" else copy.deepcopy(w)
    del w  # the clone must not depend on the original's memory
    rng = np.random.default_rng(8)
    pos = clone.landmark_positions
    width, height = clone.layout.width, clone.layout.height
    hits = 0
    for _ in range(300):
        x, y = float(rng.uniform(0.3, width - 0.3)), float(rng.uniform(0.3, height - 0.3))
        i = int(rng.integers(len(pos)))
        assert clone._landmark_visible_from(x, y, i) == pymunk_sees(clone, (x, y), pos[i], i)
        reach = float(rng.uniform(0.05, 0.6))
        hit = clone.space.point_query_nearest((x, y), reach, _MOTION_FILTER)
        clearance = clone._clearance(x, y, reach)
        assert (clearance < reach) == (hit is not None)
        if hit is not None:
            assert clearance == hit.distance
            hits += 1
    assert hits > 10


def test_validated_layout_skips_only_the_check() -> None:
    bad = arena(start_pose=(5.0, 2.5, 0.0))  # the robot would start inside the wall
    with pytest.raises(ValueError):
        World(bad, ROBOT, DT, SUBSTEPS, T)
    good = arena()
    a, b = World(good, ROBOT, DT, SUBSTEPS, T), World(good, ROBOT, DT, SUBSTEPS, T, validated=True)
    assert drive(a, 100, seed=2) == drive(b, 100, seed=2)


# ----------------------------------------------------------------------------- relayout
def same_answers(relaid: World, fresh: World, rng: np.random.Generator) -> None:
    """The relaid world and a fresh one answer alike: pose, landmarks, point queries
    (the motion's), lines of sight and scans (the compiled geometry), and steps."""
    assert relaid.pose == fresh.pose
    assert np.array_equal(relaid.landmark_positions, fresh.landmark_positions)
    assert np.array_equal(relaid.landmark_ids, fresh.landmark_ids)
    width, height = fresh.layout.width, fresh.layout.height
    for _ in range(300):
        x, y = float(rng.uniform(-0.5, width + 0.5)), float(rng.uniform(-0.5, height + 0.5))
        reach = float(rng.uniform(0.0, 1.5))
        a = relaid.space.point_query_nearest((x, y), reach, _MOTION_FILTER)
        b = fresh.space.point_query_nearest((x, y), reach, _MOTION_FILTER)
        assert (a is None) == (b is None)
        if a is not None:
            assert a.distance == b.distance
        row = int(rng.integers(len(fresh.landmark_ids)))
        target = fresh.landmark_positions[row]
        assert relaid.line_of_sight((x, y), target, row) == fresh.line_of_sight((x, y), target, row)
    angles = tuple(np.linspace(-np.pi, np.pi, 16, endpoint=False).tolist())
    assert relaid.range_scan(*fresh.pose, angles, 5.0) == fresh.range_scan(*fresh.pose, angles, 5.0)
    for _ in range(100):  # push into things: contacts resolved by the relaid shapes
        v, omega = float(rng.uniform(-1.0, 1.0)), float(rng.uniform(-1.5, 1.5))
        assert relaid.step(v, omega) == fresh.step(v, omega)
        assert relaid.pose == fresh.pose


def test_relayout_builds_the_world_a_new_one_would() -> None:
    cfg = WorldConfig(n_obstacles=6)
    rng = np.random.default_rng(11)
    w = world(random_layout(cfg, R, np.random.default_rng(0)))
    w.line_of_sight((1.0, 1.0), w.landmark_positions[0], 0)  # its compiled geometry cached
    space = w._space
    # Random worlds of one config reshape the same pymunk shapes; other presets (other
    # shape counts) rebuild them; and back again.
    layouts = [random_layout(cfg, R, np.random.default_rng(seed)) for seed in (1, 2)]
    layouts += [preset_layout("rooms", WorldConfig()), preset_layout("cluttered", WorldConfig())]
    layouts += [random_layout(cfg, R, np.random.default_rng(3)), arena()]
    kept = []
    for layout in layouts:
        w.step(1.0, 0.3)  # a pose and a clear disk from the last world, to be forgotten
        w.relayout(layout)
        kept.append(w._space is space)
        space = w._space
        assert w.layout is layout
        same_answers(w, world(layout), rng)
    assert kept == [True, True, False, False, False, False]


def test_relaid_world_pickles() -> None:
    w = world(random_layout(WorldConfig(), R, np.random.default_rng(0)))
    w.relayout(random_layout(WorldConfig(), R, np.random.default_rng(1)))
    w.step(1.0, 0.2)
    clone = pickle.loads(pickle.dumps(w))
    same_answers(clone, w, np.random.default_rng(2))


def test_relayout_forgets_what_the_queries_found() -> None:
    # Driving in the open leaves a wide clear disk around the robot; a new world with a
    # box right ahead of the same start must not be crossed on the old disk's word.
    w = world(arena(obstacles=()))
    assert not w.step(1.0, 0.0)  # a clearance query: nothing within 0.95 m
    w.set_pose(2.0, 2.5, 0.0)
    boxed = arena(obstacles=(((2.6, 2.0), (3.0, 2.0), (3.0, 3.0), (2.6, 3.0)),))
    w.relayout(boxed)
    fresh = world(boxed)
    for _ in range(10):
        assert w.step(1.0, 0.0) == fresh.step(1.0, 0.0)
        assert w.pose == fresh.pose
    assert w.pose[0] < 2.6 - R + 1e-9  # stopped at the box
    # Pressed into the box, the robot knows a point of it; without the box, it drives on.
    w.relayout(arena(obstacles=()))
    w.set_pose(*fresh.pose)
    open_arena = world(arena(obstacles=()))
    open_arena.set_pose(*fresh.pose)
    for _ in range(5):
        assert w.step(1.0, 0.0) == open_arena.step(1.0, 0.0) == False  # noqa: E712
        assert w.pose == open_arena.pose
