"""B smoothing beliefs that follow a :class:`~slam_env.ekf.batch.FilterBatch`: the
smoothing belief of ``ActiveSLAM-v0``'s sub-envs (``belief="isam2"``).

The batch's EKF state holds each sub-env's smoothing belief as a Gaussian (the
smoother's mean and joint marginal). A step runs the filters' own step on it first:
the prediction, the gate and, where the filters associate, NN or JCBB, all against
the smoother's marginal, and the association's scores. :meth:`SmootherBatch.follow`
then hands each smoother the odometry and the observations the filter step used
(corrected or initialised, with the landmarks it gave them) and writes its new mean
and joint marginal back over the filter's. So the observation, the entropy, the
reward, the diagnostics, the pictures and every agent read the smoothing belief
through the same arrays as the filter's, and the association is the filter's, made
against the smoother's marginal.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from slam_env.ekf.batch import FilterBatch
from slam_env.ekf.filter import EKFSLAM
from slam_env.ekf.results import CORRECTED, INITIALISED
from slam_env.smoothing.isam2 import ISAM2SLAM

__all__ = ["SmootherBatch", "smoother_like"]


def smoother_like(template: EKFSLAM, **options: Any) -> ISAM2SLAM:
    """An :class:`ISAM2SLAM` with ``template``'s models, noise and landmark slots, and
    the smoothing ``options`` (``relinearize_threshold``, ``relinearize_skip``,
    ``keyframes``, ``window``)."""
    c = template._config
    return ISAM2SLAM(
        motion_model=c.motion_model,
        measurement_model=c.measurement_model,
        alphas=c.alphas,
        control_noise=c.control_noise,
        measurement_cov=c.measurement_cov,
        max_landmarks=c.max_landmarks,
        initial_pose_cov=template._initial_pose_cov,
        **options,
    )


class SmootherBatch:
    """One :class:`ISAM2SLAM` per filter of a :class:`FilterBatch`, each made by
    :func:`smoother_like` from the batch's template with ``options``; ``max_updates``:
    the iSAM2 updates each may hold in an episode (the env's share of the memory
    budget, :func:`slam_env.budget.smoother_updates`)."""

    def __init__(
        self,
        filters: FilterBatch,
        max_updates: int,
        **options: Any,
    ) -> None:
        b = filters.x.shape[0]
        first = smoother_like(filters.template, **options)
        self.smoothers = [first] + [first.copy() for _ in range(b - 1)]
        self.max_updates = max_updates

    def check_room(self, stepping: np.ndarray) -> None:
        """``RuntimeError`` (nothing changed) where a stepping smoother has recorded
        :attr:`max_updates` updates this episode."""
        for b in np.flatnonzero(stepping).tolist():
            held = self.smoothers[b].n_updates
            if held >= self.max_updates:
                raise RuntimeError(
                    f"the smoothing belief of sub-env {b} holds {held:,} "
                    "updates this episode, its share of the memory budget "
                    "(slam_env.budget.smoother_updates): end episodes sooner "
                    "(max_episode_steps) or give smoothing_keyframes"
                )

    def __getitem__(self, index: int) -> ISAM2SLAM:
        return self.smoothers[index]

    def reset(self, index: int, pose: Any, filters: FilterBatch) -> None:
        """Smoother ``index`` restarted at ``pose`` (with the filter's initial
        covariance), its belief written over filter ``index``'s."""
        smoother = self.smoothers[index]
        smoother.reset(initial_pose=pose)
        self._write(index, filters)

    def follow(
        self, filters: FilterBatch, touched: np.ndarray, stepping: np.ndarray, failed: np.ndarray
    ) -> None:
        """After the filters' step on the smoothing beliefs: each ``touched``
        smoother's prediction (the ``stepping`` ones) and update with what that step
        used, its belief written back over the filter's; a smoother whose update GTSAM
        refuses keeps its state and sets ``failed``."""
        associates = filters.associates
        for b in np.flatnonzero(touched).tolist():
            smoother = self.smoothers[b]
            if stepping[b]:
                smoother.predict(filters.u[b])
            # What the filter step used (nothing where it failed): one iSAM2 update
            # a step, with or without detections, as the filter has.
            k = int(filters.counts[b]) if filters.error[b] == 0 else 0
            status = filters.status[b, :k]
            used = (status == CORRECTED) | (status == INITIALISED)
            ids = (filters.assigned if associates else filters.ids)[b, :k][used]
            # New landmarks in the order of their IDs: an associating filter's IDs
            # are its slots, which the smoother's must then be too.
            order = np.argsort(ids, kind="stable")
            try:
                smoother.update(filters.z[b, :k][used][order], ids[order])
            except FloatingPointError:
                failed[b] = True
            self._write(b, filters)

    def _write(self, index: int, filters: FilterBatch) -> None:
        """Smoother ``index``'s mean, joint marginal and landmark slots over filter
        ``index``'s state."""
        smoother = self.smoothers[index]
        d, n = smoother.dim, smoother.n_landmarks
        filters.x[index, :d] = smoother.mean
        filters.P[index, :d, :d] = smoother.cov
        filters.n[index] = n
        filters.slot_to_id[index, :n] = smoother.state_to_id
        filters.slot_to_id[index, n:] = -1
        filters.id_to_slot[index] = smoother.id_to_state
