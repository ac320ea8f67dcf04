"""The invariant filter's kernels (:mod:`slam_env.kernels.ekf.invariant`) against dense
numpy: the retraction is exp(J_r⁻¹ δ) of references/invariant_ekf.py and carries the
factor rows; the transport is T P Tᵀ with T = I + w e_θᵀ, exactly symmetric; and its
check refuses what would overflow or is not finite."""

from __future__ import annotations

import numpy as np

from references import invariant_ekf as inv
from slam_env.kernels.ekf import codes
from slam_env.kernels.ekf import invariant as kernels


def random_state(rng: np.random.Generator, n: int = 4):
    d = 3 + 2 * n
    x = np.concatenate([rng.uniform(-5, 5, 2), [rng.uniform(-3, 3)], rng.uniform(-8, 8, 2 * n)])
    A = rng.normal(size=(d, d))
    return x, A @ A.T / d


def test_retract_is_the_exponential_map_of_the_invariant_step_and_carries_the_factors():
    rng = np.random.default_rng(0)
    for _ in range(20):
        x, _ = random_state(rng)
        d = x.size
        delta = rng.normal(size=d) * 0.3
        U = rng.normal(size=(4, d))
        expected_mean = inv.exp_retract(x, np.linalg.solve(inv.retraction_jacobian(x), delta))
        xw, step, Uw = x.copy(), delta.copy(), U.copy()
        kernels.retract(xw, step, d, Uw, 3)
        np.testing.assert_allclose(xw, expected_mean, atol=1e-12)
        dw = inv.rotation_direction(xw) - inv.rotation_direction(x)
        np.testing.assert_allclose(step, dw, atol=1e-12)
        np.testing.assert_allclose(Uw[:3], U[:3] + np.outer(U[:3, 2], dw), atol=1e-12)
        np.testing.assert_array_equal(Uw[3], U[3])  # only the rows asked for


def test_the_transport_is_T_P_T_transposed_and_exactly_symmetric():
    rng = np.random.default_rng(1)
    x0, P = random_state(rng)
    x = x0 + rng.normal(size=x0.size) * 0.2
    d = x.size
    w, c = np.empty(d), np.empty(d)
    kernels.fill_transport(x, x0, d, w)
    np.testing.assert_array_equal(w, inv.rotation_direction(x) - inv.rotation_direction(x0))
    assert kernels.transport_terms(P, w, c, d) == codes.OK
    T = np.eye(d)
    T[:, 2] += w
    carried = P.copy()
    kernels.transport_in_place(carried, w, c, d)
    np.testing.assert_allclose(carried, T @ P @ T.T, rtol=0, atol=1e-12)
    assert (carried == carried.T).all()


def test_the_transports_check_refuses_an_overflow_and_a_non_finite_term():
    rng = np.random.default_rng(2)
    _, P = random_state(rng)
    d = P.shape[0]
    c = np.empty(d)
    huge = np.zeros(d)
    huge[3] = 1e160  # w cᵀ's entries would pass 1e300
    assert kernels.transport_terms(P, huge, c, d) == codes.OVERFLOW
    large = np.zeros(d)
    large[3] = 1.3e150  # every w_i c_j within 1e300, but the carried variance
    unit = P / P[2, 2]  # P_33 + 2 w_3 c_3 ≈ P_θθ w_3² = 1.7e300 is not
    assert np.abs(large).max() * np.abs(unit[:, 2] + 0.5 * large).max() <= codes.COV_LIMIT
    assert kernels.transport_terms(unit, large, c, d) == codes.OVERFLOW
    bad = np.zeros(d)
    bad[4] = np.nan
    assert kernels.transport_terms(P, bad, c, d) == codes.NOT_FINITE
    assert kernels.transport_terms(P, np.zeros(d), c, d) == codes.OK
