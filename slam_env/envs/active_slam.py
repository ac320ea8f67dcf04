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
from slam_env.smoothing import ISAM2SLAM

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

    ``belief="isam2"`` hands on a smoothing belief instead (iSAM2 over the pose graph,
    :mod:`slam_env.smoothing`; the ``gtsam`` extra): its mean and the joint marginal of
    the current pose and the map, in the filter's arrays, so every observation, reward
    term, metric and agent reads it as it reads the filter's. The gate and, with hidden
    IDs, the filter's association run against that marginal; the smoother is
    ``env.unwrapped.smoother`` (``docs/smoothing.md``, "In the env").

    ## Action Space
    As :class:`~slam_env.envs.landmarks.LandmarksEnv`'s.

    ## Observation Space
    M is the number of landmark slots (the largest landmark ID + 1), B the scan's
    beams:

    | ``observation=`` | space | content |
    |---|---|---|
    | ``"egocentric"`` (default) | ``Box((7 + 4M + B + 1 + 25,))`` | x̂/width, ŷ/height, cos θ̂, sin θ̂, tanh(σx/1 m), tanh(σy/1 m), tanh(σθ/0.5 rad); per landmark slot i: known flag, its position in the estimated robot frame / max_range (2), tanh(√trace Σᵢ / 1 m), zero while unknown; then the B proximity beams and the bumper; then the 25 coverage features |
    | ``"full"`` | ``Dict(mean, cov, known, scan, bumper, coverage)`` | the belief exactly, slotted by landmark ID: mean (3+2M,), the covariance flattened ((3+2M)²,), known (M,) (:func:`~slam_env.belief.encodings.unpack_full_belief` reshapes it) |
    | ``"local"`` | ``Dict(robot, landmarks, local_map, scan, bumper, coverage)``, the same for every world | no slot per landmark, so one policy runs on any landmark count, arena, preset or sensor (:mod:`slam_env.belief.local_encoding`): the robot's 8 figures, the 8 nearest known landmarks (4 numbers each), and a 4 × 16 × 16 map of 1 m cells around the robot, turned with its heading (unswept share, obstacles the scan hit, outside the arena, known landmarks); it needs ``coverage=True`` |

    The coverage features (``coverage=False`` leaves them out) are the swept-area
    memory a policy needs to know where it has not looked yet, since the belief holds
    only the landmarks found: the share of the arena the landmark sensor has swept from
    the estimated pose, then the unswept share in each 45° sector around the estimated
    heading in the rings 0–R, R–2R and beyond 2R (R the sensor range). A belief outside
    the bounds (or NaN, or infinite) is clipped onto them (``info["belief_clipped"]``).

    ## Rewards
    The reward = Σ of the terms (``info["reward_terms"]``), a Python float; the weights
    w are ``reward_weights``, every one finite and >= 0. A reset's reward is 0, and the
    next step's gains are measured from it.

    | term | default w | value | why |
    |---|---|---|---|
    | ``information_gain`` | 0.1 | w × (H₍t−1₎ − H_t) | the entropy (nats) the step removed from the belief over *all* M slots, H = ½ log det(2πe (Σ + 10⁻⁴ I)) with an unseen slot carrying a prior uniform over the arena (variances width²/12, height²/12): ≈ +1.2 per new landmark, a few hundredths per re-observation, negative while dead reckoning |
    | ``pose_uncertainty`` | 0.1 | −w × σ_pose | σ_pose = √(Σxx + Σyy) in m: pays for closing loops before the robot is lost |
    | ``collision`` | 1 | −w on a step in contact | the map knows nothing of obstacles |
    | ``step`` | 0.01 | −w | finishing early is better |
    | ``coverage`` | 0 | w × (s_t − s₍t−1₎) | s the swept share of the arena (``swept_fraction``): a dense signal for learning to explore, off by default |

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
      modules into layers without changing a stream, and added ``belief="isam2"``.
    """

    def __init__(self, render_mode: str | None = None, **options: Any) -> None:
        # The signature below lists the options (ActiveSLAMOptions is their table).
        core = active_core(1, options, f"{type(self).__name__}.__init__")
        # A batch of one: the native vector env runs the same core for B sub-envs.
        self._setup(core, render_mode)
        self.options = core.options
        # render() draws the belief with its estimated path and its live figures
        # (LIVE_FIGURES), which the pictures' helper of CoreEnv keeps.

    @property
    def filter(self) -> EKFSLAM:
        """The EKF-SLAM filter holding the current belief (its state is the core's);
        with ``belief="isam2"``, the smoothing belief as a Gaussian (its mean and joint
        marginal, written at every step), which planners may copy and predict with."""
        return self._core.filter(0)

    @property
    def smoother(self) -> ISAM2SLAM:
        """The smoothing belief of ``belief="isam2"`` (``ValueError`` with the EKF's)."""
        return self._core.smoother(0)

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
