"""Swept-area memory as a wrapper, for users' own stacks over ``slam_env/Landmarks-v0``
(``slam_env/ActiveSLAM-v0`` computes the same in its core)."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from slam_env.belief.coverage import COVERAGE_CELL, CoverageGrid

__all__ = ["CoverageWrapper"]


class CoverageWrapper(gym.ObservationWrapper):
    """Adds swept-area memory to a belief observation (an :class:`EKFSLAMWrapper`
    below it supplies the estimated pose; ``slam_env/ActiveSLAM-v0`` stacks it by
    default).

    The landmark sensor's footprint (its FOV, and its range less one cell, so a cell
    counts as swept only well inside it) is swept into a :class:`CoverageGrid` from the
    filter's pose on reset and after every step. The observation gains 1 + 8·3 float32
    features in [0, 1]: the share of the arena swept so far, then the unswept share per
    45° sector around the estimated heading (sector 0 ahead, counter-clockwise) in the
    rings 0–R, R–2R and beyond 2R, R the sensor range. They are appended to a ``Box``
    observation, or are the ``coverage`` key of a ``Dict`` one. ``info`` gains
    ``swept_fraction``.

    Args:
        env: an env with an :class:`EKFSLAMWrapper` in its stack.
        cell: m, the grid's cell side.
    """

    def __init__(self, env: gym.Env, cell: float = COVERAGE_CELL) -> None:
        super().__init__(env)
        try:
            self._filter = env.get_wrapper_attr("filter")
        except AttributeError:
            raise TypeError("CoverageWrapper must wrap an EKFSLAMWrapper (no filter)") from None
        base = env.unwrapped
        sensor = base.config.sensor
        width, height = base.arena_size
        self.grid = CoverageGrid.for_sensor(width, height, sensor, cell=cell)
        n = 1 + self.grid.n_features
        space = gym.spaces.Box(0.0, 1.0, (n,), np.float32)
        inner = env.observation_space
        if isinstance(inner, gym.spaces.Dict):
            self.observation_space = gym.spaces.Dict({**inner.spaces, "coverage": space})
        elif isinstance(inner, gym.spaces.Box) and len(inner.shape) == 1:
            self.observation_space = gym.spaces.Box(
                np.concatenate([inner.low, space.low]),
                np.concatenate([inner.high, space.high]),
                dtype=np.float32,
            )
        else:
            raise TypeError(f"CoverageWrapper needs a flat Box or Dict observation, got {inner}")

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        self.grid.reset()
        return self._observe(obs, info)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        obs, info = self._observe(obs, info)
        return obs, reward, terminated, truncated, info

    def observation(self, observation: Any) -> Any:
        """``observation`` with the current coverage features (no sweep)."""
        return self._attach(observation, self.grid.coverage(self._pose()))

    def _observe(self, obs: Any, info: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
        coverage = self.grid.sweep_and_cover(self._pose())
        info["swept_fraction"] = self.grid.swept_fraction
        return self._attach(obs, coverage), info

    def _pose(self) -> np.ndarray:
        """The filter's mean (1, dmax), the pose first: a view of its belief."""
        return self._filter.belief_batch().x

    @staticmethod
    def _attach(obs: Any, coverage: np.ndarray) -> Any:
        """``obs`` with the float64 ``coverage`` features rounded to float32."""
        if isinstance(obs, dict):
            return {**obs, "coverage": coverage.astype(np.float32)}
        return np.concatenate((obs, coverage), dtype=np.float32)  # rounds on the way
