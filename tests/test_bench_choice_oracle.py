"""benchmarks/bench_choice_oracle.py, the command behind "what the choices can give"
in docs/goal_policy.md: a try in hindsight predicts its episode exactly, so the hindsight
lookahead is never behind the rule it tries against; a redrawn world moves only the
landmarks not yet mapped, into the unswept free area, and keeps the robot."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from agents.evaluation import run_episode
from agents.goal_choice import GoalChoiceAgent
from agents.registry import make_env
from agents.suite_metrics import landmarks_needed, suite_metrics
from benchmarks.bench_choice_oracle import (
    MAPPED_SHARE,
    RULE,
    lookahead_agent,
    main,
    redraw_unmapped,
    report,
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
    c_env.step(np.zeros(2, np.float32))  # the redrawn world steps
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
        {"steps_to_90": s, "final_entropy": -1.0, "collisions_per_100": 0.0} for s in (10, 20)
    ]
    ahead = [{"steps_to_90": s, "final_entropy": -1.0, "collisions_per_100": 1.0} for s in (7, 19)]
    lines = report({"frontier": frontier, "lookahead (belief)": ahead}).splitlines()
    assert lines[2] == "| frontier | 15.00 | -1.00 | 0.00 |"
    assert lines[3] == "| lookahead (belief) | 13.00 | -1.00 | 1.00 |"
    # Differences −3 and −1: mean −2, standard error 1; both seeds lower.
    assert lines[4].split(" | ")[1] == "-2.00 ± 1.00 (2 lower)"
    assert lines[4].split(" | ")[3] == "+1.00 ± 0.00 (0 lower) |"
