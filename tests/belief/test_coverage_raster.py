"""The swept-area memory against a brute-force rasterisation of the sensor's sector
(issue 17).

The reference below works from the documented rules alone, cell by cell: a cell is
swept when its centre lies within ``sweep_range`` of the centre of the robot's cell
and within ±fov/2 of the heading rounded to the nearest of ``heading_bins``
directions (the robot's own cell always); a feature is the unswept share of the
arena cells in one sector (centred on 2πk/sectors from the heading, counter-
clockwise, half-open [−π/S, π/S) around its centre) and ring (inner edge inclusive).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import pytest

from slam_env.belief.coverage import CoverageGrid
from slam_env.belief.coverage_wrapper import CoverageWrapper
from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.envs.landmarks import LandmarksEnv

TWO_PI = 2.0 * math.pi
TIE = 1e-9  # rad or m: closer than this to an edge, the reference cannot tell the side


@dataclass
class Raster:
    """The reference: the grid's parameters and its swept cells, a plain bool array."""

    width: float
    height: float
    sweep_range: float
    fov: float
    cell: float = 0.5
    sectors: int = 8
    ring_edges: tuple[float, ...] = (5.0, 10.0)
    heading_bins: int = 72

    def __post_init__(self) -> None:
        self.nx = math.ceil(self.width / self.cell - 1e-12)
        self.ny = math.ceil(self.height / self.cell - 1e-12)
        self.swept = np.zeros((self.ny, self.nx), dtype=bool)

    def grid(self) -> CoverageGrid:
        return CoverageGrid(
            self.width,
            self.height,
            self.sweep_range,
            self.fov,
            cell=self.cell,
            sectors=self.sectors,
            ring_edges=self.ring_edges,
            heading_bins=self.heading_bins,
        )

    def locate(self, x: float, y: float, theta: float) -> tuple[int, int, float]:
        """The robot's cell (clamped into the grid) and its rounded heading."""
        i = min(max(math.floor(y / self.cell), 0), self.ny - 1)
        j = min(max(math.floor(x / self.cell), 0), self.nx - 1)
        step = TWO_PI / self.heading_bins
        rounded = round(math.remainder(theta, TWO_PI) / step) * step
        return i, j, rounded

    def offsets(self, x: float, y: float, theta: float):
        """Distance (m) and bearing from the heading (rad, in [−π, π]) of every cell
        centre, from the centre of the robot's cell."""
        i, j, heading = self.locate(x, y, theta)
        rows, cols = np.mgrid[0 : self.ny, 0 : self.nx]
        dy = (rows - i) * self.cell
        dx = (cols - j) * self.cell
        dist = np.hypot(dx, dy)
        relative = np.angle(np.exp(1j * (np.arctan2(dy, dx) - heading)))
        own = (rows == i) & (cols == j)
        return dist, relative, own

    def sweep(self, x: float, y: float, theta: float) -> np.ndarray:
        """Sweep the cells certainly in view; returns the edge cells (on the FOV
        boundary to within round-off: either way is right), left to the caller."""
        dist, relative, own = self.offsets(x, y, theta)
        near = dist <= self.sweep_range + TIE
        edge = near & (np.abs(np.abs(relative) - 0.5 * self.fov) < TIE) & ~own
        seen = (near & (np.abs(relative) <= 0.5 * self.fov) | own) & ~edge
        self.swept |= seen
        return edge

    def features(self, x: float, y: float, theta: float) -> np.ndarray:
        dist, relative, _ = self.offsets(x, y, theta)
        width = TWO_PI / self.sectors
        position = np.mod(relative + 0.5 * width, TWO_PI) / width
        assert not np.any(np.abs(position - np.round(position)) < TIE), "a sector tie"
        sector = np.floor(position).astype(int) % self.sectors
        ring = np.zeros_like(sector)
        for edge in self.ring_edges:
            ring += dist >= edge
        out = np.zeros((len(self.ring_edges) + 1) * self.sectors)
        for k in range(out.size):
            region = (ring * self.sectors + sector) == k
            if region.any():
                out[k] = np.count_nonzero(region & ~self.swept) / np.count_nonzero(region)
        return out


def random_poses(
    rng: np.random.Generator, raster: Raster, n: int
) -> list[tuple[float, float, float]]:
    """Poses over (and a little beyond) the arena, headings over several turns."""
    xs = rng.uniform(-1.0, raster.width + 1.0, n)
    ys = rng.uniform(-1.0, raster.height + 1.0, n)
    thetas = rng.uniform(-3 * math.pi, 3 * math.pi, n)
    return list(zip(xs.tolist(), ys.tolist(), thetas.tolist(), strict=True))


WORLDS = [
    # The CoverageWrapper's grid on the default sensor: 16 m, R = 5, 120°.
    Raster(16.0, 16.0, 4.5, TWO_PI / 3, ring_edges=(5.0, 10.0)),
    # Odd sizes, other cells and ranges, a narrow FOV and all around, other sectors
    # and bins (chosen so that no sector boundary falls on a multiple of 45°, where
    # cells can lie exactly on it: those are tested on their own below).
    Raster(
        13.3,
        7.7,
        3.25,
        math.radians(75),
        cell=0.25,
        sectors=16,
        ring_edges=(2.0, 4.5, 6.0),
        heading_bins=40,
    ),
    Raster(9.0, 11.0, 2.0, TWO_PI, cell=1.0, ring_edges=(1.5,), heading_bins=36),
    # The class defaults.
    Raster(12.0, 9.5, 3.0, math.radians(100)),
]


@pytest.mark.parametrize("world", range(len(WORLDS)))
def test_sweeps_and_features_match_the_brute_force_raster(world: int):
    raster = WORLDS[world]
    raster.swept[:] = False
    grid = (
        CoverageGrid(raster.width, raster.height, raster.sweep_range, raster.fov)
        if world == 3
        else raster.grid()
    )
    assert (grid.ny, grid.nx) == raster.swept.shape
    rng = np.random.default_rng(world)
    for x, y, theta in random_poses(rng, raster, 25):
        before = grid.swept.copy()
        edge = raster.sweep(x, y, theta)
        new = grid.sweep(x, y, theta)
        assert np.array_equal(grid.swept[~edge], raster.swept[~edge])
        raster.swept[edge] = grid.swept[edge]  # the edge cells: the grid's choice
        assert new == np.count_nonzero(grid.swept & ~before)
        assert grid.swept_fraction == np.count_nonzero(raster.swept) / raster.swept.size
        features = grid.features(x, y, theta)
        np.testing.assert_allclose(features, raster.features(x, y, theta), rtol=1e-15, atol=0)
    assert 0.2 < grid.swept_fraction < 1.0


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"width": 13.0, "height": 9.5, "max_range": 3.0, "fov": math.radians(90)},
        {"width": 11.0, "height": 7.0, "max_range": 2.5, "fov": TWO_PI},
    ],
)
def test_the_wrapper_sweeps_the_configured_sector_from_the_filters_pose(options):
    """CoverageWrapper's grid: 0.5 m cells, the sensor's FOV and its range less one
    cell, rings R and 2R, eight sectors, 72 headings, swept from the belief's pose."""
    raw = LandmarksEnv(**options)
    sensor = raw.config.sensor
    width, height = raw.arena_size
    R = sensor.max_range
    raster = Raster(width, height, R - 0.5, sensor.fov, ring_edges=(R, 2 * R))
    env = CoverageWrapper(EKFSLAMWrapper(raw))
    assert env.grid.cell == 0.5
    obs, info = env.reset(seed=5)
    f = env.get_wrapper_attr("filter")
    rng = np.random.default_rng(5)
    for step in range(60):
        x, y, theta = f.pose
        edge = raster.sweep(x, y, theta)
        assert np.array_equal(env.grid.swept[~edge], raster.swept[~edge]), step
        raster.swept[edge] = env.grid.swept[edge]
        assert info["swept_fraction"] == np.count_nonzero(raster.swept) / raster.swept.size
        coverage = obs[-25:]
        assert coverage.dtype == np.float32
        assert coverage[0] == np.float32(info["swept_fraction"])
        np.testing.assert_array_equal(coverage[1:], raster.features(x, y, theta).astype(np.float32))
        obs, _, _, _, info = env.step(np.array([1.0, rng.uniform(-0.6, 0.6)], np.float32))


def three_by_three(**kwargs) -> CoverageGrid:
    """A 3 × 3 grid of 1 m cells; a robot at (1.5, 1.5) sits in the middle one."""
    args = {"sweep_range": 2.0, "fov": TWO_PI, "cell": 1.0, "sectors": 4, "ring_edges": (9.0,)}
    return CoverageGrid(3.0, 3.0, **{**args, **kwargs})


def test_a_cell_on_a_sector_boundary_belongs_to_the_sector_counter_clockwise_of_it():
    grid = three_by_three()
    # Sectors of 90° centred ahead (east), north, west, south: the diagonal cells
    # lie exactly on the boundaries (45°, 135°, 225°, 315°).
    grid.set_swept((2, 2))  # north-east, at 45°: the north sector's
    grid.set_swept((0, 0))  # south-west, at 225°: the south sector's
    features = grid.features(1.5, 1.5, 0.0)
    # Sector 0 (east): own cell, east, south-east (at 315°); sector 1 (north): north,
    # north-east; sector 2 (west): west, north-west (at 135°); 3: south, south-west.
    np.testing.assert_array_equal(features, [1.0, 0.5, 1.0, 0.5, 0, 0, 0, 0])  # ring 1 empty
    # Facing north (heading bin 18 of 72), the same cells fall one sector clockwise.
    north = grid.features(1.5, 1.5, math.pi / 2)
    np.testing.assert_array_equal(north, [0.5, 1.0, 0.5, 1.0, 0, 0, 0, 0])


def test_a_cell_on_a_ring_edge_belongs_to_the_outer_ring():
    grid = three_by_three(sectors=1, ring_edges=(1.0,))
    grid.set_swept((1, 1))  # the robot's own cell: all of ring 0
    np.testing.assert_array_equal(grid.features(1.5, 1.5, 0.0), [0.0, 1.0])
    grid.set_swept((1, 2))  # east, at exactly 1 m: ring 1, not ring 0
    np.testing.assert_array_equal(grid.features(1.5, 1.5, 0.0), [0.0, 7.0 / 8.0])


def test_the_range_and_the_fov_edges_are_inclusive():
    disc = three_by_three(sweep_range=1.0)
    assert disc.sweep(1.5, 1.5, 0.0) == 5  # own cell and the four at exactly 1 m
    np.testing.assert_array_equal(disc.swept, [[0, 1, 0], [1, 1, 1], [0, 1, 0]])
    wedge = CoverageGrid(5.0, 5.0, sweep_range=3.0, fov=math.pi / 2, cell=1.0)
    wedge.sweep(0.5, 2.5, 0.0)  # facing east from the west edge's middle cell
    expected = np.zeros((5, 5), dtype=bool)
    expected[2, 0:4] = True  # straight ahead: 0, 1, 2, 3 m
    for k in (1, 2):  # the diagonals at exactly ±45°, within 3 m
        expected[2 + k, k] = expected[2 - k, k] = True
    expected[3, 2] = expected[1, 2] = True  # (2, ±1): 26.6° off, 2.24 m
    np.testing.assert_array_equal(wedge.swept, expected)


def test_the_robots_own_cell_is_swept_facing_any_way():
    for theta in np.linspace(-math.pi, math.pi, 13):
        grid = CoverageGrid(5.0, 5.0, sweep_range=0.0, fov=0.1, cell=1.0)
        assert grid.sweep(2.5, 2.5, theta) == 1
        assert grid.swept[2, 2] and grid.swept.sum() == 1


@pytest.mark.parametrize(
    ("width", "height", "cell", "shape"),
    [
        (7.3, 4.1, 0.5, (9, 15)),
        (5.0, 5.0, 0.5, (10, 10)),
        (5.0001, 0.3, 0.5, (1, 11)),
        (0.2, 0.2, 0.5, (1, 1)),
        (3.0, 1.0, 0.75, (2, 4)),
    ],
)
def test_grid_size_rounds_up_to_whole_cells(width, height, cell, shape):
    grid = CoverageGrid(width, height, sweep_range=1.0, fov=1.0, cell=cell)
    assert grid.swept.shape == shape == (grid.ny, grid.nx)
    assert grid.size == shape[0] * shape[1]


def test_heading_bins_round_to_the_nearest_direction():
    grid = CoverageGrid(4.0, 4.0, sweep_range=1.0, fov=1.0)  # 72 bins of 5°
    for degrees, expected in [
        (0, 0),
        (2.4, 0),
        (2.6, 1),
        (-2.6, 71),
        (-2.4, 0),
        (357.6, 0),
        (360 + 47.6, 10),
        (-180, 36),
    ]:
        assert grid.heading_bin(math.radians(degrees)) == expected, degrees


def test_a_diverged_estimate_sweeps_from_the_nearest_border_cell():
    grid = CoverageGrid(8.0, 6.0, sweep_range=1.0, fov=1.0, cell=1.0)
    assert grid.cell_of(-50.0, 99.0) == (5, 0)
    assert grid.cell_of(1e300, -1e300) == (0, 7)
    assert grid.cell_of(math.inf, math.inf) == (5, 7)
    assert grid.cell_of(-math.inf, -math.inf) == (0, 0)
    assert grid.cell_of(math.nan, math.nan) == (0, 0)
    assert grid.heading_bin(math.nan) == grid.heading_bin(math.inf) == 0


@pytest.mark.parametrize(
    "kwargs",
    [
        {"sweep_range": 0.0},
        {"sectors": 1},
        {"heading_bins": 1},
        {"ring_edges": ()},
        {"ring_edges": (0.25, 0.5)},  # small and close edges
        {"fov": TWO_PI},
    ],
)
def test_the_smallest_valid_arguments_are_accepted(kwargs):
    args = {"width": 4.0, "height": 4.0, "sweep_range": 1.0, "fov": 1.0, **kwargs}
    grid = CoverageGrid(**args)
    assert grid.sweep(2.0, 2.0, 0.0) >= 1
    assert grid.features(2.0, 2.0, 0.0).shape == (grid.n_features,)
    assert grid.n_features == args.get("sectors", 8) * (len(args.get("ring_edges", (5, 10))) + 1)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"height": -1.0}, "height"),
        ({"width": math.inf}, "width"),
        ({"cell": 0.0}, "cell"),
        ({"sweep_range": math.nan}, "sweep_range"),
        ({"fov": 0.0}, "fov"),
        ({"sectors": True}, "sectors"),
        ({"sectors": 2.0}, "sectors"),
        ({"heading_bins": 0}, "heading_bins"),
        ({"ring_edges": ((5.0, 6.0),)}, "ring_edges"),
        ({"ring_edges": (0.0, 6.0)}, "ring_edges"),
        ({"ring_edges": (5.0, 5.0)}, "ring_edges"),
    ],
)
def test_more_bad_grid_arguments_raise(kwargs, match):
    args = {"width": 8.0, "height": 8.0, "sweep_range": 2.0, "fov": 1.0, **kwargs}
    with pytest.raises(ValueError, match=match):
        CoverageGrid(**args)


class AsImage(gym.ObservationWrapper):
    """A belief observation reshaped to a 2-D Box."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        n = env.observation_space.shape[0]
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (1, n), np.float32)

    def observation(self, observation):
        return observation[None]


def test_the_wrapper_refuses_observations_it_cannot_append_to():
    with pytest.raises(TypeError, match="flat Box or Dict"):
        CoverageWrapper(AsImage(EKFSLAMWrapper(LandmarksEnv(n_landmarks=3))))
