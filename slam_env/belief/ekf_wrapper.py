"""The EKF-SLAM belief as a wrapper over ``slam_env/Landmarks-v0`` (or a user's env of its
stream), for users' own stacks: ``slam_env/ActiveSLAM-v0`` computes the same in its core."""

from __future__ import annotations

import math
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from slam_env.belief.encodings import (
    OBSERVATION_MODES,
    PASSTHROUGH_KEYS,
    BeliefGeometry,
    EgocentricEncoding,
    FullEncoding,
)
from slam_env.belief.entropy import BeliefEntropy
from slam_env.belief.overlay import BeliefOverlay
from slam_env.ekf import CORRECTION_MODES, DEFAULT_GATE, EKFSLAM
from slam_env.kernels.belief.belief_state import SINGLE, BeliefBatch
from slam_env.kernels.belief.diagnostics import DIAGNOSTICS, belief_diagnostics
from slam_env.kernels.belief.divergence import (
    DIVERGENCE_REJECTIONS,
    count_rejections,
    diverged,
)
from slam_env.sensing.raw_observation import unpack_detections

__all__ = ["EKFSLAMWrapper"]

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
            (the exact belief); see :mod:`slam_env.belief.encodings`.
        correction: ``"sequential"`` or ``"batch"``.
        gate: χ² threshold on the innovation's Mahalanobis distance (2 dof), or
            ``None`` to accept everything. Default: the 99.9% quantile.
        initial_pose_cov: (3, 3) covariance of the start pose; default zeros (known).
        linearization: ``"standard"``, ``"fej"`` (First-Estimates Jacobian EKF),
            ``"oc"`` (observability-constrained EKF) or ``"invariant"`` (right-invariant
            EKF).

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
    ``map_rmse``, where it is undefined (a pose covariance that is singular along the
    error, e.g. after the velocity model's first step, or gone non-finite).

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
        # The divergence kernels' state and outputs for the batch of one: rejections in a
        # row, a numerical failure since the reset, and the verdict.
        self._in_a_row = np.zeros(SINGLE, dtype=np.int64)
        self._failed = np.zeros(SINGLE, dtype=np.bool_)
        self._diverged = np.zeros(SINGLE, dtype=np.bool_)
        self._status_count = np.zeros(SINGLE, dtype=np.int64)

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
        self._in_a_row[0] = 0
        self._failed[0] = False
        self._correct(raw)
        return self._observe(raw, info)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        raw, reward, terminated, truncated, info = self.env.step(action)
        try:
            self.filter.predict(raw["odometry"])
        except NUMERICAL_FAILURES:
            self._failed[0] = True  # the belief has diverged: report it
        self._correct(raw)
        obs, info = self._observe(raw, info)
        return obs, reward, terminated, truncated, info

    def observation(self, observation: Any) -> Any:
        """The belief encoding of the filter's current state (the raw observation has
        already been folded into the filter by ``reset``/``step``)."""
        obs, self._last_clipped = self._encode(self.filter.belief_batch(), observation)
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
        :class:`slam_env.belief.entropy.BeliefEntropy`). ``cov``: a covariance in the
        filter's state order (not modified); default the filter's."""
        if cov is not None:
            return self._entropy(cov)
        belief = self.filter.belief_batch()
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
            self._failed[0] = True
            return
        status = result.status[None]
        self._status_count[0] = status.shape[1]
        count_rejections(status, self._status_count, self._one, self._in_a_row)

    def _observe(
        self, raw: dict[str, np.ndarray], info: dict[str, Any]
    ) -> tuple[Any, dict[str, Any]]:
        """The belief observation and the diagnostics, read off the live state."""
        f = self.filter
        belief = f.belief_batch()
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
        # landmark, the NEES of a singular or non-finite pose covariance.
        if not math.isnan(map_rmse):
            info["map_rmse"] = map_rmse
        if not math.isnan(pose_nees):
            info["pose_nees"] = pose_nees
        info["landmarks_known"] = f.n_landmarks
        info["rejected"] = f.n_rejected
        info["entropy"] = self._entropy_out.item()
        info["pose_std"] = pose_std
        info["belief_clipped"] = clipped
        info["consecutive_rejections"] = self._in_a_row.item()
        self._clipped[0] = clipped
        diverged(self._clipped, self._failed, self._in_a_row, DIVERGENCE_REJECTIONS, self._diverged)
        info["diverged"] = self._diverged.item()
        return obs, info
