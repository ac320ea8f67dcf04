"""What the goal choices could give: a lookahead over the exploring choices, in
hindsight or from the belief, beside ``frontier``, on one setting of the suite.

    .venv/bin/python benchmarks/bench_choice_oracle.py [--setting default] [--episodes 30]
        [--world hindsight|belief] [--samples 4] [--seed 10000] [--base rule|goals|goals:PATH]
        [--labels PATH.npz] [--endgame 0]

At every choice of a :class:`~agents.goal_choice.GoalChoiceAgent` made before 90% of
the landmarks are mapped, each exploring choice (the three frontier weightings) is
tried on a copy of the env and the agent, the base policy choosing after it, up to
the step at which 90% are mapped. The choice that gets there soonest is taken (the
base's own on a tie); the base's other choices (loop closures, revisits) are left
alone. The base is ``rule`` (:class:`~agents.goal_imitation.LoopClosingRule` with loop
closures from a pose σ of 0.4 m until below 0.2 m, the frontier agent's own rule) or a
goal-choosing policy (``goals``: the shipped one).

* ``hindsight``: each try runs in the copy's own world with the noise to come, so its
  count is exact: what the best choice at every choice would give, which no policy can
  make (it knows where the unmapped landmarks are).
* ``belief``: ``--samples`` copies per choice (the same ones for every choice), their
  landmarks not yet mapped redrawn uniformly over the unswept free area and their noise
  drawn afresh: what looking ahead from the belief finds.

With ``--endgame N`` the lookahead also makes the choices after 90% is mapped: it
tries going on with the revisits, a loop closure and the least-known landmark, each in
N worlds (drawn as above, or the true one), the base choosing after it, to the
episode's end, and takes the one that ends with the least belief entropy; from then
on the choices hold while their goals stand (``hold_goals``).

Prints, per agent, the means of steps to 90% mapped, final entropy, collisions per
100 steps and the share of the landmarks mapped at the end, and the lookahead's paired
difference from ``frontier`` (mean ± standard error, and the seeds it is lower on).
The episodes are the suite's: ``reset(seed=seed + i)``, the setting's length.
``--labels`` also saves every choice the lookahead weighed, for
``bench_choice_distillation.py``: its features, the steps from it to 90% mapped of each
exploring choice in each world tried, the base's own choice and the episode's seed.
"""

from __future__ import annotations

import argparse
import copy
import math
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

import gymnasium as gym
import numpy as np

from agents.arguments import non_negative_int, positive_int
from agents.evaluation import run_episode
from agents.goal_choice import CHOICES, EXPLORE, N_FEATURES, GoalChoiceAgent, Policy
from agents.goal_imitation import LoopClosingRule
from agents.registry import make_agent, make_env
from agents.suite import SUITE_SEED, SuiteSetting, suite_settings
from agents.suite_metrics import landmarks_needed, suite_metrics
from slam_env.layouts import LANDMARK_POST_RADIUS

MAPPED_SHARE = 0.9
EXPLORING = tuple(i for i, choice in enumerate(CHOICES) if choice.mode == EXPLORE)
#: The choices tried once 90% are mapped (``--endgame``): going on with the revisits
#: under way, a loop closure, the least-known landmark.
ENDGAME = tuple(
    i for i, choice in enumerate(CHOICES) if choice.name in ("explore", "localise", "refine")
)
METRICS = ("steps_to_90", "final_entropy", "collisions_per_100", "mapped_share")
#: The choices after each try, and the loop closures: the frontier agent's own rule.
RULE = LoopClosingRule(close_at=0.4, closed_at=0.2)


def redraw_unmapped(env: gym.Env, agent: GoalChoiceAgent, rng: np.random.Generator) -> None:
    """Move the landmarks the filter has not mapped to points drawn uniformly over the
    agent's unswept free cells (the world's clearance from walls and obstacles, its
    spacing between landmarks, clear of the robot; a landmark with no such point in 50
    tries stays where it is, and if it then overlaps one drawn before it, all are drawn
    again, at most 5 times, then none is moved), keep the robot where it is, and give
    the env's noise a new generator from ``rng``."""
    base = env.unwrapped
    layout = base.layout
    cfg = base.config.world
    mapped = set(base.filter.belief_views()[2].tolist())
    grid = agent._memory.grid
    unswept = agent._memory.on_planning_grid(agent._unswept())
    cells = np.argwhere(unswept & (grid.clearance >= cfg.clearance + grid.resolution))
    robot = np.array(base.world.pose[:2])
    keep_off = base.config.robot.radius + LANDMARK_POST_RADIUS
    true = dict(zip(layout.landmark_ids, layout.landmark_positions, strict=True))
    for _ in range(5):
        placed = {lid: point for lid, point in true.items() if lid in mapped}
        moved = {}
        for lid in true:
            if lid in mapped or not len(cells):
                continue
            for _ in range(50):
                row, col = cells[rng.integers(len(cells))]
                point = np.array(grid.center(row, col))
                point += rng.uniform(-0.5, 0.5, 2) * grid.resolution
                if math.dist(point, robot) > keep_off and all(
                    math.dist(point, q) >= cfg.landmark_spacing for q in placed.values()
                ):
                    moved[lid] = placed[lid] = tuple(point.tolist())
                    break
            else:
                placed[lid] = true[lid]
        try:  # one left where it is may overlap one drawn before it: draw again
            base.move_landmarks(moved)
            break
        except ValueError:
            continue
    base.np_random = np.random.default_rng(rng.integers(2**63))


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
    env: gym.Env, agent: GoalChoiceAgent, choice: int, base: Policy, need: int
) -> int:
    """The agent's step count at which ``need`` landmarks are mapped (:func:`play_on`);
    an episode that ends first counts its length plus the env's limit."""
    for done, _ in play_on(env, agent, choice, base):
        if env.unwrapped.filter.n_landmarks >= need:
            return agent._steps
        if done:
            return agent._steps + env.spec.max_episode_steps
    raise AssertionError("play_on ends with the episode")


def final_entropy(env: gym.Env, agent: GoalChoiceAgent, choice: int, base: Policy) -> float:
    """The belief entropy (nats) at the episode's end (:func:`play_on`)."""
    for done, info in play_on(env, agent, choice, base):
        if done:
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
    """The policy of a :class:`GoalChoiceAgent` that tries the exploring choices (see
    the module) over ``base``'s; :meth:`attach` it to the agent it drives. Every choice
    it weighs goes to :attr:`labels`. With ``endgame`` > 0, once 90% are mapped it
    also tries :data:`ENDGAME` in that many drawn worlds each, to the episode's end,
    and takes the one that ends with the least belief entropy (the base's own on a
    tie); from then on the agent's choices hold while their goals stand
    (``hold_goals``), in its tries as in the episode."""

    def __init__(
        self,
        env: gym.Env,
        world: str,
        samples: int,
        seed: int,
        base: Policy = RULE,
        endgame: int = 0,
    ) -> None:
        self.env, self.world, self.samples, self.base = env, world, samples, base
        self.endgame = endgame
        self.rng = np.random.default_rng(seed)  # the belief's drawn worlds
        self.agent: GoalChoiceAgent | None = None
        self._holds = False  # the agent's own hold_goals, restored at each episode
        self.labels: list[Label] = []

    def attach(self, agent: GoalChoiceAgent) -> None:
        """Drive ``agent`` (whose policy this is)."""
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
            values = self._tried(ENDGAME, self.endgame, final_entropy)
            return self._least(values.mean(axis=0), ENDGAME, own)
        if own not in EXPLORING or mapped:
            return own
        costs = self._tried(EXPLORING, self.samples, lambda *game: steps_to_mapped(*game, need))
        costs -= self.agent._steps
        self.labels.append(Label(features.copy(), costs, own))
        return self._least(costs.mean(axis=0), EXPLORING, own)

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
                    redraw_unmapped(env, agent, np.random.default_rng(seed))
                out[i, k] = value(env, agent, choice, base)
        return out

    @staticmethod
    def _least(means: np.ndarray, choices: tuple[int, ...], own: int) -> int:
        """The choice of least mean, ``own`` on a tie."""
        if own in choices and means[choices.index(own)] == means.min():
            return own
        return choices[int(np.argmin(means))]


def lookahead_agent(
    env: gym.Env, world: str, samples: int, seed: int, base: str = "rule", endgame: int = 0
) -> GoalChoiceAgent:
    """The lookahead over ``base`` (``rule``, or a goal-choosing agent spec such as
    ``goals``) acting on ``env``, with ``endgame`` worlds per choice once 90% are
    mapped (:class:`Lookahead`)."""
    if base == "rule":
        agent = GoalChoiceAgent(env, RULE, seed=seed)
    else:
        agent = make_agent(base, env, seed)
        if not isinstance(agent, GoalChoiceAgent):
            raise ValueError(f"--base must be 'rule' or a goal-choosing policy, got {base!r}")
    policy = Lookahead(env, world, samples, seed, base=agent._policy, endgame=endgame)
    agent._policy = policy
    policy.attach(agent)
    return agent


def compare(
    setting: SuiteSetting,
    seeds: Sequence[int],
    env: gym.Env,
    lookahead: GoalChoiceAgent,
    name: str,
    labels: dict[int, list[Label]] | None = None,
) -> dict[str, list[dict[str, float]]]:
    """The suite metrics of ``frontier`` (on an env of its own) and of ``lookahead``
    (a :func:`lookahead_agent` on ``env``) on the setting's episodes; the choices the
    lookahead weighed go to ``labels`` by seed."""
    out: dict[str, list[dict[str, float]]] = {}
    frontier_env = make_env(setting.env_options, setting.steps)
    try:
        frontier = make_agent("frontier", frontier_env, seeds[0])
        out["frontier"] = [suite_metrics(run_episode(frontier_env, frontier, s)) for s in seeds]
    finally:
        frontier_env.close()
    policy = lookahead._policy
    rows = []
    for s in seeds:
        rows.append(suite_metrics(run_episode(env, lookahead, s)))
        if labels is not None:
            labels[s], policy.labels = policy.labels, []
    out[name] = rows
    return out


def save_labels(path: Path, labels: dict[int, list[Label]]) -> int:
    """``labels`` (by seed) as arrays in an ``.npz`` file: ``features`` (N, N_FEATURES),
    ``costs`` (N, worlds, choices), ``own`` and ``seed`` (N,: each one's episode), and
    ``choices``, the exploring choices the costs' last axis is. How many were saved."""
    rows = [(seed, x) for seed, weighed in labels.items() for x in weighed]
    if rows:
        features = np.stack([x.features for _, x in rows]).astype(np.float32)
        costs = np.stack([x.costs for _, x in rows]).astype(np.float64)
    else:
        features, costs = np.zeros((0, N_FEATURES), np.float32), np.zeros((0, 1, len(EXPLORING)))
    np.savez(
        path,
        features=features,
        costs=costs,
        own=np.array([x.own for _, x in rows], np.int64),
        seed=np.array([seed for seed, _ in rows], np.int64),
        choices=np.array(EXPLORING, np.int64),
    )
    return len(rows)


def report(results: dict[str, list[dict[str, float]]]) -> str:
    (frontier, lookahead) = results.values()
    lines = ["| agent | " + " | ".join(METRICS) + " |", "|---" * (len(METRICS) + 1) + "|"]
    for name, rows in results.items():
        means = [f"{np.mean([r[m] for r in rows]):.2f}" for m in METRICS]
        lines.append(f"| {name} | " + " | ".join(means) + " |")
    cells = []
    for m in METRICS:
        d = np.array([a[m] - b[m] for a, b in zip(lookahead, frontier, strict=True)])
        se = d.std(ddof=1) / math.sqrt(len(d)) if len(d) > 1 else math.nan
        cells.append(f"{d.mean():+.2f} ± {se:.2f} ({int((d < 0).sum())} lower)")
    lines.append("| lookahead − frontier | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    names = [s.name for s in suite_settings("default")]
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--setting", choices=names, default="default")
    parser.add_argument("--episodes", type=positive_int, default=30)
    parser.add_argument("--world", choices=("hindsight", "belief"), default="hindsight")
    parser.add_argument("--samples", type=positive_int, default=4)
    parser.add_argument("--seed", type=non_negative_int, default=SUITE_SEED)
    parser.add_argument("--base", default="rule", help="rule, goals or goals:PATH")
    parser.add_argument("--labels", type=Path, help="save the weighed choices (.npz)")
    parser.add_argument(
        "--endgame", type=non_negative_int, default=0, help="worlds per choice once 90%% are mapped"
    )
    args = parser.parse_args(argv)
    if not (args.base in ("rule", "goals") or args.base.startswith("goals:")):
        parser.error(f"argument --base: rule, goals or goals:PATH, got {args.base!r}")
    if args.labels is not None and not args.labels.parent.is_dir():
        parser.error(f"argument --labels: no directory {args.labels.parent}")
    (setting,) = [s for s in suite_settings("default") if s.name == args.setting]
    env = make_env(setting.env_options, setting.steps)
    try:
        try:
            lookahead = lookahead_agent(
                env, args.world, args.samples, args.seed, args.base, args.endgame
            )
        except ValueError as exc:  # a policy file that does not load
            parser.error(f"argument --base: {exc}")
        name = f"lookahead ({args.world}"
        name += "" if args.base == "rule" else f", {args.base}"
        name += f", endgame {args.endgame})" if args.endgame else ")"
        seeds = [args.seed + i for i in range(args.episodes)]
        labels: dict[int, list[Label]] = {}
        results = compare(setting, seeds, env, lookahead, name, labels)
    finally:
        env.close()
    print(report(results))
    if args.labels is not None:
        saved = save_labels(args.labels, labels)
        print(f"{saved} weighed choices saved to {args.labels}")


if __name__ == "__main__":
    main()
