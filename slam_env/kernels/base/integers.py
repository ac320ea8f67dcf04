"""The largest integer an option or a filter argument may take.

The kernels hold integers as int64 and pass options through float64 parameter
columns (:mod:`slam_env.kernels.ekf.codes`); 2**53 is the largest integer both hold
exactly. A larger Python int would make numpy build an object array, which no kernel
compiles for, so every integer is refused beyond it before it reaches one."""

from __future__ import annotations

MAX_INTEGER = 2**53
MAX_INTEGER_TEXT = "2**53"  # how the checks' messages and the docs write it
