"""The raw sensor-stream environment, ``slam_env/Landmarks-v0``."""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from slam_env.actions import DISCRETE_PRIMITIVES, parse_action
from slam_env.config import EnvConfig, make_config
from slam_env.layouts import Layout
from slam_env.raw_core import RawCore
from slam_env.sensors import LandmarkSensor, OdometrySensor
from slam_env.world import World


def unpack_detections(obs: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The valid detections of a raw observation: ``z`` (k, 2) float64 and ``ids`` (k,)
    int64, in the observation's order (ascending ID)."""
    valid = obs["mask"] > 0.5
    k = int(np.count_nonzero(valid))
    if valid[:k].all():  # the env's layout: detections first, then padding
        z = obs["detections"][: 2 * k].reshape(k, 2).astype(np.float64)
        return z, obs["ids"][:k].astype(np.int64)
    z = obs["detections"].reshape(-1, 2)[valid].astype(np.float64)
    return z, obs["ids"][valid].astype(np.int64)


class LandmarksEnv(gym.Env[dict[str, np.ndarray], np.ndarray]):
    """A 2D robot among point landmarks and obstacles, sensing landmarks by ID.

    ## Description
    A circular unicycle robot, simulated with pymunk, drives in a walled arena among
    convex obstacles and point landmarks (small posts) with IDs. Each step it receives
    noisy odometry for the motion just made and the noisy range-bearing detections,
    with IDs, of the landmarks within range and field of view and not occluded. There
    is no ground truth in the observation: this is the stream a SLAM front end sees.
    ``slam_env/ActiveSLAM-v0`` puts an EKF-SLAM filter behind it.

    ## Action Space
    ``action_type="continuous"`` (default): ``Box(-1, 1, (2,), float32)``, the forward
    speed and turn rate as fractions of ``max_speed`` (m/s) and ``max_turn_rate``
    (rad/s). Finite values outside [−1, 1] are clipped; a non-finite value or a wrong
    shape raises ``ValueError``. ``action_type="discrete"``: ``Discrete(7)`` motion
    primitives (stop, forward, forward-left, forward-right, turn left, turn right,
    reverse), see :data:`slam_env.actions.DISCRETE_PRIMITIVES`.

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
    policies expect); :func:`unpack_detections` returns the valid ``(k, 2)`` rows and
    their integer IDs.
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
    ``pose`` (3,) true pose, ``landmark_positions`` (N, 2) and ``landmark_ids`` (N,)
    true map, ``collision`` (bool), ``seen`` (M,) bool: landmark ID i detected so far,
    ``odometry_true`` the noise-free control, ``reward_terms``.

    ## Arguments
    ``gym.make("slam_env/Landmarks-v0", render_mode=None, config=None, **options)``:
    ``config`` an :class:`EnvConfig`; ``options`` flat overrides of any of its fields
    (``n_landmarks=10``, ``max_range=4.0``, ``motion_model``…, see
    :func:`slam_env.config.make_config`), or a user world as ``layout=`` (a
    :class:`Layout`, a dict, or a JSON/YAML path). Unknown options raise ``TypeError``.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(
        self, render_mode: str | None = None, config: EnvConfig | None = None, **options: Any
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, "
                f"got {render_mode!r}"
            )
        self.render_mode = render_mode
        self.config = make_config(config, **options)
        # A batch of one: the native vector env runs the same core for B sub-envs.
        self._core = RawCore(self.config, 1)
        core = self._core
        self.n_landmarks = core.n_landmarks
        self.n_landmark_slots = core.n_slots
        self.arena_size = core.arena_size
        self.max_detections = core.max_detections
        # The sensor models on their own, for users who sense this world themselves.
        self.sensor = LandmarkSensor(self.config.sensor)
        self.odometry = OdometrySensor(self.config.odometry)
        self._max_speed = self.config.robot.max_speed  # m/s at action 1.0
        self._max_turn_rate = self.config.robot.max_turn_rate  # rad/s at action 1.0
        if self.config.action_type == "continuous":
            self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        else:
            self.action_space = spaces.Discrete(len(DISCRETE_PRIMITIVES))
        self.observation_space = core.observation_space
        self._active = np.ones(1, dtype=bool)
        self._started = False
        self._renderer = None
        self._closed = False
        self._trail: list[tuple[float, float]] = []
        self._steps = 0  # since the reset, for the picture
        # Drawn over the world by render(); the EKF-SLAM wrapper sets it.
        self.belief_overlay = None

    # ------------------------------------------------------------------ API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        super().reset(seed=seed)
        if self._closed:
            raise RuntimeError("reset() called on a closed LandmarksEnv; make a new env")
        if options:
            raise ValueError(f"LandmarksEnv.reset takes no options, got {sorted(options)}")
        core = self._core
        layout = core.reset(0, self.np_random)
        self._started = True
        self.belief_overlay = None
        pose = core.worlds.poses[0]
        self._trail = [(float(pose[0]), float(pose[1]))]
        self._steps = 0
        if self._renderer is not None:
            self._renderer.set_layout(layout)
        obs, info = core.observation(0), core.info(0)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(
        self, action: Any
    ) -> tuple[dict[str, np.ndarray], SupportsFloat, bool, bool, dict[str, Any]]:
        if self._closed:
            raise RuntimeError("step() called on a closed LandmarksEnv; make a new env")
        if not self._started:
            raise ResetNeeded("call reset() before step()")
        speed_frac, turn_frac = parse_action(action, self.action_space)
        core = self._core
        core.rngs[0] = self.np_random  # whoever set env.np_random since the reset
        core.step([speed_frac * self._max_speed], [turn_frac * self._max_turn_rate], self._active)
        self._steps += 1
        if self.render_mode is not None:
            pose = core.worlds.poses[0]
            self._trail.append((float(pose[0]), float(pose[1])))
        obs, info = core.observation(0), core.info(0)
        reward = float(core.out.rewards[0])
        terminated = bool(core.terminated[0])
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or "
                "'human' to gym.make"
            )
            return None
        if not self._started:
            raise ResetNeeded("call reset() before render()")
        return self._get_renderer().render(self.render_frame())

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        self._closed = True

    # ------------------------------------------------------------------ helpers
    @property
    def world(self) -> World:
        """The pymunk world of the current episode (after ``reset``)."""
        if not self._started:
            raise ResetNeeded("call reset() before accessing the world")
        return self._core.worlds.worlds[0]

    @property
    def layout(self) -> Layout:
        return self.world.layout

    def render_frame(self):
        """The plain-data :class:`slam_env.rendering.Frame` of the current state, with
        the sensor's visible region traced in the world."""
        from slam_env.visibility import visible_region

        frame = self._core.frame(0, self._trail, self.belief_overlay)
        sensor = self.config.sensor
        frame.visible_region = visible_region(self.world, frame.pose, sensor.max_range, sensor.fov)
        frame.step = self._steps
        return frame

    def _get_renderer(self):
        if self._renderer is None:
            from slam_env.rendering import Renderer

            cfg = self.config
            self._renderer = Renderer(
                self.world.layout,
                robot_radius=cfg.robot.radius,
                max_range=cfg.sensor.max_range,
                fov=cfg.sensor.fov,
                render_mode=self.render_mode,
                render_fps=self.metadata["render_fps"],
            )
        return self._renderer

    # Pickling: the renderer (a pygame window) stays behind; it is rebuilt on demand.
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None
        return state
