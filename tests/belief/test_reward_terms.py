"""The active-SLAM reward, term by term, on constructed steps (issue 17).

A scripted env hands :class:`ActiveSLAMReward` the infos a belief wrapper would (a
known entropy drop, a known newly swept share, a step in contact, a plain step), so
each term's exact value and sign is derived here from the formula of the env's
documentation (docs/envs/active_slam.md, "Reward terms"):

    reward = w_ig·(H_{t−1} − H_t) − w_pose·σ_pose − w_col·[contact] − w_step
             + w_cov·(s_t − s_{t−1})
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from slam_env.belief.reward import REWARD_TERMS, ActiveSLAMRewardWeights
from slam_env.belief.reward_wrapper import ActiveSLAMReward

ENV_PAGE = Path(__file__).resolve().parents[2] / "docs" / "envs" / "active_slam.md"
DEFAULTS = {
    "information_gain": 0.1,
    "pose_uncertainty": 0.1,
    "collision": 1.0,
    "step": 0.01,
    "coverage": 0.0,
}
CUSTOM = {
    "information_gain": 2.0,
    "pose_uncertainty": 0.5,
    "collision": 3.0,
    "step": 0.25,
    "coverage": 20.0,
}


class ScriptedBelief(gym.Env):
    """Returns the given infos in turn (the first from ``reset``), as a belief wrapper
    with a coverage wrapper on top would; its own reward and terms are decoys."""

    observation_space = gym.spaces.Box(0.0, 1.0, (1,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

    def __init__(self, infos: list[dict[str, Any]]) -> None:
        self.infos = infos

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self.t = 0
        return np.zeros(1, np.float32), self._info()

    def step(self, action):
        self.t += 1
        return np.zeros(1, np.float32), 123.0, False, False, self._info()

    def _info(self) -> dict[str, Any]:
        return {"reward_terms": {"new_landmark": 7.0}, **self.infos[self.t]}


def belief_info(entropy: float, pose_std=0.0, collision=False, swept=0.2) -> dict[str, Any]:
    return {
        "entropy": entropy,
        "pose_std": pose_std,
        "collision": collision,
        "swept_fraction": swept,
    }


def run(infos: list[dict[str, Any]], weights: dict[str, float] | None = None):
    """Reset and step through ``infos``; the rewards and reward terms of each step."""
    w = None if weights is None else ActiveSLAMRewardWeights(**weights)
    env = ActiveSLAMReward(ScriptedBelief(infos), w)
    _, info = env.reset(seed=0)
    assert info["reward_terms"] == dict.fromkeys(REWARD_TERMS, 0.0)
    out = []
    for _ in infos[1:]:
        _, reward, _, _, info = env.step(np.zeros(2, np.float32))
        assert type(reward) is float
        assert info["raw_reward_terms"] == {"new_landmark": 7.0}  # moved, not summed
        assert reward == pytest.approx(sum(info["reward_terms"].values()), rel=1e-15, abs=1e-15)
        out.append((reward, info["reward_terms"]))
    return out


def test_default_weights():
    assert {k: getattr(ActiveSLAMRewardWeights(), k) for k in REWARD_TERMS} == DEFAULTS
    assert tuple(DEFAULTS) == REWARD_TERMS


@pytest.mark.parametrize("weights", [None, CUSTOM], ids=["default", "custom"])
def test_each_term_on_constructed_steps(weights):
    w = DEFAULTS if weights is None else CUSTOM
    infos = [
        belief_info(100.0, swept=0.20),  # reset
        belief_info(100.0, swept=0.20),  # a plain step: nothing changes
        belief_info(87.5, swept=0.20),  # a landmark found: 12.5 nats removed
        belief_info(88.0, swept=0.20),  # dead reckoning: 0.5 nats added
        belief_info(88.0, pose_std=0.3, swept=0.20),  # lost by 0.3 m
        belief_info(88.0, collision=True, swept=0.20),  # in contact
        belief_info(88.0, swept=0.25),  # 5% of the arena newly swept
    ]
    steps = run(infos, weights)
    step = -w["step"]
    expected = [
        {"information_gain": 0.0, "pose_uncertainty": 0.0, "collision": 0.0, "coverage": 0.0},
        {"information_gain": 12.5 * w["information_gain"]},
        {"information_gain": -0.5 * w["information_gain"]},
        {"pose_uncertainty": -0.3 * w["pose_uncertainty"]},
        {"collision": -w["collision"]},
        {"coverage": 0.05 * w["coverage"]},
    ]
    for t, ((reward, terms), changed) in enumerate(zip(steps, expected, strict=True)):
        want = {**dict.fromkeys(REWARD_TERMS, 0.0), "step": step, **changed}
        assert terms.keys() == want.keys()
        for name in REWARD_TERMS:
            assert terms[name] == pytest.approx(want[name], rel=1e-12, abs=1e-15), (t, name)
            # The sign too: a gain is paid, a cost charged.
            assert np.sign(terms[name]) == np.sign(want[name]), (t, name)
        assert reward == pytest.approx(sum(want.values()), rel=1e-12)
    # The plain step costs exactly the step weight, nothing else.
    assert steps[0][0] == pytest.approx(-w["step"], rel=1e-15)


def test_information_gain_is_measured_against_the_previous_step():
    infos = [belief_info(50.0), belief_info(40.0), belief_info(45.0), belief_info(45.0)]
    gains = [terms["information_gain"] for _, terms in run(infos, CUSTOM)]
    assert gains == pytest.approx([2.0 * 10.0, 2.0 * -5.0, 0.0], rel=1e-12)


def test_coverage_is_measured_against_the_previous_step():
    infos = [belief_info(1.0, swept=0.1), belief_info(1.0, swept=0.3), belief_info(1.0, swept=0.3)]
    gains = [terms["coverage"] for _, terms in run(infos, CUSTOM)]
    assert gains == pytest.approx([20.0 * 0.2, 0.0], rel=1e-12)


def test_without_a_coverage_wrapper_the_coverage_term_is_zero():
    infos = [{"entropy": 3.0, "pose_std": 0.1, "collision": False}] * 3
    for reward, terms in run(infos):
        assert terms["coverage"] == 0.0
        assert reward == pytest.approx(-0.1 * 0.1 - 0.01, rel=1e-12)


def test_a_coverage_weight_needs_swept_fraction_in_info():
    env = ActiveSLAMReward(
        ScriptedBelief([{"entropy": 3.0, "pose_std": 0.1, "collision": False}]),
        ActiveSLAMRewardWeights(coverage=1.0),
    )
    with pytest.raises(TypeError, match="CoverageWrapper"):
        env.reset(seed=0)
    with pytest.raises(TypeError, match="EKFSLAMWrapper"):
        ActiveSLAMReward(ScriptedBelief([{"pose_std": 0.0}])).reset(seed=0)


@pytest.mark.parametrize("name", REWARD_TERMS)
@pytest.mark.parametrize("value", [-0.1, math.nan, math.inf, True, "1"])
def test_bad_weights_raise(name, value):
    with pytest.raises((TypeError, ValueError), match=name):
        ActiveSLAMRewardWeights(**{name: value})


def test_zero_weights_are_accepted_and_silence_their_terms():
    zero = dict.fromkeys(REWARD_TERMS, 0.0)
    infos = [belief_info(10.0), belief_info(5.0, pose_std=1.0, collision=True, swept=0.9)]
    ((reward, terms),) = run(infos, zero)
    assert reward == 0.0 and all(v == 0.0 for v in terms.values())
    with pytest.raises(TypeError, match="ActiveSLAMRewardWeights"):
        ActiveSLAMReward(ScriptedBelief(infos), weights=zero)  # a dict is not weights


def _documented_reward_table() -> dict[str, tuple[str, str]]:
    """The env page's reward table: term -> (default weight, value)."""
    text = ENV_PAGE.read_text()
    start = text.index("\n## Rewards\n")
    section = text[start : text.index("\n## ", start + 1)]
    rows = re.findall(r"^\| `(\w+)` \| ([^|]+) \| ([^|]+) \|", section, flags=re.M)
    return {name: (weight.strip(), value.strip()) for name, weight, value in rows}


def test_the_docs_state_the_formula_and_default_weights_the_tests_check():
    table = _documented_reward_table()
    assert list(table) == list(REWARD_TERMS)
    for name, (weight, _) in table.items():
        assert float(weight) == DEFAULTS[name], name
    values = {name: value for name, (_, value) in table.items()}
    assert values == {
        "information_gain": "w × (H₍t−1₎ − H_t)",
        "pose_uncertainty": "−w × σ_pose",
        "collision": "−w on a step in contact",
        "step": "−w",
        "coverage": "w × (s_t − s₍t−1₎)",
    }
    text = ENV_PAGE.read_text()
    assert "reward = Σ of the terms" in text
