"""Behaviour pinned bit for bit: 1,000-step streams (observations, rewards, flags,
infos) of both IDs, single and native vector, under option sets of every kind, hash to
what ``tests/pinned_streams.json`` recorded (see :mod:`tests.pinned_streams`)."""

from __future__ import annotations

import json

import pytest

from tests.pinned_streams import OPTION_SETS, PIN_FILE, machine, single_digest, vector_digest

PINS = json.loads(PIN_FILE.read_text())


def test_every_option_set_is_pinned() -> None:
    assert set(PINS["streams"]) == set(OPTION_SETS)


@pytest.mark.parametrize("name", sorted(OPTION_SETS))
@pytest.mark.parametrize("kind", ["single", "vector"])
def test_stream_hashes_to_its_pin(name: str, kind: str) -> None:
    here = machine()
    if here["cpu"] != PINS["machine"]["cpu"]:
        # Kernels compiled for another CPU may round a reassociated sum differently.
        pytest.skip(f"pinned on a {PINS['machine']['cpu']} CPU, this one is {here['cpu']}")
    env_id, options = OPTION_SETS[name]
    digest = (single_digest if kind == "single" else vector_digest)(env_id, options)
    assert digest == PINS["streams"][name][kind], f"{name} ({kind}) no longer replays its pin"
