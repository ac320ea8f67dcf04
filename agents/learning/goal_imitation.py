"""A teacher first: a goal-choosing policy fitted to a fixed rule's choices before PPO.

``imitation_choices: N`` in a goal-training config (:mod:`agents.learning.sb3.goal_training`):
:class:`LoopClosingRule` makes N choices (over all sub-envs) in the training envs
(:func:`demonstrate`), the policy is fitted to them by cross-entropy and its value to
their discounted returns (:func:`fit_policy`, ``imitation_epochs`` passes), and PPO
then trains as configured, from there. Behaviour cloning as a start for reinforcement
learning; docs/goal_policy.md measures what it gives (a policy that stays close to its teacher).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from agents.goals.choice import CHOICES, MODE_FEATURES, POSE_SIGMA_FEATURE
from agents.planners.frontier import LOCALISE, FrontierParams

#: The choices of the rule: the frontier agent's weighting, and a loop closure.
_EXPLORE = next(i for i, c in enumerate(CHOICES) if c.name == "explore")
_LOCALISE = next(i for i, c in enumerate(CHOICES) if c.mode == LOCALISE)
#: The unit of the pose-σ feature (m): the loop-closing threshold of the planner the
#: goal env runs, the frontier agent's with its default parameters.
_SIGMA_UNIT = FrontierParams().loop_close_std
#: Demonstrations fitted per gradient step.
BATCH_SIZE = 256


@dataclass(frozen=True)
class LoopClosingRule:
    """The teacher: the frontier agent's weighting at every choice, and a loop closure
    once the pose σ passes ``close_at`` (m), held until it falls below ``closed_at``
    (the frontier agent's own rule closes at 0.4 m; 0.6 m puts the loop closures off
    and maps faster on the default world, docs/goal_policy.md). A policy over the features alone."""

    close_at: float = 0.6
    closed_at: float = 0.2

    def __post_init__(self) -> None:
        if not (0.0 < self.closed_at <= self.close_at < math.inf):
            raise ValueError(f"LoopClosingRule needs 0 < closed_at <= close_at < inf, got {self}")

    def __call__(self, features: np.ndarray) -> int:
        sigma = float(features[POSE_SIGMA_FEATURE]) * _SIGMA_UNIT
        localising = features[MODE_FEATURES[LOCALISE]] > 0.5
        if sigma > self.close_at or (localising and sigma >= self.closed_at):
            return _LOCALISE
        return _EXPLORE


class Demonstrations(NamedTuple):
    """A teacher's choices: (N, N_FEATURES) features, (N,) choices, (N,) discounted
    returns, and (N,) whether the return is complete (its episode ended in the run)."""

    features: np.ndarray
    choices: np.ndarray
    returns: np.ndarray
    complete: np.ndarray


def demonstrate(venv: Any, teacher: Any, choices: int, gamma: float) -> Demonstrations:
    """``teacher``'s choices in the SB3 vector env ``venv`` (reset first), at least
    ``choices`` of them over its sub-envs, with their returns discounted by ``gamma``."""
    n = venv.num_envs
    obs = venv.reset()
    seen, taken, rewards, dones = [], [], [], []
    for _ in range(math.ceil(choices / n)):
        action = np.array([teacher(row) for row in obs], dtype=np.int64)
        seen.append(obs)
        taken.append(action)
        obs, reward, done, _ = venv.step(action)
        rewards.append(np.asarray(reward, dtype=np.float64))
        dones.append(np.asarray(done, dtype=bool))
    returns = np.zeros((len(rewards), n))
    complete = np.zeros((len(rewards), n), dtype=bool)
    later, ended = np.zeros(n), np.zeros(n, dtype=bool)
    for t in range(len(rewards) - 1, -1, -1):  # a return stops at its episode's end
        later = rewards[t] + gamma * np.where(dones[t], 0.0, later)
        ended = dones[t] | ended
        returns[t], complete[t] = later, ended
    return Demonstrations(
        np.concatenate(seen).astype(np.float32),
        np.concatenate(taken),
        returns.reshape(-1).astype(np.float32),
        complete.reshape(-1),
    )


def fit_policy(
    policy: Any,
    demos: Demonstrations,
    epochs: int,
    *,
    vf_coef: float,
    max_grad_norm: float,
    seed: int,
) -> float:
    """Fit an SB3 actor-critic ``policy`` to ``demos`` with its own optimiser, as PPO
    steps it (the gradient's norm clipped to ``max_grad_norm``): the choices by
    cross-entropy, the value to the complete returns (weighted ``vf_coef``), ``epochs``
    passes in batches shuffled from ``seed``. The share of the demonstrated choices the
    fitted policy makes greedily."""
    import torch

    features = torch.as_tensor(demos.features)
    choices = torch.as_tensor(demos.choices)
    returns = torch.as_tensor(demos.returns)
    complete = torch.as_tensor(demos.complete)
    generator = torch.Generator().manual_seed(seed)
    policy.set_training_mode(True)
    for _ in range(epochs):
        order = torch.randperm(len(choices), generator=generator)
        for start in range(0, len(order), BATCH_SIZE):
            batch = order[start : start + BATCH_SIZE]
            values, log_prob, _ = policy.evaluate_actions(features[batch], choices[batch])
            loss = -log_prob.mean()
            known = complete[batch]
            if known.any():
                error = values.flatten()[known] - returns[batch][known]
                loss = loss + vf_coef * (error**2).mean()
            policy.optimizer.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), max_grad_norm)
            policy.optimizer.step()
    policy.set_training_mode(False)
    with torch.no_grad():
        greedy = policy.get_distribution(features).mode()
    return float((greedy == choices).float().mean())


def imitate(model: Any, venv: Any, choices: int, epochs: int, seed: int) -> dict[str, Any]:
    """Fit ``model``'s policy (SB3 PPO) to ``choices`` of :class:`LoopClosingRule`'s in
    ``venv``, as :func:`fit_policy` does with the model's discount, value weight and
    gradient clipping; what it did, for the training summary."""
    start = time.perf_counter()
    demos = demonstrate(venv, LoopClosingRule(), choices, model.gamma)
    accuracy = fit_policy(
        model.policy,
        demos,
        epochs,
        vf_coef=model.vf_coef,
        max_grad_norm=model.max_grad_norm,
        seed=seed,
    )
    return {
        "teacher": "LoopClosingRule",
        "choices": len(demos.choices),
        "epochs": epochs,
        "accuracy": round(accuracy, 4),
        "wall_time_s": round(time.perf_counter() - start, 3),
    }
