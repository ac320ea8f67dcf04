"""``slam_env/ActiveSLAM-v0``: the raw stream, the EKF-SLAM belief and the
active-SLAM reward as one ``gymnasium.Env``: sub-env 0 of
:class:`slam_env.core.active.ActiveCore`, which computes what the wrapper stack
``LandmarksEnv → EKFSLAMWrapper → CoverageWrapper → ActiveSLAMReward`` computes, with
the same kernels, in a few compiled calls. Users reach the filter as
``env.unwrapped.filter``; users who want the wrappers on their own env use them
directly.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from slam_env.belief.overlay import BeliefOverlay
from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.core.active_options import DEFAULT_SCAN_BEAMS, ActiveSLAMOptions
from slam_env.ekf import EKFSLAM
from slam_env.envs.options import active_core, options_signature
from slam_env.envs.single import CoreEnv

__all__ = ["DEFAULT_SCAN_BEAMS", "LIVE_FIGURES", "ActiveSLAMEnv"]

# The belief's figures (``info`` keys) shown live beside the rendered map.
LIVE_FIGURES = ("entropy", "map_rmse", "pose_nees")


class ActiveSLAMEnv(CoreEnv):
    """Active SLAM: act on the EKF-SLAM belief, be paid for reducing its uncertainty.

    The world, robot, sensors and episode end are those of
    :class:`slam_env.envs.landmarks.LandmarksEnv`; the observation is the belief of
    :class:`slam_env.belief.ekf_wrapper.EKFSLAMWrapper` with the swept-area memory of
    :class:`slam_env.belief.coverage_wrapper.CoverageWrapper`, and the reward that of
    :class:`slam_env.belief.reward_wrapper.ActiveSLAMReward` (terms in ``info["reward_terms"]``).

    ## Arguments
    ``observation`` (``"egocentric"`` | ``"full"`` | ``"local"``: the one whose size does
    not depend on the world, see :mod:`slam_env.belief.local_encoding`; it needs the
    coverage), ``correction`` (``"sequential"`` |
    ``"batch"``), ``gate`` (χ² threshold or ``None``), ``filter_alphas``,
    ``filter_control_noise``, ``filter_measurement_cov`` (a mismatched filter; default:
    the env's true noise), ``data_association`` (``"known"``: the sensor's IDs;
    ``"nearest_neighbor"`` | ``"jcbb"``: the filter chooses, needed with
    ``report_ids=False``), ``new_landmark_sightings`` (1, or 2: a new landmark waits
    for a second sighting, which keeps clutter out of the map), ``wide_pairing_scans``
    (1, or more with ``"jcbb"``: a loop-closing pairing waits for that many consecutive
    scans, see :class:`slam_env.ekf.EKFSLAM`), ``linearization``
    (``"standard"`` | ``"fej"`` | ``"oc"``),
    ``reward_weights`` (an :class:`ActiveSLAMRewardWeights` or a dict of its fields),
    ``coverage`` (default ``True``: a
    :class:`slam_env.belief.coverage_wrapper.CoverageWrapper` adds the swept-area features, which a
    policy needs to know where it has not looked yet); every other option goes to
    :class:`LandmarksEnv`, where ``scan_beams`` defaults to 16 and ``bumper`` to
    ``True`` here: a policy needs to see obstacles, which the landmark map does not
    hold, and to feel when one blocks it (a corner can hide between two beams). The
    egocentric observation is the belief features, then the scan and the bumper, then
    the coverage features; the full and the local ones hold them as the ``scan``,
    ``bumper`` and ``coverage`` keys. These defaults hold whichever form the world's options take
    (``fov=2.5`` or ``sensor={"fov": 2.5}``); a whole ``config`` is taken as it is.
    Options are checked (types, numpy scalars, the resource budget of
    :mod:`slam_env.budget`) before anything is built.

    ## Info
    The raw env's, then the belief's diagnostics (see
    :class:`slam_env.belief.ekf_wrapper.EKFSLAMWrapper`), ``swept_fraction`` and the reward terms.
    Where the filter associates, ``association`` (this step's ``correct``, ``wrong`` and
    ``missed`` associations, and the map's ``duplicated`` landmarks) and
    ``association_episode`` (the same, summed over the episode), judged against the
    truth (:mod:`slam_env.kernels.ekf.association_score`). A numerical breakdown of the
    filter is reported as ``diverged``, never raised out of ``step``. ``info`` never
    holds NaN: a metric that is undefined is absent, so ``map_rmse`` appears with the
    first landmark in the belief (read it with ``info.get``). Absent rather than a
    sentinel: equal runs give equal infos, no made-up value slips into an average, and
    Gymnasium's vector envs mark the sub-envs that did not report it
    (``info["_map_rmse"]``).
    """

    def __init__(self, render_mode: str | None = None, **options: Any) -> None:
        # The signature below lists the options (ActiveSLAMOptions is their table).
        core = active_core(1, options)
        # A batch of one: the native vector env runs the same core for B sub-envs.
        self._setup(core, render_mode)
        self.options = core.options
        # What render() draws beyond the belief: the estimated path and live figures,
        # kept only when rendering.
        self._estimated_trail: list[tuple[float, float]] = []
        self._figures: dict[str, float] = {}

    @property
    def filter(self) -> EKFSLAM:
        """The EKF-SLAM filter holding the current belief (its state is the core's)."""
        return self._core.filter(0)

    @property
    def reward_weights(self) -> ActiveSLAMRewardWeights:
        """The weights of the reward terms."""
        return self.options.weights

    def belief_overlay(self, true_landmarks: Any = None) -> BeliefOverlay:
        """What the pictures draw of the belief (``true_landmarks`` (N, 2) to draw the
        truth beside it, if wanted)."""
        return self._core.belief_overlay(0, true_landmarks)

    def _remember(self, info: dict[str, Any]) -> None:
        """Keep the true and estimated positions and the live figures (map_rmse is
        absent until a landmark is mapped) for the picture."""
        if self.render_mode is None:
            return
        super()._remember(info)
        if self._steps == 0:
            self._estimated_trail = []
        x, y = self.filter.pose[:2].tolist()
        self._estimated_trail.append((x, y))
        self._figures = {name: info[name] for name in LIVE_FIGURES if name in info}

    def _overlay(self) -> BeliefOverlay:
        overlay = self.belief_overlay()
        overlay.trail = np.array(self._estimated_trail, dtype=np.float64).reshape(-1, 2)
        overlay.figures = dict(self._figures)
        return overlay


# The signature's keyword options are the table's, with their defaults (help(), IDEs).
ActiveSLAMEnv.__init__.__signature__ = options_signature(ActiveSLAMEnv.__init__, ActiveSLAMOptions)
