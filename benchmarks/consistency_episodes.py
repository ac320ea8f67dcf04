"""The episodes of the consistency benchmark (:mod:`benchmarks.bench_consistency`):
``slam_env/Landmarks-v0`` driven by :class:`TourDriver` and recorded as every belief
is then fed them (:class:`Recording`).

The driver works from the true pose: it drives A* paths on the layout's known map
(obstacles and landmark posts inflated by the robot's radius) to the nearest landmark
not yet seen from within :data:`SEEN_CLOSE` metres, and once all have been, back to the
start (a loop closure) and round again. It reads only the truth and never the noise,
so every belief gets the same data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

import slam_env  # noqa: F401  (registers the env IDs)
from agents.planners.grid_map import GridMap
from agents.planners.grid_search import astar, nearest_passable
from agents.planners.path_control import ControllerParams, PathFollower
from references.smoother import Episode
from slam_env.config import make_config
from slam_env.sensing.raw_observation import unpack_detections
from slam_env.world.layouts import LANDMARK_POST_RADIUS

__all__ = ["ENV_ID", "Recording", "TourDriver", "env_options", "record_episode"]

ENV_ID = "slam_env/Landmarks-v0"

SEEN_CLOSE = 3.0  # m, a landmark detected from closer than this needs no visit
GOAL_REACHED = 0.4  # m of path left at which the driver takes the next goal
STUCK_STEPS = 25  # steps without 0.1 m of progress before the driver gives a goal up
INFLATION_MARGIN = 0.1  # m of clearance kept beyond the robot's radius


# --------------------------------------------------------------------------- driving


class TourDriver:
    """A deterministic explorer on the true pose (see the module docstring)."""

    def __init__(self, env: gym.Env) -> None:
        base = env.unwrapped
        layout = base.layout
        robot = base.config.robot
        self.grid = GridMap.from_layout(layout, resolution=0.2)
        inflate = robot.radius + INFLATION_MARGIN
        posts = np.asarray(layout.landmark_positions, dtype=np.float64)
        self.passable = self.grid.passable(inflate, posts, LANDMARK_POST_RADIUS + inflate)
        self.controller = ControllerParams(
            max_speed=robot.max_speed,
            max_turn_rate=robot.max_turn_rate,
            turn_limit=0.5,
            dt=base.config.dt,
        )
        self.ids = np.asarray(layout.landmark_ids, dtype=np.int64)
        self.posts = posts
        self.home = np.asarray(layout.start_pose[:2], dtype=np.float64)
        self.done = np.zeros(len(self.ids), dtype=bool)
        self.follower: PathFollower | None = None
        self.goal_index = -1  # the landmark being visited, -1 for home
        self.best_left = math.inf
        self.since_progress = 0

    def observe(self, z: np.ndarray, ids: np.ndarray) -> None:
        """Mark the landmarks detected from within SEEN_CLOSE."""
        close = ids[(ids >= 0) & (z[:, 0] < SEEN_CLOSE)] if len(ids) else ids
        self.done |= np.isin(self.ids, close)

    def _plan(self, pose: np.ndarray) -> None:
        """A path to the nearest landmark not done (home when all are), skipping
        landmarks it cannot reach."""
        start = self.grid.cell_of(float(pose[0]), float(pose[1]))
        while True:
            left = np.flatnonzero(~self.done)
            if len(left):
                k = int(left[np.argmin(np.hypot(*(self.posts[left] - pose[:2]).T))])
                target = self.posts[k]
            else:
                k, target = -1, self.home
            goal = nearest_passable(self.passable, self.grid.cell_of(*target))
            cells = None if goal is None else astar(self.passable, start, goal)
            if cells or k < 0:
                break
            self.done[k] = True  # unreachable: give it up
        self.goal_index = k
        if not cells:  # not even home is reachable from here: drive at it
            points = np.array([target])
        else:
            points = np.array([self.grid.center(i, j) for i, j in cells])
        self.follower = PathFollower(points, lookahead=0.6, params=self.controller)
        self.best_left = math.inf
        self.since_progress = 0

    def act(self, pose: np.ndarray) -> np.ndarray:
        """The action (speed, turn) fractions from the true pose."""
        if self.follower is None or (self.goal_index >= 0 and self.done[self.goal_index]):
            self._plan(pose)
        _, left = self.follower.progress(pose[:2])
        if left < self.best_left - 0.1:
            self.best_left, self.since_progress = left, 0
        else:
            self.since_progress += 1
        if left < GOAL_REACHED or self.since_progress > STUCK_STEPS:
            if self.goal_index >= 0:
                self.done[self.goal_index] = True
            else:  # home again: start another round
                self.done[:] = False
            self._plan(pose)
        return self.follower.action(pose)


# --------------------------------------------------------------------------- data


@dataclass
class Recording:
    """One episode as the env gave it: the data (:class:`Episode`, known IDs only),
    each step's detections as the filters see them (``z``, ``ids`` with −1 for a
    detection the env did not label), the true poses (T+1, 3) and the true landmark
    positions by ID."""

    episode: Episode
    detections: list[tuple[np.ndarray, np.ndarray]]
    true_poses: np.ndarray
    truth: dict[int, np.ndarray]
    n_landmarks: int
    n_slots: int


def env_options(odometry_scale: float, clutter: float) -> dict[str, Any]:
    """The env's options: the default world with the odometry noise scaled, and
    ``clutter_rate``."""
    alphas = tuple(odometry_scale * a for a in make_config().odometry.alphas)
    return {"alphas": alphas, "clutter_rate": clutter}


def record_episode(env: gym.Env, seed: int, steps: int) -> Recording:
    """Drive one episode of ``steps`` steps with :class:`TourDriver`."""
    obs, info = env.reset(seed=seed)
    driver = TourDriver(env)
    config = env.unwrapped.config
    poses = [np.asarray(info["pose"], dtype=np.float64)]
    controls, detections = [], []
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(driver.act(poses[-1]))
        z, ids = unpack_detections(obs)  # clutter reads ID −1
        driver.observe(z, ids)
        poses.append(np.asarray(info["pose"], dtype=np.float64))
        controls.append(np.asarray(obs["odometry"], dtype=np.float64))
        detections.append((z, ids))
        if terminated or truncated:
            break
    labelled = [(t, z[ids >= 0], ids[ids >= 0]) for t, (z, ids) in enumerate(detections, 1)]
    episode = Episode(
        start_pose=poses[0],
        controls=np.array(controls),
        steps=np.concatenate([np.full(len(i), t, dtype=np.int64) for t, _, i in labelled]),
        ids=np.concatenate([i for _, _, i in labelled]).astype(np.int64),
        z=np.concatenate([z.reshape(-1, 2) for _, z, _ in labelled]),
        motion_model=config.odometry.motion_model,
        motion_params=(
            config.odometry.alphas
            if config.odometry.motion_model == "odometry"
            else config.odometry.velocity_noise
        ),
        measurement_model=config.sensor.measurement_model,
        measurement_cov=np.asarray(config.sensor.measurement_cov, dtype=np.float64),
    )
    truth = {
        int(i): np.asarray(p, dtype=np.float64)
        for i, p in zip(info["landmark_ids"], info["landmark_positions"], strict=True)
        if i >= 0
    }
    return Recording(
        episode, detections, np.array(poses), truth, len(truth), env.unwrapped.n_landmark_slots
    )
