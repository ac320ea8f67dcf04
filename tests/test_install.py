"""The wheel's build compiles the default kernels (``setup.py`` runs
``slam_env.envs.warm_kernels``), so its build environment must hold every dependency
of the core; ``make test-core`` checks that a fresh install's first step compiles
nothing (``tests/core_install.py``)."""

from __future__ import annotations

from pathlib import Path

import tomllib
from packaging.requirements import Requirement

PYPROJECT = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())


def test_the_build_requires_every_core_dependency_as_the_install_does() -> None:
    build = {Requirement(r).name: Requirement(r) for r in PYPROJECT["build-system"]["requires"]}
    for text in PYPROJECT["project"]["dependencies"]:
        needed = Requirement(text)
        assert needed.name in build, f"the build does not install {needed.name}"
        assert build[needed.name].specifier == needed.specifier, needed.name
