"""Counts (episodes, steps, seeds): :func:`check_count`, the check every entry point
applies to one given in code, and argparse types for one given on a command line,
shared by the ``slam-env`` command and the benchmarks, so that a count out of range is
a usage error (exit 2) that names the flag, before anything runs."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any


def check_count(name: str, value: Any, minimum: int) -> None:
    """``ValueError`` unless ``value`` is an int (not a bool) no smaller than ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}, got {value!r}")


def int_at_least(minimum: int) -> Callable[[str], int]:
    """An argparse type: an integer no smaller than ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
        return value

    return parse


positive_int = int_at_least(1)
non_negative_int = int_at_least(0)
