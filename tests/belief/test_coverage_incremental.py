"""The incremental coverage features (class counts kept per world, recounted only when
the robot's cell changes) against the full scan of every cell, bit for bit.

The reference is the same grid built without classes, which takes the scanning path
of :func:`slam_env.kernels.belief.coverage.coverage_step` (what the kernels ran before)."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

import slam_env.belief.coverage as coverage_module
from slam_env.belief.coverage import CoverageGrid
from slam_env.belief.coverage_classes import (
    MAX_FINE_BINS,
    fine_bins,
    offset_classes,
    sector_of_fine_bin,
)
from slam_env.config import SensorConfig

TWO_PI = 2.0 * math.pi

GRIDS = {
    # ActiveSLAM-v0's grid: 16 m arena, the default sensor.
    "default": {"width": 16.0, "height": 16.0, "sweep_range": 4.5, "fov": TWO_PI / 3},
    "odd sizes": {
        "width": 13.3,
        "height": 7.7,
        "sweep_range": 3.25,
        "fov": math.radians(75),
        "cell": 0.25,
        "sectors": 5,
        "ring_edges": (2.0, 4.5, 6.0),
        "heading_bins": 17,
    },
    "all around": {
        "width": 9.0,
        "height": 11.0,
        "sweep_range": 2.0,
        "fov": TWO_PI,
        "cell": 1.0,
        "ring_edges": (1.5,),
        "heading_bins": 36,
    },
    # Sector edges on multiples of 45°, where the diagonal cells lie exactly on them.
    "ties": {
        "width": 6.0,
        "height": 5.0,
        "sweep_range": 2.5,
        "fov": math.pi / 2,
        "cell": 1.0,
        "sectors": 4,
        "ring_edges": (9.0,),
        "heading_bins": 8,
    },
    # A range beyond the arena: footprint entries off the offsets' window.
    "small arena": {
        "width": 2.0,
        "height": 1.5,
        "sweep_range": 3.0,
        "fov": 2.0,
        "cell": 0.5,
        "sectors": 4,
        "ring_edges": (),
    },
    # Sector edges at thirds of a turn, which round differently under different
    # headings where a cell lies on one: no class fits such a cell, the grid scans.
    "thirds": {
        "width": 5.0,
        "height": 4.0,
        "sweep_range": 2.0,
        "fov": 2.0,
        "cell": 1.0,
        "sectors": 3,
        "heading_bins": 12,
    },
    # lcm(1000, 14) = 7000 fine bins: too many, the grid scans.
    "large lcm": {
        "width": 4.0,
        "height": 3.0,
        "sweep_range": 1.5,
        "fov": 2.5,
        "sectors": 7,
        "heading_bins": 1000,
    },
}


def scanning(monkeypatch: pytest.MonkeyPatch, **kwargs) -> CoverageGrid:
    """The grid of ``kwargs`` built without classes: the full scan, the reference."""
    with monkeypatch.context() as patch:
        patch.setattr(coverage_module, "offset_classes", lambda *args: None)
        return CoverageGrid(**kwargs)


def walk(rng: np.random.Generator, width: float, height: float, steps: int) -> np.ndarray:
    """(steps, 3) poses of a random walk that wanders a little beyond the arena."""
    pose = np.array([width / 2, height / 2, 0.0])
    out = np.empty((steps, 3))
    for t in range(steps):
        pose[2] += rng.uniform(-0.6, 0.6)
        pose[:2] += rng.uniform(0.0, 0.3) * np.array([math.cos(pose[2]), math.sin(pose[2])])
        pose[:2] = np.clip(pose[:2], -0.5, [width + 0.5, height + 0.5])
        out[t] = pose
    return out


def assert_same_step(grid: CoverageGrid, reference: CoverageGrid, pose: np.ndarray) -> None:
    assert grid.sweep(*pose) == reference.sweep(*pose)
    np.testing.assert_array_equal(grid.swept, reference.swept)
    assert grid.swept_fraction == reference.swept_fraction
    np.testing.assert_array_equal(grid.features(*pose), reference.features(*pose))


@pytest.mark.parametrize("name", GRIDS)
def test_long_walks_give_the_full_scans_features_bit_for_bit(name, monkeypatch):
    kwargs = GRIDS[name]
    grid = CoverageGrid(**kwargs)
    reference = scanning(monkeypatch, **kwargs)
    assert grid.incremental == (name not in ("large lcm", "thirds"))
    assert not reference.incremental
    rng = np.random.default_rng(len(name))
    poses = walk(rng, kwargs["width"], kwargs["height"], 1500)
    most = 0.0
    for t, pose in enumerate(poses):
        if t % 500 == 499:
            grid.reset()
            reference.reset()
        if t % 300 == 150:  # an edit between steps, over cells near and far
            cells = rng.random(grid.swept.shape) < 0.2
            value = bool(t % 600 == 150)
            grid.set_swept(cells, value)
            reference.set_swept(cells, value)
        if t == 700:  # a pickled copy carries on where the grid was
            grid = pickle.loads(pickle.dumps(grid))
        assert_same_step(grid, reference, pose)
        # The features without a sweep, from a turned heading in the same cell.
        turned = pose + np.array([0.0, 0.0, rng.uniform(-math.pi, math.pi)])
        np.testing.assert_array_equal(grid.features(*turned), reference.features(*turned))
        most = max(most, grid.swept_fraction)
    assert most > 0.3  # the walks sweep much of the arena between resets


@pytest.mark.parametrize("name", ["default", "odd sizes"])
def test_worlds_stepped_together_follow_the_full_scan(name, monkeypatch):
    """step_all on B worlds, some inactive at times, each reset at its own steps."""
    kwargs = GRIDS[name]
    B = 5
    grid = CoverageGrid(**kwargs, worlds=B)
    reference = scanning(monkeypatch, **kwargs, worlds=B)
    rng = np.random.default_rng(3)
    walks = np.stack([walk(rng, kwargs["width"], kwargs["height"], 400) for _ in range(B)], 1)
    for t, poses in enumerate(walks):
        active = rng.random(B) < 0.8
        for b in np.flatnonzero(rng.random(B) < 0.01):
            grid.reset(b)
            reference.reset(b)
        got = grid.step_all(poses, active).copy()
        want = reference.step_all(poses, active)
        np.testing.assert_array_equal(got[active], want[active], err_msg=str(t))
        np.testing.assert_array_equal(grid.new_cells[active], reference.new_cells[active])
    np.testing.assert_array_equal(grid.padded, reference.padded)


@pytest.mark.parametrize("name", [n for n in GRIDS if n not in ("large lcm", "thirds")])
def test_the_classes_reproduce_the_region_codes_under_every_heading(name):
    kwargs = GRIDS[name]
    grid = CoverageGrid(**kwargs)
    sectors = kwargs.get("sectors", 8)
    bins = grid.heading_bins
    width = fine_bins(bins, sectors) + 1
    ring, slot = np.divmod(grid.tables.classes, width)
    assert np.all((slot >= 1) & (slot < width))
    for h in range(bins):
        region = ring * sectors + sector_of_fine_bin(slot - 1, h, bins, sectors)
        np.testing.assert_array_equal(2 * region + 1, grid.tables.codes[h])


def test_a_class_for_every_lcm_up_to_the_limit_and_none_beyond():
    assert fine_bins(72, 8) == 144 and fine_bins(7, 3) == 42 and fine_bins(4, 2) == 4
    # One sector: never a tie, whatever the headings.
    assert fine_bins(4096, 1) == MAX_FINE_BINS
    assert CoverageGrid(3.0, 3.0, 1.0, 1.0, sectors=1, heading_bins=4096).incremental
    assert not CoverageGrid(3.0, 3.0, 1.0, 1.0, sectors=1, heading_bins=4097).incremental


def test_codes_that_no_class_reproduces_take_the_full_scan():
    codes = CoverageGrid(4.0, 4.0, 1.0, 1.0, cell=1.0, sectors=4, heading_bins=8).tables.codes
    assert offset_classes(codes, 8, 4) is not None
    for h, offset in [(0, (3, 5)), (5, (3, 3)), (7, (0, 6))]:  # the robot's cell among them
        tampered = codes.copy()
        # Another sector of the same ring, under one heading bin only.
        region = tampered[h][offset] // 2
        tampered[h][offset] = 2 * (region // 4 * 4 + (region + 1) % 4) + 1
        assert offset_classes(tampered, 8, 4) is None, (h, offset)


def test_the_swept_views_are_read_only_and_set_swept_edits():
    grid = CoverageGrid(6.0, 4.0, 1.0, 1.0, cell=1.0, worlds=2)
    with pytest.raises(ValueError, match="read-only"):
        grid.swept[0, 0] = True
    with pytest.raises(ValueError, match="read-only"):
        grid.padded[1, 3, 3] = True
    before = grid.features(0.5, 0.5, 0.0)
    grid.set_swept(np.s_[:, :3])
    assert grid.swept[:, :3].all() and not grid.swept[:, 3:].any()
    assert grid.swept_fraction == 0.5
    assert not np.array_equal(grid.features(0.5, 0.5, 0.0), before)
    grid.set_swept((0, 0), False)
    assert grid.swept_fraction == 11 / 24 and not grid.swept[0, 0]
    grid.set_swept(np.ones((4, 6), bool), index=1)
    p = grid.tables.pad
    assert grid.padded[1, p:-p, p:-p].all() and grid.swept_fraction == 11 / 24
    grid.reset(1)
    assert not grid.padded[1, p:-p, p:-p].any()


def test_the_env_grid_is_incremental_and_a_pickled_one_views_its_own_cells():
    grid = CoverageGrid.for_sensor(16.0, 16.0, SensorConfig(), worlds=3)
    assert grid.incremental
    grid.sweep(4.0, 5.0, 1.0)
    copy = pickle.loads(pickle.dumps(grid))
    assert not copy.swept.flags.writeable and not copy.padded.flags.writeable
    copy.sweep(9.0, 5.0, 0.0)
    assert copy.swept_fraction > grid.swept_fraction
    assert np.count_nonzero(copy.swept) == round(copy.swept_fraction * copy.size)
    assert not np.array_equal(copy.features(9.0, 5.0, 0.0), grid.features(9.0, 5.0, 0.0))
