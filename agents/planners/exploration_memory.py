"""What an exploring agent keeps through an episode: :class:`ExplorationMemory` (its
planning and coverage grids, inflated by the robot and the estimated landmark posts),
:class:`EpisodeWatch` (notices a new episode without ``episode_start``) and
:class:`StuckDetector` (blocked by something unmapped). Built from the known map only."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from agents.planners.grid_map import GridMap
from agents.planners.grid_search import nearest_passable
from agents.planners.sensor_sweep import CoverageMap
from slam_env.config import EnvConfig
from slam_env.world.layouts import LANDMARK_POST_RADIUS, Layout


class EpisodeWatch:
    """Detects the start of a new episode from what an agent can see, for callers that
    do not pass ``episode_start``: the raw env's layout or the filter object changed,
    the filter lost landmarks, or its pose covariance is back to exactly zero (the
    known start pose) after the agent has acted."""

    def __init__(self) -> None:
        self._layout: object = None
        self._filter: object = None
        self._n_landmarks = 0
        self._acted = False

    def is_new(self, base: Any) -> bool:
        """Whether ``base`` (the ActiveSLAM env) started an episode since :meth:`mark`."""
        layout = base.layout
        f = base.filter
        new = (
            layout is not self._layout
            or f is not self._filter
            or f.n_landmarks < self._n_landmarks
            or (self._acted and not np.any(f.pose_cov))
        )
        return bool(new)

    def mark(self, base: Any) -> None:
        """Record the state after the agent chose an action."""
        self._layout = base.layout
        self._filter = base.filter
        self._n_landmarks = int(base.filter.n_landmarks)
        self._acted = True

    def forget(self) -> None:
        self._acted = False
        self._n_landmarks = 0


class StuckDetector:
    """Notices that the robot is blocked by something it does not know about: over the
    last ``steps`` steps it commanded at least ``min_command`` of the max speed, but
    its (estimated) position moved less than ``ratio`` of the commanded distance.
    Odometry measures the true motion, so a robot pushing against an unmapped
    obstacle sees its estimate stand still.

    Args:
        steps: the window, env steps.
        min_command: speed fraction that counts as "trying to move".
        ratio: fraction of the commanded travel below which the robot is stuck.
        step_length: m travelled in one step at full speed (max_speed · dt).
    """

    def __init__(
        self,
        steps: int = 4,
        min_command: float = 0.3,
        ratio: float = 0.25,
        step_length: float = 0.2,
    ) -> None:
        self.steps = int(steps)
        self.min_command = float(min_command)
        self.ratio = float(ratio)
        self.step_length = float(step_length)
        self._positions: list[tuple[float, float]] = []
        self._commands: list[float] = []

    def clear(self) -> None:
        self._positions.clear()
        self._commands.clear()

    def update(self, position: Sequence[float], command: float) -> bool:
        """Record the position at which ``command`` (speed fraction) is issued; True
        when the robot is stuck (the window is then cleared)."""
        self._positions.append((float(position[0]), float(position[1])))
        self._commands.append(float(command))
        if len(self._positions) > self.steps + 1:
            del self._positions[0]
            del self._commands[0]
        if len(self._positions) <= self.steps:
            return False
        cmds = self._commands[:-1]  # the commands whose motion has been observed
        if min(cmds) < self.min_command:
            return False
        (x0, y0), (x1, y1) = self._positions[0], self._positions[-1]
        expected = sum(abs(c) for c in cmds) * self.step_length
        if math.hypot(x1 - x0, y1 - y0) < self.ratio * expected:
            self.clear()
            return True
        return False


class ExplorationMemory:
    """Per-episode memory of an exploring robot, built from the known map only.

    Holds the planning grid and its configuration space (known map inflated by the
    robot radius plus ``safety_margin``, and the *estimated* landmark posts), an
    obstacle-proximity cost for the planner, and the coverage grid the sensor has
    swept from the estimated poses.

    Args:
        layout: the known map (its landmarks are never read).
        config: the env's :class:`~slam_env.config.EnvConfig` (robot radius, sensor
            range and FOV, wall thickness).
        planning_resolution, coverage_resolution: m, the two grids' cells.
        safety_margin: m, extra inflation beyond the robot radius.
        soft_clearance: m, cells closer than this to the known map cost more.
        proximity_cost: the extra cost factor of a cell at the inflation boundary.
        range_margin, fov_margin: see :class:`CoverageMap`.
    """

    def __init__(
        self,
        layout: Layout,
        config: EnvConfig,
        *,
        planning_resolution: float = 0.25,
        coverage_resolution: float = 0.5,
        safety_margin: float = 0.07,
        soft_clearance: float = 0.8,
        proximity_cost: float = 3.0,
        range_margin: float = 0.4,
        fov_margin: float = math.radians(4.0),
    ) -> None:
        wall = float(config.world.wall_thickness)
        robot = config.robot
        sensor = config.sensor
        self.layout = layout
        self.grid = GridMap.from_layout(layout, planning_resolution, wall)
        self.coverage = CoverageMap(
            GridMap.from_layout(layout, coverage_resolution, wall),
            sensor.max_range,
            sensor.fov,
            occluders=self.grid,
            range_margin=range_margin,
            fov_margin=fov_margin,
        )
        self.inflation = float(robot.radius) + safety_margin
        self.post_radius = LANDMARK_POST_RADIUS + self.inflation
        self.static_free = self.grid.passable(self.inflation)
        self.free = self.static_free.copy()
        self._posts = np.zeros((0, 2))
        self._bumps: list[tuple[float, float, float]] = []
        band = max(soft_clearance - self.inflation, 1e-9)
        closeness = np.clip((soft_clearance - self.grid.clearance) / band, 0.0, 1.0)
        self.cell_cost = 1.0 + proximity_cost * closeness
        # The coverage cell of each planning cell (row and column maps).
        cg = self.coverage.grid
        self.cov_rows = np.clip((self.grid.ys / cg.resolution).astype(np.intp), 0, cg.ny - 1)
        self.cov_cols = np.clip((self.grid.xs / cg.resolution).astype(np.intp), 0, cg.nx - 1)

    def set_posts(self, means: np.ndarray) -> None:
        """Block the estimated landmark posts (k, 2) in the configuration space."""
        self._posts = np.asarray(means, dtype=np.float64).reshape(-1, 2)
        self._update_free()

    def add_bump(self, point: Sequence[float], radius: float) -> None:
        """Block a disc of ``radius`` (m) around ``point``: something the robot ran
        into there (in the estimated frame) that the known map does not show where
        the robot thinks it is."""
        self._bumps.append((float(point[0]), float(point[1]), float(radius)))
        self._update_free()

    def _update_free(self) -> None:
        free = self.grid.passable(self.inflation, self._posts, self.post_radius)
        for x, y, r in self._bumps:
            free &= self.grid.passable(-math.inf, np.array([[x, y]]), r)
        self.free = free

    def on_planning_grid(self, coverage_values: np.ndarray) -> np.ndarray:
        """Resample a (coverage-grid) array onto the planning grid."""
        return coverage_values[self.cov_rows[:, None], self.cov_cols[None, :]]

    def start_cell(self, position: Sequence[float]) -> tuple[int, int]:
        """The planning cell to search from: the robot's, or the nearest free one."""
        cell = self.grid.cell_of(position[0], position[1])
        near = nearest_passable(self.free, cell)
        return cell if near is None else near

    def path_points(self, cells: Sequence[tuple[int, int]]) -> np.ndarray:
        """(k, 2) world coordinates of the centres of ``cells``."""
        arr = np.asarray(cells, dtype=np.intp).reshape(-1, 2)
        return np.stack([self.grid.xs[arr[:, 1]], self.grid.ys[arr[:, 0]]], axis=-1)

    def is_free_at(self, points: np.ndarray) -> np.ndarray:
        """(k,) bool: whether each point (k, 2) lies in a free planning cell."""
        i, j = self.grid.cells_of(points)
        return self.free[i, j]
