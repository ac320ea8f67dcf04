"""Means with Student-t confidence intervals, for the evaluation's tables."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.special import stdtrit

CONFIDENCE = 0.95


# ---------------------------------------------------------------------- statistics
def t_quantile(p: float, dof: float) -> float:
    """The p-quantile of Student's t with ``dof`` degrees of freedom (scipy.stats.t's
    own formula, from scipy.special: importing scipy.stats costs every CLI call a second)."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must be in (0, 1), got {p}")
    if not (dof > 0 and not math.isnan(dof)):
        raise ValueError(f"dof must be > 0, got {dof}")
    return float(stdtrit(dof, p))


def mean_ci(values: Sequence[float], confidence: float = CONFIDENCE) -> tuple[float, float, int]:
    """(mean, half-width of the two-sided Student-t confidence interval, n) over the
    finite values; the half-width is NaN for fewer than two values."""
    arr = np.asarray(values, dtype=np.float64).reshape(-1)
    arr = arr[np.isfinite(arr)]
    n = int(arr.size)
    if n == 0:
        return math.nan, math.nan, 0
    mean = float(arr.mean())
    if n < 2:
        return mean, math.nan, n
    sem = float(arr.std(ddof=1)) / math.sqrt(n)
    return mean, t_quantile(0.5 + 0.5 * confidence, n - 1) * sem, n
