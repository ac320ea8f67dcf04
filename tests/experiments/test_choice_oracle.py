"""experiments/choice_oracle.py, the command behind "what the choices can give"
in docs/goal_policy.md: its report, the choices it weighs and saves, its bases (the
lookahead itself is tests/agents/goals/test_lookahead.py's)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.common.env import make_env
from agents.goals.choice import GoalChoiceAgent
from agents.goals.lookahead import EXPLORING, Label
from agents.rollouts.episodes import run_episode
from agents.rollouts.suite_metrics import suite_metrics
from experiments.choice_oracle import RULE, lookahead_agent, main, report, save_labels

SMALL = {"width": 8.0, "height": 8.0, "n_landmarks": 10, "n_obstacles": 2}


def small_env():
    return make_env(SMALL, 250)


def test_the_command_prints_both_agents_and_their_difference(capsys):
    main(["--setting", "arena_8m", "--episodes", "1", "--world", "belief", "--samples", "1"])
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(" | ")[0] for line in lines[2:]] == [
        "| frontier",
        "| lookahead (belief)",
        "| lookahead − frontier",
    ]
    assert math.isfinite(float(lines[3].split(" | ")[1]))


def test_the_report_pairs_the_episodes():
    frontier = [
        {"steps_to_90": s, "final_entropy": -1.0, "collisions_per_100": 0.0, "mapped_share": 1.0}
        for s in (10, 20)
    ]
    ahead = [
        {"steps_to_90": s, "final_entropy": -1.0, "collisions_per_100": 1.0, "mapped_share": m}
        for s, m in ((7, 1.0), (19, 0.9))
    ]
    lines = report({"frontier": frontier, "lookahead (belief)": ahead}).splitlines()
    assert lines[:2] == [
        "| agent | steps_to_90 | final_entropy | collisions_per_100 | mapped_share |",
        "|---|---|---|---|---|",
    ]
    assert lines[2] == "| frontier | 15.00 | -1.00 | 0.00 | 1.00 |"
    assert lines[3] == "| lookahead (belief) | 13.00 | -1.00 | 1.00 | 0.95 |"
    # Differences −3 and −1: mean −2, standard error 1; both seeds lower.
    assert lines[4].split(" | ")[1] == "-2.00 ± 1.00 (2 lower)"
    assert lines[4].split(" | ")[3] == "+1.00 ± 0.00 (0 lower)"
    assert lines[4].split(" | ")[4] == "-0.05 ± 0.05 (1 lower) |"


def test_a_weighed_choice_costs_the_steps_from_it_in_hindsight():
    env = small_env()
    rule_run = suite_metrics(run_episode(env, GoalChoiceAgent(env, RULE, seed=3), 3))
    agent = lookahead_agent(env, "hindsight", 1, 3)
    run_episode(env, agent, 3)
    first = agent._policy.labels[0]
    env.close()
    assert first.costs.shape == (1, len(EXPLORING))
    # The episode's first choice is at its first step; the rule's own choice there,
    # followed by the rule, is the rule's episode.
    assert first.costs[0, EXPLORING.index(first.own)] + 1 == rule_run["steps_to_90"]


def test_the_command_saves_the_weighed_choices(tmp_path, capsys):
    path = tmp_path / "labels.npz"
    main(["--setting", "arena_8m", "--episodes", "2", "--world", "belief", "--samples", "2",
          "--labels", str(path)])  # fmt: skip
    saved = int(capsys.readouterr().out.splitlines()[-1].split()[0])
    with np.load(path) as data:
        assert saved == len(data["own"]) > 0
        assert data["features"].shape == (saved, 32)
        assert data["costs"].shape == (saved, 2, len(EXPLORING))
        assert (data["costs"] >= 0).all()  # steps after the choice's own
        assert set(data["own"].tolist()) <= set(EXPLORING)  # the rule explores at 0
        assert set(data["seed"].tolist()) <= {10_000, 10_001}
        assert data["choices"].tolist() == list(EXPLORING)


def test_no_weighed_choices_save_empty_arrays(tmp_path):
    path = tmp_path / "none.npz"
    assert save_labels(path, {}) == 0
    label = Label(np.zeros(32, np.float32), np.ones((3, len(EXPLORING))), EXPLORING[0])
    assert save_labels(tmp_path / "one.npz", {7: [label]}) == 1
    with np.load(path) as empty, np.load(tmp_path / "one.npz") as one:
        assert empty["features"].shape == (0, 32) and empty["costs"].shape[0] == 0
        assert one["costs"].shape == (1, 3, len(EXPLORING)) and one["seed"].tolist() == [7]


def test_the_shipped_policy_can_be_the_base():
    env = small_env()
    agent = lookahead_agent(env, "belief", 1, 4, base="goals")
    record = run_episode(env, agent, 4)
    env.close()
    assert record.landmarks_known[-1] > 0
    assert agent._policy.labels  # it weighed choices over the policy's own


@pytest.mark.parametrize("base", ["frontier", "goals:/no/such/policy.zip"])
def test_a_base_that_is_not_a_goal_policy_is_a_usage_error(base, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--episodes", "1", "--base", base])
    assert exc.value.code == 2
    assert "argument --base" in capsys.readouterr().err


def test_the_command_names_the_endgame_and_refuses_a_negative_one(capsys):
    main(["--setting", "arena_8m", "--episodes", "1", "--world", "belief", "--samples", "1",
          "--endgame", "1"])  # fmt: skip
    assert "| lookahead (belief, endgame 1) |" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["--endgame", "-1"])
    assert exc.value.code == 2
