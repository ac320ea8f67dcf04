"""B EKF-SLAM filters of one configuration, stepped together: the filters of a native
vector env's sub-envs, as one batched state (:mod:`slam_env.kernels.ekf.filter`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from slam_env.ekf.chi2 import joint_gates
from slam_env.ekf.filter import EKFSLAM
from slam_env.kernels.ekf import association
from slam_env.kernels.ekf import filter as ekf
from slam_env.kernels.ekf.associated_update import correct, correction_workspaces


class FilterBatch:
    """The state of B filters configured as ``template`` (an :class:`EKFSLAM`, whose own
    state is not used): ``x (B, dmax)``, ``P (B, dmax, dmax)``, ``n``, ``id_to_slot``,
    ``slot_to_id``, ``n_rejected``, ``first`` and ``tentative``, laid out as the
    kernels take them, with the inputs and outputs of a step. :meth:`predict` and
    :meth:`update` step the filters whose mask is set, each atomically (a filter whose
    step fails keeps its state and gets an error code in :attr:`error`); :meth:`filter`
    is filter b as an :class:`EKFSLAM` over the same storage. The inputs are the
    caller's to fill and are not checked (a vector env's own stream is well-formed by
    construction).

    Args:
        num_filters: B.
        template: the configuration (models, noise, gate, correction, landmark slots).
        max_observations: D, the most observations of one update.
    """

    def __init__(self, num_filters: int, template: EKFSLAM, max_observations: int) -> None:
        self.template = template
        b, m, d = num_filters, template.max_landmarks, max_observations
        dmax = 3 + 2 * m
        self.x = np.zeros((b, dmax))
        self.P = np.zeros((b, dmax, dmax))
        self.n = np.zeros(b, dtype=np.int64)
        self.id_to_slot = np.full((b, m), -1, dtype=np.int64)
        self.slot_to_id = np.full((b, m), -1, dtype=np.int64)
        self.n_rejected = np.zeros(b, dtype=np.int64)
        self.first = np.zeros((b, dmax))
        self.tentative = np.full((b, association.HELD_ROWS, association.TENTATIVE_WIDTH), -1.0)
        self.params = np.repeat(template._params, b, axis=0)
        self.modes = np.repeat(template._modes, b, axis=0)
        # The inputs of a step (controls; observations, their IDs and counts), its
        # outputs (per observation, per filter) and the update's workspace.
        self.u = np.zeros((b, template._u.shape[1]))
        self.z = np.zeros((b, d, 2))
        self.ids = np.zeros((b, d), dtype=np.int64)
        self.counts = np.zeros(b, dtype=np.int64)
        self.status = np.zeros((b, d), dtype=np.int8)
        self.nis = np.zeros((b, d))
        self.error = np.zeros(b, dtype=np.int64)
        # Where the filters associate: the landmark each observation is given to (the
        # IDs the update uses), each one's smallest D², the association's gates and
        # the tentative sightings held until the update succeeds (placeholders, never
        # read, where they do not).
        self.associates = template.associates
        self.assigned = np.full((b, d), -1, dtype=np.int64)
        self.nearest = np.full((b, d), np.inf)
        self._joint_gates = (
            joint_gates(template.association_gates[0], d) if self.associates else np.zeros(1)
        )
        self._held = np.empty_like(self.tentative)
        # The workspaces grow with the most observations an update has had (a step
        # sees far fewer landmarks than the padded array has rows): a kernel that finds
        # its workspace too small refuses the call, changing nothing, and is called
        # again once it has grown (nothing to check on the common path).
        self._room = -1
        self._grow_workspaces(min(d, 8))
        self._views: dict[int, EKFSLAM] = {}

    def _grow_workspaces(self, max_obs: int) -> None:
        if max_obs > self._room:
            self._room = max_obs
            self.workspaces = correction_workspaces(
                self.x.shape[1], self.template.max_landmarks, max_obs, self.associates
            )

    def grow_for(self, mask: np.ndarray) -> None:
        """Grow the workspaces for the observations of the worlds of ``mask``."""
        self._grow_workspaces(min(int(self.counts[mask].max(initial=0)), self.z.shape[1]))

    def workspaces_of(self, rows: slice) -> tuple:
        """Workspaces of their own for the corrections of the filters ``rows`` in a
        thread of their own: as large as :attr:`workspaces`, or as the observations of
        those filters' :attr:`counts` need, if more."""
        needed = min(int(self.counts[rows].max(initial=0)), self.z.shape[1])
        return correction_workspaces(
            self.x.shape[1], self.template.max_landmarks, max(needed, self._room),
            self.associates,
        )  # fmt: skip

    @property
    def storage(self) -> tuple[np.ndarray, ...]:
        """The state arrays, in :attr:`EKFSLAM._STATE` order."""
        return (
            self.x, self.P, self.n, self.id_to_slot, self.slot_to_id, self.n_rejected,
            self.first, self.tentative,
        )  # fmt: skip

    def filter(self, index: int) -> EKFSLAM:
        """Filter ``index`` as an :class:`EKFSLAM` whose state is row ``index`` of this
        batch (a view: it follows the batch, and the batch what it does)."""
        view = self._views.get(index)
        if view is None:
            view = self.template._view_over(tuple(a[index : index + 1] for a in self.storage))
            self._views[index] = view
        return view

    def reset(self, index: int, pose: Any, pose_cov: Any = None) -> None:
        """Start filter ``index`` at ``pose`` with ``pose_cov`` (default the template's
        initial covariance), no landmarks, no rejections."""
        self.filter(index).reset(initial_pose=pose, initial_pose_cov=pose_cov)

    def predict(self, mask: np.ndarray) -> None:
        """Predict the filters of ``mask`` (B,) bool with their controls :attr:`u`."""
        ekf.predict(
            self.x, self.P, self.n, self.first, self.u, self.params, self.modes, mask, self.error
        )  # fmt: skip

    @property
    def config(self) -> tuple[np.ndarray, ...]:
        """``(params, modes, joint_gates)``, as
        :func:`slam_env.kernels.ekf.associated_update.correct` takes them."""
        return (self.params, self.modes, self._joint_gates)

    @property
    def correction_io(self) -> tuple[np.ndarray, ...]:
        """The inputs and outputs of a correction, in
        :func:`slam_env.kernels.ekf.associated_update.correct`'s order."""
        return (
            self.z, self.ids, self.counts, self.assigned, self.nearest, self._held,
            self.status, self.nis, self.error,
        )  # fmt: skip

    def update(self, mask: np.ndarray) -> None:
        """Update the filters of ``mask`` with their first :attr:`counts` observations
        :attr:`z` of landmarks :attr:`ids` (where the filters associate, of the
        landmarks they choose: :attr:`assigned`, each one's smallest D² in
        :attr:`nearest`); per observation :attr:`status` and :attr:`nis`."""
        args = (self.storage, self.config, self.correction_io, mask)
        if not correct(*args, self.workspaces, self.associates):
            self.grow_for(mask)
            correct(*args, self.workspaces, self.associates)

    # Pickling: the views are rebuilt on demand over the unpickled arrays.
    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_views": {}}
