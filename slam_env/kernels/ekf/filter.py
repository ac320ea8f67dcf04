"""Batched EKF-SLAM: prediction and update of B filters in one call each, over the
state arrays the vector env holds for its worlds. The correspondences are given (the
landmark IDs, or the choice of :mod:`slam_env.kernels.ekf.association`).
:func:`update` puts together the pieces of :mod:`.corrections` (the Joseph-form
corrections, the one pass over P) and :mod:`.new_landmarks` (the new landmarks, their
commit); the codes both share are :mod:`.codes`.

State of B filters with room for M landmarks (``dmax = 3 + 2M``)
    x (B, dmax) float64            means; world b's live part is ``x[b, :3 + 2 n[b]]``
    P (B, dmax, dmax) float64      covariances; live block ``P[b, :d, :d]``, never read outside
    n (B,) int64                   landmarks in each state
    id_to_slot (B, M) int64        slot of each landmark ID, -1 if unknown
    slot_to_id (B, M) int64        landmark ID of each slot (slots ≥ n[b] unused)
    n_rejected (B,) int64          observations rejected since the filter's reset
    first (B, dmax) float64        first estimates: the pose the last prediction made,
                                   then each landmark as it was initialised (what the
                                   First-Estimates Jacobian EKF linearises at)
Slot i is rows ``3+2i, 4+2i``; new landmarks take the next slots in the order first seen.

Configuration, per world: ``params`` (B, 12) float64 and ``modes`` (B, 5) int64, whose
columns and codes :mod:`.codes` names, with the statuses and error codes.

Linearisation: the standard EKF evaluates every Jacobian at the latest estimate. The
First-Estimates Jacobian EKF (Huang, Mourikis & Roumeliotis) evaluates the prediction's
G at the pose the previous prediction produced (``a = −(y' − ŷ_first)``,
``b = x' − x̂_first``), each measurement's H at the pose this step's prediction
produced and at the landmark's first estimate, and a new landmark's L (= −H_m⁻¹ H_x)
at that pose and at the new landmark's first estimate, so that the linearised system keeps the
true one's unobservable directions (global translation and rotation) and the filter
does not turn over-confident. The observability-constrained EKF (OC) keeps FEJ's G and
L, but takes each H at the latest estimate, as the standard EKF does, and removes from
it the least it must (in the Frobenius norm) for those directions to stay unobservable
(``H N = 0``, N at the first estimates; Hesch, Kottas, Bowman & Roumeliotis, 2014): FEJ's
constraint, with Jacobians nearer the truth than the first estimates. Means,
innovations and noise Jacobians are the same in all three. The right-invariant EKF
(Barrau & Bonnabel) predicts as the standard EKF and linearises at the latest
estimate, but corrects the mean by the exponential map of SE_{1+N}(2) and carries P
to each new estimate (:mod:`.invariant`): P is then J_r P_inv J_rᵀ, the covariance of
its error in invariant coordinates mapped to the state's.

Every call is atomic per world: a world whose step fails (bad input, an innovation
covariance that is not positive definite, a non-finite intermediate, a covariance that
would overflow) keeps its mean, covariance, maps and counters exactly as they were, and
its ``error`` entry says why (:data:`~.codes.ERROR_NAMES`). The work is
compute-then-commit: a prediction computes its O(d) rows before writing any; an update
works on a copy of the O(d) mean, keeps its corrections of P as deferred factors
(``P ← P − Uᵀ U``) and the new landmarks' rows in the workspace, checks them all, and
only then writes P, once.

Costs (``d = 3 + 2n``, k observations, k' of them corrections): prediction O(d); an
update O(k'·(k' + 5)·d) for the corrections, O(k'·d²) for the one pass over P that
applies them, O(d) per new landmark. No dense d×d G, R or H is built, nothing larger
than the 2×2 S (2k'×2k' in batch mode) is factorised, and P stays exactly symmetric.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel
from slam_env.kernels.base.models import ODOMETRY, motion_predict
from slam_env.kernels.ekf.codes import (
    ASSOCIATION,
    BAD_ID,
    BAD_INPUT,
    CORRECTION,
    COV_LIMIT,
    DISCARD_ID,
    DISCARDED,
    DUPLICATE_ID,
    FEJ,
    INVARIANT,
    KNOWN,
    LINEARIZATION,
    MEASUREMENT,
    MOTION,
    NOISE,
    NOT_FINITE,
    OC,
    OK,
    OVERFLOW,
    REJECTED,
    SEQUENTIAL,
    SINGULAR,
    SMALL_WORKSPACE,
    TENTATIVE,
    TENTATIVE_ID,
    UNUSED,
)
from slam_env.kernels.ekf.corrections import (
    N_SMALL,
    SMALL_S,
    add_observation,
    all_finite,
    apply_factors,
    correct_group,
    factor_check,
)
from slam_env.kernels.ekf.invariant import fill_transport, transport_in_place, transport_terms
from slam_env.kernels.ekf.new_landmarks import commit_new_landmarks, new_landmarks


@borrowing_kernel
def update_workspace_size(dmax: int, max_obs: int) -> int:
    """Entries of the float64 workspace :func:`update` needs for states of ``dmax``
    rows and up to ``max_obs`` observations per world (``z.shape[1]``). What grows
    with the observations' square is sized by :func:`most_applied`, not by the rows."""
    r = 2 * most_applied(dmax, max_obs)
    return dmax * (2 * r + 6) + N_SMALL * r * r + 2 * r + 13 * max_obs


@borrowing_kernel
def most_applied(dmax: int, max_obs: int) -> int:
    """The most observations one update of a state of ``dmax`` rows applies: each
    corrects a landmark or starts one, no landmark twice (distinct IDs, or the
    association's one pairing per landmark), so at most the ``(dmax − 3) / 2`` slots."""
    return min(max_obs, (dmax - 3) // 2)


@borrowing_kernel
def largest_count(counts: np.ndarray, mask: np.ndarray, D: int) -> int:
    """The most observations one world of ``mask`` has (counts clipped to [0, D]): what
    a call's workspaces must hold."""
    K = 0
    for b in range(counts.shape[0]):
        if mask[b]:
            K = max(K, min(max(counts[b], 0), D))
    return K


# --------------------------------------------------------------------------- prediction


@borrowing_kernel
def _predict_world(
    x: np.ndarray,
    P: np.ndarray,
    d: int,
    first: np.ndarray,
    u: np.ndarray,
    params: np.ndarray,
    model: int,
    first_estimates: bool,
) -> int:
    """One world's prediction (seed 000 §2.1): P_xx ← G P_xx Gᵀ + R_x, P_xm ← G P_xm,
    the landmarks unchanged; the new pose is also the first estimate of this pose.
    Checks everything before writing anything."""
    u0 = u[0]
    u1 = u[1]
    u2 = u[2] if model == ODOMETRY else 0.0
    if not (math.isfinite(u0) and math.isfinite(u1) and math.isfinite(u2)):
        return BAD_INPUT
    nx, ny, nth, a, b, r00, r01, r02, r11, r12, r22 = motion_predict(
        model,
        x[0],
        x[1],
        x[2],
        u0,
        u1,
        u2,
        params[NOISE],
        params[NOISE + 1],
        params[NOISE + 2],
        params[NOISE + 3],
    )
    if first_estimates:  # G at the first estimates (FEJ, OC): the pose the last prediction produced
        a = first[1] - ny
        b = nx - first[0]
    p00 = P[0, 0]
    p01 = P[0, 1]
    p02 = P[0, 2]
    p11 = P[1, 1]
    p12 = P[1, 2]
    p22 = P[2, 2]
    # G P_xx Gᵀ + R_x with G = [[1, 0, a], [0, 1, b], [0, 0, 1]] (P_xx symmetric).
    q02 = p02 + a * p22
    q12 = p12 + b * p22
    n00 = p00 + a * p02 + a * q02 + r00
    n01 = p01 + a * p12 + b * q02 + r01
    n11 = p11 + b * p12 + b * q12 + r11
    n02 = q02 + r02
    n12 = q12 + r12
    n22 = p22 + r22
    pose_ok = math.isfinite(nx) and math.isfinite(ny) and math.isfinite(nth)
    block = (n00, n01, n02, n11, n12, n22)
    for v in block:
        if not abs(v) <= COV_LIMIT:
            pose_ok = False
    if not pose_ok:
        return OVERFLOW
    # P_xm ← G P_xm: rows x and y gain a, b times the heading row.
    P0 = P[0]
    P1 = P[1]
    P2 = P[2]
    for c in range(3, d):
        if not (abs(P0[c] + a * P2[c]) <= COV_LIMIT and abs(P1[c] + b * P2[c]) <= COV_LIMIT):
            return OVERFLOW
    for c in range(3, d):
        v0 = P0[c] + a * P2[c]
        v1 = P1[c] + b * P2[c]
        P0[c] = v0
        P1[c] = v1
        P[c, 0] = v0
        P[c, 1] = v1
    P[0, 0] = n00
    P[0, 1] = n01
    P[1, 0] = n01
    P[0, 2] = n02
    P[2, 0] = n02
    P[1, 1] = n11
    P[1, 2] = n12
    P[2, 1] = n12
    P[2, 2] = n22
    x[0] = nx
    x[1] = ny
    x[2] = nth
    first[0] = nx
    first[1] = ny
    first[2] = nth
    return OK


@borrowing_kernel
def predict(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    first: np.ndarray,
    u: np.ndarray,
    params: np.ndarray,
    modes: np.ndarray,
    mask: np.ndarray,
    error: np.ndarray,
) -> None:
    """Predict every world b with ``mask[b]`` under its control ``u[b]`` ((B, 3); a
    velocity model reads the first two columns, and u may then be (B, 2)); the new pose
    is also written to ``first[b, :3]``. ``error[b]`` gets the world's error code
    (:data:`OK` for the worlds not touched)."""
    for b in range(x.shape[0]):
        error[b] = OK
        if mask[b]:
            error[b] = _predict_world(
                x[b],
                P[b],
                3 + 2 * n[b],
                first[b],
                u[b],
                params[b],
                modes[b, MOTION],
                modes[b, LINEARIZATION] == FEJ or modes[b, LINEARIZATION] == OC,
            )


@borrowing_kernel
def predict_one(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    first: np.ndarray,
    u: np.ndarray,
    params: np.ndarray,
    modes: np.ndarray,
    mask: np.ndarray,
    error: np.ndarray,
    u0: float,
    u1: float,
    u2: float,
) -> int:
    """:func:`predict` of a batch of one (the arrays as there, B = 1) with its control
    given as numbers: ``u[0]`` gets (u0, u1, u2), or (u0, u1) where u has two columns.
    Returns the error code, ``error[0]``. What :class:`~slam_env.ekf.EKFSLAM` calls:
    three writes into a numpy array from Python, and the read of the error, cost more
    than the prediction at N = 20."""
    u[0, 0] = u0
    u[0, 1] = u1
    if u.shape[1] > 2:
        u[0, 2] = u2
    predict(x, P, n, first, u, params, modes, mask, error)
    return error[0]


# --------------------------------------------------------------------------- update


@borrowing_kernel
def _check_observations(z: np.ndarray, ids: np.ndarray, k: int, n_ids: int, lowest: int) -> int:
    """BAD_INPUT for a non-finite measurement, BAD_ID / DUPLICATE_ID for the IDs
    (``lowest``: the lowest ID allowed, TENTATIVE_ID where the filter associates)."""
    for j in range(k):
        if not (math.isfinite(z[j, 0]) and math.isfinite(z[j, 1])):
            return BAD_INPUT
        lid = ids[j]
        if lid < lowest or lid >= n_ids:
            return BAD_ID
        for i in range(j):
            if ids[i] == lid and lid >= 0:
                return DUPLICATE_ID
    return OK


@borrowing_kernel
def update(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    id_to_slot: np.ndarray,
    slot_to_id: np.ndarray,
    n_rejected: np.ndarray,
    first: np.ndarray,
    params: np.ndarray,
    modes: np.ndarray,
    z: np.ndarray,
    ids: np.ndarray,
    counts: np.ndarray,
    mask: np.ndarray,
    status: np.ndarray,
    nis: np.ndarray,
    error: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Update every world b with ``mask[b]`` with its first ``counts[b]`` observations
    ``z[b, :counts[b]]`` (z: (B, D, 2)) of landmarks ``ids[b, :counts[b]]`` ((B, D)).

    Known landmarks are corrected first, in the given order (sequentially, each
    re-linearised at the corrected mean, or stacked in batch mode), each passing the
    χ² gate; then the new landmarks are initialised from the corrected belief, in the
    given order. Where the filter associates (``modes[b, ASSOCIATION] != KNOWN``) an ID
    of :data:`DISCARD_ID` is an observation given to no landmark, :data:`DISCARDED`,
    and :data:`TENTATIVE_ID` one held for confirmation, :data:`TENTATIVE`.
    ``status[b, j]`` ((B, D) int8) gets :data:`CORRECTED`, :data:`INITIALISED`,
    :data:`REJECTED`, :data:`DISCARDED` or :data:`TENTATIVE` (:data:`UNUSED` past the
    count, for worlds not touched and for a failed world); ``nis[b, j]`` ((B, D)
    float64) νᵀS⁻¹ν of each correction or rejection (NaN otherwise); ``error[b]`` the
    error code. ``work``: a float64 scratch array of at least
    :func:`update_workspace_size` ``(dmax, K)`` entries, K the largest count of the
    worlds updated (at most D: a workspace grows with the detections a step has, not
    with the rows of the padded array), shared by the worlds (they are updated one after
    the other). Returns False, with every world asked for refused
    (:data:`SMALL_WORKSPACE`) and nothing changed, where it is smaller."""
    B = x.shape[0]
    dmax = x.shape[1]
    D = z.shape[1]
    K = largest_count(counts, mask, D)
    room = work.shape[0] >= update_workspace_size(dmax, K)
    for b in range(B):
        for j in range(D):
            status[b, j] = UNUSED
            nis[b, j] = math.nan
        error[b] = OK if room or not mask[b] else SMALL_WORKSPACE
    if not room:
        return False
    # The workspace: the working mean, the factor rows U, the rows C (Cᵀ = H P, then
    # the new landmarks' cross-covariances), the corrected pose rows PR, the small
    # matrices, ν and G ν, the invariant filter's transport rows (w and c, or the step
    # of a correction: see .invariant), and the per-observation scratch; 2 rows of each
    # stacked array for an observation applied (corrections, then new landmarks:
    # most_applied).
    R = 2 * most_applied(dmax, K)
    o = 0
    xw = work[o : o + dmax]
    o += dmax
    U = work[o : o + R * dmax].reshape((R, dmax))
    o += R * dmax
    C = work[o : o + R * dmax].reshape((R, dmax))
    o += R * dmax
    PR = work[o : o + 3 * dmax].reshape((3, dmax))
    o += 3 * dmax
    small = work[o : o + N_SMALL * R * R].reshape((N_SMALL, R, R))
    o += N_SMALL * R * R
    vec = work[o : o + 2 * R].reshape((2, R))
    o += 2 * R
    tw = work[o : o + 2 * dmax].reshape((2, dmax))
    o += 2 * dmax
    obs = work[o : o + 13 * K].reshape((K, 13))
    for b in range(B):
        if not mask[b]:
            continue
        st = status[b]
        ns = nis[b]
        zb = z[b]
        ib = ids[b]
        slot_of = id_to_slot[b]
        xb = x[b]
        Pb = P[b]
        pb = params[b]
        k = counts[b]
        d = 3 + 2 * n[b]
        lowest = 0 if modes[b, ASSOCIATION] == KNOWN else TENTATIVE_ID
        err = (
            BAD_INPUT
            if k < 0 or k > D
            else _check_observations(zb, ib, k, slot_of.shape[0], lowest)
        )
        model = modes[b, MEASUREMENT]
        sequential = modes[b, CORRECTION] == SEQUENTIAL
        linearization = modes[b, LINEARIZATION]
        invariant = linearization == INVARIANT
        fb = first[b]
        # np.int64(0), not 0: a literal 0 passed on would compile the callees once more.
        r = np.int64(0)
        m = np.int64(0)
        rejected = 0
        for i in range(d):
            xw[i] = xb[i]
        # Corrections of the known landmarks, in the given order; a group of m is
        # gated and applied when it is complete: after each one in sequential mode,
        # after all of them (j == k) in batch mode.
        for j in range(k + 1 if err == OK else 0):
            if j < k:
                if ib[j] < 0:
                    st[j] = DISCARDED if ib[j] == DISCARD_ID else TENTATIVE
                    continue
                slot = slot_of[ib[j]]
                if slot < 0:
                    continue  # a new landmark
                code = add_observation(
                    model, xw, Pb, U, r, 3 + 2 * slot, zb[j, 0], zb[j, 1], obs, C, vec, m, d,
                    fb, linearization, xb, tw[0],
                )  # fmt: skip
                if code == SINGULAR:
                    st[j] = REJECTED  # h cannot be linearised (a landmark on the robot)
                    rejected += 1
                    continue
                if code != OK:
                    err = code
                    break
                obs[m, 11] = j
                m += 1
                if not sequential:
                    continue
            if m == 0:
                continue
            if sequential:  # one observation: inlined with m = 1, its loops unrolled
                added, dropped, code = correct_group(
                    xw, d, U, r, C, obs, 1, pb, small, vec, st, ns, invariant, tw[0]
                )  # fmt: skip
            else:
                added, dropped, code = correct_group(
                    xw, d, U, r, C, obs, m, pb, small, vec, st, ns, invariant, tw[0]
                )  # fmt: skip
            rejected += dropped
            m = np.int64(0)
            if code != OK:
                err = code
                break
            r += added
        if err == OK:
            err = factor_check(U, r, d, PR[0])
        transport = invariant and r > 0  # the invariant filter's Σ, carried to the new mean
        if err == OK and transport:
            fill_transport(xw, xb, d, tw[0])
            err = transport_terms(Pb, tw[0], tw[1], d)
        new = 0
        if err == OK:
            new, err = new_landmarks(
                xw, Pb, d, slot_of, zb, ib, k, pb, model, U, r, PR, C, obs, small[SMALL_S],
                fb, linearization in (FEJ, OC), transport, tw[0], tw[1],
            )  # fmt: skip
        if err == OK and not all_finite(xw, d + 2 * new):
            err = NOT_FINITE
        if err != OK:
            for j in range(D):
                st[j] = UNUSED
                ns[j] = math.nan
            error[b] = err
            continue
        # Commit: nothing above wrote the state.
        if transport:
            transport_in_place(Pb, tw[0], tw[1], d)
        if r > 0:
            apply_factors(Pb, U, r, d)
        commit_new_landmarks(
            xb, Pb, n[b], slot_of, slot_to_id[b], fb, xw, d, C, small[SMALL_S], new, ib, k, st
        )  # fmt: skip
        n[b] += new
        n_rejected[b] += rejected
    return True


@borrowing_kernel
def update_one(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    id_to_slot: np.ndarray,
    slot_to_id: np.ndarray,
    n_rejected: np.ndarray,
    first: np.ndarray,
    params: np.ndarray,
    modes: np.ndarray,
    counts: np.ndarray,
    mask: np.ndarray,
    error: np.ndarray,
    work: np.ndarray,
    z: np.ndarray,
    ids: np.ndarray,
    status: np.ndarray,
    nis: np.ndarray,
    nearest: np.ndarray,
) -> int:
    """:func:`update` of a batch of one (the state arrays as there, B = 1) with its k
    observations unbatched: ``z`` (k, 2), ``ids``, ``status``, ``nis`` and ``nearest``
    (k,), last, so that a caller can bind the arrays before them; ``counts[0]`` is set
    to k. With known correspondences ``nearest`` is set to NaN, else left as the
    association wrote it. Returns the error code, ``error[0]``. What
    :class:`~slam_env.ekf.EKFSLAM` calls: the views of a batch of one are taken here,
    where they cost nothing, not in Python."""
    k = z.shape[0]
    counts[0] = k
    if modes[0, ASSOCIATION] == KNOWN:
        for j in range(k):
            nearest[j] = math.nan
    # z[None], not z.reshape((1, k, 2)): the same view, without numba's call into its
    # reshape helper (about 230 instructions a call).
    update(
        x, P, n, id_to_slot, slot_to_id, n_rejected, first, params, modes,
        z[None], ids[None], counts, mask, status[None], nis[None], error, work,
    )  # fmt: skip
    return error[0]
