"""The native vector env on T threads: its chunks, the default T, refused thread
counts, the threads (a pool kept between steps, joined by close), a chunk that
raises, pickling. (The streams on 1, 2 and 3 threads are held to the single envs' in
tests/envs/test_vector.py.)"""

from __future__ import annotations

import pickle
import threading

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.core.active import ActiveCore
from slam_env.core.chunks import ChunkedCore, chunk_sizes
from slam_env.core.raw import RawCore
from tests.streams import digest

LANDMARKS = "slam_env/Landmarks-v0"
ACTIVE = "slam_env/ActiveSLAM-v0"


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


@pytest.mark.parametrize(("env_id", "kind"), [(LANDMARKS, RawCore), (ACTIVE, ActiveCore)])
def test_each_thread_steps_a_core_of_its_own_over_its_chunk(env_id: str, kind: type) -> None:
    one = native(env_id, 5, num_threads=1)
    assert type(one.core) is kind and one.core.num_envs == 5 and one.num_threads == 1
    three = native(env_id, 5, num_threads=3)
    assert isinstance(three.core, ChunkedCore) and three.num_threads == 3
    assert [type(c) for c in three.core.cores] == [kind] * 3
    assert [c.num_envs for c in three.core.cores] == [2, 2, 1]
    assert three.core.starts == [0, 2, 4, 5]
    # Nothing a step writes is shared between chunks: their own worlds, generators.
    worlds = [c.worlds for c in three.core.cores]
    assert len({id(w) for w in worlds}) == 3
    assert len({id(w.poses) for w in worlds}) == 3
    three.reset(seed=0)
    assert len({id(r) for r in three.core.rngs}) == 5
    assert three.core.locate(3) == (three.core.cores[1], 1)
    for venv in (one, three):
        venv.close()


def test_the_default_is_the_cores_the_process_may_use_with_128_envs_a_thread(
    monkeypatch,
) -> None:
    from slam_env.core.chunks import ENVS_PER_THREAD, default_threads

    monkeypatch.setattr("os.sched_getaffinity", lambda pid: set(range(8)), raising=False)
    assert ENVS_PER_THREAD == 128
    assert [default_threads(b) for b in (1, 5, 255, 256, 383, 384, 4096)] == [1, 1, 1, 2, 2, 3, 8]
    venv = native(LANDMARKS, 5)
    assert venv.num_threads == 1 and isinstance(venv.core, RawCore)
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


def _recording(core, seen: list, failing: list | None = None):
    """``core.advance`` that notes the thread it runs on, and raises once ``failing``
    holds something."""
    advance = core.advance

    def wrapped(*args):
        seen.append(threading.current_thread())
        if failing:
            raise RuntimeError("injected failure in a chunk")
        return advance(*args)

    return wrapped


@pytest.mark.parametrize("env_id", [LANDMARKS, ACTIVE])
def test_the_chunks_step_on_pool_threads_and_close_joins_them(env_id: str) -> None:
    venv = native(env_id, 5, num_threads=3)
    seen: list[list[threading.Thread]] = [[], [], []]
    for core, threads in zip(venv.core.cores, seen, strict=True):
        core.advance = _recording(core, threads)
    venv.reset(seed=0)
    for _ in range(3):
        venv.step(venv.action_space.sample())
    # Chunk 0 in the calling thread, the others on the pool's (at most T - 1) threads.
    assert set(seen[0]) == {threading.main_thread()}
    workers = set(seen[1] + seen[2])
    assert threading.main_thread() not in workers and 1 <= len(workers) <= 2
    assert all(t.is_alive() for t in workers)  # the pool is kept between steps
    venv.close()
    assert not any(t.is_alive() for t in workers)
    venv.close()  # idempotent
    venv.reset(seed=1)  # as Gymnasium's envs: reset after close works (new threads)
    venv.step(venv.action_space.sample())
    assert not workers & set(seen[1][-1:] + seen[2][-1:])
    venv.close()


@pytest.mark.parametrize("failing", [0, 1, 2])
def test_a_raising_chunk_surfaces_from_step_and_leaves_no_thread(failing: int) -> None:
    venv = native(ACTIVE, 5, num_threads=3)
    seen: list[threading.Thread] = []
    fail: list[bool] = []
    for k, core in enumerate(venv.core.cores):
        core.advance = _recording(core, seen, fail if k == failing else None)
    venv.reset(seed=0)
    venv.step(venv.action_space.sample())
    fail.append(True)
    before = len(seen)
    with pytest.raises(RuntimeError, match="injected failure"):
        venv.step(venv.action_space.sample())
    assert len(seen) == before + 3  # every chunk ran before step raised
    workers = {t for t in seen if t is not threading.main_thread()}
    assert workers
    alive = set(threading.enumerate())
    assert not workers & alive and not any(t.is_alive() for t in workers)
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


def test_a_raising_reset_needs_a_full_reset_too() -> None:
    venv = native(LANDMARKS, 4, num_threads=2)
    fail = [True]
    core = venv.core.cores[1]
    core.advance = _recording(core, [], fail)
    with pytest.raises(RuntimeError, match="injected failure"):
        venv.reset(seed=0)
    with pytest.raises(gym.error.ResetNeeded, match="raised part-way"):
        venv.step(venv.action_space.sample())
    fail.clear()
    venv.reset(seed=0)
    venv.step(venv.action_space.sample())
    venv.close()


@pytest.mark.parametrize("env_id", [LANDMARKS, ACTIVE])
def test_a_pickled_threaded_env_continues_identically_on_its_own_threads(env_id: str) -> None:
    venv = native(env_id, 5, num_threads=3, max_episode_steps=40)
    venv.action_space.seed(2)
    venv.reset(seed=2)
    for _ in range(30):
        venv.step(venv.action_space.sample())
    twin = pickle.loads(pickle.dumps(venv))
    assert twin.num_threads == 3 and twin.core._pool is None  # threads are not pickled
    actions = [venv.action_space.sample() for _ in range(60)]
    assert digest([venv.step(a) for a in actions]) == digest([twin.step(a) for a in actions])
    assert twin.core._pool is not venv.core._pool
    for env in (venv, twin):
        env.close()
        env.close()
