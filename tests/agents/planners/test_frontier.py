"""The frontier-exploration agent: full episodes, thresholds, episode handling."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from agents.common.base import Agent
from agents.goals.choice import GoalChoiceAgent
from agents.planners.frontier import EXPLORE, LOCALISE, POCKET_AREA, FrontierAgent, FrontierParams
from tests.agents.exploration_runs import (
    ENV_ID,
    assert_beats_random_on_default_episodes,
    assert_rejects_unsupported_envs,
    assert_same_seed_same_actions,
    drive,
)


def test_full_default_episodes_on_fixed_seeds():
    """Valid actions, ≥ 90% of the landmarks and better than random on the default env.
    (One test, so that parallel workers do not repeat the episodes.)"""
    assert_beats_random_on_default_episodes(FrontierAgent)


def test_is_an_sb3_style_predictor():
    env = gym.make(ENV_ID)
    agent = FrontierAgent(env, seed=0)
    assert isinstance(agent, Agent)
    obs, _ = env.reset(seed=3)
    state = object()
    action, out_state = agent.predict(obs, state=state, episode_start=np.array([True]))
    assert out_state is state
    assert env.action_space.contains(action)


def test_same_seed_same_actions():
    assert_same_seed_same_actions(FrontierAgent, 7, env_seed=5, steps=60)


def test_detects_a_new_random_world_without_episode_start():
    env = gym.make(ENV_ID)
    agent = FrontierAgent(env, seed=0)
    obs, _ = env.reset(seed=1)
    drive(agent, env, obs, 40)
    swept_before = agent.memory.coverage.fraction_swept()
    obs, _ = env.reset(seed=2)
    agent.predict(obs)  # no episode_start: the layout object changed
    assert agent.memory.layout is env.unwrapped.layout
    assert agent.memory.coverage.fraction_swept() < swept_before


def test_detects_a_reset_of_a_fixed_world_without_episode_start():
    env = gym.make(ENV_ID, preset="open")
    agent = FrontierAgent(env, seed=0)
    obs, _ = env.reset(seed=1)
    drive(agent, env, obs, 40)
    old = agent.memory
    obs, _ = env.reset(seed=1)  # same layout object: the belief is back at the start
    agent.predict(obs)
    assert agent.memory is not old


def test_closes_a_loop_when_the_pose_is_uncertain():
    """With a low threshold the agent leaves exploration to re-observe a landmark it
    knows much better than its pose, from a viewpoint of that landmark's estimate."""
    env = gym.make(ENV_ID)
    agent = FrontierAgent(env, seed=0, loop_close_std=0.06, loop_close_done_std=0.03)
    obs, _ = env.reset(seed=0)
    f = env.unwrapped.filter
    seen_localise = False
    for k in range(150):
        action, _ = agent.predict(obs, episode_start=k == 0)
        obs, *_ = env.step(action)
        if agent.mode == LOCALISE and agent.goal is not None:
            seen_localise = True
            mean, cov = f.landmark(agent.target_landmark)
            goal = agent.goal
            lo, hi = agent.params.view_distance
            reach = agent.memory.grid.resolution
            assert lo - reach <= math.dist(goal, mean) <= hi + reach
            sigma_pose = math.sqrt(f.pose_cov[0, 0] + f.pose_cov[1, 1])
            assert math.sqrt(np.trace(cov)) <= agent.params.useful_ratio * sigma_pose + 1e-9
            break
    assert seen_localise
    assert agent.mode in (EXPLORE, LOCALISE)


@pytest.mark.parametrize("agent_class", [FrontierAgent, GoalChoiceAgent])
def test_a_robot_walled_in_by_the_inflated_map_plans_its_way_out(agent_class):
    """Squeezed between obstacles closer than twice the planner's inflation, the robot
    stands in a pocket of free cells that no search leaves (moves never cut corners, so
    a diagonal neighbour is walled off too): the search starts from the nearest free
    cell of a part larger than POCKET_AREA instead, and so reaches the open map."""
    env = gym.make(ENV_ID, preset="open")
    extra = {"policy": lambda features: 0} if agent_class is GoalChoiceAgent else {}
    agent = agent_class(env, seed=0, **extra)
    obs, _ = env.reset(seed=1)
    agent.predict(obs, episode_start=True)
    mem = agent.memory
    pose = env.unwrapped.filter.pose
    i, j = mem.grid.cell_of(pose[0], pose[1])
    step = 1 if i + 8 < mem.free.shape[0] else -1  # toward the side with room
    free = np.zeros_like(mem.free)
    free[i, j] = free[i + step, j + 1] = True  # the robot's cell and a diagonal pocket
    free[i + 3 * step, j - 2 : j + 3] = True  # a part too small to count as open
    open_rows = slice(i + 5 * step, i + 9 * step, step)
    free[open_rows, :] = True
    mem.free = free
    cells = np.count_nonzero(free[open_rows, :])
    assert cells * mem.grid.resolution**2 >= POCKET_AREA

    dist, _ = agent._paths_from(pose)
    assert np.isfinite(dist[open_rows, :]).all() and dist[i + 5 * step, j] == 0.0
    assert np.count_nonzero(np.isfinite(dist)) == cells  # from there, the open part only
    # Once the robot has reached open space, it searches from its own cell again.
    free[i + step : i + 5 * step : step, j] = True
    dist, _ = agent._paths_from(pose)
    assert dist[i, j] == 0.0 and np.isfinite(dist[open_rows, :]).all()


def test_runs_in_a_world_with_inner_walls():
    env = gym.make(ENV_ID, preset="rooms", max_episode_steps=200)
    agent = FrontierAgent(env, seed=0)
    obs, info = env.reset(seed=0)
    run = drive(agent, env, obs)
    assert all(env.action_space.contains(action) for action in run.actions)
    assert run.info["landmarks_known"] > info["landmarks_known"]


def test_rejects_what_it_cannot_drive():
    assert_rejects_unsupported_envs(FrontierAgent)


def test_rejects_bad_parameters():
    env = gym.make(ENV_ID)
    with pytest.raises(TypeError, match="gain_weigth"):
        FrontierAgent(env, gain_weigth=1.0)
    with pytest.raises(ValueError, match="lookahead"):
        FrontierAgent(env, lookahead=0.0)
    with pytest.raises(ValueError, match="loop_close_done_std"):
        FrontierParams(loop_close_std=0.2, loop_close_done_std=0.3)
