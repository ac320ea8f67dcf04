"""The new landmarks of the batched EKF-SLAM update (seed 000 §2.2;
:func:`slam_env.kernels.ekf.filter.update` calls them after the corrections of
:mod:`.corrections`): their initialisation from the corrected belief
(:func:`new_landmarks`, which writes no state) and, once everything is checked, their
commit into the state (:func:`commit_new_landmarks`). The codes they return are those
of :mod:`.codes`."""

from __future__ import annotations

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel
from slam_env.kernels.base.models import inverse, inverse_jacobian
from slam_env.kernels.ekf.codes import (
    COV_LIMIT,
    INITIALISED,
    NOT_FINITE,
    OK,
    OVERFLOW,
    Q00,
    Q01,
    Q11,
)
from slam_env.kernels.ekf.corrections import all_finite
from slam_env.kernels.ekf.invariant import transported


@borrowing_kernel
def new_landmarks(
    xw: np.ndarray,
    P: np.ndarray,
    d: int,
    slot_of: np.ndarray,
    z: np.ndarray,
    ids: np.ndarray,
    k: int,
    params: np.ndarray,
    model: int,
    U: np.ndarray,
    r: int,
    PR: np.ndarray,
    C: np.ndarray,
    LW: np.ndarray,
    NB: np.ndarray,
    first: np.ndarray,
    first_estimates: bool,
    transport: bool,
    w: np.ndarray,
    cw: np.ndarray,
) -> tuple[int, int]:
    """The new landmarks (seed 000 §2.2), in the given order, from the corrected
    belief, without writing P: m = h⁻¹(z, pose) into ``xw[d:]``; with L = ∂h⁻¹/∂pose,
    W = ∂h⁻¹/∂z, their rows P_m,y = L P_x,y into C (2 rows each; P_x,y the corrected
    pose rows, P − Uᵀ U, into PR) and the block between them, L P_xx Lᵀ + W Q Wᵀ,
    into NB (not yet symmetrised). ``LW`` gets (l02, l12, w00, w01, w10, w11) of each.
    Returns (new landmarks, error code).

    With ``first_estimates`` (FEJ and OC), L is linearised at the first estimates, as
    FEJ's H is: the pose this step's prediction produced (``first[:3]``) and the new
    landmark's own first estimate m, so L = −H_m⁻¹ H_x there: [[1, 0, −(m_y − ŷ)],
    [0, 1, m_x − x̂]] (both measurement models). At the corrected pose instead, L would
    map the global rotation's direction at the predicted pose, (−ŷ, x̂, 1), to
    J(m − p̂_corrected) + J p̂ rather than to the landmark's own J m, and a scan that both
    corrects and starts a landmark would give the filter information about the
    unobservable rotation.

    With ``transport`` (the invariant filter, after a correction) the corrected belief
    is T P Tᵀ − Uᵀ U, T P Tᵀ = P + w cᵀ + c wᵀ with ``w`` and ``cw`` from
    :func:`~.invariant.transport_terms`; L and W are then the standard ones at the
    corrected pose (docs/filter.md, "How the kernels keep it")."""
    new = 0
    for j in range(k):
        if ids[j] >= 0 and slot_of[ids[j]] < 0:
            new += 1
    if new == 0:
        return 0, OK
    for t in range(3):
        PRt = PR[t]
        Pt = P[t]
        for c in range(d):
            v = transported(P, w, cw, t, c) if transport else Pt[c]
            for rho in range(r):
                v -= U[rho, t] * U[rho, c]
            PRt[c] = v  # the arithmetic of apply_factors: the same bits
    px = xw[0]
    py = xw[1]
    pth = xw[2]
    a = 0
    for j in range(k):
        if ids[j] < 0 or slot_of[ids[j]] >= 0:
            continue
        mx, my = inverse(model, px, py, pth, z[j, 0], z[j, 1])
        lw = inverse_jacobian(model, pth, z[j, 0], z[j, 1])
        for t in range(6):
            LW[a, t] = lw[t]
        if first_estimates:  # L at the first estimates (see above); W as the standard EKF's
            LW[a, 0] = first[1] - my
            LW[a, 1] = mx - first[0]
        xw[d + 2 * a] = mx
        xw[d + 2 * a + 1] = my
        Ca = C[2 * a]
        Cb = C[2 * a + 1]
        l02 = LW[a, 0]
        l12 = LW[a, 1]
        for c in range(d):
            Ca[c] = PR[0, c] + l02 * PR[2, c]
            Cb[c] = PR[1, c] + l12 * PR[2, c]
        if not (all_finite(Ca, d) and all_finite(Cb, d)):
            return new, NOT_FINITE
        a += 1
    q00 = params[Q00]
    q01 = params[Q01]
    q11 = params[Q11]
    for i in range(2 * new):
        Ci = C[i]
        for b in range(new):
            NB[i, 2 * b] = Ci[0] + Ci[2] * LW[b, 0]
            NB[i, 2 * b + 1] = Ci[1] + Ci[2] * LW[b, 1]
    for a in range(new):
        w00 = LW[a, 2]
        w01 = LW[a, 3]
        w10 = LW[a, 4]
        w11 = LW[a, 5]
        t00 = w00 * q00 + w01 * q01  # W Q
        t01 = w00 * q01 + w01 * q11
        t10 = w10 * q00 + w11 * q01
        t11 = w10 * q01 + w11 * q11
        NB[2 * a, 2 * a] += t00 * w00 + t01 * w01
        NB[2 * a, 2 * a + 1] += t00 * w10 + t01 * w11
        NB[2 * a + 1, 2 * a] += t10 * w00 + t11 * w01
        NB[2 * a + 1, 2 * a + 1] += t10 * w10 + t11 * w11
    for i in range(2 * new):
        for j in range(2 * new):
            if not abs(NB[i, j]) <= COV_LIMIT:
                return new, OVERFLOW
    return new, OK


@borrowing_kernel
def commit_new_landmarks(
    x: np.ndarray,
    P: np.ndarray,
    n: int,
    slot_of: np.ndarray,
    slot_to_id: np.ndarray,
    first: np.ndarray,
    xw: np.ndarray,
    d: int,
    C: np.ndarray,
    NB: np.ndarray,
    new: int,
    ids: np.ndarray,
    k: int,
    status: np.ndarray,
) -> None:
    """Write the working mean and the new landmarks (rows, mirrored columns, the
    symmetrised block, the ID maps, the first estimates) into the state."""
    for i in range(d + 2 * new):
        x[i] = xw[i]
    for i in range(d, d + 2 * new):
        first[i] = xw[i]
    for i in range(2 * new):
        Ci = C[i]
        row = P[d + i]
        for c in range(d):
            v = Ci[c]
            row[c] = v
            P[c, d + i] = v
        for j in range(2 * new):
            row[d + j] = (NB[i, j] + NB[j, i]) * 0.5
    slot = n
    for j in range(k):
        lid = ids[j]
        if lid >= 0 and slot_of[lid] < 0:
            slot_of[lid] = slot
            slot_to_id[slot] = lid
            status[j] = INITIALISED
            slot += 1
