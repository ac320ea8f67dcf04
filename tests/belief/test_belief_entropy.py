"""The belief entropy, against numpy's log-determinant of the full covariance with
every unseen landmark's uniform prior written out (issue 17).

The expected numbers are derived here from the definition, not from the wrapper's
code: H = ½ log det(2πe (Σ_full + 10⁻⁴ I)), Σ_full the (3 + 2M)² covariance over the
pose and all M landmark slots, an unseen slot holding an independent prior uniform
over the w × h arena (variances w²/12, h²/12).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.belief.entropy import ENTROPY_FLOOR
from slam_env.envs.landmarks import LandmarksEnv

WIDTH, HEIGHT, SLOTS = 20.0, 12.0, 7  # a non-square arena: width and height not swapped


def _wrapper(**options) -> EKFSLAMWrapper:
    env = LandmarksEnv(width=WIDTH, height=HEIGHT, n_landmarks=SLOTS, **options)
    return EKFSLAMWrapper(env)


def expected_entropy(cov: np.ndarray, slots: int, width: float, height: float) -> float:
    """½ log det(2πe (Σ_full + 10⁻⁴ I)) with the unseen slots' prior written out."""
    d = cov.shape[0]
    dim = 3 + 2 * slots
    full = np.zeros((dim, dim))
    full[:d, :d] = cov
    for row in range(d, dim, 2):
        full[row, row] = width**2 / 12.0  # var of U(0, w)
        full[row + 1, row + 1] = height**2 / 12.0
    sign, log_det = np.linalg.slogdet(2.0 * math.pi * math.e * (full + 1e-4 * np.eye(dim)))
    assert sign == 1.0
    return 0.5 * log_det


def _random_cov(rng: np.random.Generator, d: int, scale: float) -> np.ndarray:
    a = rng.normal(size=(d, d)) * scale
    return a @ a.T + 1e-3 * np.eye(d)


def test_the_floor_is_one_centimetre():
    assert ENTROPY_FLOOR == 1e-4  # m², rad²: the README's "uncertainty below 1 cm"


@pytest.mark.parametrize("known", range(SLOTS + 1))
def test_entropy_of_a_constructed_belief_matches_slogdet(known: int):
    rng = np.random.default_rng(known)
    wrapper = _wrapper()
    cov = _random_cov(rng, 3 + 2 * known, scale=0.3)
    expected = expected_entropy(cov, SLOTS, WIDTH, HEIGHT)
    assert wrapper.belief_entropy(cov) == pytest.approx(expected, rel=1e-12, abs=1e-10)


def test_an_exactly_known_pose_has_the_floor_as_its_uncertainty():
    wrapper = _wrapper()
    cov = np.zeros((3, 3))
    expected = expected_entropy(cov, SLOTS, WIDTH, HEIGHT)
    assert wrapper.belief_entropy(cov) == pytest.approx(expected, rel=1e-12)
    # By hand: three floored pose variances and SLOTS priors (each raised by the floor).
    by_hand = 0.5 * (
        (3 + 2 * SLOTS) * math.log(2 * math.pi * math.e)
        + 3 * math.log(1e-4)
        + SLOTS * (math.log(WIDTH**2 / 12 + 1e-4) + math.log(HEIGHT**2 / 12 + 1e-4))
    )
    assert wrapper.belief_entropy(cov) == pytest.approx(by_hand, rel=1e-12)


def test_the_entropy_does_not_modify_the_covariance_it_is_given():
    cov = _random_cov(np.random.default_rng(5), 7, scale=0.2)
    before = cov.copy()
    _wrapper().belief_entropy(cov)
    np.testing.assert_array_equal(cov, before)


def test_discovering_a_landmark_lowers_the_entropy_by_its_prior_less_its_estimate():
    """A landmark joining the state with an uncorrelated 2×2 block B replaces its
    slot's prior: H drops by ½ log(det(prior + floor) / det(B + floor))."""
    wrapper = _wrapper()
    pose = np.diag([0.01, 0.02, 0.003])
    block = np.array([[0.04, 0.01], [0.01, 0.05]])
    with_landmark = np.zeros((5, 5))
    with_landmark[:3, :3] = pose
    with_landmark[3:, 3:] = block
    drop = wrapper.belief_entropy(pose) - wrapper.belief_entropy(with_landmark)
    prior = (WIDTH**2 / 12 + 1e-4) * (HEIGHT**2 / 12 + 1e-4)
    assert drop == pytest.approx(0.5 * math.log(prior / np.linalg.det(block + 1e-4 * np.eye(2))))
    assert drop > 0


def test_a_slightly_indefinite_covariance_still_gets_a_finite_entropy():
    """Round-off can leave Σ + floor·I with an eigenvalue at or below zero; the entropy
    then clamps its eigenvalues (at 1e-300) rather than failing."""
    wrapper = _wrapper()
    q = np.linalg.qr(np.random.default_rng(2).normal(size=(5, 5)))[0]
    eig = np.array([0.5, 0.2, 0.1, 0.05, -3e-4])  # −3e-4 + 1e-4 < 0
    cov = q @ np.diag(eig) @ q.T
    cov = 0.5 * (cov + cov.T)
    shifted_eig = np.linalg.eigvalsh(cov + 1e-4 * np.eye(5))
    log_det = np.sum(np.log(np.maximum(shifted_eig, 1e-300)))
    prior = SLOTS - 1
    expected = 0.5 * (
        (3 + 2 * SLOTS) * math.log(2 * math.pi * math.e)
        + log_det
        + prior * (math.log(WIDTH**2 / 12 + 1e-4) + math.log(HEIGHT**2 / 12 + 1e-4))
    )
    assert wrapper.belief_entropy(cov) == pytest.approx(expected, rel=1e-9)


def test_entropy_in_info_is_that_of_the_filters_belief_along_a_run():
    env = gym.make(
        "slam_env/ActiveSLAM-v0", width=WIDTH, height=HEIGHT, n_landmarks=SLOTS, coverage=False
    )
    _, info = env.reset(seed=3)
    f = env.unwrapped.filter
    discoveries = 0
    for step in range(40):
        expected = expected_entropy(f.cov, SLOTS, WIDTH, HEIGHT)
        assert info["entropy"] == pytest.approx(expected, rel=1e-12), step
        known, entropy = info["landmarks_known"], info["entropy"]
        _, _, _, _, info = env.step(np.array([1.0, 0.35], dtype=np.float32))
        if info["landmarks_known"] > known:  # a slot's arena-wide prior replaced
            discoveries += 1
            assert info["entropy"] < entropy - 5.0
    assert discoveries == 2
