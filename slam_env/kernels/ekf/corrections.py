"""The corrections of the batched EKF-SLAM update (:func:`slam_env.kernels.ekf.filter.update`
puts them together with the new landmarks of :mod:`.new_landmarks`): linearising an
observation (:func:`add_observation`), the Joseph-form correction of a group of
observations (:func:`correct_group`, its factor :func:`_joseph_factor`), and the check
and the one application of the deferred covariance factors (:func:`factor_check`,
:func:`apply_factors`). None of them writes the state but the last, which runs only
once everything is checked. The codes they return are those of :mod:`.codes`."""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel, inline_kernel
from slam_env.kernels.base.linalg import cholesky_in_place
from slam_env.kernels.base.models import (
    innovation,
    jacobian,
    observe,
    singular,
    wrap_angle,
)
from slam_env.kernels.ekf.codes import (
    CORRECTED,
    COV_LIMIT,
    FEJ,
    FLOAT_MAX,
    GATE,
    INVARIANT,
    NOT_FINITE,
    NOT_POSITIVE_DEFINITE,
    OC,
    OK,
    OVERFLOW,
    Q00,
    Q01,
    Q11,
    REJECTED,
    SINGULAR,
)
from slam_env.kernels.ekf.invariant import fill_transport, retract

# The small matrices of a correction in the workspace (see correct_group).
SMALL_S, SMALL_SK, SMALL_L, SMALL_LI, SMALL_G, SMALL_E, SMALL_EL, SMALL_W, SMALL_V, SMALL_F = range(
    10
)
N_SMALL = 10


@borrowing_kernel
def all_finite(a: np.ndarray, count: int) -> bool:
    """Whether ``a[:count]`` is all finite (a count of the finite entries: an integer
    sum, which the compiler vectorises where a float test in the loop it would not)."""
    finite = 0
    for i in range(count):
        finite += abs(a[i]) <= FLOAT_MAX
    return finite == count


# --------------------------------------------------------------------------- corrections
#
# One correction of m observations stacked (sequential mode: m = 1, at the mean and
# covariance corrected by the ones before it; batch mode: all of them at once, at the
# belief before the update). With Cᵀ = H P (2m×d), S = H C + Q = L Lᵀ and the gain
# K = C G, G = S⁻¹ as computed, the Joseph form is
#
#     P⁺ = (I − KH) P (I − KH)ᵀ + K Q Kᵀ = P − K Cᵀ − C Kᵀ + K S Kᵀ = P − Y Yᵀ,
#
# Y = C L⁻ᵀ V with V Vᵀ = I − Wᵀ W, W = L⁻¹ E L and E = I − S G the gain's rounding
# error (V = I when the gain is exact). Why Joseph: the gain is S⁻¹ only up to
# rounding, and this stays the covariance of the estimate actually made with it,
# positive semi-definite, with one well-scaled factor. The rows of Yᵀ go to the
# factor rows U; P itself is not written until the update commits (P ← P − Uᵀ U), and
# a later observation reads the rows of P its H touches less Σ Uᵀ U of the ones before.
#
# Per-observation scratch ``obs`` (D, 13): the two rows of [H_x | H_m], the landmark's
# first row, the observation's index and whether the gate kept it (as floats); for
# new landmarks the entries of L and W. ``small`` (10, 2D, 2D): S (later the block
# between new landmarks), S + Q of the kept ones, L, L⁻¹, G, E, E L, W,
# I − Wᵀ W (then V), Vᵀ L⁻¹. ``vec`` (2, 2D): ν and G ν.


@borrowing_kernel
def add_observation(
    model: int,
    xw: np.ndarray,
    P: np.ndarray,
    U: np.ndarray,
    r: int,
    s: int,
    z0: float,
    z1: float,
    obs: np.ndarray,
    C: np.ndarray,
    vec: np.ndarray,
    m: int,
    d: int,
    first: np.ndarray,
    linearization: int,
    x0: np.ndarray,
    w: np.ndarray,
) -> int:
    """Observation m of a group: the landmark at rows s, s+1 of the mean ``xw``
    linearised (H into ``obs[m]``, ν into ``vec[0, 2m:2m+2]``) and its rows 2m, 2m+1
    of Cᵀ = H P at the current covariance P − Σ_{ρ<r} U[ρ]ᵀ U[ρ]. ν is taken at the
    mean; H there too (:data:`STANDARD`), at the first estimates ``first``
    (:data:`FEJ`), or at the mean and then projected off the global rotation at the
    first estimates (:data:`OC`, :func:`_constrain_rotation`). With :data:`INVARIANT`
    the current covariance is T P Tᵀ − Σ U[ρ]ᵀ U[ρ], T the transport from the committed
    mean ``x0`` to ``xw`` (:mod:`.invariant`; w = v(xw) − v(x0) into ``w``), and
    Cᵀ = (h T) P Tᵀ less the factors' part. :data:`SINGULAR` where h cannot be
    linearised. (Rows are indexed, not sliced, here and below: a view of an array
    costs a reference count.)"""
    x = xw[0]
    y = xw[1]
    th = xw[2]
    mx = xw[s]
    my = xw[s + 1]
    lin = first if linearization == FEJ else xw
    lx = lin[0]
    ly = lin[1]
    lmx = lin[s]
    lmy = lin[s + 1]
    if singular(model, x, y, mx, my) or singular(model, lx, ly, lmx, lmy):
        return SINGULAR
    zh0, zh1 = observe(model, x, y, th, mx, my)
    h00, h01, h02, h03, h04, h10, h11, h12, h13, h14 = jacobian(model, lx, ly, lin[2], lmx, lmy)
    if linearization == OC:
        dx = first[s] - first[0]
        dy = first[s + 1] - first[1]
        h00, h01, h02, h03, h04 = _constrain_rotation(h00, h01, h02, h03, h04, dx, dy)
        h10, h11, h12, h13, h14 = _constrain_rotation(h10, h11, h12, h13, h14, dx, dy)
    nu0, nu1 = innovation(model, z0, z1, zh0, zh1)
    total = nu0 + nu1 + h00 + h01 + h02 + h03 + h04 + h10 + h11 + h12 + h13 + h14
    if not math.isfinite(total):
        return NOT_FINITE
    vec[0, 2 * m] = nu0
    vec[0, 2 * m + 1] = nu1
    obs[m, 0] = h00
    obs[m, 1] = h01
    obs[m, 2] = h02
    obs[m, 3] = h03
    obs[m, 4] = h04
    obs[m, 5] = h10
    obs[m, 6] = h11
    obs[m, 7] = h12
    obs[m, 8] = h13
    obs[m, 9] = h14
    obs[m, 10] = s
    a = 2 * m
    g02 = h02  # the heading column of h T (T = I but for the invariant filter)
    g12 = h12
    invariant = linearization == INVARIANT
    if invariant:
        fill_transport(xw, x0, d, w)
        g02 = h02 + (h00 * w[0] + h01 * w[1] + h03 * w[s] + h04 * w[s + 1])
        g12 = h12 + (h10 * w[0] + h11 * w[1] + h13 * w[s] + h14 * w[s + 1])
    for c in range(d):
        p0 = P[0, c]
        p1 = P[1, c]
        p2 = P[2, c]
        ps = P[s, c]
        pt = P[s + 1, c]
        C[a, c] = h00 * p0 + h01 * p1 + g02 * p2 + h03 * ps + h04 * pt
        C[a + 1, c] = h10 * p0 + h11 * p1 + g12 * p2 + h13 * ps + h14 * pt
    if invariant:  # (h T) P, then times Tᵀ on the right: + its θ entry times w
        c0 = C[a, 2]
        c1 = C[a + 1, 2]
        for c in range(d):
            C[a, c] += c0 * w[c]
            C[a + 1, c] += c1 * w[c]
    for rho in range(r):
        w0 = h00 * U[rho, 0] + h01 * U[rho, 1] + h02 * U[rho, 2]
        w0 += h03 * U[rho, s] + h04 * U[rho, s + 1]
        w1 = h10 * U[rho, 0] + h11 * U[rho, 1] + h12 * U[rho, 2]
        w1 += h13 * U[rho, s] + h14 * U[rho, s + 1]
        for c in range(d):
            u = U[rho, c]
            C[a, c] -= w0 * u
            C[a + 1, c] -= w1 * u
    return OK


@inline_kernel
def _constrain_rotation(
    hx: float, hy: float, hth: float, hmx: float, hmy: float, dx: float, dy: float
) -> tuple[float, float, float, float, float]:
    """One row h = (∂/∂x, ∂/∂y, ∂/∂θ, ∂/∂m_x, ∂/∂m_y) of H, changed as little as
    possible (least squares) so that h N = 0 for the unobservable directions N of the
    pose p̂ and landmark m̂ at their first estimates, δ = m̂ − p̂ = (dx, dy): the two
    translations t_x, t_y and the rotation (−p̂_y, p̂_x, 1, −m̂_y, m̂_x). Both models'
    rows already give h t = 0 (only m − p enters h), so the projection is onto the
    rotation's part orthogonal to the translations, n = (δ_y/2, −δ_x/2, 1, −δ_y/2,
    δ_x/2): h ← h − (h n) n / |n|², with h n = h_θ + h_m · (−δ_y, δ_x)."""
    hn = hth - hmx * dy + hmy * dx
    k = hn / (1.0 + 0.5 * (dx * dx + dy * dy))
    return (
        hx - k * 0.5 * dy,
        hy + k * 0.5 * dx,
        hth - k,
        hmx + k * 0.5 * dy,
        hmy - k * 0.5 * dx,
    )


@inline_kernel
def _joseph_factor(small: np.ndarray, m: int) -> bool:
    """From S + Q in ``small[SMALL_SK]`` (m×m): G = S⁻¹ in ``small[SMALL_G]`` and the factor
    Vᵀ L⁻¹ in ``small[SMALL_F]`` (S = L Lᵀ, E = I − S G, W = L⁻¹ E L, V Vᵀ = I − Wᵀ W),
    so that Yᵀ = Vᵀ L⁻¹ Cᵀ. False where S or I − Wᵀ W is not positive definite.
    Triangular factors are kept with exact zeros above the diagonal, and the sums
    run over their non-zero parts only."""
    for i in range(m):
        for j in range(m):
            small[SMALL_L, i, j] = small[SMALL_SK, i, j] if j <= i else 0.0
    if not cholesky_in_place(small[SMALL_L], m):
        return False
    for c in range(m):  # L⁻¹, column by column (forward substitution on e_c)
        for i in range(m):
            if i < c:
                small[SMALL_LI, i, c] = 0.0
            else:
                acc = 1.0 if i == c else 0.0
                for t in range(c, i):
                    acc -= small[SMALL_L, i, t] * small[SMALL_LI, t, c]
                small[SMALL_LI, i, c] = acc / small[SMALL_L, i, i]
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for t in range(max(i, j), m):
                acc += small[SMALL_LI, t, i] * small[SMALL_LI, t, j]
            small[SMALL_G, i, j] = acc  # G = L⁻ᵀ L⁻¹
    for i in range(m):
        for j in range(m):
            acc = 1.0 if i == j else 0.0
            for t in range(m):
                acc -= small[SMALL_SK, i, t] * small[SMALL_G, t, j]
            small[SMALL_E, i, j] = acc  # E = I − S G
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for t in range(j, m):
                acc += small[SMALL_E, i, t] * small[SMALL_L, t, j]
            small[SMALL_EL, i, j] = acc  # E L
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for t in range(i + 1):
                acc += small[SMALL_LI, i, t] * small[SMALL_EL, t, j]
            small[SMALL_W, i, j] = acc  # W = L⁻¹ E L
    for i in range(m):
        for j in range(m):
            if j <= i:
                acc = 1.0 if i == j else 0.0
                for t in range(m):
                    acc -= small[SMALL_W, t, i] * small[SMALL_W, t, j]
                small[SMALL_V, i, j] = acc  # I − Wᵀ W (lower), factorised in place
            else:
                small[SMALL_V, i, j] = 0.0
    if not cholesky_in_place(small[SMALL_V], m):
        return False
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for t in range(max(i, j), m):
                acc += small[SMALL_V, t, i] * small[SMALL_LI, t, j]
            small[SMALL_F, i, j] = acc  # Vᵀ L⁻¹
    return True


@inline_kernel
def correct_group(
    xw: np.ndarray,
    d: int,
    U: np.ndarray,
    r: int,
    C: np.ndarray,
    obs: np.ndarray,
    m: int,
    params: np.ndarray,
    small: np.ndarray,
    vec: np.ndarray,
    status: np.ndarray,
    nis: np.ndarray,
    invariant: bool,
    delta: np.ndarray,
) -> tuple[int, int, int]:
    """Gate and apply m linearised observations (``obs[:m]``, their rows of Cᵀ in
    ``C[:2m]``, ν in ``vec[0, :2m]``) as one stacked correction. S = H P Hᵀ; each
    observation is gated on its NIS νᵀS⁻¹ν over its own 2×2 block of S + Q; the kept
    ones are moved up (their block of S + blockdiag(Q) into ``small[SMALL_SK]``, their
    rows of Cᵀ and ν in place: a target row never passes its source) and applied:
    the factor rows Yᵀ = Vᵀ L⁻¹ Cᵀ into ``U[r:]``, the mean step x += K ν =
    (G ν)ᵀ Cᵀ on the working mean ``xw``. Returns (factor rows added, rejected,
    error code). With ``invariant`` the step K ν is summed into ``delta`` and applied by
    the exponential map, which also carries the factor rows to the new mean
    (:func:`~.invariant.retract`). (A non-finite value in U or the mean is caught
    before the commit: by the next linearisation, :func:`factor_check` or the check
    of the mean.)"""
    q00 = params[Q00]
    q01 = params[Q01]
    q11 = params[Q11]
    gate = params[GATE]
    for i in range(2 * m):
        for b in range(m):
            sb = int(obs[b, 10])
            for beta in range(2):
                o = 5 * beta
                small[SMALL_S, i, 2 * b + beta] = (
                    C[i, 0] * obs[b, o]
                    + C[i, 1] * obs[b, o + 1]
                    + C[i, 2] * obs[b, o + 2]
                    + C[i, sb] * obs[b, o + 3]
                    + C[i, sb + 1] * obs[b, o + 4]
                )
    for i in range(2 * m):
        for j in range(i):
            v = (small[SMALL_S, i, j] + small[SMALL_S, j, i]) * 0.5  # exactly symmetric
            small[SMALL_S, i, j] = v
            small[SMALL_S, j, i] = v
    rejected = 0
    kept = 0
    for a in range(m):
        # NIS = |L⁻¹ν|² with S_aa + Q = L Lᵀ.
        sa = small[SMALL_S, 2 * a, 2 * a] + q00
        sb = small[SMALL_S, 2 * a, 2 * a + 1] + q01
        sc = small[SMALL_S, 2 * a + 1, 2 * a + 1] + q11
        if not math.isfinite(sa + sb + sc):
            return 0, rejected, NOT_FINITE
        if not sa > 0.0:
            return 0, rejected, NOT_POSITIVE_DEFINITE
        l00 = math.sqrt(sa)
        l10 = sb / l00
        v = sc - l10 * l10
        if not v > 0.0:
            return 0, rejected, NOT_POSITIVE_DEFINITE
        w0 = vec[0, 2 * a] / l00
        w1 = (vec[0, 2 * a + 1] - l10 * w0) / math.sqrt(v)
        value = w0 * w0 + w1 * w1
        j = int(obs[a, 11])
        nis[j] = value
        if value > gate:
            status[j] = REJECTED
            rejected += 1
            obs[a, 12] = 0.0
        else:
            status[j] = CORRECTED
            obs[a, 12] = 1.0
            kept += 1
    ka = 0
    for a in range(m):
        if obs[a, 12] == 0.0:
            continue
        kb = 0
        for b in range(m):
            if obs[b, 12] != 0.0:
                for alpha in range(2):
                    for beta in range(2):
                        small[SMALL_SK, 2 * ka + alpha, 2 * kb + beta] = small[
                            SMALL_S, 2 * a + alpha, 2 * b + beta
                        ]
                kb += 1
        small[SMALL_SK, 2 * ka, 2 * ka] += q00
        small[SMALL_SK, 2 * ka, 2 * ka + 1] += q01
        small[SMALL_SK, 2 * ka + 1, 2 * ka] += q01
        small[SMALL_SK, 2 * ka + 1, 2 * ka + 1] += q11
        if ka < a:
            for alpha in range(2):
                for c in range(d):
                    C[2 * ka + alpha, c] = C[2 * a + alpha, c]
                vec[0, 2 * ka + alpha] = vec[0, 2 * a + alpha]
        ka += 1
    if kept == 0:
        return 0, rejected, OK
    mm = 2 * kept
    # One observation (sequential mode): inlined with m = 2, its loops unrolled.
    factored = _joseph_factor(small, 2) if mm == 2 else _joseph_factor(small, mm)
    if not factored:
        return 0, rejected, NOT_POSITIVE_DEFINITE
    for i in range(mm):
        acc = 0.0
        for t in range(mm):
            acc += small[SMALL_G, i, t] * vec[0, t]
        vec[1, i] = acc  # G ν
    for i in range(mm):
        coef = small[SMALL_F, i, 0]
        for c in range(d):
            U[r + i, c] = coef * C[0, c]
        for t in range(1, mm):
            coef = small[SMALL_F, i, t]
            for c in range(d):
                U[r + i, c] += coef * C[t, c]
    if invariant:
        for c in range(d):
            delta[c] = 0.0
        for t in range(mm):
            coef = vec[1, t]
            for c in range(d):
                delta[c] += coef * C[t, c]
        retract(xw, delta, d, U, r + mm)
        return mm, rejected, OK
    for t in range(mm):
        coef = vec[1, t]
        for c in range(d):
            xw[c] += coef * C[t, c]
    xw[2] = wrap_angle(xw[2])
    return mm, rejected, OK


@borrowing_kernel
def factor_check(U: np.ndarray, r: int, d: int, norms: np.ndarray) -> int:
    """OK where every (Uᵀ U)ᵢᵢ = Σ_ρ U[ρ, i]² (into ``norms``) is finite and at most
    COV_LIMIT: then, by Cauchy–Schwarz, so is every entry of Uᵀ U, and P − Uᵀ U
    cannot overflow. NOT_FINITE for a NaN in U, OVERFLOW otherwise."""
    for i in range(d):
        norms[i] = 0.0
    for rho in range(r):
        for i in range(d):
            norms[i] += U[rho, i] * U[rho, i]
    bounded = 0
    for i in range(d):
        bounded += norms[i] <= COV_LIMIT
    if bounded == d:
        return OK
    for i in range(d):
        if math.isnan(norms[i]):
            return NOT_FINITE
    return OVERFLOW


@inline_kernel
def _subtract_from_rows(
    p0: np.ndarray,
    p1: np.ndarray,
    p2: np.ndarray,
    p3: np.ndarray,
    U: np.ndarray,
    i: int,
    r: int,
    lo: int,
    n: int,
) -> None:
    """Rows i..i+3 of P on the n columns from ``lo`` (``p0``..``p3``: those segments)
    less their part of Uᵀ U, two factor rows a pass: four rows share each load of U."""
    for rho in range(0, r, 2):
        a0 = U[rho, i]
        a1 = U[rho + 1, i]
        b0 = U[rho, i + 1]
        b1 = U[rho + 1, i + 1]
        c0 = U[rho, i + 2]
        c1 = U[rho + 1, i + 2]
        e0 = U[rho, i + 3]
        e1 = U[rho + 1, i + 3]
        # Views from lo, indexed from 0: with a loop from lo the compiler cannot tell
        # the index is not negative, and would not vectorise.
        u0 = U[rho, lo:]
        u1 = U[rho + 1, lo:]
        for j in range(n):
            x0 = u0[j]
            x1 = u1[j]
            p0[j] = (p0[j] - a0 * x0) - a1 * x1
            p1[j] = (p1[j] - b0 * x0) - b1 * x1
            p2[j] = (p2[j] - c0 * x0) - c1 * x1
            p3[j] = (p3[j] - e0 * x0) - e1 * x1


@inline_kernel
def _mirror_rows(P: np.ndarray, g: int, d: int) -> None:
    """Rows g..g+3 of P, from column g + 4 on, copied into columns g..g+3 of the rows
    below, four rows at a time (16 loads, then 16 stores)."""
    r0 = P[g]
    r1 = P[g + 1]
    r2 = P[g + 2]
    r3 = P[g + 3]
    j = g + 4
    while j + 4 <= d:
        a0, a1, a2, a3 = r0[j], r0[j + 1], r0[j + 2], r0[j + 3]
        b0, b1, b2, b3 = r1[j], r1[j + 1], r1[j + 2], r1[j + 3]
        c0, c1, c2, c3 = r2[j], r2[j + 1], r2[j + 2], r2[j + 3]
        e0, e1, e2, e3 = r3[j], r3[j + 1], r3[j + 2], r3[j + 3]
        s = P[j]
        s[g], s[g + 1], s[g + 2], s[g + 3] = a0, b0, c0, e0
        s = P[j + 1]
        s[g], s[g + 1], s[g + 2], s[g + 3] = a1, b1, c1, e1
        s = P[j + 2]
        s[g], s[g + 1], s[g + 2], s[g + 3] = a2, b2, c2, e2
        s = P[j + 3]
        s[g], s[g + 1], s[g + 2], s[g + 3] = a3, b3, c3, e3
        j += 4
    while j < d:
        s = P[j]
        s[g], s[g + 1], s[g + 2], s[g + 3] = r0[j], r1[j], r2[j], r3[j]
        j += 1


@borrowing_kernel
def apply_factors(P: np.ndarray, U: np.ndarray, r: int, d: int) -> None:
    """P ← P − Uᵀ U on the live block, entry by entry as ((P − u₀u₀) − u₁u₁) − …
    One pass over P however many corrections the update made (r is even).

    Only the upper triangle is computed, four rows at a time, each block of four from
    its diagonal on (the lower entries of its 4×4 diagonal block too), then copied
    into the rows below; the last d mod 4 rows compute their block on the diagonal.
    Half the arithmetic of the whole product, and P stays exactly symmetric: an entry
    and its mirror are one number, the one the whole product would give either (P was
    symmetric, and u_i u_j = u_j u_i)."""
    d4 = d - d % 4
    for g in range(0, d4, 4):
        n = d - g
        _subtract_from_rows(P[g, g:], P[g + 1, g:], P[g + 2, g:], P[g + 3, g:], U, g, r, g, n)
        _mirror_rows(P, g, d)
    for i in range(d4, d):
        row = P[i]
        for j in range(d4, d):
            v = row[j]
            for rho in range(r):
                v -= U[rho, i] * U[rho, j]
            row[j] = v
