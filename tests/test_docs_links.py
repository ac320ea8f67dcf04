"""Every relative link of the README and of every page of the documentation
(``docs/**/*.md``) leads somewhere: the file exists, and a ``#fragment`` names a heading
of it (as GitHub spells heading anchors, which the site's ``myst_heading_anchors`` also
follows)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [
    ROOT / "README.md",
    ROOT / "CHANGELOG.md",
    *sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.relative_to(DOCS).parts),
]
LINK = re.compile(r"\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", flags=re.S | re.M)


def heading_anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation but ``-`` and ``_``
    dropped, each space a hyphen."""
    text = heading.strip().lower().replace("`", "")
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    text = FENCE.sub("", page.read_text())
    return {heading_anchor(m) for m in re.findall(r"^#+ (.+)$", text, flags=re.M)}


def relative_links(page: Path) -> list[str]:
    text = FENCE.sub("", page.read_text())
    return [t for t in LINK.findall(text) if not re.match(r"[a-z]+:", t)]


def test_heading_anchor_spells_as_github_does():
    assert heading_anchor("The revisits' round, kept") == "the-revisits-round-kept"
    assert (
        heading_anchor("`slam_env/Landmarks-v0` — the raw sensor stream")
        == "slam_envlandmarks-v0--the-raw-sensor-stream"
    )


def test_the_pages_link_to_each_other():
    assert any("docs/research/goal_policy.md" in t for t in relative_links(ROOT / "README.md"))
    assert any("docs/benchmarks.md" in t for t in relative_links(ROOT / "README.md"))


def test_every_page_is_checked():
    # The README, the changelog and every page of the site, the research record's too.
    names = {p.relative_to(ROOT).as_posix() for p in PAGES}
    assert {"README.md", "docs/index.md", "docs/research/goal_policy.md"} <= names
    assert {"docs/envs/landmarks.md", "docs/envs/active_slam.md"} <= names


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_resolves(page: Path):
    broken = []
    for target in relative_links(page):
        path, _, fragment = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            broken.append(f"{target}: no file {dest}")
        elif fragment and dest.suffix == ".md" and fragment not in anchors(dest):
            broken.append(f"{target}: no heading #{fragment} in {dest.name}")
    assert not broken, broken
