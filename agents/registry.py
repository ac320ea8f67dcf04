"""Agents by name.

An agent spec is a short string, as the command line takes it:

| spec               | agent                                                           |
|--------------------|-----------------------------------------------------------------|
| ``random``         | :class:`agents.common.base.RandomAgent`: uniform random actions |
| ``frontier``       | :class:`agents.planners.frontier.FrontierAgent`: the frontier   |
| ``infogain``       | :class:`agents.planners.infogain.InfoGainAgent`: greedy info    |
| ``ppo``            | the shipped PPO policy, ``agents/policies/ppo_active_slam.zip`` |
| ``ppo:PATH``       | a PPO policy saved by ``slam-env train`` (an SB3 ``.zip``)      |
| ``rllib:PATH``     | an RLlib checkpoint of ``slam-env train --engine rllib``        |
| ``goals``          | the shipped goal policy, ``agents/policies/goal_explore.zip``   |
| ``goals:PATH``     | a goal-choosing policy (:mod:`agents.goals.choice`)             |
| ``lookahead``      | ``goals`` looking ahead in worlds drawn from the belief         |
| ``lookahead:PATH`` | the lookahead around the goal-choosing policy at PATH           |

Heuristic agents are imported only when asked for, so that one agent's import cost
(or absence) never affects another.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import gymnasium as gym

from agents.common.base import Agent, RandomAgent

#: The PPO policy shipped with the package (written by the lead after training).
SHIPPED_POLICY = Path(__file__).resolve().parent / "policies" / "ppo_active_slam.zip"
#: The goal-choosing policy shipped with the package (agents/configs/goal_explore.yaml).
SHIPPED_GOAL_POLICY = SHIPPED_POLICY.with_name("goal_explore.zip")

# name -> (module, class): imported lazily by make_agent.
_HEURISTICS: dict[str, tuple[str, str]] = {
    "frontier": ("agents.planners.frontier", "FrontierAgent"),
    "infogain": ("agents.planners.infogain", "InfoGainAgent"),
}

AGENT_NAMES = (
    "random",
    *_HEURISTICS,
    "ppo",
    "ppo:PATH",
    "rllib:PATH",
    "goals",
    "goals:PATH",
    "lookahead",
    "lookahead:PATH",
)


def agent_label(spec: str) -> str:
    """A short display name: ``ppo:runs/x/model.zip`` → ``ppo:model``."""
    spec = spec.strip()
    if spec.startswith("ppo:"):
        return f"ppo:{Path(spec[4:]).stem}"
    if spec.startswith("rllib:"):
        return f"rllib:{Path(spec[6:]).name}"
    for kind in ("goals", "lookahead"):
        if spec.startswith(f"{kind}:"):
            return f"{kind}:{Path(spec[len(kind) + 1 :]).stem}"
    return spec


def parse_agent_specs(text: str) -> list[str]:
    """Split a comma-separated list of specs; empty items and duplicates are errors."""
    specs = [s.strip() for s in text.split(",")]
    if not specs or any(not s for s in specs):
        raise ValueError(f"empty agent spec in {text!r}; expected e.g. 'random,frontier'")
    labels = [agent_label(s) for s in specs]
    dupes = sorted({x for x in labels if labels.count(x) > 1})
    if dupes:
        raise ValueError(f"agent(s) given twice: {', '.join(dupes)}")
    return specs


def _import_heuristic(name: str) -> type:
    module_name, class_name = _HEURISTICS[name]
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name != module_name:
            raise
        raise ValueError(f"agent {name!r} is not available: {module_name} is missing") from exc
    return getattr(module, class_name)


def make_agent(spec: str, env: gym.Env, seed: int | None = None) -> Agent:
    """The agent named by ``spec`` (see the module docstring), acting on ``env``.

    ``seed`` seeds the agent's own randomness (random and heuristic agents).
    Raises ``ValueError`` for an unknown spec, a PPO file that does not exist or a
    policy whose spaces do not match ``env``'s.
    """
    if not isinstance(spec, str):
        raise ValueError(f"agent spec must be a string, got {type(spec).__name__}")
    spec = spec.strip()
    if spec == "random":
        return RandomAgent(env, seed=seed)
    if spec in _HEURISTICS:
        return _import_heuristic(spec)(env, seed=seed)
    if spec == "ppo" or spec.startswith("ppo:"):
        from agents.learning.ppo_agent import load_ppo_agent

        if spec == "ppo":
            if not SHIPPED_POLICY.is_file():
                raise ValueError(
                    f"agent 'ppo': no shipped policy at {SHIPPED_POLICY}; train one with "
                    "'slam-env train' and pass it as 'ppo:PATH'"
                )
            return load_ppo_agent(SHIPPED_POLICY, env)
        path = spec[4:].strip()
        if not path:
            raise ValueError("agent spec 'ppo:' needs a path, e.g. 'ppo:runs/ppo/model.zip'")
        return load_ppo_agent(path, env)
    if spec.startswith("rllib:"):
        from agents.learning.rllib.agent import load_rllib_agent

        path = spec[6:].strip()
        if not path:
            raise ValueError("agent spec 'rllib:' needs a path, e.g. 'rllib:runs/rllib/model'")
        return load_rllib_agent(path, env)
    for kind in ("goals", "lookahead"):
        if spec == kind:
            return _goal_agent(kind, SHIPPED_GOAL_POLICY, env, seed)
        if spec.startswith(f"{kind}:"):
            path = spec[len(kind) + 1 :].strip()
            if not path:
                raise ValueError(
                    f"agent spec '{kind}:' needs a path, e.g. '{kind}:runs/goals/model.zip'"
                )
            return _goal_agent(kind, path, env, seed)
    raise ValueError(f"unknown agent {spec!r}; choose from {', '.join(AGENT_NAMES)}")


def _goal_agent(kind: str, path: str | Path, env: gym.Env, seed: int | None) -> Agent:
    """The goal-choosing policy at ``path``, with a lookahead around it for
    ``lookahead`` (:func:`agents.goals.lookahead.with_lookahead`)."""
    from agents.learning.sb3.goal_training import load_goal_agent

    agent = load_goal_agent(path, env, seed=seed)
    if kind == "lookahead":
        from agents.goals.lookahead import with_lookahead

        agent = with_lookahead(agent, env, seed=seed)
    return agent
