"""The raw sensor-stream environment, ``slam_env/Landmarks-v0``."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from slam_env.actions import DISCRETE_PRIMITIVES, parse_action
from slam_env.budget import check_budget, world_size
from slam_env.config import EnvConfig, check_option_names, make_config
from slam_env.faults import corrupt_odometry, corrupt_scan, kidnap_pose
from slam_env.layouts import Layout, layout_for
from slam_env.sensors import LandmarkSensor, OdometrySensor
from slam_env.world import World

# Headroom of the odometry translation bound over the largest physical motion of a
# step: the noise is proportional to the motion, so a reading beyond this is a >10σ event.
_ODOMETRY_TRANSLATION_HEADROOM = 4.0
# Detections are clipped to the sensor's range plus this many range standard deviations.
_RANGE_HEADROOM_STD = 6.0


# The env's own arguments besides the config options (for the list of valid names).
ENV_ARGUMENTS = ("config", "render_mode")


def odometry_translation_bound(config: EnvConfig) -> float:
    """The bound (m) of the odometry's translation reading (δtr or Δp)."""
    return _ODOMETRY_TRANSLATION_HEADROOM * config.robot.max_speed * config.dt + 1.0


def detection_reach(config: EnvConfig) -> float:
    """The bound (m) of a detection's range (or robot-frame coordinates)."""
    sensor = config.sensor
    return sensor.max_range + _RANGE_HEADROOM_STD * max(sensor.range_std, sensor.cartesian_std)


def check_reset_options(options: Any, env_name: str) -> None:
    """``TypeError`` unless ``options`` is ``None`` or a mapping, ``ValueError`` unless
    it is empty: the envs take no reset options."""
    if options is not None and not isinstance(options, Mapping):
        raise TypeError(
            f"{env_name}.reset options must be a dict or None, got {type(options).__name__}"
        )
    if options:
        raise ValueError(f"{env_name}.reset takes no options, got {sorted(map(str, options))}")


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
    :class:`Layout`, a dict, or a JSON/YAML path). Flat and nested forms mean the same;
    an option given in both raises ``ValueError``, an unknown one ``TypeError``; numpy
    scalars are taken as the Python values they hold. Every option that scales work or
    memory is checked against :mod:`slam_env.budget` before anything is built.
    ``reset`` takes no options. ``close`` releases the renderer; the env stays usable
    (``step``, ``reset``, and ``render``, which reopens its window), as Gymnasium's are.
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
        check_option_names(options, ENV_ARGUMENTS)
        self.config = make_config(config, **options)
        cfg = self.config
        # Everything that scales work or memory, before any of it is built.
        size = world_size(cfg)
        check_budget(cfg, size)

        # A fixed world (preset or user layout) is built once; a random one at each reset.
        self._fixed_layout: Layout | None = None
        if cfg.layout is not None or cfg.world.preset != "random":
            self._fixed_layout = layout_for(cfg, rng=None)
            ids = self._fixed_layout.landmark_ids
            if not ids:
                raise ValueError("the world has no landmarks: slam_env needs at least one")
            self.n_landmarks = len(ids)
            self.n_landmark_slots = max(ids) + 1
            self.arena_size = (self._fixed_layout.width, self._fixed_layout.height)
        else:
            self.n_landmarks = cfg.world.n_landmarks
            self.n_landmark_slots = cfg.world.n_landmarks
            self.arena_size = (cfg.world.width, cfg.world.height)
        self.max_detections = size.max_detections

        self._max_speed = cfg.robot.max_speed  # m/s at action 1.0
        self._max_turn_rate = cfg.robot.max_turn_rate  # rad/s at action 1.0
        self.sensor = LandmarkSensor(cfg.sensor)
        self._faults_on = cfg.faults.any
        self.odometry = OdometrySensor(cfg.odometry)

        if cfg.action_type == "continuous":
            self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        else:
            self.action_space = spaces.Discrete(len(DISCRETE_PRIMITIVES))
        self.observation_space = self._build_observation_space()

        self._world: World | None = None
        self._renderer = None
        self._seen = np.zeros(self.n_landmark_slots, dtype=bool)
        self._trail: list[tuple[float, float]] = []
        # The last scan (rows, IDs, z), for render_frame.
        self._last_scan: tuple[list[int], list[int], list[tuple[float, float]]] | None = None
        self._last_collision = False
        # Drawn over the world by render(); the EKF-SLAM wrapper sets it.
        self.belief_overlay = None

    # ------------------------------------------------------------------ spaces
    def _build_observation_space(self) -> spaces.Dict:
        cfg = self.config
        trans_bound = odometry_translation_bound(cfg)
        if cfg.odometry.motion_model == "odometry":
            odo_high = np.array([math.pi, trans_bound, math.pi], dtype=np.float32)
        else:
            odo_high = np.array([trans_bound, math.pi], dtype=np.float32)
        self._odometry_low, self._odometry_high = -odo_high, odo_high

        reach = detection_reach(cfg)
        d = self.max_detections
        if cfg.sensor.measurement_model == "range_bearing":
            det_low = np.tile(np.array([0.0, -math.pi], dtype=np.float32), (d, 1))
            det_high = np.tile(np.array([reach, math.pi], dtype=np.float32), (d, 1))
        else:
            det_low = np.full((d, 2), -reach, dtype=np.float32)
            det_high = np.full((d, 2), reach, dtype=np.float32)
        self._det_low, self._det_high = det_low, det_high
        # The same bounds as Python floats, for clipping the few values of a step
        # without numpy calls (clipping in float64 to float32 bounds, then rounding to
        # float32, equals rounding then clipping: the rounding is monotonic).
        self._odometry_bounds = tuple(
            zip(self._odometry_low.tolist(), self._odometry_high.tolist(), strict=True)
        )
        self._detection_bounds = tuple(zip(det_low[0].tolist(), det_high[0].tolist(), strict=True))
        # Padding of an empty observation, and the mask of each detection count k: each
        # step fills or takes a copy (cheaper than building them).
        self._empty_detections = np.zeros(2 * d, dtype=np.float32)
        self._empty_ids = np.full(d, -1.0, dtype=np.float32)
        self._masks = tuple((np.arange(d) < k).astype(np.float32) for k in range(d + 1))
        beams = cfg.sensor.scan_beams
        self._scan_angles = tuple(
            -math.pi + 2.0 * math.pi * (i + 0.5) / beams for i in range(beams)
        )
        obs_spaces = {
            "odometry": spaces.Box(-odo_high, odo_high, dtype=np.float32),
            "detections": spaces.Box(det_low.ravel(), det_high.ravel(), dtype=np.float32),
            "ids": spaces.Box(-1.0, float(self.n_landmark_slots - 1), (d,), np.float32),
            "mask": spaces.Box(0.0, 1.0, (d,), np.float32),
        }
        if beams:
            obs_spaces["scan"] = spaces.Box(0.0, 1.0, (beams,), np.float32)
        if cfg.sensor.bumper:
            obs_spaces["bumper"] = spaces.Box(0.0, 1.0, (1,), np.float32)
        return spaces.Dict(obs_spaces)

    # ------------------------------------------------------------------ API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        check_reset_options(options, type(self).__name__)  # before the seed is applied
        super().reset(seed=seed)
        cfg = self.config
        layout = self._fixed_layout or layout_for(cfg, rng=self.np_random)
        # layout_for validated the layout for this robot and wall thickness.
        self._world = World(
            layout,
            cfg.robot,
            cfg.dt,
            cfg.physics_substeps,
            cfg.world.wall_thickness,
            validated=True,
        )
        self._landmark_positions = self._world.landmark_positions
        # The sensor's form of the same positions (a read-only view, x + i·y).
        self._landmark_points = LandmarkSensor._as_points(self._landmark_positions)
        self._landmark_ids = self._world.landmark_ids
        self._landmark_id_list = self._landmark_ids.tolist()
        # Row order is ID order (the usual case): the sensor need not sort its finds.
        self._ids_ascending = self._landmark_id_list == sorted(self._landmark_id_list)
        self._seen[:] = False
        self._last_collision = False
        self.belief_overlay = None
        pose = self._world.pose
        self._trail = [(pose[0], pose[1])]
        if self._renderer is not None:
            self._renderer.set_layout(layout)

        _, det_ids, z = self._sense(pose, self.np_random)
        self._mark_seen(det_ids)
        zero_control = (0.0,) * self.odometry.dim
        obs = self._get_obs(zero_control, det_ids, z)
        if self._scan_angles:
            obs["scan"] = self._scan(pose)
        if self.config.sensor.bumper:
            obs["bumper"] = np.zeros(1, dtype=np.float32)  # layouts start clear
        info = self._get_info(pose, zero_control, {"new_landmarks": 0.0, "collision": 0.0})
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(
        self, action: Any
    ) -> tuple[dict[str, np.ndarray], SupportsFloat, bool, bool, dict[str, Any]]:
        world = self._world
        if world is None:
            raise ResetNeeded("call reset() before step()")
        speed_frac, turn_frac = parse_action(action, self.action_space)
        cfg = self.config
        rng = self.np_random

        # Simulate: the physics runs several substeps per env step.
        pose0 = world.pose
        collided = world.step(speed_frac * self._max_speed, turn_frac * self._max_turn_rate)
        pose1 = world.pose
        self._last_collision = collided

        # Observe: odometry of the motion just made, then the landmark sensor. The
        # private sensor methods skip the checks of the public ones (the env's inputs
        # are well-formed by construction) and work on plain floats.
        odometry = self.odometry
        true_control = odometry._true_control(pose0, pose1)
        control = odometry._perturb(true_control, rng)
        kidnapped = False
        if self._faults_on:
            control = corrupt_odometry(control, cfg.faults, rng)
            kidnapped = self._maybe_kidnap()
            pose1 = world.pose
        if self.render_mode is not None:
            self._trail.append((pose1[0], pose1[1]))
        _, det_ids, z = self._sense(pose1, rng)
        if self._faults_on:
            det_ids, z = corrupt_scan(det_ids, z, self._seen, cfg.faults, cfg.sensor, rng)
        n_new = self._mark_seen(det_ids)

        # Reward terms, then episode end.
        new_term = cfg.reward.new_landmark_bonus * n_new
        collision_term = -cfg.reward.collision_penalty if collided else 0.0
        terms = {"new_landmarks": new_term, "collision": collision_term}
        reward = 0.0 + new_term + collision_term  # what sum(terms.values()) adds
        terminated = bool(cfg.terminate_when_all_detected and self._all_seen())
        obs = self._get_obs(control, det_ids, z)
        if self._scan_angles:
            obs["scan"] = self._scan(pose1)
        if cfg.sensor.bumper:
            obs["bumper"] = np.array([1.0 if collided else 0.0], dtype=np.float32)
        info = self._get_info(pose1, true_control, terms)
        if self._faults_on:
            info["kidnapped"] = kidnapped
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, False, info

    def _maybe_kidnap(self) -> bool:
        rate = self.config.faults.kidnap_rate
        if rate > 0.0 and self.np_random.random() < rate:
            pose = kidnap_pose(self._world, self.np_random)
            if pose is not None:
                self._world.set_pose(*pose)
                return True
        return False

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or "
                "'human' to gym.make"
            )
            return None
        if self._world is None:
            raise ResetNeeded("call reset() before render()")
        return self._get_renderer().render(self.render_frame())

    def close(self) -> None:
        """Release the renderer (its window, if any). As in Gymnasium's own envs the
        episode is kept: ``step``, ``reset`` and ``render`` (which reopens what it
        needs) still work."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # ------------------------------------------------------------------ helpers
    @property
    def world(self) -> World:
        """The pymunk world of the current episode (after ``reset``)."""
        if self._world is None:
            raise ResetNeeded("call reset() before accessing the world")
        return self._world

    @property
    def layout(self) -> Layout:
        return self.world.layout

    def _sense(
        self, pose: tuple[float, float, float], rng: np.random.Generator
    ) -> tuple[list[int], list[int], list[tuple[float, float]]]:
        """The scan from ``pose``: the detections' rows, IDs and z, sorted by ID, as
        Python lists (what the observation is built from; no intermediate arrays)."""
        x, y, theta = pose
        scan = self.sensor._scan(
            x,
            y,
            theta,
            self._landmark_points,
            self._landmark_id_list,
            rng,
            self._world._landmark_visible_from,
            ids_ascending=self._ids_ascending,
        )
        self._last_scan = scan
        return scan

    def _mark_seen(self, ids: list[int]) -> int:
        seen = self._seen
        new = [i for i in ids if not seen[i]]
        if new:
            seen[new] = True
        return len(new)

    def _all_seen(self) -> bool:
        return bool(np.all(self._seen[self._landmark_ids]))

    def _scan(self, pose: tuple[float, float, float]) -> np.ndarray:
        """The proximity scan, each beam's free distance / ``scan_range`` in [0, 1]."""
        reach = self.config.sensor.scan_range
        distances = self._world.range_scan(*pose, self._scan_angles, reach)
        return np.array(distances, dtype=np.float32) / np.float32(reach)

    def _get_obs(
        self, control: tuple[float, ...], ids_found: list[int], z: list[tuple[float, float]]
    ) -> dict[str, np.ndarray]:
        k = len(ids_found)
        det = self._empty_detections.copy()
        ids = self._empty_ids.copy()
        mask = self._masks[k].copy()
        if k:
            # Clipped with comparisons: builtin min/max calls cost several times more.
            (a_lo, a_hi), (b_lo, b_hi) = self._detection_bounds
            det[: 2 * k] = [
                v
                for a, b in z
                for v in (
                    a_lo if a < a_lo else a_hi if a > a_hi else a,
                    b_lo if b < b_lo else b_hi if b > b_hi else b,
                )
            ]
            ids[:k] = ids_found
        odometry = [
            lo if u < lo else hi if u > hi else u
            for u, (lo, hi) in zip(control, self._odometry_bounds, strict=True)
        ]
        return {
            "odometry": np.array(odometry, dtype=np.float32),
            "detections": det,
            "ids": ids,
            "mask": mask,
        }

    def _get_info(
        self, pose: tuple[float, float, float], true_control: np.ndarray, terms: dict[str, float]
    ) -> dict[str, Any]:
        return {
            "pose": np.array(pose, dtype=np.float64),
            "landmark_positions": self._landmark_positions.copy(),
            "landmark_ids": self._landmark_ids.copy(),
            "collision": self._last_collision,
            # Fixed size (one entry per landmark ID), so vector envs can stack it.
            "seen": self._seen.copy(),
            "odometry_true": np.array(true_control, dtype=np.float64),
            "reward_terms": terms,  # a new dict from each step and reset
        }

    def render_frame(self):
        """The plain-data :class:`slam_env.rendering.Frame` of the current state."""
        from slam_env.geometry import robot_to_world
        from slam_env.rendering import Frame

        pose = self.world.pose
        scan = self._last_scan
        if scan is not None and scan[0]:
            z = np.array(scan[2], dtype=np.float64)
            if self.config.sensor.measurement_model == "range_bearing":
                r, phi = z[:, 0], z[:, 1]
                local = np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)
            else:
                local = z
            points = robot_to_world(pose, local)
            ids = np.array(scan[1], dtype=np.int64)
        else:
            points = np.zeros((0, 2))
            ids = np.zeros(0, dtype=np.int64)
        return Frame(
            pose=pose,
            trail=np.array(self._trail, dtype=np.float64).reshape(-1, 2),
            detections_world=points,
            detected_ids=ids,
            seen_mask=self._seen[self._landmark_ids].copy(),
            collision=self._last_collision,
            belief=self.belief_overlay,
        )

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
