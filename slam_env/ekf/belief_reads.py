"""The reads of an :class:`~slam_env.ekf.filter.EKFSLAM`'s belief: its mean and
covariance, the pose, the landmarks and the ID maps, as copies or read-only views.

:class:`BeliefReads` is the filter's base class: it reads the state the filter keeps
(a batch of one, see :mod:`slam_env.ekf.filter`) and writes nothing. The names it reads
are the filter's: ``_xb``, ``_Pb``, ``_nb``, ``_slot_to_id_b`` and ``_n_rejected_b``
(the batched arrays), ``_x``, ``_P``, ``_slot_to_id``, ``_id_to_slot`` (their row 0)
and ``_N`` (max_landmarks).
"""

from __future__ import annotations

import numpy as np

from slam_env.ekf import checks
from slam_env.kernels.belief.belief_state import BeliefBatch

__all__ = ["BeliefReads"]


class BeliefReads:
    """What an EKF-SLAM filter's belief reads: see the module's docstring."""

    _x: np.ndarray
    _P: np.ndarray
    _xb: np.ndarray
    _Pb: np.ndarray
    _nb: np.ndarray
    _slot_to_id: np.ndarray
    _slot_to_id_b: np.ndarray
    _id_to_slot: np.ndarray
    _n_rejected_b: np.ndarray
    _N: int

    @property
    def n_landmarks(self) -> int:
        """n, the number of landmarks in the state."""
        return int(self._nb[0])

    @property
    def n_rejected(self) -> int:
        """Observations rejected by the gate since the last reset."""
        return int(self._n_rejected_b[0])

    @property
    def dim(self) -> int:
        """3 + 2n, the length of the live state."""
        return 3 + 2 * int(self._nb[0])

    @property
    def mean(self) -> np.ndarray:
        """x: (3+2n,) the state mean [x, y, θ, m_0x, m_0y, …] (a copy; θ in [−π, π))."""
        return self._x[: self.dim].copy()

    @property
    def cov(self) -> np.ndarray:
        """P: (3+2n, 3+2n) the state covariance (a copy)."""
        d = self.dim
        return self._P[:d, :d].copy()

    def belief_views(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Read-only *views* of the live ``mean``, ``cov`` and ``state_to_id``, for a
        caller that reads the belief every step (the gym wrapper) and need not pay
        for copies. They are valid until the next ``predict``/``update``/``reset``."""
        n = int(self._nb[0])
        d = 3 + 2 * n
        views = self._x[:d], self._P[:d, :d], self._slot_to_id[:n]
        for view in views:
            view.flags.writeable = False
        return views

    def belief_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Read-only views of the whole batched state as the kernels of
        :mod:`slam_env.kernels` take it, a batch of one: ``x (1, dmax)``,
        ``P (1, dmax, dmax)``, ``n (1,)`` and ``slot_to_id (1, max_landmarks)``
        (``dmax = 3 + 2·max_landmarks``; world 0's live part is ``3 + 2·n[0]``). They
        follow the filter (the same storage for its whole life)."""
        views = (
            self._xb.view(),
            self._Pb.view(),
            self._nb.view(),
            self._slot_to_id_b.view(),
        )
        for view in views:
            view.flags.writeable = False
        return views

    def belief_batch(self) -> BeliefBatch:
        """The live belief as the belief kernels take it: the storage itself, which is
        a batch of one (nothing copied). Ask again after the filter is unpickled or
        copied (that one has storage of its own)."""
        return BeliefBatch(self._xb, self._Pb, self._nb, self._slot_to_id_b)

    @property
    def pose(self) -> np.ndarray:
        """(3,) the pose mean (a copy)."""
        return self._x[:3].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        """(3, 3) the pose covariance (a copy)."""
        return self._P[:3, :3].copy()

    @property
    def state_to_id(self) -> np.ndarray:
        """(n,) int64: the landmark ID of each slot, in state order (a copy)."""
        return self._slot_to_id[: self.n_landmarks].copy()

    @property
    def id_to_state(self) -> np.ndarray:
        """(max_landmarks,) int64: the slot of each landmark ID, -1 if not in the
        state (a copy). Slot i is rows 3+2i, 4+2i of the mean and covariance."""
        return self._id_to_slot.copy()

    def landmark(self, landmark_id: int) -> tuple[np.ndarray, np.ndarray]:
        """(mean (2,), cov (2, 2)) of one landmark; ``ValueError`` if it is unknown."""
        lid = checks.landmark_id(landmark_id)
        if not 0 <= lid < self._N or self._id_to_slot[lid] < 0:
            raise ValueError(f"landmark id {lid} is not in the state")
        s = 3 + 2 * int(self._id_to_slot[lid])
        return self._x[s : s + 2].copy(), self._P[s : s + 2, s : s + 2].copy()

    def landmark_means(self) -> np.ndarray:
        """(n, 2) landmark means in state order (a copy)."""
        n = self.n_landmarks
        return self._x[3 : 3 + 2 * n].reshape(n, 2).copy()

    def landmark_covs(self) -> np.ndarray:
        """(n, 2, 2) the landmarks' marginal covariances in state order (a copy)."""
        n = self.n_landmarks
        rs, cs = self._P.strides
        blocks = np.lib.stride_tricks.as_strided(
            self._P[3:, 3:], shape=(n, 2, 2), strides=(2 * (rs + cs), rs, cs), writeable=False
        )
        return blocks.copy()

    def landmark_pose_covs(self) -> np.ndarray:
        """(n, 2, 3) each landmark's cross-covariance with the pose, in state order."""
        n = self.n_landmarks
        return self._P[3 : 3 + 2 * n, :3].reshape(n, 2, 3).copy()
