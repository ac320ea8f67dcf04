"""χ² quantiles for the filter's validation gate and consistency bands, in pure Python
(no scipy)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["chi2_gate", "chi2_ppf"]


def _gammainc_lower(a: float, x: float) -> float:
    """Regularised lower incomplete gamma P(a, x) (series / continued fraction)."""
    if x <= 0.0:
        return 0.0
    log_prefix = -x + a * math.log(x) - math.lgamma(a)
    if x < a + 1.0:
        term = total = 1.0 / a
        n = a
        while abs(term) > abs(total) * 1e-17:
            n += 1.0
            term *= x / n
            total += term
        return total * math.exp(log_prefix)
    # Lentz's continued fraction for Q(a, x).
    tiny = 1e-300
    b = x + 1.0 - a
    c = 1.0 / tiny
    d = 1.0 / b
    h = d
    i = 0
    while True:
        i += 1
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-16 or i > 10_000:
            break
    return 1.0 - math.exp(log_prefix) * h


def chi2_ppf(p: float, dof: int) -> float:
    """The p-quantile of the χ² distribution with ``dof`` degrees of freedom.

    Pure Python (no scipy): closed form for 2 dof, otherwise bisection on the
    regularised incomplete gamma function, accurate to ~1e-12 relative.
    """
    if isinstance(p, bool) or not isinstance(p, (int, float)) or not 0.0 < p < 1.0:
        raise ValueError(f"chi2 probability must be in (0, 1), got {p!r}")
    if isinstance(dof, bool) or not isinstance(dof, (int, np.integer)) or dof < 1:
        raise ValueError(f"chi2 dof must be an int >= 1, got {dof!r}")
    if dof == 2:
        return -2.0 * math.log1p(-p)
    a = 0.5 * dof
    lo, hi = 0.0, max(1.0, float(dof))
    while _gammainc_lower(a, 0.5 * hi) < p:
        lo, hi = hi, 2.0 * hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _gammainc_lower(a, 0.5 * mid) < p:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-13 * hi:
            break
    return 0.5 * (lo + hi)


def chi2_gate(probability: float = 0.99, dof: int = 2) -> float:
    """The χ² validation gate for ``EKFSLAM(gate=...)``: an observation with
    ``νᵀS⁻¹ν`` above it is rejected. A correct, noise-matched filter rejects a
    fraction ``1 − probability`` of good observations (seed 004 validation)."""
    return chi2_ppf(probability, dof)
