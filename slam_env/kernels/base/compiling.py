"""How the kernels are compiled: :func:`kernel` and its variants, and numba's on-disk
cache.

:func:`kernel` compiles with numba's on-disk cache, so a second process pays no
compile time; where no cache directory is writable it still works, compiling in each
process, and says so once. numba checks a cached kernel against its own source file
only, not against the kernels it calls from other files, so the cache lives in a
directory named by a hash of every source of the kernels' tree (:func:`cache_directory`):
an edit to any of them starts a fresh cache rather than running stale code. Every
compiled function of ``slam_env`` lives under ``slam_env/kernels``, so that tree is the
one hashed; a kernel defined elsewhere (a planner's, in ``agents``) gets a cache of its
own, named by a hash of its own folder.

Inside that directory each source folder's entries sit under its path relative to the
tree (:class:`TreeCacheLocator`), not under a hash of its absolute path as numba's own
locator puts them, so the cache stays valid when the tree moves: a wheel's build
compiles the kernels into the package (``python -m slam_env.warm_kernels``), and the
installed package finds them.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numba
from numba.core.caching import UserProvidedCacheLocator

__all__ = [
    "KERNELS",
    "KernelCacheWarning",
    "TreeCacheLocator",
    "borrowing_kernel",
    "cache_directory",
    "inline_kernel",
    "kernel",
    "kernel_counts",
    "summing_kernel",
]

F = TypeVar("F", bound=Callable)


class KernelCacheWarning(UserWarning):
    """numba found no writable cache directory: kernels compile in every process."""


_warned = False

KERNELS: list = []
"""The dispatchers of every kernel defined so far, for checking what was compiled."""


# The tree that holds every compiled function of slam_env.
KERNEL_TREE = Path(__file__).resolve().parents[1]


def sources_hash(folder: Path) -> str:
    """A short hash of the sources under ``folder`` (every ``*.py``, recursively, by
    its path relative to ``folder``)."""
    digest = hashlib.sha256()
    for path in sorted(folder.rglob("*.py")):
        name = path.relative_to(folder).as_posix()
        digest.update(name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / f".probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError:
        return False
    return True


def tree_of(source: str | Path) -> Path:
    """The folder whose sources name the cache of a kernel defined in ``source``:
    :data:`KERNEL_TREE` for slam_env's kernels, else the file's own folder."""
    source = Path(source).resolve()
    return KERNEL_TREE if KERNEL_TREE in source.parents else source.parent


def cache_directory(tree: Path = KERNEL_TREE) -> str | None:
    """Where the numba cache of the kernels of ``tree`` lives: ``numba-<hash of its
    sources>`` under ``$NUMBA_CACHE_DIR`` if set, else under the tree's ``__pycache__``,
    else under ``~/.cache/slam_env``; ``None`` if none is writable. In the tree's own
    ``__pycache__``, the caches of earlier versions of its sources are removed (they
    can never be used again); shared places are left as they are."""
    name = f"numba-{sources_hash(tree)}"
    own = tree / "__pycache__"
    roots = [Path(numba.config.CACHE_DIR)] if numba.config.CACHE_DIR else []
    roots += [own, Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "slam_env"]
    for root in roots:
        if _writable(root / name):
            if root == own:
                for old in root.glob("numba-*"):
                    if old.name != name:
                        shutil.rmtree(old, ignore_errors=True)
                for stale in (*root.glob("*.nbi"), *root.glob("*.nbc")):  # numba's own
                    stale.unlink(missing_ok=True)
            return str(root / name)
    return None


_CACHES: dict[Path, str | None] = {}  # tree -> its cache directory, found once


def _cache_of(fn: Callable) -> str | None:
    tree = tree_of(fn.__code__.co_filename)
    if tree not in _CACHES:
        _CACHES[tree] = cache_directory(tree)
    return _CACHES[tree]


class TreeCacheLocator(UserProvidedCacheLocator):
    """numba's locator for a user cache directory, with each source folder's entries
    under its path relative to the kernels' tree (``ekf``, ``base``, …) instead of a
    hash of its absolute path: the same entries wherever the tree is installed."""

    @classmethod
    def get_suitable_cache_subpath(cls, py_file: str) -> str:
        folder = Path(py_file).resolve().parent
        relative = folder.relative_to(tree_of(py_file)).as_posix()
        return "tree" if relative == "." else relative.replace("/", "_")


_LOCATOR = f"{__name__}.{TreeCacheLocator.__name__}"


@contextlib.contextmanager
def _caching_in(cache: str) -> Iterator[None]:
    """numba's user cache directory set to ``cache``, and its locator to
    :class:`TreeCacheLocator`, while a kernel is declared (numba reads both then), and
    put back afterwards, for other libraries' caches."""
    before = numba.config.CACHE_DIR, getattr(numba.config, "CACHE_LOCATOR_CLASSES", None)
    numba.config.CACHE_DIR = cache
    if before[1] is not None:  # numba >= 0.62; older ones keep their own locator
        numba.config.CACHE_LOCATOR_CLASSES = _LOCATOR
    try:
        yield
    finally:
        numba.config.CACHE_DIR = before[0]
        if before[1] is not None:
            numba.config.CACHE_LOCATOR_CLASSES = before[1]


def kernel_counts() -> dict[str, int]:
    """What numba has done in this process for the kernels used so far: how many
    ``kernels`` and ``specialisations`` (signatures), and how many of those it
    ``compiled`` and ``loaded`` from its cache."""
    used = [k for k in KERNELS if k.signatures]
    return {
        "kernels": len(used),
        "specialisations": sum(len(k.signatures) for k in used),
        "compiled": sum(sum(k.stats.cache_misses.values()) for k in used),
        "loaded": sum(sum(k.stats.cache_hits.values()) for k in used),
    }


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


def borrowing_kernel(fn: F) -> F:
    """:func:`kernel` compiled without numba's reference counting (``_nrt=False``), for
    kernels that allocate nothing and return no array: every array they touch is one
    the caller passed, and the caller keeps it alive for the call. With counting, each
    array a compiled function is passed, and each view it keeps across blocks, costs an
    atomic increment and decrement (about 6 ns each): some 380 of them in one EKF step
    of 5 corrections, a quarter of its time at N = 20. And each array a call from Python
    passes is wrapped for the counting (about 80 ns: 3.4 µs of the 43 arrays of
    :func:`~slam_env.kernels.stream.raw_step.raw_step`'s call). A kernel that allocates cannot
    be compiled this way (numba refuses it when it compiles): its scratch comes from the
    caller."""
    return _compile(fn, _nrt=False)


def summing_kernel(fn: F) -> F:
    """:func:`kernel` whose floating-point sums may be reassociated and contracted
    (numba's ``fastmath={"reassoc", "contract"}``, nothing about NaN or infinities), so
    that LLVM vectorises its inner products: for kernels whose time is one serial chain
    of additions, like the Cholesky factorisation (2.3× faster at 43 × 43). The results
    differ from a serial sum in the last bits, the same on every run of a machine."""
    return _compile(fn, fastmath={"reassoc", "contract"})


def _compile(fn: F, **options: Any) -> F:
    global _warned
    try:
        cache = _cache_of(fn)
        if cache is None:
            raise RuntimeError("no writable cache directory")
        with _caching_in(cache):
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
