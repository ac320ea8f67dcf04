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

from slam_env.belief.overlay import BeliefOverlay
from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.core.active_options import DEFAULT_SCAN_BEAMS, ActiveSLAMOptions
from slam_env.ekf import EKFSLAM
from slam_env.envs.options import active_core, options_signature
from slam_env.envs.pictures import LIVE_FIGURES
from slam_env.envs.single import CoreEnv

__all__ = ["DEFAULT_SCAN_BEAMS", "LIVE_FIGURES", "ActiveSLAMEnv"]


class ActiveSLAMEnv(CoreEnv):
    """Active SLAM: act on the EKF-SLAM belief, be paid for reducing its uncertainty.

    ## Description
    The world, robot and sensors of :class:`slam_env.envs.landmarks.LandmarksEnv`, with
    an EKF-SLAM filter (:class:`slam_env.ekf.EKFSLAM`) folding in each step's odometry
    reading and detections. The agent sees the filter's belief, not the truth, and is
    paid for making it certain: this is the environment active-SLAM policies are
    trained on. It computes what the wrapper stack ``LandmarksEnv → EKFSLAMWrapper →
    CoverageWrapper → ActiveSLAMReward`` (:mod:`slam_env.belief`) computes, in a few
    compiled calls; the filter is ``env.unwrapped.filter``.

    ## Action Space
    As :class:`~slam_env.envs.landmarks.LandmarksEnv`'s.

    ## Observation Space
    ``observation="egocentric"`` (default): a flat ``Box`` of float32, the belief
    features of :class:`~slam_env.belief.encodings.EgocentricEncoding` (7 + 4M for M
    landmark slots), then the proximity scan and the bumper (on by default here: a
    policy must see obstacles, which the landmark map does not hold), then 1 + 24
    swept-area features (:class:`~slam_env.belief.coverage.CoverageGrid`).
    ``"full"``: a ``Dict`` with the belief's ``mean``, flattened ``cov`` and ``known``
    mask (:class:`~slam_env.belief.encodings.FullEncoding`) and the ``scan``,
    ``bumper`` and ``coverage`` keys. ``"local"``: a ``Dict`` whose size does not
    depend on the world (:mod:`slam_env.belief.local_encoding`), for training across
    worlds. Values beyond the bounds are clipped onto them (``info["belief_clipped"]``).

    ## Rewards
    The named terms of :class:`~slam_env.belief.reward.ActiveSLAMRewardWeights`, each
    weight times its signal: the entropy the step removed from the belief, the pose's
    standard deviation, a collision, a time cost and (off by default) the share of the
    arena newly swept; reported in ``info["reward_terms"]``.

    ## Starting State
    As :class:`~slam_env.envs.landmarks.LandmarksEnv`'s; the filter starts at the true
    start pose, known exactly, and folds in the first scan.

    ## Episode End
    As :class:`~slam_env.envs.landmarks.LandmarksEnv`'s. A numerical breakdown of the
    filter is reported as ``info["diverged"]``, never raised out of ``step``.

    ## Arguments
    ``gym.make("slam_env/ActiveSLAM-v0", render_mode=None, **options)``: the options of
    :class:`~slam_env.core.active_options.ActiveSLAMOptions` (the table of the env's
    page lists each with its default and limits), and every option of
    ``Landmarks-v0``, flat or nested, where ``scan_beams`` defaults to 16 and
    ``bumper`` to ``True`` (a whole ``config`` is taken as it is). Options are checked,
    the resource budget of :mod:`slam_env.budget` too, before anything is built.

    ## Info
    The keys of :data:`slam_env.info_keys.ACTIVE_INFO`: the raw env's truth, the
    belief's diagnostics, the swept share and the reward terms, and, where the filter
    associates, the associations judged against the truth. An undefined metric is
    absent, never NaN: ``map_rmse`` appears with the first landmark in the belief.

    ## Version History
    * v0: the EKF-SLAM belief (standard, FEJ, OC), known IDs or nearest-neighbour and
      JCBB association, three observations, the coverage features; 0.2.0 moved the
      modules into layers without changing a stream.
    """

    def __init__(self, render_mode: str | None = None, **options: Any) -> None:
        # The signature below lists the options (ActiveSLAMOptions is their table).
        core = active_core(1, options)
        # A batch of one: the native vector env runs the same core for B sub-envs.
        self._setup(core, render_mode)
        self.options = core.options
        # render() draws the belief with its estimated path and its live figures
        # (LIVE_FIGURES), which the pictures' helper of CoreEnv keeps.

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


# The signature's keyword options are the table's, with their defaults (help(), IDEs).
ActiveSLAMEnv.__init__.__signature__ = options_signature(ActiveSLAMEnv.__init__, ActiveSLAMOptions)
