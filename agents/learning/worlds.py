"""Training across worlds: a distribution of world settings (preset, arena side,
landmark and obstacle counts, sensor range and FOV) that a training draws each
episode's world from; :mod:`agents.learning.sb3.world_sampling` steps it on the native
vector env."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from slam_env.config import PRESETS, make_config

# Draws of a setting before giving up on a distribution that cannot lay out its worlds.
MAX_DRAWS = 20


def _choices(name: str, value: Any, kind: type) -> tuple:
    """A field's choices as a tuple of ``kind``; numbers > 0 (obstacle counts >= 0)."""
    if isinstance(value, (str, int, float)) and not isinstance(value, bool):
        value = [value]
    if not isinstance(value, Sequence) or isinstance(value, str) or not value:
        raise ValueError(f"worlds.{name} must be a non-empty list, got {value!r}")
    out = []
    for v in value:
        ok = isinstance(v, kind) or (kind is float and isinstance(v, int))
        if isinstance(v, bool) or not ok:
            raise ValueError(f"worlds.{name} must hold {kind.__name__}s, got {v!r}")
        least = 0 if name == "obstacle_counts" else 1e-300
        if kind is not str and not (math.isfinite(v) and v >= least):
            bound = ">= 0" if least == 0 else "> 0"
            raise ValueError(f"worlds.{name} must hold numbers {bound}, got {v!r}")
        out.append(kind(v))
    return tuple(out)


@dataclass(frozen=True)
class WorldDistribution:
    """World settings, each drawn uniformly and independently per episode. A field left
    as ``None`` keeps the env's own value (``env_options`` or its default)."""

    presets: tuple[str, ...] = ("random",)  # slam_env presets (random draws a layout)
    arena_sizes: tuple[float, ...] | None = None  # m, square arenas
    landmark_counts: tuple[int, ...] | None = None
    obstacle_counts: tuple[int, ...] | None = None  # of random worlds
    sensor_ranges: tuple[float, ...] | None = None  # m
    fovs: tuple[float, ...] | None = None  # rad

    def __post_init__(self) -> None:
        for name, kind in (
            ("presets", str),
            ("arena_sizes", float),
            ("landmark_counts", int),
            ("obstacle_counts", int),
            ("sensor_ranges", float),
            ("fovs", float),
        ):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _choices(name, value, kind))
        unknown = sorted(set(self.presets) - set(PRESETS))
        if unknown:
            raise ValueError(f"worlds.presets: unknown {unknown}; presets: {', '.join(PRESETS)}")

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> WorldDistribution:
        """From a config's ``worlds`` mapping; unknown keys are errors."""
        valid = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - valid)
        if unknown:
            raise ValueError(f"unknown worlds key(s) {unknown}; valid: {', '.join(sorted(valid))}")
        return cls(**dict(data))

    def up_to(self, share: float) -> WorldDistribution:
        """The distribution with only the smallest ``ceil(share · K)`` (at least one) of
        its K arena sizes: a curriculum's worlds at ``share`` of its ramp; itself once
        every size is in (or without arena sizes)."""
        if self.arena_sizes is None:
            return self
        sizes = sorted(self.arena_sizes)
        k = max(1, math.ceil(min(max(share, 0.0), 1.0) * len(sizes)))
        return self if k == len(sizes) else replace(self, arena_sizes=tuple(sizes[:k]))

    def _drawn_fields(self) -> dict[str, tuple]:
        """The fields that are drawn and their choices, in :data:`_ENV_KEYS`' order."""
        return {name: getattr(self, name) for name in _ENV_KEYS if getattr(self, name)}

    def sample(self, rng: np.random.Generator) -> dict[str, Any]:
        """One setting's env options (flat names), drawn from ``rng``."""
        picks = {
            name: values[int(rng.integers(len(values)))]
            for name, values in self._drawn_fields().items()
        }
        return _setting(picks)

    def check(self, env_options: Mapping[str, Any] | None = None, num_envs: int = 1) -> None:
        """``ValueError`` naming the field and the value, or the setting, that cannot run
        with ``env_options`` on ``num_envs`` sub-envs, so that no setting is dropped
        while training: each value alone against the option table, then, against the
        budget too, every preset with each other field at its smallest and its largest
        value (every figure of the budget grows or shrinks with each of them), before
        anything is built."""
        from agents.common.env import check_env_options

        choices = self._drawn_fields()
        for name, values in choices.items():
            for value in values:
                try:
                    make_config(**_setting({name: value}))
                except (TypeError, ValueError) as exc:
                    raise ValueError(f"worlds.{name} value {value!r} cannot run: {exc}") from None
        ends = [v if n == "presets" else sorted({min(v), max(v)}) for n, v in choices.items()]
        for combination in itertools.product(*ends):
            picks = dict(zip(choices, combination, strict=True))
            try:
                check_env_options({**(env_options or {}), **_setting(picks)}, num_envs)
            except ValueError as exc:
                raise ValueError(f"worlds setting {picks} cannot run: {exc}") from None


#: Each field's env options.
_ENV_KEYS: dict[str, tuple[str, ...]] = {
    "presets": ("preset",),
    "arena_sizes": ("width", "height"),  # square arenas
    "landmark_counts": ("n_landmarks",),
    "obstacle_counts": ("n_obstacles",),
    "sensor_ranges": ("max_range",),
    "fovs": ("fov",),
}


def _setting(picks: Mapping[str, Any]) -> dict[str, Any]:
    """The env options of the fields' ``picks`` (field name → value)."""
    return {key: value for name, value in picks.items() for key in _ENV_KEYS[name]}
