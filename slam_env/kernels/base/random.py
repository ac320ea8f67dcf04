"""Random variates from uniforms, for kernels that draw no random numbers themselves.

Each sub-env draws a block of uniforms in [0, 1) per step from its own ``np_random``
(one numpy call); the kernels turn them into what they need. Normals come in pairs
from the Box–Muller transform, which is exact and needs no rejection, so a step
always consumes the same number of uniforms.
"""

from __future__ import annotations

import math

from slam_env.kernels.base.compiling import kernel

TWO_PI = 2.0 * math.pi


@kernel
def normal_pair(u1: float, u2: float) -> tuple[float, float]:
    """Two independent standard normals from two uniforms in [0, 1) (Box–Muller):
    r = √(−2 ln(1 − u1)), a = 2π·u2, (r cos a, r sin a). 1 − u1 ∈ (0, 1], so the
    logarithm is always finite."""
    r = math.sqrt(-2.0 * math.log(1.0 - u1))
    a = TWO_PI * u2
    return r * math.cos(a), r * math.sin(a)
