"""Data association for B filters: which landmark of each filter's map each observation
of a scan is of, when the sensor reports no IDs.

Each world's observations ``z[b, :counts[b]]`` are compared with the landmarks of its
belief before the update (the mean ``x[b]``, covariance ``P[b]``, ``n[b]`` landmarks):
for observation j and landmark i, the innovation ``ν = z_j − h(x, m_i)``, its covariance
``S = H P Hᵀ + Q`` and the squared Mahalanobis distance ``D²_ji = νᵀ S⁻¹ ν``.

* ``NEAREST_NEIGHBOR`` (individual compatibility): the pairs with ``D² ≤ MATCH_GATE``
  are taken in increasing ``D²``, each observation and each landmark at most once.
* ``JCBB`` (Joint Compatibility Branch and Bound, Neira & Tardós 2001): the hypothesis
  (an individually compatible landmark or none for each observation, no landmark
  twice) with the most pairings whose stacked innovation passes the joint χ² test
  ``ν_Hᵀ S_H⁻¹ ν_H ≤ joint_gates[m]`` (2m degrees of freedom for m pairings, S_H with
  the cross-covariances of the pairings through the shared pose and landmarks); among
  equals, the smallest joint NIS. A depth-first search over the observations in
  order, pruned when the pairings left cannot beat the best found, and stopped after
  :data:`MAX_NODES` hypotheses (the best so far is kept). S_H's Cholesky factor grows
  by two rows per pairing and is reused down the branch; a hypothesis holds at most
  :data:`MAX_PAIRINGS` pairings (what keeps a scan's search within about a second).

Wide pairings (JCBB, with ``WIDE_SCANS`` > 1). A pairing is *wide* when its
innovation covariance S spans more than :data:`WIDE_RATIO` times the area of the
sensor's own noise Q (``det S > WIDE_RATIO² det Q``): the pose is then so uncertain
relative to that landmark (a loop closing) that an unmapped landmark near where it is
expected fits as well as the landmark itself, and one wrong pairing drags pose and map
so far that the filter never recovers. So a wide pairing is withdrawn (the observation
is then treated as paired with nothing) unless it is confirmed:

* it is withdrawn outright where another observation of the scan is also within
  ``MATCH_GATE`` of its landmark (two candidates for one landmark: ambiguous);
* otherwise the world follows one landmark (the one it followed last scan if it is
  among the scan's wide pairings, else the one of smallest D²), and commits its
  pairing once that landmark has had a wide pairing in ``WIDE_SCANS`` consecutive
  scans; the other wide pairings of the scan wait. The scans before are lost, the
  price of not mistaking a new landmark for a mapped one it hides or stands beside.

Then, in both: an observation paired with no landmark starts a new one if no landmark
lies within the wider ``NEW_GATE`` of it (``min_i D²_ji > NEW_GATE``) and the state has
room; otherwise it is discarded (ambiguous: near a landmark, but not compatible, or
wanted by another observation). The filter owns the identities: a landmark's ID is its
slot, so a new one gets the next free slot, in the order of the observations.

Clutter (detections of nothing) would start a landmark each time. With ``SIGHTINGS``
= 2 a new landmark needs a second sighting: a first one is held as *tentative* (its
world position from the pose estimate, and that position's covariance from the
measurement noise alone, ``W Q Wᵀ``), and a later observation outside every
landmark's ``NEW_GATE`` that lies within ``MATCH_GATE`` of a tentative one (the χ²
distance of the two positions over the sum of their covariances) starts the landmark,
from that observation. A tentative sighting lapses after :data:`CONFIRM_WINDOW`
updates; clutter, scattered at random, is almost never confirmed.

Output ``assigned[b, j]``: the ID the update (:func:`slam_env.kernels.ekf.filter.update`)
should use for observation j: a landmark's ID, a new ID, ``DISCARD_ID`` or
``TENTATIVE_ID``.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.compiling import kernel
from slam_env.kernels.base.models import (
    innovation,
    inverse,
    inverse_jacobian,
    jacobian,
    observe,
    singular,
)
from slam_env.kernels.ekf.codes import (
    ASSOCIATION,
    DISCARD_ID,
    JCBB,
    MATCH_GATE,
    MEASUREMENT,
    NEW_GATE,
    Q00,
    Q01,
    Q11,
    SIGHTINGS,
    TENTATIVE_ID,
    WIDE_SCANS,
)
from slam_env.kernels.ekf.filter import largest_count

MAX_NODES = 20_000  # hypotheses JCBB examines in one scan, at most
# Pairings a JCBB hypothesis holds, at most. A node at m pairings extends S_H's factor
# in ~4m² multiply-adds (the forward substitution of its 2m rows), so a scan costs up
# to MAX_NODES · 4m²: 3.3e8 at 64 (~0.3 s; the hardest scans of benchmarks/bench_jcbb
# take 0.13 s), 1.8e10 at the 480 pairings of a ring of landmarks in view (17 s). The
# filter and the budget refuse a scan or an env that could need more
# (slam_env.ekf.checks.jcbb_pairings); the kernel never pairs more.
MAX_PAIRINGS = 64
CONFIRM_WINDOW = 5  # updates a tentative sighting waits for its confirmation
# Columns of a tentative sighting: world position, its covariance, its age in updates
# (negative: the row is free).
PX, PY, C00, C01, C11, AGE, TENTATIVE_WIDTH = 0, 1, 2, 3, 4, 5, 6
TENTATIVE_ROWS = 16  # tentative sightings a filter holds at once (the oldest gives way)
# The table a filter keeps between updates: its tentative sightings, then one row for
# the wide pairing it follows (the landmark in PX, the scans followed in AGE).
HOLD_ROW = TENTATIVE_ROWS
HELD_ROWS = TENTATIVE_ROWS + 1
WIDE_RATIO = 10.0  # a pairing is wide when det S > WIDE_RATIO² det Q
_WIDE = -2  # out[j] = _WIDE - i marks observation j's wide pairing with landmark i

# Columns of a pairing's scratch row: H (2×5, row major), ν, the landmark's first row,
# the observation's index.
_H, _NU, _ROW, _OBS, _PAIR_WIDTH = 0, 10, 12, 13, 14


@kernel
def most_pairings(max_landmarks: int, max_obs: int) -> int:
    """The most pairings a hypothesis of JCBB holds: one landmark per observation, no
    landmark twice, and no more than :data:`MAX_PAIRINGS`."""
    return min(max_obs, max_landmarks, MAX_PAIRINGS)


@kernel
def association_workspace_sizes(max_landmarks: int, max_obs: int) -> tuple[int, int]:
    """Entries of the float64 and int64 workspaces :func:`associate` needs for up to
    ``max_landmarks`` landmarks and ``max_obs`` observations per world: the D² table
    and the candidates, per observation, and JCBB's factor of S_H, which grows with
    the square of the pairings (:func:`most_pairings`), not of the observations."""
    pairings = most_pairings(max_landmarks, max_obs)
    r = 2 * pairings
    table = max_obs * max_landmarks  # D² (floats) and the candidates (ints)
    floats = table + _PAIR_WIDTH + r * r + 3 * r + pairings * _PAIR_WIDTH + max_obs + 1
    ints = table + 2 * max_obs + max_landmarks + 4 * max_obs + 2
    return floats, ints


@kernel
def _linearise(
    model: int,
    x: np.ndarray,
    s: int,
    z0: float,
    z1: float,
    pair: np.ndarray,
) -> bool:
    """H (2×5 over the pose and the landmark at rows s, s+1) and ν of one observation
    of that landmark into ``pair``; False where h cannot be linearised there."""
    if singular(model, x[0], x[1], x[s], x[s + 1]):
        return False
    zh0, zh1 = observe(model, x[0], x[1], x[2], x[s], x[s + 1])
    h = jacobian(model, x[0], x[1], x[2], x[s], x[s + 1])
    for t in range(10):
        pair[_H + t] = h[t]
    nu0, nu1 = innovation(model, z0, z1, zh0, zh1)
    pair[_NU] = nu0
    pair[_NU + 1] = nu1
    pair[_ROW] = s
    total = nu0 + nu1
    for t in range(10):
        total += h[t]
    return math.isfinite(total)


@kernel
def _cross(P: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[float, float, float, float]:
    """The 2×2 block H_a P H_bᵀ between two linearised observations (each H touches
    the pose and its landmark's two rows only)."""
    ia = (0, 1, 2, int(a[_ROW]), int(a[_ROW]) + 1)
    ib = (0, 1, 2, int(b[_ROW]), int(b[_ROW]) + 1)
    s00 = 0.0
    s01 = 0.0
    s10 = 0.0
    s11 = 0.0
    for u in range(5):
        t0 = 0.0  # (P H_bᵀ)[ia[u], 0] and [.., 1]
        t1 = 0.0
        row = ia[u]
        for v in range(5):
            p = P[row, ib[v]]
            t0 += p * b[_H + v]
            t1 += p * b[_H + 5 + v]
        s00 += a[_H + u] * t0
        s01 += a[_H + u] * t1
        s10 += a[_H + 5 + u] * t0
        s11 += a[_H + 5 + u] * t1
    return s00, s01, s10, s11


@kernel
def _innovation_covariance(
    P: np.ndarray, pair: np.ndarray, params: np.ndarray
) -> tuple[float, float, float]:
    """S = H P Hᵀ + Q of one linearised observation, as (S00, S01, S11)."""
    s00, s01, _, s11 = _cross(P, pair, pair)
    return s00 + params[Q00], s01 + params[Q01], s11 + params[Q11]


@kernel
def _extend(
    P: np.ndarray,
    params: np.ndarray,
    pairs: np.ndarray,
    m: int,
    L: np.ndarray,
    y: np.ndarray,
    X: np.ndarray,
) -> float:
    """The joint NIS increment of adding pairing ``pairs[m]`` to the pairings
    ``pairs[:m]`` whose S_H = L Lᵀ (L: rows ``:2m``) and ``y = L⁻¹ ν_H``: S_H's new
    column block C (cross-covariances), X = L⁻¹ C, the Schur complement
    S_mm + Q − Xᵀ X = l lᵀ, and |l⁻¹ (ν_m − Xᵀ y)|². Writes rows 2m, 2m+1 of L and
    of y. ``inf`` where the Schur complement is not positive definite."""
    new = pairs[m]
    r = 2 * m
    for a in range(m):
        c00, c01, c10, c11 = _cross(P, pairs[a], new)
        X[2 * a, 0] = c00
        X[2 * a, 1] = c01
        X[2 * a + 1, 0] = c10
        X[2 * a + 1, 1] = c11
    for i in range(r):  # forward substitution, both columns
        for col in range(2):
            acc = X[i, col]
            for t in range(i):
                acc -= L[i, t] * X[t, col]
            X[i, col] = acc / L[i, i]
    s00, s01, s11 = _innovation_covariance(P, new, params)
    v0 = new[_NU]
    v1 = new[_NU + 1]
    for i in range(r):
        s00 -= X[i, 0] * X[i, 0]
        s01 -= X[i, 0] * X[i, 1]
        s11 -= X[i, 1] * X[i, 1]
        v0 -= X[i, 0] * y[i]
        v1 -= X[i, 1] * y[i]
    if not s00 > 0.0:
        return math.inf
    l00 = math.sqrt(s00)
    l10 = s01 / l00
    rest = s11 - l10 * l10
    if not rest > 0.0:
        return math.inf
    l11 = math.sqrt(rest)
    for i in range(r):
        L[r, i] = X[i, 0]
        L[r + 1, i] = X[i, 1]
    L[r, r] = l00
    L[r, r + 1] = 0.0
    L[r + 1, r] = l10
    L[r + 1, r + 1] = l11
    y[r] = v0 / l00
    y[r + 1] = (v1 - l10 * y[r]) / l11
    return y[r] * y[r] + y[r + 1] * y[r + 1]


@kernel
def _nearest_neighbour(
    d2: np.ndarray,
    cand: np.ndarray,
    n_cand: np.ndarray,
    k: int,
    assigned: np.ndarray,
    used: np.ndarray,
    head: np.ndarray,
) -> None:
    """Greedy pairing by increasing D² among the candidates (within the gate), each
    observation and landmark once (ties go to the lower observation, then the lower
    landmark). Each observation's candidates are sorted by D² (ties by landmark), so
    its best free one is the first not yet used: ``head[j]`` walks past the used ones,
    and a pairing costs O(k), not O(k·n)."""
    for j in range(k):
        head[j] = 0
    for _ in range(k):
        best = math.inf
        bj = -1
        for j in range(k):
            if assigned[j] >= 0:
                continue
            h = head[j]
            while h < n_cand[j] and used[cand[j, h]]:
                h += 1
            head[j] = h
            if h < n_cand[j] and (bj < 0 or d2[j, cand[j, h]] < best):
                best = d2[j, cand[j, h]]
                bj = j
        if bj < 0:
            return
        i = cand[bj, head[bj]]
        assigned[bj] = i
        used[i] = True


@kernel
def _jcbb(
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    k: int,
    model: int,
    params: np.ndarray,
    joint_gates: np.ndarray,
    cand: np.ndarray,
    n_cand: np.ndarray,
    assigned: np.ndarray,
    used: np.ndarray,
    fwork: np.ndarray,
    iwork: np.ndarray,
    o: int,
    io: int,
    D: int,
    most: int,
) -> None:
    """Joint Compatibility Branch and Bound over observations ``0..k-1`` with the
    candidates ``cand[j, :n_cand[j]]`` (in increasing D²); the best hypothesis into
    ``assigned`` (landmark or -1). Iterative depth-first search: level j tries each
    candidate of observation j, then none; L and y (S_H's factor and L⁻¹ν_H) grow by
    two rows per pairing and are overwritten on backtracking. The workspaces from
    ``o``/``io`` have room for D ≥ k observations and ``most`` pairings (a hypothesis
    holds no more)."""
    R = 2 * most
    L = fwork[o : o + R * R].reshape((R, R))
    o += R * R
    y = fwork[o : o + R]
    o += R
    X = fwork[o : o + 2 * R].reshape((R, 2))
    o += 2 * R
    pairs = fwork[o : o + most * _PAIR_WIDTH].reshape((most, _PAIR_WIDTH))
    o += most * _PAIR_WIDTH
    nis_at = fwork[o : o + D + 1]
    choice = iwork[io : io + D + 1]
    io += D + 1
    pairs_at = iwork[io : io + D + 1]
    io += D + 1
    pair_lm = iwork[io : io + most]
    io += most
    best_of = iwork[io : io + D]
    best_pairs = 0
    best_nis = math.inf
    for j in range(k):
        best_of[j] = -1
    j = 0
    choice[0] = 0
    pairs_at[0] = 0
    nis_at[0] = 0.0
    nodes = 0
    while j >= 0:
        m = pairs_at[j]
        nis = nis_at[j]
        if j == k:  # a complete hypothesis
            if m > best_pairs or (m == best_pairs and nis < best_nis):
                best_pairs = m
                best_nis = nis
                for t in range(k):
                    best_of[t] = -1
                for t in range(m):
                    best_of[int(pairs[t, _OBS])] = pair_lm[t]
            j -= 1
            if j >= 0 and pairs_at[j + 1] > pairs_at[j]:
                used[pair_lm[pairs_at[j]]] = False
            continue
        # Bound: even pairing every observation left cannot beat the best.
        if m + (k - j) < best_pairs or (m + (k - j) == best_pairs and nis >= best_nis):
            j -= 1
            if j >= 0 and pairs_at[j + 1] > pairs_at[j]:
                used[pair_lm[pairs_at[j]]] = False
            continue
        c = choice[j]
        choice[j] = c + 1
        if c < n_cand[j] and nodes < MAX_NODES and m < most:
            i = cand[j, c]
            if used[i]:
                continue
            nodes += 1
            if not _linearise(model, x, 3 + 2 * i, z[j, 0], z[j, 1], pairs[m]):
                continue
            pairs[m, _OBS] = j
            step = _extend(P, params, pairs, m, L, y, X)
            if not nis + step <= joint_gates[m + 1]:
                continue
            pair_lm[m] = i
            used[i] = True
            j += 1
            choice[j] = 0
            pairs_at[j] = m + 1
            nis_at[j] = nis + step
        elif c <= n_cand[j]:  # observation j paired with nothing
            if c < n_cand[j]:
                choice[j] = n_cand[j] + 1  # out of nodes or pairings: no more here
            j += 1
            choice[j] = 0
            pairs_at[j] = m
            nis_at[j] = nis
        else:  # every option of level j tried: back up
            j -= 1
            if j >= 0 and pairs_at[j + 1] > pairs_at[j]:
                used[pair_lm[pairs_at[j]]] = False
    for t in range(k):
        assigned[t] = best_of[t]


@kernel
def _wide(
    model: int,
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    i: int,
    params: np.ndarray,
    pair: np.ndarray,
) -> bool:
    """Whether pairing observation ``z`` (2,) with landmark ``i`` is wide: its
    innovation covariance S spans more than :data:`WIDE_RATIO` times the area of the
    sensor's own noise Q (det S > WIDE_RATIO² det Q)."""
    if not _linearise(model, x, 3 + 2 * i, z[0], z[1], pair):
        return False
    s00, s01, s11 = _innovation_covariance(P, pair, params)
    det_q = params[Q00] * params[Q11] - params[Q01] * params[Q01]
    return s00 * s11 - s01 * s01 > WIDE_RATIO * WIDE_RATIO * det_q


@kernel
def _hold_wide_pairings(
    model: int,
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    k: int,
    params: np.ndarray,
    out: np.ndarray,
    pair: np.ndarray,
    d2: np.ndarray,
    hold: np.ndarray,
) -> None:
    """Withdraw (``out[j] = -1``) the wide pairings of JCBB's hypothesis ``out`` that
    are not yet confirmed (see the module's docstring, "Wide pairings"); ``hold`` is
    the world's hold row (the landmark followed in :data:`PX`, the consecutive scans
    it was followed in :data:`AGE`, negative for none), updated in place."""
    tracked = int(hold[PX]) if hold[AGE] > 0.0 else -1
    seen = False
    best = -1  # the wide pairing of smallest D², followed if the tracked one is absent
    for j in range(k):
        i = out[j]
        if i < 0 or not _wide(model, x, P, z[j], i, params, pair):
            continue
        out[j] = -1
        rival = False
        for t in range(k):
            rival = rival or (t != j and d2[t, i] <= params[MATCH_GATE])
        if rival:  # another observation of the scan fits that landmark too
            continue
        out[j] = _WIDE - i  # marked: decided below
        seen = seen or i == tracked
        if best < 0 or d2[j, i] < d2[best, _WIDE - out[best]]:
            best = j
    if best < 0:
        hold[AGE] = -1.0
        return
    if seen:
        hold[AGE] += 1.0
    else:
        tracked = _WIDE - out[best]
        hold[PX] = tracked
        hold[AGE] = 1.0
    commit = hold[AGE] >= params[WIDE_SCANS]
    if commit:
        hold[AGE] = -1.0
    for j in range(k):
        if out[j] <= _WIDE:
            i = _WIDE - out[j]
            out[j] = i if commit and i == tracked else -1


@kernel
def _confirm(
    model: int,
    x: np.ndarray,
    z0: float,
    z1: float,
    params: np.ndarray,
    held: np.ndarray,
) -> bool:
    """A sighting outside every landmark's new-landmark gate: True where it confirms
    a tentative one in ``held`` (T, 6) (which is then freed), False where it is held
    as tentative itself (in a free row, or over the oldest)."""
    px, py = inverse(model, x[0], x[1], x[2], z0, z1)
    lw = inverse_jacobian(model, x[2], z0, z1)
    w00, w01, w10, w11 = lw[2], lw[3], lw[4], lw[5]
    q00, q01, q11 = params[Q00], params[Q01], params[Q11]
    t00 = w00 * q00 + w01 * q01  # W Q
    t01 = w00 * q01 + w01 * q11
    t10 = w10 * q00 + w11 * q01
    t11 = w10 * q01 + w11 * q11
    c00 = t00 * w00 + t01 * w01  # W Q Wᵀ
    c01 = t00 * w10 + t01 * w11
    c11 = t10 * w10 + t11 * w11
    best = params[MATCH_GATE]
    found = -1
    free = -1
    oldest = 0
    for t in range(held.shape[0]):
        age = held[t, AGE]
        if age < 0.0:
            free = t if free < 0 else free
            continue
        oldest = t if age > held[oldest, AGE] else oldest
        if age < 1.0:
            continue  # held in this very scan: another observation of it cannot confirm it
        dx = px - held[t, PX]
        dy = py - held[t, PY]
        s00 = c00 + held[t, C00]
        s01 = c01 + held[t, C01]
        s11 = c11 + held[t, C11]
        det = s00 * s11 - s01 * s01
        if not det > 0.0:
            continue
        d2 = (s11 * dx * dx - 2.0 * s01 * dx * dy + s00 * dy * dy) / det
        if d2 <= best:
            best = d2
            found = t
    if found >= 0:
        held[found, AGE] = -1.0
        return True
    row = free if free >= 0 else oldest
    held[row, PX] = px
    held[row, PY] = py
    held[row, C00] = c00
    held[row, C01] = c01
    held[row, C11] = c11
    held[row, AGE] = 0.0
    return False


@kernel
def associate(
    x: np.ndarray,
    P: np.ndarray,
    n: np.ndarray,
    params: np.ndarray,
    modes: np.ndarray,
    joint_gates: np.ndarray,
    z: np.ndarray,
    counts: np.ndarray,
    mask: np.ndarray,
    assigned: np.ndarray,
    d2_min: np.ndarray,
    tentative: np.ndarray,
    held: np.ndarray,
    fwork: np.ndarray,
    iwork: np.ndarray,
) -> bool:
    """Associate the first ``counts[b]`` observations ``z[b]`` ((B, D, 2)) of every
    world with ``mask[b]`` (see the module's docstring) into ``assigned[b]`` ((B, D)
    int64, -1 past the count and in the worlds not touched); ``d2_min[b, j]`` gets the
    smallest D² of observation j over the world's landmarks (``inf`` with none).
    ``joint_gates[m]``: the joint χ² threshold for m pairings (length ≥ D + 1).
    ``tentative`` (B, :data:`HELD_ROWS`, 6): each world's tentative sightings and its
    followed wide pairing (row :data:`HOLD_ROW`), not written; the worlds associated
    get them after this update in ``held`` (same shape), for the
    caller to keep once the update has succeeded. The workspaces ``fwork``/``iwork``
    need :func:`association_workspace_sizes` ``(M, K)`` entries (M the landmark slots,
    K the largest count of the worlds associated); False, and nothing done, where they
    are smaller."""
    B = x.shape[0]
    M = (x.shape[1] - 3) // 2
    D = largest_count(counts, mask, z.shape[1])
    floats, ints = association_workspace_sizes(M, D)
    if fwork.shape[0] < floats or iwork.shape[0] < ints:
        return False
    # The workspaces: D² and the candidates of each observation, one pairing's scratch,
    # the landmarks paired so far, then JCBB's own (see _jcbb).
    table = D * M
    d2 = fwork[:table].reshape((D, M))
    pair = fwork[table : table + _PAIR_WIDTH]
    cand = iwork[:table].reshape((D, M))
    n_cand = iwork[table : table + D]
    head = iwork[table + D : table + 2 * D]
    used = iwork[table + 2 * D : table + 2 * D + M]
    o = table + _PAIR_WIDTH
    io = table + 2 * D + M
    most = most_pairings(M, D)
    for b in range(B):
        for j in range(z.shape[1]):
            assigned[b, j] = -1
            d2_min[b, j] = math.inf
        if not mask[b]:
            continue
        k = min(max(counts[b], 0), D)
        nb = n[b]
        xb = x[b]
        Pb = P[b]
        pb = params[b]
        model = modes[b, MEASUREMENT]
        gate = pb[MATCH_GATE]
        for j in range(k):
            n_cand[j] = 0
            for i in range(nb):
                value = math.inf
                if _linearise(model, xb, 3 + 2 * i, z[b, j, 0], z[b, j, 1], pair):
                    # D² = |l⁻¹ν| with S = H P Hᵀ + Q = l lᵀ (2×2)
                    s00, s01, s11 = _innovation_covariance(Pb, pair, pb)
                    if s00 > 0.0:
                        l00 = math.sqrt(s00)
                        l10 = s01 / l00
                        rest = s11 - l10 * l10
                        if rest > 0.0:
                            w0 = pair[_NU] / l00
                            w1 = (pair[_NU + 1] - l10 * w0) / math.sqrt(rest)
                            value = w0 * w0 + w1 * w1
                d2[j, i] = value
                d2_min[b, j] = min(d2_min[b, j], value)
                if value <= gate:  # insert into the candidates, kept sorted by D²
                    t = n_cand[j]
                    while t > 0 and d2[j, cand[j, t - 1]] > value:
                        cand[j, t] = cand[j, t - 1]
                        t -= 1
                    cand[j, t] = i
                    n_cand[j] += 1
        for i in range(nb):
            used[i] = False
        out = assigned[b]
        if modes[b, ASSOCIATION] == JCBB:
            _jcbb(
                xb,
                Pb,
                z[b],
                k,
                model,
                pb,
                joint_gates,
                cand,
                n_cand,
                out,
                used,
                fwork,
                iwork,
                o,
                io,
                D,
                most,
            )
        else:
            _nearest_neighbour(d2, cand, n_cand, k, out, used, head)
        # New landmarks: at once, or on a second sighting.
        confirm = pb[SIGHTINGS] > 1.0
        hb = held[b]
        for t in range(hb.shape[0]):
            for c in range(TENTATIVE_WIDTH):
                hb[t, c] = tentative[b, t, c]
        if modes[b, ASSOCIATION] == JCBB and pb[WIDE_SCANS] > 1.0:
            _hold_wide_pairings(model, xb, Pb, z[b], k, pb, out, pair, d2, hb[HOLD_ROW])
        for t in range(TENTATIVE_ROWS):
            if confirm and hb[t, AGE] >= 0.0:
                hb[t, AGE] += 1.0
                if hb[t, AGE] > CONFIRM_WINDOW:
                    hb[t, AGE] = -1.0
        slot = nb
        for j in range(k):
            if out[j] >= 0:
                continue
            out[j] = DISCARD_ID
            if not (d2_min[b, j] > pb[NEW_GATE] and slot < M):
                continue
            if confirm and not _confirm(model, xb, z[b, j, 0], z[b, j, 1], pb, hb[:TENTATIVE_ROWS]):
                out[j] = TENTATIVE_ID
                continue
            out[j] = slot
            slot += 1
    return True
