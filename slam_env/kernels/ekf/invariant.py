"""The pieces of the right-invariant EKF (``linearization="invariant"``, docs/filter.md,
"The right-invariant EKF") that the standard update does not have. The kernels keep
the covariance in the state's own coordinates, Σ = J_r P J_rᵀ with J_r = I + v e_θᵀ
and v(ŷ) = (−ŷ, x̂, 0, −m̂₁ᵧ, m̂₁ₓ, …). So the invariant filter is the standard EKF with
two changes:

* the mean is corrected by the exponential map of SE_{1+N}(2),
  ξ̄ = J_r⁻¹ δ for the standard step δ = K ν (:func:`retract`);
* after each correction Σ is carried to the new estimate, Σ ← T Σ Tᵀ with
  T = I + w e_θᵀ and w = v(ŷ⁺) − v(ŷ). Transports add up (e_θᵀ w = 0), so an update
  keeps the total w = v(working mean) − v(committed mean) (:func:`fill_transport`)
  beside its deferred factors. Each factor row u becomes u + u_θ Δw when a later
  correction moves the mean (inside :func:`retract`). The committed block is
  T Σ₀ Tᵀ = Σ₀ + w cᵀ + c wᵀ with c = Σ₀ e_θ + ½ Σ₀,θθ w (:func:`transport_terms`,
  :func:`transported`, :func:`transport_in_place`).
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel, inline_kernel
from slam_env.kernels.base.models import wrap_angle
from slam_env.kernels.ekf.codes import COV_LIMIT, FLOAT_MAX, NOT_FINITE, OK, OVERFLOW


@inline_kernel
def fill_transport(xw: np.ndarray, x0: np.ndarray, d: int, w: np.ndarray) -> None:
    """w = v(xw) − v(x0) over the d rows: (−Δy, Δx) for each point, 0 at the heading."""
    w[0] = x0[1] - xw[1]
    w[1] = xw[0] - x0[0]
    w[2] = 0.0
    for i in range(3, d, 2):
        w[i] = x0[i + 1] - xw[i + 1]
        w[i + 1] = xw[i] - x0[i]


@inline_kernel
def _retract_point(
    xw: np.ndarray, delta: np.ndarray, k: int, phi: float, c: float, s: float, a: float, b: float
) -> None:
    """The point q at rows k, k+1: ξ̄_q = δ_q − φ J q = (δx + φ q_y, δy − φ q_x), then
    q ← R(φ) q + V(φ) ξ̄_q; ``delta[k:k+2]`` gets Δ(J q) = (−Δq_y, Δq_x)."""
    qx = xw[k]
    qy = xw[k + 1]
    ex = delta[k] + phi * qy
    ey = delta[k + 1] - phi * qx
    nx = (c * qx - s * qy) + (a * ex - b * ey)
    ny = (s * qx + c * qy) + (b * ex + a * ey)
    xw[k] = nx
    xw[k + 1] = ny
    delta[k] = qy - ny
    delta[k + 1] = nx - qx


@inline_kernel
def retract(xw: np.ndarray, delta: np.ndarray, d: int, U: np.ndarray, rows: int) -> None:
    """The working mean ``xw`` moved by exp(ξ̄), where ξ̄ = J_r⁻¹ δ and δ = ``delta[:d]``
    is the standard EKF's step: θ += ξ̄_θ = δ_θ, and each point q (the position, then
    the landmarks) becomes R(ξ̄_θ) q + V(ξ̄_θ) ξ̄_q, V(φ) = (sin φ/φ) I + ((1 − cos φ)/φ) J.
    ``delta`` is overwritten with the transport's Δw = v(new) − v(old), and each of the
    first ``rows`` factor rows u of ``U`` becomes u + u_θ Δw."""
    phi = delta[2]
    c = math.cos(phi)
    s = math.sin(phi)
    a = 1.0
    b = 0.0
    if phi != 0.0:
        a = s / phi
        half = math.sin(0.5 * phi)
        b = 2.0 * half * half / phi  # (1 − cos φ)/φ without the cancellation
    _retract_point(xw, delta, 0, phi, c, s, a, b)
    for k in range(3, d, 2):
        _retract_point(xw, delta, k, phi, c, s, a, b)
    xw[2] = wrap_angle(xw[2] + phi)
    delta[2] = 0.0
    for rho in range(rows):
        u2 = U[rho, 2]
        for col in range(d):
            U[rho, col] += u2 * delta[col]


@borrowing_kernel
def transport_terms(P: np.ndarray, w: np.ndarray, cw: np.ndarray, d: int) -> int:
    """c = P e_θ + ½ P_θθ w into ``cw``, so that T P Tᵀ = P + w cᵀ + c wᵀ. OK where
    every term stays finite and the diagonal of T P Tᵀ within COV_LIMIT (then, T P Tᵀ
    being positive semi-definite, so is every entry). NOT_FINITE or OVERFLOW otherwise."""
    p22 = P[2, 2]
    wmax = 0.0
    cmax = 0.0
    for i in range(d):
        cw[i] = P[i, 2] + 0.5 * p22 * w[i]
        if not (abs(w[i]) <= FLOAT_MAX and abs(cw[i]) <= FLOAT_MAX):
            return NOT_FINITE
        wmax = max(wmax, abs(w[i]))
        cmax = max(cmax, abs(cw[i]))
    if not wmax * cmax <= COV_LIMIT:
        return OVERFLOW
    for i in range(d):
        if not abs(transported(P, w, cw, i, i)) <= COV_LIMIT:
            return OVERFLOW
    return OK


@inline_kernel
def transported(P: np.ndarray, w: np.ndarray, cw: np.ndarray, i: int, j: int) -> float:
    """Entry (i, j) of T P Tᵀ: the same bits as entry (j, i)."""
    return P[i, j] + (w[i] * cw[j] + cw[i] * w[j])


@borrowing_kernel
def transport_in_place(P: np.ndarray, w: np.ndarray, cw: np.ndarray, d: int) -> None:
    """P ← T P Tᵀ on the live block, with ``cw`` from :func:`transport_terms` (P is read
    only through its own entry, so the order of the writes does not matter)."""
    for i in range(d):
        row = P[i]
        for j in range(d):
            row[j] = transported(P, w, cw, i, j)
