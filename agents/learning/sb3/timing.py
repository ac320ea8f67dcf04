"""Where the wall time of a training run goes: env stepping against gradient updates.

:class:`StepTimer` wraps the training ``VecEnv`` and adds up the time spent in its
``step_wait`` (every env step of every sub-env, with any wrappers beneath it);
:class:`UpdateTimer` times an algorithm's ``train()`` (the gradient updates on a
rollout) the same way (:class:`TimedPPO`). :func:`time_shares` turns both into shares
of a wall time; what is left is the policy's forward passes while collecting,
callbacks and logging.
"""

from __future__ import annotations

import time
from typing import Any

from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper


class StepTimer(VecEnvWrapper):
    """A ``VecEnv`` that passes everything through and keeps :attr:`seconds`, the wall
    time spent in the wrapped env's ``step_wait``."""

    def __init__(self, venv: VecEnv) -> None:
        super().__init__(venv)
        self.seconds = 0.0

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> Any:
        start = time.perf_counter()
        out = self.venv.step_wait()
        self.seconds += time.perf_counter() - start
        return out


class UpdateTimer:
    """A mixin for a stable-baselines3 on-policy algorithm that keeps
    :attr:`update_seconds`, the wall time spent in ``train()``, the gradient updates on
    each rollout. It saves and loads as the algorithm does (its ``load`` reads the
    files)."""

    update_seconds = 0.0

    def train(self) -> None:
        start = time.perf_counter()
        try:
            super().train()
        finally:
            self.update_seconds += time.perf_counter() - start

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "update_seconds"]


class TimedPPO(UpdateTimer, PPO):
    """stable-baselines3's PPO with :class:`UpdateTimer` (``PPO.load`` reads its files)."""


def time_shares(wall: float, env_step: float, updates: float) -> dict[str, float | None]:
    """Seconds and shares of ``wall`` spent stepping the envs and in the gradient
    updates, and the share of the rest; shares are None for a zero wall time."""
    rest = max(wall - env_step - updates, 0.0)
    shares = {
        "env_step_s": round(env_step, 3),
        "gradient_updates_s": round(updates, 3),
        "env_step_share": None,
        "gradient_updates_share": None,
        "other_share": None,
    }
    if wall > 0:
        shares["env_step_share"] = round(env_step / wall, 4)
        shares["gradient_updates_share"] = round(updates / wall, 4)
        shares["other_share"] = round(rest / wall, 4)
    return shares
