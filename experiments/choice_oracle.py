"""What the goal choices could give: a lookahead over the exploring choices, in
hindsight or from the belief, beside ``frontier``, on one setting of the suite.

    .venv/bin/python -m experiments.choice_oracle [--setting default] [--episodes 30]
        [--world hindsight|belief] [--samples 4] [--seed 10000] [--base rule|goals|goals:PATH]
        [--labels PATH.npz] [--endgame 0]

The lookahead is :mod:`agents.goals.lookahead`'s (the ``lookahead`` agent is this one with
``--world belief --samples 4 --base goals --endgame 2``): at every choice
of a :class:`~agents.goals.choice.GoalChoiceAgent` made before 90% of the landmarks
are mapped, each exploring choice (the three frontier weightings) is tried on a copy
of the env and the agent, the base policy choosing after it, up to the step at which
90% are mapped, and the one that gets there soonest is taken (the base's own on a
tie); the base's other choices are left alone. With ``--endgame N`` it also chooses
after 90% is mapped, by the final entropy of tries of the revisits, a loop closure
and the least-known landmark. The base is ``rule``
(:class:`~agents.learning.goal_imitation.LoopClosingRule` with loop closures from a pose σ of
0.4 m until below 0.2 m, the frontier agent's own rule) or a goal-choosing policy
(``goals``: the shipped one).

* ``hindsight``: each try runs in the copy's own world with the noise to come, so its
  count is exact: what the best choice at every choice would give, which no policy can
  make (it knows where the unmapped landmarks are and the true pose).
* ``belief``: ``--samples`` copies per choice (the same ones for every choice), the
  robot and the mapped landmarks drawn from the belief, the landmarks not yet mapped
  drawn uniformly over the unswept free area, and the noise drawn afresh
  (:func:`~agents.goals.lookahead.draw_belief_world`): what looking ahead from the belief
  finds.

Prints, per agent, the means of steps to 90% mapped, final entropy, collisions per
100 steps and the share of the landmarks mapped at the end, and the lookahead's paired
difference from ``frontier`` (mean ± standard error, and the seeds it is lower on).
The episodes are the suite's: ``reset(seed=seed + i)``, the setting's length.
``--labels`` also saves every choice the lookahead weighed, for
``experiments/choice_distillation.py``: its features, the steps from it to 90% mapped of each
exploring choice in each world tried, the base's own choice and the episode's seed.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path

import gymnasium as gym
import numpy as np

from agents.common.arguments import non_negative_int, positive_int
from agents.common.env import make_env
from agents.evaluation.suite import SUITE_SEED, SuiteSetting, suite_settings
from agents.goals.choice import N_FEATURES, GoalChoiceAgent
from agents.goals.lookahead import EXPLORING, Label, with_lookahead
from agents.learning.goal_imitation import LoopClosingRule
from agents.registry import make_agent
from agents.rollouts.episodes import run_episode
from agents.rollouts.suite_metrics import suite_metrics

METRICS = ("steps_to_90", "final_entropy", "collisions_per_100", "mapped_share")
#: The choices after each try, and the loop closures: the frontier agent's own rule.
RULE = LoopClosingRule(close_at=0.4, closed_at=0.2)


def lookahead_agent(
    env: gym.Env, world: str, samples: int, seed: int, base: str = "rule", endgame: int = 0
) -> GoalChoiceAgent:
    """The lookahead over ``base`` (``rule``, or a goal-choosing agent spec such as
    ``goals``) acting on ``env``, with ``endgame`` worlds per choice once 90% are
    mapped, recording the choices it weighs (:class:`~agents.goals.lookahead.Lookahead`)."""
    if base == "rule":
        agent = GoalChoiceAgent(env, RULE, seed=seed)
    else:
        agent = make_agent(base, env, seed)
        if not isinstance(agent, GoalChoiceAgent):
            raise ValueError(f"--base must be 'rule' or a goal-choosing policy, got {base!r}")
    options = dict(world=world, samples=samples, endgame=endgame, record=True)
    return with_lookahead(agent, env, seed=seed, **options)


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
