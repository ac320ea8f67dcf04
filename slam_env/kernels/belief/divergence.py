"""Whether each world's filter has lost track: the gate's rejections in a row, and the
``diverged`` flag that sums up every sign of it (see
:class:`slam_env.belief.ekf_wrapper.EKFSLAMWrapper`)."""

from __future__ import annotations

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel, kernel

# This many gate rejections in a row, with no accepted correction between, means the
# belief no longer explains what the robot sees.
DIVERGENCE_REJECTIONS = 10
# slam_env.ekf.Status codes (the kernels' own).
CORRECTED, REJECTED = 0, 2


@kernel
def count_rejections(
    status: np.ndarray, counts: np.ndarray, updated: np.ndarray, in_a_row: np.ndarray
) -> None:
    """Advance ``in_a_row[b]`` ((B,) int64) over world b's update, if ``updated[b]``:
    each rejected observation, in order, adds one; each corrected one sets it back to
    0; a new landmark leaves it as it is (``status`` (B, D) int8, ``counts`` (B,))."""
    for b in range(status.shape[0]):
        if not updated[b]:
            continue
        run = in_a_row[b]
        for j in range(counts[b]):
            if status[b, j] == REJECTED:
                run += 1
            elif status[b, j] == CORRECTED:
                run = 0
        in_a_row[b] = run


@borrowing_kernel
def diverged(
    clipped: np.ndarray,
    failed: np.ndarray,
    in_a_row: np.ndarray,
    max_rejections: int,
    out: np.ndarray,
) -> None:
    """``out[b]``: world b's belief left the observation's bounds, or its filter failed
    numerically since its reset, or the gate refused ``max_rejections`` observations
    in a row."""
    for b in range(out.shape[0]):
        out[b] = clipped[b] or failed[b] or in_a_row[b] >= max_rejections
