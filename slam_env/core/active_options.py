"""The options ``slam_env/ActiveSLAM-v0`` adds to the world's: normalised (numpy
scalars and arrays taken as the Python values they hold), checked, and named in every
error, before the env builds anything."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from slam_env.belief.encodings import OBSERVATION_MODES
from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.config import BELIEFS, EnvConfig, check_options, option, plain
from slam_env.ekf import CORRECTION_MODES, DATA_ASSOCIATIONS, DEFAULT_GATE, LINEARIZATIONS, checks

# Proximity beams in the active-SLAM observation, unless the options set them.
DEFAULT_SCAN_BEAMS = 16
# The world options whose default differs here: a policy must see obstacles, which the
# landmark map does not hold, and feel when one blocks it (a corner can hide between
# two beams). They apply unless the options set them, flat or nested.
ACTIVE_SLAM_DEFAULTS = {"scan_beams": DEFAULT_SCAN_BEAMS, "bumper": True}
# The observations of ActiveSLAM-v0: the belief wrapper's, and "local", which does not
# depend on the landmark count (slam_env.belief.local_encoding; it needs the coverage).
ACTIVE_OBSERVATION_MODES = (*OBSERVATION_MODES, "local")


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return float(value)


def _noise_gains(name: str, value: Any) -> tuple[float, ...] | None:
    """None, or 4 finite numbers >= 0."""
    if value is None:
        return None
    if not isinstance(value, tuple) or len(value) != 4:
        raise ValueError(f"{name} must be 4 numbers, got {value!r}")
    out = tuple(_number(f"{name}[{i}]", v) for i, v in enumerate(value))
    for i, v in enumerate(out):
        if v < 0.0:
            raise ValueError(f"{name}[{i}] must be >= 0, got {v}")
    return out


def _measurement_cov(name: str, value: Any) -> tuple[tuple[float, float], ...] | None:
    """None, or a 2×2 symmetric positive-definite matrix."""
    if value is None:
        return None
    if not (
        isinstance(value, tuple)
        and len(value) == 2
        and all(isinstance(row, tuple) and len(row) == 2 for row in value)
    ):
        raise ValueError(f"{name} must be a 2×2 matrix, got {value!r}")
    (a, b), (c, d) = (
        (_number(f"{name}[{i}][{j}]", v) for j, v in enumerate(row)) for i, row in enumerate(value)
    )
    if b != c or not (a > 0.0 and d > 0.0 and a * d - b * c > 0.0):
        raise ValueError(
            f"{name} must be symmetric positive definite (a noise-free sensor makes the "
            f"innovation covariance singular), got {value!r}"
        )
    return ((a, b), (c, d))


@dataclass(frozen=True)
class ActiveSLAMOptions:
    """The arguments of :class:`slam_env.envs.active_slam.ActiveSLAMEnv` other than the
    world's options, checked (see its docstring for their meaning)."""

    observation: str = option(
        "egocentric",
        "the belief as flat features; the exact mean, covariance and known-mask; or the "
        "count-independent local map (it needs coverage)",
        choices=ACTIVE_OBSERVATION_MODES,
    )
    correction: str = option(
        "sequential",
        "one observation at a time, re-linearised, or the whole scan stacked",
        choices=CORRECTION_MODES,
    )
    gate: float | None = option(
        DEFAULT_GATE,
        "χ² threshold on an innovation's Mahalanobis distance (2 dof), or None to accept "
        "everything; the default is the 99.9% quantile",
        above=0,
    )
    filter_alphas: Any = option(
        None, "the filter's α1..α4 (a mismatched filter); None: the env's alphas"
    )
    filter_control_noise: Any = option(
        None, "the filter's (σp, σθ, βp, βθ); None: the env's velocity_noise"
    )
    filter_measurement_cov: Any = option(
        None, "the filter's 2×2 Q, symmetric positive definite; None: the sensor's"
    )
    reward_weights: Any = option(
        None,
        "an ActiveSLAMRewardWeights or a dict of its fields (information_gain, "
        "pose_uncertainty, collision, step, coverage); None: their defaults",
    )
    coverage: bool = option(
        True,
        "the swept-area memory and its features, which a policy needs to know where it "
        "has not looked yet",
    )
    data_association: str = option(
        "known",
        "the sensor's IDs, or the filter associates by itself (needed with report_ids=False)",
        choices=DATA_ASSOCIATIONS,
    )
    linearization: str = option(
        "standard",
        "the standard EKF, First-Estimates Jacobian, observability-constrained, or right-invariant",
        choices=LINEARIZATIONS,
    )
    new_landmark_sightings: int = option(
        1, "2: a new landmark waits for a second sighting (keeps clutter out)", low=1, high=2
    )
    wide_pairing_scans: int = option(
        1,
        "with 'jcbb', a loop-closing pairing waits for that many consecutive scans",
        low=1,
    )
    belief: str = option(
        "ekf",
        "the EKF-SLAM filter, or iSAM2 smoothing over the pose graph (the gtsam extra), "
        "its mean and joint marginal handed on as the filter's are",
        choices=BELIEFS,
    )
    smoothing_relinearize_threshold: float = option(
        0.02,
        "with belief='isam2': a variable whose linear step exceeds this is relinearised "
        "(GTSAM's default 0.1 left the map 5% off the optimum)",
        "m, rad",
        low=0,
    )
    smoothing_relinearize_skip: int = option(
        1, "with belief='isam2': updates between relinearisation checks", low=1
    )
    smoothing_keyframes: int | None = option(
        None,
        "with belief='isam2': a pose variable every that many steps (and at every new "
        "landmark), the detections between left out; None: every step",
        low=1,
    )
    smoothing_window: int | None = option(
        None,
        "with belief='isam2': keep the latest that many pose variables, marginalise the "
        "older; None: keep them all",
        low=1,
    )
    weights: ActiveSLAMRewardWeights = field(init=False)

    def __post_init__(self) -> None:
        values = {f.name: plain(getattr(self, f.name)) for f in fields(self) if f.init}
        if values["observation"] not in ACTIVE_OBSERVATION_MODES:
            raise ValueError(
                f"observation must be one of {ACTIVE_OBSERVATION_MODES}, got {self.observation!r}"
            )
        # The filter's own checks, run before anything is built.
        checks.choice("correction", values["correction"], CORRECTION_MODES)
        checks.choice("data_association", values["data_association"], DATA_ASSOCIATIONS)
        checks.choice("linearization", values["linearization"], LINEARIZATIONS)
        checks.new_landmark_sightings(values["new_landmark_sightings"])
        checks.wide_pairing_scans(values["wide_pairing_scans"], values["data_association"])
        checks.choice("belief", values["belief"], BELIEFS)
        if values["belief"] == "isam2" and values["linearization"] != "standard":
            raise ValueError(
                f"linearization={values['linearization']!r} is the filter's: belief='isam2' "
                "relinearises its whole graph (leave linearization='standard')"
            )
        gate = values["gate"]
        if gate is not None and not _number("gate", gate) > 0.0:
            raise ValueError(f"gate must be > 0 (a χ² threshold) or None, got {gate!r}")
        values["filter_alphas"] = _noise_gains("filter_alphas", values["filter_alphas"])
        values["filter_control_noise"] = _noise_gains(
            "filter_control_noise", values["filter_control_noise"]
        )
        values["filter_measurement_cov"] = _measurement_cov(
            "filter_measurement_cov", values["filter_measurement_cov"]
        )
        if not isinstance(values["coverage"], bool):
            raise TypeError(f"coverage must be a bool, got {self.coverage!r}")
        if values["observation"] == "local" and not values["coverage"]:
            raise ValueError(
                "observation='local' needs coverage=True: its local map shows the swept area"
            )
        for name, value in values.items():
            object.__setattr__(self, name, value)
        check_options(self)  # the table's limits, the integers' upper bound among them
        if values["belief"] != "isam2":
            for f in fields(self):
                if f.name.startswith("smoothing_") and values[f.name] != f.default:
                    raise ValueError(
                        f"{f.name} applies to belief='isam2', not {values['belief']!r}"
                    )
        object.__setattr__(self, "weights", self._weights(self.reward_weights))

    @classmethod
    def argument_names(cls) -> tuple[str, ...]:
        """The options' names, as ``ActiveSLAM-v0`` takes them."""
        return tuple(f.name for f in fields(cls) if f.init)

    @staticmethod
    def _weights(value: Any) -> ActiveSLAMRewardWeights:
        if value is None:
            return ActiveSLAMRewardWeights()
        if isinstance(value, ActiveSLAMRewardWeights):
            return value
        if not isinstance(value, Mapping):
            raise TypeError(
                "reward_weights must be an ActiveSLAMRewardWeights or a dict of its "
                f"fields, got {type(value).__name__}"
            )
        valid = ActiveSLAMRewardWeights.__dataclass_fields__
        unknown = sorted(set(value) - set(valid))
        if unknown:
            raise TypeError(f"unknown reward_weights {unknown}; valid: {sorted(valid)}")
        try:
            return ActiveSLAMRewardWeights(**{k: plain(v) for k, v in value.items()})
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"reward_weights: {exc}") from None

    def check_against(self, config: EnvConfig) -> None:
        """``ValueError`` when the filter would take a noise-free measurement model
        from the env (its innovation covariance would be singular), or would need the
        landmark IDs that the sensor does not report."""
        sensor = config.sensor
        if not sensor.report_ids and self.data_association == "known":
            raise ValueError(
                "report_ids=False hides the landmark IDs that data_association='known' needs: "
                "choose data_association='nearest_neighbor' or 'jcbb'"
            )
        if self.filter_measurement_cov is not None:
            return
        q = sensor.measurement_cov
        if not (q[0, 0] > 0.0 and q[1, 1] > 0.0):  # squares that underflow count as 0
            names = (
                "range_std and bearing_std"
                if sensor.measurement_model == "range_bearing"
                else "cartesian_std"
            )
            raise ValueError(
                f"{names} must be > 0 (and their squares > 0) for ActiveSLAM-v0's filter: a "
                "noise-free sensor makes its innovation covariance singular; or give "
                "filter_measurement_cov"
            )
