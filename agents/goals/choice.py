"""A learned choice of the planner's next goal: where to go next, and what for.

The split of Active Neural SLAM (Chaplot et al., 2020): a learned policy picks the
goal, a classical planner drives there. Here the planner is the frontier agent's
(:class:`~agents.planners.frontier.FrontierAgent`: Dijkstra on the known map, pure pursuit,
backing off what it runs into), and at each of its decisions (no path to follow, a
goal reached, or ``replan_interval`` steps gone; with ``hold_goals``, only those where
the goal is reached or replanning moves it) the policy picks one of
:data:`CHOICES`: a frontier target under one of three weightings of unswept area
against path length, a loop closure on a well-known landmark, or a revisit of the
least-known one. The frontier agent itself makes those choices by fixed rules (the
1.5 weighting; a loop closure when the pose σ passes 0.4 m; revisits once nothing is
left to sweep); the policy makes them from :func:`choice_features`, which describe
the belief, the sweep and each choice's target, and never depend on the landmark
count, their IDs or the arena (so one policy runs on every world).

:class:`GoalChoiceAgent` runs such a policy; :mod:`agents.learning.sb3.goal_training` trains one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

from agents.common.episode_length import episode_length
from agents.planners.frontier import EXPLORE, LOCALISE, REFINE, FrontierAgent, FrontierTerms


class Choice(NamedTuple):
    """One decision the policy can take: the planner's mode, and for EXPLORE the
    weight of unswept area against path length (m of path per m²)."""

    name: str
    mode: str
    gain_weight: float


CHOICES: tuple[Choice, ...] = (
    Choice("explore", EXPLORE, 1.5),  # the frontier agent's own weighting
    Choice("explore_near", EXPLORE, 0.5),  # the nearest frontier, nearly whatever its size
    Choice("explore_wide", EXPLORE, 4.0),  # large unswept areas, even far away
    Choice("localise", LOCALISE, 1.5),  # re-observe a landmark known much better than the pose
    Choice("refine", REFINE, 1.5),  # revisit the least-known landmark
)
_MODES = (EXPLORE, LOCALISE, REFINE)
_EXPLORE_CHOICES = tuple(c for c in CHOICES if c.mode == EXPLORE)
#: :func:`choice_features` starts with 11 features of the belief, the sweep and the
#: world (the pose σ first), then the planner's mode one-hot (mode -> index).
POSE_SIGMA_FEATURE = 0
MODE_FEATURES = {mode: 11 + i for i, mode in enumerate(_MODES)}
#: Length of :func:`choice_features`' vector.
N_FEATURES = 11 + len(_MODES) + 4 * len(_EXPLORE_CHOICES) + 3 + 3
#: Every feature is clipped to ±this (they are scaled to be of order one).
FEATURE_BOUND = 10.0

Policy = Callable[[np.ndarray], int]


def check_hold_goals(hold_goals: Any) -> None:
    """``TypeError`` unless ``hold_goals`` is a bool (:class:`GoalChoiceAgent`'s and
    :class:`~agents.learning.goal_env.GoalChoiceEnv`'s argument)."""
    if not isinstance(hold_goals, bool):
        raise TypeError(f"hold_goals must be a bool, got {hold_goals!r}")


def choice_space() -> gym.spaces.Discrete:
    """The policy's action: an index into :data:`CHOICES`."""
    return gym.spaces.Discrete(len(CHOICES))


def feature_space() -> gym.spaces.Box:
    """The policy's observation: :func:`choice_features`' vector."""
    return gym.spaces.Box(-FEATURE_BOUND, FEATURE_BOUND, (N_FEATURES,), np.float32)


class GoalChoiceAgent(FrontierAgent):
    """The frontier agent's planner, driven by a policy that picks its goals.

    Args:
        env: a ``slam_env/ActiveSLAM-v0`` env (continuous actions).
        policy: maps :func:`choice_features` ((N_FEATURES,) float32) to an index into
            :data:`CHOICES`; one with a ``reset()`` method (a policy with memory) has it
            called at the start of each episode.
        seed: seed of the agent's random generator (backing off only).
        hold_goals: a choice holds while its goal stands: at a replan with the goal
            not yet reached, the planner replans in the chosen mode and asks the policy
            only if that moves the goal (an option that ends with its goal), instead
            of asking at every replan.
        **params: overrides of :class:`~agents.planners.frontier.FrontierParams`.
    """

    def __init__(
        self,
        env: gym.Env,
        policy: Policy,
        seed: int | None = None,
        hold_goals: bool = False,
        **params: Any,
    ) -> None:
        check_hold_goals(hold_goals)
        self._policy = policy  # (before the base class starts the first episode)
        self._hold_goals = hold_goals
        super().__init__(env, seed=seed, **params)

    @property
    def hold_goals(self) -> bool:
        """Whether a choice holds while its goal stands (see the class); it may be set
        mid-episode, and holds from the next decision."""
        return self._hold_goals

    @hold_goals.setter
    def hold_goals(self, value: bool) -> None:
        check_hold_goals(value)
        self._hold_goals = value

    def _new_episode(self) -> None:
        super()._new_episode()
        reset = getattr(self._policy, "reset", None)
        if callable(reset):
            reset()
        self._steps = 0  # steps of this episode so far
        self._paths: tuple[np.ndarray, np.ndarray] | None = None  # of a pending choice
        self._terms: tuple[np.ndarray, FrontierTerms | None] | None = None  # (dist, terms)

    # ------------------------------------------------------------------ decision
    def _act(self) -> np.ndarray:
        action = self.begin_step()
        if action is None:
            action = self.finish_step(self._policy(self.features()))
        return action

    def begin_step(self) -> np.ndarray | None:
        """Sweep the maps and the action of this step; None when a choice is due
        (then :meth:`features` describe it and :meth:`finish_step` takes it)."""
        pose = self._base.filter.pose
        self._steps += 1
        recovery = self._observe(pose)
        if recovery is not None:
            return self._sent(recovery)
        if self._look_at is None and self._needs_plan(pose):
            paths = self._paths_from(pose)
            if not (self._hold_goals and self._goal_stands(pose, paths[0])):
                self._paths = paths
                return None
            self._since_plan = 0  # replanned in the chosen mode: the same goal
        return self._sent(self._drive(pose))

    def _goal_stands(self, pose: np.ndarray, dist: np.ndarray) -> bool:
        """Whether replanning in the current mode keeps the goal being driven to."""
        if self._follower is None:
            return False
        goal = self._memory.grid.cell_of(*self._follower.goal)
        if self._mode == EXPLORE:
            return self._frontier_goal(pose, dist) == goal
        candidate = self._landmark_candidate(dist, self._mode)
        return candidate is not None and candidate[:2] == (self._target_landmark, goal)

    def _frontier_terms(self, pose: np.ndarray, dist: np.ndarray) -> FrontierTerms | None:
        # The terms of a step's paths (``dist``, from the step's pose) serve whether a
        # held goal stands, the features and the plan: computed once. Nothing between
        # these uses changes the sweep (but for giving up what is out of reach when the
        # terms are None, which leaves them None).
        if self._terms is None or self._terms[0] is not dist:
            self._terms = (dist, super()._frontier_terms(pose, dist))
        return self._terms[1]

    def finish_step(self, choice: int) -> np.ndarray:
        """Plan toward ``choice`` (an index into :data:`CHOICES`) and this step's action."""
        if self._paths is None:
            raise RuntimeError("finish_step without a pending choice (call begin_step first)")
        if not 0 <= int(choice) < len(CHOICES):
            raise ValueError(f"choice must be in [0, {len(CHOICES)}), got {choice!r}")
        chosen = CHOICES[int(choice)]
        pose = self._base.filter.pose
        paths, self._paths = self._paths, None
        mode = chosen.mode
        revisiting = self._mode == REFINE
        if mode == EXPLORE and revisiting and self._frontier_terms(pose, paths[0]) is None:
            # Exploring hands over to the revisits under way, as the frontier agent's
            # does, keeping their round (a new one would send the robot back to the
            # landmark it has just revisited) and their path.
            mode = REFINE
        if mode != self._mode:
            self._set_mode(mode)
        self._gain_weight = chosen.gain_weight
        self._plan(pose, paths)
        if self._follower is None and self._mode != EXPLORE:
            # A revisit with nothing to revisit (no landmark known yet) would leave the
            # robot standing until the next choice, and a policy can keep choosing it:
            # hand it on to exploring, as the frontier agent's own modes hand over.
            self._set_mode(EXPLORE)
            self._gain_weight = CHOICES[0].gain_weight
            self._plan(pose, paths)
        return self._sent(self._drive(pose))

    def features(self) -> np.ndarray:
        """:func:`choice_features` of the pending choice (or, with none pending, of a
        choice made now: at the end of an episode)."""
        paths = self._paths_from(self._base.filter.pose) if self._paths is None else self._paths
        return choice_features(self, paths[0])


def choice_features(agent: GoalChoiceAgent, dist: np.ndarray) -> np.ndarray:
    """What the policy sees at a choice, (N_FEATURES,) float32, each of order one:

    * the belief: pose σ (position, in units of the frontier agent's loop-closing
      threshold; heading, in units of 0.1 rad), landmarks known (log), their σ (mean
      and largest, m);
    * the sweep: share of the arena swept, unswept area left (log m²), share of the
      episode gone;
    * the world as the agent is told it: sensor range (in 5 m), FOV (in 2π), arena
      side (in 32 m);
    * the planner's mode now (one-hot);
    * per frontier weighting: whether it has a target, the path to it (in arena sides),
      the unswept area there (in 10 m²), the turn toward it (in π);
    * the loop closure and the revisit: whether there is one, the path to the viewpoint
      (in arena sides), the landmark's σ (relative to the pose's for the loop
      closure, in m for the revisit).
    """
    base = agent._base
    p = agent.params
    cfg = base.config
    f = base.filter
    cov = agent._memory.coverage
    pose = f.pose
    side = max(float(cfg.world.width), float(cfg.world.height))
    pc = f.pose_cov
    sigma = agent._sigma()
    n = f.n_landmarks
    if n:
        sig = np.sqrt(np.maximum(np.trace(f.landmark_covs(), axis1=1, axis2=2), 0.0))
        mean_sig, max_sig = float(sig.mean()), float(sig.max())
    else:
        mean_sig = max_sig = 0.0
    res = cov.grid.resolution
    out = [
        sigma / p.loop_close_std,
        math.sqrt(max(pc[2, 2], 0.0)) / 0.1,
        math.log1p(n) / 4.0,
        mean_sig,
        max_sig,
        cov.fraction_swept(),
        math.log1p(float(np.count_nonzero(cov.unswept)) * res * res) / 5.0,
        agent._steps / episode_length(side, side),
        float(cfg.sensor.max_range) / 5.0,
        float(cfg.sensor.fov) / (2.0 * math.pi),
        side / 32.0,
    ]
    out += [float(agent._mode == m) for m in _MODES]
    terms = agent._frontier_terms(pose, dist)
    for choice in _EXPLORE_CHOICES:
        if terms is None:
            out += [0.0, 0.0, 0.0, 0.0]
            continue
        score = agent._frontier_score(dist, terms, choice.gain_weight)
        k = int(np.argmin(score))
        gain, bearing, _ = terms
        out += [1.0, dist.flat[k] / side, gain.flat[k] / 10.0, bearing.flat[k] / math.pi]
    for mode in (LOCALISE, REFINE):
        candidate = agent._landmark_candidate(dist, mode)
        if candidate is None:
            out += [0.0, 0.0, 0.0]
            continue
        _, _, reach, landmark_sigma = candidate
        scale = max(sigma, 1e-3) if mode == LOCALISE else 1.0
        out += [1.0, reach / side, landmark_sigma / scale]
    x = np.asarray(out, dtype=np.float64)
    return np.clip(x, -FEATURE_BOUND, FEATURE_BOUND).astype(np.float32)
