"""χ² quantiles for the filter's validation gate and consistency bands, behind argument
checks that name the bad value.

The formulas are scipy.stats.chi2's own (``ppf = 2·gammaincinv(dof/2, p)``, ``cdf =
chdtr(dof, x)``), taken from ``scipy.special``: the same floats, without the second
that importing ``scipy.stats`` adds to every process that makes an env. Even
``scipy.special`` costs a process ~0.25 s to import, so it is imported only when a
quantile is asked for that :data:`QUANTILES` does not hold: the ones every filter's
configuration needs by default, which are scipy's floats (the tests recompute each).
"""

from __future__ import annotations

import numpy as np

__all__ = ["DEFAULT_GATE", "QUANTILES", "chi2_gate", "chi2_ppf", "joint_gates"]

# (p, dof): χ²(dof).ppf(p) as scipy computes it, for the gates a filter takes by
# default: the validation gate and the association's match gate (99.9%), and its
# new-landmark gate (99.999%), all on 2 dof.
QUANTILES = {(0.999, 2): 13.815510557964274, (0.99999, 2): 23.02585092994956}


def chi2_ppf(p: float, dof: int) -> float:
    """The p-quantile of the χ² distribution with ``dof`` degrees of freedom."""
    if isinstance(p, bool) or not isinstance(p, (int, float)) or not 0.0 < p < 1.0:
        raise ValueError(f"chi2 probability must be in (0, 1), got {p!r}")
    if isinstance(dof, bool) or not isinstance(dof, (int, np.integer)) or dof < 1:
        raise ValueError(f"chi2 dof must be an int >= 1, got {dof!r}")
    known = QUANTILES.get((p, int(dof)))
    if known is not None:
        return known
    from scipy.special import gammaincinv

    return float(2 * gammaincinv(dof / 2, p))


def chi2_gate(probability: float = 0.99, dof: int = 2) -> float:
    """The χ² validation gate for ``EKFSLAM(gate=...)``: an observation with
    ``νᵀS⁻¹ν`` above it is rejected. A correct, noise-matched filter rejects a
    fraction ``1 − probability`` of good observations (seed 004 validation)."""
    return chi2_ppf(probability, dof)


def joint_gates(match_gate: float, max_obs: int) -> np.ndarray:
    """JCBB's joint χ² thresholds for 0..max_obs pairings (2 dof each), at the
    probability of the individual ``match_gate`` (2 dof)."""
    from scipy.special import chdtr, gammaincinv

    p = float(chdtr(2, match_gate))
    gates = np.full(max_obs + 1, np.inf)
    if 0.0 < p < 1.0:
        gates[1:] = 2 * gammaincinv(np.arange(1, max_obs + 1), p)  # dof/2 = 1..max_obs
    return gates


# The envs' default validation gate: χ²(2 dof) at 99.9%. A noise-matched filter rejects
# one good observation in a thousand, while a gross outlier (say 10σ) never passes.
DEFAULT_GATE = chi2_gate(0.999)
