"""``slam_env/ActiveSLAM-v0``: the raw env behind the EKF-SLAM wrapper and the
active-SLAM reward, as one ``gymnasium.Env``.

The registered env is a thin :class:`gymnasium.Env` that owns the wrapper stack
``LandmarksEnv → EKFSLAMWrapper → CoverageWrapper → ActiveSLAMReward`` and delegates to
it, so that the env checkers see an unwrapped env and users reach the filter as
``env.unwrapped.filter``.
Users who want the wrappers on their own env use them directly.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from slam_env.active_options import ACTIVE_SLAM_DEFAULTS, DEFAULT_SCAN_BEAMS, ActiveSLAMOptions
from slam_env.budget import check_budget, world_size
from slam_env.config import check_option_names, make_config, with_defaults
from slam_env.coverage import CoverageWrapper
from slam_env.ekf import EKFSLAM
from slam_env.env import ENV_ARGUMENTS, LandmarksEnv, check_reset_options
from slam_env.wrappers import (
    DEFAULT_GATE,
    ActiveSLAMReward,
    ActiveSLAMRewardWeights,
    EKFSLAMWrapper,
)

__all__ = ["DEFAULT_SCAN_BEAMS", "ActiveSLAMEnv"]


class ActiveSLAMEnv(gym.Env):
    """Active SLAM: act on the EKF-SLAM belief, be paid for reducing its uncertainty.

    The world, robot, sensors and episode end are those of
    :class:`slam_env.env.LandmarksEnv`; the observation is the belief of
    :class:`slam_env.wrappers.EKFSLAMWrapper` with the swept-area memory of
    :class:`slam_env.coverage.CoverageWrapper`, and the reward that of
    :class:`slam_env.wrappers.ActiveSLAMReward` (terms in ``info["reward_terms"]``).

    ## Arguments
    ``observation`` (``"egocentric"`` | ``"full"``), ``correction`` (``"sequential"`` |
    ``"batch"``), ``gate`` (χ² threshold or ``None``), ``filter_alphas``,
    ``filter_control_noise``, ``filter_measurement_cov`` (a mismatched filter; default:
    the env's true noise), ``reward_weights`` (an :class:`ActiveSLAMRewardWeights` or a
    dict of its fields), ``coverage`` (default ``True``: a
    :class:`slam_env.coverage.CoverageWrapper` adds the swept-area features, which a
    policy needs to know where it has not looked yet); every other option goes to
    :class:`LandmarksEnv`, where ``scan_beams`` defaults to 16 and ``bumper`` to
    ``True`` here: a policy needs to see obstacles, which the landmark map does not
    hold, and to feel when one blocks it (a corner can hide between two beams). The
    egocentric observation is the belief features, then the scan and the bumper, then
    the coverage features; the full one holds them as the ``scan``, ``bumper`` and
    ``coverage`` keys. These defaults hold whichever form the world's options take
    (``fov=2.5`` or ``sensor={"fov": 2.5}``); a whole ``config`` is taken as it is.
    Options are checked (types, numpy scalars, the resource budget of
    :mod:`slam_env.budget`) before anything is built.

    ## Info
    The raw env's, then the belief's diagnostics (see
    :class:`slam_env.wrappers.EKFSLAMWrapper`), ``swept_fraction`` and the reward
    terms. A numerical breakdown of the filter is reported as ``diverged``, never
    raised out of ``step``. ``info`` never holds NaN: a metric that is undefined is
    absent, so ``map_rmse`` appears with the first landmark in the belief (read it with
    ``info.get``). Absent rather than a sentinel: equal runs give equal infos, no
    made-up value slips into an average, and Gymnasium's vector envs mark the sub-envs
    that did not report it (``info["_map_rmse"]``).
    """

    metadata = LandmarksEnv.metadata

    def __init__(
        self,
        render_mode: str | None = None,
        observation: str = "egocentric",
        correction: str = "sequential",
        gate: float | None = DEFAULT_GATE,
        filter_alphas: tuple[float, float, float, float] | None = None,
        filter_control_noise: tuple[float, float, float, float] | None = None,
        filter_measurement_cov: np.ndarray | None = None,
        reward_weights: ActiveSLAMRewardWeights | Mapping[str, float] | None = None,
        coverage: bool = True,
        **env_options: Any,
    ) -> None:
        opts = ActiveSLAMOptions(
            observation,
            correction,
            gate,
            filter_alphas,
            filter_control_noise,
            filter_measurement_cov,
            reward_weights,
            coverage,
        )
        check_option_names(env_options, ENV_ARGUMENTS + _OWN_ARGUMENTS)
        env_options = with_defaults(env_options, ACTIVE_SLAM_DEFAULTS)
        config = make_config(env_options.pop("config", None), **env_options)
        # Everything that scales work or memory, before any of it is built.
        check_budget(
            config,
            world_size(config),
            belief=opts.observation,
            coverage=opts.coverage,
            filter_alphas=opts.filter_alphas,
            filter_control_noise=opts.filter_control_noise,
            filter_measurement_cov=opts.filter_measurement_cov,
            reward_weights=vars(opts.weights),
        )
        opts.check_against(config)
        self.raw_env = LandmarksEnv(render_mode=render_mode, config=config)
        self.belief_wrapper = EKFSLAMWrapper(
            self.raw_env,
            observation=opts.observation,
            correction=opts.correction,
            gate=opts.gate,
            alphas=opts.filter_alphas,
            control_noise=opts.filter_control_noise,
            measurement_cov=opts.filter_measurement_cov,
        )
        belief: gym.Env = self.belief_wrapper
        if opts.coverage:
            belief = CoverageWrapper(belief)
        self._stack = ActiveSLAMReward(belief, opts.weights)
        self.render_mode = render_mode
        self.observation_space = self._stack.observation_space
        self.action_space = self._stack.action_space

    @property
    def filter(self) -> EKFSLAM:
        """The EKF-SLAM filter holding the current belief."""
        return self.belief_wrapper.filter

    @property
    def config(self):
        return self.raw_env.config

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        check_reset_options(options, type(self).__name__)  # before the seed is applied
        super().reset(seed=seed)
        obs, info = self._stack.reset(seed=seed, options=options)
        # One random stream for the whole stack: the raw env's.
        self._np_random = self.raw_env.np_random
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        return self._stack.step(action)

    def render(self) -> Any:
        return self._stack.render()

    def close(self) -> None:
        self._stack.close()
        super().close()


# ActiveSLAMEnv's own arguments, for the list of valid names in errors.
_OWN_ARGUMENTS = tuple(
    name
    for name, p in inspect.signature(ActiveSLAMEnv.__init__).parameters.items()
    if name != "self" and p.kind is p.POSITIONAL_OR_KEYWORD
)
