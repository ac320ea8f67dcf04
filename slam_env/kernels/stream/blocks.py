"""Each sub-env's per-step uniforms, taken from its block of steps (drawn by
:class:`slam_env.core.random_blocks.RandomBlocks` from its own generator) inside the raw
step's kernel."""

from __future__ import annotations

import numpy as np

from slam_env.kernels.base.compiling import kernel


@kernel
def used_up_rows(
    blocks: np.ndarray, cursor: np.ndarray, active: np.ndarray, used_up: np.ndarray
) -> int:
    """List in ``used_up`` the active sub-envs whose block is used up; return how many."""
    n = 0
    for b in range(blocks.shape[0]):
        if active[b] and cursor[b] >= blocks.shape[1]:
            used_up[n] = b
            n += 1
    return n


@kernel
def take_rows(blocks: np.ndarray, cursor: np.ndarray, active: np.ndarray, out: np.ndarray) -> None:
    """Copy each active sub-env's next row of its block into ``out`` and advance its
    cursor (:func:`used_up_rows` lists none of them)."""
    for b in range(blocks.shape[0]):
        if active[b]:
            row = cursor[b]
            for k in range(out.shape[1]):  # a loop: numba's slice copy may allocate
                out[b, k] = blocks[b, row, k]
            cursor[b] = row + 1
