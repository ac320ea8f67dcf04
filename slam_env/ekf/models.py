"""Motion and measurement models of the seeds, their Jacobians and inverse models.

Pure functions of numpy arrays; the filter and the env's odometry sensor both use
the noise covariances defined here, so a noise-matched filter is matched exactly.
"""

from __future__ import annotations

import numpy as np


def odometry_action_cov(u, alphas) -> np.ndarray:
    """M, the 3×3 action-space noise of the odometry model (seed 000).

    u = (δrot1, δtr, δrot2); alphas = (α1, α2, α3, α4).
    M = diag(α1·δrot1² + α2·δtr², α3·δtr² + α4·(δrot1² + δrot2²), α1·δrot2² + α2·δtr²).
    """
    rot1, trans, rot2 = float(u[0]), float(u[1]), float(u[2])
    a1, a2, a3, a4 = (float(a) for a in alphas)
    r1, t, r2 = rot1 * rot1, trans * trans, rot2 * rot2
    return np.diag([a1 * r1 + a2 * t, a3 * t + a4 * (r1 + r2), a1 * r2 + a2 * t])


def velocity_control_cov(u, noise) -> np.ndarray:
    """Σu, the 2×2 control noise of the (Δp, Δθ) model (seed 004).

    u = (Δp, Δθ); noise = (σp, σθ, βp, βθ); Σu = diag(σp² + βp·Δp², σθ² + βθ·Δθ²).
    """
    dp, dth = float(u[0]), float(u[1])
    sp, sth, bp, bth = (float(n) for n in noise)
    return np.diag([sp * sp + bp * dp * dp, sth * sth + bth * dth * dth])
