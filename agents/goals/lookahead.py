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
import dataclasses
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


class NoBeliefWorld(RuntimeError):
    """Not even the belief's mean could be laid out as a world (nothing was moved)."""


def draw_belief_world(env: gym.Env, agent: GoalChoiceAgent, rng: np.random.Generator) -> bool:
    """Make ``env`` (a copy the agent may look ahead in) a world drawn from the belief:
    the robot and the mapped landmarks jointly from the filter's Gaussian, the
    landmarks not mapped at points drawn uniformly over the agent's unswept free cells
    (over all its free cells when none is unswept, or no point there will do; the
    world's clearance from walls and obstacles, its spacing between landmarks, clear
    of the robot), and the env's noise from a new generator. A draw that does not make
    a valid world (a post in an obstacle, the robot on a post) is drawn again, up to
    :data:`DRAWS` times; then the world is the belief's mean, each landmark whose mean
    will not do drawn as an unmapped one (False). Every landmark and the robot are
    moved: nothing of the true world is left. ``NoBeliefWorld`` when not even that
    can be laid out (then nothing is moved).

    With known IDs, slot k of the filter is the landmark of ID ``state_to_id[k]``; a
    filter that associates by itself owns its IDs (its slots are the tracks it
    keeps), so slot k stands for the world's k-th landmark in the layout's order
    (which one does not matter: the copy's sensor reports no IDs either), and tracks
    beyond the world's landmark count are left out of the world."""
    base = env.unwrapped
    mean, cov, slot_ids = base.filter.belief_views()
    world_ids = list(base.layout.landmark_ids)
    if base.filter.associates:
        slots = dict(zip(world_ids, range(len(slot_ids)), strict=False))
    else:
        known = set(world_ids)
        slots = {int(lid): k for k, lid in enumerate(slot_ids) if int(lid) in known}
    mapped = {lid: 3 + 2 * k for lid, k in slots.items()}
    unmapped = [lid for lid in world_ids if lid not in mapped]
    places = _Places(base, agent)
    drawn = False
    for _ in range(DRAWS):
        state = rng.multivariate_normal(mean, cov, method="eigh")
        placed = {lid: tuple(state[i : i + 2].tolist()) for lid, i in mapped.items()}
        for lid in unmapped:
            point = places.free_point(rng, state[:2], placed.values())
            if point is None:
                break
            placed[lid] = point
        else:
            try:
                base.move_landmarks(placed, robot_pose=tuple(state[:3].tolist()))
                drawn = True
                break
            except ValueError:
                continue
    if not drawn:
        robot, placed = places.mean_world(mean, mapped, unmapped, rng)
        base.move_landmarks(placed, robot_pose=robot)
    base.np_random = np.random.default_rng(rng.integers(2**63))
    return drawn


class _Places:
    """Where the landmarks and the robot of a drawn world may go: the agent's free
    (and unswept) planning cells, and the env's own check of a world."""

    def __init__(self, base: Any, agent: GoalChoiceAgent) -> None:
        cfg = base.config
        self.layout = base.layout
        self.grid = grid = agent._memory.grid
        free = grid.clearance >= cfg.world.clearance + grid.resolution
        unswept = agent._memory.on_planning_grid(agent._unswept())
        self.areas = [np.argwhere(unswept & free), np.argwhere(free)]
        self.robot_cells = np.argwhere(grid.clearance >= cfg.robot.radius + grid.resolution)
        self.keep_off = cfg.robot.radius + LANDMARK_POST_RADIUS
        self.spacing = cfg.world.landmark_spacing
        self.robot_radius = cfg.robot.radius
        self.wall_thickness = cfg.world.wall_thickness

    def free_point(
        self, rng: np.random.Generator, robot: Any, placed: Any
    ) -> tuple[float, float] | None:
        clear_of = [(robot, self.keep_off)] + [(q, self.spacing) for q in placed]
        return _free_point(self.areas, self.grid, rng, clear_of)

    def valid(self, robot: tuple, placed: dict[int, tuple[float, float]]) -> bool:
        """Whether the robot at ``robot`` among the landmarks ``placed`` (ID → (x, y))
        is a world the env takes (the check of its ``move_landmarks``)."""
        world = dataclasses.replace(
            self.layout,
            landmark_ids=tuple(placed),
            landmark_positions=tuple(placed.values()),
            start_pose=robot,
        )
        try:
            world.validate(self.robot_radius, wall_thickness=self.wall_thickness)
        except ValueError:
            return False
        return True

    def mean_world(
        self, mean: np.ndarray, mapped: dict[int, int], unmapped: list[int], rng: Any
    ) -> tuple[tuple, dict[int, tuple[float, float]]]:
        """The robot and the landmarks at the belief's mean, laid out one by one: the
        robot, where its mean will not do, at the nearest cell it fits in; a landmark
        whose mean will not do, and each unmapped one, drawn as :meth:`free_point`
        draws."""
        robot = tuple(mean[:3].tolist())
        if not self.valid(robot, {}) and len(self.robot_cells):
            centres = np.array([self.grid.center(i, j) for i, j in self.robot_cells])
            x, y = centres[int(np.argmin(np.hypot(*(centres - mean[:2]).T)))]
            robot = (float(x), float(y), robot[2])
        if not self.valid(robot, {}):
            raise NoBeliefWorld("the robot fits nowhere near the belief's mean")
        placed: dict[int, tuple[float, float]] = {}
        wanted = [(lid, tuple(mean[i : i + 2].tolist())) for lid, i in mapped.items()]
        for lid, point in wanted + [(lid, None) for lid in unmapped]:
            for _ in range(DRAWS + 1):
                if point is not None and self.valid(robot, {**placed, lid: point}):
                    placed[lid] = point
                    break
                point = self.free_point(rng, robot[:2], placed.values())
            else:
                raise NoBeliefWorld(f"no place for landmark {lid} in the belief's mean world")
        return robot, placed


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
        self.worlds = 0  # worlds drawn from the belief for a try
        self.fallbacks = 0  # of them, the belief's mean (no draw made a valid world)
        self.skipped = 0  # choices left to the base: not even the mean made a world

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
            return own if values is None else self._least(values.mean(axis=0), ENDGAME, own)
        if own not in EXPLORING or mapped:
            return own
        costs = self._tried(
            EXPLORING, self.samples, lambda *game: steps_to_mapped(*game, need, self.horizon)
        )
        if costs is None:
            return own
        costs -= self.agent._steps
        if self.labels is not None:
            self.labels.append(Label(features.copy(), costs, own))
        return self._least(costs.mean(axis=0), EXPLORING, own)

    def report(self) -> dict[str, int]:
        """What the lookahead has drawn so far: ``worlds`` drawn from the belief for a
        try, ``fallbacks`` of them laid out at the belief's mean, and the choices
        ``skipped`` (left to the base) where not even that made a world."""
        return {"worlds": self.worlds, "fallbacks": self.fallbacks, "skipped": self.skipped}

    def _final_entropy(self, *game: Any) -> float:
        return final_entropy(*game, self.horizon)

    def _tried(self, choices: tuple[int, ...], worlds: int, value: Callable) -> np.ndarray | None:
        """(tries, len(choices)): ``value(env, agent, choice, base)`` of each choice on
        copies of the env, the agent and the base (its memory as of this choice), in
        ``worlds`` drawn worlds (the same ones for each choice), or the true one; None
        when a world could not be drawn (the base chooses: never the true world)."""
        tries = worlds if self.world == "belief" else 1
        out = np.zeros((tries, len(choices)))
        for i in range(tries):
            seed = self.rng.integers(2**63)
            for k, choice in enumerate(choices):
                env, agent, base = copy.deepcopy((self.env, self.agent, self.base))
                if self.world == "belief":
                    try:
                        drawn = draw_belief_world(env, agent, np.random.default_rng(seed))
                    except NoBeliefWorld:
                        self.skipped += 1
                        return None
                    self.worlds += 1
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
