"""What the raw step of B worlds senses and reports once their robots have moved, in
one kernel call (see :class:`slam_env.raw_core.RawCore`): the landmark scan, its
faults, the proximity scan and the raw observation. They chain the kernels of
:mod:`~slam_env.kernels.sensing`, :mod:`~slam_env.kernels.faults` and
:mod:`~slam_env.kernels.observe`; as one call, a batch of one pays numba's dispatch
once, and each array is passed once."""

from __future__ import annotations

import numpy as np

from slam_env.kernels import kernel
from slam_env.kernels.faults import corrupt_scans
from slam_env.kernels.observe import observe_raw
from slam_env.kernels.sensing import proximity_scan, sense_landmarks


@kernel
def sense_and_observe(
    worlds: tuple,
    geometry_fields: tuple,
    sensor_fields: tuple,
    uniforms: np.ndarray,
    scan_offset: int,
    touched: np.ndarray,
    detections: tuple,
    faults: tuple | None,
    stepping: np.ndarray,
    beams: tuple,
    readings: tuple,
    seen: np.ndarray,
    params_fields: tuple,
    out_fields: tuple,
) -> None:
    """Sense and observe each ``touched`` world.

    ``worlds``: ``(poses, landmarks, landmark_ids, id_order)`` of
    :class:`slam_env.world_batch.WorldBatch`; ``detections``: ``(z, ids, rows, count)``,
    what :func:`~slam_env.kernels.sensing.sense_landmarks` writes; ``faults``: None, or
    the :class:`~slam_env.kernels.faults.FaultParams` fields and the faults' offset in
    ``uniforms``, applied to the scans of the ``stepping`` worlds; ``beams``:
    ``(beam_angles, reach, scan)`` of :func:`~slam_env.kernels.sensing.proximity_scan`
    (no angles: no scan); ``readings``: ``(control, collided)``, the odometry reading
    and the contact flag the observation reports."""
    poses, landmarks, landmark_ids, id_order = worlds
    z, ids, rows, count = detections
    beam_angles, reach, scan = beams
    control, collided = readings
    sense_landmarks(
        poses, landmarks, landmark_ids, id_order, geometry_fields, sensor_fields, uniforms,
        scan_offset, touched, z, ids, rows, count,
    )  # fmt: skip
    if faults is not None:
        fault_fields, fault_offset = faults
        corrupt_scans(fault_fields, seen, uniforms, fault_offset, stepping, z, ids, rows, count)
    if beam_angles.shape[0]:
        proximity_scan(poses, geometry_fields, beam_angles, reach, touched, scan)
    observe_raw(
        control, z, ids, count, collided, landmark_ids, params_fields, touched, seen, out_fields
    )
