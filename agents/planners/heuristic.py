"""What the heuristic exploration agents share: parameters, episode handling, recovery.

:class:`HeuristicAgent` holds the plumbing of :class:`~agents.planners.frontier.FrontierAgent`
and :class:`~agents.planners.infogain.InfoGainAgent`; each of them adds only its decision
(``_act``), its parameters (a subclass of :class:`HeuristicParams`) and its
per-episode state (``_new_episode``).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from agents.common.base import ScriptedAgent
from agents.planners.exploration_memory import EpisodeWatch, ExplorationMemory, StuckDetector
from agents.planners.path_control import ControllerParams


def make_params(cls: type, params: dict[str, Any]) -> Any:
    """``cls(**params)`` for a parameter dataclass, with a ``TypeError`` that lists the
    valid names for an unknown one."""
    valid = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(params) - valid)
    if unknown:
        raise TypeError(f"unknown {cls.__name__} {unknown}; valid: {sorted(valid)}")
    return cls(**params)


def belief_env(env: Any) -> Any:
    """The ``slam_env/ActiveSLAM-v0`` env under ``env``'s wrappers: the object whose
    ``filter`` holds the belief and whose ``layout`` is the known map. Raises
    ``TypeError`` for anything else (the heuristics plan on the EKF belief) and for a
    discrete action space (they output continuous speed and turn commands)."""
    from gymnasium import spaces

    base = getattr(env, "unwrapped", env)
    if not (hasattr(base, "filter") and hasattr(type(base), "layout")):
        raise TypeError(
            "the exploration heuristics act on the EKF-SLAM belief: pass an env made with "
            f"gym.make('slam_env/ActiveSLAM-v0'), got {type(base).__name__}"
        )
    space = getattr(env, "action_space", None)
    if not isinstance(space, spaces.Box) or space.shape != (2,):
        raise TypeError(
            "the exploration heuristics need the continuous Box(-1, 1, (2,)) action space "
            f"(action_type='continuous'), got {space!r}"
        )
    return base


def is_truthy(flag: object) -> bool:
    """``episode_start`` as SB3 passes it: None, a bool, or a (1,)-array."""
    if flag is None:
        return False
    return bool(np.any(np.asarray(flag)))


def _finite(value: object) -> bool:
    return isinstance(value, numbers.Real) and math.isfinite(value)


@dataclass(frozen=True)
class HeuristicParams:
    """Parameters every heuristic agent has (units in the comments). An agent's own
    parameter class adds its fields and may redeclare a field with its own default."""

    planning_resolution: float = 0.25  # m, planning grid cell
    coverage_resolution: float = 0.5  # m, coverage grid cell
    safety_margin: float = 0.07  # m, inflation of the known map beyond the robot radius
    soft_clearance: float = 0.8  # m, paths closer than this to the known map cost more
    proximity_cost: float = 3.0  # extra cost factor at the inflation boundary
    range_margin: float = 0.4  # m, a cell is swept when its centre is this far inside range
    fov_margin: float = math.radians(4.0)  # rad, and this far inside the FOV edges
    gain_radius: float = 1.5  # m, half-side of the window whose unswept area counts
    min_gain: float = 1.0  # m², less unswept area than this around a cell: not a frontier
    lookahead: float = 0.6  # m, pure-pursuit look-ahead along a path
    replan_interval: int = 10  # steps between re-plans
    # Fraction of the max turn rate path following uses: 0.75 maps nearly as fast as
    # the full rate and keeps the filter consistent, which the full rate does not
    # (docs/goal_policy.md, "The planners' turn rate").
    turn_limit: float = 0.75
    stuck_steps: int = 4  # steps of commanded motion without progress before backing off
    recovery_steps: int = 6  # steps of backing off when stuck
    bump_radius: float = 0.5  # m, disc blocked ahead of the robot when it gets stuck

    def __post_init__(self) -> None:
        self._require_counts("replan_interval", "stuck_steps", "recovery_steps")
        self._require_positive(
            "planning_resolution",
            "coverage_resolution",
            "gain_radius",
            "lookahead",
            "turn_limit",
            "bump_radius",
        )
        self._require_non_negative(
            "safety_margin",
            "soft_clearance",
            "proximity_cost",
            "range_margin",
            "fov_margin",
            "min_gain",
        )

    def _require(self, names: tuple[str, ...], ok: Callable[[Any], bool], what: str) -> None:
        for name in names:
            value = getattr(self, name)
            if not ok(value):
                raise ValueError(f"{type(self).__name__}.{name} must be {what}, got {value!r}")

    def _require_counts(self, *names: str) -> None:
        self._require(names, lambda v: isinstance(v, int) and v >= 1, "an int >= 1")

    def _require_positive(self, *names: str) -> None:
        self._require(names, lambda v: _finite(v) and v > 0, "finite and > 0")

    def _require_non_negative(self, *names: str) -> None:
        self._require(names, lambda v: _finite(v) and v >= 0, "finite and >= 0")


class HeuristicAgent(ScriptedAgent):
    """Base of the exploration heuristics that plan on the EKF-SLAM belief.

    It reads only the belief (``env.unwrapped.filter``), the known map
    (``layout`` obstacles and walls) and the env's configuration; never the
    true pose or landmark positions. Each episode it rebuilds the maps
    (:class:`ExplorationMemory`), on ``episode_start`` or when it notices a new episode
    by itself (:class:`EpisodeWatch`). When it runs into something the map does not
    show (it commands motion and the estimate does not move) it remembers an obstacle
    there and backs off, turning to a side drawn from its generator, which ``seed``
    seeds: that is its only randomness.

    Subclasses set ``params_class`` and implement ``_act`` (the raw action),
    ``_new_episode`` (their per-episode state) and ``_drop_plan`` (forget the current
    plan after a bump).

    Args:
        env: a ``slam_env/ActiveSLAM-v0`` env (continuous actions).
        seed: seed of the agent's random generator.
        **params: overrides of the fields of ``params_class``.
    """

    params_class: ClassVar[type[HeuristicParams]] = HeuristicParams

    def __init__(self, env: gym.Env, seed: int | None = None, **params: Any) -> None:
        self._base = belief_env(env)
        self.params = make_params(self.params_class, params)
        self.rng = np.random.default_rng(seed)
        self._control = self._controller()
        self._watch = EpisodeWatch()
        self._memory: ExplorationMemory | None = None

    def _controller(self) -> ControllerParams:
        """The path-following controller: the robot's limits and ``turn_limit``."""
        cfg = self._base.config
        return ControllerParams(
            max_speed=float(cfg.robot.max_speed),
            max_turn_rate=float(cfg.robot.max_turn_rate),
            dt=float(cfg.dt),
            turn_limit=self.params.turn_limit,
        )

    # ------------------------------------------------------------------ interface
    def _action(self, episode_start: Any) -> np.ndarray:
        """The next action, float32 (2,) in [−1, 1]."""
        base = self._base
        if is_truthy(episode_start) or self._memory is None or self._watch.is_new(base):
            self.reset()
        action = self._sent(self._act())
        self._watch.mark(base)
        return action

    def _sent(self, raw: np.ndarray) -> np.ndarray:
        """``raw`` clipped to [−1, 1] as float32: the action sent, remembered so that
        being stuck can be noticed."""
        action = np.clip(raw, -1.0, 1.0).astype(np.float32)
        self._last_command = (float(action[0]), float(action[1]))
        return action

    def reset(self) -> None:
        """Forget the episode: rebuild the maps from the current layout."""
        base = self._base
        p = self.params
        self._memory = ExplorationMemory(
            base.layout,
            base.config,
            planning_resolution=p.planning_resolution,
            coverage_resolution=p.coverage_resolution,
            safety_margin=p.safety_margin,
            soft_clearance=p.soft_clearance,
            proximity_cost=p.proximity_cost,
            range_margin=p.range_margin,
            fov_margin=p.fov_margin,
        )
        cg = self._memory.coverage.grid
        self._gain_cells = max(1, round(p.gain_radius / cg.resolution))  # window half-side
        self._n_posts = -1  # landmarks whose posts block the planning grid
        self._recovery = 0  # backing-off steps left
        self._recovery_action = np.zeros(2, dtype=np.float32)
        self._last_command = (0.0, 0.0)  # (speed, turn) of the last action
        step = self._control.max_speed * self._control.dt
        self._stuck = StuckDetector(p.stuck_steps, step_length=step)
        self._new_episode()
        self._watch.forget()

    @property
    def memory(self) -> ExplorationMemory | None:
        """The episode's maps (planning grid, coverage)."""
        return self._memory

    # ------------------------------------------------------------------ for subclasses
    def _act(self) -> np.ndarray:
        """The raw action of this step (clipped to [−1, 1] by the caller)."""
        raise NotImplementedError

    def _new_episode(self) -> None:
        """Set up the subclass's per-episode state (the maps are already built)."""

    def _drop_plan(self) -> None:
        """Forget the current plan: the robot ran into something and backs off."""

    def _update_maps(self, pose: np.ndarray) -> bool:
        """Sweep the coverage from ``pose`` and block the posts of the landmarks the
        filter knows; True when new posts were blocked."""
        mem = self._memory
        f = self._base.filter
        mem.coverage.sweep(pose)
        if f.n_landmarks == self._n_posts:
            return False
        mem.set_posts(f.landmark_means())
        self._n_posts = f.n_landmarks
        return True

    def _backing_off(self, pose: np.ndarray) -> np.ndarray | None:
        """The recovery action while backing off or once stuck at ``pose``, else None."""
        if self._recovery > 0:
            self._recovery -= 1
            return self._recovery_action
        if not self._stuck.update(pose, self._last_command[0]):
            return None
        # Something unmapped (where the robot thinks it is) blocks the way: remember it.
        p = self.params
        mem = self._memory
        reach = self._base.config.robot.radius + 0.5 * p.bump_radius
        ahead = pose[:2] + reach * np.array([math.cos(pose[2]), math.sin(pose[2])])
        mem.add_bump(ahead, p.bump_radius + mem.inflation)
        self._drop_plan()
        self._recovery = p.recovery_steps - 1
        turn = 0.6 if self.rng.random() < 0.5 else -0.6
        self._recovery_action = np.array([-0.5, turn], dtype=np.float32)
        return self._recovery_action
