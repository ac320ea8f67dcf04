"""One correction of B filters in one call: where the filters associate, the
association first (:mod:`slam_env.kernels.ekf.association`), then the update
(:func:`slam_env.kernels.ekf.filter.update`), then the tentative sightings of the worlds whose
update succeeded. Its workspaces are checked first, so that a refused call changes
nothing and can be made again once they have grown."""

from __future__ import annotations

import numpy as np

from slam_env.kernels.base.compiling import kernel
from slam_env.kernels.ekf.association import associate, association_workspace_sizes
from slam_env.kernels.ekf.filter import largest_count, update, update_workspace_size


def correction_workspaces(
    dmax: int, max_landmarks: int, max_obs: int, associates: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Workspaces of :func:`correct` for states of ``dmax`` rows, ``max_landmarks``
    slots and up to ``max_obs`` observations per world: the update's float64 scratch,
    then the association's float64 and int64 ones (empty where the filters do not
    associate)."""
    floats, ints = association_workspace_sizes(max_landmarks, max_obs) if associates else (0, 0)
    return (
        np.empty(update_workspace_size(dmax, max_obs)),
        np.empty(floats),
        np.empty(ints, dtype=np.int64),
    )


@kernel
def workspaces_fit(
    dmax: int, counts: np.ndarray, mask: np.ndarray, D: int, workspaces: tuple, associates: bool
) -> bool:
    """Whether ``workspaces`` (the update's float64 scratch, then the association's
    float64 and int64 ones) hold a correction of the worlds of ``mask`` with their
    ``counts`` (at most D) observations, for states of ``dmax`` rows."""
    work, fwork, iwork = workspaces
    K = largest_count(counts, mask, D)
    if work.shape[0] < update_workspace_size(dmax, K):
        return False
    if associates:
        floats, ints = association_workspace_sizes((dmax - 3) // 2, K)
        return fwork.shape[0] >= floats and iwork.shape[0] >= ints
    return True


@kernel
def correct(
    state: tuple,
    config: tuple,
    io: tuple,
    mask: np.ndarray,
    workspaces: tuple,
    associates: bool,
) -> bool:
    """Correct every world of ``mask`` with its first ``counts[b]`` observations.

    ``state``: ``(x, P, n, id_to_slot, slot_to_id, n_rejected, first, tentative)`` as in
    :class:`slam_env.ekf.batch.FilterBatch`; ``config``: ``(params, modes,
    joint_gates)``; ``io``: ``(z, ids, counts, assigned, nearest, held, status, nis,
    error)``, the inputs and what :func:`~slam_env.kernels.ekf.association.associate` and
    :func:`~slam_env.kernels.ekf.filter.update` write; ``workspaces`` as in
    :func:`workspaces_fit`. Where ``associates``, the filters choose the landmarks
    (``assigned``, each observation's smallest D² in ``nearest``) and ``ids`` is not
    read. Returns False, with nothing changed, where the workspaces are too small."""
    x, P, n, id_to_slot, slot_to_id, n_rejected, first, tentative = state
    params, modes, joint_gates = config
    z, ids, counts, assigned, nearest, held, status, nis, error = io
    work, fwork, iwork = workspaces
    if not workspaces_fit(x.shape[1], counts, mask, z.shape[1], workspaces, associates):
        return False
    used = ids
    if associates:
        associate(
            x, P, n, params, modes, joint_gates, z, counts, mask, assigned, nearest, tentative,
            held, fwork, iwork,
        )  # fmt: skip
        used = assigned
    update(
        x, P, n, id_to_slot, slot_to_id, n_rejected, first, params, modes, z, used, counts,
        mask, status, nis, error, work,
    )  # fmt: skip
    if associates:  # a sighting is kept only once its update has succeeded
        for b in range(x.shape[0]):
            if mask[b] and error[b] == 0:
                for t in range(held.shape[1]):  # loops: numba's slice copy may allocate
                    for c in range(held.shape[2]):
                        tentative[b, t, c] = held[b, t, c]
    return True
