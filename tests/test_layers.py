"""The import contracts of ``pyproject.toml`` (import-linter's ``lint-imports``, which
``make lint`` and CI run): the tree keeps them, and each kind of break fails them. The
breaks are made in a copy of the tree."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")


def lint_imports(tree: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(tree))  # the copy's packages, not the install
    return subprocess.run(
        [str(LINT_IMPORTS), "--no-cache"],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    for name in ("slam_env", "agents"):
        shutil.copytree(ROOT / name, tmp_path / name, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path)
    return tmp_path


def add_line(path: Path, line: str) -> None:
    path.write_text(path.read_text() + f"\n{line}\n")


def test_the_tree_keeps_every_contract() -> None:
    done = lint_imports(ROOT)
    assert done.returncode == 0, done.stdout
    assert "BROKEN" not in done.stdout and " KEPT" in done.stdout


@pytest.mark.parametrize(
    ("file", "line", "contract"),
    [
        # A kernel reaching up into the envs.
        (
            "slam_env/kernels/base/angles.py",
            "import slam_env.envs.single  # noqa",
            "The layers of slam_env, and agents above them BROKEN",
        ),
        # The world reading the belief, one layer above it.
        (
            "slam_env/world/frames.py",
            "from slam_env.belief import metrics  # noqa",
            "The layers of slam_env, and agents above them BROKEN",
        ),
        # A stream kernel importing a belief kernel.
        (
            "slam_env/kernels/stream/odometry.py",
            "from slam_env.kernels.belief import reward  # noqa",
            "The kernels' layers BROKEN",
        ),
        # A planner importing the evaluation.
        (
            "agents/planners/grid_map.py",
            "import agents.evaluation.compare  # noqa",
            "The agents' layers BROKEN",
        ),
        # A circle inside one layer: the metrics importing the entropy, which imports
        # the metrics.
        (
            "slam_env/belief/metrics.py",
            "import slam_env.belief.entropy  # noqa",
            "No circles",
        ),
        # The filter importing gymnasium.
        ("slam_env/ekf/chi2.py", "import gymnasium  # noqa", "The filter stands alone"),
        # The env importing torch.
        ("slam_env/core/raw.py", "import torch  # noqa", "slam_env imports no agent's library"),
        # pygame outside slam_env.render.
        ("slam_env/envs/single.py", "import pygame  # noqa", "picture libraries BROKEN"),
    ],
)
def test_a_deliberate_violation_fails_its_contract(tree: Path, file: str, line: str, contract):
    add_line(tree / file, line)
    done = lint_imports(tree)
    assert done.returncode == 1, done.stdout
    assert contract in done.stdout, done.stdout
