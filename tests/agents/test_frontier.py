"""The frontier-exploration agent: full episodes, thresholds, episode handling."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from agents.base import Agent, RandomAgent
from agents.frontier import EXPLORE, LOCALISE, FrontierAgent, FrontierParams
from tests.agents.exploration_runs import (
    ENV_ID,
    N_LANDMARKS,
    SEEDS,
    assert_valid_actions,
    run_episode,
)


def test_full_default_episodes_on_fixed_seeds():
    """On the default env (500 steps, a new random world per seed) the agent acts
    validly throughout, maps at least 90% of the landmarks on every seed, and beats
    the random agent on mean landmarks mapped and mean final belief entropy. (One test,
    so that parallel workers do not repeat the episodes.)"""
    ours = [run_episode(FrontierAgent, seed) for seed in SEEDS]
    baseline = [run_episode(RandomAgent, seed) for seed in SEEDS]
    space = gym.make(ENV_ID).action_space
    for episode in ours:
        assert episode.steps == 500 and episode.truncated
        assert_valid_actions(episode, space)
    known = {e.seed: e.landmarks_known for e in ours}
    assert all(k >= math.ceil(0.9 * N_LANDMARKS) for k in known.values()), known
    ours_known = np.mean([e.landmarks_known for e in ours])
    random_known = np.mean([e.landmarks_known for e in baseline])
    ours_entropy = np.mean([e.entropy for e in ours])
    random_entropy = np.mean([e.entropy for e in baseline])
    assert ours_known > random_known, (ours_known, random_known)
    assert ours_entropy < random_entropy, (ours_entropy, random_entropy)


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
    def actions(seed: int) -> np.ndarray:
        env = gym.make(ENV_ID)
        agent = FrontierAgent(env, seed=seed)
        obs, _ = env.reset(seed=5)
        out = []
        for k in range(60):
            action, _ = agent.predict(obs, episode_start=k == 0)
            out.append(action)
            obs, *_ = env.step(action)
        return np.array(out)

    np.testing.assert_array_equal(actions(7), actions(7))


def test_detects_a_new_random_world_without_episode_start():
    env = gym.make(ENV_ID)
    agent = FrontierAgent(env, seed=0)
    obs, _ = env.reset(seed=1)
    for k in range(40):
        action, _ = agent.predict(obs, episode_start=k == 0)
        obs, *_ = env.step(action)
    swept_before = agent.memory.coverage.fraction_swept()
    obs, _ = env.reset(seed=2)
    agent.predict(obs)  # no episode_start: the layout object changed
    assert agent.memory.layout is env.unwrapped.raw_env.layout
    assert agent.memory.coverage.fraction_swept() < swept_before


def test_detects_a_reset_of_a_fixed_world_without_episode_start():
    env = gym.make(ENV_ID, preset="open")
    agent = FrontierAgent(env, seed=0)
    obs, _ = env.reset(seed=1)
    for k in range(40):
        action, _ = agent.predict(obs, episode_start=k == 0)
        obs, *_ = env.step(action)
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


def test_runs_in_a_world_with_inner_walls():
    env = gym.make(ENV_ID, preset="rooms", max_episode_steps=200)
    agent = FrontierAgent(env, seed=0)
    obs, info = env.reset(seed=0)
    first = info["landmarks_known"]
    done, k = False, 0
    while not done:
        action, _ = agent.predict(obs, episode_start=k == 0)
        assert env.action_space.contains(action)
        obs, _, terminated, truncated, info = env.step(action)
        done, k = terminated or truncated, k + 1
    assert info["landmarks_known"] > first


def test_rejects_what_it_cannot_drive():
    with pytest.raises(TypeError, match="continuous"):
        FrontierAgent(gym.make(ENV_ID, action_type="discrete"))
    with pytest.raises(TypeError, match="ActiveSLAM"):
        FrontierAgent(gym.make("slam_env/Landmarks-v0"))


def test_rejects_bad_parameters():
    env = gym.make(ENV_ID)
    with pytest.raises(TypeError, match="gain_weigth"):
        FrontierAgent(env, gain_weigth=1.0)
    with pytest.raises(ValueError, match="lookahead"):
        FrontierAgent(env, lookahead=0.0)
    with pytest.raises(ValueError, match="loop_close_done_std"):
        FrontierParams(loop_close_std=0.2, loop_close_done_std=0.3)
