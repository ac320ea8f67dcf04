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

from slam_env.kernels.base.integers import MAX_INTEGER, MAX_INTEGER_TEXT

PRESETS = ("random", "open", "cluttered", "rooms")
MOTION_MODELS = ("odometry", "velocity")
MEASUREMENT_MODELS = ("range_bearing", "cartesian")
ACTION_TYPES = ("continuous", "discrete")
# The beliefs ActiveSLAM-v0 can hand its agents: the EKF-SLAM filter, or the smoothing
# belief over the pose graph (slam_env.smoothing; the gtsam extra). Here, with the other
# choices, so that the command line can offer them without importing the filter.
BELIEFS = ("ekf", "isam2")


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


# ---------------------------------------------------------------------- the table
def option(
    default: Any,
    doc: str,
    unit: str = "",
    *,
    above: float | None = None,
    low: float | None = None,
    high: float | None = None,
    choices: tuple[str, ...] | None = None,
    entries: tuple[str, ...] | None = None,
) -> Any:
    """A field of an option table: its default, what it means (``doc``), its ``unit``,
    and what it may be, which :func:`check_options` checks and the docs list: a number
    ``> above``, ``>= low``, ``<= high``; one of ``choices``; or, with ``entries``, a
    tuple of that many numbers (each bounded so), the labels naming them. An integer
    option without a ``high`` is bounded by
    :data:`~slam_env.kernels.base.integers.MAX_INTEGER` (what the kernels hold)."""
    limits = {"above": above, "low": low, "high": high, "choices": choices, "entries": entries}
    metadata = {"doc": doc, "unit": unit, **limits}
    if isinstance(default, (list, dict)) or dataclasses.is_dataclass(default):
        return field(default_factory=lambda: default, metadata=metadata)  # never shared
    return field(default=default, metadata=metadata)


def limits_text(f: dataclasses.Field) -> str:
    """The limits of an option field in words (for the docs)."""
    m = f.metadata
    if m.get("choices"):
        return "one of " + ", ".join(repr(c) for c in m["choices"])
    integer = isinstance(f.default, int) and not isinstance(f.default, bool)
    integer = integer or "int" in str(f.type)
    bound = _interval(m, integer) if _bounded(m) or integer else ""
    if m.get("entries"):
        each = f", each {bound}" if bound else ""
        return f"{len(m['entries'])} numbers ({', '.join(m['entries'])}){each}"
    return bound


def _bounded(m: Mapping) -> bool:
    return any(m.get(key) is not None for key in ("above", "low", "high"))


def _interval(m: Mapping, integer: bool) -> str:
    """The bounds of a table entry as ``> 0``, ``>= 1``, ``in [0, 1]`` or ``in (0, 1]``
    (an integer's ``high`` is at most :data:`MAX_INTEGER`)."""

    def show(b: float) -> str:
        if not integer:
            return f"{b:g}"
        return MAX_INTEGER_TEXT if b == MAX_INTEGER else str(int(b))

    above, low, high = m.get("above"), m.get("low"), _high(m, integer)
    if high is None:
        return f"> {show(above)}" if above is not None else f">= {show(low)}"
    if above is None and low is None:
        return f"<= {show(high)}"
    opening = f"({show(above)}" if above is not None else f"[{show(low)}"
    return f"in {opening}, {show(high)}]"


def _high(m: Mapping, integer: bool) -> float | None:
    """An entry's upper bound: its ``high``, and for an integer at most MAX_INTEGER."""
    high = m.get("high")
    if not integer:
        return high
    return MAX_INTEGER if high is None else min(high, MAX_INTEGER)


def _check_number(owner: str, name: str, value: Any, integer: bool, m: Mapping) -> None:
    if integer:
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"{owner}.{name} must be an int, got {type(value).__name__}")
    else:
        _check_finite(owner, **{name: value})
    above, low, high = m.get("above"), m.get("low"), _high(m, integer)
    if (
        (above is not None and not value > above)
        or (low is not None and not value >= low)
        or (high is not None and not value <= high)
    ):
        shown = value if integer else repr(value)
        raise ValueError(f"{owner}.{name} must be {_interval(m, integer)}, got {shown}")


def check_options(obj: Any) -> None:
    """Check every field of the frozen option dataclass ``obj`` against its table entry
    (:func:`option`): ``TypeError`` for a wrong type, ``ValueError`` for a value out of
    its limits, each naming ``Class.field``. ``None`` passes where it is the default."""
    owner = type(obj).__name__
    for f in dataclasses.fields(obj):
        m = f.metadata
        if "doc" not in m:
            continue
        value = getattr(obj, f.name)
        if value is None and (f.default is None or "None" in str(f.type)):
            continue
        if m["choices"]:
            _check_choice(owner, f.name, value, m["choices"])
        elif m["entries"]:
            _check_tuple(owner, f.name, value, (len(m["entries"]),))
            for i, (label, v) in enumerate(zip(m["entries"], value, strict=True)):
                _check_number(owner, f"{f.name}[{i}] ({label})", v, False, m)
        elif isinstance(f.default, bool):
            if not isinstance(value, bool):
                raise TypeError(f"{owner}.{f.name} must be a bool, got {value!r}")
        elif isinstance(f.default, (int, float)) or _bounded(m):
            integer = isinstance(f.default, int) or "int" in str(f.type)
            _check_number(owner, f.name, value, integer, m)


def _check_finite(owner: str, **values: float) -> None:
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"{owner}.{name} must be a number, got {type(value).__name__}")
        if not math.isfinite(value):
            raise ValueError(f"{owner}.{name} must be finite, got {value!r}")


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


# ---------------------------------------------------------------------- the sections
@dataclass(frozen=True)
class WorldConfig:
    """How the world is laid out. ``preset="random"`` draws a new world from the
    env's seed at every reset; the other presets are fixed maps."""

    preset: str = option(
        "random", "the world: drawn anew at every reset, or a fixed map", choices=PRESETS
    )
    width: float = option(16.0, "arena extent along x", "m", above=0)
    height: float = option(16.0, "arena extent along y", "m", above=0)
    n_landmarks: int = option(20, "landmarks in random worlds (IDs 0..n-1)", low=1)
    n_obstacles: int = option(6, "box obstacles in random worlds", low=0)
    obstacle_size: tuple[float, float] = option(
        (0.6, 2.0), "min and max side of a random box obstacle", "m", above=0,
        entries=("min", "max"),
    )  # fmt: skip
    landmark_spacing: float = option(1.0, "minimum distance between two landmarks", "m", low=0)
    clearance: float = option(0.4, "landmark distance from walls and obstacles", "m", low=0)
    wall_thickness: float = option(0.1, "radius of the wall segments", "m", above=0)

    def __post_init__(self) -> None:
        _plain_fields(self)
        check_options(self)
        lo, hi = self.obstacle_size
        if lo > hi:
            raise ValueError(f"WorldConfig.obstacle_size min {lo} exceeds max {hi}")


@dataclass(frozen=True)
class RobotConfig:
    """A circular unicycle robot."""

    radius: float = option(0.25, "the robot's radius", "m", above=0)
    max_speed: float = option(1.0, "|forward speed| at action 1.0", "m/s", above=0)
    max_turn_rate: float = option(1.5, "|turn rate| at action 1.0", "rad/s", above=0)
    mass: float = option(10.0, "the robot's mass (pymunk's contacts)", "kg", above=0)

    def __post_init__(self) -> None:
        _plain_fields(self)
        check_options(self)


@dataclass(frozen=True)
class SensorConfig:
    """The landmark sensor (seed 000 range-bearing, or seed 004 cartesian)."""

    measurement_model: str = option(
        "range_bearing",
        "z = [r, φ] (seed 000), or z = R(θ)ᵀ(m − t), the landmark in the robot frame (seed 004)",
        choices=MEASUREMENT_MODELS,
    )
    max_range: float = option(5.0, "the landmark sensor's range", "m", above=0)
    fov: float = option(
        2.0 * math.pi / 3.0, "full opening angle, centred on the heading", "rad", above=0,
        high=2.0 * math.pi,
    )  # fmt: skip
    range_std: float = option(0.05, "σr of the range-bearing model", "m", low=0)
    bearing_std: float = option(math.radians(1.0), "σφ of the range-bearing model", "rad", low=0)
    cartesian_std: float = option(0.05, "σz of the cartesian model, per axis", "m", low=0)
    detection_prob: float = option(
        1.0, "probability that a visible landmark is reported", above=0, high=1
    )
    max_detections: int | None = option(
        None, "rows of the padded detections; None: one per landmark", low=1
    )
    scan_beams: int = option(
        0, "proximity beams evenly spread over 360°; 0: no scan observation", low=0
    )
    scan_range: float = option(3.0, "reach of the proximity beams", "m", above=0)
    bumper: bool = option(False, "a contact sensor: 1.0 after a blocked step")
    report_ids: bool = option(
        True, "False: detections carry no landmark ID (-1); the truth is in info"
    )

    def __post_init__(self) -> None:
        _plain_fields(self)
        check_options(self)

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

    motion_model: str = option(
        "odometry",
        "u = (δrot1, δtr, δrot2) (seed 000), or u = (Δp, Δθ) (seed 004)",
        choices=MOTION_MODELS,
    )
    alphas: tuple[float, float, float, float] = option(
        (0.005, 0.002, 0.01, 0.001), "the odometry model's noise gains", low=0,
        entries=("α1", "α2", "α3", "α4"),
    )  # fmt: skip
    velocity_noise: tuple[float, float, float, float] = option(
        (0.01, 0.01, 0.01, 0.02),
        "the velocity model's noise: σp (m), σθ (rad), βp, βθ; by default, on a straight "
        "step at the default speed (0.2 m), σ = 0.022 m along and 0.010 rad in heading, "
        "near the default alphas' 0.020 m and 0.013 rad, and never zero (σp, σθ > 0: "
        "without them a step without a turn adds no heading noise)",
        low=0,
        entries=("σp", "σθ", "βp", "βθ"),
    )

    def __post_init__(self) -> None:
        _plain_fields(self)
        check_options(self)


@dataclass(frozen=True)
class RewardConfig:
    """The raw env's scripting reward: a bonus per landmark seen for the first time,
    a penalty per step spent in collision."""

    new_landmark_bonus: float = option(1.0, "reward per first detection of a landmark")
    collision_penalty: float = option(0.1, "subtracted on a step with a collision")

    def __post_init__(self) -> None:
        _plain_fields(self)
        check_options(self)


@dataclass(frozen=True)
class FaultConfig:
    """Injected faults for robustness studies, all off by default (see
    :mod:`slam_env.world.kidnap`). Probabilities are per env step."""

    outlier_rate: float = option(
        0.0, "a spurious detection with a wrong (seen) landmark ID", low=0, high=1
    )
    clutter_rate: float = option(
        0.0, "a spurious detection of no landmark at all (ID -1)", low=0, high=1
    )
    scan_dropout: float = option(0.0, "the whole scan is lost", low=0, high=1)
    odometry_dropout: float = option(0.0, "the odometry reads zero motion", low=0, high=1)
    odometry_bias: tuple[float, ...] | None = option(
        None, "added to every odometry reading, in the model's units (3 or 2 entries)"
    )
    kidnap_rate: float = option(0.0, "the robot is carried to a random free pose", low=0, high=1)

    def __post_init__(self) -> None:
        _plain_fields(self)
        check_options(self)
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
    dt: float = option(0.2, "one env step (the policy's rate, 5 Hz)", "s", above=0)
    physics_substeps: int = option(4, "pymunk steps per env step", low=1)
    action_type: str = option(
        "continuous", "a Box of (speed, turn rate) fractions, or motion primitives",
        choices=ACTION_TYPES,
    )  # fmt: skip
    terminate_when_all_detected: bool = option(
        False, "end the episode on the step the last landmark is first seen"
    )
    layout: Any = option(
        None, "a user's world: a Layout, a dict or a JSON/YAML path; None: world.preset"
    )

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
        check_options(self)


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


def check_option_names(
    names: Iterable[str], extra: Iterable[str] = (), owner: str = "make_config"
) -> None:
    """``TypeError`` for the first name that is neither an option nor in ``extra``, in
    the words Python uses for the function ``owner`` (``"LandmarksEnv.__init__"``) and
    then every valid name. Wrappers such as torchrl's ``GymEnv`` try an argument
    (``frameskip``) and drop it when the error says it in those words."""
    valid = option_names(extra)
    for name in names:
        if name not in valid:
            raise TypeError(
                f"{owner}() got an unexpected keyword argument {name!r}; "
                f"valid options: {', '.join(valid)}"
            )


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
