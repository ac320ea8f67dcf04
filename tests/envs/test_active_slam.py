"""slam_env/ActiveSLAM-v0's own choices (issue 17): the proximity sensors it turns on,
its reward weights, and the stack it delegates to."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401
from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.envs.active_slam import DEFAULT_SCAN_BEAMS, ActiveSLAMEnv

ENV_ID = "slam_env/ActiveSLAM-v0"
BELIEF_FEATURES = 7 + 4 * 20  # the egocentric belief of the default 20 landmarks
COVERAGE_FEATURES = 25


@pytest.mark.parametrize(
    ("options", "beams", "bumper"),
    [
        ({}, 16, True),
        ({"scan_beams": 4}, 4, True),
        ({"scan_beams": 0, "bumper": False}, 0, False),
        ({"sensor": {"scan_beams": 3, "bumper": False}}, 3, False),
    ],
)
def test_a_scan_of_sixteen_beams_and_the_bumper_unless_the_options_say_otherwise(
    options, beams, bumper
):
    assert DEFAULT_SCAN_BEAMS == 16
    env = ActiveSLAMEnv(**options)
    sensor = env.config.sensor
    assert (sensor.scan_beams, sensor.bumper) == (beams, bumper)
    size = BELIEF_FEATURES + beams + int(bumper) + COVERAGE_FEATURES
    assert env.observation_space.shape == (size,)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (size,)


def test_reward_weights_as_a_dict_or_dataclass():
    from_dict = ActiveSLAMEnv(reward_weights={"coverage": 20.0, "step": 0.5})
    weights = from_dict.reward_weights
    assert weights == ActiveSLAMRewardWeights(coverage=20.0, step=0.5)
    given = ActiveSLAMRewardWeights(collision=2.0)
    assert ActiveSLAMEnv(reward_weights=given).reward_weights is given
    assert ActiveSLAMEnv().reward_weights == ActiveSLAMRewardWeights()


def test_unknown_reward_weights_are_named():
    with pytest.raises(TypeError, match=r"unknown reward_weights \['curiosity', 'zeal'\]"):
        ActiveSLAMEnv(reward_weights={"zeal": 1.0, "step": 0.1, "curiosity": 1.0})


@pytest.mark.parametrize("coverage", [True, False])
def test_the_observation_holds_the_belief_the_sensors_and_the_coverage(coverage):
    env = ActiveSLAMEnv(coverage=coverage)
    size = BELIEF_FEATURES + 17 + COVERAGE_FEATURES * coverage
    assert env.observation_space.shape == (size,)
    with pytest.raises(TypeError, match="coverage must be a bool"):
        ActiveSLAMEnv(coverage=1)


def test_one_random_stream_and_the_same_run_for_the_same_seed():
    a, b = gym.make(ENV_ID), gym.make(ENV_ID)
    a.reset(seed=12)
    b.reset(seed=12)
    assert a.unwrapped.np_random is a.unwrapped._core.rngs[0]  # the one stream it draws from
    for _ in range(30):
        action = np.array([0.7, -0.4], np.float32)
        step_a, step_b = a.step(action), b.step(action)
        np.testing.assert_array_equal(step_a[0], step_b[0])
        assert step_a[1:4] == step_b[1:4]
