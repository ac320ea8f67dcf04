"""Compiled kernels of the batched core: plain numba functions over arrays with a
leading env axis.

A step of B worlds is a few calls to these kernels instead of hundreds of small numpy
calls; the single envs are the case B = 1 of the same code, and the standalone filter
(:mod:`slam_env.ekf`) runs on the same kernels.

Conventions every kernel follows:

* Per-world arrays have the env axis first: ``poses (B, 3)``, ``P (B, d, d)``,
  detections ``(B, D, 2)`` with counts ``(B,)``. Variable-size sets are padded arrays
  with counts or masks, never Python lists.
* float64 for state and geometry, int64 for indices, IDs and counts, ``np.bool_`` for
  masks, float32 only for observation outputs. Arrays are C-contiguous, so that each
  kernel compiles once.
* Outputs are preallocated by the caller and passed in; kernels allocate nothing in
  their loops and touch no Python objects.
* Related arrays and constants are grouped in NamedTuples, but a kernel called from
  Python takes their fields as a plain tuple (``tuple(named)``) and rebuilds the
  NamedTuple inside (``Geometry(*fields)``): numba types a NamedTuple argument at
  every call for ~0.3 µs a field, a plain tuple for a fifth of that, and a step is
  made of a few such calls.
* Kernels draw no random numbers: they take uniforms drawn from each sub-env's own
  ``np_random`` (see :mod:`slam_env.kernels.random`), so that every sub-env replays
  the single env with the same seed.
* Each kernel has a plain reference that the tests hold it to (the dense textbook
  filter, pymunk's own queries, the numpy code it replaced).

:func:`kernel` compiles with numba's on-disk cache, so a second process pays no
compile time; where no cache directory is writable it still works, compiling in each
process, and says so once.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import TypeVar

import numba

__all__ = ["KERNELS", "KernelCacheWarning", "inline_kernel", "kernel"]

F = TypeVar("F", bound=Callable)


class KernelCacheWarning(UserWarning):
    """numba found no writable cache directory: kernels compile in every process."""


_warned = False

KERNELS: list = []
"""The dispatchers of every kernel defined so far, for checking what was compiled."""


def kernel(fn: F) -> F:
    """``numba.njit(cache=True, nogil=True)``, falling back to an uncached compile
    (with one :class:`KernelCacheWarning` per process) where no cache directory is
    writable, e.g. a read-only install without ``NUMBA_CACHE_DIR``."""
    return _compile(fn)


def inline_kernel(fn: F) -> F:
    """:func:`kernel`, and numba also inlines it into the kernels that call it
    (``inline="always"``): for small functions that another kernel calls per item in a
    loop. A compiled call increfs and decrefs each array it is passed (each array of a
    NamedTuple too), about 10 ns apiece, which can cost more than the work itself."""
    return _compile(fn, inline="always")


def _compile(fn: F, **options: str) -> F:
    global _warned
    try:
        compiled = numba.njit(cache=True, nogil=True, **options)(fn)
    except RuntimeError as exc:  # numba: "cannot cache function ...: no locator available"
        if not _warned:
            _warned = True
            warnings.warn(
                f"slam_env: numba cannot write its cache ({exc}); kernels compile in each "
                "process. Set NUMBA_CACHE_DIR to a writable directory to keep them.",
                KernelCacheWarning,
                stacklevel=3,
            )
        compiled = numba.njit(cache=False, nogil=True, **options)(fn)
    KERNELS.append(compiled)
    return compiled
