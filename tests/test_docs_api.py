"""The API reference (docs/api/) documents every module of slam_env and agents: a new
module needs its ``automodule`` entry on its package's page."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
API = ROOT / "docs" / "api"


def modules() -> set[str]:
    found = set()
    for package in ("slam_env", "agents"):
        for path in (ROOT / package).rglob("*.py"):
            if path.name == "__main__.py":
                continue
            parts = path.relative_to(ROOT).with_suffix("").parts
            found.add(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return found


def documented() -> set[str]:
    text = "\n".join(page.read_text() for page in API.glob("*.md"))
    return set(re.findall(r"^\.\. automodule:: (\S+)$", text, flags=re.M))


def test_every_module_has_an_api_entry():
    assert modules() - documented() == set()


def test_every_api_entry_is_a_module():
    assert documented() - modules() == set()
