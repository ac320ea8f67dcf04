"""The "local" observation of ActiveSLAM-v0: its kernels against plain references, its
size fixed across worlds, and the env's use of it."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.belief.coverage import CoverageGrid
from slam_env.belief.encodings import BeliefGeometry
from slam_env.belief.local_encoding import (
    MAP_CELL,
    MAP_SIDE,
    NEAREST_LANDMARKS,
    LocalEncoding,
    local_space,
)
from slam_env.config import SensorConfig
from slam_env.kernels.belief.local_map import MAP_CHANNELS, SUBSAMPLES, mark_scan_hits

ACTIVE = "slam_env/ActiveSLAM-v0"


# ---------------------------------------------------------------------- references
def _tanh_std(variance: float, scale: float) -> float:
    return math.tanh(math.sqrt(max(variance, 0.0)) / scale)


def reference_local(enc: LocalEncoding, x, P, n, obstacles, swept_padded):
    """World-by-world, the layout of :class:`LocalEncoding` written out plainly."""
    scales = enc.params.scales
    width, height, max_range, pscale, hscale, total, cell_m = scales
    grid_cell, pad = enc.params.cell, enc.params.pad
    low, high = enc.params.robot_bounds
    ny, nx = obstacles.shape[1:]
    b_count = x.shape[0]
    robot = np.zeros((b_count, 8), np.float32)
    lms = np.zeros((b_count, 4 * NEAREST_LANDMARKS), np.float32)
    local_map = np.zeros((b_count, MAP_CHANNELS, MAP_SIDE, MAP_SIDE), np.float32)
    for b in range(b_count):
        px, py, th = x[b, :3]
        c, s = math.cos(th), math.sin(th)
        feats = [
            _tanh_std(P[b, 0, 0], pscale),
            _tanh_std(P[b, 1, 1], pscale),
            _tanh_std(P[b, 2, 2], hscale),
            c,
            s,
            px / width,
            py / height,
            n[b] / total,
        ]
        robot[b] = np.clip(feats, low, high)
        pos = x[b, 3 : 3 + 2 * n[b]].reshape(-1, 2)
        d2 = ((pos - [px, py]) ** 2).sum(axis=1)
        order = np.argsort(d2, kind="stable")[:NEAREST_LANDMARKS]
        for j, i in enumerate(order):
            dx, dy = pos[i] - [px, py]
            row = 3 + 2 * i
            lms[b, 4 * j : 4 * j + 4] = [
                1.0,
                (c * dx + s * dy) / max_range,
                (-s * dx + c * dy) / max_range,
                _tanh_std(P[b, row, row] + P[b, row + 1, row + 1], pscale),
            ]
        half = 0.5 * MAP_SIDE * cell_m
        for r in range(MAP_SIDE):
            for q in range(MAP_SIDE):
                points = [
                    (
                        (q + (v + 0.5) / SUBSAMPLES) * cell_m - half,
                        (r + (u + 0.5) / SUBSAMPLES) * cell_m - half,
                    )
                    for u in range(SUBSAMPLES)
                    for v in range(SUBSAMPLES)
                ]
                for fx, fy in points:
                    wx, wy = px + c * fx - s * fy, py + s * fx + c * fy
                    if not (0 <= wx < nx * grid_cell and 0 <= wy < ny * grid_cell):
                        local_map[b, 2, r, q] += 1 / len(points)
                        continue
                    i, j = int(wy / grid_cell), int(wx / grid_cell)
                    if not swept_padded[b, i + pad, j + pad]:
                        local_map[b, 0, r, q] += 1 / len(points)
                    if obstacles[b, i, j]:
                        local_map[b, 1, r, q] = 1.0
        for i, (lx, ly) in enumerate(pos):
            dx, dy = lx - px, ly - py
            q = math.floor((c * dx + s * dy + half) / cell_m)
            r = math.floor((-s * dx + c * dy + half) / cell_m)
            if 0 <= q < MAP_SIDE and 0 <= r < MAP_SIDE:
                row = 3 + 2 * i
                mark = 0.25 + 0.75 * _tanh_std(P[b, row, row] + P[b, row + 1, row + 1], pscale)
                local_map[b, 3, r, q] = max(local_map[b, 3, r, q], mark)
    return robot, lms, local_map.reshape(b_count, -1)


def _encoding(worlds: int, width: float = 12.0, height: float = 9.0, beams: int = 8):
    sensor = SensorConfig(max_range=4.0)
    grid = CoverageGrid.for_sensor(width, height, sensor, worlds=worlds)
    angles = -math.pi + 2 * math.pi * (np.arange(beams) + 0.5) / beams
    enc = LocalEncoding(BeliefGeometry(15, width, height, 4.0), 15, grid, angles, 3.0)
    return enc, grid


def _random_belief(rng: np.random.Generator, worlds: int, m: int = 15):
    dmax = 3 + 2 * m
    x = np.zeros((worlds, dmax))
    P = np.zeros((worlds, dmax, dmax))
    n = rng.integers(0, m + 1, size=worlds).astype(np.int64)
    for b in range(worlds):
        x[b, :2] = rng.uniform([0.5, 0.5], [11.5, 8.5])
        x[b, 2] = rng.uniform(-math.pi, math.pi)
        x[b, 3:] = rng.uniform(-1.0, 13.0, dmax - 3)
        a = rng.normal(size=(dmax, dmax)) * 0.2
        P[b] = a @ a.T
    slot_to_id = np.tile(np.arange(m, dtype=np.int64), (worlds, 1))
    return x, P, n, slot_to_id


def test_the_kernel_matches_the_plain_reference():
    rng = np.random.default_rng(4)
    worlds = 5
    enc, grid = _encoding(worlds)
    x, P, n, ids = _random_belief(rng, worlds)
    n[0] = 0  # no landmark known
    n[1] = 15  # more than K
    grid.step_all(x, np.ones(worlds, bool))
    enc.obstacles[:] = rng.random(enc.obstacles.shape) < 0.1
    out = enc.empty(worlds)
    clipped = np.zeros(worlds, bool)
    active = np.ones(worlds, bool)
    obstacles = enc.obstacles.copy()
    enc.encode_batch((x, P, n, ids), np.ones((worlds, 8), np.float32), out, clipped, active)
    np.testing.assert_array_equal(enc.obstacles, obstacles)  # a scan of no hits marks nothing
    robot, lms, local_map = reference_local(enc, x, P, n, obstacles, grid.padded)
    np.testing.assert_allclose(out["robot"], robot, atol=1e-6)
    np.testing.assert_allclose(out["landmarks"], lms, atol=1e-5)
    np.testing.assert_allclose(out["local_map"], local_map, atol=1e-6)
    assert not clipped.any()
    assert out["landmarks"][0].sum() == 0.0  # padding when nothing is known
    assert out["landmarks"][1, 0::4].sum() == NEAREST_LANDMARKS
    for key, box in local_space().spaces.items():
        assert all(box.contains(row) for row in out[key]), key


def test_inactive_worlds_are_left_alone():
    rng = np.random.default_rng(1)
    enc, _ = _encoding(2)
    x, P, n, ids = _random_belief(rng, 2)
    out = enc.empty(2)
    out["robot"][1] = 7.0
    enc.encode_batch(
        (x, P, n, ids), np.zeros((2, 8), np.float32), out, np.zeros(2, bool), np.array([1, 0], bool)
    )
    assert (out["robot"][1] == 7.0).all()
    assert not enc.obstacles[1].any()


def test_scan_hits_are_marked_just_behind_the_hit_from_the_estimated_pose():
    rng = np.random.default_rng(2)
    worlds, beams, reach, cell = 3, 12, 3.0, 0.5
    obstacles = np.zeros((worlds, 18, 24), np.bool_)
    x = np.zeros((worlds, 5))
    x[:, :2] = rng.uniform(1.0, 8.0, (worlds, 2))
    x[:, 2] = rng.uniform(-3, 3, worlds)
    x[2, 0] = np.nan  # a diverged pose marks nothing
    angles = -math.pi + 2 * math.pi * (np.arange(beams) + 0.5) / beams
    scan = rng.uniform(0.0, 1.0, (worlds, beams)).astype(np.float32)
    scan[:, ::3] = 1.0  # no hit
    mark_scan_hits(x, scan, angles, reach, cell, obstacles, np.ones(worlds, bool))
    expected = np.zeros_like(obstacles)
    for b in range(2):
        for k in range(beams):
            if scan[b, k] < 1.0:
                d = float(scan[b, k]) * reach + 0.25 * cell
                hx = x[b, 0] + d * math.cos(x[b, 2] + angles[k])
                hy = x[b, 1] + d * math.sin(x[b, 2] + angles[k])
                if 0 <= hx < 24 * cell and 0 <= hy < 18 * cell:
                    expected[b, int(hy / cell), int(hx / cell)] = True
    np.testing.assert_array_equal(obstacles, expected)
    assert obstacles[:2].any() and not obstacles[2].any()


def test_a_diverged_belief_is_clipped_and_reported():
    rng = np.random.default_rng(3)
    enc, _ = _encoding(2)
    x, P, n, ids = _random_belief(rng, 2)
    n[:] = 3
    x[0, 0] = np.nan
    x[1, 3] = 1e9  # a landmark far beyond the bound
    out = enc.empty(2)
    clipped = np.zeros(2, bool)
    enc.encode_batch((x, P, n, ids), np.ones((2, 8), np.float32), out, clipped, np.ones(2, bool))
    assert clipped.all()
    for key, box in local_space().spaces.items():
        assert all(box.contains(row) for row in out[key]), key
    assert out["local_map"][0].sum() == 0.0  # no map from a NaN pose


WORLDS = [
    {},
    {"n_landmarks": 1},
    {"n_landmarks": 60, "width": 32.0, "height": 32.0},
    {"width": 8.0, "height": 8.0, "n_landmarks": 10},
    {"preset": "open"},
    {"preset": "cluttered"},
    {"preset": "rooms"},
    {"max_range": 2.0},
    {"fov": 2 * math.pi},
]


def test_the_space_is_the_same_for_every_world():
    spaces = []
    for options in WORLDS:
        env = gym.make(ACTIVE, observation="local", **options)
        obs, _ = env.reset(seed=0)
        for _ in range(5):
            obs, *_ = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs), options
        spaces.append(env.observation_space)
        env.close()
    assert all(s == spaces[0] for s in spaces)
    assert spaces[0]["local_map"].shape == (MAP_CHANNELS * MAP_SIDE * MAP_SIDE,)
    assert MAP_CELL > 0


def test_the_vector_env_batches_the_same_space():
    venv = gym.make_vec(
        ACTIVE,
        num_envs=3,
        vectorization_mode="vector_entry_point",
        observation="local",
        preset="cluttered",
    )
    obs, _ = venv.reset(seed=0)
    assert venv.single_observation_space == local_space_with_extras()
    assert obs["local_map"].shape == (3, MAP_CHANNELS * MAP_SIDE * MAP_SIDE)
    assert venv.observation_space.contains(obs)
    venv.close()


def local_space_with_extras() -> gym.spaces.Dict:
    env = gym.make(ACTIVE, observation="local")
    try:
        return env.observation_space
    finally:
        env.close()


def test_the_map_remembers_obstacles_and_forgets_them_at_reset():
    env = gym.make(ACTIVE, observation="local", preset="cluttered")
    env.reset(seed=0)
    memory = env.unwrapped._core._encoding.obstacles
    first = memory.copy()  # what the first scan hit
    for _ in range(40):
        env.step(np.array([1.0, 0.2], np.float32))
    assert memory.sum() > first.sum()
    env.reset(seed=0)
    np.testing.assert_array_equal(memory, first)
    env.close()


def test_local_needs_the_coverage():
    with pytest.raises(ValueError, match="coverage"):
        gym.make(ACTIVE, observation="local", coverage=False)
    with pytest.raises(ValueError, match="observation must be one of"):
        gym.make(ACTIVE, observation="nearby")
