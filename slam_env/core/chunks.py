"""B sub-envs' rows as T contiguous chunks, and the T - 1 threads that step all but the
first concurrently with the caller: how the native vector env uses T threads.

One core holds every sub-env's rows; a step's Python (the robots' moves, the resets,
the infos) runs once, in the calling thread, and only its compiled stages are split:
thread k runs them over chunk k's rows, views of the core's (B, …) arrays, with
scratch of its own (every kernel is compiled ``nogil``), and the little Python they
hand back for those rows (a block of uniforms to refill, a kidnapping, a workspace to
grow). A row is one sub-env's and
nothing a kernel computes for it depends on another row, so sub-env b's stream is the
single env's whatever T is.
"""

from __future__ import annotations

import contextlib
import os
import threading
import weakref
from collections.abc import Callable
from itertools import pairwise
from typing import Any

import numpy as np

__all__ = [
    "ENVS_PER_THREAD",
    "RowThreads",
    "chunk_sizes",
    "default_threads",
    "rows_of",
    "thread_count",
]


# The fewest sub-envs a thread is given by default. Below it a second thread saves
# little or nothing: on the 2-core development machine T = 2 stepped ActiveSLAM-v0 at
# 0.95-1.11x T = 1's rate at B = 64, 1.22-1.26x at 128 and 1.26-1.51x at 256
# (benchmarks/bench_env.py --threads 1 2). The step's Python runs once, in one thread,
# and each of two chunks' kernels running at once took 60-80% longer than alone.
ENVS_PER_THREAD = 64


def default_threads(num_envs: int) -> int:
    """The cores this process may run on (its CPU affinity), but no more than give
    each thread :data:`ENVS_PER_THREAD` sub-envs."""
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


def rows_of(array: np.ndarray, rows: slice | None) -> np.ndarray:
    """``array``'s rows ``rows`` (a view, of the same numba type as ``array``: a slice
    of a C-contiguous array's first axis is C-contiguous), ``array`` itself for None
    (every row)."""
    return array if rows is None else array[rows]


class _Worker:
    """One thread that runs ``job(k)`` each time it is handed a job, for its chunk k."""

    def __init__(self, k: int) -> None:
        self.k = k
        self._go = threading.Lock()  # released: a job (or the stop) is handed
        self._go.acquire()
        self._done = threading.Lock()
        self._done.acquire()
        self._job: Callable[[int], Any] | None = None
        self._error: BaseException | None = None
        self.thread = threading.Thread(target=self._loop, name=f"slam_env-chunk-{k}", daemon=True)
        self.thread.start()

    def _loop(self) -> None:
        while True:
            self._go.acquire()
            job, self._job = self._job, None
            if job is None:  # stop
                return
            try:
                job(self.k)
            except BaseException as exc:  # handed to the caller by wait()
                self._error = exc
            finally:
                del job  # the job's owner is not kept alive by an idle thread
                self._done.release()

    def hand(self, job: Callable[[int], Any]) -> None:
        self._job = job
        self._go.release()

    def wait(self) -> BaseException | None:
        """Wait for the job handed last; what it raised, if anything."""
        self._done.acquire()
        error, self._error = self._error, None
        return error

    def stop(self) -> None:
        """End the thread once its job (if any) is done, and join it."""
        self._job = None
        # A handed job still pending (the lock already released): the thread takes it
        # as the stop.
        with contextlib.suppress(RuntimeError):
            self._go.release()
        if self.thread is not threading.current_thread():  # a finalizer run by it
            self.thread.join()


def _stop_all(workers: list[_Worker]) -> None:
    for worker in workers:
        worker.stop()
    workers.clear()


class RowThreads:
    """The rows of ``num_envs`` sub-envs as ``num_threads`` contiguous chunks
    (:attr:`rows`, their sizes :func:`chunk_sizes`; None, every row, for one chunk),
    and the threads that run a job over them: :meth:`run` calls ``job(k)`` for every
    chunk k concurrently, chunk 0 in the calling thread, the others on T - 1 threads
    made at the first run and kept until :meth:`close` (which joins them; a later run
    makes new ones). Threads are not pickled: a copy makes its own."""

    def __init__(self, num_envs: int, num_threads: int) -> None:
        sizes = chunk_sizes(num_envs, num_threads)
        starts = np.concatenate([[0], np.cumsum(sizes)]).tolist()
        self.count = num_threads
        self.rows: list[slice | None] = (
            [None] if num_threads == 1 else [slice(a, b) for a, b in pairwise(starts)]
        )
        self._workers: list[_Worker] = []

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in ("_workers", "_finalizer")}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._workers = []

    def run(self, job: Callable[[int], Any]) -> None:
        """``job(k)`` for every chunk k, concurrently; returns when all are done. If any
        raised, the threads are joined and the first exception (in chunk order) is
        raised."""
        if self.count == 1:
            job(0)
            return
        workers = self._workers or self._start_workers()
        failure: BaseException | None = None
        handed: list[_Worker] = []
        try:
            for worker in workers:
                worker.hand(job)
                handed.append(worker)
            job(0)
        except BaseException as exc:  # raised once the handed chunks are done
            failure = exc
        try:
            for worker in handed:  # every chunk done before anything returns or raises
                error = worker.wait()
                failure = failure or error
        except BaseException:  # interrupted while waiting: the threads are stopped
            self.close()
            raise
        if failure is not None:
            self.close()
            raise failure

    def _start_workers(self) -> list[_Worker]:
        self._workers = [_Worker(k) for k in range(1, self.count)]
        # A core dropped without close() still ends its threads.
        self._finalizer = weakref.finalize(self, _stop_all, self._workers)
        return self._workers

    @property
    def threads(self) -> list[threading.Thread]:
        """The worker threads alive now (none before the first run or after close)."""
        return [w.thread for w in self._workers]

    def close(self) -> None:
        """Join the threads (idempotent; a later run makes new ones)."""
        workers, self._workers = self._workers, []
        _stop_all(workers)
