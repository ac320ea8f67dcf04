"""The README's Python snippets, and those of every page of the documentation in
``docs/``, run as written (docs that match the code)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SNIPPET = re.compile(r"```python\n(.*?)```", flags=re.S)
SNIPPETS = SNIPPET.findall(README.read_text())
DOC_SNIPPETS = [
    (page.relative_to(ROOT).as_posix(), index, code)
    for page in sorted((ROOT / "docs").rglob("*.md"))
    if "_build" not in page.parts
    for index, code in enumerate(SNIPPET.findall(page.read_text()))
]


def run_snippet(code: str, cwd: Path) -> subprocess.CompletedProcess:
    # Each snippet runs on its own, in a fresh interpreter, as a reader would paste it,
    # on this checkout's code (not whichever copy the interpreter has installed).
    path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    return subprocess.run(
        [sys.executable, "-c", code],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": path},
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_readme_has_snippets():
    assert len(SNIPPETS) >= 3


@pytest.mark.parametrize("index", range(len(SNIPPETS)))
def test_readme_snippet_runs(index, tmp_path):
    result = run_snippet(SNIPPETS[index], tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]


def test_the_docs_have_snippets():
    assert len(DOC_SNIPPETS) >= 5


@pytest.mark.parametrize(
    ("page", "index", "code"), DOC_SNIPPETS, ids=[f"{p}:{i}" for p, i, _ in DOC_SNIPPETS]
)
def test_docs_snippet_runs(page, index, code, tmp_path):
    result = run_snippet(code, tmp_path)
    assert result.returncode == 0, f"{page}, snippet {index}: {result.stderr[-2000:]}"
