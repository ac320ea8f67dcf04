"""Frontier exploration with loop closing, on the EKF-SLAM belief."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from agents.planners.grid_search import dijkstra, nearest_passable, path_from_parents
from agents.planners.heuristic import HeuristicAgent, HeuristicParams
from agents.planners.path_control import ControllerParams, PathFollower, unicycle_control
from agents.planners.sensor_sweep import box_sum
from slam_env.world.frames import wrap_angle

EXPLORE, LOCALISE, REFINE = "explore", "localise", "refine"
#: m², a reachable part of the planning grid smaller than this is a pocket to leave,
#: toward the nearest free cell within POCKET_EXIT cells of a part at least this large.
POCKET_AREA = 1.0
POCKET_EXIT = 8
#: What :meth:`FrontierAgent._frontier_terms` gives per planning cell.
FrontierTerms = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class FrontierParams(HeuristicParams):
    """Parameters of :class:`FrontierAgent` (units in the comments), beyond (and with the
    defaults of) :class:`~agents.planners.heuristic.HeuristicParams`."""

    gain_weight: float = 1.5  # m of path traded per m² of unswept area at the target
    turn_weight: float = 1.0  # m of path traded per rad of turn toward a target
    switch_margin: float = 1.0  # m, a new target must score this much better than the current
    goal_tolerance: float = 0.35  # m, a target is reached this close
    look_tolerance: float = math.radians(20.0)  # rad, facing a look-at point this well
    look_timeout: int = 15  # steps spent turning toward a look-at point at most
    loop_close_std: float = 0.4  # m, pose σ (√trace of the position cov) that starts a loop closure
    loop_close_done_std: float = 0.2  # m, pose σ at which loop closing stops
    loop_close_timeout: int = 40  # steps before a loop closure gives up (and pauses as long)
    loop_close_step: float = 0.1  # m, σ growth before retrying a loop closure that failed
    useful_ratio: float = 0.5  # loop closing only uses landmarks with σ below this × pose σ
    max_detour: float = 5.0  # m, loop closing only uses landmarks with a viewpoint this near
    view_distance: tuple[float, float] = (1.0, 3.0)  # m, viewpoint ring around a landmark
    uncertainty_weight: float = 10.0  # m of path per m of landmark σ (landmark choice)
    cruise: float = 1.0  # fraction of max speed when aligned with the path

    def __post_init__(self) -> None:
        super().__post_init__()
        self._require_counts("look_timeout", "loop_close_timeout")
        self._require_positive(
            "goal_tolerance",
            "look_tolerance",
            "loop_close_std",
            "loop_close_done_std",
            "loop_close_step",
            "max_detour",
            "cruise",
        )
        self._require_non_negative(
            "gain_weight", "turn_weight", "switch_margin", "useful_ratio", "uncertainty_weight"
        )
        if self.loop_close_done_std > self.loop_close_std:
            raise ValueError("FrontierParams.loop_close_done_std must be <= loop_close_std")
        lo, hi = self.view_distance
        if not 0.0 <= lo < hi:
            raise ValueError("FrontierParams.view_distance must be (lo, hi), 0 <= lo < hi")


class FrontierAgent(HeuristicAgent):
    """Frontier exploration on the EKF-SLAM belief, with loop closing.

    Each step the agent sweeps a coarse coverage grid with the sensor footprint (range,
    FOV, occlusion by the known map) seen from the filter's *estimated* pose. It plans
    with Dijkstra on a grid of the known map (walls and obstacles inflated by the robot
    radius plus ``safety_margin``, and the estimated landmark posts) to the frontier
    target that minimises path length − ``gain_weight``·(unswept area around it) +
    ``turn_weight``·(turn toward it), keeps its target unless another is
    ``switch_margin`` better, follows the path with pure pursuit (at up to ``turn_limit``
    of the robot's turn rate) and, on arrival, turns to face what is left unswept there
    (or gives it up, if it stays out of sight).

    When the pose uncertainty σ = √(Σxx + Σyy) from ``filter.pose_cov`` exceeds
    ``loop_close_std`` it closes a loop instead: it drives to a viewpoint of a known
    landmark that is known much better than the pose (σ below ``useful_ratio``·σ
    pose), within ``max_detour``, cheapest to reach and best known, and faces it,
    until σ falls below ``loop_close_done_std`` (or ``loop_close_timeout`` passes: it
    then explores on and retries only once σ has grown by ``loop_close_step``). Once
    nothing is left to sweep it revisits the least certain landmarks in turn. What
    it reads, how it notices episodes and how it backs off something it ran into:
    see :class:`~agents.planners.heuristic.HeuristicAgent`. Deterministic given ``seed``.

    Args:
        env: a ``slam_env/ActiveSLAM-v0`` env (continuous actions).
        seed: seed of the agent's random generator.
        **params: overrides of :class:`FrontierParams`.
    """

    params_class = FrontierParams
    params: FrontierParams

    def _controller(self) -> ControllerParams:
        return dataclasses.replace(super()._controller(), cruise=self.params.cruise)

    def _new_episode(self) -> None:
        self._mode = EXPLORE
        self._follower: PathFollower | None = None
        self._look_at: np.ndarray | None = None
        self._look_steps = 0
        self._target_landmark = -1
        self._since_plan = 0
        self._mode_steps = 0
        self._tried: set[int] = set()
        self._cooldown = 0
        self._trigger = self.params.loop_close_std
        self._gain_weight = self.params.gain_weight  # m of path per m² of unswept area

    @property
    def mode(self) -> str:
        """``"explore"``, ``"localise"`` (closing a loop) or ``"refine"`` (all swept)."""
        return self._mode

    @property
    def goal(self) -> np.ndarray | None:
        """(2,) the position (m, estimated frame) the agent is driving to, or None."""
        return None if self._follower is None else self._follower.goal

    @property
    def target_landmark(self) -> int | None:
        """The landmark ID a loop closure or revisit is heading for, or None."""
        return None if self._target_landmark < 0 else self._target_landmark

    # ------------------------------------------------------------------ decision
    def _act(self) -> np.ndarray:
        p = self.params
        f = self._base.filter
        pose = f.pose
        sigma = self._sigma()
        backing_off = self._observe(pose)
        if backing_off is not None:
            return backing_off

        # Close a loop when lost; stop when localised again. A loop closure that
        # timed out is not retried for as long again.
        if sigma < p.loop_close_std:
            self._trigger = p.loop_close_std
        if (
            self._mode != LOCALISE
            and not self._cooldown
            and sigma > self._trigger
            and f.n_landmarks
        ):
            self._set_mode(LOCALISE)
        elif self._mode == LOCALISE and (
            sigma < p.loop_close_done_std or self._mode_steps > p.loop_close_timeout
        ):
            self._give_up_localising(sigma)

        if self._look_at is None and self._needs_plan(pose):
            self._plan(pose)
        return self._drive(pose)

    def _observe(self, pose: np.ndarray) -> np.ndarray | None:
        """Sweep the maps from ``pose`` and count the step; the recovery action while
        backing off from something the robot ran into, else None."""
        if self._update_maps(pose) and self._follower is not None:
            path = self._follower.points[1:]
            if not self._memory.is_free_at(path).all():
                self._follower = None  # a new post blocks the path
        self._since_plan += 1
        self._mode_steps += 1
        self._cooldown = max(self._cooldown - 1, 0)
        return self._backing_off(pose)

    def _sigma(self) -> float:
        cov = self._base.filter.pose_cov
        return math.sqrt(max(cov[0, 0] + cov[1, 1], 0.0))

    def _give_up_localising(self, sigma: float) -> None:
        """Back to exploring; if still lost, only try again once σ has grown further."""
        p = self.params
        if sigma >= p.loop_close_done_std:
            self._cooldown = p.loop_close_timeout
            self._trigger = max(p.loop_close_std, sigma + p.loop_close_step)
        self._set_mode(EXPLORE)

    def _set_mode(self, mode: str) -> None:
        self._mode = mode
        self._mode_steps = 0
        self._follower = None
        self._look_at = None
        self._target_landmark = -1
        self._tried.clear()

    def _needs_plan(self, pose: np.ndarray) -> bool:
        if self._follower is None or self._since_plan >= self.params.replan_interval:
            return True
        if self._mode == EXPLORE and self._gain_at(self._follower.goal) < self.params.min_gain:
            return True
        off_path, _ = self._follower.progress(pose)
        return off_path > 1.0

    def _unswept(self) -> np.ndarray:
        return self._memory.coverage.unswept

    def _window(self, point: np.ndarray) -> tuple[slice, slice]:
        """The coverage cells within ``gain_radius`` (a square) of ``point``."""
        i, j = self._memory.coverage.grid.cell_of(point[0], point[1])
        r = self._gain_cells
        return slice(max(i - r, 0), i + r + 1), slice(max(j - r, 0), j + r + 1)

    def _gain_at(self, point: np.ndarray) -> float:
        """Unswept area (m²) around ``point``."""
        res = self._memory.coverage.grid.resolution
        return float(np.count_nonzero(self._unswept()[self._window(point)])) * res * res

    def _unswept_centroid(self, point: np.ndarray) -> np.ndarray | None:
        cg = self._memory.coverage.grid
        rows, cols = self._window(point)
        ii, jj = np.nonzero(self._unswept()[rows, cols])
        if not len(ii):
            return None
        return np.array([cg.xs[jj + cols.start].mean(), cg.ys[ii + rows.start].mean()])

    # ------------------------------------------------------------------ planning
    def _paths_from(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Path lengths (m) over the planning grid from ``pose``, and the parents.

        The robot can squeeze into a pocket: a few free cells that the inflated map
        walls off from the rest (it fits between obstacles closer than twice the
        inflation). Searched from there, nothing is reachable and the robot would stand
        still for good; the search then starts from the nearest free cell outside the
        pocket, and the path from the robot's pose to it leads out the way it came in."""
        mem = self._memory
        res = mem.grid.resolution
        start = mem.start_cell(pose)
        dist, parent = dijkstra(mem.free, [start], resolution=res, cell_cost=mem.cell_cost)
        if np.count_nonzero(np.isfinite(dist)) * res * res < POCKET_AREA:
            # Moves never cut corners, so the 4-connected parts are what a search reaches.
            parts, _ = ndimage.label(mem.free)
            sizes = np.bincount(parts.ravel()) * res * res
            sizes[0] = 0.0  # the blocked cells
            escape = nearest_passable(sizes[parts] >= POCKET_AREA, start, POCKET_EXIT)
            if escape is not None:
                return dijkstra(mem.free, [escape], resolution=res, cell_cost=mem.cell_cost)
        return dist, parent

    def _plan(self, pose: np.ndarray, paths: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Pick the goal of the current mode and the path to it (``paths``: those of
        :meth:`_paths_from` at ``pose``, where already computed)."""
        mem = self._memory
        self._since_plan = 0
        dist, parent = self._paths_from(pose) if paths is None else paths
        goal = None
        for _ in range(3):  # a mode may hand over to the next one
            if self._mode == EXPLORE:
                goal = self._frontier_goal(pose, dist)
                if goal is None:
                    self._set_mode(REFINE)
                    continue
            else:
                goal = self._landmark_goal(dist)
                if goal is None:
                    if self._mode == LOCALISE:
                        # No landmark left that would help: explore on for a while.
                        self._give_up_localising(self._sigma())
                        continue
                    if self._tried:
                        self._tried.clear()  # every landmark revisited: another round
                        continue
            break
        if goal is None:
            self._follower = None
            return
        if self._follower is not None and mem.grid.cell_of(*self._follower.goal) == goal:
            return  # same goal: keep the path (and its progress)
        cells = path_from_parents(parent, goal, mem.grid.nx)
        points = mem.path_points(cells)
        points[0] = pose[:2]
        self._follower = PathFollower(points, self.params.lookahead, self._control)

    def _frontier_terms(self, pose: np.ndarray, dist: np.ndarray) -> FrontierTerms | None:
        """Per planning cell: its unswept area around it (m²), |bearing| to it (rad),
        and whether it is a reachable frontier; None when no cell is one."""
        mem = self._memory
        grid = mem.grid
        unswept = self._unswept()
        if not unswept.any():
            return None
        res = mem.coverage.grid.resolution
        gain = mem.on_planning_grid(box_sum(unswept, self._gain_cells) * res * res)  # m²
        ok = np.isfinite(dist) & (gain >= self.params.min_gain)
        if not ok.any():
            return None
        dx = grid.xs[None, :] - pose[0]
        dy = grid.ys[:, None] - pose[1]
        bearing = np.abs(np.arctan2(dy, dx) - pose[2])
        bearing = np.minimum(bearing % (2.0 * math.pi), -bearing % (2.0 * math.pi))
        return gain, bearing, ok

    def _frontier_score(
        self, dist: np.ndarray, terms: FrontierTerms, gain_weight: float
    ) -> np.ndarray:
        """Path length − gain_weight·unswept area + turn_weight·|bearing|; inf off the
        frontier."""
        gain, bearing, ok = terms
        return np.where(ok, dist - gain_weight * gain + self.params.turn_weight * bearing, np.inf)

    def _frontier_goal(self, pose: np.ndarray, dist: np.ndarray) -> tuple[int, int] | None:
        """The planning cell of least :meth:`_frontier_score` (at the current gain
        weight), with hysteresis for the current goal."""
        p = self.params
        grid = self._memory.grid
        terms = self._frontier_terms(pose, dist)
        if terms is None:
            self._memory.coverage.abandoned |= self._unswept()  # nothing left to reach
            return None
        _, _, ok = terms
        score = self._frontier_score(dist, terms, self._gain_weight)
        k = int(np.argmin(score))
        best = divmod(k, grid.nx)
        if self._follower is not None:
            cur = grid.cell_of(*self._follower.goal)
            if ok[cur] and score[cur] <= score[best] + p.switch_margin:
                return cur
        return best

    def _landmark_goal(self, dist: np.ndarray) -> tuple[int, int] | None:
        """A viewpoint of the landmark to (re)observe in the current mode (see
        :meth:`_landmark_candidate`); it becomes the target landmark."""
        candidate = self._landmark_candidate(dist, self._mode)
        if candidate is None:
            return None
        self._target_landmark, cell, _, _ = candidate
        return cell

    def _landmark_candidate(
        self, dist: np.ndarray, mode: str
    ) -> tuple[int, tuple[int, int], float, float] | None:
        """(landmark ID, viewpoint cell, path length to it (m), the landmark's σ (m)),
        or None: LOCALISE picks a landmark known much better than the pose, cheap to
        reach; REFINE the least-known one not revisited yet."""
        p = self.params
        mem = self._memory
        f = self._base.filter
        if not f.n_landmarks:
            return None
        means = f.landmark_means()
        sig = np.sqrt(np.maximum(np.trace(f.landmark_covs(), axis1=1, axis2=2), 0.0))
        ids = f.state_to_id
        lo, hi = p.view_distance
        grid = mem.grid
        if mode == LOCALISE:
            cov = f.pose_cov
            limit = p.useful_ratio * math.sqrt(max(cov[0, 0] + cov[1, 1], 0.0))
        else:
            limit = math.inf
        r = math.ceil(hi / grid.resolution)
        best, best_score, best_cell = -1, math.inf, None
        for k in range(len(ids)):
            lid = int(ids[k])
            if lid in self._tried or sig[k] > limit:
                continue
            mx, my = means[k]
            ci, cj = grid.cell_of(mx, my)
            i0, i1 = max(ci - r, 0), min(ci + r + 1, grid.ny)
            j0, j1 = max(cj - r, 0), min(cj + r + 1, grid.nx)
            dx = grid.xs[None, j0:j1] - mx
            dy = grid.ys[i0:i1, None] - my
            d2 = dx * dx + dy * dy
            ring = (d2 >= lo * lo) & (d2 <= hi * hi)
            cand = np.where(ring, dist[i0:i1, j0:j1], np.inf)
            m = int(np.argmin(cand))
            reach = float(cand.flat[m])
            if not math.isfinite(reach) or (mode == LOCALISE and reach > p.max_detour):
                continue
            if mode == LOCALISE:
                score = reach + p.uncertainty_weight * float(sig[k])
            else:
                score = reach - p.uncertainty_weight * float(sig[k])
            if score < best_score:
                a, b = divmod(m, j1 - j0)
                best, best_score, best_cell = lid, score, (a + i0, b + j0)
                best_reach, best_sigma = reach, float(sig[k])
        if best_cell is None:
            return None
        return best, best_cell, best_reach, best_sigma

    # ------------------------------------------------------------------ control
    def _drive(self, pose: np.ndarray) -> np.ndarray:
        p = self.params
        if self._follower is not None:
            _, left = self._follower.progress(pose)
            goal = self._follower.goal
            if left > p.goal_tolerance and math.dist(pose[:2], goal) > p.goal_tolerance:
                return self._follower.action(pose)
            self._follower = None
            self._on_arrival(pose, goal)
        if self._look_at is not None:
            dx, dy = self._look_at - pose[:2]
            err = wrap_angle(math.atan2(dy, dx) - pose[2])
            self._look_steps += 1
            if abs(err) > p.look_tolerance and self._look_steps <= p.look_timeout:
                return unicycle_control(pose, self._look_at, self._control, stop_distance=1e9)
            self._done_looking()
        # Nothing to follow right now: plan again on the next step.
        self._since_plan = p.replan_interval
        return np.zeros(2, dtype=np.float32)

    def _on_arrival(self, pose: np.ndarray, goal: np.ndarray) -> None:
        """At a goal: face what it was for (the unswept cells left around it, or the
        landmark), unless already facing it."""
        if self._mode == EXPLORE:
            self._look_at = self._unswept_centroid(goal)
        elif self._target_landmark >= 0:
            self._look_at = self._base.filter.landmark(self._target_landmark)[0]
        self._look_steps = 0

    def _done_looking(self) -> None:
        """Facing the look-at point: the goal is done."""
        if self._mode == EXPLORE:
            if self._gain_at(self._look_at) >= self.params.min_gain:
                # Seen from its viewpoint and still unswept (occluded): stop chasing it.
                self._memory.coverage.abandoned[self._window(self._look_at)] = True
        elif self._target_landmark >= 0:
            self._tried.add(self._target_landmark)
        self._look_at = None
        self._since_plan = self.params.replan_interval

    def _drop_plan(self) -> None:
        self._follower = None
        self._look_at = None
        self._since_plan = self.params.replan_interval
