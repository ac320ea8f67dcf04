"""agents/goals/lookahead.py: a try in hindsight is the episode that follows, a drawn world
is a draw from the belief (the robot and the mapped landmarks from the filter's
Gaussian, the rest over the unswept area) with noise of its own, tries stop at their
horizon, the endgame takes the least final entropy, and the ``lookahead`` agent is
reproducible and runs on every setting of the suite."""

from __future__ import annotations

import copy
import dataclasses
import pickle

import numpy as np
import pytest
from scipy import stats

from agents.common.env import make_env
from agents.evaluation.suite import suite_settings
from agents.goals import lookahead
from agents.goals.choice import GoalChoiceAgent
from agents.goals.lookahead import (
    DRAWS,
    ENDGAME,
    EXPLORING,
    MAPPED_SHARE,
    Lookahead,
    draw_belief_world,
    final_entropy,
    play_on,
    steps_to_mapped,
    with_lookahead,
)
from agents.learning.goal_imitation import LoopClosingRule
from agents.registry import agent_label, make_agent
from agents.rollouts.episodes import run_episode
from agents.rollouts.suite_metrics import landmarks_needed, suite_metrics

SMALL = {"width": 8.0, "height": 8.0, "n_landmarks": 10, "n_obstacles": 2}
RULE = LoopClosingRule(close_at=0.4, closed_at=0.2)


def small_env():
    return make_env(SMALL, 250)


def at_first_choice(seed):
    env = small_env()
    env.reset(seed=seed)
    agent = GoalChoiceAgent(env, RULE, seed=seed)
    agent.reset()
    assert agent.begin_step() is None  # the episode's first step is a choice
    return env, agent


def mapped_a_few(seed=5, steps=40):
    """An env and a rule-driven agent after ``steps`` steps, some landmarks mapped."""
    env = small_env()
    env.reset(seed=seed)
    agent = GoalChoiceAgent(env, RULE, seed=seed)
    for step in range(steps):
        env.step(agent.predict(None, episode_start=step == 0)[0])
    mapped = env.unwrapped.filter.belief_views()[2]
    assert 0 < len(mapped) < env.unwrapped.n_landmarks
    return env, agent


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


def first_steps(env, agent, choice, steps):
    """The infos of the first ``steps`` steps of :func:`play_on` with the rule."""
    infos = []
    for _, info in play_on(env, agent, choice, RULE):
        infos.append(info)
        if len(infos) == steps:
            return infos
    raise AssertionError("the episode ended first")


@pytest.mark.parametrize("seed", [3, 4])
def test_a_try_in_hindsight_is_the_episode_that_follows(seed):
    env = small_env()
    rule_run = suite_metrics(run_episode(env, GoalChoiceAgent(env, RULE, seed=seed), seed))
    env, agent = at_first_choice(seed)
    need = landmarks_needed(env.unwrapped.n_landmarks, MAPPED_SHARE)
    tried = steps_to_mapped(*copy.deepcopy((env, agent)), RULE(agent.features()), RULE, need)
    assert tried == rule_run["steps_to_90"]


@pytest.mark.parametrize("seed", [3, 4])
def test_the_hindsight_lookahead_is_never_behind_its_rule(seed):
    env = small_env()
    rule_run = suite_metrics(run_episode(env, GoalChoiceAgent(env, RULE, seed=seed), seed))
    agent = with_lookahead(GoalChoiceAgent(env, RULE, seed=seed), env, seed, world="hindsight")
    look = suite_metrics(run_episode(env, agent, seed))
    assert look["steps_to_90"] <= rule_run["steps_to_90"]


def test_a_try_stops_at_its_horizon_and_counts_the_rest_at_its_rate():
    env, agent = at_first_choice(3)
    need = landmarks_needed(env.unwrapped.n_landmarks, MAPPED_SHARE)
    choice = RULE(agent.features())
    game = copy.deepcopy((env, agent))
    tried = steps_to_mapped(*game, choice, RULE, need, horizon=12)
    twin_env, twin = copy.deepcopy((env, agent))
    infos = first_steps(twin_env, twin, choice, 12)
    mapped = twin_env.unwrapped.filter.n_landmarks
    assert mapped < need and twin._steps == 12  # the episode's steps
    gained = mapped - env.unwrapped.filter.n_landmarks
    assert tried == 12 + (need - mapped) * 12 / max(gained, 1)
    # An entropy try stops there too: the entropy after its 12th step.
    assert final_entropy(*copy.deepcopy((env, agent)), choice, RULE, 12) == infos[-1]["entropy"]


def test_a_drawn_world_is_a_draw_from_the_belief():
    env, agent = mapped_a_few()
    base = env.unwrapped
    mean, cov, slot_ids = (v.copy() for v in base.filter.belief_views())
    truth = base.world.pose
    true_positions = np.array(base.layout.landmark_positions)
    world_env, world_agent = copy.deepcopy((env, agent))
    rng = np.random.default_rng(0)
    states = []
    for _ in range(300):
        assert draw_belief_world(world_env, world_agent, rng)
        layout = world_env.unwrapped.layout
        where = dict(zip(layout.landmark_ids, layout.landmark_positions, strict=True))
        marks = [where[int(lid)] for lid in slot_ids]
        states.append(np.concatenate([world_env.unwrapped.world.pose, np.ravel(marks)]))
    states = np.array(states)
    # Heading wrapped like the mean's; the draws' mean and spread are the belief's.
    d = states - mean
    d[:, 2] = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
    nees = np.einsum("ij,ij->i", d @ np.linalg.pinv(cov), d)
    lo, hi = stats.chi2.ppf([0.005, 0.995], 300 * len(mean)) / 300
    assert lo < nees.mean() < hi
    # The original env keeps its true world and belief.
    assert base.world.pose == truth
    np.testing.assert_array_equal(base.layout.landmark_positions, true_positions)
    np.testing.assert_array_equal(base.filter.mean, mean)


def test_a_drawn_world_puts_the_unmapped_landmarks_in_the_unswept_area_with_new_noise():
    env, agent = mapped_a_few()
    base = env.unwrapped
    mapped = set(base.filter.belief_views()[2].tolist())
    before = np.array(base.layout.landmark_positions)
    copies = [copy.deepcopy((env, agent)) for _ in range(2)]
    for c_env, c_agent in copies:
        assert draw_belief_world(c_env, c_agent, np.random.default_rng(7))
    (c_env, c_agent), (d_env, _) = copies
    after = np.array(c_env.unwrapped.layout.landmark_positions)
    np.testing.assert_array_equal(after, np.array(d_env.unwrapped.layout.landmark_positions))
    np.testing.assert_array_equal(c_env.unwrapped._core.worlds.landmarks[0], after)
    memory = c_agent._memory
    unswept = memory.on_planning_grid(c_agent._unswept())
    spacing = base.config.world.landmark_spacing
    for i, lid in enumerate(base.layout.landmark_ids):
        assert not np.array_equal(after[i], before[i])  # every landmark is drawn
        if lid in mapped:
            continue
        assert unswept[memory.grid.cell_of(*after[i])]
        others = np.delete(after, i, axis=0)
        assert np.hypot(*(others - after[i]).T).min() >= spacing - 1e-9
    # The drawn world steps on noise of its own, not the episode's noise to come.
    for e in (c_env, env):
        e.step(np.zeros(2, np.float32))
    noise = [e.unwrapped._core.blocks.uniforms[0] for e in (c_env, env)]
    assert not np.array_equal(*noise)


def test_with_nothing_unswept_the_unmapped_landmarks_are_drawn_over_the_free_area():
    env, agent = mapped_a_few()
    base = env.unwrapped
    mapped = set(base.filter.belief_views()[2].tolist())
    w_env, w_agent = copy.deepcopy((env, agent))
    swept = np.zeros_like(w_agent._unswept())
    w_agent._unswept = lambda: swept
    assert draw_belief_world(w_env, w_agent, np.random.default_rng(3))
    before = np.array(base.layout.landmark_positions)
    after = np.array(w_env.unwrapped.layout.landmark_positions)
    grid = w_agent._memory.grid
    for i, lid in enumerate(base.layout.landmark_ids):
        if lid not in mapped:
            assert not np.array_equal(after[i], before[i])  # not left where it truly is
            assert grid.clearance[grid.cell_of(*after[i])] > 0


class Unlikely:
    """A generator whose joint draws put the robot outside the arena."""

    def __init__(self, seed):
        self._rng = np.random.default_rng(seed)
        self.joint_draws = 0

    def multivariate_normal(self, mean, cov, method):
        self.joint_draws += 1
        return np.full_like(mean, -50.0)

    def __getattr__(self, name):
        return getattr(self._rng, name)


def test_a_world_that_cannot_be_drawn_takes_the_mean_never_the_truth(monkeypatch):
    env, agent = mapped_a_few()
    base = env.unwrapped
    mean = base.filter.mean
    truth = np.array(base.layout.landmark_positions)
    w_env, w_agent = copy.deepcopy((env, agent))
    rng = Unlikely(1)
    assert not draw_belief_world(w_env, w_agent, rng)  # the mean, after DRAWS draws
    assert rng.joint_draws == DRAWS
    assert np.allclose(w_env.unwrapped.world.pose, mean[:3])
    after = np.array(w_env.unwrapped.layout.landmark_positions)
    assert not (after == truth).all(axis=1).any()  # every landmark moved
    mapped = base.filter.belief_views()[2].tolist()
    where = dict(zip(base.layout.landmark_ids, after.tolist(), strict=True))
    np.testing.assert_allclose([where[lid] for lid in mapped], mean[3:].reshape(-1, 2))
    policy = Lookahead(env, RULE, samples=1)
    policy.attach(agent)
    draw = lookahead.draw_belief_world
    monkeypatch.setattr(lookahead, "draw_belief_world", lambda e, a, r: draw(e, a, Unlikely(1)))
    policy._tried(EXPLORING[:1], 2, lambda *game: 0.0)
    assert policy.report() == {"worlds": 2, "fallbacks": 2, "skipped": 0}  # one a world


def test_a_mean_that_cannot_be_laid_out_is_left_to_the_base_never_the_truth(monkeypatch):
    env, agent = mapped_a_few()
    rule = lambda features: EXPLORING[0]  # noqa: E731 (an exploring choice: looked ahead)
    policy = Lookahead(env, rule, samples=2)
    policy.attach(agent)
    while (action := agent.begin_step()) is not None:
        env.step(action)
    monkeypatch.setattr(lookahead, "DRAWS", 0)  # straight to the mean ...
    monkeypatch.setattr(lookahead._Places, "valid", lambda *args: False)  # ... refused
    played = []
    monkeypatch.setattr(lookahead, "steps_to_mapped", lambda *a: played.append(a) or 0.0)
    assert policy(agent.features()) == EXPLORING[0]
    assert not played  # nothing was tried, in no world
    assert policy.report() == {"worlds": 0, "fallbacks": 0, "skipped": 1}


@pytest.mark.parametrize("choice", ENDGAME)
def test_an_endgame_try_in_hindsight_ends_as_the_episode_that_follows(choice):
    env, agent = at_the_endgame(3)
    tried = final_entropy(*copy.deepcopy((env, agent)), choice, RULE)
    steps = [info for _, info in play_on(env, agent, choice, RULE)]
    assert steps[-1]["entropy"] == tried
    assert agent._steps == env.spec.max_episode_steps


def test_the_endgame_takes_the_choice_that_ends_with_the_least_entropy(monkeypatch):
    env, agent = at_the_endgame(4)
    policy = Lookahead(env, RULE, samples=1, endgame=2, seed=0)
    policy.attach(agent)
    assert agent._policy is policy
    features = agent.features()
    own = RULE(features)
    values = dict(zip(ENDGAME, (-1.0, -5.0, -3.0), strict=True))
    tried = []

    def fake(env, agent, choice, base, horizon):
        tried.append((choice, horizon))
        return values[choice]

    monkeypatch.setattr(lookahead, "final_entropy", fake)
    assert policy(features) == ENDGAME[1]
    assert tried == [(c, policy.horizon) for c in ENDGAME] * 2  # each choice in 2 worlds
    assert agent.hold_goals  # the endgame's choices hold
    values = dict.fromkeys(ENDGAME, -2.0)
    assert policy(features) == own  # a tie keeps the base's own
    policy.endgame = 0
    tried.clear()
    assert policy(features) == own and not tried  # off: the base chooses
    policy.reset()
    assert not agent.hold_goals  # a new episode: the agent's own again


def test_exploring_choices_are_weighed_only_before_90_percent_and_only_over_exploring():
    env, agent = at_first_choice(3)
    policy = Lookahead(env, lambda features: ENDGAME[1], samples=1, endgame=0, record=True)
    policy.attach(agent)
    assert policy(agent.features()) == ENDGAME[1] and policy.labels == []  # a loop closure
    env, agent = at_the_endgame(3)
    policy = Lookahead(env, RULE, samples=1, endgame=0, record=True)
    policy.attach(agent)
    assert policy(agent.features()) == RULE(agent.features()) and policy.labels == []
    assert Lookahead(env, RULE).labels is None  # not recorded unless asked


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"samples": 0}, "samples"),
        ({"endgame": -1}, "endgame"),
        ({"horizon": 0}, "horizon"),
        ({"horizon": 2.5}, "horizon"),
        ({"world": "true"}, "world"),
    ],
)
def test_bad_lookahead_options_are_refused(options, match):
    env = small_env()
    with pytest.raises(ValueError, match=match):
        Lookahead(env, RULE, **options)


def test_a_lookahead_needs_a_goal_choosing_agent():
    env = small_env()
    with pytest.raises(TypeError, match="goal-choosing agent"):
        with_lookahead(make_agent("frontier", env), env)


def test_the_lookahead_agent_is_the_shipped_policy_looking_ahead_and_reproducible():
    env = small_env()
    agent = make_agent("lookahead", env, seed=2)
    assert isinstance(agent, GoalChoiceAgent) and isinstance(agent._policy, Lookahead)
    policy = agent._policy
    assert (policy.world, policy.samples, policy.endgame) == ("belief", 4, 2)
    twin = pickle.loads(pickle.dumps(agent))  # the same agent, its generator too
    first = suite_metrics(run_episode(env, agent, 6))
    again = suite_metrics(run_episode(env, make_agent("lookahead", env, seed=2), 6))
    assert first == again
    twin_env = twin._policy.env
    assert suite_metrics(run_episode(twin_env, twin, 6)) == first
    assert agent_label("lookahead") == "lookahead"
    assert agent_label("lookahead:runs/x/model.zip") == "lookahead:model"


@pytest.mark.parametrize(
    ("spec", "match"), [("lookahead:", "needs a path"), ("lookahead:/no/such.zip", "no")]
)
def test_bad_lookahead_specs_are_refused(spec, match):
    with pytest.raises(ValueError, match=match):
        make_agent(spec, small_env())


def test_the_lookahead_agent_runs_on_every_setting_of_the_suite():
    for setting in suite_settings("default"):
        env = make_env(setting.env_options, 12)
        agent = make_agent("lookahead", env, seed=0)
        record = run_episode(env, agent, 0)
        assert len(record.entropy) == 13
        env.close()


def ids_10_to_17(data_association):
    """The small world with 8 landmarks whose IDs are 10-17, and a rule-driven agent
    at its first choice after 40 steps in it (some landmarks mapped)."""
    env = make_env({**SMALL, "n_landmarks": 8}, 250)
    env.reset(seed=5)
    layout = env.unwrapped.layout
    layout = dataclasses.replace(layout, landmark_ids=tuple(range(10, 18)))
    env = make_env({"layout": layout, "data_association": data_association}, 250)
    env.reset(seed=5)
    agent = GoalChoiceAgent(env, RULE, seed=5)
    for step in range(40):
        env.step(agent.predict(None, episode_start=step == 0)[0])
    while (action := agent.begin_step()) is not None:
        env.step(action)
    assert 0 < env.unwrapped.filter.n_landmarks < 8
    return env, agent


@pytest.mark.parametrize("association", ["known", "jcbb"])
def test_worlds_are_drawn_whatever_the_landmark_ids_and_the_association(association):
    env, agent = ids_10_to_17(association)
    policy = Lookahead(env, RULE, samples=1)
    policy.attach(agent)
    policy._tried(EXPLORING, 10, lambda *game: 0.0)
    assert policy.report() == {"worlds": 10 * len(EXPLORING), "fallbacks": 0, "skipped": 0}


def far_from_the_truth(env, rng, distance=2.0):
    """Move every true landmark of ``env`` to a valid point ``distance`` m or more from
    where it was (one at a time, each move checked by the env)."""
    base = env.unwrapped
    width, height = base.arena_size
    for lid, was in zip(base.layout.landmark_ids, base.layout.landmark_positions, strict=True):
        for _ in range(2000):
            point = rng.uniform((0.0, 0.0), (width, height))
            if np.hypot(*(point - was)) < distance:
                continue
            try:
                base.move_landmarks({lid: point})
                break
            except ValueError:
                continue
        else:
            raise AssertionError(f"landmark {lid} found no other place")


@pytest.mark.parametrize("association", ["known", "jcbb"])
def test_the_lookahead_never_reads_the_true_landmarks(association):
    env, agent = ids_10_to_17(association)
    moved_env, moved_agent = copy.deepcopy((env, agent))
    far_from_the_truth(moved_env, np.random.default_rng(0))
    assert moved_env.unwrapped.layout.landmark_positions != env.unwrapped.layout.landmark_positions
    need = landmarks_needed(8, MAPPED_SHARE)
    costs = []
    for e, a in ((env, agent), (moved_env, moved_agent)):
        policy = Lookahead(e, RULE, samples=2, horizon=40, seed=3)
        policy.attach(a)
        tried = policy._tried(EXPLORING, 2, lambda *game: steps_to_mapped(*game, need, 40))
        costs.append(tried)
    np.testing.assert_array_equal(*costs)
