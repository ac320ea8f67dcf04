"""The native vector env on T threads: the chunks of rows, the default T, refused
thread counts, the threads (kept between steps, joined by close, ended with their
core), a chunk that raises, pickling. (The streams on 1, 2 and 3 threads are held to
the single envs' in tests/envs/test_vector.py.)"""

from __future__ import annotations

import gc
import pickle
import threading
import time

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.core.active import ActiveCore
from slam_env.core.chunks import RowThreads, chunk_sizes, rows_of
from slam_env.core.raw import RawCore
from tests.streams import digest

LANDMARKS = "slam_env/Landmarks-v0"
ACTIVE = "slam_env/ActiveSLAM-v0"
# The job each core's threads run over their chunks.
JOB = {LANDMARKS: "sense", ACTIVE: "_step_chunk"}


def native(env_id: str, num_envs: int, **kwargs):
    return gym.make_vec(
        env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs
    ).unwrapped


def test_chunks_are_contiguous_and_as_even_as_can_be() -> None:
    assert chunk_sizes(5, 1) == [5]
    assert chunk_sizes(5, 2) == [3, 2]
    assert chunk_sizes(5, 3) == [2, 2, 1]
    assert chunk_sizes(64, 5) == [13, 13, 13, 13, 12]
    assert chunk_sizes(4, 4) == [1, 1, 1, 1]
    assert RowThreads(5, 3).rows == [slice(0, 2), slice(2, 4), slice(4, 5)]
    assert RowThreads(5, 1).rows == [None]  # one chunk: the arrays themselves


def test_a_chunk_views_the_rows_with_the_array_type() -> None:
    array = np.zeros((5, 3, 2))
    view = rows_of(array, slice(2, 4))
    assert view.base is array and view.shape == (2, 3, 2) and view.flags.c_contiguous
    assert rows_of(array, None) is array


@pytest.mark.parametrize(("env_id", "kind"), [(LANDMARKS, RawCore), (ACTIVE, ActiveCore)])
def test_one_core_holds_every_sub_env_and_its_threads_split_the_rows(
    env_id: str, kind: type
) -> None:
    one = native(env_id, 5, num_threads=1)
    assert type(one.core) is kind and one.core.num_envs == 5 and one.num_threads == 1
    three = native(env_id, 5, num_threads=3)
    assert type(three.core) is kind and three.core.num_envs == 5 and three.num_threads == 3
    threads = three.core.threads if kind is RawCore else three.core.raw.threads
    assert threads.rows == [slice(0, 2), slice(2, 4), slice(4, 5)]
    three.reset(seed=0)
    assert len({id(r) for r in three.core.rngs}) == 5
    for venv in (one, three):
        venv.close()


def test_the_default_is_the_cores_the_process_may_use_with_64_envs_a_thread(
    monkeypatch,
) -> None:
    from slam_env.core.chunks import ENVS_PER_THREAD, default_threads

    # This process's affinity (pid 0), not another's.
    affinity = {0: set(range(8))}
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: affinity.get(pid, {0}), raising=False)
    assert ENVS_PER_THREAD == 64
    assert [default_threads(b) for b in (1, 5, 127, 128, 191, 192, 4096)] == [1, 1, 1, 2, 2, 3, 8]
    venv = native(LANDMARKS, 5)
    assert venv.num_threads == 1
    venv.close()
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: {0}, raising=False)
    assert default_threads(4096) == 1


@pytest.mark.parametrize(
    ("value", "error", "match"),
    [
        (0, ValueError, "from 1 to num_envs"),
        (-1, ValueError, "from 1 to num_envs"),
        (5, ValueError, r"num_envs \(4\).*got 5"),
        (10**30, ValueError, "from 1 to num_envs"),
        (2.5, TypeError, "must be an int"),
        ("2", TypeError, "must be an int"),
        (True, TypeError, "must be an int"),
    ],
)
def test_a_bad_thread_count_is_refused_clearly(value, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        native(ACTIVE, 4, num_threads=value)


def test_the_single_env_takes_no_thread_count() -> None:
    with pytest.raises(TypeError, match="num_threads"):
        gym.make(LANDMARKS, num_threads=2)


def _recording(core, name: str, seen: list, failing: list | None = None):
    """Patch the job ``name`` that ``core``'s threads run over their chunks so that it
    notes (chunk, thread) in ``seen``, and raises in chunk ``failing[0]`` once
    ``failing`` holds something."""
    job = getattr(core, name)

    def wrapped(k: int) -> None:
        seen.append((k, threading.current_thread()))
        if failing and failing[0] == k:
            raise RuntimeError(f"injected failure in chunk {k}")
        job(k)

    setattr(core, name, wrapped)


def _workers(seen: list) -> set[threading.Thread]:
    return {t for _, t in seen if t is not threading.main_thread()}


@pytest.mark.parametrize("env_id", [LANDMARKS, ACTIVE])
def test_the_chunks_step_on_worker_threads_and_close_joins_them(env_id: str) -> None:
    venv = native(env_id, 5, num_threads=3)
    seen: list = []
    core = venv.core if env_id == LANDMARKS else venv.core.raw
    _recording(venv.core, JOB[env_id], seen)
    venv.reset(seed=0)
    for _ in range(3):
        venv.step(venv.action_space.sample())
    # Chunk 0 in the calling thread, the others each on a thread of its own.
    assert {t for k, t in seen if k == 0} == {threading.main_thread()}
    one, two = ({t for k, t in seen if k == c} for c in (1, 2))
    assert len(one) == len(two) == 1 and one != two and threading.main_thread() not in one
    workers = one | two
    assert all(t.is_alive() for t in workers)  # kept between steps
    assert set(core.threads.threads) == workers
    venv.close()
    assert not any(t.is_alive() for t in workers) and core.threads.threads == []
    venv.close()  # idempotent
    seen.clear()
    venv.reset(seed=1)  # as Gymnasium's envs: reset after close works (new threads)
    venv.step(venv.action_space.sample())
    assert _workers(seen) and not workers & _workers(seen)
    venv.close()


@pytest.mark.parametrize("failing", [0, 1, 2])
def test_a_raising_chunk_surfaces_from_step_and_leaves_no_thread(failing: int) -> None:
    venv = native(ACTIVE, 5, num_threads=3)
    seen: list = []
    fail: list[int] = []
    _recording(venv.core, JOB[ACTIVE], seen, fail)
    venv.reset(seed=0)
    venv.step(venv.action_space.sample())
    fail.append(failing)
    before = len(seen)
    with pytest.raises(RuntimeError, match=f"injected failure in chunk {failing}"):
        venv.step(venv.action_space.sample())
    assert sorted(k for k, _ in seen[before:]) == [0, 1, 2]  # every chunk ran first
    workers = _workers(seen)
    assert workers and not any(t.is_alive() for t in workers)
    assert not workers & set(threading.enumerate())
    # Its sub-envs are part-way through the step: it refuses to go on until a reset.
    with pytest.raises(gym.error.ResetNeeded, match="raised part-way"):
        venv.step(venv.action_space.sample())
    with pytest.raises(gym.error.ResetNeeded):
        venv.reset(options={"reset_mask": np.array([True, False, False, False, False])})
    fail.clear()
    venv.reset(seed=0)
    venv.step(venv.action_space.sample())
    venv.close()
    venv.close()


def test_the_first_chunk_in_order_is_the_one_raised() -> None:
    threads = RowThreads(6, 3)
    done: list[int] = []

    def job(k: int) -> None:
        done.append(k)
        if k:
            raise ValueError(f"chunk {k}")

    with pytest.raises(ValueError, match="chunk 1"):
        threads.run(job)
    assert sorted(done) == [0, 1, 2] and threads.threads == []


def test_a_raising_reset_needs_a_full_reset_too() -> None:
    venv = native(LANDMARKS, 4, num_threads=2)
    fail = [1]
    _recording(venv.core, JOB[LANDMARKS], [], fail)
    with pytest.raises(RuntimeError, match="injected failure"):
        venv.reset(seed=0)
    with pytest.raises(gym.error.ResetNeeded, match="raised part-way"):
        venv.step(venv.action_space.sample())
    fail.clear()
    venv.reset(seed=0)
    venv.step(venv.action_space.sample())
    venv.close()


def test_threads_end_with_their_core_without_close() -> None:
    threads = RowThreads(4, 2)
    threads.run(lambda k: None)
    (worker,) = threads.threads
    assert worker.is_alive()
    del threads
    gc.collect()
    worker.join(timeout=10)
    assert not worker.is_alive()


@pytest.mark.parametrize("env_id", [LANDMARKS, ACTIVE])
def test_a_pickled_threaded_env_continues_identically_on_its_own_threads(env_id: str) -> None:
    venv = native(env_id, 5, num_threads=3, max_episode_steps=40)
    venv.action_space.seed(2)
    venv.reset(seed=2)
    for _ in range(30):
        venv.step(venv.action_space.sample())
    twin = pickle.loads(pickle.dumps(venv))

    def threads_of(env):
        core = env.core
        return (core if env_id == LANDMARKS else core.raw).threads

    assert twin.num_threads == 3 and threads_of(twin).threads == []  # threads not pickled
    actions = [venv.action_space.sample() for _ in range(60)]
    assert digest([venv.step(a) for a in actions]) == digest([twin.step(a) for a in actions])
    assert len(threads_of(twin).threads) == 2
    assert not set(threads_of(twin).threads) & set(threads_of(venv).threads)
    for env in (venv, twin):
        env.close()
        env.close()


def test_close_with_a_handed_job_still_pending_ends_every_thread() -> None:
    for _ in range(50):
        threads = RowThreads(8, 4)
        threads.run(lambda k: None)
        workers = list(threads._workers)
        for worker in workers:  # handed, perhaps not yet taken
            worker.hand(lambda k: None)
        threads.close()
        assert not any(w.thread.is_alive() for w in workers)


def test_a_chunk_grows_its_own_workspaces_and_keeps_the_stream() -> None:
    """Many landmarks in view at once outgrow the first workspaces (room for 8
    observations): each chunk grows its own, and the stream stays T = 1's."""
    options = {"n_landmarks": 60, "max_range": 8.0, "max_episode_steps": 100}
    runs, grown = {}, {}
    for t in (1, 2):
        venv = native(ACTIVE, 5, num_threads=t, **options)
        venv.action_space.seed(4)
        out = [venv.reset(seed=4)]
        first = [ws[0].shape[0] for ws in venv.core._workspaces]
        out += [venv.step(venv.action_space.sample()) for _ in range(250)]
        grown[t] = [
            ws[0].shape[0] > size for ws, size in zip(venv.core._workspaces, first, strict=True)
        ]
        runs[t] = digest(out)
        venv.close()
    assert runs[1] == runs[2]
    assert grown[2] == [True, True]


def test_a_failure_while_handing_out_the_jobs_waits_for_those_handed() -> None:
    threads = RowThreads(6, 3)
    threads.run(lambda k: None)
    done: list[int] = []

    def refuse(job) -> None:
        raise RuntimeError("interrupted while handing out")

    threads._workers[1].hand = refuse  # chunk 2's worker
    with pytest.raises(RuntimeError, match="interrupted while handing out"):
        threads.run(lambda k: (time.sleep(0.05), done.append(k)))
    assert done == [1]  # chunk 1 was handed and finished first; chunk 0 never started
    assert threads.threads == []
