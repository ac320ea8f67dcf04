"""The raw sensor-stream environment, ``slam_env/Landmarks-v0``."""

from __future__ import annotations

from typing import Any

import numpy as np

from slam_env.config import EnvConfig
from slam_env.envs.options import raw_core
from slam_env.envs.single import CoreEnv
from slam_env.sensing.landmark_sensor import LandmarkSensor
from slam_env.sensing.odometry_sensor import OdometrySensor

__all__ = ["LandmarksEnv"]


class LandmarksEnv(CoreEnv):
    """A 2D robot among point landmarks and obstacles, sensing landmarks by ID.

    ## Description
    A circular unicycle robot, simulated with pymunk, drives in a walled arena among
    convex obstacles and point landmarks (small posts) with IDs. Each step it receives
    noisy odometry for the motion just made and the noisy range-bearing detections,
    with IDs, of the landmarks within range and field of view and not occluded. There
    is no ground truth in the observation: this is the stream a SLAM front end sees.
    ``slam_env/ActiveSLAM-v0`` puts an EKF-SLAM filter behind it.

    The robot is a circle driven as a unicycle at 5 Hz (``dt=0.2`` s, 4 sub-steps). A
    collision *stops* its translation (its rotation goes on), as for a bumper-equipped
    differential drive: a wheeled robot cannot slide sideways, and a sideways slip is
    what the seeds' odometry model cannot describe. The sensor sees the landmarks
    within ``max_range`` and the field of view ``fov`` whose line of sight no wall,
    obstacle or other post blocks. Lines of sight, the scan and the robots' moves are
    compiled queries against the worlds' static geometry
    (:mod:`slam_env.kernels.world`) that give exactly the answers of pymunk's own
    queries, grazing rays included; the rare move within 1e-9 m of a contact is
    settled by pymunk itself. The sensor models also stand alone, for a world of your
    own: :class:`~slam_env.sensing.LandmarkSensor` and
    :class:`~slam_env.sensing.OdometrySensor` (``env.unwrapped.sensor`` and
    ``env.unwrapped.odometry``).

    ## Action Space
    ``action_type="continuous"`` (default): ``Box(-1, 1, (2,), float32)``, the forward
    speed and turn rate as fractions of ``max_speed`` (m/s) and ``max_turn_rate``
    (rad/s). Finite values outside [−1, 1] are clipped; a non-finite value or a wrong
    shape raises ``ValueError``. ``action_type="discrete"``: ``Discrete(7)`` motion
    primitives (stop, forward, forward-left, forward-right, turn left, turn right,
    reverse), see :data:`slam_env.envs.actions.DISCRETE_PRIMITIVES`.

    ## Observation Space
    A ``Dict`` of float32 arrays (``D = max_detections``, default one row per landmark):

    | key            | shape  | content                                                      |
    |----------------|--------|--------------------------------------------------------------|
    | ``odometry``   | (3,)   | (δrot1 rad, δtr m, δrot2 rad) for the step, seed 000 model;   |
    |                | (2,)   | or (Δp m, Δθ rad) with ``motion_model="velocity"``            |
    | ``detections`` | (2D,)  | row-major pairs: [r m, φ rad] per detection (φ ∈ [−π, π));    |
    |                |        | [x, y] m in the robot frame with                              |
    |                |        | ``measurement_model="cartesian"``; zero pairs are padding     |
    | ``ids``        | (D,)   | the landmark ID of each pair; −1 for padding                  |
    | ``mask``       | (D,)   | 1.0 for a real detection, 0.0 for padding                     |
    | ``scan``       | (B,)   | only with ``scan_beams=B > 0``: a proximity scan, the free    |
    |                |        | distance along B beams spread over 360° (the first from       |
    |                |        | behind, counter-clockwise) / ``scan_range``, in [0, 1]        |
    | ``bumper``     | (1,)   | only with ``bumper=True``: a contact sensor, 1.0 when the     |
    |                |        | last step was blocked (as ``info["collision"]``), else 0.0    |

    ``detections`` is flat so that every key is a vector (what stable-baselines3's
    policies expect); :func:`~slam_env.sensing.raw_observation.unpack_detections`
    returns the valid ``(k, 2)`` rows and their integer IDs.
    Detections are sorted by landmark ID. δtr/Δp may be negative (reversing). Values
    are clipped to the bounds, which lie more than 10σ beyond any physical reading.

    ## Rewards
    ``new_landmark_bonus`` (1.0) for every landmark detected for the first time, minus
    ``collision_penalty`` (0.1) on a step in which the robot touched anything. The terms
    are reported in ``info["reward_terms"]``. The active-SLAM reward lives in the wrapper.

    ## Starting State
    The layout's start pose; with ``preset="random"`` a new world (obstacles,
    landmarks, start pose) is drawn from the env's seed at every reset.

    ## Episode End
    Truncation after ``max_episode_steps`` (500 at registration). The robot cannot
    fail, so there is no terminal state, unless ``terminate_when_all_detected=True``,
    which terminates the episode on the step in which the last landmark is first seen.

    ## Info
    The keys of :data:`slam_env.info_keys.RAW_INFO`: the true pose and map, the
    contact, the landmarks seen so far, the noise-free odometry, the reward terms, and
    with faults or hidden IDs what the observation does not tell.

    ## Arguments
    ``gym.make("slam_env/Landmarks-v0", render_mode=None, config=None, **options)``:
    ``config`` an :class:`EnvConfig`; ``options`` flat overrides of any of its fields
    (``n_landmarks=10``, ``max_range=4.0``, ``motion_model``…, see
    :func:`slam_env.config.make_config`), or a user world as ``layout=`` (a
    :class:`Layout`, a dict, or a JSON/YAML path). Flat and nested forms mean the same;
    an option given in both raises ``ValueError``, an unknown one ``TypeError``; numpy
    scalars are taken as the Python values they hold. Every option that scales work or
    memory is checked against :mod:`slam_env.budget` before anything is built.
    ``reset`` takes no options. ``close`` releases the renderer; the env stays usable
    (``step``, ``reset``, and ``render``, which reopens its window), as Gymnasium's are.

    ## Version History
    * v0: the range-bearing (seed 000) and cartesian (seed 004) sensors with IDs, the
      odometry and velocity models, faults, hidden IDs and clutter, user layouts;
      0.2.0 moved the modules into layers without changing a stream.
    """

    def __init__(
        self, render_mode: str | None = None, config: EnvConfig | None = None, **options: Any
    ) -> None:
        # A batch of one: the native vector env runs the same core for B sub-envs.
        core = raw_core(1, {"config": config, **options}, f"{type(self).__name__}.__init__")
        self._setup(core, render_mode)
        config = self.config
        # The sensor models on their own, for users who sense this world themselves.
        self.sensor = LandmarkSensor(config.sensor)
        self.odometry = OdometrySensor(config.odometry)
        # Drawn over the world by render(); the EKF-SLAM wrapper sets it.
        self.belief_overlay = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        self.belief_overlay = None
        return super().reset(seed=seed, options=options)

    def _overlay(self) -> Any:
        return self.belief_overlay
