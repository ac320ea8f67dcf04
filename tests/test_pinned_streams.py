"""Behaviour pinned bit for bit: 1,000-step streams (observations, rewards, flags,
infos) of both IDs, single and native vector, under option sets of every kind, hash to
what ``tests/pinned_streams.json`` recorded for this machine's CPU (see
:mod:`tests.pinned_streams`)."""

from __future__ import annotations

import json

import pytest

from tests.pinned_streams import (
    OPTION_SETS,
    PIN_FILE,
    machine,
    pins_for,
    single_digest,
    vector_digest,
)

CPUS = json.loads(PIN_FILE.read_text())["by_cpu"]


def test_every_option_set_is_pinned_on_some_cpu() -> None:
    pinned = set().union(*(entry["streams"] for entry in CPUS.values()))
    assert pinned == set(OPTION_SETS)


@pytest.mark.parametrize("name", sorted(OPTION_SETS))
@pytest.mark.parametrize("kind", ["single", "vector"])
def test_stream_hashes_to_its_pin(name: str, kind: str) -> None:
    cpu = machine()["cpu"]
    pins = pins_for(cpu)
    if pins is None or name not in pins:
        # Kernels compiled for another CPU may round a reassociated sum differently.
        pytest.skip(f"{name} is pinned on {sorted(CPUS)} CPUs only, this one is {cpu}")
    env_id, options = OPTION_SETS[name]
    digest = (single_digest if kind == "single" else vector_digest)(env_id, options)
    assert digest == pins[name][kind], f"{name} ({kind}) no longer replays its pin on {cpu}"
