"""Angle wrapping, compiled once for the kernels and for Python callers alike."""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import kernel

TWO_PI = 2.0 * math.pi
# The largest float below π: (a + π) % 2π − π rounds to +π for some a just below −π.
BELOW_PI = math.nextafter(math.pi, 0.0)


@kernel
def wrap(angle: float) -> float:
    """An angle (rad) wrapped to [−π, π), half-open even at round-off; NaN stays NaN.
    numba's float ``%`` follows Python's (the sign of the divisor), so this agrees
    bit for bit with the same expression evaluated by Python or numpy."""
    # Python's float % is fmod plus 2π for a negative remainder, and fmod is the
    # identity within one turn: the angles a filter meets skip the library call.
    w = angle + math.pi
    if 0.0 <= w < TWO_PI:
        r = w
    elif -TWO_PI < w < 0.0:
        r = w + TWO_PI
    else:
        r = w % TWO_PI
    r -= math.pi
    return BELOW_PI if r > BELOW_PI else r


@kernel
def wrap_array(angles: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = wrap(angles[i])`` over 1-D arrays of the same size (``ravel`` others)."""
    for i in range(angles.shape[0]):
        out[i] = wrap(angles[i])
