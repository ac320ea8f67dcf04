"""Layout generators: random worlds, presets and layout_for."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math

import numpy as np
import pytest

from slam_env.config import EnvConfig, WorldConfig
from slam_env.world.layout_files import layout_to_dict
from slam_env.world.layout_generators import (
    PASSAGE_MARGIN,
    START_MARGIN,
    _preset_cached,
    layout_for,
    preset_layout,
    random_layout,
)
from slam_env.world.layouts import Layout, _polygon_signed_distance
from tests.world.layout_samples import R, make

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


def test_every_drawn_world_is_valid() -> None:
    # random_layout does not call Layout.validate (each reset would pay it): what it
    # draws must pass it by construction, over the whole configuration space, or it
    # must refuse the configuration with a ValueError.
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    sizes = st.floats(1.0, 30.0)

    # Derandomized: the same 300 configurations in every run (102 of them drawable).
    # Drawn afresh, 90 to 151 were, fewer than 100 in 2 runs of 17: a flaky test.
    @settings(
        max_examples=300,
        deadline=None,
        derandomize=True,
        suppress_health_check=list(HealthCheck),
    )
    @given(
        width=sizes,
        height=sizes,
        n_landmarks=st.integers(1, 60),
        n_obstacles=st.integers(0, 12),
        box=st.tuples(st.floats(0.05, 4.0), st.floats(0.0, 3.0)),
        spacing=st.floats(0.0, 3.0),
        clearance=st.floats(0.0, 1.5),
        wall_thickness=st.floats(0.01, 0.5),
        radius=st.floats(0.02, 0.8),
        seed=st.integers(0, 2**32 - 1),
    )
    def drawn_world_is_valid(
        width,
        height,
        n_landmarks,
        n_obstacles,
        box,
        spacing,
        clearance,
        wall_thickness,
        radius,
        seed,
    ) -> None:
        cfg = WorldConfig(
            width=width,
            height=height,
            n_landmarks=n_landmarks,
            n_obstacles=n_obstacles,
            obstacle_size=(box[0], box[0] + box[1]),
            landmark_spacing=spacing,
            clearance=clearance,
            wall_thickness=wall_thickness,
        )
        try:
            layout = random_layout(cfg, radius, np.random.default_rng(seed))
        except ValueError:
            drawn["refused"] += 1
            return
        drawn["drawn"] += 1
        layout.validate(radius, clearance, wall_thickness=wall_thickness)

    drawn = {"drawn": 0, "refused": 0}
    drawn_world_is_valid()
    assert drawn["drawn"] >= 100  # a third of the configurations were drawn, and checked


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
