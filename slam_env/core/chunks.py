"""B sub-envs as T batched cores over contiguous slices of them, offering one core's
interface, stepped concurrently: what the native vector env steps on T threads.

Each chunk is a core of its own (its own arrays, worlds, pymunk spaces, filters and
the generators of its sub-envs), so that chunks share nothing that a step writes: sub-env
b of chunk k is row ``b - start_k`` of that core, and its stream is the single env's,
whatever T is. :meth:`ChunkedCore.advance` steps the chunks and gathers what the
vector env reads at every step (rewards, terminated) into preallocated (B,) arrays;
observations and infos are stacked from the chunks when they are asked for.

The chunks step concurrently: chunk 0 in the calling thread, the others in a persistent
pool of T - 1 threads, while the compiled kernels run without the GIL (every kernel
is compiled ``nogil``); the Python between the kernel calls (pymunk's settling, the
resets' new worlds, the calls' glue) still takes turns on the GIL.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import numpy as np

from slam_env.core.batch import BatchCore
from slam_env.world.layouts import Layout

__all__ = ["ENVS_PER_THREAD", "ChunkedCore", "chunk_sizes", "default_threads", "thread_count"]


# The fewest sub-envs a thread is given by default. Below it the threads' hand-offs of
# the GIL between the kernel calls cost more than they save: on an idle 2-core machine
# T = 2 stepped ActiveSLAM-v0 at 0.66× T = 1's rate at B = 64, 0.71× at 128, 1.23× at
# 256 and 1.30× at 512 (benchmarks/bench_env.py --threads 1 2).
ENVS_PER_THREAD = 128


def default_threads(num_envs: int) -> int:
    """The cores this process may run on (its CPU affinity), but no more than give
    each thread :data:`ENVS_PER_THREAD` sub-envs: 1 below 256 sub-envs."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # no affinity on this OS (macOS, Windows)
        cores = os.cpu_count() or 1
    return max(1, min(cores, num_envs // ENVS_PER_THREAD))


def thread_count(num_threads: Any, num_envs: int) -> int:
    """``num_threads`` checked against ``num_envs`` (B): an int from 1 to B, or None
    for :func:`default_threads`; ``TypeError``/``ValueError`` otherwise."""
    if num_threads is None:
        return default_threads(num_envs)
    if isinstance(num_threads, bool) or not isinstance(num_threads, (int, np.integer)):
        raise TypeError(
            f"num_threads must be an int from 1 to num_envs ({num_envs}) or None (the "
            f"default), got {type(num_threads).__name__} {num_threads!r}"
        )
    if not 1 <= num_threads <= num_envs:
        raise ValueError(
            f"num_threads must be from 1 to num_envs ({num_envs}): each thread steps at "
            f"least one sub-env; got {num_threads}"
        )
    return int(num_threads)


def chunk_sizes(num_envs: int, num_chunks: int) -> list[int]:
    """The sizes of ``num_chunks`` contiguous chunks of ``num_envs`` sub-envs, as even as
    can be (the first ones one larger)."""
    small, larger = divmod(num_envs, num_chunks)
    return [small + (k < larger) for k in range(num_chunks)]


def _stacked(parts: Sequence[Any]) -> Any:
    """The chunks' (B_k, …) arrays (or nested dicts of them) stacked into (B, …)."""
    first = parts[0]
    if isinstance(first, dict):
        return {key: _stacked([part[key] for part in parts]) for key in first}
    return np.concatenate(parts)


class _Rows:
    """A per-sub-env list of the chunks' (their ``rngs``) read and written by sub-env
    index, as one list of B."""

    def __init__(self, owner: ChunkedCore, name: str) -> None:
        self._owner, self._name = owner, name

    def __len__(self) -> int:
        return self._owner.num_envs

    def __getitem__(self, index: int) -> Any:
        core, row = self._owner.locate(index)
        return getattr(core, self._name)[row]

    def __setitem__(self, index: int, value: Any) -> None:
        core, row = self._owner.locate(index)
        getattr(core, self._name)[row] = value

    def __iter__(self) -> Iterator[Any]:
        for core in self._owner.cores:
            yield from getattr(core, self._name)


class ChunkedCore:
    """The cores ``cores`` (each a :class:`~slam_env.core.raw.RawCore` or each an
    :class:`~slam_env.core.active.ActiveCore`, of one config) as one core of their
    sub-envs in order: chunk k holds sub-envs ``starts[k]`` to ``starts[k + 1] - 1``.

    It offers what the vector env and its pictures use of a core: :meth:`advance`
    (each chunk its slice of the arguments), :attr:`rewards` and :attr:`terminated`
    (gathered), :meth:`observations` and :meth:`infos` (stacked, fresh arrays), and one
    sub-env's :meth:`observation`, :meth:`info`, :meth:`filter`, :meth:`frame`, ...
    from its chunk.
    """

    def __init__(self, cores: Sequence[BatchCore]) -> None:
        if not cores:
            raise ValueError("a ChunkedCore needs at least one core")
        self.cores = list(cores)
        sizes = [core.num_envs for core in self.cores]
        self.starts = np.concatenate([[0], np.cumsum(sizes)]).tolist()
        self.num_envs = b = self.starts[-1]
        first = self.cores[0]
        self.config = first.config
        self.observation_space = first.observation_space
        # Which chunk each sub-env is in, and its row there.
        self._chunk_of = np.repeat(np.arange(len(sizes)), sizes).tolist()
        self.rewards = np.zeros(b)
        self.terminated = np.zeros(b, dtype=bool)
        self.rngs = _Rows(self, "rngs")
        self._pool: ThreadPoolExecutor | None = None  # made at the first step

    # The pool's threads are not pickled: a copy makes its own at its first step.
    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k != "_pool"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._pool = None

    def close(self) -> None:
        """Join the pool's threads (idempotent; a later step makes new ones)."""
        pool, self._pool = self._pool, None
        if pool is not None:
            pool.shutdown(wait=True)

    def locate(self, index: int) -> tuple[Any, int]:
        """The core of sub-env ``index`` and its row there."""
        k = self._chunk_of[index]
        return self.cores[k], index - self.starts[k]

    # ------------------------------------------------------------------ stepping
    def advance(
        self, commands: np.ndarray, stepping: np.ndarray, resetting: Sequence[int]
    ) -> list[Layout]:
        """:meth:`RawCore.advance <slam_env.core.raw.RawCore.advance>` of every chunk
        over its slice of ``commands`` ((B, 2)) and ``stepping`` ((B,) bool) and its
        sub-envs of ``resetting``; then their rewards and flags gathered. Returns the new
        episodes' layouts, in the order of ``resetting``."""
        calls = self._calls(commands, stepping, resetting)
        for k, _, chunk_stepping, _ in calls:  # every chunk, before any of them steps
            self.cores[k].check_room(chunk_stepping)
        made = self._run(calls)
        by_sub_env: dict[int, Layout] = {}
        for (_, _, _, rows), layouts in zip(calls, made, strict=True):
            by_sub_env.update(zip(rows, layouts, strict=True))
        return [by_sub_env[b] for b in resetting]

    def _calls(
        self, commands: np.ndarray, stepping: np.ndarray, resetting: Sequence[int]
    ) -> list[tuple[int, np.ndarray, np.ndarray, list[int]]]:
        """Each chunk's call: its index, its commands, its stepping mask and the global
        indices of its sub-envs that reset."""
        starts = self.starts
        resetting = [int(b) for b in resetting]
        calls = []
        for k in range(len(self.cores)):
            lo, hi = starts[k], starts[k + 1]
            rows = [b for b in resetting if lo <= b < hi]
            calls.append((k, commands[lo:hi], stepping[lo:hi], rows))
        return calls

    def _advance_chunk(
        self, k: int, commands: np.ndarray, stepping: np.ndarray, rows: list[int]
    ) -> list[Layout]:
        """Chunk k's step; its rewards and flags into its slice of the gathered arrays
        (no other chunk writes there)."""
        core, lo = self.cores[k], self.starts[k]
        layouts = core.advance(commands, stepping, [b - lo for b in rows])
        hi = self.starts[k + 1]
        np.copyto(self.rewards[lo:hi], core.rewards)
        np.copyto(self.terminated[lo:hi], core.terminated)
        return layouts

    def _run(self, calls: list[tuple[Any, ...]]) -> list[list[Layout]]:
        """Every chunk's call, concurrently: the first in this thread, the others in
        the pool. Returns when all are done; if any raised, the pool's threads are
        joined and the first chunk's exception (in chunk order) is raised."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(
                max_workers=len(calls) - 1, thread_name_prefix="slam_env-chunk"
            )
        futures: list[Future] = [self._pool.submit(self._advance_chunk, *c) for c in calls[1:]]
        results: list[Any] = []
        failure: BaseException | None = None
        try:
            results.append(self._advance_chunk(*calls[0]))
        except BaseException as exc:  # re-raised once the other chunks are done
            failure = exc
        try:
            for future in futures:  # every chunk done before anything returns or raises
                exc = future.exception()
                failure = failure or exc
                results.append(None if exc else future.result())
        except BaseException:  # interrupted while waiting: the workers finish first
            self.close()
            raise
        if failure is not None:
            self.close()
            raise failure
        return results

    # ------------------------------------------------------------------ reading
    def observations(self) -> Any:
        """Every sub-env's observation, stacked (B, …), fresh arrays."""
        return _stacked([core.observations() for core in self.cores])

    def infos(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Every sub-env's info, stacked (B, …), fresh arrays, and the masks of the keys
        that not every sub-env reports (see the cores' ``infos``)."""
        parts = [core.infos() for core in self.cores]
        return _stacked([p[0] for p in parts]), _stacked([p[1] for p in parts])

    def observation(self, index: int) -> Any:
        core, row = self.locate(index)
        return core.observation(row)

    def info(self, index: int) -> dict[str, Any]:
        core, row = self.locate(index)
        return core.info(row)

    def filter(self, index: int) -> Any:
        core, row = self.locate(index)
        return core.filter(row)

    def smoother(self, index: int) -> Any:
        core, row = self.locate(index)
        return core.smoother(row)

    def belief_overlay(self, index: int, *args: Any) -> Any:
        core, row = self.locate(index)
        return core.belief_overlay(row, *args)

    def frame(self, index: int, trail: Any, belief: Any = None) -> Any:
        core, row = self.locate(index)
        return core.frame(row, trail, belief)

    def true_pose(self, index: int) -> np.ndarray:
        core, row = self.locate(index)
        return core.true_pose(row)

    def layout(self, index: int) -> Layout:
        core, row = self.locate(index)
        return core.layout(row)

    def __getattr__(self, name: str) -> Any:
        # What every chunk has alike (n_landmarks, n_slots, arena_size, ...): the first's.
        if name in _SHARED:
            return getattr(self.cores[0], name)
        raise AttributeError(f"{type(self).__name__} has no attribute {name!r}")


# The cores' attributes that are the same for every chunk (they depend on the config).
_SHARED = frozenset(
    {"has_belief", "n_landmarks", "n_slots", "arena_size", "max_detections", "beam_angles"}
)
