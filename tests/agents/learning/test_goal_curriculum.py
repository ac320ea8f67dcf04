"""A curriculum over the arena sizes of a goal-choosing policy's training worlds
(``curriculum:`` in a goal-training config)."""

from __future__ import annotations

import pytest

from agents.learning.config import ConfigError, config_from_dict
from agents.learning.goal_env import GoalChoiceEnv
from agents.learning.sb3.goal_training import GoalEnvFactory
from agents.learning.sb3.training import train
from agents.learning.worlds import WorldDistribution
from tests.agents.goals.test_choice import INFORMATION_ONLY, tiny_goal_config

GOALS = {"decisions": "goals", "vectorization": "dummy"}


def test_up_to_keeps_the_smallest_share_of_the_arena_sizes():
    worlds = WorldDistribution(arena_sizes=(16.0, 8.0, 32.0, 12.0, 24.0), landmark_counts=(5,))
    for share, sizes in (
        (-1.0, (8.0,)),
        (0.0, (8.0,)),  # at least one
        (0.2, (8.0,)),
        (0.21, (8.0, 12.0)),
        (0.5, (8.0, 12.0, 16.0)),
        (0.8, (8.0, 12.0, 16.0, 24.0)),
    ):
        narrowed = worlds.up_to(share)
        assert narrowed.arena_sizes == sizes
        assert narrowed.landmark_counts == (5,)  # the rest as it was
    for share in (0.81, 1.0, 2.0):
        assert worlds.up_to(share) is worlds  # every size in: the same draws as without
    assert WorldDistribution(landmark_counts=(5,)).up_to(0.0).arena_sizes is None


def arena_sides(env: GoalChoiceEnv, episodes: int, seed: int) -> list[tuple[int, float]]:
    """(choices made before the episode, arena side) of each of ``episodes`` episodes,
    every choice the frontier weighting."""
    out = []
    for e in range(episodes):
        env.reset(seed=seed if e == 0 else None)
        out.append((env._choices_made, float(env._env.unwrapped.config.world.width)))
        done = False
        while not done:
            _, _, terminated, truncated, _ = env.step(0)
            done = terminated or truncated
    return out


def test_the_arenas_grow_over_the_curriculums_choices():
    worlds = WorldDistribution(arena_sizes=(8.0, 10.0), landmark_counts=(4,))
    env = GoalChoiceEnv(INFORMATION_ONLY, worlds, max_episode_steps=30, curriculum_choices=12)
    sides = arena_sides(env, episodes=14, seed=3)
    env.close()
    # Before half of the 12 choices only the smaller of the two; after, both are drawn.
    assert all(side == 8.0 for made, side in sides if made <= 6)
    assert {side for made, side in sides if made > 6} == {8.0, 10.0}
    assert sum(made <= 6 for made, _ in sides) >= 2
    # Without a curriculum the same env draws the larger arena from the start.
    plain = GoalChoiceEnv(INFORMATION_ONLY, worlds, max_episode_steps=30)
    assert 10.0 in {side for made, side in arena_sides(plain, 4, seed=3) if made <= 6}
    plain.close()


@pytest.mark.parametrize("bad", [-1, 1.5, True, "12", None])
def test_a_bad_curriculum_length_is_refused(bad):
    with pytest.raises(ValueError, match="curriculum_choices must be an int >= 0"):
        GoalChoiceEnv(INFORMATION_ONLY, None, curriculum_choices=bad)


def test_the_curriculum_key_is_checked():
    worlds = {"arena_sizes": [8.0, 16.0]}
    assert config_from_dict({**GOALS, "worlds": worlds, "curriculum": 0.5}).curriculum == 0.5
    assert config_from_dict(GOALS).curriculum == 0.0
    for bad in (-0.1, 1.1, float("nan"), True, "0.5", None):
        with pytest.raises(ConfigError, match=r"'curriculum' must be a number in \[0, 1\]"):
            config_from_dict({**GOALS, "worlds": worlds, "curriculum": bad})
    expected = "0 unless decisions is goals and worlds has arena_sizes to grow"
    for config in (
        {"curriculum": 0.5, "worlds": worlds},  # decisions: actions
        {**GOALS, "curriculum": 0.5},  # no worlds
        {**GOALS, "curriculum": 0.5, "worlds": {"landmark_counts": [5]}},  # no sizes to grow
    ):
        with pytest.raises(ConfigError, match=expected):
            config_from_dict(config)


@pytest.mark.parametrize(("curriculum", "choices"), [(0.5, 16), (0.001, 1)])
def test_each_sub_env_takes_its_share_of_the_curriculum(tmp_path, monkeypatch, curriculum, choices):
    made: list[GoalEnvFactory] = []
    original = GoalEnvFactory.__call__

    def record(self):
        made.append(self)
        return original(self)

    monkeypatch.setattr(GoalEnvFactory, "__call__", record)
    config = tiny_goal_config(tmp_path, curriculum=curriculum, total_timesteps=64)
    config["worlds"] = {"arena_sizes": [8.0, 10.0], "landmark_counts": [4]}
    path = train(config)
    assert path.is_file()
    # Its share of the 64 choices over 2 sub-envs; never none for a curriculum above 0.
    assert {f.curriculum_choices for f in made} == {choices}
