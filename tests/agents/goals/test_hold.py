"""Held goals (``hold_goals``): a choice lasts until its goal is reached or moves."""

from __future__ import annotations

import re

import numpy as np
import pytest
from stable_baselines3 import PPO

from agents.common.env import make_env
from agents.goals.choice import GoalChoiceAgent
from agents.learning.config import ConfigError, config_from_dict
from agents.learning.goal_env import GoalChoiceEnv
from agents.learning.sb3.goal_training import load_goal_agent
from agents.learning.sb3.training import train
from agents.planners.frontier import EXPLORE, REFINE, FrontierAgent
from agents.registry import SHIPPED_GOAL_POLICY
from tests.agents.goals.test_choice import SMALL_ARENA, Recorder, run, tiny_goal_config


@pytest.mark.parametrize(("options", "steps"), [({}, 150), (SMALL_ARENA, 250)])
def test_a_constant_choice_drives_the_same_held_and_is_asked_less(options, steps):
    """Asked again at a replan, a policy that always makes the same choice replans to
    the goal that would have stood: holding changes only how often it is asked."""
    streams, asked = [], []
    for hold in (False, True):
        env = make_env(options, steps)
        policy = Recorder((0,))
        streams.append(run(GoalChoiceAgent(env, policy, seed=3, hold_goals=hold), env, 4, steps))
        asked.append(len(policy.seen))
        env.close()
    np.testing.assert_array_equal(np.array(streams[0]), np.array(streams[1]))
    assert len(streams[0]) == steps
    assert 0 < asked[1] < asked[0]


def planned(choice: int, hold: bool, explore_steps: int = 0):
    """An agent on the default world that chose ``choice`` (after ``explore_steps``
    steps of exploring), and its env."""
    env = make_env({}, 200)
    agent = GoalChoiceAgent(env, Recorder(), seed=0, hold_goals=hold)
    env.reset(seed=2)
    agent.reset()
    for _ in range(explore_steps):
        action = agent.begin_step()
        env.step(agent.finish_step(0) if action is None else action)
    while (action := agent.begin_step()) is not None:
        env.step(action)  # on to the next choice
    env.step(agent.finish_step(choice))
    return agent, env


def replan_due(agent: GoalChoiceAgent) -> np.ndarray | None:
    """begin_step with the replan interval just gone."""
    agent._since_plan = agent.params.replan_interval
    return agent.begin_step()


@pytest.mark.parametrize(("choice", "explore_steps"), [(0, 0), (4, 40)])
def test_a_held_goal_that_stands_is_driven_on_without_asking(choice, explore_steps):
    for hold in (False, True):
        agent, env = planned(choice, hold, explore_steps)
        goal, mode, target = agent.goal, agent.mode, agent.target_landmark
        assert goal is not None and mode == (EXPLORE if choice == 0 else REFINE)
        action = replan_due(agent)
        if not hold:
            assert action is None  # asked at every replan
            continue
        assert env.action_space.contains(action) and np.abs(action).max() > 0.0
        assert agent.goal is not None and np.array_equal(agent.goal, goal)
        assert (agent.mode, agent.target_landmark) == (mode, target)
        assert agent._since_plan == 0  # replanned now, as _plan counts it


def test_a_held_frontier_goal_swept_meanwhile_asks_again():
    agent, _ = planned(0, hold=True)
    goal = agent.goal
    agent.memory.coverage.abandoned[agent._window(goal)] = True  # nothing left there
    assert replan_due(agent) is None
    agent.finish_step(0)
    assert agent.goal is not None and not np.array_equal(agent.goal, goal)


def test_a_replan_whose_held_goal_moved_computes_the_frontier_terms_once(monkeypatch):
    """Whether the goal stands, the features and the plan share one computation."""
    agent, _ = planned(0, hold=True)
    agent.memory.coverage.abandoned[agent._window(agent.goal)] = True  # the goal moves
    compute, calls = FrontierAgent._frontier_terms, []

    def counted(self, pose, dist):
        calls.append(dist)
        return compute(self, pose, dist)

    monkeypatch.setattr(FrontierAgent, "_frontier_terms", counted)
    assert replan_due(agent) is None
    agent.features()
    agent.finish_step(0)
    assert len(calls) == 1


def test_a_held_revisit_whose_landmark_is_done_meanwhile_asks_again():
    agent, _ = planned(4, hold=True, explore_steps=40)
    target = agent.target_landmark
    agent._tried.add(target)  # revisited meanwhile: another one is next
    assert replan_due(agent) is None
    agent.finish_step(4)
    assert agent.target_landmark not in (None, target)


def test_holding_can_start_mid_episode():
    agent, _ = planned(0, hold=False)
    agent.hold_goals = True
    assert agent.hold_goals and replan_due(agent) is not None  # the goal stands: held
    for bad in (1, None):
        with pytest.raises(TypeError, match="hold_goals must be a bool"):
            agent.hold_goals = bad
    assert agent.hold_goals is True


def test_hold_goals_must_be_a_bool():
    env = make_env({}, 20)
    for bad in (1, "yes", None):
        with pytest.raises(TypeError, match="hold_goals must be a bool"):
            GoalChoiceAgent(env, Recorder(), hold_goals=bad)
        with pytest.raises(TypeError, match="hold_goals must be a bool"):
            GoalChoiceEnv({}, hold_goals=bad)
    goals = tiny_goal_config("unused")
    assert config_from_dict(goals).hold_goals is False
    assert config_from_dict({**goals, "hold_goals": True}).hold_goals is True
    for bad in (1, "true", None):
        with pytest.raises(ConfigError, match="'hold_goals' must be true or false"):
            config_from_dict({**goals, "hold_goals": bad})
    with pytest.raises(ConfigError, match="false unless decisions is goals"):
        config_from_dict({"hold_goals": True})


def test_the_env_holds_its_agents_goals():
    choices = []
    for hold in (False, True):
        env = GoalChoiceEnv({}, max_episode_steps=300, hold_goals=hold)
        env.reset(seed=5)
        n, done = 0, False
        while not done:
            _, _, terminated, truncated, _ = env.step(0)
            done, n = terminated or truncated, n + 1
        choices.append(n)
        env.close()
    assert 0 < choices[1] < choices[0]


def test_a_policy_trained_holding_goals_runs_holding_them(tmp_path):
    path = train(tiny_goal_config(tmp_path, hold_goals=True))
    env = make_env({}, 20)
    assert load_goal_agent(path, env, seed=0).hold_goals is True
    assert load_goal_agent(SHIPPED_GOAL_POLICY, env, seed=0).hold_goals is False  # before it
    plain = train(tiny_goal_config(tmp_path / "plain"))
    assert load_goal_agent(plain, env, seed=0).hold_goals is False
    model = PPO.load(path, device="cpu")
    model.hold_goals = 1  # a file that says something else than true or false
    odd = tmp_path / "odd.zip"
    model.save(odd)
    with pytest.raises(ValueError, match=re.escape(f"{odd}: hold_goals must be a bool, got 1")):
        load_goal_agent(odd, env, seed=0)
