"""A Gymnasium vector env as a stable-baselines3 ``VecEnv``.

stable-baselines3 steps its own ``VecEnv`` interface, not Gymnasium's ``VectorEnv``:
:class:`SB3VectorEnv` adapts slam_env's native vector envs (one process steps all the
sub-envs, far cheaper than one process per env) so that SB3's algorithms, wrappers
(``VecMonitor``, ``VecNormalize``) and callbacks take them as they take a
``DummyVecEnv`` of the same single envs, with the same results for the same seeds:

    from agents.learning.sb3.vector_env import make_sb3_vec_env
    venv = make_sb3_vec_env("slam_env/ActiveSLAM-v0", n_envs=8, seed=0)
    model = PPO("MlpPolicy", VecMonitor(venv)).learn(10_000)

Conventions are SB3's: a sub-env that ends is reset in the same step, its last
observation in ``infos[i]["terminal_observation"]``, ``infos[i]["TimeLimit.truncated"]``
set when the episode was cut by the time limit, the reset's info in ``reset_infos``;
rewards are float32. Per-step infos are read lazily from the vector info (a sub-env's
row is materialised only for the keys read), which keeps them cheap.
"""

from __future__ import annotations

from collections.abc import MutableMapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices

import slam_env  # noqa: F401  (registers the env IDs)
from agents.common.info_rows import InfoRow

# Where a SAME_STEP vector env reports an episode's last observation and info.
_FINAL_KEYS = ("final_obs", "final_info")


class SB3VectorEnv(VecEnv):
    """A Gymnasium ``VectorEnv`` with ``AutoresetMode.SAME_STEP`` (slam_env's native
    vector envs) behind stable-baselines3's ``VecEnv`` interface."""

    def __init__(self, venv: gym.vector.VectorEnv) -> None:
        if venv.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
            raise ValueError(
                "SB3VectorEnv needs a vector env with autoreset_mode=AutoresetMode.SAME_STEP "
                "(SB3 resets a finished env within the step), got "
                f"{venv.metadata.get('autoreset_mode')}"
            )
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions: np.ndarray | None = None

    def reset(self) -> Any:
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        if any(self._options):
            raise ValueError("slam_env envs take no reset options")
        obs, info = self.venv.reset(seed=seeds)
        self.reset_infos = [dict(InfoRow(info, i)) for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> tuple[Any, np.ndarray, np.ndarray, list[MutableMapping]]:
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = terminated | truncated
        infos: list[MutableMapping] = [InfoRow(info, i) for i in range(self.num_envs)]
        for i in np.flatnonzero(dones).tolist():
            # SB3's step info of a finished env is its last one; the reset's goes aside.
            self.reset_infos[i] = {k: v for k, v in infos[i].items() if k not in _FINAL_KEYS}
            final = InfoRow(info["final_info"], i)
            final["terminal_observation"] = info["final_obs"][i]
            infos[i] = final
        for i, row in enumerate(infos):
            row["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        frames = self.venv.render()
        return [None] * self.num_envs if frames is None else list(frames)

    # The sub-envs of a native vector env are rows of arrays, not objects: attributes
    # are the vector env's own, the same for every index.
    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        raise AttributeError(
            f"cannot set {attr_name!r} per sub-env: a native vector env's sub-envs share "
            "one config; make a new env instead"
        )

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any
    ) -> list[Any]:
        raise AttributeError(
            f"cannot call {method_name!r} per sub-env: a native vector env has no sub-env objects"
        )

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


def make_sb3_vec_env(
    env_id: str, n_envs: int, seed: int | None = None, **env_options: Any
) -> SB3VectorEnv:
    """The native vector env of ``env_id`` with ``n_envs`` sub-envs as an SB3 ``VecEnv``
    (sub-env i seeded ``seed + i`` at the first reset, as ``make_vec_env`` seeds)."""
    venv = gym.make_vec(
        env_id,
        num_envs=n_envs,
        vectorization_mode="vector_entry_point",
        autoreset_mode=AutoresetMode.SAME_STEP,
        **env_options,
    )
    sb3 = SB3VectorEnv(venv)
    if seed is not None:
        sb3.seed(seed)
    return sb3
