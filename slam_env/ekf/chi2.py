"""χ² quantiles for the filter's validation gate and consistency bands (scipy's,
behind argument checks that name the bad value)."""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

__all__ = ["DEFAULT_GATE", "chi2_gate", "chi2_ppf", "joint_gates"]


def chi2_ppf(p: float, dof: int) -> float:
    """The p-quantile of the χ² distribution with ``dof`` degrees of freedom."""
    if isinstance(p, bool) or not isinstance(p, (int, float)) or not 0.0 < p < 1.0:
        raise ValueError(f"chi2 probability must be in (0, 1), got {p!r}")
    if isinstance(dof, bool) or not isinstance(dof, (int, np.integer)) or dof < 1:
        raise ValueError(f"chi2 dof must be an int >= 1, got {dof!r}")
    return float(chi2.ppf(p, dof))


def chi2_gate(probability: float = 0.99, dof: int = 2) -> float:
    """The χ² validation gate for ``EKFSLAM(gate=...)``: an observation with
    ``νᵀS⁻¹ν`` above it is rejected. A correct, noise-matched filter rejects a
    fraction ``1 − probability`` of good observations (seed 004 validation)."""
    return chi2_ppf(probability, dof)


def joint_gates(match_gate: float, max_obs: int) -> np.ndarray:
    """JCBB's joint χ² thresholds for 0..max_obs pairings (2 dof each), at the
    probability of the individual ``match_gate`` (2 dof)."""
    p = float(chi2.cdf(match_gate, 2))
    gates = np.full(max_obs + 1, np.inf)
    if 0.0 < p < 1.0:
        gates[1:] = chi2.ppf(p, 2 * np.arange(1, max_obs + 1))
    return gates


# The envs' default validation gate: χ²(2 dof) at 99.9%. A noise-matched filter rejects
# one good observation in a thousand, while a gross outlier (say 10σ) never passes.
DEFAULT_GATE = chi2_gate(0.999)
