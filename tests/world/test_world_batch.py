"""WorldBatch: B worlds moved by one kernel call are the standalone worlds, bit for bit;
each world's pose lives in the batch's row, through pickling too."""

from __future__ import annotations

import copy
import math
import pickle

import numpy as np
import pytest

from slam_env.config import EnvConfig, WorldConfig
from slam_env.world.kidnap import kidnap_pose
from slam_env.world.pymunk_world import World
from slam_env.world.world_batch import WorldBatch
from tests.world.world_samples import CountingSpace

B = 6


def batch_and_twins(
    config: EnvConfig, batch: WorldBatch | None = None, seed: int = 0
) -> tuple[WorldBatch, list[World]]:
    """A batch whose worlds are reset (a new batch's first reset, or a batch's next)
    and fresh standalone worlds of the same layouts."""
    batch = batch or WorldBatch(config, B)
    twins = []
    for b in range(B):
        layout = batch.reset(b, np.random.default_rng(seed + b))
        twins.append(
            World(
                layout,
                config.robot,
                config.dt,
                config.physics_substeps,
                config.world.wall_thickness,
            )
        )
    return batch, twins


def commands(rng: np.random.Generator, config: EnvConfig) -> np.ndarray:
    """(B, 2) speeds and turn rates: mostly full speed ahead (so that robots press into
    things), some reversing, turning in place and standing still."""
    speed = rng.choice([1.0, 1.0, 1.0, -0.6, 0.0], B) * config.robot.max_speed
    turn = rng.uniform(-1.0, 1.0, B) * config.robot.max_turn_rate
    return np.column_stack([speed, turn])


@pytest.mark.parametrize("preset", ["random", "cluttered", "rooms"])
def test_moving_the_batch_is_stepping_each_world(preset) -> None:
    config = EnvConfig(world=WorldConfig(preset=preset))
    batch, twins = batch_and_twins(config)
    rng = np.random.default_rng(0)
    collided = np.zeros(B, dtype=bool)
    n_collisions = 0
    for i in range(300):
        if i == 150:  # a second episode: each world relaid, the same objects kept
            kept = list(batch.worlds)
            batch, twins = batch_and_twins(config, batch, seed=B)
            assert all(a is b for a, b in zip(kept, batch.worlds, strict=True))
        command = commands(rng, config)
        active = rng.random(B) < 0.9
        collided[:] = False
        before = batch.move(command, active, collided)
        for b, twin in enumerate(twins):
            if active[b]:
                speed, turn = command[b].tolist()
                assert collided[b] == twin.step(speed, turn), (i, b)
            assert batch.poses[b].tolist() == list(twin.pose) == list(batch.worlds[b].pose)
        assert not np.shares_memory(before, batch.poses)
        n_collisions += int(collided.sum())
    assert n_collisions > 20  # contacts were resolved, not only free moves


def test_the_batch_settles_steps_without_a_query() -> None:
    """The batch's worlds, whose kernel knows the static geometry, settle their steps,
    contacts included, without pymunk's clearance queries, pose for pose as the
    standalone worlds do with them (pymunk decides only a distance within the slack
    of a contact: tests/kernels/test_motion.py)."""
    config = EnvConfig()
    batch, twins = batch_and_twins(config)
    asked_by_batch, asked_by_twins = [], []
    for b in range(B):
        for world, asked in ((batch.worlds[b], asked_by_batch), (twins[b], asked_by_twins)):
            world._space = CountingSpace(world._space)
            asked.append(world._space)
    rng = np.random.default_rng(3)
    collided = np.zeros(B, dtype=bool)
    robot = config.robot
    contacts = 0
    for _ in range(300):  # a random agent's commands: it wanders more than it presses
        command = rng.uniform(-1.0, 1.0, (B, 2)) * (robot.max_speed, robot.max_turn_rate)
        batch.move(command, np.ones(B, dtype=bool), collided)
        contacts += int(collided.sum())
        for b, twin in enumerate(twins):
            assert collided[b] == twin.step(*command[b].tolist())
            assert batch.poses[b].tolist() == list(twin.pose)
    by_batch = sum(space.queries for space in asked_by_batch)
    by_twins = sum(space.queries for space in asked_by_twins)
    assert by_twins > 100 and by_batch == 0, (by_batch, by_twins)
    assert contacts > 10  # contacts were settled, not only free moves


def test_kidnapped_worlds_still_move_as_their_twins() -> None:
    """A robot carried elsewhere (a kidnapping: set_pose between moves) leaves its old
    clear disk behind; the batch's worlds keep matching their standalone twins."""
    config = EnvConfig(world=WorldConfig(preset="cluttered"))
    batch, twins = batch_and_twins(config)
    rng = np.random.default_rng(4)
    collided = np.zeros(B, dtype=bool)
    kidnaps = 0
    for i in range(300):
        if i % 25 == 24:
            for b in np.flatnonzero(rng.random(B) < 0.5).tolist():
                pose = kidnap_pose(twins[b], rng)
                if pose is not None:
                    batch.worlds[b].set_pose(*pose)
                    twins[b].set_pose(*pose)
                    kidnaps += 1
        command = commands(rng, config)
        batch.move(command, np.ones(B, dtype=bool), collided)
        for b, twin in enumerate(twins):
            assert collided[b] == twin.step(*command[b].tolist()), (i, b)
            assert batch.poses[b].tolist() == list(twin.pose), (i, b)
    assert kidnaps > 20


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_copied_batch_moves_its_own_worlds(how) -> None:
    config = EnvConfig()
    batch, _ = batch_and_twins(config)
    rng = np.random.default_rng(1)
    active = np.ones(B, dtype=bool)
    collided = np.zeros(B, dtype=bool)
    for _ in range(20):
        batch.move(commands(rng, config), active, collided)
    clone = pickle.loads(pickle.dumps(batch)) if how == "pickle" else copy.deepcopy(batch)
    for _ in range(20):
        command = commands(rng, config)
        batch.move(command, active, collided)
        clone.move(command, active, collided.copy())
    np.testing.assert_array_equal(clone.poses, batch.poses)
    for b in range(B):
        assert list(clone.worlds[b].pose) == clone.poses[b].tolist()
        assert clone.worlds[b].pose == batch.worlds[b].pose


def test_a_worlds_pose_is_its_batch_row() -> None:
    batch, _ = batch_and_twins(EnvConfig(world=WorldConfig(preset="open")))
    world = batch.worlds[2]
    world.set_pose(3.0, 4.0, 0.5)
    assert batch.poses[2].tolist() == [3.0, 4.0, 0.5]
    world.step(0.5, 0.1)  # a world of a batch still steps on its own
    assert batch.poses[2].tolist() == list(world.pose) != [3.0, 4.0, 0.5]


def test_a_speed_beyond_the_move_budget_is_refused_with_nothing_moved() -> None:
    config = EnvConfig()
    batch, twins = batch_and_twins(config)
    poses = batch.poses.copy()
    collided = np.ones(B, dtype=bool)
    command = np.zeros((B, 2))
    command[:, 0] = 0.5
    command[4, 0] = 1e6
    with pytest.raises(ValueError, match="too fast"):
        batch.move(command, np.ones(B, dtype=bool), collided)
    np.testing.assert_array_equal(batch.poses, poses)
    assert collided.all()
    world = twins[0]
    pose = world.pose
    for v in (1e4, -1e300, math.nextafter(math.inf, 0.0)):
        with pytest.raises(ValueError, match="too fast"):
            world.step(v, 1.0)
        assert world.pose == pose
    # Fast, but within the budget: more moves than substeps, same as a slow step's rules.
    fast = 0.5 * config.robot.radius * 50 / config.dt
    assert world.step(fast, 0.0) or world.pose != pose
