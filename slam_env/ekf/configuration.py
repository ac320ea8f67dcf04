"""An :class:`~slam_env.ekf.filter.EKFSLAM`'s configuration: its options checked
(:func:`checked_config`, every bad value a ``TypeError``/``ValueError`` naming it) and
encoded as the compiled kernels take them (:func:`kernel_config`)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from slam_env.ekf import checks
from slam_env.ekf.chi2 import chi2_gate
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.kernels.ekf import codes as ekf_codes

CORRECTION_MODES = ("sequential", "batch")
_CORRECTION_CODES = {"sequential": ekf_codes.SEQUENTIAL, "batch": ekf_codes.BATCH}
_ASSOCIATION_CODES = {
    "known": ekf_codes.KNOWN,
    "nearest_neighbor": ekf_codes.NEAREST_NEIGHBOR,
    "jcbb": ekf_codes.JCBB,
}
DATA_ASSOCIATIONS = tuple(_ASSOCIATION_CODES)
_LINEARIZATION_CODES = {
    "standard": ekf_codes.STANDARD,
    "fej": ekf_codes.FEJ,
    "oc": ekf_codes.OC,
    "invariant": ekf_codes.INVARIANT,
}
LINEARIZATIONS = tuple(_LINEARIZATION_CODES)
# The association's gates by default: a landmark within the 99.9% χ² region of an
# observation is compatible with it (as ActiveSLAM-v0's validation gate accepts it);
# one within the 99.999% region forbids starting a new landmark there.
MATCH_PROBABILITY = 0.999
NEW_LANDMARK_PROBABILITY = 0.99999


class FilterConfig(NamedTuple):
    """The checked options of one filter (:class:`~slam_env.ekf.filter.EKFSLAM`'s
    arguments but the prior; ``association_gates`` = (match_gate, new_landmark_gate),
    their defaults filled in)."""

    motion_model: str
    measurement_model: str
    alphas: tuple[float, float, float, float] | None
    control_noise: tuple[float, float, float, float] | None
    measurement_cov: np.ndarray
    max_landmarks: int
    gate: float | None
    correction: str
    data_association: str
    linearization: str
    association_gates: tuple[float, float]
    new_landmark_sightings: int
    wide_pairing_scans: int


def checked_config(
    *,
    motion_model: Any,
    measurement_model: Any,
    alphas: Any,
    control_noise: Any,
    measurement_cov: Any,
    max_landmarks: Any,
    gate: Any,
    correction: Any,
    data_association: Any,
    linearization: Any,
    match_gate: Any,
    new_landmark_gate: Any,
    new_landmark_sightings: Any,
    wide_pairing_scans: Any,
) -> FilterConfig:
    """:class:`~slam_env.ekf.filter.EKFSLAM`'s options (as its docstring says) checked, or the
    ``TypeError``/``ValueError`` of the first bad one."""
    if motion_model not in MOTION_MODELS:
        raise ValueError(
            f"motion_model must be one of {tuple(MOTION_MODELS)}, got {motion_model!r}"
        )
    if measurement_model not in MEASUREMENT_MODELS:
        raise ValueError(
            f"measurement_model must be one of {tuple(MEASUREMENT_MODELS)}, "
            f"got {measurement_model!r}"
        )
    checks.choice("correction", correction, CORRECTION_MODES)
    checks.choice("data_association", data_association, DATA_ASSOCIATIONS)
    checks.choice("linearization", linearization, LINEARIZATIONS)
    gates = _association_gates(match_gate, new_landmark_gate)
    sightings = checks.new_landmark_sightings(new_landmark_sightings)
    wide_scans = checks.wide_pairing_scans(wide_pairing_scans, data_association)
    alphas = None if alphas is None else checks.noise_params(alphas, "alphas")
    control_noise = (
        None if control_noise is None else checks.noise_params(control_noise, "control_noise")
    )
    if motion_model == "odometry" and alphas is None:
        raise ValueError("alphas (α1, α2, α3, α4) are required for motion_model='odometry'")
    if motion_model == "velocity" and control_noise is None:
        raise ValueError("control_noise (σp, σθ, βp, βθ) is required for motion_model='velocity'")
    Q = checks.covariance(measurement_cov, "measurement_cov", 2, definite=True)
    max_landmarks = checks.integer(max_landmarks, "max_landmarks", 0)
    if gate is not None:
        gate = checks.number(gate, "gate")
        if gate <= 0.0:
            raise ValueError(f"gate must be > 0 (a χ² threshold) or None, got {gate}")
    return FilterConfig(
        motion_model,
        measurement_model,
        alphas,
        control_noise,
        Q,
        int(max_landmarks),
        gate,
        correction,
        data_association,
        linearization,
        gates,
        sightings,
        wide_scans,
    )


def _association_gates(match: Any, new: Any) -> tuple[float, float]:
    gates = []
    for name, value, probability in (
        ("match_gate", match, MATCH_PROBABILITY),
        ("new_landmark_gate", new, NEW_LANDMARK_PROBABILITY),
    ):
        if value is None:
            value = chi2_gate(probability)
        value = checks.number(value, name)
        if value <= 0.0:
            raise ValueError(f"{name} must be > 0 (a χ² threshold), got {value}")
        gates.append(value)
    if gates[1] < gates[0]:
        raise ValueError(
            f"new_landmark_gate ({gates[1]:g}) must be at least match_gate ({gates[0]:g}): "
            "a new landmark starts only where no landmark is compatible"
        )
    return gates[0], gates[1]


def kernel_config(
    motion_model: str,
    measurement_model: str,
    correction: str,
    noise: tuple[float, float, float, float],
    measurement_cov: np.ndarray,
    gate: float | None,
    data_association: str = "known",
    linearization: str = "standard",
    association_gates: tuple[float, float] = (np.inf, np.inf),
    new_landmark_sightings: int = 1,
    wide_pairing_scans: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """One filter's configuration as the kernels of :mod:`slam_env.kernels.ekf.filter` take
    it: its row of ``params`` ((12,) float64: the motion noise (α1..α4, or σp, σθ, βp,
    βθ), Q00, Q01, Q11, the gate, ``inf`` for none, the association's match and
    new-landmark gates, the sightings a new landmark needs and the scans a wide pairing
    waits) and of ``modes`` ((5,)
    int64: the motion, measurement, correction, association and linearisation codes).
    Arguments as :class:`EKFSLAM`'s, already checked (``noise`` the parameters of the
    chosen motion model)."""
    Q = measurement_cov
    params = np.array(
        [
            *noise, Q[0, 0], Q[0, 1], Q[1, 1], np.inf if gate is None else gate,
            *association_gates, new_landmark_sightings, wide_pairing_scans,
        ]
    )  # fmt: skip
    modes = np.array(
        [
            MOTION_MODELS[motion_model].code,
            MEASUREMENT_MODELS[measurement_model].code,
            _CORRECTION_CODES[correction],
            _ASSOCIATION_CODES[data_association],
            _LINEARIZATION_CODES[linearization],
        ],
        dtype=np.int64,
    )
    return params, modes
