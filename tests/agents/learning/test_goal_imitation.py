"""A teacher first: the loop-closing rule, its demonstrations, fitting a policy to them
and a goal training that starts from them (``imitation_choices:``)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from stable_baselines3 import PPO
from stable_baselines3.common.policies import ActorCriticPolicy

from agents.common.env import make_env
from agents.goals.choice import (
    CHOICES,
    MODE_FEATURES,
    N_FEATURES,
    POSE_SIGMA_FEATURE,
    GoalChoiceAgent,
    choice_space,
    feature_space,
)
from agents.learning.config import ConfigError, config_from_dict
from agents.learning.goal_imitation import Demonstrations, LoopClosingRule, demonstrate, fit_policy
from agents.learning.sb3.training import train
from agents.planners.frontier import EXPLORE, LOCALISE, REFINE
from tests.agents.goals.test_choice import tiny_goal_config

EXPLORE_CHOICE, LOCALISE_CHOICE = 0, 3


def features(sigma: float, mode: str = EXPLORE) -> np.ndarray:
    """Choice features with the pose σ (m) and the planner's mode set, the rest zero."""
    x = np.zeros(N_FEATURES, dtype=np.float32)
    x[POSE_SIGMA_FEATURE] = sigma / 0.4  # in units of the frontier agent's threshold
    x[MODE_FEATURES[mode]] = 1.0
    return x


def test_the_rule_closes_a_loop_past_its_threshold_and_until_the_pose_is_known():
    assert (CHOICES[EXPLORE_CHOICE].name, CHOICES[LOCALISE_CHOICE].mode) == ("explore", LOCALISE)
    rule = LoopClosingRule(close_at=0.6, closed_at=0.2)
    assert rule(features(0.5)) == EXPLORE_CHOICE  # the frontier agent would close at 0.4
    assert rule(features(0.65)) == LOCALISE_CHOICE
    assert rule(features(0.65, REFINE)) == LOCALISE_CHOICE
    assert rule(features(0.3, LOCALISE)) == LOCALISE_CHOICE  # held while closing
    assert rule(features(0.2, LOCALISE)) == LOCALISE_CHOICE  # until below, as frontier's
    assert rule(features(0.15, LOCALISE)) == EXPLORE_CHOICE  # closed
    assert rule(features(0.3, REFINE)) == EXPLORE_CHOICE
    assert LoopClosingRule(close_at=0.3)(features(0.35)) == LOCALISE_CHOICE
    assert LoopClosingRule(close_at=0.4)(features(0.4)) == EXPLORE_CHOICE  # past it, as frontier


@pytest.mark.parametrize(("close_at", "closed_at"), [(0.2, 0.3), (0.5, 0.0), (np.inf, 0.2)])
def test_a_rule_that_cannot_close_loops_is_refused(close_at, closed_at):
    with pytest.raises(ValueError, match="closed_at <= close_at"):
        LoopClosingRule(close_at=close_at, closed_at=closed_at)


def test_the_rule_reads_the_pose_and_the_mode_from_the_agents_features():
    seen = []

    def rule_and_truth(x: np.ndarray) -> int:
        seen.append((x, agent._sigma(), agent.mode))
        return LoopClosingRule(close_at=0.1, closed_at=0.05)(x)  # closes loops early

    env = make_env({}, 200)
    agent = GoalChoiceAgent(env, rule_and_truth, seed=0)
    obs, _ = env.reset(seed=1)
    for _ in range(200):
        obs, *_ = env.step(agent.predict(obs)[0])
    assert len(seen) > 10
    for x, sigma, mode in seen:
        assert x[POSE_SIGMA_FEATURE] * 0.4 == pytest.approx(sigma, rel=1e-5, abs=1e-6)
        assert x[MODE_FEATURES[mode]] == 1.0
    assert LOCALISE in {mode for *_, mode in seen}  # the rule's loop closures were taken


class ScriptedVecEnv:
    """An SB3-style vector env of one sub-env whose rewards and ends are given."""

    num_envs = 1

    def __init__(self, rewards: list[float], dones: list[bool]) -> None:
        self.rewards, self.dones, self.t = rewards, dones, 0

    def reset(self) -> np.ndarray:
        return np.full((1, N_FEATURES), -1.0, dtype=np.float32)

    def step(self, action: np.ndarray):
        t, self.t = self.t, self.t + 1
        obs = np.full((1, N_FEATURES), float(t), dtype=np.float32)
        return obs, np.array([self.rewards[t]]), np.array([self.dones[t]]), [{}]


def test_demonstrations_hold_the_teachers_choices_and_their_discounted_returns():
    venv = ScriptedVecEnv([1.0, 2.0, 4.0, 8.0, 16.0], [False, True, False, False, False])
    teacher_saw = []

    def teacher(x: np.ndarray) -> int:
        teacher_saw.append(float(x[0]))
        return len(teacher_saw) % len(CHOICES)

    demos = demonstrate(venv, teacher, choices=4, gamma=0.5)
    assert teacher_saw == [-1.0, 0.0, 1.0, 2.0]  # what each choice was made on
    np.testing.assert_array_equal(demos.features[:, 0], teacher_saw)
    np.testing.assert_array_equal(demos.choices, [1, 2, 3, 4])
    # The first episode ends at the second choice; the second is cut off by the run.
    np.testing.assert_allclose(demos.returns, [1 + 0.5 * 2, 2, 4 + 0.5 * 8, 8])
    np.testing.assert_array_equal(demos.complete, [True, True, False, False])
    assert demos.features.dtype == np.float32 and demos.features.shape == (4, N_FEATURES)


def test_a_policy_fitted_to_demonstrations_makes_their_choices_and_learns_their_values():
    rng = np.random.default_rng(0)
    sigma = rng.uniform(0.0, 1.0, 2000)
    localising = rng.random(2000) < 0.5
    x = np.stack(
        [features(s, LOCALISE if c else EXPLORE) for s, c in zip(sigma, localising, strict=True)]
    )
    rule = LoopClosingRule()
    choices = np.array([rule(row) for row in x])
    returns = (3.0 * sigma).astype(np.float32)
    complete = rng.random(2000) < 0.8
    demos = Demonstrations(x, choices, returns, complete)

    def make_policy() -> ActorCriticPolicy:
        return ActorCriticPolicy(feature_space(), choice_space(), lambda _: 3e-3, net_arch=[32])

    import torch

    torch.manual_seed(0)
    policy = make_policy()
    before = fit_policy(policy, demos, 0, vf_coef=0.5, max_grad_norm=0.5, seed=0)
    accuracy = fit_policy(policy, demos, 30, vf_coef=0.5, max_grad_norm=0.5, seed=0)
    assert accuracy > 0.97 and accuracy > before
    with torch.no_grad():
        values = policy.predict_values(torch.as_tensor(x)).numpy().ravel()
    assert np.abs(values - returns)[complete].mean() < 0.2
    torch.manual_seed(0)
    again = make_policy()
    assert fit_policy(again, demos, 30, vf_coef=0.5, max_grad_norm=0.5, seed=0) == accuracy
    for a, b in zip(policy.parameters(), again.parameters(), strict=True):
        torch.testing.assert_close(a, b, rtol=0, atol=0)  # the same seed, the same fit
    # Every demonstration is fitted, down to a single one.
    fresh = make_policy()
    with torch.no_grad():
        untrained = int(fresh.get_distribution(torch.as_tensor(x[:1])).mode()[0])
    one = Demonstrations(
        x[:1], np.array([(untrained + 1) % len(CHOICES)]), returns[:1], complete[:1]
    )
    assert fit_policy(fresh, one, 20, vf_coef=0.5, max_grad_norm=0.5, seed=0) == 1.0


def trained_weights(out_dir, **overrides) -> tuple[list[np.ndarray], dict]:
    path = train(tiny_goal_config(out_dir, seed=2, **overrides))
    summary = json.loads((out_dir / "training_summary.json").read_text())
    weights = [t.detach().numpy() for t in PPO.load(path, device="cpu").policy.parameters()]
    return weights, summary


def test_goal_training_starts_from_the_teachers_choices(tmp_path):
    teacher = {"imitation_choices": 96, "imitation_epochs": 3}
    first, summary = trained_weights(tmp_path / "a", **teacher)
    again, _ = trained_weights(tmp_path / "b", **teacher)
    plain, plain_summary = trained_weights(tmp_path / "c")
    imitation = summary["imitation"]
    assert imitation["teacher"] == "LoopClosingRule" and imitation["epochs"] == 3
    assert imitation["choices"] == 96 and 0.0 <= imitation["accuracy"] <= 1.0
    assert 0.0 < imitation["wall_time_s"] < summary["wall_time_s"] + 600
    assert summary["env_step_s"] <= summary["wall_time_s"]  # PPO's stepping, not the teacher's
    assert summary["choices"] == plain_summary["choices"]  # PPO's, beside the teacher's
    assert plain_summary["imitation"] is None
    for a, b in zip(first, again, strict=True):
        np.testing.assert_array_equal(a, b)  # reproducible from its seed
    assert any(not np.array_equal(a, b) for a, b in zip(first, plain, strict=True))


def test_the_imitation_keys_are_checked():
    goals = tiny_goal_config("unused")
    cfg = config_from_dict({**goals, "imitation_choices": 500, "imitation_epochs": 4})
    assert (cfg.imitation_choices, cfg.imitation_epochs) == (500, 4)
    assert config_from_dict(goals).imitation_choices == 0
    for bad in (-1, 1.5, True, "10", 10**7):
        with pytest.raises(ConfigError, match=r"'imitation_choices' must be an int in \[0,"):
            config_from_dict({**goals, "imitation_choices": bad})
    for bad in (0, 2.0, None, 10**4):
        with pytest.raises(ConfigError, match=r"'imitation_epochs' must be an int in \[1,"):
            config_from_dict({**goals, "imitation_epochs": bad})
    for other in ({"decisions": "actions", "vectorization": "native"}, {"memory": "frame_stack"}):
        with pytest.raises(ConfigError, match="0 unless decisions is goals and memory is"):
            config_from_dict({**goals, **other, "imitation_choices": 10})
