"""Shared fixtures and helpers for the test suite."""

from __future__ import annotations

import os

# Rendering tests run headless.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
os.environ.setdefault("MPLBACKEND", "Agg")
