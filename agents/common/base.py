"""The agent interface, the base of the untrained agents, and the simplest agent."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import gymnasium as gym
import numpy as np


@runtime_checkable
class Agent(Protocol):
    """Anything with stable-baselines3's ``predict``: SB3 models and our heuristics.

    Heuristic agents reset their per-episode memory when ``episode_start`` is true
    (the evaluator passes ``True`` on the first step of every episode).
    """

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, Any]: ...


class ScriptedAgent:
    """Base of the agents that are not trained: SB3's ``predict`` around :meth:`_action`.

    They act on the env they were made with, not on ``observation``, and pass
    ``state`` through unchanged.
    """

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, Any]:
        return self._action(episode_start), state

    def _action(self, episode_start: Any) -> np.ndarray:
        """The next action; ``episode_start`` as SB3 passes it (None, bool or array)."""
        raise NotImplementedError


class RandomAgent(ScriptedAgent):
    """Uniform random actions from the env's action space, seeded explicitly."""

    def __init__(self, env: gym.Env, seed: int | None = None) -> None:
        self.action_space = env.action_space
        self.rng = np.random.default_rng(seed)

    def _action(self, episode_start: Any) -> np.ndarray:
        space = self.action_space
        if isinstance(space, gym.spaces.Discrete):
            return np.int64(self.rng.integers(space.n))
        return self.rng.uniform(space.low, space.high).astype(space.dtype)
