"""Shared fixtures and helpers for the test suite."""

from __future__ import annotations

import os

import pytest

from slam_env.world.layouts import Layout

# Rendering tests run headless.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def layout() -> Layout:
    """A small hand-made world: 10 × 8 m, three landmarks, a box and an inner wall."""
    return Layout(
        width=10,
        height=8,
        landmark_ids=(0, 1, 2),
        landmark_positions=((2, 2), (5, 6), (8, 3)),
        obstacles=(((4, 1), (5, 1), (5, 2), (4, 2)),),
        walls=((6, 0, 6, 4),),
        start_pose=(1, 1, 0),
    )


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests marked ``rllib`` need Ray RLlib, which the default install lacks: they run
    only when the marker expression names them (``-m rllib``, ``make test-rllib``), and
    are deselected (not skipped) otherwise, so the default suite never needs Ray."""
    if "rllib" in (config.option.markexpr or ""):
        return
    needs_ray = [item for item in items if item.get_closest_marker("rllib") is not None]
    if needs_ray:
        config.hook.pytest_deselected(items=needs_ray)
        items[:] = [item for item in items if item.get_closest_marker("rllib") is None]
