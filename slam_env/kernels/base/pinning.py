"""A kernel's compiled code for one fixed set of argument types, called without
numba's dispatch.

At every call numba's dispatcher types each argument to pick the compiled code, about
0.1 µs an array; a core's step passes the same few dozen arrays to the same kernel at
every step, so that typing costs more than the kernel's work. :func:`pin` does it
once: it returns the compiled code for the types of the arguments it is shown, which
the caller then calls with arguments of exactly those types.

The compiled code trusts its arguments: one of another type is undefined behaviour,
not an error. So a caller pins only arguments that cannot change type (arrays it owns
and never replaces, Python scalars of fixed type), and pins again when it replaces one.

Typing an argument in Python (numba's ``typeof``) and looking up the compiled code
cost tens of microseconds an array, so the pins are kept by numba's own fingerprint
of each argument's type (the key of its dispatcher's cache of argument types): pinning
again to arguments of types already seen (a copied filter, a grown workspace) costs
a fraction of a microsecond an argument. For arrays a fingerprint is at least as fine
as numba's type (it also tells read-only and unaligned arrays apart); all Python ints
share one, so a pinned int is an int64 (a larger one is refused by the call with an
``OverflowError``). An argument without a fingerprint (a string) is typed at every pin.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

try:  # numba's own, private: without it every pin types its arguments in Python
    from numba._dispatcher import compute_fingerprint
except ImportError:  # pragma: no cover (another numba)

    def compute_fingerprint(value: Any) -> Any:
        raise NotImplementedError


_PINNED: dict[tuple[Any, ...], Callable[..., Any]] = {}


def pin(kernel: Callable[..., Any], *args: Any) -> Callable[..., Any]:
    """``kernel``'s compiled code for the numba types of ``args`` (compiled or loaded
    from the cache now if need be), to be called with arguments of exactly these
    types; ``kernel`` itself where it is not compiled (numba's JIT disabled)."""
    compile_for = getattr(kernel, "compile", None)
    if compile_for is None:
        return kernel
    try:
        key: tuple[Any, ...] | None = (kernel, *map(compute_fingerprint, args))
    except NotImplementedError:  # a value numba's dispatcher types the slow way too
        key = None
    compiled = _PINNED.get(key) if key is not None else None
    if compiled is None:
        compiled = compile_for(tuple(kernel.typeof_pyval(arg) for arg in args))
        if key is not None:
            _PINNED[key] = compiled
    return compiled
