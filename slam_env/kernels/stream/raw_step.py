"""The raw step of B worlds once their robots have moved, in one kernel call (see
:class:`slam_env.core.raw.RawCore`): the step's uniforms, the odometry reading, the
landmark scan, its faults, the proximity scan and the raw observation. They chain the
kernels of :mod:`~slam_env.core.random_blocks`, :mod:`~slam_env.kernels.stream.odometry`,
:mod:`~slam_env.kernels.stream.sensing`, :mod:`~slam_env.kernels.stream.faults` and
:mod:`~slam_env.kernels.stream.observe`; as one call, a batch of one pays numba's dispatch
once, and each array is passed once. What needs Python (refilling a block of
uniforms, a kidnapping) stops the call for the caller, who calls again."""

from __future__ import annotations

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel
from slam_env.kernels.stream.blocks import take_rows, used_up_rows
from slam_env.kernels.stream.faults import corrupt_odometry, corrupt_scans
from slam_env.kernels.stream.observe import observe_raw
from slam_env.kernels.stream.odometry import read_odometry
from slam_env.kernels.stream.sensing import proximity_scan, sense_landmarks


@borrowing_kernel
def raw_step(
    random_blocks: tuple,
    odometry: tuple,
    odometry_faults: tuple | None,
    worlds: tuple,
    geometry_fields: tuple,
    sensor_fields: tuple,
    scan_offset: int,
    touched: np.ndarray,
    detections: tuple,
    faults: tuple | None,
    beams: tuple,
    collided: np.ndarray,
    seen: np.ndarray,
    params_fields: tuple,
    out_fields: tuple,
    stepping: np.ndarray,
    scratch: tuple,
    read: bool,
    sense: bool,
) -> int:
    """The step of each ``touched`` world once the robots have moved: if ``read``, its
    uniforms (the next row of its block) and each ``stepping`` robot's odometry
    reading; then, if ``sense``, :func:`sense_and_observe` (a kidnapping comes between
    the two, in Python). A world whose block is used up stops the call before anything
    is done: it returns how many there are, listed in the blocks' ``used_up``, for the
    caller to refill them and call again; else 0.

    ``random_blocks``: ``(blocks, cursor, uniforms, used_up)`` of
    :class:`~slam_env.core.random_blocks.RandomBlocks`; ``odometry``: ``(before,
    velocity_model, noise, control_true, control)``, ``before`` the poses before the
    motion (those after are the first of ``worlds``), as
    :func:`~slam_env.kernels.stream.odometry.read_odometry` takes them; ``odometry_faults``:
    None, or ``(dropout, bias, offset)`` of
    :func:`~slam_env.kernels.stream.faults.corrupt_odometry`; the rest as
    :func:`sense_and_observe` takes it (its ``readings`` are ``control`` and
    ``collided``)."""
    blocks, cursor, uniforms, used_up = random_blocks
    before, velocity_model, noise, control_true, control = odometry
    if read:
        n = used_up_rows(blocks, cursor, touched, used_up)
        if n:
            return n
        take_rows(blocks, cursor, touched, uniforms)
        read_odometry(
            before, worlds[0], velocity_model, noise, uniforms, 0, stepping, control_true, control
        )
        if odometry_faults is not None:
            dropout, bias, fault_offset = odometry_faults
            corrupt_odometry(dropout, bias, uniforms, fault_offset, stepping, control)
    if sense:
        sense_and_observe(
            worlds, geometry_fields, sensor_fields, uniforms, scan_offset, touched, detections,
            faults, stepping, beams, (control, collided), seen, params_fields, out_fields,
            scratch,
        )  # fmt: skip
    return 0


@borrowing_kernel
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
    scratch: tuple,
) -> None:
    """Sense and observe each ``touched`` world.

    ``worlds``: ``(poses, landmarks, landmark_ids, id_order)`` of
    :class:`slam_env.world.world_batch.WorldBatch`; ``detections``: ``(z, ids, rows, count)``,
    what :func:`~slam_env.kernels.stream.sensing.sense_landmarks` writes; ``faults``: None, or
    the :class:`~slam_env.kernels.stream.faults.FaultParams` fields and the faults' offset in
    ``uniforms``, applied to the scans of the ``stepping`` worlds; ``beams``:
    ``(beam_angles, reach, scan)`` of :func:`~slam_env.kernels.stream.sensing.proximity_scan`
    (no angles: no scan); ``readings``: ``(control, collided)``, the odometry reading
    and the contact flag the observation reports; ``scratch``: the sensing's
    workspaces (:func:`~slam_env.kernels.stream.sensing.sensing_scratch`)."""
    poses, landmarks, landmark_ids, id_order = worlds
    z, ids, rows, count = detections
    beam_angles, reach, scan = beams
    control, collided = readings
    sense_landmarks(
        poses, landmarks, landmark_ids, id_order, geometry_fields, sensor_fields, uniforms,
        scan_offset, touched, z, ids, rows, count, scratch,
    )  # fmt: skip
    if faults is not None:
        fault_fields, fault_offset = faults
        corrupt_scans(fault_fields, seen, uniforms, fault_offset, stepping, z, ids, rows, count)
    if beam_angles.shape[0]:
        proximity_scan(poses, geometry_fields, beam_angles, reach, touched, scan, scratch)
    observe_raw(
        control, z, ids, count, collided, landmark_ids, params_fields, touched, seen, out_fields
    )
