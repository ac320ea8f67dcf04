"""The greedy information-gain agent: full episodes, thresholds, its scoring."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from agents.common.base import Agent
from agents.planners.infogain import DEFAULT_PRIMITIVES, InfoGainAgent, InfoGainParams
from tests.agents.exploration_runs import (
    ENV_ID,
    assert_beats_random_on_default_episodes,
    assert_rejects_unsupported_envs,
    assert_same_seed_same_actions,
    drive,
)

INFO, DISCOVERY, FRONTIER, COLLISION = range(4)


def test_full_default_episodes_on_fixed_seeds():
    """Valid actions, ≥ 90% of the landmarks and better than random on the default env.
    (One test, so that parallel workers do not repeat the episodes.)"""
    assert_beats_random_on_default_episodes(InfoGainAgent)


def _start(layout: dict, **params) -> tuple[gym.Env, InfoGainAgent, np.ndarray]:
    env = gym.make(ENV_ID, layout=layout)
    agent = InfoGainAgent(env, seed=0, **params)
    obs, _ = env.reset(seed=0)
    action, _ = agent.predict(obs, episode_start=True)
    return env, agent, action


def test_does_not_drive_into_a_known_obstacle():
    layout = {
        "width": 10.0,
        "height": 10.0,
        "landmarks": [[1.0, 9.0], [9.0, 9.0]],
        "obstacles": [{"box": [3.0, 5.0, 1.0, 4.0]}],  # 0.75 m ahead of the start
        "start": [1.75, 5.0, 0.0],
    }
    _, agent, action = _start(layout)
    scores = agent.last_scores
    straight = DEFAULT_PRIMITIVES.index((1.0, 0.0))
    assert scores[straight, COLLISION] < 0.0  # straight ahead is predicted to hit it
    total = scores.sum(axis=1)
    assert scores[int(np.argmax(total)), COLLISION] == 0.0
    assert not (action[0] > 0.5 and abs(action[1]) < 0.3)


def test_expected_observations_of_known_landmarks_are_worth_information():
    """The same motion from the same (exactly known) start removes more predicted
    entropy when a known landmark stays in view than when nothing is in view."""

    def straight_info(landmark: list[float]) -> float:
        layout = {"width": 12.0, "height": 12.0, "landmarks": [landmark], "start": [2, 6, 0]}
        env, agent, _ = _start(layout)
        known = env.unwrapped.filter.n_landmarks
        info = agent.last_scores[:, INFO]
        assert np.all(np.isfinite(info))
        return known, info[DEFAULT_PRIMITIVES.index((1.0, 0.0))]

    known_ahead, info_ahead = straight_info([5.5, 6.0])  # 3.5 m ahead: seen all along
    known_behind, info_behind = straight_info([1.0, 1.0])  # behind: never seen
    assert (known_ahead, known_behind) == (1, 0)
    assert info_behind < 0.0  # dead reckoning only adds uncertainty
    assert info_ahead > info_behind + 0.5


def test_unseen_area_and_frontier_progress_are_rewarded():
    layout = {
        "width": 16.0,
        "height": 8.0,
        "landmarks": [[15.0, 7.0]],
        "start": [1.0, 4.0, math.pi],  # facing the near wall, the arena behind
    }
    _, agent, action = _start(layout)
    scores = agent.last_scores
    assert scores[:, DISCOVERY].max() > 0.0
    assert scores[:, FRONTIER].max() > 0.0
    assert action[0] < 0.5  # it turns toward the open arena instead of the wall


def test_same_seed_same_actions():
    assert_same_seed_same_actions(InfoGainAgent, 3, env_seed=4, steps=40)


def test_is_an_sb3_style_predictor_that_notices_new_episodes():
    env = gym.make(ENV_ID)
    agent = InfoGainAgent(env, seed=0)
    assert isinstance(agent, Agent)
    obs, _ = env.reset(seed=1)
    state = ("anything",)
    for k in range(30):
        action, out_state = agent.predict(obs, state=state, episode_start=np.array([k == 0]))
        assert out_state is state
        obs, *_ = env.step(action)
    old = agent.memory
    obs, _ = env.reset(seed=2)
    agent.predict(obs)  # no episode_start: a new world all the same
    assert agent.memory is not old
    assert agent.memory.layout is env.unwrapped.layout


def test_runs_in_a_small_world_with_inner_walls():
    for options in ({"preset": "rooms"}, {"n_landmarks": 6, "width": 8.0, "height": 8.0}):
        env = gym.make(ENV_ID, max_episode_steps=150, **options)
        agent = InfoGainAgent(env, seed=0)
        obs, info = env.reset(seed=0)
        run = drive(agent, env, obs)
        assert all(env.action_space.contains(action) for action in run.actions)
        assert run.info["landmarks_known"] > info["landmarks_known"], options


def test_rejects_what_it_cannot_drive_and_bad_parameters():
    assert_rejects_unsupported_envs(InfoGainAgent)
    env = gym.make(ENV_ID)
    with pytest.raises(TypeError, match="horizn"):
        InfoGainAgent(env, horizn=3)
    with pytest.raises(ValueError, match="observe_at"):
        InfoGainParams(horizon=4, observe_at=(6,))
    with pytest.raises(ValueError, match="primitives"):
        InfoGainParams(primitives=((2.0, 0.0),))


@pytest.mark.parametrize("association", ["nearest_neighbor", "jcbb"])
def test_plans_on_a_filter_that_associates_by_itself(association):
    """With hidden correspondences the predicted observations name the filter's own
    slots: the agent runs, and a landmark in view is worth information."""
    env = gym.make(ENV_ID, data_association=association, max_episode_steps=30)
    agent = InfoGainAgent(env, seed=0)
    obs, _ = env.reset(seed=1)
    infos = []
    for step in range(30):
        action, _ = agent.predict(obs, episode_start=step == 0)
        assert env.action_space.contains(action)
        obs, _, terminated, truncated, _ = env.step(action)
        if agent.last_scores is not None and env.unwrapped.filter.n_landmarks:
            infos.append(agent.last_scores[:, INFO].max())
        if terminated or truncated:
            break
    assert env.unwrapped.filter.n_landmarks > 0
    assert max(infos) > 0.0
