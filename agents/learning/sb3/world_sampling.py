"""Training across worlds: an SB3 ``VecEnv`` that draws a new setting of a
:class:`~agents.learning.worlds.WorldDistribution` for every episode on the native
vector env.

A policy that must explore worlds it never saw is trained on many: every episode of
every group of sub-envs gets a setting drawn from a :class:`WorldDistribution` (preset,
arena side, landmark and obstacle counts, sensor range and FOV), with an episode
length that scales with the arena (:func:`episode_length`). The observation must be
one whose space does not depend on the world (``observation="local"``); a setting that
gives another space is refused.

The native vector env keeps one config for all its sub-envs, so the sub-envs are split
into ``groups`` native vector envs of ``n_envs / groups`` sub-envs each. A group's
episodes start together and the group cuts them together at their length (the time
limit is the group's, not the env's); then the group draws its next setting, builds
(or takes from a small cache) the vector env of that setting and resets it with seeds
drawn from the group's own generator: a run is the same for the same seed. A setting
whose world cannot be laid out (a random world too cluttered for its arena) is drawn
again; a setting that cannot run at all is refused up front
(:meth:`~agents.learning.worlds.WorldDistribution.check`).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices

from agents.common.episode_length import REFERENCE_ARENA, episode_length
from agents.learning.sb3.vector_env import SB3VectorEnv, make_sb3_vec_env
from agents.learning.worlds import MAX_DRAWS, WorldDistribution

# Built vector envs a group keeps for settings drawn again.
CACHED_SETTINGS = 8
# The inner vector envs' time limit: never reached, the group cuts its episodes itself.
NEVER = 2**62


def _row_of(obs: Any, k: int) -> Any:
    """Row ``k`` of a batched observation (a ``Dict``'s: every key's), fresh arrays."""
    if isinstance(obs, dict):
        return {key: value[k].copy() for key, value in obs.items()}
    return obs[k].copy()


class WorldSamplingVecEnv(VecEnv):
    """``n_envs`` sub-envs of ``env_id`` in ``groups`` native vector envs, each group on a
    world setting drawn from ``worlds`` for every episode (see the module docstring).

    Args:
        env_id: the env (its observation space must not depend on the setting).
        n_envs: sub-envs in all; a multiple of ``groups``.
        worlds: the distribution of settings.
        env_options: options every setting shares (e.g. ``observation="local"``,
            reward weights); a drawn setting overrides them.
        groups: native vector envs (default: one per sub-env, so that every sub-env
            draws its own worlds; fewer batch more sub-envs in each kernel call).
        seed: the groups' generators (and so every drawn setting and world).
        max_episode_steps: episode length; None: :func:`episode_length` of the arena.
    """

    def __init__(
        self,
        env_id: str,
        n_envs: int,
        worlds: WorldDistribution,
        env_options: Mapping[str, Any] | None = None,
        *,
        groups: int | None = None,
        seed: int = 0,
        max_episode_steps: int | None = None,
    ) -> None:
        groups = n_envs if groups is None else groups
        if groups < 1 or n_envs % groups:
            raise ValueError(f"n_envs ({n_envs}) must be a multiple of groups ({groups})")
        worlds.check(env_options, n_envs // groups)  # no setting is dropped while training
        self.env_id = env_id
        self.worlds = worlds
        self.env_options = dict(env_options or {})
        self.group_size = n_envs // groups
        self.max_episode_steps = max_episode_steps
        self._rngs = [np.random.default_rng([seed, g]) for g in range(groups)]
        self._cache: list[OrderedDict[tuple, SB3VectorEnv]] = [OrderedDict() for _ in range(groups)]
        self.settings: list[dict[str, Any]] = []  # each group's current setting
        self.episodes_drawn = 0  # settings drawn so far, over all groups
        self.lengths = np.zeros(groups, dtype=np.int64)  # each group's episode length
        self.elapsed = np.zeros(groups, dtype=np.int64)  # and its steps so far
        drawn = [self._draw(0)]
        self._envs = [drawn[0][0]]  # what VecEnv's set-up reads (render_mode)
        super().__init__(n_envs, drawn[0][0].observation_space, drawn[0][0].action_space)
        drawn += [self._draw(g) for g in range(1, groups)]
        self._envs = [env for env, _ in drawn]
        self._first = [first for _, first in drawn]  # each group's reset observation
        self._actions: np.ndarray | None = None
        self._started = False

    # ------------------------------------------------------------------ settings
    def _draw(self, group: int) -> tuple[SB3VectorEnv, Any]:
        """Group ``group``'s next setting (recorded in :attr:`settings`), its vector env
        and that env's first observation, reset with seeds from the group's generator."""
        rng = self._rngs[group]
        for _ in range(MAX_DRAWS):
            setting = self.worlds.sample(rng)
            env = self._env_for(group, setting)  # every setting runs (checked up front)
            env.seed(int(rng.integers(2**31)))
            try:
                first = env.reset()
                break
            except ValueError:
                continue  # a world that cannot be laid out (too cluttered): draw again
        else:
            raise ValueError(f"worlds: no layable setting in {MAX_DRAWS} draws from {self.worlds}")
        if group < len(self.settings):
            self.settings[group] = setting
        else:
            self.settings.append(setting)
        self.episodes_drawn += 1
        options = {**self.env_options, **setting}
        self.lengths[group] = self.max_episode_steps or episode_length(
            options.get("width", REFERENCE_ARENA), options.get("height", REFERENCE_ARENA)
        )
        self.elapsed[group] = 0
        return env, first

    def _env_for(self, group: int, setting: dict[str, Any]) -> SB3VectorEnv:
        key = tuple(sorted(setting.items()))
        cache = self._cache[group]
        if key in cache:
            cache.move_to_end(key)
            return cache[key]
        options = {**self.env_options, **setting}
        # The group cuts its episodes itself (see step_wait): the env never truncates.
        env = make_sb3_vec_env(self.env_id, self.group_size, max_episode_steps=NEVER, **options)
        if self.settings and env.observation_space != self.observation_space:
            env.close()
            raise TypeError(
                f"the observation space of setting {setting} differs from the first "
                "setting's: train across worlds on a world-independent observation "
                "(observation='local')"
            )
        cache[key] = env
        if len(cache) > CACHED_SETTINGS:
            cache.popitem(last=False)[1].close()
        return env

    # ------------------------------------------------------------------ VecEnv
    def _slices(self) -> list[slice]:
        k = self.group_size
        return [slice(g * k, (g + 1) * k) for g in range(len(self._envs))]

    def _stack(self, parts: list[Any]) -> Any:
        if isinstance(parts[0], dict):
            return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
        return np.concatenate(parts)

    def reset(self) -> Any:
        if self._started:  # a new start: every group draws again
            for g in range(len(self._envs)):
                self._envs[g], self._first[g] = self._draw(g)
        self._started = True
        obs = list(self._first)
        self.reset_infos = [row for env in self._envs for row in env.reset_infos]
        return self._stack(obs)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> tuple[Any, np.ndarray, np.ndarray, list[Any]]:
        obs, rewards, dones, infos = [], [], [], []
        for g, rows in enumerate(self._slices()):
            o, r, d, i = self._envs[g].step(self._actions[rows])
            self.elapsed[g] += 1
            if self.elapsed[g] >= self.lengths[g]:
                # The time limit: the group's episodes end together; a new setting. (An
                # episode that terminates before, with terminate_when_all_detected, is
                # reset by the env in the same world.)
                for k, row in enumerate(i):
                    if not d[k]:
                        row["terminal_observation"] = _row_of(o, k)
                        row["TimeLimit.truncated"] = True
                d = np.ones_like(d)
                self._envs[g], o = self._draw(g)
                self._first[g] = o
            obs.append(o)
            rewards.append(r)
            dones.append(d)
            infos += list(i)
        return self._stack(obs), np.concatenate(rewards), np.concatenate(dones), infos

    def close(self) -> None:
        for cache in self._cache:
            for env in cache.values():
                env.close()
            cache.clear()

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [frame for env in self._envs for frame in env.get_images()]

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        last = len(self._envs) - 1
        return [
            getattr(self._envs[min(i // self.group_size, last)].venv, attr_name)
            for i in self._get_indices(indices)
        ]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        raise AttributeError(f"cannot set {attr_name!r}: the sub-envs' worlds are drawn")

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any
    ) -> list[Any]:
        raise AttributeError(f"cannot call {method_name!r} per sub-env of a native vector env")

    def env_is_wrapped(self, wrapper_class: type, indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]
