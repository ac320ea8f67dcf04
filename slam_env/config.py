"""Frozen, validated configuration for the world, robot, sensors and env.

Every number carries its unit in a comment. Each dataclass checks itself in
``__post_init__`` and raises ``ValueError``/``TypeError`` naming the bad field; numpy
scalars, 0-d arrays and arrays are taken as the Python values they hold (see
:func:`plain`). ``make_config(**overrides)`` turns the keyword arguments that
``gym.make`` passes, flat or nested, into an :class:`EnvConfig`; an unknown name is an
error, never ignored, and so is an option given twice.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

PRESETS = ("random", "open", "cluttered", "rooms")
MOTION_MODELS = ("odometry", "velocity")
MEASUREMENT_MODELS = ("range_bearing", "cartesian")
ACTION_TYPES = ("continuous", "discrete")


def plain(value: Any) -> Any:
    """The Python form of an option value: a numpy scalar or 0-d array becomes the
    int, float, bool or str it holds, and an array, list or tuple becomes a tuple of
    such (configs stay hashable, and options can be swept over numpy arrays). A
    ``bool`` stays a ``bool``, so it is still refused where a number is expected."""
    if isinstance(value, (list, tuple)):
        return tuple(plain(v) for v in value)
    if hasattr(value, "ndim") and hasattr(value, "tolist"):  # numpy (or alike), no import
        value = value.tolist()  # Python scalars, or nested lists for an array
        return plain(value) if isinstance(value, list) else value
    return value


def _plain_fields(obj: Any) -> None:
    """Replace each field of the frozen dataclass ``obj`` by its :func:`plain` form
    (nested configs and the ``layout`` stay as they are)."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if f.name == "layout" or dataclasses.is_dataclass(value):
            continue
        converted = plain(value)
        if converted is not value:
            object.__setattr__(obj, f.name, converted)


def _check_positive(owner: str, **values: float) -> None:
    for name, value in values.items():
        _check_finite(owner, **{name: value})
        if value <= 0:
            raise ValueError(f"{owner}.{name} must be > 0, got {value!r}")


def _check_non_negative(owner: str, **values: float) -> None:
    for name, value in values.items():
        _check_finite(owner, **{name: value})
        if value < 0:
            raise ValueError(f"{owner}.{name} must be >= 0, got {value!r}")


def _check_finite(owner: str, **values: float) -> None:
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"{owner}.{name} must be a number, got {type(value).__name__}")
        if not math.isfinite(value):
            raise ValueError(f"{owner}.{name} must be finite, got {value!r}")


def _check_int(owner: str, low: int, **values: int) -> None:
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{owner}.{name} must be an int, got {type(value).__name__}")
        if value < low:
            raise ValueError(f"{owner}.{name} must be >= {low}, got {value}")


def _check_tuple(owner: str, name: str, value: Any, sizes: tuple[int, ...]) -> None:
    if not isinstance(value, tuple):
        raise TypeError(
            f"{owner}.{name} must be a sequence of {' or '.join(map(str, sizes))} numbers, "
            f"got {type(value).__name__}"
        )
    if len(value) not in sizes:
        raise ValueError(
            f"{owner}.{name} must have {' or '.join(map(str, sizes))} entries, got {len(value)}"
        )


def _check_choice(owner: str, name: str, value: str, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ValueError(f"{owner}.{name} must be one of {choices}, got {value!r}")


@dataclass(frozen=True)
class WorldConfig:
    """How the world is laid out. ``preset="random"`` draws a new world from the
    env's seed at every reset; the other presets are fixed maps."""

    preset: str = "random"
    width: float = 16.0  # m, arena extent along x
    height: float = 16.0  # m, arena extent along y
    n_landmarks: int = 20  # landmarks in random worlds (IDs 0..n-1)
    n_obstacles: int = 6  # box obstacles in random worlds
    obstacle_size: tuple[float, float] = (0.6, 2.0)  # m, min/max box side
    landmark_spacing: float = 1.0  # m, minimum distance between two landmarks
    clearance: float = 0.4  # m, landmark distance from walls and obstacles
    wall_thickness: float = 0.1  # m, radius of the wall segments

    def __post_init__(self) -> None:
        _plain_fields(self)
        _check_choice("WorldConfig", "preset", self.preset, PRESETS)
        _check_positive("WorldConfig", width=self.width, height=self.height)
        _check_int("WorldConfig", 1, n_landmarks=self.n_landmarks)
        _check_int("WorldConfig", 0, n_obstacles=self.n_obstacles)
        _check_tuple("WorldConfig", "obstacle_size", self.obstacle_size, (2,))
        lo, hi = self.obstacle_size
        _check_positive("WorldConfig", obstacle_size_min=lo, obstacle_size_max=hi)
        if lo > hi:
            raise ValueError(f"WorldConfig.obstacle_size min {lo} exceeds max {hi}")
        _check_non_negative(
            "WorldConfig", landmark_spacing=self.landmark_spacing, clearance=self.clearance
        )
        _check_positive("WorldConfig", wall_thickness=self.wall_thickness)


@dataclass(frozen=True)
class RobotConfig:
    """A circular unicycle robot."""

    radius: float = 0.25  # m
    max_speed: float = 1.0  # m/s, |v| at action 1.0
    max_turn_rate: float = 1.5  # rad/s, |ω| at action 1.0
    mass: float = 10.0  # kg

    def __post_init__(self) -> None:
        _plain_fields(self)
        _check_positive(
            "RobotConfig",
            radius=self.radius,
            max_speed=self.max_speed,
            max_turn_rate=self.max_turn_rate,
            mass=self.mass,
        )


@dataclass(frozen=True)
class SensorConfig:
    """The landmark sensor (seed 000 range-bearing, or seed 004 cartesian)."""

    measurement_model: str = "range_bearing"  # or "cartesian": z = R(θ)ᵀ(m − t)
    max_range: float = 5.0  # m
    fov: float = 2.0 * math.pi / 3.0  # rad, full opening angle centred on the heading
    range_std: float = 0.05  # m, σr
    bearing_std: float = math.radians(1.0)  # rad, σφ
    cartesian_std: float = 0.05  # m, σz for the cartesian model
    detection_prob: float = 1.0  # probability a visible landmark is reported
    max_detections: int | None = None  # rows of the padded array; None: one per landmark
    scan_beams: int = 0  # proximity beams evenly spread over 360°; 0: no "scan" observation
    scan_range: float = 3.0  # m, reach of the proximity beams
    bumper: bool = False  # a contact sensor: a "bumper" observation, 1.0 after a blocked step
    report_ids: bool = True  # False: detections carry no landmark ID (-1); the truth is in info

    def __post_init__(self) -> None:
        _plain_fields(self)
        _check_choice(
            "SensorConfig", "measurement_model", self.measurement_model, MEASUREMENT_MODELS
        )
        if not isinstance(self.report_ids, bool):
            raise TypeError(f"SensorConfig.report_ids must be a bool, got {self.report_ids!r}")
        _check_positive("SensorConfig", max_range=self.max_range, fov=self.fov)
        if self.fov > 2.0 * math.pi:
            raise ValueError(f"SensorConfig.fov must be <= 2π rad, got {self.fov}")
        _check_non_negative(
            "SensorConfig",
            range_std=self.range_std,
            bearing_std=self.bearing_std,
            cartesian_std=self.cartesian_std,
        )
        _check_finite("SensorConfig", detection_prob=self.detection_prob)
        if not 0.0 < self.detection_prob <= 1.0:
            raise ValueError(
                f"SensorConfig.detection_prob must be in (0, 1], got {self.detection_prob}"
            )
        if self.max_detections is not None:
            _check_int("SensorConfig", 1, max_detections=self.max_detections)
        _check_int("SensorConfig", 0, scan_beams=self.scan_beams)
        _check_positive("SensorConfig", scan_range=self.scan_range)
        if not isinstance(self.bumper, bool):
            raise TypeError(f"SensorConfig.bumper must be a bool, got {self.bumper!r}")

    @property
    def measurement_cov(self):
        """Q, the 2×2 measurement noise covariance the filter should use."""
        import numpy as np

        if self.measurement_model == "range_bearing":
            return np.diag([self.range_std**2, self.bearing_std**2])
        return np.diag([self.cartesian_std**2, self.cartesian_std**2])


@dataclass(frozen=True)
class OdometryConfig:
    """Odometry and its noise. ``motion_model="odometry"``: u = (δrot1, δtr, δrot2) with the α1–α4
    action-space noise of seed 000. ``"velocity"``: u = (Δp, Δθ) with the diagonal
    control noise Σu = diag(σp² + βp·Δp², σθ² + βθ·Δθ²) of seed 004."""

    motion_model: str = "odometry"
    alphas: tuple[float, float, float, float] = (0.005, 0.002, 0.01, 0.001)  # α1..α4, unitless
    velocity_noise: tuple[float, float, float, float] = (0.0, 0.0, 0.01, 0.02)
    # (σp [m], σθ [rad], βp [unitless], βθ [unitless])

    def __post_init__(self) -> None:
        _plain_fields(self)
        _check_choice("OdometryConfig", "motion_model", self.motion_model, MOTION_MODELS)
        _check_tuple("OdometryConfig", "alphas", self.alphas, (4,))
        for i, a in enumerate(self.alphas):
            _check_non_negative("OdometryConfig", **{f"alphas[{i}] (α{i + 1})": a})
        _check_tuple("OdometryConfig", "velocity_noise", self.velocity_noise, (4,))
        labels = ("σp", "σθ", "βp", "βθ")
        for i, (label, v) in enumerate(zip(labels, self.velocity_noise, strict=True)):
            _check_non_negative("OdometryConfig", **{f"velocity_noise[{i}] ({label})": v})


@dataclass(frozen=True)
class RewardConfig:
    """The raw env's scripting reward: a bonus per landmark seen for the first time,
    a penalty per step spent in collision."""

    new_landmark_bonus: float = 1.0  # reward per first detection
    collision_penalty: float = 0.1  # subtracted on a step with a collision

    def __post_init__(self) -> None:
        _plain_fields(self)
        _check_finite(
            "RewardConfig",
            new_landmark_bonus=self.new_landmark_bonus,
            collision_penalty=self.collision_penalty,
        )


@dataclass(frozen=True)
class FaultConfig:
    """Injected faults for robustness studies, all off by default (see
    :mod:`slam_env.world.kidnap`). Probabilities are per env step."""

    outlier_rate: float = 0.0  # a spurious detection with a wrong (seen) landmark ID
    clutter_rate: float = 0.0  # a spurious detection of no landmark at all (ID -1)
    scan_dropout: float = 0.0  # the whole scan is lost
    odometry_dropout: float = 0.0  # the odometry reads zero motion
    odometry_bias: tuple[float, ...] | None = None  # added to every reading, model units
    kidnap_rate: float = 0.0  # the robot is carried to a random free pose

    def __post_init__(self) -> None:
        _plain_fields(self)
        for name in (
            "outlier_rate", "clutter_rate", "scan_dropout", "odometry_dropout", "kidnap_rate",
        ):  # fmt: skip
            value = getattr(self, name)
            _check_finite("FaultConfig", **{name: value})
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"FaultConfig.{name} must be in [0, 1], got {value}")
        if self.odometry_bias is not None:
            # 3 entries for the odometry model, 2 for the velocity model
            _check_tuple("FaultConfig", "odometry_bias", self.odometry_bias, (3, 2))
            for i, b in enumerate(self.odometry_bias):
                _check_finite("FaultConfig", **{f"odometry_bias[{i}]": b})

    @property
    def any(self) -> bool:
        return bool(
            self.outlier_rate
            or self.clutter_rate
            or self.scan_dropout
            or self.odometry_dropout
            or self.kidnap_rate
            or self.odometry_bias is not None
        )


@dataclass(frozen=True)
class EnvConfig:
    """Everything the env needs. ``layout`` (a :class:`slam_env.world.layouts.Layout`, a dict
    or a JSON/YAML path) overrides ``world.preset`` with a user-given world."""

    world: WorldConfig = field(default_factory=WorldConfig)
    robot: RobotConfig = field(default_factory=RobotConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    odometry: OdometryConfig = field(default_factory=OdometryConfig)
    reward: RewardConfig = field(default_factory=RewardConfig)
    faults: FaultConfig = field(default_factory=FaultConfig)
    dt: float = 0.2  # s, one env step (policy rate 5 Hz)
    physics_substeps: int = 4  # pymunk steps per env step
    action_type: str = "continuous"  # or "discrete": motion primitives
    terminate_when_all_detected: bool = False  # end the episode once every landmark was seen
    layout: Any = None  # user world: Layout | dict | path; None uses world.preset

    def __post_init__(self) -> None:
        _plain_fields(self)
        for name, cls in (
            ("world", WorldConfig),
            ("robot", RobotConfig),
            ("sensor", SensorConfig),
            ("odometry", OdometryConfig),
            ("reward", RewardConfig),
            ("faults", FaultConfig),
        ):
            if not isinstance(getattr(self, name), cls):
                raise TypeError(f"EnvConfig.{name} must be a {cls.__name__}")
        bias = self.faults.odometry_bias
        dims = 3 if self.odometry.motion_model == "odometry" else 2
        if bias is not None and len(bias) != dims:
            raise ValueError(
                f"odometry_bias needs {dims} entries for motion_model="
                f"{self.odometry.motion_model!r}, got {len(bias)}"
            )
        _check_positive("EnvConfig", dt=self.dt)
        _check_int("EnvConfig", 1, physics_substeps=self.physics_substeps)
        _check_choice("EnvConfig", "action_type", self.action_type, ACTION_TYPES)
        if not isinstance(self.terminate_when_all_detected, bool):
            raise TypeError("EnvConfig.terminate_when_all_detected must be a bool")


_SECTIONS: dict[str, type] = {
    "world": WorldConfig,
    "robot": RobotConfig,
    "sensor": SensorConfig,
    "odometry": OdometryConfig,
    "reward": RewardConfig,
    "faults": FaultConfig,
}


def _flat_option_names() -> dict[str, str]:
    """Map each flat override name to its section; a name two sections share is
    reachable only through the nested ``section={...}`` form."""
    owners: dict[str, list[str]] = {}
    for section, cls in _SECTIONS.items():
        for f in dataclasses.fields(cls):
            owners.setdefault(f.name, []).append(section)
    return {name: s[0] for name, s in owners.items() if len(s) == 1}


def option_names(extra: Iterable[str] = ()) -> list[str]:
    """Every name ``make_config`` accepts (flat options, the nested sections and the
    top-level fields), plus ``extra`` (an env's own arguments), sorted."""
    top = [f.name for f in dataclasses.fields(EnvConfig)]
    return sorted(set(top) | set(_flat_option_names()) | set(extra))


def check_option_names(names: Iterable[str], extra: Iterable[str] = ()) -> None:
    """``TypeError`` for the first name that is neither an option nor in ``extra``,
    listing every valid name."""
    valid = option_names(extra)
    for name in names:
        if name not in valid:
            raise TypeError(f"unknown slam_env option {name!r}; valid options: {', '.join(valid)}")


def with_defaults(options: Mapping[str, Any], defaults: Mapping[str, Any]) -> dict[str, Any]:
    """``options`` with each flat option of ``defaults`` that they do not set, flat or
    nested (``sensor={...}``), added: an env's own defaults. A whole ``config`` or
    section object (``sensor=SensorConfig(...)``) is taken as it is, without them."""
    out = dict(options)
    if out.get("config") is not None:
        return out
    flat = _flat_option_names()
    for name, value in defaults.items():
        section = out.get(flat[name])
        if name in out or (section is not None and not isinstance(section, Mapping)):
            continue
        if isinstance(section, Mapping) and name in section:
            continue
        out[name] = value
    return out


def make_config(config: EnvConfig | None = None, **overrides: Any) -> EnvConfig:
    """Build an :class:`EnvConfig` from flat overrides such as
    ``make_config(n_landmarks=10, max_range=4.0, dt=0.1)`` or nested ones such as
    ``make_config(sensor={"fov": 3.14})``, on top of ``config`` (default: the defaults).
    Both forms mean the same; an option given in both raises ``ValueError``, an unknown
    name ``TypeError``."""
    base = config if config is not None else EnvConfig()
    if not isinstance(base, EnvConfig):
        raise TypeError(f"config must be an EnvConfig, got {type(base).__name__}")
    check_option_names(overrides)
    flat = _flat_option_names()
    section_updates: dict[str, dict[str, Any]] = {s: {} for s in _SECTIONS}
    top_updates: dict[str, Any] = {}
    given: dict[str, str] = {}  # option -> the form it was given in, to refuse a second

    def once(key: str, form: str) -> None:
        if key in given:
            raise ValueError(f"option {key!r} given twice, as {given[key]} and as {form}")
        given[key] = form

    for name, value in overrides.items():
        if name in _SECTIONS and isinstance(value, Mapping):
            valid = {f.name for f in dataclasses.fields(_SECTIONS[name])}
            for key, sub in value.items():
                if key not in valid:
                    raise TypeError(
                        f"unknown {name} option {key!r}; valid: {', '.join(sorted(valid))}"
                    )
                once(key, f"{name}={{{key!r}: {sub!r}}}")
                section_updates[name][key] = sub
        elif name in flat:
            once(name, f"{name}={value!r}")
            section_updates[flat[name]][name] = value
        else:  # a top-level field (check_option_names let nothing else through)
            top_updates[name] = value
    for section, updates in section_updates.items():
        if updates:
            current = top_updates.get(section, getattr(base, section))
            if not isinstance(current, _SECTIONS[section]):
                raise TypeError(
                    f"{section} must be a mapping or a {_SECTIONS[section].__name__}, "
                    f"got {type(current).__name__}"
                )
            top_updates[section] = dataclasses.replace(current, **updates)
    return dataclasses.replace(base, **top_updates) if top_updates else base
