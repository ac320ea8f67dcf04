"""RawCore's kernel call, pinned to its arrays, follows them when a reset replaces them."""

from __future__ import annotations

import numpy as np

from slam_env.config import EnvConfig, WorldConfig
from slam_env.core.raw import RawCore
from slam_env.world.layout_generators import preset_layout


def _episode(core: RawCore, seed: int, steps: int) -> list[bytes]:
    """Sub-env 0 reset from ``seed`` and driven in a circle: its observations."""
    core.reset(0, np.random.default_rng(seed))
    commands = np.array([[0.8, 0.6]])
    frames = []
    for _ in range(steps):
        core.step(commands, np.ones(1, dtype=bool))
        frames.append(b"".join(a.tobytes() for a in core.observation(0).values()))
    return frames


def test_a_world_that_grows_the_geometry_is_sensed_in_its_own() -> None:
    """An episode in the cluttered world after one in the open world (whose geometry
    has no room for obstacles: a reset makes new arrays) is the episode of a core that
    only ever knew the cluttered world."""
    core = RawCore(EnvConfig(world=WorldConfig(preset="open")), 1)
    _episode(core, seed=1, steps=5)
    before = core.worlds.geometry_fields
    cluttered = EnvConfig(world=WorldConfig(preset="cluttered"))
    core.worlds.fixed_layout = preset_layout("cluttered", cluttered.world)
    grown = _episode(core, seed=2, steps=60)
    assert core.worlds.geometry_fields is not before  # the arrays were replaced
    assert grown == _episode(RawCore(cluttered, 1), seed=2, steps=60)
