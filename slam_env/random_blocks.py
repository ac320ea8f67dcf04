"""Each sub-env's per-step uniforms, drawn from its own generator a block of steps at
a time."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from slam_env.kernels import kernel

# A block holds about this many uniforms (and at most MAX_BLOCK_STEPS steps' worth):
# one numpy call per block instead of one per step.
BLOCK_UNIFORMS = 4096
MAX_BLOCK_STEPS = 16


@kernel
def _take_rows(
    blocks: np.ndarray, cursor: np.ndarray, active: np.ndarray, out: np.ndarray, used_up: np.ndarray
) -> int:
    """Copy each active sub-env's next row of its block into ``out`` and advance its
    cursor; a sub-env whose block is used up is skipped and listed in ``used_up``.
    Returns how many were listed."""
    n = 0
    for b in range(blocks.shape[0]):
        if not active[b]:
            continue
        row = cursor[b]
        if row >= blocks.shape[1]:
            used_up[n] = b
            n += 1
            continue
        out[b, :] = blocks[b, row, :]
        cursor[b] = row + 1
    return n


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

    def take(self, rngs: Sequence[np.random.Generator], active: np.ndarray) -> np.ndarray:
        """This step's uniforms, (B, width), and advance the active sub-envs by one step.
        Rows of inactive sub-envs are stale; the array is reused by the next call."""
        n = _take_rows(self._blocks, self._cursor, active, self._uniforms, self._used_up)
        if n:
            refill = np.zeros_like(active)
            for b in self._used_up[:n].tolist():
                self.restart(b, rngs[b])
                refill[b] = True
            _take_rows(self._blocks, self._cursor, refill, self._uniforms, self._used_up)
        return self._uniforms
