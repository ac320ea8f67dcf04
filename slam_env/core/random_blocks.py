"""Each sub-env's per-step uniforms, drawn from its own generator a block of steps at
a time."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

# A block holds about this many uniforms (and at most MAX_BLOCK_STEPS steps' worth):
# one numpy call per block instead of one per step.
BLOCK_UNIFORMS = 4096
MAX_BLOCK_STEPS = 16


class RandomBlocks:
    """The uniforms in [0, 1) that the kernels of B sub-envs consume, ``width`` per
    sub-env per step, drawn from each sub-env's own ``numpy.random.Generator``.

    A sub-env draws a new block of several steps when its last one is used up, and a
    reset (:meth:`restart`) drops what is left of it and draws a fresh one, after the
    reset's own draws (a random world). So each sub-env's stream is a function of its
    own seed and history only: sub-env i of a vector env replays the single env with
    the same seed, whatever the other sub-envs do.
    """

    def __init__(self, num_envs: int, width: int) -> None:
        self.width = width
        steps = max(1, min(MAX_BLOCK_STEPS, BLOCK_UNIFORMS // max(width, 1)))
        self._blocks = np.zeros((num_envs, steps, width))
        self._cursor = np.full(num_envs, steps, dtype=np.int64)  # used up: draw first
        self._uniforms = np.zeros((num_envs, width))
        self._used_up = np.zeros(num_envs, dtype=np.int64)

    def restart(self, index: int, rng: np.random.Generator) -> None:
        """Start sub-env ``index`` on a fresh block from ``rng`` (at a reset)."""
        rng.random(out=self._blocks[index])
        self._cursor[index] = 0

    def drop(self, index: int) -> None:
        """Drop what is left of sub-env ``index``'s block: its next step draws a new
        one from its generator (which has just been replaced)."""
        self._cursor[index] = self._blocks.shape[1]

    @property
    def kernel_args(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(blocks, cursor, uniforms, used_up)``: the blocks as
        :func:`~slam_env.kernels.stream.raw_step.raw_step` takes them; it writes the
        step's uniforms ((B, width); stale rows for inactive sub-envs) into
        ``uniforms``, or lists the sub-envs whose block is used up in ``used_up``."""
        return (self._blocks, self._cursor, self._uniforms, self._used_up)

    @property
    def uniforms(self) -> np.ndarray:
        """(B, width): the last step's uniforms (reused by the next step)."""
        return self._uniforms

    def refill(self, n: int, rngs: Sequence[np.random.Generator], first: int = 0) -> None:
        """Restart the first ``n`` sub-envs listed in ``used_up`` on fresh blocks, each
        from its own generator in ``rngs``; ``first``: where the kernel ran over the
        rows from ``first`` on, the list is its view's (from ``first``, indices from
        ``first``)."""
        for b in self._used_up[first : first + n].tolist():
            self.restart(first + b, rngs[first + b])
