"""What the single envs share: a ``gymnasium.Env`` over a batched core with B = 1."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from slam_env.envs.actions import DISCRETE_PRIMITIVES, parse_action
from slam_env.envs.pictures import Pictures
from slam_env.render.renderer import Frame, Renderer
from slam_env.world.layouts import Layout, as_floats, as_int
from slam_env.world.pymunk_world import World


def check_reset_options(options: Any, env_name: str) -> None:
    """``TypeError`` unless ``options`` is ``None`` or a mapping, ``ValueError`` unless
    it is empty: the envs take no reset options."""
    if options is not None and not isinstance(options, Mapping):
        raise TypeError(
            f"{env_name}.reset options must be a dict or None, got {type(options).__name__}"
        )
    if options:
        raise ValueError(f"{env_name}.reset takes no options, got {sorted(map(str, options))}")


class CoreEnv(gym.Env):
    """A single env: sub-env 0 of a batched core (:class:`slam_env.core.raw.RawCore` or
    :class:`slam_env.core.active.ActiveCore`) built with B = 1, the very code that the
    native vector env runs for B sub-envs. Subclasses build the core and document the
    env; this class does the rest of Gymnasium's API: reset, step, render, close."""

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def _setup(self, core: Any, render_mode: str | None) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, "
                f"got {render_mode!r}"
            )
        self.render_mode = render_mode
        self._core = core
        self.config = core.config
        self._max_speed = self.config.robot.max_speed  # m/s at action 1.0
        self._max_turn_rate = self.config.robot.max_turn_rate  # rad/s at action 1.0
        if self.config.action_type == "continuous":
            self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        else:
            self.action_space = spaces.Discrete(len(DISCRETE_PRIMITIVES))
        self.observation_space = core.observation_space
        self._active = np.ones(1, dtype=bool)
        self._command = np.zeros((1, 2))
        self._started = False
        # The paths, the step count and the renderer of the pictures: the native vector
        # env keeps its sub-envs' in the same helper, so that both draw one frame.
        self._pictures = Pictures(core, render_mode, self.metadata["render_fps"])

    # ------------------------------------------------------------------ API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        check_reset_options(options, type(self).__name__)  # before the seed is applied
        super().reset(seed=seed)
        core = self._core
        core.reset(0, self.np_random)
        self._started = True
        self._pictures.restart([0])
        obs, info = core.observation(0), core.info(0)
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        if not self._started:
            raise ResetNeeded("call reset() before step()")
        speed_frac, turn_frac = parse_action(action, self.action_space)
        core = self._core
        core.rngs[0] = self.np_random  # whoever set env.np_random since the reset
        command = self._command  # (1, 2): speed m/s, turn rate rad/s
        command[0, 0] = speed_frac * self._max_speed
        command[0, 1] = turn_frac * self._max_turn_rate
        core.step(command, self._active)
        self._pictures.advance([0])
        obs, info = core.observation(0), core.info(0)
        reward = float(core.rewards[0])
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
        return self._pictures.render(0, self._overlay())

    def close(self) -> None:
        """Release the renderer (its window, if any). As in Gymnasium's own envs the
        episode is kept: ``step``, ``reset`` and ``render`` (which reopens what it
        needs) still work."""
        self._pictures.close()

    @property
    def _renderer(self) -> Renderer | None:
        """The renderer, once a frame was drawn (None before, and after ``close``)."""
        return self._pictures.renderers[0]

    # ------------------------------------------------------------------ the world
    @property
    def world(self) -> World:
        """The pymunk world of the current episode (after ``reset``): one object for
        the env's life, relaid at each reset (:meth:`World.relayout`)."""
        if not self._started:
            raise ResetNeeded("call reset() before accessing the world")
        return self._core.worlds.worlds[0]

    @property
    def layout(self) -> Layout:
        """The world of the current episode (after ``reset``)."""
        return self.world.layout

    @property
    def n_landmarks(self) -> int:
        """Landmarks in each world."""
        return self._core.n_landmarks

    @property
    def n_landmark_slots(self) -> int:
        """Landmark IDs 0 … n_landmark_slots − 1 (max ID + 1)."""
        return self._core.n_slots

    @property
    def arena_size(self) -> tuple[float, float]:
        """(width, height) of the arena, m."""
        return self._core.arena_size

    @property
    def max_detections(self) -> int:
        """Rows of the detections in the raw observation."""
        return self._core.max_detections

    def move_landmarks(self, positions: Mapping[int, Any], robot_pose: Any = None) -> None:
        """Move landmarks of this episode's world: ``positions`` maps landmark IDs to
        their new true (x, y), m; with ``robot_pose`` the robot too, to that true
        (x, y, θ) (m, rad), at rest. The belief and the rest of the episode stay as
        they are. This is for what-if worlds: a planner tries its choices on
        ``copy.deepcopy(env)`` with the robot and the landmarks drawn from its belief,
        and gives the copy noise of its own by setting its ``np_random``.

        The moved world, started where the robot is now (or at ``robot_pose``), must
        pass :meth:`~slam_env.world.layouts.Layout.validate` (landmarks in the arena, clear
        of obstacles and walls, no two posts overlapping, the robot clear of them all);
        ``TypeError`` or ``ValueError`` otherwise, and nothing is moved.
        """
        world = self.world  # ResetNeeded before the first reset
        if not isinstance(positions, Mapping):
            raise TypeError(
                f"positions must be a mapping of landmark ID to (x, y), "
                f"got {type(positions).__name__}"
            )
        layout = world.layout
        index = {lid: i for i, lid in enumerate(layout.landmark_ids)}
        moved = list(layout.landmark_positions)
        for key, value in positions.items():
            lid = as_int(key, "a landmark ID of positions")
            if lid not in index:
                raise ValueError(
                    f"positions names landmark ID {lid}, which this world does not have "
                    f"(its IDs: {sorted(index)})"
                )
            moved[index[lid]] = as_floats(value, 2, f"positions[{lid}]")
        new_layout = dataclasses.replace(layout, landmark_positions=tuple(moved))
        pose = world.pose if robot_pose is None else as_floats(robot_pose, 3, "robot_pose")
        # Checked as a world that starts where the robot is (to be).
        here = dataclasses.replace(new_layout, start_pose=pose)
        start = "the robot's now" if robot_pose is None else "robot_pose"
        try:
            here.validate(self.config.robot.radius, wall_thickness=self.config.world.wall_thickness)
        except ValueError as err:
            raise ValueError(
                f"cannot move the landmarks there: {err} (the start pose is {start})"
            ) from None
        self._core.worlds.move_landmarks(0, new_layout, pose)
        self._pictures.set_layout(0, new_layout)

    @property
    def np_random(self) -> np.random.Generator:
        """The env's generator (Gymnasium's, seeded by ``reset(seed=…)``). Setting a
        new one mid-episode gives the noise of every step from the next one on."""
        return gym.Env.np_random.fget(self)

    @np_random.setter
    def np_random(self, value: np.random.Generator) -> None:
        if not isinstance(value, np.random.Generator):
            raise TypeError(f"np_random must be a numpy Generator, got {type(value).__name__}")
        gym.Env.np_random.fset(self, value)
        if self._started:
            # The steps draw their noise a block at a time: drop the old generator's.
            self._core.blocks.drop(0)

    def _overlay(self) -> Any:
        """The belief to draw over the world, if any: the core's, with its estimated
        path and live figures."""
        return self._pictures.belief_overlay(0)

    def render_frame(self) -> Frame:
        """The plain-data :class:`slam_env.render.renderer.Frame` of the current state, with
        the sensor's visible region traced in the world and the step number: the frame
        that :meth:`render` draws (built as the native vector env builds a sub-env's)."""
        return self._pictures.frame(0, self._overlay())
