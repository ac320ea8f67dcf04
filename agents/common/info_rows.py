"""One sub-env's row of a Gymnasium vector info, read on demand (what the single env
would have given), for the SB3 adapter and the batched episodes alike."""

from __future__ import annotations

from collections.abc import Iterator, MutableMapping
from typing import Any

import numpy as np


def _row(value: Any, index: int) -> Any:
    """Sub-env ``index``'s entry of a vector-info value, as the single env gives it."""
    if isinstance(value, dict):
        return {
            k: _row(v, index)
            for k, v in value.items()
            if not k.startswith("_") and value[f"_{k}"][index]
        }
    item = value[index]
    if isinstance(item, np.ndarray):
        return item.copy()
    return item.item() if isinstance(item, np.generic) else item


_MISSING = object()  # a key this row does not have


class InfoRow(MutableMapping):
    """One sub-env's info, read on demand from a Gymnasium vector info: the keys its
    ``_key`` masks say it reported, values as the single env gives them (fresh arrays,
    Python scalars). Writes (SB3's ``terminal_observation``, ``episode``) stay local."""

    def __init__(self, vector_info: dict[str, Any], index: int) -> None:
        self._vector = vector_info
        self._index = index
        self._own: dict[str, Any] = {}
        self._deleted: set[str] = set()

    @property
    def vector_info(self) -> dict[str, Any]:
        """The vector info this row reads (shared by the rows of one step), so that a
        reader of many rows can take a key's (B,) array in one go."""
        return self._vector

    @property
    def index(self) -> int:
        """The sub-env this row reads in :attr:`vector_info`."""
        return self._index

    def _reported(self) -> list[str]:
        info, i = self._vector, self._index
        return [
            k for k in info if not k.startswith("_") and k not in self._deleted and info[f"_{k}"][i]
        ]

    def _lookup(self, key: str) -> Any:
        """``key``'s value, or :data:`_MISSING` where this row has no such key."""
        if key in self._own:
            return self._own[key]
        info = self._vector
        if key in self._deleted or key.startswith("_") or key not in info:
            return _MISSING
        if not info[f"_{key}"][self._index]:
            return _MISSING
        return _row(info[key], self._index)

    def __getitem__(self, key: str) -> Any:
        value = self._lookup(key)
        if value is _MISSING:
            raise KeyError(key)
        return value

    def get(self, key: str, default: Any = None) -> Any:
        # Without the KeyError that Mapping.get catches: SB3 asks every row of every
        # step for keys it rarely has ("episode", "terminal_observation").
        value = self._lookup(key)
        return default if value is _MISSING else value

    def __setitem__(self, key: str, value: Any) -> None:
        self._own[key] = value
        self._deleted.discard(key)

    def __delitem__(self, key: str) -> None:
        if key in self._own:
            del self._own[key]
        elif key in self._reported():
            self._deleted.add(key)
        else:
            raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        yield from self._reported()
        yield from (k for k in self._own if k not in self._vector)

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def copy(self) -> dict[str, Any]:
        """A plain dict of everything (what SB3's wrappers copy and extend)."""
        return dict(self.items())

    def __repr__(self) -> str:
        return f"InfoRow({self.copy()!r})"
