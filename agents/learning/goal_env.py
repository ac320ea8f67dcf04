"""The env a goal-choosing policy learns in: one step per choice of the planner's goal.

:class:`GoalChoiceEnv` wraps ``slam_env/ActiveSLAM-v0`` and a
:class:`~agents.goals.choice.GoalChoiceAgent`: ``step(choice)`` hands the choice to the
agent's planner, which drives (env step after env step) until its next choice is due,
and returns that choice's :func:`~agents.goals.choice.choice_features`. The reward is
the sum of the active-SLAM env's rewards over those env steps (its ``reward_weights``
shape it), plus ``discovery_bonus`` for each landmark the belief gains (up to
``discovery_until`` of the world's landmarks), per landmark of the world, so that
worlds of 10 and of 60 landmarks weigh alike. Each episode draws
its world from a :class:`~agents.learning.worlds.WorldDistribution` (or keeps the env
options' world) and lasts :func:`~agents.common.episode_length.episode_length` of its arena unless
``max_episode_steps`` says otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np

from agents.common.arguments import check_count
from agents.common.env import make_env
from agents.common.episode_length import REFERENCE_ARENA, episode_length
from agents.goals.choice import GoalChoiceAgent, check_hold_goals, choice_space, feature_space
from agents.learning.worlds import MAX_DRAWS, WorldDistribution

_SEED_BOUND = 2**31


#: How the discovery bonus is paid over an episode (``discovery_schedule``).
DISCOVERY_SCHEDULES = ("flat", "remaining")


def check_discovery(bonus: Any, until: Any, schedule: Any = "flat") -> None:
    """``ValueError`` unless ``discovery_bonus`` is a finite number >= 0,
    ``discovery_until`` a number in (0, 1] and ``discovery_schedule`` one of
    :data:`DISCOVERY_SCHEDULES` (:class:`GoalChoiceEnv`'s arguments)."""
    if not (_is_number(bonus) and 0 <= bonus < math.inf):
        raise ValueError(f"discovery_bonus must be a finite number >= 0, got {bonus!r}")
    if not (_is_number(until) and 0 < until <= 1):
        raise ValueError(f"discovery_until must be a number in (0, 1], got {until!r}")
    if not (isinstance(schedule, str) and schedule in DISCOVERY_SCHEDULES):
        raise ValueError(
            f"discovery_schedule must be one of {DISCOVERY_SCHEDULES}, got {schedule!r}"
        )


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _refuse_choice(features: np.ndarray) -> int:
    raise RuntimeError("GoalChoiceEnv's agent takes its choices from step()")  # a bug here


class GoalChoiceEnv(gym.Env):
    """Decision-level env: observations are choice features, actions choices.

    Args:
        env_options: options of ``slam_env/ActiveSLAM-v0`` (every episode's).
        worlds: the distribution each episode draws its world from (its options
            override ``env_options``'); None: ``env_options``' world.
        max_episode_steps: env steps of an episode; None: the arena's episode length.
        discovery_bonus: reward (in the env's units, nats for the information gain)
            for each landmark the belief gains, on top of the env's reward: the
            information gain pays for a discovery too, and as much for refining the
            map, so this weighs finding the landmarks early against refining them.
        discovery_until: the share of the world's landmarks, in (0, 1], up to which
            discoveries earn the bonus (0.9: the first 90%, after which only the env's
            reward pays, so that the last landmarks weigh no more than loop closures).
        discovery_schedule: ``"flat"``: each discovery earns ``discovery_bonus``;
            ``"remaining"``: times the share of the episode still left when it is made
            (1 on the first step, 1/T on the last of T), so that the bonuses of an
            episode sum to the area above its discovery curve: mapping early pays.
        curriculum_choices: a curriculum over the arena sizes of ``worlds``: an episode
            that starts after c choices (over all episodes of this env) draws from the
            smallest ``ceil(c / curriculum_choices · K)`` of its K sizes
            (:meth:`~agents.learning.worlds.WorldDistribution.up_to`), so that the
            arenas grow to all K over the first ``curriculum_choices`` choices; 0: all
            from the start.
        hold_goals: the agent's choices hold while their goals stand
            (:class:`~agents.goals.choice.GoalChoiceAgent`).
    """

    metadata: dict[str, Any] = {"render_modes": []}

    def __init__(
        self,
        env_options: Mapping[str, Any] | None = None,
        worlds: WorldDistribution | None = None,
        max_episode_steps: int | None = None,
        discovery_bonus: float = 0.0,
        discovery_until: float = 1.0,
        discovery_schedule: str = "flat",
        curriculum_choices: int = 0,
        hold_goals: bool = False,
    ) -> None:
        check_discovery(discovery_bonus, discovery_until, discovery_schedule)
        check_count("curriculum_choices", curriculum_choices, 0)
        check_hold_goals(hold_goals)
        self.observation_space = feature_space()
        self.action_space = choice_space()
        self._options = dict(env_options or {})
        self._worlds = worlds
        self._max_steps = max_episode_steps
        self._discovery_bonus = float(discovery_bonus)
        self._discovery_until = float(discovery_until)
        self._pay_by_time_left = discovery_schedule == "remaining"
        self._horizon = 1  # env steps of the episode
        self._t = 0  # env steps so far
        self._env: gym.Env | None = None
        self._agent: GoalChoiceAgent | None = None
        self._info: dict[str, Any] = {}
        self._n_landmarks = 1
        self._paid_until = 1.0  # landmarks known up to which a discovery earns the bonus
        self._curriculum_choices = curriculum_choices
        self._choices_made = 0  # over all episodes: the curriculum's clock
        self._hold_goals = hold_goals

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        rng = self.np_random
        self.close()
        worlds = self._worlds
        if worlds is not None and self._curriculum_choices:
            worlds = worlds.up_to(self._choices_made / self._curriculum_choices)
        for _ in range(MAX_DRAWS):
            setting = dict(self._options)
            if worlds is not None:
                setting.update(worlds.sample(rng))
            side = max(
                setting.get("width", REFERENCE_ARENA), setting.get("height", REFERENCE_ARENA)
            )
            agent_seed, world_seed = (int(s) for s in rng.integers(_SEED_BOUND, size=2))
            horizon = self._max_steps or episode_length(side, side)
            env = make_env(setting, horizon)
            try:
                _, info = env.reset(seed=world_seed)
                break
            except ValueError:
                env.close()
                if self._worlds is None:
                    raise
                # A world that cannot be laid out in this arena: draw again.
        else:
            raise ValueError(f"worlds: no layable setting in {MAX_DRAWS} draws from {self._worlds}")
        self._env = env
        self._horizon, self._t = horizon, 0
        self._agent = GoalChoiceAgent(
            env, _refuse_choice, seed=agent_seed, hold_goals=self._hold_goals
        )
        self._agent.reset()
        self._n_landmarks = max(len(info["landmark_ids"]), 1)
        self._paid_until = self._discovery_until * self._n_landmarks
        self._info = info
        features, _, terminated, truncated = self._drive(None)
        if terminated or truncated:  # an episode over before its first choice
            raise RuntimeError("the episode ended before the planner's first choice")
        return features, dict(info)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._agent is None:
            raise RuntimeError("call reset() before step()")
        if not self.action_space.contains(action):
            raise ValueError(f"action must be an int in [0, {self.action_space.n}), got {action!r}")
        features, reward, terminated, truncated = self._drive(int(action))
        self._choices_made += 1
        return features, reward, terminated, truncated, dict(self._info)

    def _drive(self, choice: int | None) -> tuple[np.ndarray, float, bool, bool]:
        """Env steps from ``choice`` (None: the episode's start) until the next choice
        is due or the episode ends: (features, summed reward, terminated, truncated)."""
        agent, env = self._agent, self._env
        total = 0.0
        action = None if choice is None else agent.finish_step(choice)
        while True:
            if action is not None:
                known = self._info["landmarks_known"]
                _, reward, terminated, truncated, self._info = env.step(action)
                now, cap = self._info["landmarks_known"], self._paid_until
                paid = max(min(now, cap) - min(known, cap), 0.0)  # fractional at the cap
                if self._pay_by_time_left:
                    paid *= 1.0 - self._t / self._horizon
                self._t += 1
                total += float(reward) + self._discovery_bonus * paid
                if terminated or truncated:
                    return agent.features(), total / self._n_landmarks, terminated, truncated
            action = agent.begin_step()
            if action is None:
                return agent.features(), total / self._n_landmarks, False, False

    def close(self) -> None:
        if self._env is not None:
            self._env.close()
            self._env = None
