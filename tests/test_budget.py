"""The resource budget (slam_env/budget.py): every option that scales work or memory is
refused at construction, before anything is built, with the option, the derived figure
and the limit; what fits is not refused; the memory figure bounds what is allocated;
the documentation's resource budget page (docs/budget.md) lists every limit."""

from __future__ import annotations

import importlib
import math
import re
import tracemalloc
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from slam_env import budget
from slam_env.budget import check_budget, memory_bytes, world_size
from slam_env.config import WorldConfig, make_config
from slam_env.world.layout_generators import landmark_capacity

RAW, ACTIVE = "slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0"
BUDGET_PAGE = Path(__file__).resolve().parents[1] / "docs" / "budget.md"


def _layout(ids, width=20.0, height=20.0):
    """A layout dict with landmarks of the given IDs on a 1 m grid."""
    return {
        "width": width,
        "height": height,
        "start": [0.5, 0.5, 0.0],
        "landmarks": [
            {"id": int(lid), "x": 1.5 + (k % 15), "y": 1.5 + (k // 15) % 15}
            for k, lid in enumerate(ids)
        ],
    }


# (env ID, options, what the message must name, the figure it must state)
REFUSED = [
    (RAW, {"max_speed": 1e6}, "max_speed", "1.6e+06"),
    (RAW, {"dt": 1e6}, "dt", "8e+06"),
    (RAW, {"radius": 1e-9}, "radius", "4e+08"),
    (RAW, {"physics_substeps": 10**7}, "physics_substeps", "10000000"),
    (RAW, {"scan_beams": 10**7}, "scan_beams", "10000000"),
    (ACTIVE, {"width": 1e5, "height": 1e5}, "width", "40000000000"),
    (RAW, {"preset": "open", "width": 1e5}, "width", "6400000"),
    (ACTIVE, {"max_range": 1e7}, "max_range", "memory"),
    (RAW, {"n_landmarks": 10**4}, "n_landmarks", "10000"),
    (RAW, {"n_landmarks": 400}, "n_landmarks", "400"),  # cannot fit: Oler's bound 298
    (RAW, {"n_obstacles": 10**4}, "n_obstacles", "10000"),
    (RAW, {"max_detections": 10**6}, "max_detections", "1000000"),
    (ACTIVE, {"range_std": 1e200}, "range_std", "1e+200"),
    (RAW, {"max_range": 1e40}, "max_range", "1e+40"),
    (ACTIVE, {"width": 1e18, "radius": 1e9, "coverage": False}, "width", "1e+38"),
    (RAW, {"width": 1e12}, "radius", "4e+12"),
    (ACTIVE, {"alphas": (0.1, 0.1, 1e31, 0.1)}, "alphas[2]", "1e+31"),
    (ACTIVE, {"filter_control_noise": (1e31, 0, 0, 0)}, "filter_control_noise[0]", "1e+31"),
    (ACTIVE, {"filter_measurement_cov": [[1e61, 0], [0, 1]]}, "filter_measurement_cov", "1e+61"),
    (RAW, {"new_landmark_bonus": 1e101}, "new_landmark_bonus", "1e+101"),
    (ACTIVE, {"reward_weights": {"coverage": 1e101}}, "reward_weights.coverage", "1e+101"),
    (RAW, {"layout": _layout([10**9])}, "layout's landmarks and IDs", "memory"),
    (RAW, {"layout": _layout(range(2500), 40.0, 40.0)}, "layout's landmarks", "2500"),
    (
        ACTIVE,
        {"observation": "full", "max_range": 8000.0, "layout": _layout([1999])},
        "observation",
        "memory",
    ),
    (
        ACTIVE,
        {
            "n_landmarks": 2000,
            "width": 200.0,
            "height": 200.0,
            "max_range": 300.0,
            "coverage": False,
        },
        "max_range",
        "32048018000",
    ),
]


@pytest.fixture
def nothing_is_built(monkeypatch):
    """Fail the test if a world, a layout, a filter or a coverage grid is built."""

    def forbidden(*args, **kwargs):
        raise AssertionError("built before the budget was checked")

    # Every module that binds these names is imported before they are patched: one first
    # imported under the patches would keep a fake after them (and fail later tests).
    importlib.import_module("slam_env.envs.vector")  # the envs and both cores
    importlib.import_module("slam_env.belief.ekf_wrapper")
    importlib.import_module("slam_env.belief.coverage_wrapper")
    monkeypatch.setattr("slam_env.world.world_batch.layout_for", forbidden)
    monkeypatch.setattr("slam_env.world.world_batch.World", forbidden)
    monkeypatch.setattr("slam_env.world.layouts.Layout.validate", forbidden)
    monkeypatch.setattr("slam_env.belief.ekf_wrapper.EKFSLAM", forbidden)
    monkeypatch.setattr("slam_env.belief.coverage.CoverageGrid", forbidden)
    monkeypatch.setattr("slam_env.belief.coverage_wrapper.CoverageGrid", forbidden)
    # ActiveSLAM-v0 builds its grid under the name it imported.
    monkeypatch.setattr("slam_env.core.active.CoverageGrid", forbidden)


@pytest.mark.parametrize(("env_id", "options", "name", "figure"), REFUSED)
def test_over_budget_is_refused_before_anything_is_built(
    env_id, options, name, figure, nothing_is_built
):
    with pytest.raises(ValueError, match="exceeds the budget of") as exc:
        gym.make(env_id, **options)
    message = str(exc.value)
    assert name in message and figure in message
    assert "README: Resource budget" in message


def test_refusals_say_what_to_change():
    with pytest.raises(ValueError, match="lower max_speed or dt, or raise radius"):
        gym.make(RAW, max_speed=1e6)
    with pytest.raises(ValueError, match="lower physics_substeps"):
        gym.make(RAW, physics_substeps=10**7)
    with pytest.raises(ValueError, match="coverage=False"):
        gym.make(ACTIVE, width=200.0, height=200.0)


def test_the_limits_themselves_are_accepted():
    cfg = make_config(physics_substeps=budget.MAX_MOVES_PER_STEP)
    assert check_budget(cfg).moves_per_step == budget.MAX_MOVES_PER_STEP
    # 1 m/s · 0.125 s over 0.5·0.25 m: exactly the limit in moves
    cfg = make_config(max_speed=1.0, dt=0.125, radius=0.25 / budget.MAX_MOVES_PER_STEP)
    assert check_budget(cfg).moves_per_step == budget.MAX_MOVES_PER_STEP
    check_budget(make_config(scan_beams=budget.MAX_SCAN_BEAMS))
    check_budget(make_config(max_detections=budget.MAX_DETECTIONS))
    for options in (
        {"physics_substeps": budget.MAX_MOVES_PER_STEP + 1},
        {"scan_beams": budget.MAX_SCAN_BEAMS + 1},
        {"max_detections": budget.MAX_DETECTIONS + 1},
    ):
        with pytest.raises(ValueError, match="budget"):
            check_budget(make_config(**options))
    # A variance may reach NOISE_LIMIT², a σ NOISE_LIMIT.
    check_budget(make_config(), filter_measurement_cov=[[1e59, 0.0], [0.0, 1.0]])
    check_budget(make_config(range_std=budget.NOISE_LIMIT))
    # The egocentric bound 20·max(width, height) / max_range, around its limit.
    check_budget(make_config(max_range=4e-35), belief="egocentric")
    with pytest.raises(ValueError, match="belief bound = 20"):
        check_budget(make_config(max_range=2e-35), belief="egocentric")
    # 100 m × 100 m is the coverage grid's limit, in cells of 0.5 m.
    check_budget(make_config(width=100.0, height=100.0), coverage=True)
    with pytest.raises(ValueError, match="arena cells"):
        check_budget(make_config(width=100.5, height=100.0), coverage=True)


def test_the_belief_work_counts_only_the_landmarks_a_step_can_see():
    """2,000 landmark slots are fine with a 5 m sensor (at most (2·5/1 + 1)² = 121
    landmarks 1 m apart in view); with a 300 m one every landmark may be in view and a
    step could take minutes."""
    near = make_config(n_landmarks=2000, width=200.0, height=200.0)
    assert budget.detections_in_view(near, world_size(near)) == 121
    check_budget(near, belief="egocentric")
    check_budget(near, belief="full")
    far = make_config(n_landmarks=2000, width=200.0, height=200.0, max_range=300.0)
    assert budget.detections_in_view(far, world_size(far)) == 2000
    with pytest.raises(ValueError, match="belief work per step"):
        check_budget(far, belief="egocentric")
    check_budget(
        make_config(
            n_landmarks=2000, width=200.0, height=200.0, max_range=300.0, max_detections=200
        ),
        belief="egocentric",
    )
    check_budget(far)  # the raw stream has no belief


def test_a_huge_arena_without_a_grid_over_it_still_works():
    """A random world needs no grid over the arena: a 100 km arena is fine for the raw
    stream and for the belief without coverage (obstacles far from the origin are not
    mistaken for degenerate ones)."""
    for env_id, options in ((RAW, {}), (ACTIVE, {"coverage": False})):
        env = gym.make(env_id, width=1e5, height=1e5, **options)
        obs, _ = env.reset(seed=0)
        for _ in range(5):
            obs, reward, *_ = env.step(env.action_space.sample())
            assert env.observation_space.contains(obs) and math.isfinite(reward)


def test_the_memory_figure_scales_with_the_sub_envs():
    """A vector env counts the coverage grid's tables once (its sub-envs share them) and
    everything else once per sub-env."""
    cfg = make_config(n_landmarks=200, width=40.0, height=40.0)
    world = world_size(cfg)
    one = memory_bytes(cfg, world, belief="full", coverage=True)
    parts = budget.memory_parts(cfg, world, belief="full", coverage=True)
    shared = parts["coverage_tables"]
    assert budget.SHARED_PARTS == ("coverage_tables",) and shared > 0
    per_env = one - shared
    usage = check_budget(cfg, world, belief="full", coverage=True)
    assert usage.memory_bytes == one > 0
    fits = (budget.MAX_MEMORY_BYTES - shared) // per_env
    usage = check_budget(cfg, world, belief="full", coverage=True, num_envs=fits)
    assert usage.memory_bytes == shared + fits * per_env
    with pytest.raises(ValueError, match=f"memory of {fits + 1} env"):
        check_budget(cfg, world, belief="full", coverage=True, num_envs=fits + 1)
    # The belief's part is (3 + 2·slots)², the raw env's is small.
    assert memory_bytes(cfg, world) < per_env / 10


@pytest.mark.parametrize(
    "options",
    [
        {"observation": "full", "coverage": False, "layout": _layout([0, 5, 399], 30.0, 30.0)},
        {"observation": "egocentric", "width": 60.0, "height": 60.0, "max_range": 20.0},
        {
            "observation": "egocentric",
            "coverage": False,
            "layout": _layout([0, 5, 399], 30.0, 30.0),
            "max_detections": 400,
            "data_association": "jcbb",
        },
        {"observation": "local", "width": 60.0, "height": 60.0, "max_range": 20.0},
    ],
    ids=["dense-belief", "coverage-grid", "association", "local-grids"],
)
def test_the_memory_figure_bounds_what_is_allocated(options):
    """tracemalloc's peak while building and stepping the env stays below the budget's
    figure plus what does not scale with the options (libraries' caches, small arrays)."""
    env = gym.make(ACTIVE, **options)  # warm the imports and caches outside the trace
    env.reset(seed=0)
    base = env.unwrapped
    world = world_size(base.config)
    figure = memory_bytes(
        base.config,
        world,
        belief=options["observation"],
        coverage=options.get("coverage", True),
        association=options.get("data_association", "known") != "known",
    )
    del env, base
    tracemalloc.start()
    try:
        env = gym.make(ACTIVE, **options)
        env.reset(seed=0)
        for _ in range(3):
            env.step(env.action_space.sample())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert figure > 20 * 2**20  # the case is dominated by what the figure models
    assert peak < figure + 8 * 2**20


@pytest.mark.parametrize(("width", "height", "spacing"), [(16, 16, 1.0), (5, 30, 0.7), (3, 3, 2.0)])
def test_landmark_capacity_bounds_a_hexagonal_packing(width, height, spacing):
    """The densest packing of points ``spacing`` apart, a hexagonal lattice in any
    offset, never holds more than the capacity (Oler's bound), and is not far below."""
    cfg = WorldConfig(width=width, height=height, landmark_spacing=spacing, clearance=0.4)
    inner_w, inner_h = width - 0.8, height - 0.8
    best = 0
    for ox in np.linspace(0.0, spacing, 5):
        for oy in np.linspace(0.0, spacing, 5):
            rows = np.arange(oy, inner_h + 1e-9, spacing * math.sqrt(3) / 2)
            count = 0
            for r in range(len(rows)):
                start = ox if r % 2 == 0 else (ox + spacing / 2) % spacing
                count += len(np.arange(start, inner_w + 1e-9, spacing))
            best = max(best, count)
    assert best <= landmark_capacity(cfg) <= 1.5 * best + 5


LIMITS = {
    "MAX_MOVES_PER_STEP": "1,000",
    "MAX_SCAN_BEAMS": "4,096",
    "MAX_LANDMARKS": "2,000",
    "MAX_OBSTACLES": "1,000",
    "MAX_DETECTIONS": "4,096",
    "MAX_BELIEF_WORK": "10¹⁰",
    "MAX_ARENA_CELLS": "40,000",
    "MAX_ARENA_RADII": "10¹⁰",
    "MAX_OBSERVATION_BOUND": "10³⁷",
    "NOISE_LIMIT": "10³⁰",
    "MAX_REWARD_WEIGHT": "10¹⁰⁰",
    "MAX_MEMORY_BYTES": "2 GiB",
}


def test_the_budget_page_lists_every_limit_with_its_value():
    constants = {
        name: getattr(budget, name) for name in dir(budget) if re.fullmatch(r"[A-Z_]+", name)
    }
    limits = {name for name in constants if name.startswith("MAX_") or name.endswith("_LIMIT")}
    assert limits == set(LIMITS)
    section = BUDGET_PAGE.read_text().split("# Resource budget")[1].split("\n## ")[0]
    for name, shown in LIMITS.items():
        row = next(line for line in section.splitlines() if f"`{name}`" in line)
        assert f"| {shown} |" in row, row
        assert constants[name] == _page_number(shown)


def _page_number(shown: str) -> float:
    """A number as the budget page writes it: 1,000; 10³⁰; 2 GiB."""
    if shown.endswith(" GiB"):
        return float(shown[: -len(" GiB")]) * 2**30
    if shown.startswith("10") and not shown[2:].isascii():
        return 10.0 ** int(shown[2:].translate(str.maketrans("⁰¹²³⁴⁵⁶⁷⁸⁹", "0123456789")))
    return float(shown.replace(",", ""))
