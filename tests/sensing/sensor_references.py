"""What the sensor tests share: an independent angle wrap, sampled errors held to
their model's Gaussian at N_SE standard errors, and the Box–Muller pair the sensors
draw with.

Statistical tolerances come from the sampling distributions (every check is at
N_SE standard errors, with an explicit seed): for n i.i.d. draws of a zero-mean
Gaussian error with variance σ²,
  sample mean        SE = σ / √n
  sample variance    SE = σ² · √(2 / (n − 1))
  sample covariance  SE = σi σj / √(n − 1)     (independent components)
  Σ whitened²        χ²(ν): mean ν, SD √(2ν)  (ν large: normal approximation)
plus a Kolmogorov–Smirnov test of the whitened errors against N(0, 1). Only numpy
and the standard library are used.
"""

from __future__ import annotations

import math

import numpy as np

N_SE = 5.0  # standard errors allowed in every statistical check
PI = math.pi


def ref_wrap(a):
    """Independent wrap to [−π, π): the phase of e^{ia}, with +π sent to −π."""
    out = np.angle(np.exp(1j * np.asarray(a, dtype=np.float64)))
    return np.where(out >= PI, out - 2 * PI, out)


def ks_pvalue_standard_normal(w: np.ndarray) -> float:
    """Asymptotic p-value of the one-sample KS test of w against N(0, 1), with
    Stephens' small-sample correction λ = (√n + 0.12 + 0.11/√n)·D."""
    x = np.sort(np.asarray(w, dtype=np.float64).ravel())
    n = x.size
    cdf = 0.5 * (1.0 + np.frompyfunc(math.erf, 1, 1)(x / math.sqrt(2.0)).astype(np.float64))
    i = np.arange(1, n + 1)
    d = max(float(np.max(i / n - cdf)), float(np.max(cdf - (i - 1) / n)))
    lam = (math.sqrt(n) + 0.12 + 0.11 / math.sqrt(n)) * d
    p = 2.0 * sum((-1) ** (k - 1) * math.exp(-2.0 * k * k * lam * lam) for k in range(1, 101))
    return min(max(p, 0.0), 1.0)


def assert_gaussian_errors(err: np.ndarray, cov: np.ndarray, what: str) -> None:
    """err (n, d) should be i.i.d. N(0, cov) with cov diagonal. Zero-variance
    components must be exactly zero."""
    n, dim = err.shape
    var = np.diag(cov)
    mean = err.mean(axis=0)
    sample_cov = np.atleast_2d(np.cov(err, rowvar=False, ddof=1))
    for i in range(dim):
        if var[i] == 0.0:
            assert np.all(err[:, i] == 0.0), f"{what}: component {i} should be noiseless"
            continue
        se_mean = math.sqrt(var[i] / n)
        assert abs(mean[i]) <= N_SE * se_mean, (
            f"{what}: mean[{i}]={mean[i]:.3g} vs SE {se_mean:.3g}"
        )
        se_var = var[i] * math.sqrt(2.0 / (n - 1))
        assert abs(sample_cov[i, i] - var[i]) <= N_SE * se_var, (
            f"{what}: var[{i}]={sample_cov[i, i]:.4g}, model {var[i]:.4g}, SE {se_var:.3g}"
        )
        for j in range(i + 1, dim):
            if var[j] == 0.0:
                continue
            se_cov = math.sqrt(var[i] * var[j] / (n - 1))
            assert abs(sample_cov[i, j]) <= N_SE * se_cov, (
                f"{what}: cov[{i},{j}]={sample_cov[i, j]:.3g}, SE {se_cov:.3g}"
            )
    # whitened errors: jointly Gaussian (KS) and the total χ² in its central range
    live = var > 0
    w = err[:, live] / np.sqrt(var[live])
    p_ks = ks_pvalue_standard_normal(w)
    assert p_ks > 1e-6, f"{what}: whitened errors not N(0,1) (KS p={p_ks:.2g})"
    chi2 = float(np.sum(w * w))
    dof = w.size
    assert abs(chi2 - dof) <= N_SE * math.sqrt(2.0 * dof), f"{what}: χ²={chi2:.1f}, {dof} dof"


def box_muller(u1, u2):
    r = math.sqrt(-2.0 * math.log(1.0 - u1))
    return r * math.cos(2.0 * math.pi * u2), r * math.sin(2.0 * math.pi * u2)
