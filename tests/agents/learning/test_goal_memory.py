"""A goal-choosing policy with memory (``memory:`` in a goal-training config): the
checks of its keys, the stack of features and the LSTM state the loaded agent keeps,
and training and running a policy of each kind."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from agents.common.env import make_env
from agents.evaluation.suite import suite_settings
from agents.goals.choice import N_FEATURES, GoalChoiceAgent
from agents.learning.config import (
    MAX_MEMORY_FRAMES,
    MAX_MEMORY_UNITS,
    ConfigError,
    config_from_dict,
)
from agents.learning.sb3.goal_training import PolicyChooser, load_goal_agent
from agents.learning.sb3.training import train
from agents.registry import make_agent
from tests.agents.goals.test_choice import run, tiny_goal_config

GOALS = {"decisions": "goals", "vectorization": "dummy"}


def test_memory_keys_are_checked():
    assert config_from_dict(GOALS).memory == "features"
    for kind in ("frame_stack", "recurrent"):
        assert config_from_dict({**GOALS, "memory": kind}).memory == kind
    with pytest.raises(ConfigError, match="'memory' must be one of"):
        config_from_dict({**GOALS, "memory": "lstm"})
    with pytest.raises(ConfigError, match="'features' unless decisions is goals"):
        config_from_dict({"memory": "frame_stack"})  # a policy acting every step: no such key
    for name, top in (("memory_frames", MAX_MEMORY_FRAMES), ("memory_units", MAX_MEMORY_UNITS)):
        assert getattr(config_from_dict({**GOALS, name: top}), name) == top
        for bad in (0, top + 1, 10**9, 2.0, True, "4", None):
            with pytest.raises(ConfigError, match=rf"'{name}' must be an int in \[1, {top}\]"):
                config_from_dict({**GOALS, name: bad})


class FakeModel:
    """Answers choice 1 and a new state each call; keeps what ``predict`` was given."""

    def __init__(self) -> None:
        self.calls: list[tuple[np.ndarray, object, bool]] = []

    def predict(self, obs, state=None, episode_start=None, deterministic=False):
        assert deterministic and obs.shape[0] == 1 and episode_start.shape == (1,)
        self.calls.append((obs[0].copy(), state, bool(episode_start[0])))
        return np.array([1]), len(self.calls)


def features(value: float) -> np.ndarray:
    return np.full(N_FEATURES, value, dtype=np.float32)


def test_the_chooser_stacks_features_as_vec_frame_stack_and_starts_afresh_on_reset():
    model = FakeModel()
    chooser = PolicyChooser(model, frames=3)
    assert [chooser(features(v)) for v in (1.0, 2.0, 3.0, 4.0)] == [1, 1, 1, 1]
    zero = np.zeros(N_FEATURES, dtype=np.float32)
    expected = [
        (zero, zero, features(1)),  # oldest first, zeros before the episode's first choice
        (zero, features(1), features(2)),
        (features(1), features(2), features(3)),
        (features(2), features(3), features(4)),
    ]
    for (obs, _, _), frames in zip(model.calls, expected, strict=True):
        np.testing.assert_array_equal(obs, np.concatenate(frames))
    # The state goes back to the model, and the episode start is said once.
    assert [(state, start) for _, state, start in model.calls] == [
        (None, True),
        (1, False),
        (2, False),
        (3, False),
    ]
    chooser.reset()
    chooser(features(5.0))
    obs, state, start = model.calls[-1]
    np.testing.assert_array_equal(obs, np.concatenate([zero, zero, features(5)]))
    assert state is None and start


class CountingPolicy:
    def __init__(self) -> None:
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1

    def __call__(self, features: np.ndarray) -> int:
        return 0


def test_the_agent_resets_a_policy_with_memory_at_each_episode():
    env = make_env({}, 12)
    policy = CountingPolicy()
    agent = GoalChoiceAgent(env, policy, seed=0)
    before = policy.resets
    for seed in (0, 1):
        run(agent, env, seed=seed, steps=12)
    assert policy.resets == before + 2
    env.close()


@pytest.mark.parametrize(
    ("memory", "frames"), [("frame_stack", 3), ("recurrent", 1)], ids=["frame_stack", "recurrent"]
)
def test_a_policy_with_memory_trains_loads_and_runs_on_every_setting_of_the_suite(
    tmp_path, memory, frames
):
    from sb3_contrib import RecurrentPPO

    config = tiny_goal_config(
        tmp_path, memory=memory, memory_frames=3, memory_units=8, eval_freq=32, eval_episodes=1
    )
    path = train(config)
    env = make_env({}, 12)
    agent = load_goal_agent(path, env, seed=0)
    chooser = agent._policy
    assert isinstance(chooser._model, RecurrentPPO) == (memory == "recurrent")
    assert chooser._model.observation_space.shape == (frames * N_FEATURES,)
    if memory == "recurrent":
        assert chooser._model.policy.lstm_actor.hidden_size == 8
    env.close()
    for setting in suite_settings("default"):
        env = make_env(setting.env_options, 12)
        actions = run(make_agent(f"goals:{path}", env, seed=0), env, seed=0, steps=12)
        assert len(actions) == 12 and all(env.action_space.contains(a) for a in actions)
        env.close()


def test_without_sb3_contrib_a_recurrent_policy_is_refused_with_what_to_install(
    tmp_path, monkeypatch
):
    path = train(tiny_goal_config(tmp_path, memory="recurrent", memory_units=4))
    for name in [m for m in sys.modules if m == "sb3_contrib" or m.startswith("sb3_contrib.")]:
        monkeypatch.setitem(sys.modules, name, None)  # as if not installed
    install = r"\(pip install 'slam_env\[recurrent\]'\)"
    with pytest.raises(ConfigError, match=rf"'recurrent' needs sb3-contrib {install}"):
        config_from_dict({**GOALS, "memory": "recurrent"})
    env = make_env({}, 12)
    with pytest.raises(ValueError, match=r"needs the module 'sb3_contrib.*slam_env\[recurrent\]"):
        load_goal_agent(path, env)
    env.close()
