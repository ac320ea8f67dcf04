"""Layouts: validation, dict/JSON/YAML round trips, random worlds and presets."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math

import gymnasium as gym
import numpy as np
import pytest
import yaml

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.config import EnvConfig, WorldConfig
from slam_env.layouts import (
    LANDMARK_POST_RADIUS,
    PASSAGE_MARGIN,
    START_MARGIN,
    Layout,
    _polygon_problem,
    _polygon_signed_distance,
    _preset_cached,
    _segment_distance,
    layout_for,
    layout_from_dict,
    layout_to_dict,
    load_layout,
    preset_layout,
    random_layout,
)

R = 0.25  # m, robot radius used throughout
SQUARE = ((4.0, 4.0), (6.0, 4.0), (6.0, 6.0), (4.0, 6.0))


def make(**overrides) -> Layout:
    base = dict(
        width=10.0,
        height=10.0,
        landmark_ids=(0, 1),
        landmark_positions=((2.0, 8.0), (8.0, 8.0)),
        obstacles=(SQUARE,),
        walls=((1.0, 3.0, 3.0, 3.0),),
        start_pose=(1.0, 1.0, 0.0),
    )
    base.update(overrides)
    return Layout(**base)


def test_valid_layout_passes_and_returns_itself() -> None:
    layout = make()
    assert layout.validate(R, clearance=0.4) is layout


# ----------------------------------------------------------------------------- invalid


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"landmark_positions": ((5.0, 5.0), (8.0, 8.0))}, "landmark ID 0 .* inside obstacle 0"),
        ({"landmark_positions": ((6.05, 5.0), (8.0, 8.0))}, "from obstacle 0, closer than"),
        ({"landmark_positions": ((2.0, 3.0), (8.0, 8.0))}, "inside wall 0"),
        ({"landmark_positions": ((2.0, 3.15), (8.0, 8.0))}, "from wall 0, closer than"),
        ({"landmark_positions": ((11.0, 5.0), (8.0, 8.0))}, "landmark ID 0 .* outside the arena"),
        ({"landmark_positions": ((-0.5, 5.0), (8.0, 8.0))}, "outside the arena"),
        ({"landmark_positions": ((0.05, 5.0), (8.0, 8.0))}, "from the arena boundary"),
        ({"landmark_positions": ((8.0, 8.0), (8.1, 8.0))}, "posts of ID 0 and ID 1 overlap"),
        ({"landmark_ids": (3, 3)}, "duplicate landmark ID 3"),
        ({"landmark_ids": (0, -2)}, "negative landmark ID -2"),
        ({"landmark_ids": (0, 1, 2)}, "landmark_ids has 3 entries but landmark_positions has 2"),
        ({"landmark_positions": ((2.0, 8.0),)}, "has 2 entries but landmark_positions has 1"),
        ({"landmark_positions": ((math.nan, 8.0), (8.0, 8.0))}, "non-finite position"),
        ({"landmark_positions": ((2.0, math.inf), (8.0, 8.0))}, "non-finite position"),
        ({"width": math.inf}, "arena size must be finite"),
        ({"height": -1.0}, "arena size must be finite and > 0"),
        ({"obstacles": (((1.0, 1.0), (2.0, math.nan), (2.0, 2.0)),)}, "obstacle 0 .*non-finite"),
        ({"walls": ((1.0, 3.0, math.inf, 3.0),)}, "wall 0 has a non-finite"),
        ({"start_pose": (1.0, 1.0, math.nan)}, "start_pose is not finite"),
        ({"obstacles": (((4.0, 4.0), (6.0, 4.0)),)}, "obstacle 0 is degenerate: .*2 vertices"),
        ({"obstacles": (((4.0, 4.0), (6.0, 4.0), (8.0, 4.0)),)}, "obstacle 0 .*zero area"),
        (
            {"obstacles": (((4.0, 4.0), (4.0, 4.0), (6.0, 4.0), (5.0, 6.0)),)},
            "obstacle 0 is degenerate: vertex 0 repeats",
        ),
        (
            # An arrowhead: a reflex vertex.
            {"obstacles": (((4.0, 4.0), (7.0, 5.0), (4.0, 6.0), (5.0, 5.0)),)},
            "obstacle 0 is not convex",
        ),
        (
            # A pentagram: every turn has the same sign, but the edges cross.
            {
                "obstacles": (
                    tuple(
                        (5.0 + math.cos(a), 5.0 + math.sin(a))
                        for a in (math.pi / 2 + k * 4 * math.pi / 5 for k in range(5))
                    ),
                )
            },
            "obstacle 0 is not convex",
        ),
        (
            {"obstacles": (((9.0, 4.0), (11.0, 4.0), (11.0, 6.0), (9.0, 6.0)),)},
            "obstacle 0 extends outside the arena",
        ),
        ({"walls": ((1.0, 3.0, 1.0, 3.0),)}, "wall 0 has zero length"),
        ({"walls": ((1.0, 3.0, 12.0, 3.0),)}, "wall 0 extends outside the arena"),
        ({"start_pose": (0.1, 1.0, 0.0)}, r"start pose .* in collision: .*arena boundary"),
        ({"start_pose": (12.0, 1.0, 0.0)}, "start pose .* outside the arena"),
        ({"start_pose": (3.8, 5.0, 0.0)}, "start pose .* overlaps obstacle 0"),
        ({"start_pose": (2.0, 3.3, 0.0)}, "start pose .* overlaps wall 0"),
        ({"start_pose": (2.0, 7.7, 0.0)}, "start pose .* post of landmark ID 0"),
    ],
)
def test_invalid_layouts_raise_naming_the_problem(overrides, match) -> None:
    with pytest.raises(ValueError, match=match):
        make(**overrides).validate(R, clearance=0.4)


def test_clearance_only_applies_when_asked() -> None:
    near = make(landmark_positions=((6.3, 5.0), (8.0, 8.0)))  # 0.3 m from the square
    near.validate(R)  # post radius only
    with pytest.raises(ValueError, match=r"0\.3 m from obstacle 0"):
        near.validate(R, clearance=0.4)


def test_wall_thickness_counts_for_start_and_landmarks() -> None:
    layout = make(start_pose=(2.0, 3.5, 0.0))  # 0.5 m from the wall's centre line
    layout.validate(R, wall_thickness=0.1)
    with pytest.raises(ValueError, match="overlaps wall 0"):
        layout.validate(R, wall_thickness=0.3)


def test_validate_rejects_bad_robot_radius() -> None:
    with pytest.raises(ValueError, match="robot_radius"):
        make().validate(0.0)
    with pytest.raises(ValueError, match="clearance"):
        make().validate(R, clearance=-1.0)


def test_wrong_types_raise_type_error() -> None:
    with pytest.raises(TypeError, match="landmark_ids"):
        make(landmark_ids=(0, 1.5))
    with pytest.raises(TypeError, match="landmark_ids"):
        make(landmark_ids=(True, 1))
    with pytest.raises(TypeError, match="width"):
        make(width="10")
    with pytest.raises(TypeError, match="name"):
        make(name=3)
    with pytest.raises(ValueError, match="start_pose must have 3 numbers"):
        make(start_pose=(1.0, 1.0))


def test_either_winding_is_accepted_and_normalised() -> None:
    cw = tuple(reversed(SQUARE))
    layout = make(obstacles=(cw,))
    layout.validate(R)
    assert layout.obstacles == make().obstacles  # counter-clockwise


def test_construction_normalises_numpy_inputs() -> None:
    layout = make(
        landmark_ids=np.array([4, 7]),
        landmark_positions=np.array([[2.0, 8.0], [8.0, 8.0]]),
        start_pose=np.array([1.0, 1.0, 0.0]),
    )
    assert layout.landmark_ids == (4, 7)
    assert all(type(i) is int for i in layout.landmark_ids)
    assert layout.landmark_positions == ((2.0, 8.0), (8.0, 8.0))
    assert all(type(c) is float for p in layout.landmark_positions for c in p)
    assert hash(layout) == hash(make(landmark_ids=(4, 7)))


def test_geometry_helpers() -> None:
    assert _segment_distance(0.0, 1.0, -1.0, 0.0, 1.0, 0.0) == pytest.approx(1.0)
    assert _segment_distance(3.0, 0.0, -1.0, 0.0, 1.0, 0.0) == pytest.approx(2.0)
    assert _polygon_signed_distance(5.0, 5.0, SQUARE) == pytest.approx(-1.0)
    assert _polygon_signed_distance(7.0, 5.0, SQUARE) == pytest.approx(1.0)
    assert _polygon_signed_distance(7.0, 7.0, SQUARE) == pytest.approx(math.sqrt(2.0))


def test_collision_queries() -> None:
    layout = make()
    assert layout.is_free(1.0, 1.0, R)
    assert layout.collision_reason(3.8, 5.0, R) == "overlaps obstacle 0"
    assert layout.collision_reason(3.75, 5.0, R) is None  # touching counts as free
    assert not layout.is_free(3.75, 5.0, R, margin=0.01)


# ----------------------------------------------------------------------------- dict / files


def test_dict_round_trip_is_exact() -> None:
    layout = make(name="demo", start_pose=(1.0, 1.5, 0.25))
    d = layout_to_dict(layout)
    assert layout_from_dict(d) == layout
    assert json.loads(json.dumps(d)) == d  # plain JSON types


def test_json_and_yaml_files_round_trip(tmp_path) -> None:
    layout = random_layout(WorldConfig(), R, np.random.default_rng(3))
    jpath = tmp_path / "world.json"
    jpath.write_text(json.dumps(layout_to_dict(layout)))
    assert load_layout(jpath) == layout
    assert load_layout(str(jpath)) == layout
    for name in ("world.yaml", "world.yml"):
        ypath = tmp_path / name
        ypath.write_text(yaml.safe_dump(layout_to_dict(layout)))
        assert load_layout(ypath) == layout
    bad = tmp_path / "world.txt"
    bad.write_text("{}")
    with pytest.raises(ValueError, match=r"\.json, \.yaml or \.yml"):
        load_layout(bad)
    listy = tmp_path / "list.yaml"
    listy.write_text("- 1\n- 2\n")
    with pytest.raises(TypeError, match="mapping"):
        load_layout(listy)


def test_from_dict_accepts_point_lists_boxes_and_defaults() -> None:
    layout = layout_from_dict(
        {
            "width": 10,
            "height": 8,
            "landmarks": [[2, 2], [8, 6]],
            "obstacles": [{"box": [5, 4, 2, 1]}, [[1, 5], [1, 7], [2, 7]]],
            "walls": [[7, 1, 7, 3]],
        }
    )
    assert layout.landmark_ids == (0, 1)
    assert layout.obstacles[0] == ((4.0, 3.5), (6.0, 3.5), (6.0, 4.5), (4.0, 4.5))
    assert layout.obstacles[1] == ((2.0, 7.0), (1.0, 7.0), (1.0, 5.0))  # now CCW
    assert layout.start_pose == (1.0, 1.0, 0.0)
    assert layout.name == "custom"
    layout.validate(R)
    assert load_layout(layout) is layout


@pytest.mark.parametrize(
    ("d", "exc", "match"),
    [
        ({"width": 5, "height": 5, "colour": 1, "size": 2}, ValueError, "'colour', 'size'"),
        ({"height": 5}, ValueError, "missing 'width'"),
        ({"width": "5", "height": 5}, TypeError, "width"),
        ({"width": 5, "height": 5, "landmarks": 3}, TypeError, "landmarks"),
        ({"width": 5, "height": 5, "landmarks": [{"id": 0, "x": 1}]}, ValueError, "missing: y"),
        (
            {"width": 5, "height": 5, "landmarks": [{"id": 0, "x": 1, "y": 1, "z": 0}]},
            ValueError,
            "unknown: z",
        ),
        (
            {"width": 5, "height": 5, "landmarks": [{"id": "a", "x": 1, "y": 1}]},
            TypeError,
            "id",
        ),
        (
            {"width": 5, "height": 5, "landmarks": [{"id": 0, "x": 1, "y": 1}, [2, 2]]},
            ValueError,
            "mixes",
        ),
        ({"width": 5, "height": 5, "landmarks": [[1, 2, 3]]}, ValueError, "2 numbers"),
        ({"width": 5, "height": 5, "obstacles": [{"circle": 1}]}, ValueError, "circle"),
        ({"width": 5, "height": 5, "obstacles": [{"box": [1, 1, 0, 1]}]}, ValueError, "> 0"),
        ({"width": 5, "height": 5, "obstacles": [{"box": [1, 1, "2", 1]}]}, TypeError, "box"),
        ({"width": 5, "height": 5, "walls": [[0, 0, 1]]}, ValueError, "4 numbers"),
        ({"width": 5, "height": 5, "start": "here"}, TypeError, "start"),
        ({"width": 5, "height": 5, "name": 7}, TypeError, "name"),
        ([1, 2], TypeError, "mapping"),
    ],
)
def test_from_dict_errors(d, exc, match) -> None:
    with pytest.raises(exc, match=match):
        layout_from_dict(d)


# ----------------------------------------------------------------------------- random


def check_random_layout(layout: Layout, cfg: WorldConfig, r: float) -> None:
    layout.validate(r, cfg.clearance, wall_thickness=cfg.wall_thickness)
    assert layout.landmark_ids == tuple(range(cfg.n_landmarks))
    assert len(layout.obstacles) == cfg.n_obstacles
    pts = layout.landmark_array()
    assert np.all(pts >= cfg.clearance) and np.all(pts <= [cfg.width - cfg.clearance] * 2)
    d = np.linalg.norm(pts[:, None] - pts[None], axis=-1) + np.eye(len(pts)) * 1e9
    assert d.min() >= cfg.landmark_spacing
    lo, hi = cfg.obstacle_size
    gap = 2 * r + PASSAGE_MARGIN
    for poly in layout.obstacles:
        xs, ys = [p[0] for p in poly], [p[1] for p in poly]
        assert lo <= max(xs) - min(xs) <= hi and lo <= max(ys) - min(ys) <= hi
        assert min(xs) >= gap - 1e-9 and max(xs) <= cfg.width - gap + 1e-9
        for x, y in pts:
            assert _polygon_signed_distance(x, y, poly) >= cfg.clearance
    sx, sy, sth = layout.start_pose
    assert -math.pi <= sth < math.pi
    assert layout.is_free(sx, sy, r, wall_thickness=cfg.wall_thickness, margin=START_MARGIN - 1e-9)


def test_random_layout_satisfies_constraints() -> None:
    cfg = WorldConfig()
    for seed in range(20):
        check_random_layout(random_layout(cfg, R, np.random.default_rng(seed)), cfg, R)
    dense = WorldConfig(width=10.0, height=6.0, n_landmarks=30, n_obstacles=4, clearance=0.3)
    for seed in range(5):
        check_random_layout(random_layout(dense, 0.3, np.random.default_rng(seed)), dense, 0.3)


def test_random_layout_is_reproducible_from_the_rng() -> None:
    cfg = WorldConfig()
    a = random_layout(cfg, R, np.random.default_rng(7))
    b = random_layout(cfg, R, np.random.default_rng(7))
    c = random_layout(cfg, R, np.random.default_rng(8))
    assert a == b
    assert a.landmark_positions != c.landmark_positions
    assert a.obstacles != c.obstacles
    assert a.start_pose != c.start_pose


@pytest.mark.parametrize(
    ("cfg", "match"),
    [
        (WorldConfig(n_landmarks=400, landmark_spacing=1.0), "landmark_spacing"),
        (WorldConfig(width=4.0, height=4.0, n_landmarks=20, n_obstacles=0), "landmark_spacing"),
        (WorldConfig(n_obstacles=60, obstacle_size=(1.5, 2.0)), "could not place obstacle"),
        (WorldConfig(width=3.0, height=3.0, obstacle_size=(2.0, 2.0)), "does not fit"),
        (WorldConfig(width=3.0, height=3.0, n_obstacles=0, clearance=1.6), "clearance"),
    ],
)
def test_random_layout_reports_infeasible_density(cfg, match) -> None:
    with pytest.raises(ValueError, match=match):
        random_layout(cfg, R, np.random.default_rng(0))


def test_random_layout_checks_arguments() -> None:
    with pytest.raises(TypeError, match="Generator"):
        random_layout(WorldConfig(), R, 0)
    with pytest.raises(ValueError, match="robot_radius"):
        random_layout(WorldConfig(), -1.0, np.random.default_rng(0))


# ----------------------------------------------------------------------------- presets


@pytest.mark.parametrize("name", ["open", "cluttered", "rooms"])
@pytest.mark.parametrize(
    "cfg",
    [
        WorldConfig(),
        WorldConfig(width=30.0, height=20.0, n_landmarks=50),
        WorldConfig(width=8.0, height=8.0, n_landmarks=8),
    ],
)
def test_presets_validate_and_are_deterministic(name, cfg) -> None:
    layout = preset_layout(name, cfg)
    layout.validate(R, cfg.clearance, wall_thickness=cfg.wall_thickness)
    assert layout.name == name
    assert layout.landmark_ids == tuple(range(cfg.n_landmarks))
    assert layout.width == cfg.width and layout.height == cfg.height
    pts = layout.landmark_array()
    d = np.linalg.norm(pts[:, None] - pts[None], axis=-1) + np.eye(len(pts)) * 1e9
    assert d.min() >= cfg.landmark_spacing
    _preset_cached.cache_clear()
    assert preset_layout(name, cfg) == layout  # rebuilt from scratch: the same map


def test_preset_shapes() -> None:
    cfg = WorldConfig()
    open_ = preset_layout("open", cfg)
    cluttered = preset_layout("cluttered", cfg)
    rooms = preset_layout("rooms", cfg)
    assert open_.obstacles == () and open_.walls == ()
    assert len(cluttered.obstacles) >= 2 * cfg.n_obstacles
    assert cluttered.walls == ()
    assert len(rooms.walls) >= 4 and rooms.obstacles == ()
    # Every door leaves room for the robot: wall ends on one line are > 2(r + t) apart.
    t = cfg.wall_thickness
    ends = sorted((w[1], w[3]) for w in rooms.walls if w[0] == w[2] == cfg.width / 2)
    gaps = [start1 - end0 for (_, end0), (start1, _) in itertools.pairwise(ends)]
    doors = [g for g in gaps if g > 1e-9]
    assert len(doors) == 2  # one per room pair the middle wall separates
    assert all(g > 2 * (R + t) for g in doors)


def test_preset_errors() -> None:
    with pytest.raises(ValueError, match="unknown preset 'maze'"):
        preset_layout("maze", WorldConfig())
    with pytest.raises(ValueError, match="rooms"):
        preset_layout("rooms", WorldConfig(width=4.0, height=4.0, n_landmarks=2))
    with pytest.raises(ValueError, match="landmark_spacing"):
        preset_layout("open", WorldConfig(width=5.0, height=5.0, n_landmarks=100))


# ----------------------------------------------------------------------------- layout_for


def test_layout_for_dispatch(tmp_path) -> None:
    rng = np.random.default_rng(0)
    random_cfg = EnvConfig()
    a = layout_for(random_cfg, np.random.default_rng(5))
    assert a == random_layout(random_cfg.world, random_cfg.robot.radius, np.random.default_rng(5))
    with pytest.raises(ValueError, match="rng"):
        layout_for(random_cfg, None)

    rooms_cfg = EnvConfig(world=WorldConfig(preset="rooms"))
    assert layout_for(rooms_cfg, rng) == preset_layout("rooms", rooms_cfg.world)

    user = make(name="user")
    path = tmp_path / "user.json"
    path.write_text(json.dumps(layout_to_dict(user)))
    for source in (user, layout_to_dict(user), path, str(path)):
        cfg = dataclasses.replace(rooms_cfg, layout=source)
        assert layout_for(cfg, None) == user

    bad = dataclasses.replace(EnvConfig(), layout=make(start_pose=(4.0, 5.0, 0.0)))
    with pytest.raises(ValueError, match="overlaps obstacle 0"):
        layout_for(bad, None)


def test_post_radius_constant() -> None:
    assert pytest.approx(0.1) == LANDMARK_POST_RADIUS


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("bad.yaml", "width: 10\nheight: [1,\nstart: 3\n", r"bad\.yaml', line 4: not valid YAML"),
        ("bad.json", '{"width": 10,\n "height": }', r"bad\.json', line 2: not valid JSON"),
        ("binary.yaml", b"\xff\xfe\x00", r"binary\.yaml' cannot be read: 'utf-8' codec"),
        ("missing.yaml", None, r"missing\.yaml' cannot be read: No such file"),
        ("folder.yml", "dir", r"folder\.yml' cannot be read: Is a directory"),
        (
            "short.json",
            '{"width": 5, "height": 5, "start": [1, 1]}',
            r"short\.json': layout 'start'",
        ),
    ],
)
def test_layout_file_errors_name_the_file(tmp_path, name, content, message) -> None:
    path = tmp_path / name
    if content == "dir":
        path.mkdir()
    elif isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    with pytest.raises(ValueError, match=message):
        load_layout(path)
    # The env reports it the same way, before building anything.
    with pytest.raises(ValueError, match=message):
        gym.make("slam_env/Landmarks-v0", layout=str(path))


def test_a_far_obstacle_is_not_taken_for_a_degenerate_one() -> None:
    """Degeneracy is judged on the polygon's own size, wherever it lies."""
    box = ((5e8, 5e8), (5e8 + 1.0, 5e8), (5e8 + 1.0, 5e8 + 1.0), (5e8, 5e8 + 1.0))
    assert _polygon_problem(box) is None
    assert "zero area" in _polygon_problem(((5e8, 5e8), (5e8 + 1.0, 5e8), (5e8 + 2.0, 5e8)))
    assert "repeats" in _polygon_problem(((5e8, 5e8), (5e8, 5e8), (5e8 + 1.0, 5e8 + 1.0)))
