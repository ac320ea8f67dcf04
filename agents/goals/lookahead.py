"""A lookahead from the belief around a goal-choosing policy: before each of its
choices the agent tries the candidates on copies of the env in worlds drawn from
what it believes, and takes the one that does best there.

Before 90% of the landmarks are mapped, when the base policy would explore, each
exploring choice (the three frontier weightings, :data:`EXPLORING`) is tried in
``samples`` drawn worlds (the same ones for every choice), the base policy choosing
after it, up to the step at which 90% are mapped; the choice that gets there soonest
on average is taken (the base's own on a tie). The base's loop closures and revisits
are left alone. Once 90% are mapped (with ``endgame`` > 0) it tries going on with the
revisits, a loop closure and the least-known landmark (:data:`ENDGAME`), each in
``endgame`` drawn worlds, to the episode's end, and takes the one that ends with the
least belief entropy; from then on its choices hold while their goals stand. Every
try stops after ``horizon`` steps: one that has not mapped 90% by then counts the
steps it would take at the rate it mapped landmarks, an endgame try its entropy then.

A drawn world (:func:`draw_belief_world`) is a copy of the env in which the robot and
the mapped landmarks are a draw from the belief (the filter's Gaussian), the landmarks
not mapped yet are drawn uniformly over the area the sensor has not swept, and the
noise is fresh: the copy knows nothing the agent does not (the map of walls and
obstacles is given to every agent; see :mod:`agents.planners.grid_map`).

``--agents lookahead`` runs it over the shipped goal policy (``lookahead:PATH`` over
another); ``experiments/choice_oracle.py`` measures it against ``frontier``.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

from agents.common.arguments import check_count
from agents.common.episode_length import REFERENCE_ARENA, episode_length
from agents.goals.choice import CHOICES, EXPLORE, GoalChoiceAgent, Policy
from agents.rollouts.suite_metrics import landmarks_needed
from slam_env.world.layouts import LANDMARK_POST_RADIUS

MAPPED_SHARE = 0.9
EXPLORING = tuple(i for i, choice in enumerate(CHOICES) if choice.mode == EXPLORE)
#: The choices tried once 90% are mapped: going on with the revisits under way, a loop
#: closure, the least-known landmark.
ENDGAME = tuple(
    i for i, choice in enumerate(CHOICES) if choice.name in ("explore", "localise", "refine")
)
#: The default bound on a try's steps: the reference arena's episode (so that on worlds
#: of that size or smaller every try runs to its end).
HORIZON = episode_length(REFERENCE_ARENA, REFERENCE_ARENA)
WORLDS = ("belief", "hindsight")
#: Joint draws of the robot and the mapped landmarks tried before the belief's mean.
DRAWS = 20


def draw_belief_world(env: gym.Env, agent: GoalChoiceAgent, rng: np.random.Generator) -> bool:
    """Make ``env`` (a copy the agent may look ahead in) a world drawn from the belief:
    the robot and the mapped landmarks jointly from the filter's Gaussian, the
    landmarks not mapped at points drawn uniformly over the agent's unswept free cells
    (over all its free cells when none is unswept, or no point there will do; the
    world's clearance from walls and obstacles, its spacing between landmarks, clear
    of the robot), and the env's noise from a new generator. A draw that does not make
    a valid world (a post in an obstacle, the robot on a post) is drawn again, up to
    :data:`DRAWS` times, then the belief's mean is used. False when no valid world was
    found (then the true robot and landmarks stay, and only the noise is new)."""
    base = env.unwrapped
    cfg = base.config.world
    mean, cov, slot_ids = base.filter.belief_views()
    mapped = {int(lid): 3 + 2 * k for k, lid in enumerate(slot_ids)}
    unmapped = [lid for lid in base.layout.landmark_ids if lid not in mapped]
    grid = agent._memory.grid
    free = grid.clearance >= cfg.clearance + grid.resolution
    unswept = agent._memory.on_planning_grid(agent._unswept())
    areas = [np.argwhere(unswept & free), np.argwhere(free)]
    keep_off = base.config.robot.radius + LANDMARK_POST_RADIUS
    drawn = False
    for draw in range(DRAWS + 1):
        state = mean if draw == DRAWS else rng.multivariate_normal(mean, cov, method="eigh")
        robot = state[:2]
        placed = {lid: tuple(state[i : i + 2].tolist()) for lid, i in mapped.items()}
        for lid in unmapped:
            point = _free_point(
                areas,
                grid,
                rng,
                [(robot, keep_off)] + [(q, cfg.landmark_spacing) for q in placed.values()],
            )
            if point is not None:
                placed[lid] = point
        try:
            base.move_landmarks(placed, robot_pose=tuple(state[:3].tolist()))
            drawn = True
            break
        except ValueError:  # unplaced landmarks stay, and may be in the way
            continue
    base.np_random = np.random.default_rng(rng.integers(2**63))
    return drawn


def _free_point(
    areas: list[np.ndarray], grid: Any, rng: np.random.Generator, clear_of: list[tuple]
) -> tuple[float, float] | None:
    """A point drawn uniformly over the first of ``areas`` ((k, 2) rows and columns of
    ``grid``) that has one farther than d from each (point, d) of ``clear_of`` in 50
    tries; None when none has."""
    for cells in areas:
        for _ in range(50 if len(cells) else 0):
            row, col = cells[rng.integers(len(cells))]
            point = np.array(grid.center(row, col))
            point += rng.uniform(-0.5, 0.5, 2) * grid.resolution
            if all(math.dist(point, q) >= d for q, d in clear_of):
                return (float(point[0]), float(point[1]))
    return None


def play_on(
    env: gym.Env, agent: GoalChoiceAgent, choice: int, base: Policy
) -> Iterator[tuple[bool, dict]]:
    """Step ``env`` and ``agent`` themselves, taking ``choice`` now and ``base``'s
    choices after it, to the episode's end: each step's (episode over, info)."""
    agent._policy = base
    action = agent.finish_step(choice)
    while True:
        _, _, terminated, truncated, info = env.step(action)
        done = bool(terminated or truncated)
        yield done, info
        if done:
            return
        action = agent.begin_step()
        if action is None:
            action = agent.finish_step(base(agent.features()))


def steps_to_mapped(
    env: gym.Env,
    agent: GoalChoiceAgent,
    choice: int,
    base: Policy,
    need: int,
    horizon: int = HORIZON,
) -> float:
    """The agent's step count at which ``need`` landmarks are mapped (:func:`play_on`).
    An episode that ends first counts its length plus the env's limit; a try still
    short after ``horizon`` steps counts the steps the rest would take at the rate it
    mapped landmarks (at least one per ``horizon`` steps)."""
    had = env.unwrapped.filter.n_landmarks
    for steps, (done, _) in enumerate(play_on(env, agent, choice, base), 1):
        mapped = env.unwrapped.filter.n_landmarks
        if mapped >= need:
            return float(agent._steps)
        if done:
            return float(agent._steps + env.spec.max_episode_steps)
        if steps >= horizon:
            return agent._steps + (need - mapped) * horizon / max(mapped - had, 1)
    raise AssertionError("play_on ends with the episode")


def final_entropy(
    env: gym.Env, agent: GoalChoiceAgent, choice: int, base: Policy, horizon: int = HORIZON
) -> float:
    """The belief entropy (nats) at the episode's end (:func:`play_on`), or after
    ``horizon`` steps."""
    for steps, (done, info) in enumerate(play_on(env, agent, choice, base), 1):
        if done or steps >= horizon:
            return float(info["entropy"])
    raise AssertionError("play_on ends with the episode")


class Label(NamedTuple):
    """One choice the lookahead weighed: its features, the steps from it to 90% mapped
    of each exploring choice in each world tried ((worlds, len(EXPLORING))), and the
    base's own choice."""

    features: np.ndarray
    costs: np.ndarray
    own: int


class Lookahead:
    """The policy of a :class:`GoalChoiceAgent` that looks ahead over ``base``'s
    choices (see the module); :meth:`attach` it to the agent it drives.

    Args:
        env: the env the agent acts on.
        base: the policy that chooses after each try, and whose choice is kept on a tie.
        samples: worlds each exploring choice is tried in.
        endgame: worlds each :data:`ENDGAME` choice is tried in once 90% are mapped
            (0: the base chooses then).
        horizon: steps a try runs at most.
        seed: seed of the drawn worlds.
        world: ``belief`` (drawn worlds) or ``hindsight`` (the true world with the
            noise to come, one try per choice: what no agent can know, for benchmarks).
        record: keep every exploring choice weighed in :attr:`labels`.
    """

    def __init__(
        self,
        env: gym.Env,
        base: Policy,
        samples: int = 4,
        endgame: int = 2,
        horizon: int = HORIZON,
        seed: int | None = None,
        world: str = "belief",
        record: bool = False,
    ) -> None:
        check_count("samples", samples, 1)
        check_count("endgame", endgame, 0)
        check_count("horizon", horizon, 1)
        if world not in WORLDS:
            raise ValueError(f"world must be one of {WORLDS}, got {world!r}")
        self.env, self.base, self.world = env, base, world
        self.samples, self.endgame, self.horizon = samples, endgame, horizon
        self.rng = np.random.default_rng(seed)  # the drawn worlds
        self.agent: GoalChoiceAgent | None = None
        self._holds = False  # the agent's own hold_goals, restored at each episode
        self.labels: list[Label] | None = [] if record else None
        self.fallbacks = 0  # drawn worlds that kept the true robot and landmarks

    def attach(self, agent: GoalChoiceAgent) -> None:
        """Drive ``agent`` (whose policy this becomes)."""
        agent._policy = self
        self.agent, self._holds = agent, agent.hold_goals

    def reset(self) -> None:
        reset = getattr(self.base, "reset", None)
        if callable(reset):
            reset()
        if self.agent is not None:
            self.agent.hold_goals = self._holds  # as the agent was made

    def __call__(self, features: np.ndarray) -> int:
        own = self.base(features)
        need = landmarks_needed(self.env.unwrapped.n_landmarks, MAPPED_SHARE)
        mapped = self.env.unwrapped.filter.n_landmarks >= need
        if mapped and self.endgame:
            # Each try assumes its choice is followed: without holding, the next
            # decision switched it, and the robot stood among its goals.
            self.agent.hold_goals = True
            values = self._tried(ENDGAME, self.endgame, self._final_entropy)
            return self._least(values.mean(axis=0), ENDGAME, own)
        if own not in EXPLORING or mapped:
            return own
        costs = self._tried(
            EXPLORING, self.samples, lambda *game: steps_to_mapped(*game, need, self.horizon)
        )
        costs -= self.agent._steps
        if self.labels is not None:
            self.labels.append(Label(features.copy(), costs, own))
        return self._least(costs.mean(axis=0), EXPLORING, own)

    def _final_entropy(self, *game: Any) -> float:
        return final_entropy(*game, self.horizon)

    def _tried(self, choices: tuple[int, ...], worlds: int, value: Callable) -> np.ndarray:
        """(tries, len(choices)): ``value(env, agent, choice, base)`` of each choice on
        copies of the env, the agent and the base (its memory as of this choice), in
        ``worlds`` drawn worlds (the same ones for each choice), or the true one."""
        tries = worlds if self.world == "belief" else 1
        out = np.zeros((tries, len(choices)))
        for i in range(tries):
            seed = self.rng.integers(2**63)
            for k, choice in enumerate(choices):
                env, agent, base = copy.deepcopy((self.env, self.agent, self.base))
                if self.world == "belief":
                    drawn = draw_belief_world(env, agent, np.random.default_rng(seed))
                    self.fallbacks += not drawn
                out[i, k] = value(env, agent, choice, base)
        return out

    @staticmethod
    def _least(means: np.ndarray, choices: tuple[int, ...], own: int) -> int:
        """The choice of least mean, ``own`` on a tie."""
        if own in choices and means[choices.index(own)] == means.min():
            return own
        return choices[int(np.argmin(means))]


def with_lookahead(
    agent: GoalChoiceAgent, env: gym.Env, seed: int | None = None, **options: Any
) -> GoalChoiceAgent:
    """``agent`` (a goal-choosing agent acting on ``env``) driven by a
    :class:`Lookahead` over its own policy; ``options`` are the lookahead's
    (``samples``, ``endgame``, ``horizon``, ``world``, ``record``)."""
    if not isinstance(agent, GoalChoiceAgent):
        raise TypeError(f"a lookahead needs a goal-choosing agent, got {type(agent).__name__}")
    Lookahead(env, agent._policy, seed=seed, **options).attach(agent)
    return agent
