"""The EKF-SLAM belief wrapper and the active-SLAM reward wrapper."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from slam_env.belief import BeliefGeometry, EgocentricEncoding, FullEncoding
from slam_env.belief_entropy import ENTROPY_FLOOR, BeliefEntropy, landmark_prior_variance
from slam_env.ekf import CORRECTED, CORRECTION_MODES, EKFSLAM, REJECTED, chi2_gate
from slam_env.kernels.belief.belief_state import SINGLE, BeliefBatch, filter_belief
from slam_env.kernels.belief.diagnostics import DIAGNOSTICS, belief_diagnostics
from slam_env.kernels.belief.reward import RewardSignals, active_slam_reward
from slam_env.overlay import BeliefOverlay
from slam_env.sensing.raw_observation import unpack_detections

__all__ = [
    "DEFAULT_GATE",
    "DIVERGENCE_REJECTIONS",
    "ENTROPY_FLOOR",
    "OBSERVATION_MODES",
    "REWARD_TERMS",
    "ActiveSLAMReward",
    "ActiveSLAMRewardWeights",
    "EKFSLAMWrapper",
    "landmark_prior_variance",
]

OBSERVATION_MODES = ("egocentric", "full")
# Raw observation keys handed to the policy as they are, in this order: the proximity
# sensors, which say where obstacles are (the landmark map does not hold them).
PASSTHROUGH_KEYS = ("scan", "bumper")
# The default validation gate: χ²(2 dof) at 99.9%. A noise-matched filter rejects one
# good observation in a thousand, while a gross outlier (say 10σ) never passes.
DEFAULT_GATE = chi2_gate(0.999)
# This many gate rejections in a row, with no accepted correction between, means the
# belief no longer explains what the robot sees.
DIVERGENCE_REJECTIONS = 10
# What the filter raises when its arithmetic breaks down. The wrapper feeds it only the
# env's own stream, well-formed by construction (finite, of the right shapes, IDs in
# range), so a ValueError from it (a math domain error, a LinAlgError) is numerical too.
NUMERICAL_FAILURES = (ArithmeticError, ValueError)


class EKFSLAMWrapper(gym.ObservationWrapper):
    """Runs EKF-SLAM (known correspondences) on ``slam_env/Landmarks-v0``'s raw stream
    and observes the belief.

    On reset the filter starts at the known start pose; each step it predicts with the
    *odometry reading in the raw observation* (not the commanded action, as on a real
    robot) and corrects with the detections and their IDs. By default the filter's
    noise parameters are the env's true ones; ``alphas``, ``control_noise`` and
    ``measurement_cov`` override them to study a mismatched filter. The motion and
    measurement models are those of the env's stream (set them on the env:
    ``motion_model``/``measurement_model`` options).

    Args:
        env: a ``LandmarksEnv`` (possibly wrapped).
        observation: ``"egocentric"`` (flat features, the RL default) or ``"full"``
            (the exact belief); see :mod:`slam_env.belief`.
        correction: ``"sequential"`` or ``"batch"``.
        gate: χ² threshold on the innovation's Mahalanobis distance (2 dof), or
            ``None`` to accept everything. Default: the 99.9% quantile.
        initial_pose_cov: (3, 3) covariance of the start pose; default zeros (known).
        linearization: ``"standard"``, ``"fej"`` (First-Estimates Jacobian EKF) or
            ``"oc"`` (observability-constrained EKF).

    The filter takes the sensor's landmark IDs (known correspondences) and leaves out
    detections without one (clutter). A filter that associates by itself, and the
    scoring of its associations against the truth, is ``ActiveSLAM-v0``'s
    ``data_association`` option.

    The raw proximity sensors, if the env has them (``scan``, ``bumper``), are passed
    through: appended to the egocentric features in that order, or as their own keys of
    the full belief.

    ``info`` gains, every step: ``pose_error`` (m), ``heading_error`` (rad),
    ``map_rmse`` (m, over known landmarks; absent before the first, as an undefined
    metric is: never NaN, so equal runs give equal infos), ``pose_nees``,
    ``landmarks_known``, ``rejected`` (observations the gate refused this episode),
    ``entropy`` (nats, see :meth:`belief_entropy`), ``pose_std`` (m, √trace of the
    position covariance), ``belief_clipped`` (the belief left the observation's
    bounds), ``consecutive_rejections`` (observations of known landmarks the gate has
    refused in a row) and ``diverged``: the filter has lost track, because the belief
    was clipped, a prediction or correction failed numerically (it is then skipped,
    never applied as NaN, and never raised out of ``step``), or the gate refused
    ``DIVERGENCE_REJECTIONS`` observations in a row (after a kidnapping, every
    landmark is where the belief says it cannot be). ``pose_nees`` is absent, like
    ``map_rmse``, in the one case it is undefined (a covariance gone non-finite).

    The encoding, the diagnostics and the entropy are computed by the belief kernels
    (:mod:`slam_env.kernels`) on the filter's belief as a batch of one.
    """

    def __init__(
        self,
        env: gym.Env,
        observation: str = "egocentric",
        correction: str = "sequential",
        gate: float | None = DEFAULT_GATE,
        alphas: tuple[float, float, float, float] | None = None,
        control_noise: tuple[float, float, float, float] | None = None,
        measurement_cov: np.ndarray | None = None,
        initial_pose_cov: np.ndarray | None = None,
        linearization: str = "standard",
    ) -> None:
        super().__init__(env)
        if observation not in OBSERVATION_MODES:
            raise ValueError(f"observation must be one of {OBSERVATION_MODES}, got {observation!r}")
        if correction not in CORRECTION_MODES:
            raise ValueError(f"correction must be one of {CORRECTION_MODES}, got {correction!r}")
        base = env.unwrapped
        cfg = base.config
        self.observation_mode = observation
        self._initial_pose_cov = (
            np.zeros((3, 3)) if initial_pose_cov is None else np.asarray(initial_pose_cov, float)
        )
        self.filter = EKFSLAM(
            motion_model=cfg.odometry.motion_model,
            measurement_model=cfg.sensor.measurement_model,
            alphas=cfg.odometry.alphas if alphas is None else alphas,
            control_noise=cfg.odometry.velocity_noise if control_noise is None else control_noise,
            measurement_cov=(
                cfg.sensor.measurement_cov if measurement_cov is None else measurement_cov
            ),
            max_landmarks=base.n_landmark_slots,
            initial_pose_cov=self._initial_pose_cov,
            gate=gate,
            correction=correction,
            linearization=linearization,
        )
        width, height = base.arena_size
        self._geometry = BeliefGeometry(
            max_landmarks=base.n_landmark_slots,
            width=width,
            height=height,
            max_range=cfg.sensor.max_range,
        )
        self._entropy = BeliefEntropy(base.n_landmark_slots, width, height)
        # The kernels' outputs for the batch of one, read each step.
        self._entropy_out = np.empty(SINGLE)
        self._entropy_ok = np.empty(SINGLE, dtype=np.bool_)
        self._diagnostics = np.empty((len(DIAGNOSTICS), SINGLE))
        self._clipped = np.empty(SINGLE, dtype=np.bool_)
        self._no_tail = np.empty((SINGLE, 0), dtype=np.float32)
        self._one = np.ones(SINGLE, dtype=np.bool_)  # the kernels' mask: the one world
        if observation == "full":
            self._encoding = FullEncoding(self._geometry)
        else:
            self._encoding = EgocentricEncoding(self._geometry)
        self.observation_space = self._encoding.space
        # The raw proximity sensors the env has (scan, bumper) are passed through:
        # appended to the egocentric features, or as their own keys of the full belief.
        raw_spaces = env.observation_space.spaces
        self._passthrough = tuple(k for k in PASSTHROUGH_KEYS if k in raw_spaces)
        if self._passthrough:
            extra = {k: raw_spaces[k] for k in self._passthrough}
            if observation == "full":
                self.observation_space = gym.spaces.Dict({**self.observation_space.spaces, **extra})
            else:
                space = self.observation_space
                self.observation_space = gym.spaces.Box(
                    np.concatenate([space.low, *(e.low for e in extra.values())]),
                    np.concatenate([space.high, *(e.high for e in extra.values())]),
                    dtype=np.float32,
                )
        self._last_clipped = False
        self._consecutive_rejections = 0
        self._numerical_failure = False

    # ------------------------------------------------------------------ API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        raw, info = self.env.reset(seed=seed, options=options)
        # Landmarks do not move: index the true map by ID once per episode.
        truth = np.full((self._geometry.max_landmarks, 2), np.nan)
        truth[info["landmark_ids"]] = info["landmark_positions"]
        self._true_landmarks = truth[None]
        self.filter.reset(initial_pose=info["pose"], initial_pose_cov=self._initial_pose_cov)
        self._consecutive_rejections = 0
        self._numerical_failure = False
        self._correct(raw)
        return self._observe(raw, info)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        raw, reward, terminated, truncated, info = self.env.step(action)
        try:
            self.filter.predict(raw["odometry"])
        except NUMERICAL_FAILURES:
            self._numerical_failure = True  # the belief has diverged: report it
        self._correct(raw)
        obs, info = self._observe(raw, info)
        return obs, reward, terminated, truncated, info

    def observation(self, observation: Any) -> Any:
        """The belief encoding of the filter's current state (the raw observation has
        already been folded into the filter by ``reset``/``step``)."""
        obs, self._last_clipped = self._encode(filter_belief(self.filter), observation)
        return obs

    def _encode(self, belief: BeliefBatch, raw: dict[str, np.ndarray]) -> tuple[Any, bool]:
        """The belief observation (fresh arrays) with the raw proximity readings passed
        through."""
        if self.observation_mode == "full":
            out = self._encoding.empty(SINGLE)
            self._encoding.encode_batch(belief, out)
            obs = {"mean": out.mean[0], "cov": out.cov[0], "known": out.known[0]}
            for key in self._passthrough:
                obs[key] = raw[key].copy()
            return obs, bool(out.clipped[0])
        if self._passthrough:
            tail = np.concatenate([raw[key] for key in self._passthrough])[None]
        else:
            tail = self._no_tail
        out = np.empty((SINGLE, self._encoding.size + tail.shape[1]), dtype=np.float32)
        self._encoding.encode_batch(belief, tail, out, self._clipped)
        return out[0], bool(self._clipped[0])

    def belief_entropy(self, cov: np.ndarray | None = None) -> float:
        """Entropy (nats) of the belief over the pose and all ``max_landmarks`` slots:
        an unseen landmark's slot carries an independent prior, uniform over the arena
        in its first two moments, so discovering a landmark lowers the entropy and the
        dimension never changes. It is computed for Σ + ``ENTROPY_FLOOR``·I (see
        :class:`slam_env.belief_entropy.BeliefEntropy`). ``cov``: a covariance in the
        filter's state order (not modified); default the filter's."""
        if cov is not None:
            return self._entropy(cov)
        belief = filter_belief(self.filter)
        self._entropy.batch(belief.P, belief.n, self._entropy_out, self._entropy_ok)
        return self._entropy_out.item()

    def belief_overlay(self, true_landmarks: Any = None) -> BeliefOverlay:
        f = self.filter
        return BeliefOverlay.from_state(f.mean, f.cov, f.state_to_id, true_landmarks)

    def render(self) -> Any:
        base = self.env.unwrapped
        if base.render_mode is not None and base._started:
            base.belief_overlay = self.belief_overlay()
        return self.env.render()

    # ------------------------------------------------------------------ helpers
    def _correct(self, raw: dict[str, np.ndarray]) -> None:
        if not raw["mask"].any():
            return  # nothing detected (the mask is 0 or 1): no unpacking, no update
        z, ids = unpack_detections(raw)
        labelled = ids >= 0
        if not labelled.all():  # clutter: no landmark ID to correct with
            z, ids = z[labelled], ids[labelled]
        try:
            result = self.filter.update(z, ids)
        except NUMERICAL_FAILURES:
            # The filter refused an update that would break Σ (and left itself as it
            # was): the belief has diverged; report it rather than hand out NaN.
            self._numerical_failure = True
            return
        for status in result.status.tolist():
            if status == REJECTED:
                self._consecutive_rejections += 1
            elif status == CORRECTED:
                self._consecutive_rejections = 0

    def _observe(
        self, raw: dict[str, np.ndarray], info: dict[str, Any]
    ) -> tuple[Any, dict[str, Any]]:
        """The belief observation and the diagnostics, read off the live state."""
        f = self.filter
        belief = filter_belief(f)
        obs, clipped = self._encode(belief, raw)
        diagnostics = self._diagnostics
        belief_diagnostics(
            *belief, info["pose"][None], self._true_landmarks, diagnostics, self._one
        )
        # (In DIAGNOSTICS order.)
        pose_error, heading_error, map_rmse, pose_nees, pose_std = diagnostics.ravel().tolist()
        self._entropy.batch(belief.P, belief.n, self._entropy_out, self._entropy_ok)
        info["pose_error"] = pose_error
        info["heading_error"] = heading_error
        # Undefined metrics are absent, never NaN: the map error before the first
        # landmark, the NEES of a covariance gone non-finite.
        if not math.isnan(map_rmse):
            info["map_rmse"] = map_rmse
        if not math.isnan(pose_nees):
            info["pose_nees"] = pose_nees
        info["landmarks_known"] = f.n_landmarks
        info["rejected"] = f.n_rejected
        info["entropy"] = self._entropy_out.item()
        info["pose_std"] = pose_std
        info["belief_clipped"] = clipped
        info["consecutive_rejections"] = self._consecutive_rejections
        info["diverged"] = bool(
            clipped
            or self._numerical_failure
            or self._consecutive_rejections >= DIVERGENCE_REJECTIONS
        )
        return obs, info


REWARD_TERMS = ("information_gain", "pose_uncertainty", "collision", "step", "coverage")


@dataclass(frozen=True)
class ActiveSLAMRewardWeights:
    """Weights of the active-SLAM reward terms (see :class:`ActiveSLAMReward`)."""

    information_gain: float = 0.1  # per nat of entropy removed
    pose_uncertainty: float = 0.1  # per m of pose standard deviation, each step
    collision: float = 1.0  # per step in contact
    step: float = 0.01  # per step
    coverage: float = 0.0  # per share of the arena newly swept (needs a CoverageWrapper)

    def __post_init__(self) -> None:
        for name in REWARD_TERMS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"reward weight {name} must be a number, got {value!r}")
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"reward weight {name} must be finite and >= 0, got {value}")


class ActiveSLAMReward(gym.Wrapper):
    """The active-SLAM reward over an :class:`EKFSLAMWrapper`, as named terms:

    * ``information_gain`` = w · (H_{t−1} − H_t): the entropy the step removed from the
      belief over all landmark slots. Discovering a landmark is worth about 10–15 nats
      (its slot goes from the arena-wide prior to a few cm), re-observing one a few
      tenths; dead reckoning costs a little. This is the term that drives exploration.
    * ``pose_uncertainty`` = −w · σ_pose (m): an information-gain reward alone does not
      care *when* the robot is lost; this term pays for closing loops early.
    * ``collision`` = −w on a step in contact: the map does not see obstacles.
    * ``step`` = −w: a small time cost, so that finishing early is better.
    * ``coverage`` = w · (the share of the arena newly swept by the sensor, from a
      :class:`slam_env.coverage.CoverageWrapper` below): off by default. Information
      gain pays only when a landmark turns up; this pays for looking where none has
      been seen yet, a dense signal that speeds up learning to explore.

    The terms are reported in ``info["reward_terms"]``; the raw env's scripting terms
    move to ``info["raw_reward_terms"]``. The reward is their sum, a Python float.
    """

    def __init__(self, env: gym.Env, weights: ActiveSLAMRewardWeights | None = None) -> None:
        super().__init__(env)
        self.weights = weights or ActiveSLAMRewardWeights()
        # The step's signals, the previous step's (the baseline of the gains), and the
        # terms and reward: the reward kernel's batch of one.
        self._now = RewardSignals(
            np.zeros(SINGLE), np.zeros(SINGLE), np.zeros(SINGLE, dtype=np.bool_), np.zeros(SINGLE)
        )
        self._last = np.zeros((SINGLE, 2))  # the previous entropy and swept fraction
        self._terms = np.zeros((SINGLE, len(REWARD_TERMS)))
        self._reward = np.zeros(SINGLE)
        self._one = np.ones(SINGLE, dtype=np.bool_)  # the kernel's mask: the one world

    @property
    def weights(self) -> ActiveSLAMRewardWeights:
        """The weights of the terms."""
        return self._weights

    @weights.setter
    def weights(self, weights: ActiveSLAMRewardWeights) -> None:
        if not isinstance(weights, ActiveSLAMRewardWeights):
            raise TypeError("weights must be an ActiveSLAMRewardWeights")
        self._weights = weights
        self._weight_array = np.array([getattr(weights, name) for name in REWARD_TERMS])

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._require_belief_info(info)
        self._last[0] = (info["entropy"], _swept_fraction(info))
        info["raw_reward_terms"] = info.pop("reward_terms", {})
        info["reward_terms"] = dict.fromkeys(REWARD_TERMS, 0.0)
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, _, terminated, truncated, info = self.env.step(action)
        now = self._now
        now.entropy[0] = info["entropy"]
        now.pose_std[0] = info["pose_std"]
        now.collision[0] = info["collision"]
        now.swept_fraction[0] = _swept_fraction(info)
        active_slam_reward(
            self._weight_array, *now, self._last, self._terms, self._reward, self._one
        )
        info["raw_reward_terms"] = info.pop("reward_terms", {})
        info["reward_terms"] = dict(zip(REWARD_TERMS, self._terms[0].tolist(), strict=True))
        return obs, self._reward.item(), terminated, truncated, info

    def _require_belief_info(self, info: dict[str, Any]) -> None:
        if "entropy" not in info:
            raise TypeError("ActiveSLAMReward must wrap an EKFSLAMWrapper (info has no entropy)")
        if self.weights.coverage and "swept_fraction" not in info:
            raise TypeError(
                "ActiveSLAMReward with a coverage weight must wrap a CoverageWrapper "
                "(info has no swept_fraction)"
            )


def _swept_fraction(info: dict[str, Any]) -> float:
    """The swept share of the arena from a CoverageWrapper below, 0 without one."""
    return info.get("swept_fraction", 0.0)
