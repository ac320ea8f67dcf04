"""The belief entropy over all landmark slots: the number the information-gain reward
pays on, for one filter or B worlds at once (:mod:`slam_env.kernels.belief.entropy`)."""

from __future__ import annotations

import math

import numpy as np

from slam_env.belief import metrics
from slam_env.kernels.belief.belief_state import SINGLE
from slam_env.kernels.belief.entropy import belief_entropy, slots_entropy

# Covariance floor (m², rad²) of the entropy: uncertainty below 1 cm carries no
# information worth paying for, and it keeps the entropy finite for an exactly
# known start pose.
ENTROPY_FLOOR = 1e-4


def landmark_prior_variance(width: float, height: float) -> tuple[float, float]:
    """Variance of a landmark position uniform over the arena: the broad prior that an
    unseen landmark's slot carries in the belief entropy."""
    return width * width / 12.0, height * height / 12.0


class BeliefEntropy:
    """Entropy (nats) of beliefs over the pose and all ``max_landmarks`` slots: an
    unseen landmark's slot carries an independent prior, uniform over the arena in
    its first two moments, so discovering a landmark lowers the entropy and the
    dimension never changes. It is computed for Σ + ``ENTROPY_FLOOR``·I.

    The kernel factors each world's covariance; the rare world that round-off left
    not positive definite is finished here, its eigenvalues clamped at 1e-300
    (:func:`slam_env.belief.metrics.log_det_psd`).
    """

    def __init__(self, max_landmarks: int, width: float, height: float) -> None:
        self.max_landmarks = max_landmarks
        vx, vy = landmark_prior_variance(width, height)
        self.prior_log_det = math.log(vx + ENTROPY_FLOOR) + math.log(vy + ENTROPY_FLOOR)
        dim = 3 + 2 * max_landmarks
        self._scratch = np.empty((dim, dim))
        self._entropy = np.empty(SINGLE)
        self._ok = np.empty(SINGLE, dtype=np.bool_)

    def batch(
        self,
        P: np.ndarray,
        n: np.ndarray,
        out: np.ndarray,
        ok: np.ndarray,
        active: np.ndarray | None = None,
    ) -> None:
        """``out[b]``: the entropy of world b's belief (``P`` (B, dmax, dmax) float64
        with dmax ≤ 3 + 2·max_landmarks, ``n`` (B,) int64 landmarks in the state), for
        the worlds of ``active`` (B,) bool (default all); ``ok`` (B,) bool scratch."""
        active = np.ones(P.shape[0], dtype=np.bool_) if active is None else active
        if P.shape[1] > self._scratch.shape[0]:
            raise ValueError(
                f"a belief of {P.shape[1]} rows is more than {self.max_landmarks} landmarks"
            )
        belief_entropy(
            P, n, self.max_landmarks, ENTROPY_FLOOR, self.prior_log_det, self._scratch, out, ok,
            active,
        )  # fmt: skip
        if not ok[active].all():
            self.finish(P, n, out, ok, active)

    @property
    def kernel_args(self) -> tuple[int, float, float, np.ndarray]:
        """``(slots, floor, prior_log_det, scratch)``, the entropy kernel's settings."""
        return (self.max_landmarks, ENTROPY_FLOOR, self.prior_log_det, self._scratch)

    def kernel_args_of_a_thread(self) -> tuple[int, float, float, np.ndarray]:
        """:attr:`kernel_args` with scratch of their own, for a thread of their own."""
        return (self.max_landmarks, ENTROPY_FLOOR, self.prior_log_det, np.empty_like(self._scratch))

    def finish(
        self, P: np.ndarray, n: np.ndarray, out: np.ndarray, ok: np.ndarray, active: np.ndarray
    ) -> None:
        """``out[b]`` for the worlds of ``active`` that the kernel left (``ok[b]``
        False: Σ + floor·I not positive definite to round-off), from the eigenvalues."""
        for b in np.flatnonzero(active & ~ok).tolist():
            d = 3 + 2 * int(n[b])
            shifted = P[b, :d, :d] + ENTROPY_FLOOR * np.eye(d)
            live = metrics.log_det_psd(shifted, copy=False)
            out[b] = slots_entropy(live, int(n[b]), self.max_landmarks, self.prior_log_det)

    def __call__(self, cov: np.ndarray) -> float:
        """The entropy of one belief with covariance ``cov`` ((3 + 2n)², not modified)."""
        cov = np.ascontiguousarray(cov, dtype=np.float64)
        n = np.full(SINGLE, (cov.shape[0] - 3) // 2, dtype=np.int64)
        self.batch(cov[None], n, self._entropy, self._ok)
        return float(self._entropy[0])
