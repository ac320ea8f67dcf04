"""benchmarks/bench_choice_oracle.py, the command behind "what the choices can give"
in docs/goal_policy.md: a try in hindsight predicts its episode exactly, so the hindsight
lookahead is never behind the rule it tries against; a redrawn world moves only the
landmarks not yet mapped, into the unswept free area, and keeps the robot; the endgame
takes the choice whose tries end least uncertain."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from agents.evaluation import run_episode
from agents.goal_choice import GoalChoiceAgent
from agents.registry import make_env
from agents.suite_metrics import landmarks_needed, suite_metrics
from benchmarks import bench_choice_oracle
from benchmarks.bench_choice_oracle import (
    ENDGAME,
    EXPLORING,
    MAPPED_SHARE,
    RULE,
    Label,
    Lookahead,
    final_entropy,
    lookahead_agent,
    main,
    play_on,
    redraw_unmapped,
    report,
    save_labels,
    steps_to_mapped,
)

SMALL = {"width": 8.0, "height": 8.0, "n_landmarks": 10, "n_obstacles": 2}


def small_env():
    return make_env(SMALL, 250)


@pytest.mark.parametrize("seed", [3, 4])
def test_a_try_in_hindsight_is_the_episode_that_follows(seed):
    env = small_env()
    rule_run = suite_metrics(run_episode(env, GoalChoiceAgent(env, RULE, seed=seed), seed))
    env.reset(seed=seed)
    agent = GoalChoiceAgent(env, RULE, seed=seed)
    agent.reset()
    assert agent.begin_step() is None  # the episode's first step is a choice
    need = landmarks_needed(env.unwrapped.n_landmarks, MAPPED_SHARE)
    tried = steps_to_mapped(*copy.deepcopy((env, agent)), RULE(agent.features()), RULE, need)
    assert tried == rule_run["steps_to_90"]
    env.close()


@pytest.mark.parametrize("seed", [3, 4])
def test_the_hindsight_lookahead_is_never_behind_its_rule(seed):
    env = small_env()
    rule_run = suite_metrics(run_episode(env, GoalChoiceAgent(env, RULE, seed=seed), seed))
    look = suite_metrics(run_episode(env, lookahead_agent(env, "hindsight", 1, seed), seed))
    env.close()
    assert look["steps_to_90"] <= rule_run["steps_to_90"]


def test_a_redrawn_world_moves_only_the_unmapped_landmarks():
    env = small_env()
    env.reset(seed=5)
    agent = GoalChoiceAgent(env, RULE, seed=5)
    for step in range(40):  # map a few landmarks first
        env.step(agent.predict(None, episode_start=step == 0)[0])
    base = env.unwrapped
    mapped = set(base.filter.belief_views()[2].tolist())
    assert 0 < len(mapped) < base.n_landmarks
    before = np.array(base.layout.landmark_positions)
    pose = base.world.pose
    copies = [copy.deepcopy((env, agent)) for _ in range(2)]
    for c_env, c_agent in copies:
        redraw_unmapped(c_env, c_agent, np.random.default_rng(7))
    (c_env, c_agent), (d_env, _) = copies
    world = c_env.unwrapped.world
    after = np.array(world.layout.landmark_positions)
    np.testing.assert_array_equal(after, np.array(d_env.unwrapped.layout.landmark_positions))
    np.testing.assert_array_equal(c_env.unwrapped._core.worlds.landmarks[0], after)
    assert world.pose == pose
    memory = c_agent._memory
    unswept = memory.on_planning_grid(c_agent._unswept())
    spacing = base.config.world.landmark_spacing
    for i, lid in enumerate(base.layout.landmark_ids):
        if lid in mapped:
            np.testing.assert_array_equal(after[i], before[i])
            continue
        assert not np.array_equal(after[i], before[i])
        assert unswept[memory.grid.cell_of(*after[i])]
        others = np.delete(after, i, axis=0)
        assert np.hypot(*(others - after[i]).T).min() >= spacing - 1e-9
    # The redrawn world steps, on noise of its own: not the episode's noise to come.
    for e in (c_env, env):
        e.step(np.zeros(2, np.float32))
    noise = [e.unwrapped._core.blocks.uniforms[0] for e in (c_env, env)]
    assert not np.array_equal(*noise)
    env.close()


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


def at_the_endgame(seed):
    """An env and a rule-driven agent at their first choice once 90% are mapped."""
    env = small_env()
    env.reset(seed=seed)
    agent = GoalChoiceAgent(env, RULE, seed=seed)
    agent.reset()
    need = landmarks_needed(env.unwrapped.n_landmarks, MAPPED_SHARE)
    while True:
        action = agent.begin_step()
        if action is None:
            if env.unwrapped.filter.n_landmarks >= need:
                return env, agent
            action = agent.finish_step(RULE(agent.features()))
        env.step(action)


@pytest.mark.parametrize("choice", ENDGAME)
def test_an_endgame_try_in_hindsight_ends_as_the_episode_that_follows(choice):
    env, agent = at_the_endgame(3)
    tried = final_entropy(*copy.deepcopy((env, agent)), choice, RULE)
    steps = [info for _, info in play_on(env, agent, choice, RULE)]
    assert steps[-1]["entropy"] == tried
    assert agent._steps == env.spec.max_episode_steps
    env.close()


def test_the_endgame_takes_the_choice_that_ends_with_the_least_entropy(monkeypatch):
    env, agent = at_the_endgame(4)
    policy = Lookahead(env, "belief", 1, 0, endgame=2)
    policy.attach(agent)
    features = agent.features()
    own = RULE(features)
    values = dict(zip(ENDGAME, (-1.0, -5.0, -3.0), strict=True))
    tried = []

    def fake(env, agent, choice, base):
        tried.append(choice)
        return values[choice]

    monkeypatch.setattr(bench_choice_oracle, "final_entropy", fake)
    assert policy(features) == ENDGAME[1]
    assert tried == list(ENDGAME) * 2  # each choice in each of the 2 worlds
    assert agent.hold_goals  # the endgame's choices hold
    values = dict.fromkeys(ENDGAME, -2.0)
    assert policy(features) == own  # a tie keeps the base's own
    policy.endgame = 0
    tried.clear()
    assert policy(features) == own and not tried  # off: the base chooses
    policy.reset()
    assert not agent.hold_goals  # a new episode: the agent's own again
    env.close()


def test_the_command_names_the_endgame_and_refuses_a_negative_one(capsys):
    main(["--setting", "arena_8m", "--episodes", "1", "--world", "belief", "--samples", "1",
          "--endgame", "1"])  # fmt: skip
    assert "| lookahead (belief, endgame 1) |" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["--endgame", "-1"])
    assert exc.value.code == 2
