"""What both batched cores (:mod:`.raw`, :mod:`.active`) offer on top of their
``advance``."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from slam_env.world.layouts import Layout
from slam_env.world.world_batch import WorldBatch

__all__ = ["BatchCore"]


class BatchCore:
    """What both batched cores offer on top of their ``advance``: one sub-env's reset,
    and a step of some sub-envs."""

    #: Whether the sub-envs have a belief (a filter each) beside the raw stream.
    has_belief = False
    rngs: list[np.random.Generator | None]
    worlds: WorldBatch
    _idle: np.ndarray  # (B, 2) zeros: the commands of sub-envs that only reset
    _none: np.ndarray  # (B,) False: no sub-env steps

    def advance(
        self, commands: np.ndarray, stepping: np.ndarray, resetting: Sequence[int]
    ) -> list[Layout]:
        raise NotImplementedError

    def check_room(self, stepping: np.ndarray) -> None:
        """Raise, before anything changes, where stepping the sub-envs of ``stepping``
        would outgrow what a sub-env may hold (only a smoothing belief grows)."""

    def reset(self, index: int, rng: np.random.Generator) -> Layout:
        """Start sub-env ``index`` on a new episode, its randomness from ``rng``."""
        self.rngs[index] = rng
        return self.advance(self._idle, self._none, [index])[0]

    def step(self, commands: np.ndarray, active: np.ndarray) -> None:
        """One step of the active sub-envs (see :meth:`advance`)."""
        self.advance(commands, active, ())

    def use_threads(self, num_threads: int) -> None:
        """Step the compiled stages on ``num_threads`` threads (see the cores')."""
        raise NotImplementedError

    def close(self) -> None:
        """Join the threads of :meth:`use_threads`."""
        raise NotImplementedError

    def true_pose(self, index: int) -> np.ndarray:
        """(3,) sub-env ``index``'s true robot pose (x, y m, θ rad): a view of its row."""
        return self.worlds.poses[index]

    def layout(self, index: int) -> Layout:
        """Sub-env ``index``'s world as it is now (its landmarks may have moved)."""
        return self.worlds.worlds[index].layout
