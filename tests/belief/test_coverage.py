"""The swept-area memory (slam_env.belief.coverage) and its place in ActiveSLAM-v0."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401
from slam_env.belief.coverage import CoverageGrid
from slam_env.belief.coverage_wrapper import CoverageWrapper
from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.belief.reward_wrapper import ActiveSLAMReward
from slam_env.envs.landmarks import LandmarksEnv

ENV_ID = "slam_env/ActiveSLAM-v0"


def cell_centres(grid: CoverageGrid) -> tuple[np.ndarray, np.ndarray]:
    xs = (np.arange(grid.nx) + 0.5) * grid.cell
    ys = (np.arange(grid.ny) + 0.5) * grid.cell
    return np.meshgrid(xs, ys)


@pytest.mark.parametrize("theta", [0.0, 1.0, -2.5, math.pi])
def test_sweep_marks_the_cells_within_range_and_fov(theta):
    grid = CoverageGrid(10.0, 8.0, sweep_range=3.0, fov=math.radians(90), heading_bins=360)
    x, y = 5.25, 4.25  # a cell centre: the footprint is measured from there
    new = grid.sweep(x, y, theta)
    cx, cy = cell_centres(grid)
    dist = np.hypot(cx - x, cy - y)
    off = np.angle(np.exp(1j * (np.arctan2(cy - y, cx - x) - theta)))
    expected = (dist <= 3.0) & (np.abs(off) <= math.radians(45) + 1e-9)
    expected[grid.cell_of(x, y)] = True
    # Cells right on the FOV edge may fall either way of the rounded heading.
    edge = np.abs(np.abs(off) - math.radians(45)) < math.radians(1.0)
    assert np.array_equal(grid.swept[~edge], expected[~edge])
    assert new == np.count_nonzero(grid.swept)
    assert grid.swept_fraction == pytest.approx(new / grid.size)
    assert grid.sweep(x, y, theta) == 0  # nothing new the second time


def test_full_circle_sweep_is_a_disc_clipped_by_the_arena():
    grid = CoverageGrid(6.0, 6.0, sweep_range=2.0, fov=2 * math.pi, cell=0.5)
    grid.sweep(0.1, 0.1, 0.0)  # the corner cell: most of the disc is outside
    cx, cy = cell_centres(grid)
    assert np.array_equal(grid.swept, np.hypot(cx - 0.25, cy - 0.25) <= 2.0)


def test_features_fresh_swept_and_out_of_arena_regions():
    grid = CoverageGrid(16.0, 16.0, sweep_range=4.5, fov=2 * math.pi / 3)
    fresh = grid.features(8.0, 8.0, 0.0)
    assert fresh.shape == (grid.n_features,) == (24,)
    assert np.all(fresh[:16] == 1.0)  # every nearby region holds unswept arena cells
    # In a corner facing out, the sectors behind the walls hold no cell: share 0.
    corner = grid.features(0.1, 0.1, math.pi).reshape(3, 8)
    assert corner[0, 0] == 0.0 and corner[0, 4] == 1.0
    grid.set_swept(np.s_[:])
    assert np.all(grid.features(8.0, 8.0, 0.0) == 0.0)


def test_features_are_egocentric():
    grid = CoverageGrid(16.0, 16.0, sweep_range=4.5, fov=2 * math.pi / 3)
    grid.set_swept(np.s_[:, 8:])  # the east half (x > 4 m) swept
    facing_east = grid.features(4.25, 8.25, 0.0).reshape(3, 8)
    facing_west = grid.features(4.25, 8.25, math.pi).reshape(3, 8)
    assert facing_east[0, 0] == 0.0 and facing_east[0, 4] > 0.9  # ahead swept, behind not
    assert np.array_equal(facing_west, np.roll(facing_east, 4, axis=1))
    # Sector 2 is to the left (counter-clockwise): north when facing east.
    grid.reset()
    grid.set_swept(np.s_[17:, :])  # y > 8.5 m swept
    north_of_robot = grid.features(8.25, 8.25, 0.0).reshape(3, 8)
    assert north_of_robot[0, 2] == 0.0 and north_of_robot[0, 6] == 1.0


def test_reset_and_a_diverged_estimate():
    grid = CoverageGrid(8.0, 8.0, sweep_range=2.0, fov=math.pi)
    assert grid.sweep(math.nan, math.inf, math.nan) > 0  # clamped, never an error
    assert grid.cell_of(-50.0, 99.0) == (grid.ny - 1, 0)
    assert np.all(np.isfinite(grid.features(math.nan, 1e9, -math.inf)))
    grid.reset()
    assert grid.swept_fraction == 0.0 and not grid.swept.any()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"width": 0.0}, "width"),
        ({"cell": math.nan}, "cell"),
        ({"sweep_range": -1.0}, "sweep_range"),
        ({"fov": 7.0}, "fov"),
        ({"sectors": 0}, "sectors"),
        ({"heading_bins": 2.5}, "heading_bins"),
        ({"ring_edges": (5.0, 3.0)}, "ring_edges"),
    ],
)
def test_bad_grid_arguments_raise(kwargs, match):
    args = {"width": 8.0, "height": 8.0, "sweep_range": 2.0, "fov": 1.0, **kwargs}
    with pytest.raises(ValueError, match=match):
        CoverageGrid(**args)


@pytest.mark.parametrize("observation", ["egocentric", "full"])
def test_active_slam_env_observes_coverage(observation):
    # (The env checkers run on ActiveSLAM-v0, coverage included, in test_wrappers.)
    env = gym.make(ENV_ID, observation=observation)
    plain = gym.make(ENV_ID, observation=observation, coverage=False)
    obs, info = env.reset(seed=3)
    plain_obs, _ = plain.reset(seed=3)
    if observation == "full":
        coverage = obs.pop("coverage")
        assert obs.keys() == plain_obs.keys()
        for key in obs:  # the belief part is unchanged
            np.testing.assert_array_equal(obs[key], plain_obs[key])
    else:
        coverage = obs[plain_obs.size :]
        np.testing.assert_array_equal(obs[: plain_obs.size], plain_obs)
    assert coverage[0] == pytest.approx(info["swept_fraction"]) and 0.0 < coverage[0] < 0.2
    swept = [info["swept_fraction"]]
    for _ in range(100):
        obs, _, _, _, info = env.step(np.array([0.8, 0.3], dtype=np.float32))
        assert env.observation_space.contains(obs)
        swept.append(info["swept_fraction"])
    assert np.all(np.diff(swept) >= 0.0) and swept[-1] > swept[0]
    env.reset(seed=3)
    assert env.unwrapped._core.coverage.swept_fraction == pytest.approx(swept[0])


def test_coverage_reward_pays_for_newly_swept_area():
    env = gym.make(ENV_ID, reward_weights={"coverage": 20.0, "information_gain": 0.0})
    _, info = env.reset(seed=1)
    last = info["swept_fraction"]
    assert info["reward_terms"]["coverage"] == 0.0
    for _ in range(30):
        _, reward, _, _, info = env.step(np.array([1.0, 0.5], dtype=np.float32))
        term = info["reward_terms"]["coverage"]
        assert term == pytest.approx(20.0 * (info["swept_fraction"] - last))
        assert reward == pytest.approx(sum(info["reward_terms"].values()))
        last = info["swept_fraction"]
    assert last > 0.1


def test_coverage_needs_a_filter_and_the_reward_needs_coverage():
    raw = LandmarksEnv()
    with pytest.raises(TypeError, match="EKFSLAMWrapper"):
        CoverageWrapper(raw)
    reward = ActiveSLAMReward(EKFSLAMWrapper(raw), ActiveSLAMRewardWeights(coverage=1.0))
    with pytest.raises(TypeError, match="CoverageWrapper"):
        reward.reset(seed=0)
    with pytest.raises(TypeError, match="coverage must be a bool"):
        gym.make(ENV_ID, coverage="yes")


@pytest.mark.parametrize(("max_range", "sweep_range"), [(1.0, 0.5), (0.4, 0.0), (5.0, 4.5)])
def test_a_sensor_sweeps_its_range_less_one_cell(max_range, sweep_range):
    """for_sensor counts a cell swept only within the range less one cell (never less
    than the robot's own cell), with the sensor's FOV and rings at R and 2R."""
    from slam_env.config import SensorConfig

    sensor = SensorConfig(max_range=max_range, fov=2 * math.pi)
    grid = CoverageGrid.for_sensor(8.0, 8.0, sensor)
    grid.sweep(4.25, 4.25, 0.0)
    cx, cy = cell_centres(grid)
    assert np.array_equal(grid.swept, np.hypot(cx - 4.25, cy - 4.25) <= sweep_range)
    twin = CoverageGrid(8.0, 8.0, sweep_range, 2 * math.pi, ring_edges=(max_range, 2.0 * max_range))
    twin.sweep(4.25, 4.25, 0.0)
    np.testing.assert_array_equal(grid.features(4.25, 4.25, 0.0), twin.features(4.25, 4.25, 0.0))


@pytest.mark.parametrize("observation", ["egocentric", "full"])
def test_the_coverage_features_space_is_the_unit_interval(observation):
    wrapper = CoverageWrapper(EKFSLAMWrapper(LandmarksEnv(), observation=observation))
    n = 1 + wrapper.grid.n_features
    space = wrapper.observation_space
    if isinstance(space, gym.spaces.Dict):
        low, high = space["coverage"].low, space["coverage"].high
    else:
        low, high = space.low[-n:], space.high[-n:]
    assert low.shape == (n,) and np.all(low == 0.0) and np.all(high == 1.0)
