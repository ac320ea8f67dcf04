"""Swept-area memory: which parts of the arena the landmark sensor has looked at,
seen from the *estimated* pose, and egocentric features of what is left to look at.

The belief says where the known landmarks are but nothing about where the unknown ones
may still hide; a memoryless policy needs that to explore. :class:`CoverageGrid` keeps
a coarse grid of swept cells and summarises the unswept share per sector around the
robot; :class:`slam_env.belief.coverage_wrapper.CoverageWrapper` puts it in the
observation and ``info``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from slam_env.belief.coverage_classes import class_counts_shape, offset_classes
from slam_env.config import SensorConfig
from slam_env.kernels.belief import coverage as kernels
from slam_env.kernels.belief.belief_state import SINGLE
from slam_env.kernels.belief.coverage import CoverageTables, coverage_step

TWO_PI = 2.0 * math.pi
# m, the side of a coverage cell (the wrapper's default).
COVERAGE_CELL = 0.5
# The grid's default sectors and heading bins (those of the wrapper and the env).
SECTORS = 8
HEADING_BINS = 72
# The inner edges of a sensor's grid's rings after the first, in sensor ranges.
SENSOR_RING_EDGES = (1.0, 2.0)


class CoverageGrid:
    """A grid over the arena of the cells a range-and-FOV sensor has swept.

    A cell is swept when its centre has been within ``sweep_range`` of the (estimated)
    position and within ±``fov``/2 of the heading, measured from the centre of the
    robot's cell with the heading rounded to one of ``heading_bins`` directions.
    Occlusion is ignored: the memory is a cheap guide for exploration, not a
    visibility map.

    The features are the unswept share of the cells in each of ``sectors`` equal
    sectors around the robot (sector k is centred on bearing 2πk/``sectors`` from the
    heading, counter-clockwise, from −π/``sectors`` inclusive to +π/``sectors``
    exclusive about its centre) and each distance ring (bounded by ``ring_edges``, m,
    each edge inclusive in the ring outside it, the last ring unbounded), measured
    like the footprint; ring-major: feature ``r·sectors + k``. The robot's own cell,
    which has no bearing of its own, counts at bearing 0 of the world frame. A region
    that holds no arena cell has share 0: nothing left to see there.

    Footprints and region maps are tabulated per heading bin once (:attr:`tables`,
    shared by any number of worlds); a step is one call to the coverage kernels
    (:mod:`slam_env.kernels.belief.coverage`) on this grid as a batch of one. They keep each
    world's cells counted by class around the robot's cell, so that a step counts
    afresh only when that cell changes (:attr:`incremental`; a grid whose classes would
    not give the same features bit for bit, :mod:`slam_env.belief.coverage_classes`, scans
    every cell each step instead). So the swept cells change only through the methods:
    :attr:`swept` and :attr:`padded` are read-only views, and :meth:`set_swept` edits.

    Args:
        width, height: m, the arena.
        sweep_range: m, how far a cell counts as seen.
        fov: rad, the full opening angle (2π: all around).
        cell: m, the cell side.
        sectors: sectors around the robot.
        ring_edges: m, increasing inner edges of the rings after the first.
        heading_bins: directions the heading is rounded to.
        worlds: how many grids of this geometry to keep (the sub-envs of a vector env,
            :meth:`step_all`); the methods that take one pose act on world 0.
    """

    def __init__(
        self,
        width: float,
        height: float,
        sweep_range: float,
        fov: float,
        *,
        cell: float = 0.5,
        sectors: int = SECTORS,
        ring_edges: tuple[float, ...] = (5.0, 10.0),
        heading_bins: int = HEADING_BINS,
        worlds: int = SINGLE,
    ) -> None:
        for name, value in (("width", width), ("height", height), ("cell", cell)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"CoverageGrid {name} must be finite and > 0, got {value}")
        if not (math.isfinite(sweep_range) and sweep_range >= 0.0):
            raise ValueError(f"CoverageGrid sweep_range must be finite and >= 0, got {sweep_range}")
        if not 0.0 < fov <= TWO_PI:
            raise ValueError(f"CoverageGrid fov must be in (0, 2π], got {fov}")
        for name, value in (
            ("sectors", sectors),
            ("heading_bins", heading_bins),
            ("worlds", worlds),
        ):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"CoverageGrid {name} must be an int >= 1, got {value!r}")
        edges = np.asarray(ring_edges, dtype=np.float64)
        if edges.ndim != 1 or np.any(edges <= 0.0) or np.any(np.diff(edges) <= 0.0):
            raise ValueError(f"CoverageGrid ring_edges must increase and be > 0, got {ring_edges}")
        self.cell = float(cell)
        self.nx = max(math.ceil(width / cell), 1)
        self.ny = max(math.ceil(height / cell), 1)
        self.sectors = sectors
        self.n_features = sectors * (edges.size + 1)
        self.heading_bins = heading_bins
        headings = np.arange(heading_bins) * (TWO_PI / heading_bins)

        # Offsets (in cells) from the robot's cell to every cell of the grid.
        di = np.arange(-(self.ny - 1), self.ny)[:, None]
        dj = np.arange(-(self.nx - 1), self.nx)[None, :]
        dist = np.hypot(di, dj) * self.cell
        bearing = np.arctan2(di, dj)
        # Region (ring·sectors + sector) of every offset, per heading bin; a step slices
        # the window that the robot's cell sees.
        turned = (bearing[None] - headings[:, None, None] + math.pi / sectors) % TWO_PI
        sector = np.minimum((turned * (sectors / TWO_PI)).astype(np.intp), sectors - 1)
        ring = np.searchsorted(edges, dist, side="right")
        # Coded 2·region + 1, so that less the swept flag (0/1) each (region, swept) pair
        # has a code, the unswept cells' odd: one pass counts both.
        codes = 2 * (ring * sectors + sector) + 1
        codes = codes.astype(np.min_scalar_type(codes.max()))
        # The classes the features are counted by, or None: a scan each step.
        classes = offset_classes(codes, heading_bins, sectors)

        # The swept cells live inside a border of always-swept cells as wide as the
        # footprint, so a footprint never needs clipping and never counts the border.
        p = math.ceil(sweep_range / self.cell)
        stride = self.nx + 2 * p
        # The footprint per heading bin, as offsets into the flattened padded grid.
        near = dist <= sweep_range
        foot_di = np.broadcast_to(di, dist.shape)[near]
        foot_dj = np.broadcast_to(dj, dist.shape)[near]
        off = (bearing[near][None] - headings[:, None] + math.pi) % TWO_PI - math.pi
        # The robot's own cell is always seen, whatever its offset's nominal bearing.
        in_view = (np.abs(off) <= 0.5 * fov) | ((foot_di == 0) & (foot_dj == 0))[None]
        # Measured from the corner of the footprint's (2p+1)² window rather than from the
        # robot's cell, so that they are never negative.
        flat = (foot_di + p) * stride + foot_dj + p
        sizes = np.count_nonzero(in_view, axis=1)
        footprints = np.zeros((heading_bins, max(int(sizes.max()), 1)), dtype=np.int64)
        for h, row in enumerate(in_view):
            footprints[h, : sizes[h]] = flat[row]
        counts_shape = class_counts_shape(heading_bins, sectors, edges.size + 1)
        if classes is None:
            footprint_classes = classes = np.zeros((0, 0), dtype=np.int64)
            counts_shape = (*counts_shape[:2], 0)
        else:
            # Footprint offsets off the classes' window land in the border only: slot 0.
            inside = (np.abs(foot_di) < self.ny) & (np.abs(foot_dj) < self.nx)
            slots = np.zeros(foot_di.shape, dtype=np.int64)
            slots[inside] = classes[foot_di[inside] + self.ny - 1, foot_dj[inside] + self.nx - 1]
            footprint_classes = np.zeros(footprints.shape, dtype=np.int64)
            for h, row in enumerate(in_view):
                footprint_classes[h, : sizes[h]] = slots[row]
        self.tables = CoverageTables(
            self.cell,
            heading_bins,
            p,
            footprints,
            sizes.astype(np.int64),
            codes,
            classes,
            footprint_classes,
        )
        # The grids of the worlds, as the coverage kernels take them.
        self._padded = np.ones((worlds, self.ny + 2 * p, stride), dtype=np.bool_)
        self._n_swept = np.zeros(worlds, dtype=np.int64)
        # Each world's class counts and the cell they are about (−1: count afresh).
        self._class_counts = np.zeros((worlds, *counts_shape), dtype=np.int64)
        self._held = np.full(worlds, -1, dtype=np.int64)
        self._setup_scratch()
        self.reset()

    @classmethod
    def for_sensor(
        cls,
        width: float,
        height: float,
        sensor: SensorConfig,
        *,
        cell: float = COVERAGE_CELL,
        worlds: int = SINGLE,
    ) -> CoverageGrid:
        """The grid a landmark sensor sweeps (see
        :class:`~slam_env.belief.coverage_wrapper.CoverageWrapper`): its FOV, and its
        range less one cell, so that a cell counts as swept only well inside it; rings
        at R and 2R, R the range."""
        reach = sensor.max_range
        return cls(
            width,
            height,
            sweep_range=max(reach - cell, 0.0),
            fov=sensor.fov,
            cell=cell,
            ring_edges=tuple(k * reach for k in SENSOR_RING_EDGES),
            worlds=worlds,
        )

    # Views and scratch buffers: rebuilt on unpickling, never pickled (a view
    # would come back as a copy, detached from the padded grid).
    _TRANSIENT = ("_flat", "_read_only", "_pose", "new_cells", "_all", "_out", "_counts")

    def _setup_scratch(self) -> None:
        worlds = self._padded.shape[0]
        self._flat = self._padded.reshape(worlds, -1)  # a view: the padded grid is contiguous
        self._read_only = self._padded.view()
        self._read_only.flags.writeable = False
        self._pose = np.zeros((worlds, 3))  # world 0's pose, for the one-pose methods
        self.new_cells = np.empty(worlds, dtype=np.int64)
        self._all = np.ones(worlds, dtype=np.bool_)
        self._out = np.empty((worlds, 1 + self.n_features))  # [swept fraction, features...]
        self._counts = np.empty(2 * self.n_features, dtype=np.int64)  # the kernel's scratch

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in self._TRANSIENT}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._setup_scratch()

    @property
    def padded(self) -> np.ndarray:
        """(worlds, ny + 2·pad, nx + 2·pad) bool: every world's swept cells inside the
        always-swept border of ``tables.pad`` cells (a read-only view of the grid
        itself, not a copy; :meth:`set_swept` edits)."""
        return self._read_only

    @property
    def swept(self) -> np.ndarray:
        """(ny, nx) bool, row i at y ∈ [i·cell, (i+1)·cell): the cells swept so far
        (a read-only view, :meth:`set_swept` edits; a property, so that a pickled copy
        views its own padded grid)."""
        p = self.tables.pad
        return self._read_only[0, p : p + self.ny, p : p + self.nx]

    @property
    def incremental(self) -> bool:
        """Whether the features are counted by class, afresh only when the robot's
        cell changes (False: a scan of every cell each step; the same features)."""
        return self._class_counts.shape[3] > 0

    def set_swept(self, cells: Any, value: bool = True, index: int = 0) -> None:
        """Mark the cells ``cells`` picks from world ``index``'s (ny, nx) grid (any
        numpy index: ``np.s_[:, 8:]``, a bool mask, a (row, column) pair) swept, or
        unswept when ``value`` is False; the swept fraction follows."""
        p = self.tables.pad
        arena = self._padded[index, p : p + self.ny, p : p + self.nx]
        arena[cells] = value
        self._n_swept[index] = np.count_nonzero(arena)
        self._held[index] = -1

    @property
    def size(self) -> int:
        """Number of cells."""
        return self.nx * self.ny

    @property
    def swept_fraction(self) -> float:
        """Share of the arena's cells swept so far (world 0)."""
        return self._n_swept[0].item() / self.size

    def reset(self, index: int = 0) -> None:
        """Forget everything world ``index`` swept."""
        p = self.tables.pad
        self._padded[index, p : p + self.ny, p : p + self.nx] = False
        self._n_swept[index] = 0
        self._held[index] = -1

    def cell_of(self, x: float, y: float) -> tuple[int, int]:
        """(row, column) of the cell holding (x, y), clamped into the grid (a diverged
        estimate outside the arena sweeps from the nearest border cell, a NaN one from
        the first)."""
        return kernels.cell_of(self.tables.cell, self.tables.codes, x, y)

    def heading_bin(self, theta: float) -> int:
        """The tabulated direction nearest to ``theta`` (bin 0 for NaN or ±inf)."""
        return kernels.heading_bin(self.heading_bins, theta)

    def sweep(self, x: float, y: float, theta: float) -> int:
        """Mark the footprint seen from pose (x, y, θ) swept; return the new cells."""
        self._pose[0] = (x, y, theta)
        self._step(self._pose, True)
        return self.new_cells[0].item()

    def features(self, x: float, y: float, theta: float) -> np.ndarray:
        """(n_features,) float64 in [0, 1]: the unswept share per sector and ring
        around pose (x, y, θ) (see the class docstring)."""
        self._pose[0] = (x, y, theta)
        return self.coverage(self._pose)[1:].copy()

    def coverage(self, pose: np.ndarray) -> np.ndarray:
        """(1 + n_features,) float64: the swept fraction, then the features around
        ``pose`` ((1, ≥ 3) float64, x, y, θ first) of a one-world grid. A view of
        scratch that the next call overwrites."""
        return self._step(pose, False)[0]

    def sweep_and_cover(self, pose: np.ndarray) -> np.ndarray:
        """:meth:`sweep` from ``pose`` ((1, ≥ 3) float64, x, y, θ first), then
        :meth:`coverage` there, in one kernel call, for a one-world grid."""
        return self._step(pose, True)[0]

    def step_all(self, poses: np.ndarray, active: np.ndarray) -> np.ndarray:
        """Each active world's (``active`` (worlds,) bool) sweep from its pose (``poses``
        (worlds, ≥ 3) float64, x, y, θ first), then its coverage there:
        (worlds, 1 + n_features) float64, a view of scratch that the next call
        overwrites (the inactive worlds' rows stale); :attr:`new_cells` the cells each
        swept."""
        return self._step(poses, True, active)

    @property
    def kernel_args(self) -> tuple[Any, ...]:
        """The :class:`CoverageTables` fields, then ``(swept, n_swept, held,
        class_counts, new_cells, features, counts)``: the grid as
        :func:`slam_env.kernels.belief.active_step.belief_outputs` takes it (``features`` what
        :meth:`step_all` returns, ``counts`` scratch)."""
        return (*self._state, self.new_cells, self._out, self._counts)

    def kernel_args_of(self, rows: slice) -> tuple[Any, ...]:
        """:attr:`kernel_args` over the worlds ``rows`` (views of their rows, the same
        tables), with scratch of their own: what one thread's chunk of them takes."""
        worlds = (self._flat, self._n_swept, self._held, self._class_counts, self.new_cells)
        return (
            *self.tables,
            *(a[rows] for a in worlds),
            self._out[rows],
            np.empty_like(self._counts),
        )

    @property
    def _state(self) -> tuple[Any, ...]:
        """The :class:`CoverageTables` fields and the worlds' state, as
        :func:`~slam_env.kernels.belief.coverage.coverage_step` takes them."""
        return (*self.tables, self._flat, self._n_swept, self._held, self._class_counts)

    def _step(self, poses: np.ndarray, sweep: bool, active: np.ndarray | None = None) -> np.ndarray:
        active = self._all if active is None else active
        coverage_step(*self._state, poses, sweep, self.new_cells, self._out, self._counts, active)
        return self._out
