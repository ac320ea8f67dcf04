"""A pinned kernel is the kernel: the same results for the types it was pinned to,
compiled by the pin when it never ran, and plain Python where numba does not compile."""

from __future__ import annotations

import numpy as np
import pytest

from slam_env.kernels.base.compiling import kernel
from slam_env.kernels.base.pinning import pin


@kernel
def _scaled_sum(values: np.ndarray, weights: tuple, scale: float, out: np.ndarray) -> int:
    """``out[i] = scale · Σ_k weights[k][i] · values[i]``; returns how many are > 0."""
    positive = 0
    for i in range(values.shape[0]):
        total = 0.0
        for w in weights:
            total += w[i] * values[i]
        out[i] = scale * total
        positive += out[i] > 0.0
    return positive


def _arguments(rng: np.random.Generator):
    values = rng.normal(size=7)
    weights = (rng.normal(size=7), rng.normal(size=7))
    return values, weights, 1.5, np.zeros(7)


def test_a_pinned_kernel_gives_the_kernels_results() -> None:
    rng = np.random.default_rng(0)
    args = _arguments(rng)
    pinned = pin(_scaled_sum, *args)
    for _ in range(3):
        values, weights, scale, out = _arguments(rng)  # new arrays of the same types
        expected = np.zeros_like(out)
        count = _scaled_sum(values, weights, scale, expected)
        assert pinned(values, weights, scale, out) == count
        assert out.tolist() == expected.tolist()


def test_pinning_compiles_a_kernel_that_never_ran() -> None:
    @kernel
    def doubled(values: np.ndarray) -> float:
        return 2.0 * values.sum()

    assert doubled.signatures == []
    pinned = pin(doubled, np.ones(3))
    assert len(doubled.signatures) == 1
    assert pinned(np.arange(4.0)) == 12.0


def test_a_plain_function_is_its_own_pin() -> None:
    def plain(x: float) -> float:
        return x + 1.0

    assert pin(plain, 1.0) is plain


def test_pins_are_kept_by_their_argument_types(monkeypatch) -> None:
    """Pinning again to arguments of the types already seen types nothing (a copied
    filter pins in microseconds); arguments of another type get their own code."""
    rng = np.random.default_rng(1)
    args = _arguments(rng)
    first = pin(_scaled_sum, *args)
    readonly = args[0].copy()
    readonly.flags.writeable = False

    def no_typing(value):
        raise AssertionError(f"typed again: {value!r}")

    with monkeypatch.context() as patched:
        patched.setattr(_scaled_sum, "typeof_pyval", no_typing)
        assert pin(_scaled_sum, *_arguments(rng)) is first
        with pytest.raises(AssertionError, match="typed again"):
            pin(_scaled_sum, readonly, *args[1:])
    other = pin(_scaled_sum, readonly, *args[1:])
    assert other is not first
    out, expected = np.zeros(7), np.zeros(7)
    assert other(readonly, args[1], 2.0, out) == _scaled_sum(readonly, args[1], 2.0, expected)
    assert out.tolist() == expected.tolist()


@kernel
def _length_times(text: str, factor: float) -> float:
    return len(text) * factor


def test_an_argument_without_a_fingerprint_is_typed_at_every_pin(monkeypatch) -> None:
    """numba cannot fingerprint a string: such a pin types its arguments every time
    (and keeps nothing), and its code is still the kernel's."""
    typed = []
    typeof = _length_times.typeof_pyval

    def counted(value):
        typed.append(value)
        return typeof(value)

    monkeypatch.setattr(_length_times, "typeof_pyval", counted)
    first = pin(_length_times, "abc", 2.0)
    second = pin(_length_times, "wxyz", 0.5)
    assert typed == ["abc", 2.0, "wxyz", 0.5]
    assert first("abcd", 1.5) == second("abcd", 1.5) == 6.0
