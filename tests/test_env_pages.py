"""The env pages of the docs are generated from the code (docs/_ext/env_pages.py):
every option of each ID, with its default, and every info key stands on its page, and
the env docstrings keep Gymnasium's fixed sections. An option added without an entry
in its table (slam_env.config.option) fails here."""

from __future__ import annotations

import dataclasses
import importlib.util
import re
from pathlib import Path

import pytest

from slam_env import config
from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.core.active_options import ActiveSLAMOptions
from slam_env.info_keys import ACTIVE_INFO, RAW_INFO

GENERATOR = Path(__file__).resolve().parents[1] / "docs" / "_ext" / "env_pages.py"
SECTIONS = ("Description", "Action Space", "Observation Space", "Rewards", "Starting State")
SECTIONS += ("Episode End", "Arguments", "Info", "Version History")


def generator():
    spec = importlib.util.spec_from_file_location("env_pages", GENERATOR)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def world_options() -> list[dataclasses.Field]:
    out = []
    for f in dataclasses.fields(config.EnvConfig):
        if f.name in ("world", "robot", "sensor", "odometry", "reward", "faults"):
            out += dataclasses.fields(f.default_factory)
        else:
            out.append(f)
    return out


@pytest.mark.parametrize("env_id", ["slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0"])
def test_every_option_and_info_key_is_on_its_page(env_id: str) -> None:
    page = generator().env_page(env_id)
    active = env_id.endswith("ActiveSLAM-v0")
    options = world_options()
    if active:
        options += [f for f in dataclasses.fields(ActiveSLAMOptions) if f.init]
        options += dataclasses.fields(ActiveSLAMRewardWeights)
    rows: dict[str, list[str]] = {}  # option name -> its rows (a name may recur)
    for line in page.splitlines():
        cells = re.split(r"(?<!\\)\|", line)  # the cells, not an escaped \|
        if line.startswith("| `") and len(cells) == 7:  # name, default, unit, limits, meaning
            rows.setdefault(cells[1].strip(), []).append(line)
    for f in options:
        assert f"`{f.name}`" in rows, f"option {f.name} has no row on the {env_id} page"
        first_word = f.metadata["doc"].split()[0]
        assert any(first_word in row for row in rows[f"`{f.name}`"]), f.name
    for key in ACTIVE_INFO if active else RAW_INFO:
        assert f"| `{key.name}` | " in page, f"info key {key.name} missing"
    for heading in SECTIONS:
        assert f"\n## {heading}\n" in page, heading
    if active:  # the ID's own defaults are the ones shown
        assert "| `scan_beams` | `16` (here)" in page and "| `bumper` | `True` (here)" in page


def test_an_option_without_its_entry_gets_no_row() -> None:
    @dataclasses.dataclass(frozen=True)
    class Sensors(config.SensorConfig):
        new_option: float = 1.0  # no option(...) entry

    fields = dataclasses.fields(Sensors)
    assert "doc" not in fields[-1].metadata
    rows = generator().option_rows(Sensors)
    assert not any("`new_option`" in row for row in rows)  # so the test above would fail


def test_the_committed_pages_are_current() -> None:
    """docs/envs/*.md are committed (GitHub shows them) and written afresh by the docs
    build; a change of an option, an info key or an env docstring regenerates them:
    ``python docs/_ext/env_pages.py``."""
    pages = generator()
    for env_id, name in (
        ("slam_env/Landmarks-v0", "landmarks"),
        ("slam_env/ActiveSLAM-v0", "active_slam"),
    ):
        committed = (pages.PAGES / f"{name}.md").read_text()
        assert committed == pages.env_page(env_id), (
            f"docs/envs/{name}.md is stale: run python docs/_ext/env_pages.py"
        )
