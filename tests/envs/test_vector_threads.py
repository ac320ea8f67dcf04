"""The native vector env on T threads: its chunks, the default T, refused thread
counts. (The streams on 1, 2 and 3 threads are held to the single envs' in
tests/envs/test_vector.py.)"""

from __future__ import annotations

import gymnasium as gym
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.core.active import ActiveCore
from slam_env.core.chunks import ChunkedCore, chunk_sizes
from slam_env.core.raw import RawCore

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


def test_the_default_is_the_cores_the_process_may_use_at_most_b(monkeypatch) -> None:
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: set(range(8)), raising=False)
    assert native(LANDMARKS, 5).num_threads == 5
    assert native(LANDMARKS, 12).num_threads == 8
    assert native(LANDMARKS, 1).num_threads == 1
    monkeypatch.setattr("os.sched_getaffinity", lambda pid: {0}, raising=False)
    venv = native(LANDMARKS, 4)
    assert venv.num_threads == 1 and isinstance(venv.core, RawCore)


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
