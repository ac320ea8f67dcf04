"""``slam_env/ActiveSLAM-v0``: the raw env behind the EKF-SLAM wrapper and the
active-SLAM reward, as one ``gymnasium.Env``.

The registered env is a thin :class:`gymnasium.Env` that owns the wrapper stack
``LandmarksEnv → EKFSLAMWrapper → CoverageWrapper → ActiveSLAMReward`` and delegates to
it, so that the env checkers see an unwrapped env and users reach the filter as
``env.unwrapped.filter``.
Users who want the wrappers on their own env use them directly.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from slam_env.coverage import CoverageWrapper
from slam_env.ekf import EKFSLAM
from slam_env.env import LandmarksEnv
from slam_env.wrappers import (
    DEFAULT_GATE,
    ActiveSLAMReward,
    ActiveSLAMRewardWeights,
    EKFSLAMWrapper,
)

# Proximity beams in the active-SLAM observation, unless the options set them.
DEFAULT_SCAN_BEAMS = 16
# The belief's figures (``info`` keys) shown live beside the rendered map.
LIVE_FIGURES = ("entropy", "map_rmse", "pose_nees")


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
    ``coverage`` keys.
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
        if isinstance(reward_weights, Mapping):
            valid = ActiveSLAMRewardWeights.__dataclass_fields__
            unknown = sorted(set(reward_weights) - set(valid))
            if unknown:
                raise TypeError(f"unknown reward_weights {unknown}; valid: {sorted(valid)}")
            reward_weights = ActiveSLAMRewardWeights(**reward_weights)
        # A policy must see obstacles, which the landmark map does not hold, and feel
        # when one blocks it (a corner can hide between two beams).
        if not {"config", "sensor", "scan_beams"} & set(env_options):
            env_options["scan_beams"] = DEFAULT_SCAN_BEAMS
        if not {"config", "sensor", "bumper"} & set(env_options):
            env_options["bumper"] = True
        self.raw_env = LandmarksEnv(render_mode=render_mode, **env_options)
        self.belief_wrapper = EKFSLAMWrapper(
            self.raw_env,
            observation=observation,
            correction=correction,
            gate=gate,
            alphas=filter_alphas,
            control_noise=filter_control_noise,
            measurement_cov=filter_measurement_cov,
        )
        if not isinstance(coverage, bool):
            raise TypeError(f"coverage must be a bool, got {coverage!r}")
        belief: gym.Env = self.belief_wrapper
        if coverage:
            belief = CoverageWrapper(belief)
        self._stack = ActiveSLAMReward(belief, reward_weights)
        self.render_mode = render_mode
        # What render() draws beyond the belief: the estimated path and live figures,
        # kept only when rendering.
        self._estimated_trail: list[tuple[float, float]] = []
        self._figures: dict[str, float] = {}
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
        super().reset(seed=seed)
        obs, info = self._stack.reset(seed=seed, options=options)
        # One random stream for the whole stack: the raw env's.
        self._np_random = self.raw_env.np_random
        self._estimated_trail = []
        self._remember(info)
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        out = self._stack.step(action)
        self._remember(out[4])
        return out

    def _remember(self, info: dict[str, Any]) -> None:
        """Keep the estimated position and the live figures for the picture."""
        if self.render_mode is None:
            return
        x, y = self.filter.pose[:2].tolist()
        self._estimated_trail.append((x, y))
        self._figures = {name: info[name] for name in LIVE_FIGURES}

    def render(self) -> Any:
        raw = self.raw_env
        if self.render_mode is None or not raw._started:
            return self._stack.render()  # warns or raises as the raw env does
        overlay = self.belief_wrapper.belief_overlay()
        overlay.trail = np.array(self._estimated_trail, dtype=np.float64).reshape(-1, 2)
        overlay.figures = dict(self._figures)
        raw.belief_overlay = overlay
        return raw.render()

    def close(self) -> None:
        self._stack.close()
        super().close()
