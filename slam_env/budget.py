"""The resource budget: the limits on every option that scales an env's work or memory,
checked when an env is built, before anything is allocated or stepped.

:func:`check_budget` takes an :class:`~slam_env.config.EnvConfig` and what an env derives
from it (:func:`world_size`: landmark slots, detections, the arena; and the options of
``ActiveSLAM-v0`` that scale memory) and raises ``ValueError`` naming the options, the
derived figure and the limit, with the reason and what to change. It returns the
:class:`Usage` figures; :func:`memory_bytes` is the memory figure of one env; a vector
env of ``num_envs`` sub-envs counts the parts it shares (:data:`SHARED_PARTS`, the
coverage grid's tables) once and the others once per sub-env. The README's
"Resource budget" lists the limits with their reasons.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, NoReturn

from slam_env.belief.coverage import COVERAGE_CELL, HEADING_BINS, SECTORS, SENSOR_RING_EDGES
from slam_env.belief.coverage_classes import class_counts_shape
from slam_env.belief.encodings import BeliefGeometry
from slam_env.config import EnvConfig, plain
from slam_env.ekf.checks import jcbb_pairings
from slam_env.kernels.ekf.association import association_workspace_sizes
from slam_env.kernels.ekf.filter import update_workspace_size
from slam_env.kernels.world import motion
from slam_env.sensing.raw_observation import detection_reach, odometry_translation_bound
from slam_env.world.drive import MAX_MOVES_PER_STEP
from slam_env.world.layout_files import load_layout
from slam_env.world.layout_generators import landmark_capacity, landmark_spacing

# Proximity beams: a ray query each per step (~16 ms at the limit).
MAX_SCAN_BEAMS = 4_096
# Landmarks: a random world places them in O(n²) (~1.7 s per reset at the limit), a
# layout's are validated in O(n²). (Their slots, max ID + 1, cost memory, and the
# belief's work below.)
MAX_LANDMARKS = 2_000
# Obstacles of a random world (placed in O(n²)) or a layout's, with its inner walls.
MAX_OBSTACLES = 1_000
# Detection rows of the raw observation: the env tabulates a mask per count.
MAX_DETECTIONS = 4_096
# Entries of the belief's (3 + 2·slots)² covariance touched per step at worst: a
# correction per detection in view (~1 ns an entry), and the full observation's copies
# (FULL_OBSERVATION_PASSES). At the limit such a step takes ~10 s; beyond, minutes.
MAX_BELIEF_WORK = 1e10
# 0.5 m cells of the arena where a grid over it is built: the coverage grid (~7 KB and
# ~20 µs per cell to build) and the presets' lattices. A 100 m × 100 m arena.
MAX_ARENA_CELLS = 40_000
# Arena side / robot radius: float64 positions must resolve the physics' contact
# bisection (2⁻¹³ radius) with room to spare (here 2e-6 radius).
MAX_ARENA_RADII = 1e10
# Every observation bound must be a finite float32 (the largest is 3.4e38).
MAX_OBSERVATION_BOUND = 1e37
# Noise σ (m, rad) and gains α, β: the models square them and the filter multiplies
# the variances in pairs, which must stay finite in float64.
NOISE_LIMIT = 1e30
# Reward weights: a step's reward, and the sums and squares a learner forms of it, stay
# finite.
MAX_REWARD_WEIGHT = 1e100
# What the options allocate, over all the sub-envs of a vector env.
MAX_MEMORY_BYTES = 2 * 2**30
# The smoothing belief (ActiveSLAM-v0's belief="isam2") keeps every iSAM2 update of an
# episode in GTSAM's graph and in the record a pickle replays: ~6 KB an update on the
# default world (20 landmarks, RSS over 3,000 steps), counted as 8 KB. It grows while
# the env runs, so it is checked before each step (smoother_updates), not at build.
SMOOTHER_BYTES_PER_UPDATE = 8 * 2**10

# The memory model: what the options allocate, measured with tracemalloc on the current
# code with a margin (the interpreter and the libraries, ~200 MB, are not counted).
# Dense (3 + 2·slots)² float64 arrays alive at once: the filter's Σ and scratch, the
# entropy's floor and shifted copy; the full observation adds its padded copy, the
# clipped ones and its space's bounds (measured 3.2 and 7.9).
BELIEF_DENSE_COPIES = {"egocentric": 4, "full": 9, "local": 4}
# The coverage grid: per offset of its (2·nx − 1)(2·ny − 1) window, the region codes and
# their temporaries over 72 heading bins (measured ~1,900 B); per offset in the sensor's
# footprint, the footprint tables and temporaries; one byte per cell of the padded grid,
# and each world's class counts (slam_env.belief.coverage_classes).
COVERAGE_BYTES_PER_OFFSET = 2_100
COVERAGE_BYTES_PER_FOOTPRINT_OFFSET = 2_400
# Per landmark: pymunk's post and query filter, the sensor's and the world's tables;
# per slot (max ID + 1): the raw env's and the wrapper's per-ID arrays, the egocentric
# features and their bounds (generous).
BYTES_PER_LANDMARK = 4_096
BYTES_PER_LANDMARK_SLOT = 256
# Passes over the padded (3 + 2·slots)² covariance per step of the full observation
# (scatter, clip, copies, cast; ~180 ms a step at 2,000 slots).
FULL_OBSERVATION_PASSES = 10


@dataclass(frozen=True)
class WorldSize:
    """The sizes an env derives from its config: the world's landmarks and the slots
    their IDs need (max ID + 1), obstacles (a layout's inner walls included), the
    arena, the detection rows of the raw observation, and the layout parsed from a
    file (``None`` for generated worlds), not yet validated."""

    n_landmarks: int
    n_landmark_slots: int
    n_obstacles: int
    width: float
    height: float
    max_detections: int
    layout: Any = None


@dataclass(frozen=True)
class Usage:
    """The budget's figures for one env (:func:`check_budget` returns them)."""

    moves_per_step: int
    arena_cells: int
    memory_bytes: int  # over all the sub-envs checked


def world_size(config: EnvConfig) -> WorldSize:
    """The :class:`WorldSize` of ``config``, without generating or validating a world:
    a layout is parsed (a file is read), a preset or random world is sized from the
    options."""

    if config.layout is not None:
        layout = load_layout(config.layout)
        ids = layout.landmark_ids
        n, slots = len(ids), (max(ids) + 1 if ids else 0)
        obstacles = len(layout.obstacles) + len(layout.walls)
        width, height = layout.width, layout.height
    else:
        layout = None
        n = slots = config.world.n_landmarks
        obstacles = config.world.n_obstacles if config.world.preset == "random" else 0
        width, height = config.world.width, config.world.height
    detections = config.sensor.max_detections or n
    return WorldSize(n, slots, obstacles, width, height, detections, layout)


def _refuse(figure: str, value: float, limit: float, reason: str, fix: str) -> NoReturn:
    def show(x: float) -> str:
        return str(x) if isinstance(x, int) else f"{x:.6g}"

    raise ValueError(
        f"{figure} = {show(value)} exceeds the budget of {show(limit)}: {reason}; {fix} "
        "(README: Resource budget)"
    )


def _arena_cells(world: WorldSize) -> int:
    cell = COVERAGE_CELL
    return max(math.ceil(world.width / cell), 1) * max(math.ceil(world.height / cell), 1)


def _coverage_geometry(config: EnvConfig, world: WorldSize) -> tuple[int, int, int]:
    """The coverage grid's window offsets, footprint offsets (an upper bound) and padded
    cells (see :class:`slam_env.belief.coverage.CoverageGrid`)."""
    cell = COVERAGE_CELL
    nx = max(math.ceil(world.width / cell), 1)
    ny = max(math.ceil(world.height / cell), 1)
    offsets = (2 * nx - 1) * (2 * ny - 1)
    pad = math.ceil(max(config.sensor.max_range - cell, 0.0) / cell)
    footprint = min(offsets, math.ceil(math.pi * (pad + 1) ** 2))
    return offsets, footprint, (nx + 2 * pad) * (ny + 2 * pad)


def _coverage_counts_bytes() -> int:
    """The bytes of one world's class counts in ``CoverageWrapper``'s grid (an upper
    bound: a grid that scans instead keeps none)."""

    return 8 * math.prod(class_counts_shape(HEADING_BINS, SECTORS, len(SENSOR_RING_EDGES) + 1))


def memory_parts(
    config: EnvConfig,
    world: WorldSize,
    *,
    belief: str | None = None,
    coverage: bool = False,
    association: bool = False,
) -> dict[str, int]:
    """The bytes one env allocates for what its options scale, by part: ``detections``
    (the raw env's mask table), ``landmarks``, ``belief`` (an observation mode of
    ``ActiveSLAM-v0``; ``None`` for the raw env) with ``filter_workspace`` (the update's
    scratch, which grows with the square of the detections), ``association`` (the data
    association's workspaces, where the filter associates), and ``coverage_tables`` and
    ``coverage`` (the coverage grid's tables, shared by a vector env's sub-envs, and its
    cells and class counts)."""
    rows = world.max_detections
    parts = {
        "detections": 4 * (rows + 1) * rows,
        "landmarks": BYTES_PER_LANDMARK * world.n_landmarks
        + BYTES_PER_LANDMARK_SLOT * world.n_landmark_slots,
        "belief": 0,
        "coverage": 0,
    }
    if belief is not None:
        dim = 3 + 2 * world.n_landmark_slots
        parts["belief"] = BELIEF_DENSE_COPIES[belief] * 8 * dim * dim
        # The filter's workspaces grow with the detections a step has.
        seen = detections_in_view(config, world)
        parts["filter_workspace"] = 8 * update_workspace_size(dim, seen)
        if association:
            floats, ints = association_workspace_sizes(world.n_landmark_slots, seen)
            parts["association"] = 8 * (floats + ints)
    if coverage:
        offsets, footprint, padded = _coverage_geometry(config, world)
        parts["coverage_tables"] = (
            COVERAGE_BYTES_PER_OFFSET * offsets + COVERAGE_BYTES_PER_FOOTPRINT_OFFSET * footprint
        )
        # The local observation keeps a grid of scan-hit obstacles beside the swept one.
        parts["coverage"] = padded * (2 if belief == "local" else 1) + _coverage_counts_bytes()
    return parts


# The parts a vector env builds once for all its sub-envs: the coverage grid's tables.
SHARED_PARTS = ("coverage_tables",)


def memory_bytes(
    config: EnvConfig,
    world: WorldSize,
    *,
    belief: str | None = None,
    coverage: bool = False,
    association: bool = False,
) -> int:
    """The bytes one env allocates for what its options scale (see :func:`memory_parts`)."""
    parts = memory_parts(config, world, belief=belief, coverage=coverage, association=association)
    return sum(parts.values())


def _numbers(value: Any) -> Iterable[tuple[str, float]]:
    """(index suffix, value) of each real number in a scalar, sequence or array; anything
    else is left to the caller's own validation."""
    value = plain(value)
    if isinstance(value, tuple):
        for i, item in enumerate(value):
            for suffix, number in _numbers(item):
                yield f"[{i}]{suffix}", number
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield "", float(value)


def _check_magnitudes(named: Mapping[str, Any], limit: float, why: str) -> None:
    for name, value in named.items():
        for suffix, number in _numbers(value):
            if abs(number) > limit:  # NaN and inf are the options' own checks
                _refuse(f"|{name}{suffix}|", abs(number), limit, why, "lower it")


def check_budget(
    config: EnvConfig,
    world: WorldSize | None = None,
    *,
    belief: str | None = None,
    coverage: bool = False,
    filter_alphas: Any = None,
    filter_control_noise: Any = None,
    filter_measurement_cov: Any = None,
    reward_weights: Mapping[str, Any] | None = None,
    num_envs: int = 1,
    association: bool = False,
    jcbb: bool = False,
) -> Usage:
    """Check ``config`` against the budget; ``ValueError`` names what exceeds it.

    Args:
        config: the env's config.
        world: its :func:`world_size` (computed when ``None``).
        belief: ``"egocentric"`` or ``"full"`` for ``ActiveSLAM-v0``'s belief
            observation; ``None`` for the raw stream.
        coverage: whether a coverage grid is built (``ActiveSLAM-v0``'s ``coverage``).
        filter_alphas, filter_control_noise, filter_measurement_cov, reward_weights:
            ``ActiveSLAM-v0``'s options of those names (magnitudes only: their types
            and shapes are the filter's and the reward's own checks).
        num_envs: sub-envs sharing the memory budget (a vector env).
        association: whether the filter associates its observations itself
            (``ActiveSLAM-v0``'s ``data_association`` other than ``"known"``).
        jcbb: whether it does so with JCBB, whose search grows with the square of
            the pairings a scan can have (:func:`slam_env.ekf.checks.jcbb_pairings`).
    """
    world = world_size(config) if world is None else world
    moves = _check_work(config)
    cells = _check_world(config, world, coverage)
    _check_magnitudes(
        {
            "range_std": config.sensor.range_std,
            "bearing_std": config.sensor.bearing_std,
            "cartesian_std": config.sensor.cartesian_std,
            "alphas": config.odometry.alphas,
            "velocity_noise": config.odometry.velocity_noise,
            "filter_alphas": filter_alphas,
            "filter_control_noise": filter_control_noise,
        },
        NOISE_LIMIT,
        "the models square it and the filter multiplies the variances in pairs",
    )
    _check_magnitudes(
        {"filter_measurement_cov": filter_measurement_cov},
        NOISE_LIMIT**2,
        "a variance, which the filter multiplies in pairs",
    )
    weights = {
        "new_landmark_bonus": config.reward.new_landmark_bonus,
        "collision_penalty": config.reward.collision_penalty,
    }
    weights.update({f"reward_weights.{k}": v for k, v in (reward_weights or {}).items()})
    _check_magnitudes(
        weights, MAX_REWARD_WEIGHT, "a step's reward, its sums and squares must stay finite"
    )
    _check_observation_bounds(config, world, belief)
    if belief is not None:
        _check_belief_work(config, world, belief)
    if jcbb:
        seen = detections_in_view(config, world)
        jcbb_pairings(
            min(seen, world.n_landmark_slots),
            f"its pairings per scan = min(detections in view, landmark slots) = min({seen}, "
            f"{world.n_landmark_slots})",
            "lower max_range or max_detections, or use fewer landmarks (n_landmarks, or a "
            "layout's)",
        )
    memory = _check_memory(config, world, belief, coverage, association, num_envs)
    return Usage(moves, cells, memory)


def smoother_updates(num_envs: int) -> int:
    """The iSAM2 updates one sub-env's smoothing belief may hold in an episode: its
    share of :data:`MAX_MEMORY_BYTES` among ``num_envs`` sub-envs (262,144 alone)."""
    return MAX_MEMORY_BYTES // (SMOOTHER_BYTES_PER_UPDATE * num_envs)


def _check_work(config: EnvConfig) -> int:
    """The work of a step: robot moves and scan beams. Returns the moves per step."""

    robot = config.robot
    # World.step's count: max(physics_substeps, ⌈|v|·dt / (MAX_MOVE_FRACTION·radius)⌉).
    moves = max(
        robot.max_speed * config.dt / (motion.MAX_MOVE_FRACTION * robot.radius),
        config.physics_substeps,
    )
    if moves > MAX_MOVES_PER_STEP:
        _refuse(
            "robot moves per step = max(physics_substeps, ⌈max_speed·dt / (radius/2)⌉)",
            moves,
            MAX_MOVES_PER_STEP,
            "each move is at most half the robot's radius, so that it cannot tunnel "
            "through a wall or a post, and is checked against the shapes near it",
            "lower physics_substeps"
            if config.physics_substeps > MAX_MOVES_PER_STEP
            else "lower max_speed or dt, or raise radius",
        )
    beams = config.sensor.scan_beams
    if beams > MAX_SCAN_BEAMS:
        _refuse("scan_beams", beams, MAX_SCAN_BEAMS, "a ray query each per step", "lower it")
    return math.ceil(moves)


def _check_world(config: EnvConfig, world: WorldSize, coverage: bool) -> int:
    """Landmarks, obstacles, detection rows and the arena. Returns the arena's cells."""

    if config.layout is None:
        counts = {"n_landmarks": world.n_landmarks, "n_obstacles": world.n_obstacles}
    else:
        counts = {
            "the layout's landmarks": world.n_landmarks,
            "the layout's obstacles and inner walls": world.n_obstacles,
        }
    for figure, count in counts.items():
        landmarks = "landmarks" in figure
        limit = MAX_LANDMARKS if landmarks else MAX_OBSTACLES
        if count > limit:
            _refuse(
                figure,
                count,
                limit,
                "a world places and validates them in O(n²)",
                f"use fewer {'landmarks' if landmarks else 'obstacles'}",
            )
    if config.layout is None and world.n_landmarks > landmark_capacity(config.world):
        _refuse(
            "n_landmarks",
            world.n_landmarks,
            landmark_capacity(config.world),
            "no more fit landmark_spacing apart and clearance from the walls in the "
            "width × height arena (Oler's bound)",
            "lower n_landmarks, landmark_spacing or clearance, or enlarge the arena",
        )
    if world.max_detections > MAX_DETECTIONS:
        _refuse(
            "max_detections (default: one per landmark)",
            world.max_detections,
            MAX_DETECTIONS,
            "the raw env tabulates a mask per detection count",
            "lower max_detections",
        )
    lattice_world = config.layout is None and config.world.preset != "random"
    cells = _arena_cells(world)
    if (lattice_world or coverage) and cells > MAX_ARENA_CELLS:
        _refuse(
            f"arena cells = ⌈width/{COVERAGE_CELL:g} m⌉·⌈height/{COVERAGE_CELL:g} m⌉",
            cells,
            MAX_ARENA_CELLS,
            "the coverage grid's tables and the presets' lattices grow with them",
            "shrink width or height"
            + (", or pass coverage=False" if coverage else "")
            + (", or use preset='random'" if lattice_world else ""),
        )
    radii = max(world.width, world.height) / config.robot.radius
    if radii > MAX_ARENA_RADII:
        _refuse(
            "arena side / radius = max(width, height) / radius",
            radii,
            MAX_ARENA_RADII,
            "float64 positions must resolve the physics' contact bisection",
            "shrink width or height, or raise radius",
        )
    return cells


def detections_in_view(config: EnvConfig, world: WorldSize) -> int:
    """The most detections a step can hold: the detection rows, the landmarks, and no
    more than fit within ``max_range`` of the robot at their least spacing s, (2R/s + 1)²
    (their discs of radius s/2 lie inside a disc of radius R + s/2)."""

    spacing = landmark_spacing(config.world if config.layout is None else None)
    around = (2.0 * config.sensor.max_range / spacing + 1.0) ** 2
    return int(min(world.max_detections, world.n_landmarks, around))


def _check_belief_work(config: EnvConfig, world: WorldSize, belief: str) -> None:
    """The covariance entries the belief touches per step."""
    passes = detections_in_view(config, world) + (
        FULL_OBSERVATION_PASSES if belief == "full" else 0
    )
    dim = 3 + 2 * world.n_landmark_slots
    if passes * dim * dim > MAX_BELIEF_WORK:
        _refuse(
            "belief work per step = (detections in view + the full observation's "
            f"{FULL_OBSERVATION_PASSES} passes) · (3 + 2·landmark slots)²",
            passes * dim * dim,
            MAX_BELIEF_WORK,
            "a correction per detection in view (within max_range, at most max_detections) "
            "touches the whole covariance, as does the full observation",
            "lower max_range or max_detections, use fewer landmark slots (n_landmarks, "
            "or a layout's IDs from 0), or observation='egocentric'",
        )


def _check_observation_bounds(config: EnvConfig, world: WorldSize, belief: str | None) -> None:
    """Every bound of the observation space must be a finite float32."""

    bounds = {
        "odometry bound = 4·max_speed·dt + 1 m": odometry_translation_bound(config),
        "detection bound = max_range + 6·max(range_std, cartesian_std)": detection_reach(config),
    }
    if belief is not None:
        max_range = config.sensor.max_range
        extent = BeliefGeometry(0, world.width, world.height, max_range).extent
        bounds["belief bound = (10·max(width, height))²"] = extent * extent
        bounds["belief bound = 20·max(width, height) / max_range"] = 2.0 * extent / max_range
    for figure, value in bounds.items():
        if not value <= MAX_OBSERVATION_BOUND:  # inf and NaN too
            _refuse(
                figure,
                value,
                MAX_OBSERVATION_BOUND,
                "observation bounds must be finite float32",
                "lower the options named",
            )


def _check_memory(
    config: EnvConfig,
    world: WorldSize,
    belief: str | None,
    coverage: bool,
    association: bool,
    num_envs: int,
) -> int:
    """What the options allocate over the sub-envs: the shared parts once, the others
    once per sub-env. Returns that figure."""
    parts = memory_parts(config, world, belief=belief, coverage=coverage, association=association)
    total_parts = {k: v if k in SHARED_PARTS else v * num_envs for k, v in parts.items()}
    total = sum(total_parts.values())
    if total > MAX_MEMORY_BYTES:
        biggest = ", ".join(
            f"{name} {size / 2**20:.4g} MiB ({_MEMORY_OPTIONS[name]})"
            for name, size in sorted(total_parts.items(), key=lambda item: -item[1])
            if size >= 0.1 * total
        )
        _refuse(
            f"memory of {num_envs} env(s), MiB",
            total / 2**20,
            MAX_MEMORY_BYTES / 2**20,
            f"what the options allocate, mostly {biggest}",
            "lower them",
        )
    return total


# The options that scale each part of the memory figure, for its error message.
_MEMORY_OPTIONS = {
    "detections": "max_detections²",
    "landmarks": "n_landmarks, or a layout's landmarks and IDs",
    "belief": "(3 + 2·landmark slots)² for each observation",
    "filter_workspace": "the detections in view², and landmark slots × detections",
    "association": "landmark slots × detections in view, or data_association='known'",
    "coverage": "width, height and max_range, or coverage=False",
    "coverage_tables": "width, height and max_range, or coverage=False",
}
