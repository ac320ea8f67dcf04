"""Greedy information-gain exploration on the EKF-SLAM belief."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from agents.planners.grid_search import dijkstra, nearest_passable
from agents.planners.heuristic import HeuristicAgent, HeuristicParams
from agents.planners.path_control import PathFollower
from agents.planners.sensor_sweep import box_sum
from slam_env.belief.entropy import ENTROPY_FLOOR, landmark_prior_variance
from slam_env.ekf.models import MEASUREMENT_MODELS
from slam_env.world.frames import odometry_from_poses, velocity_from_poses, wrap_angle

#: (speed, turn) fractions of the default motion primitives: straight, gentle and
#: tighter arcs each way, slow turns and turns on the spot. Turn rates stay at or below
#: 0.6 of the maximum: the odometry noise grows with the square of each step's rotation.
DEFAULT_PRIMITIVES: tuple[tuple[float, float], ...] = (
    (1.0, 0.0),
    (1.0, 0.25),
    (1.0, -0.25),
    (0.8, 0.6),
    (0.8, -0.6),
    (0.3, 0.6),
    (0.3, -0.6),
    (0.0, 0.6),
    (0.0, -0.6),
)


@dataclass(frozen=True)
class InfoGainParams(HeuristicParams):
    """Parameters of :class:`InfoGainAgent` (units in the comments), beyond those of
    :class:`~agents.planners.heuristic.HeuristicParams` (the maps, the frontier window, the
    guided candidate's path following, backing off). ``range_margin`` and
    ``fov_margin`` also narrow the sensor for the observations it predicts."""

    primitives: tuple[tuple[float, float], ...] = DEFAULT_PRIMITIVES  # (speed, turn) fractions
    horizon: int = 6  # env steps a primitive is held in the prediction
    observe_at: tuple[int, ...] = (3, 6)  # steps of the horizon at which observations are predicted
    replan_interval: int = 2  # env steps between decisions (the chosen primitive is held)
    safety_margin: float = 0.15  # m, inflation of the known map beyond the robot radius
    discovery_nats: float | None = None  # nats per landmark discovered; None: from the prior
    frontier_weight: float = 4.0  # nats per m of progress toward the nearest frontier
    field_interval: int = 8  # steps between recomputations of the frontier distance field
    heading_lookahead: float = 0.5  # m, facing the frontier counts as this much nearer
    give_up_radius: float = 2.5  # m, unswept cells this near the robot for too long ...
    give_up_steps: int = 40  # ... (this many steps) are abandoned: out of sight
    collision_penalty: float = 1000.0  # nats per predicted pose in collision
    keep_bonus: float = 0.3  # nats for keeping the previous primitive (less dithering)
    reversal_penalty: float = 2.0  # nats for reversing the previous turn direction on the spot
    guide_length: float = 4.0  # m of frontier-field descent the guided candidate follows
    escape_lookahead: float = 0.3  # m, look-ahead when hemmed in (tight path following)
    # Fraction of the max turn rate the guided candidate uses: at 0.75 it is no better
    # here, at 1.0 its filter leaves the NEES band (docs/goal_policy.md).
    turn_limit: float = 0.6
    recovery_steps: int = 5  # steps of backing off when stuck

    def __post_init__(self) -> None:
        prims = self.primitives
        if not prims or any(len(p) != 2 for p in prims):
            raise ValueError("InfoGainParams.primitives must be non-empty (speed, turn) pairs")
        if any(not (math.isfinite(a) and -1.0 <= a <= 1.0) for p in prims for a in p):
            raise ValueError("InfoGainParams.primitives must hold fractions in [-1, 1]")
        super().__post_init__()
        self._require_counts("horizon", "field_interval", "give_up_steps")
        if not self.observe_at or any(
            not isinstance(k, int) or not 1 <= k <= self.horizon for k in self.observe_at
        ):
            raise ValueError(f"InfoGainParams.observe_at must be steps in [1, {self.horizon}]")
        self._require_positive("give_up_radius", "guide_length", "escape_lookahead")
        self._require_non_negative(
            "frontier_weight",
            "collision_penalty",
            "keep_bonus",
            "reversal_penalty",
            "heading_lookahead",
        )
        if self.discovery_nats is not None:
            self._require_non_negative("discovery_nats")


class InfoGainAgent(HeuristicAgent):
    """Greedy expected-information-gain exploration (active SLAM, one-step lookahead).

    Every ``replan_interval`` steps the agent scores a set of candidate motions from
    the filter's *estimated* pose and executes the best one until the next decision
    (receding horizon). The candidates are the fixed ``primitives`` — (speed, turn)
    commands held for ``horizon`` steps — plus one *guided* candidate: pure pursuit
    down the frontier distance field (below), simulated in closed loop. A candidate's
    score, in nats, is the sum of:

    * **belief information**: on ``filter.copy_with_known_ids()`` (the landmarks of
      the predicted observations are the ones picked, whichever association the
      filter runs), the EKF prediction with the odometry the motion would produce,
      then, at the ``observe_at`` steps, the update with the expected observations
      of the known landmarks in range, FOV and line of sight (zero innovation: only
      the covariance changes); the score is the entropy removed,
      ½·(log det P_now − log det P_after). Turning costs heading certainty, and
      seeing well-known landmarks closes loops, both through this term;
    * **discovery**: the coverage-grid area the sensor would sweep for the first time
      (the footprint at the end of the horizon) × the expected landmark density in the
      unswept area × the nats a discovered landmark is worth (``discovery_nats``, by
      default the slot's prior entropy minus that of an estimate as uncertain as the
      robot's position);
    * **frontier progress**: ``frontier_weight`` × the decrease of the path distance to
      the nearest frontier (a Dijkstra field on the known map, refreshed every
      ``field_interval`` steps; facing downhill counts as ``heading_lookahead`` nearer),
      so that the agent heads somewhere useful when nothing is in view; once
      everything is swept the field leads to the least certain landmarks instead;
    * **collision**: −``collision_penalty`` per predicted pose inside the known map's
      obstacles or the estimated landmark posts, inflated by the robot radius and
      ``safety_margin``.

    Keeping the previous candidate earns ``keep_bonus`` and reversing a turn on the
    spot costs ``reversal_penalty`` (no dithering). When every moving candidate would
    collide (a narrow passage) the agent follows the field's descent path closely
    instead. Unswept cells that stay out of sight while the robot spends
    ``give_up_steps`` next to them are abandoned. What it reads, how it notices
    episodes and how it backs off something it ran into: see
    :class:`~agents.planners.heuristic.HeuristicAgent`.

    Args:
        env: a ``slam_env/ActiveSLAM-v0`` env (continuous actions).
        seed: seed of the agent's random generator.
        **params: overrides of :class:`InfoGainParams`.
    """

    params_class = InfoGainParams
    params: InfoGainParams

    def __init__(self, env: gym.Env, seed: int | None = None, **params: Any) -> None:
        super().__init__(env, seed, **params)
        cfg = self._base.config
        self._range = max(float(cfg.sensor.max_range) - self.params.range_margin, 0.0)
        fov = float(cfg.sensor.fov)
        self._half_fov = math.pi if fov >= 2.0 * math.pi else 0.5 * fov - self.params.fov_margin
        self._n_total = int(self._base.n_landmarks)
        self._prior_var = landmark_prior_variance(*self._base.arena_size)

    def _new_episode(self) -> None:
        self._field: np.ndarray | None = None
        self._since_field = 0
        self._choice = -1
        self._follower: PathFollower | None = None
        self._held = 0
        self._last_scores: np.ndarray | None = None

    def _drop_plan(self) -> None:
        self._field = None
        self._choice = -1
        self._follower = None

    @property
    def last_scores(self) -> np.ndarray | None:
        """(n_candidates, 4) the terms of the last decision — information, discovery,
        frontier progress, collision (nats) — for the primitives in order, then the
        guided candidate when there was one; None before the first decision."""
        return None if self._last_scores is None else self._last_scores.copy()

    # ------------------------------------------------------------------ decision
    def _act(self) -> np.ndarray:
        p = self.params
        pose = self._base.filter.pose
        self._update_maps(pose)
        if self._memory.coverage.expose(pose, p.give_up_radius, p.give_up_steps):
            self._field = None
        self._since_field += 1

        backing_off = self._backing_off(pose)
        if backing_off is not None:
            return backing_off

        if self._choice >= 0 and self._held < p.replan_interval:
            self._held += 1
            return self._command(pose)
        if self._field is None or self._since_field >= p.field_interval:
            self._field = self._distance_field(pose)
            self._since_field = 0
        paths, actions, follower = self._candidates(pose)
        scores = self._score(pose, paths)
        total = scores.sum(axis=1)
        if 0 <= self._choice < len(total):
            total[self._choice] += p.keep_bonus
        # No dithering: turning back the way the robot just turned (on the spot, or
        # nearly) costs extra.
        last_speed, last_turn = self._last_command
        if last_turn != 0.0 and abs(last_speed) < 0.5:
            turns = np.array([float(a[1]) for a in actions])
            total[turns * last_turn < 0.0] -= p.reversal_penalty
        self._last_scores = scores
        self._held = 1
        moving = np.array([abs(float(a[0])) > 0.0 for a in actions])
        if follower is not None and not (moving & (scores[:, 3] == 0.0)).any():
            # Hemmed in (every motion would touch the inflated map): follow the field's
            # descent path closely — it runs through free cells — until out.
            self._follower = PathFollower(follower.points, p.escape_lookahead, self._control)
            self._choice = len(p.primitives)
            return self._follower.action(pose)
        self._choice = int(np.argmax(total))
        self._follower = follower if self._choice == len(p.primitives) else None
        return actions[self._choice]

    def _command(self, pose: np.ndarray) -> np.ndarray:
        """The held candidate's command: its primitive, or the frontier follower's."""
        if self._follower is not None:
            return self._follower.action(pose)
        return np.array(self.params.primitives[self._choice], dtype=np.float32)

    # ------------------------------------------------------------------ prediction
    def _arcs(self, pose: np.ndarray, commands: np.ndarray, steps: int) -> np.ndarray:
        """(k, steps + 1, 3) the poses of a unicycle at ``pose`` holding each of the
        (speed, turn) fraction ``commands`` (k, 2) for ``steps`` env steps (exact
        arcs), starting with ``pose``."""
        c = self._control
        v = commands[:, 0] * c.max_speed  # m/s
        w = commands[:, 1] * c.max_turn_rate  # rad/s
        t = np.arange(steps + 1) * c.dt  # s
        th = pose[2] + w[:, None] * t[None, :]
        straight = np.abs(w) < 1e-9
        w_safe = np.where(straight, 1.0, w)[:, None]
        arc_x = (np.sin(th) - math.sin(pose[2])) / w_safe
        arc_y = (math.cos(pose[2]) - np.cos(th)) / w_safe
        line = t[None, :] * np.ones_like(w)[:, None]
        dx = np.where(straight[:, None], line * math.cos(pose[2]), arc_x) * v[:, None]
        dy = np.where(straight[:, None], line * math.sin(pose[2]), arc_y) * v[:, None]
        out = np.empty((len(commands), steps + 1, 3))
        out[..., 0] = pose[0] + dx
        out[..., 1] = pose[1] + dy
        out[..., 2] = wrap_angle(th)
        return out

    def _candidates(
        self, pose: np.ndarray
    ) -> tuple[np.ndarray, list[np.ndarray], PathFollower | None]:
        """The candidates' predicted poses (k, horizon + 1, 3), their first commands,
        and the frontier follower: the fixed primitives, plus (when the frontier field
        leads somewhere) pure pursuit down the field, simulated in closed loop."""
        p = self.params
        prims = np.asarray(p.primitives, dtype=np.float64)
        paths = self._arcs(pose, prims, p.horizon)
        actions = [np.array(c, dtype=np.float32) for c in p.primitives]
        follower = self._frontier_follower(pose)
        if follower is None:
            return paths, actions, None
        sim = PathFollower(follower.points, follower.lookahead, follower.params)
        guided = np.empty((1, p.horizon + 1, 3))
        guided[0, 0] = pose
        for k in range(p.horizon):
            command = sim.action(guided[0, k]).astype(np.float64)
            if k == 0:
                actions.append(command.astype(np.float32))
            guided[0, k + 1] = self._arcs(guided[0, k], command[None, :], 1)[0, 1]
        return np.concatenate([paths, guided]), actions, follower

    def _frontier_follower(self, pose: np.ndarray) -> PathFollower | None:
        """Pure pursuit along the steepest descent of the frontier field from the
        robot (up to ``guide_length`` m of path), or None at a frontier."""
        field = self._field
        if field is None:
            return None
        start = self._field_cell(field, pose)
        if start is None:
            return None
        grid = self._memory.grid
        points = [pose[:2].copy()]
        for i, j in _downhill(field, start, math.ceil(self.params.guide_length / grid.resolution)):
            points.append(np.array([grid.xs[j], grid.ys[i]]))
        if len(points) < 2:
            return None
        return PathFollower(np.array(points), self.params.lookahead, self._control)

    def _score(self, pose: np.ndarray, paths: np.ndarray) -> np.ndarray:
        """(k, 4) information, discovery, frontier and collision terms of the
        candidates' predicted poses ``paths`` (k, horizon + 1, 3)."""
        p = self.params
        mem = self._memory
        f = self._base.filter
        n = len(paths)
        scores = np.zeros((n, 4))

        # Collision: predicted positions in the inflated known map or a post, unless the
        # robot already is there and the motion does not make it worse.
        pts = paths[:, 1:, :2].reshape(-1, 2)
        blocked = ~mem.is_free_at(pts).reshape(n, p.horizon)
        if not mem.is_free_at(pose[None, :2])[0]:
            clear_now = self._clearance(pose[None, :2])[0]
            worse = self._clearance(pts).reshape(n, p.horizon) < clear_now
            blocked &= worse
        scores[:, 3] = -p.collision_penalty * blocked.sum(axis=1)
        feasible = ~blocked.any(axis=1)

        # Discovery: new area swept at the observation steps.
        cov = mem.coverage
        unswept = cov.unswept
        area = cov.grid.resolution**2
        density = max(self._n_total - f.n_landmarks, 0) / max(
            float(np.count_nonzero(unswept)) * area, 1.0
        )
        value = density * self._discovery_nats(f) * area  # nats per new cell
        # Frontier progress.
        field = self._field
        d_now = self._field_ahead(field, pose)

        logdet_now = self._logdet(f.cov)
        model = f.motion_model
        means = f.landmark_means()
        ids = f.state_to_id
        h = MEASUREMENT_MODELS[f.measurement_model].h
        for k in range(n):
            if not feasible[k] and feasible.any():
                continue  # a colliding primitive never wins: skip the costly terms
            path = paths[k]
            # The observations predicted are of the slots picked here: the copy takes
            # them as given, whether or not the filter associates by itself.
            g = f.copy_with_known_ids()
            for step in range(1, p.horizon + 1):
                p0, p1 = path[step - 1], path[step]
                if model == "odometry":
                    u = odometry_from_poses(p0, p1)
                else:
                    u = velocity_from_poses(p0, p1)
                g.predict(np.asarray(u))
                if step in p.observe_at and len(ids):
                    vis = self._visible(p1, means)
                    if vis.any():
                        g.update(h(p1, means[vis]), ids[vis])
            scores[k, 0] = 0.5 * (logdet_now - self._logdet(g.cov))
            # The footprint at the end: with the one at the start it brackets what a
            # turn of less than the FOV sweeps on the way.
            ii, jj = cov.footprint(path[-1])
            scores[k, 1] = value * float(np.count_nonzero(unswept[ii, jj]))
            d_end = self._field_ahead(field, path[-1])
            if math.isfinite(d_now) and math.isfinite(d_end):
                scores[k, 2] = p.frontier_weight * (d_now - d_end)
        scores[~feasible & feasible.any(), :3] = 0.0
        return scores

    def _visible(self, pose: np.ndarray, means: np.ndarray) -> np.ndarray:
        """(n,) bool: known landmarks the sensor would see from ``pose``."""
        dx = means[:, 0] - pose[0]
        dy = means[:, 1] - pose[1]
        r = np.hypot(dx, dy)
        bearing = wrap_angle(np.arctan2(dy, dx) - pose[2])
        vis = (r <= self._range) & (r > 1e-6) & (np.abs(bearing) <= self._half_fov)
        if vis.any():
            idx = np.flatnonzero(vis)
            vis[idx] = self._memory.grid.line_of_sight(pose[:2], means[idx])
        return vis

    def _discovery_nats(self, f: Any) -> float:
        """Entropy removed by discovering a landmark: its slot's prior (uniform over the
        arena) against a new estimate about as uncertain as the robot's position."""
        if self.params.discovery_nats is not None:
            return self.params.discovery_nats
        vx, vy = self._prior_var
        pc = f.pose_cov
        var = max(0.5 * (pc[0, 0] + pc[1, 1]), 0.0) + 0.05**2  # m², plus sensor noise
        return 0.5 * (math.log(vx + ENTROPY_FLOOR) + math.log(vy + ENTROPY_FLOOR)) - math.log(
            var + ENTROPY_FLOOR
        )

    @staticmethod
    def _logdet(cov: np.ndarray) -> float:
        d = cov.shape[0]
        sign, value = np.linalg.slogdet(cov + ENTROPY_FLOOR * np.eye(d))
        return float(value) if sign > 0 else -math.inf

    def _clearance(self, points: np.ndarray) -> np.ndarray:
        """(k,) clearance (m) of points to the known map, from the planning grid."""
        grid = self._memory.grid
        i, j = grid.cells_of(points)
        return grid.clearance[i, j]

    # ------------------------------------------------------------------ guidance
    def _distance_field(self, pose: np.ndarray) -> np.ndarray:
        """Path distance (m, on the planning grid) to the nearest frontier cell — a free
        cell with at least ``min_gain`` unswept area around it — or, when everything is
        swept, to the viewpoints of the least certain landmarks."""
        p = self.params
        mem = self._memory
        grid = mem.grid
        unswept = mem.coverage.unswept
        res = mem.coverage.grid.resolution
        gain = mem.on_planning_grid(box_sum(unswept, self._gain_cells) * res * res)
        sources = mem.free & (gain >= p.min_gain)
        if not sources.any():
            sources = self._landmark_viewpoints()
        if not sources.any():
            return np.full(grid.shape, np.inf)
        ii, jj = np.nonzero(sources)
        dist, _ = dijkstra(
            mem.free,
            zip(ii.tolist(), jj.tolist(), strict=True),
            resolution=grid.resolution,
            cell_cost=mem.cell_cost,
        )
        return dist

    def _landmark_viewpoints(self) -> np.ndarray:
        """Free planning cells 1–3 m from the three least certain landmarks."""
        grid = self._memory.grid
        f = self._base.filter
        out = np.zeros(grid.shape, dtype=bool)
        if not f.n_landmarks:
            return out
        sig = np.trace(f.landmark_covs(), axis1=1, axis2=2)
        means = f.landmark_means()
        for k in np.argsort(sig)[::-1][:3].tolist():
            dx = grid.xs[None, :] - means[k, 0]
            dy = grid.ys[:, None] - means[k, 1]
            d2 = dx * dx + dy * dy
            out |= (d2 >= 1.0) & (d2 <= 9.0)
        return out & self._memory.free

    def _field_ahead(self, field: np.ndarray | None, pose: np.ndarray) -> float:
        """The field at ``pose``, minus ``heading_lookahead``·cos(heading error to the
        field's descent direction): facing downhill counts as being that much nearer,
        so turning toward the frontier is progress too (and turning away is not)."""
        if field is None:
            return math.inf
        start = self._field_cell(field, pose)
        if start is None:
            return math.inf
        grid = self._memory.grid
        value = float(field[start]) + math.dist(grid.center(*start), pose[:2])
        descent = list(_downhill(field, start, 4))  # up to 4 cells: the downhill direction
        if not descent:
            return value
        x, y = grid.center(*descent[-1])
        err = math.atan2(y - pose[1], x - pose[0]) - pose[2]
        return value - self.params.heading_lookahead * math.cos(err)

    def _field_cell(self, field: np.ndarray, point: np.ndarray) -> tuple[int, int] | None:
        """The planning cell of ``point``, or the nearest one (within 3 cells) that
        ``field`` reaches; None if there is none."""
        cell = self._memory.grid.cell_of(point[0], point[1])
        if math.isfinite(field[cell]):
            return cell
        return nearest_passable(np.isfinite(field), cell, max_radius=3)

    def _field_at(self, field: np.ndarray | None, point: np.ndarray, search: int = 2) -> float:
        """The field at ``point``, or at the nearest reached cell around it."""
        if field is None:
            return math.inf
        grid = self._memory.grid
        i, j = grid.cell_of(point[0], point[1])
        value = field[i, j]
        if math.isfinite(value):
            return float(value)
        window = field[max(i - search, 0) : i + search + 1, max(j - search, 0) : j + search + 1]
        finite = window[np.isfinite(window)]
        return float(finite.min()) + search * grid.resolution if finite.size else math.inf


def _downhill(field: np.ndarray, cell: tuple[int, int], steps: int) -> Iterator[tuple[int, int]]:
    """The cells of steepest descent of ``field`` from ``cell`` (not included): at most
    ``steps``, ending early where no neighbour is lower (a frontier: 0)."""
    i, j = cell
    for _ in range(steps):
        i0, j0 = max(i - 1, 0), max(j - 1, 0)
        window = field[i0 : i + 2, j0 : j + 2]
        a, b = divmod(int(np.argmin(window)), window.shape[1])
        if not window[a, b] < field[i, j]:
            return
        i, j = a + i0, b + j0
        yield i, j
