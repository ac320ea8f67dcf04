"""The option tables (``slam_env.config.option`` fields): every option has its entry
(a meaning, a unit where it has one, its limits), the checks enforce exactly the
limits the table states, and the envs' signatures take their defaults from it."""

from __future__ import annotations

import dataclasses
import inspect

import pytest

from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.config import (
    EnvConfig,
    FaultConfig,
    OdometryConfig,
    RewardConfig,
    RobotConfig,
    SensorConfig,
    WorldConfig,
    limits_text,
)
from slam_env.core.active_options import ActiveSLAMOptions
from slam_env.envs.active_slam import ActiveSLAMEnv

TABLES = (
    WorldConfig,
    RobotConfig,
    SensorConfig,
    OdometryConfig,
    RewardConfig,
    FaultConfig,
    EnvConfig,
    ActiveSLAMOptions,
    ActiveSLAMRewardWeights,
)
SECTIONS = {"world", "robot", "sensor", "odometry", "reward", "faults"}


def entries(table: type) -> list[dataclasses.Field]:
    return [f for f in dataclasses.fields(table) if f.init and f.name not in SECTIONS]


@pytest.mark.parametrize("table", TABLES, ids=lambda t: t.__name__)
def test_every_option_has_its_entry(table: type) -> None:
    for f in entries(table):
        assert f.metadata.get("doc"), f"{table.__name__}.{f.name} has no entry in the table"
        assert "unit" in f.metadata


def bounded_cases():
    """(table, field, a value just outside, a value on an inclusive bound or inside)."""
    for table in TABLES:
        for f in entries(table):
            m = f.metadata
            if m.get("entries") or m.get("choices") or isinstance(f.default, bool):
                continue
            integer = isinstance(f.default, int) or "int" in str(f.type)
            step = 1 if integer else 1e-9
            if m.get("above") is not None:
                yield table, f.name, m["above"], m["above"] + step
            if m.get("low") is not None:
                low = int(m["low"]) if integer else m["low"]
                yield table, f.name, low - step, low
            if m.get("high") is not None:
                high = int(m["high"]) if integer else m["high"]
                yield table, f.name, high + (step if integer else 1e-6), high


CASES = list(bounded_cases())


@pytest.mark.parametrize(
    ("table", "name", "outside", "inside"),
    CASES,
    ids=[f"{t.__name__}.{n}:{o}" for t, n, o, _ in CASES],
)
def test_the_checks_hold_the_stated_limits(table, name, outside, inside) -> None:
    # The smoothing belief's options are refused with the filter's belief.
    extra = {"belief": "isam2"} if name.startswith("smoothing_") else {}
    with pytest.raises(ValueError, match=name):
        table(**{name: outside}, **extra)
    assert getattr(table(**{name: inside}, **extra), name) == inside


def test_the_limits_tested_are_the_ones_the_table_states() -> None:
    # A spot check of the words the docs print.
    fov = next(f for f in dataclasses.fields(SensorConfig) if f.name == "fov")
    assert limits_text(fov) == "in (0, 6.28319]"
    alphas = next(f for f in dataclasses.fields(OdometryConfig) if f.name == "alphas")
    assert limits_text(alphas) == "4 numbers (α1, α2, α3, α4), each >= 0"
    assert len(CASES) >= 30


@pytest.mark.parametrize("table", TABLES, ids=lambda t: t.__name__)
def test_a_choice_outside_its_list_is_refused_by_name(table: type) -> None:
    for f in entries(table):
        if f.metadata.get("choices"):
            with pytest.raises(ValueError, match=f"{f.name} must be one of"):
                table(**{f.name: "no such choice"})


def test_the_active_slam_signature_takes_its_defaults_from_the_table() -> None:
    params = inspect.signature(ActiveSLAMEnv).parameters
    for f in entries(ActiveSLAMOptions):
        assert params[f.name].default == f.default
        assert params[f.name].kind is inspect.Parameter.KEYWORD_ONLY
    names = list(params)
    assert names[0] == "render_mode" and names[-1] == "options"
    env = ActiveSLAMEnv()
    assert env.options == ActiveSLAMOptions()
