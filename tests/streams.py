"""Helpers that turn an env rollout into a comparable digest."""

from __future__ import annotations

import hashlib
from typing import Any

import gymnasium as gym
import numpy as np


def _feed(h: hashlib._Hash, value: Any) -> None:
    if isinstance(value, dict):
        for key in sorted(value):
            h.update(str(key).encode())
            _feed(h, value[key])
    elif isinstance(value, np.ndarray) and value.dtype == object:
        for item in value.ravel().tolist():  # e.g. vector envs' final_obs/final_info
            _feed(h, item)
    elif isinstance(value, np.ndarray):
        h.update(str(value.dtype).encode() + str(value.shape).encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (list, tuple)):
        for item in value:
            _feed(h, item)
    else:
        h.update(repr(value).encode())


def digest(*values: Any) -> str:
    """A hash over observations, rewards, flags and infos, bit-exact."""
    h = hashlib.sha256()
    for value in values:
        _feed(h, value)
    return h.hexdigest()


def rollout_digest(
    env_id: str, seed: int, steps: int, action_seed: int = 123, **kwargs: Any
) -> str:
    """Digest of a seeded rollout with seeded random actions."""
    import slam_env  # noqa: F401  (registers the env IDs)

    env = gym.make(env_id, **kwargs)
    env.action_space.seed(action_seed)
    h = hashlib.sha256()
    obs, info = env.reset(seed=seed)
    _feed(h, (obs, info))
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        _feed(h, (obs, reward, terminated, truncated, info))
        if terminated or truncated:
            obs, info = env.reset()
            _feed(h, (obs, info))
    env.close()
    return h.hexdigest()


def pickled_twin_digests(env_id: str, seed: int, warmup: int, **kwargs: Any) -> tuple[str, str]:
    """Run ``warmup`` seeded random steps, pickle the env, then feed the same 100
    actions to the original and the copy: the digests of both continuations."""
    import pickle

    import slam_env  # noqa: F401  (registers the env IDs)

    env = gym.make(env_id, **kwargs)
    env.action_space.seed(seed)
    env.reset(seed=seed)
    for _ in range(warmup):
        env.step(env.action_space.sample())
    twin = pickle.loads(pickle.dumps(env))
    actions = [env.action_space.sample() for _ in range(100)]
    return digest([env.step(a) for a in actions]), digest([twin.step(a) for a in actions])


def assert_same(a: Any, b: Any, where: str = "", exact_types: bool = True) -> None:
    """Two rollouts' values (dicts, lists and tuples of arrays and scalars) equal bit
    for bit, of the same dtypes and, with ``exact_types``, the same Python types (a
    vector env's row of an info holds numpy scalars where the single env's holds
    Python ones); ``where`` names the first difference."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), (where, sorted(set(a) ^ set(b)))
        for key in a:
            assert_same(a[key], b[key], f"{where}/{key}", exact_types)
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{i}]", exact_types)
    else:
        assert not exact_types or type(a) is type(b), (where, type(a), type(b))
        a, b = np.asarray(a), np.asarray(b)
        assert a.dtype == b.dtype and np.array_equal(a, b), (where, a, b)
