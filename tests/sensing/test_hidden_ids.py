"""Detections without IDs (``report_ids=False``), clutter (``clutter_rate``), and
``ActiveSLAM-v0`` associating by itself: the observation hides the truth that ``info``
keeps, clutter is no landmark, the association is scored in ``info``, and a second
sighting keeps clutter out of the map."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401
from slam_env.sensing.raw_observation import unpack_detections
from tests.belief.test_wrappers import _smooth_actions
from tests.streams import rollout_digest

RAW = "slam_env/Landmarks-v0"
ACTIVE = "slam_env/ActiveSLAM-v0"
SCORES = ("correct", "wrong", "missed", "duplicated")


def test_hidden_ids_change_only_the_ids_of_the_observation():
    """The same seed gives the same detections; the IDs read −1 and the truth moves
    to ``info["detection_ids"]``."""
    shown, hidden = gym.make(RAW), gym.make(RAW, report_ids=False)
    obs_s, _ = shown.reset(seed=4)
    obs_h, info = hidden.reset(seed=4)
    rng = np.random.default_rng(0)
    detections = 0
    for _ in range(300):
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        obs_s, *_ = shown.step(action)
        obs_h, *_, info = hidden.step(action)
        np.testing.assert_array_equal(obs_h["detections"], obs_s["detections"])
        np.testing.assert_array_equal(obs_h["mask"], obs_s["mask"])
        assert (obs_h["ids"] == -1).all()
        valid = obs_s["mask"] > 0
        np.testing.assert_array_equal(info["detection_ids"][valid], obs_s["ids"][valid])
        assert (info["detection_ids"][~valid] == -1).all()
        detections += int(valid.sum())
        assert hidden.observation_space.contains(obs_h)
    assert detections > 100


def test_clutter_is_a_detection_of_no_landmark_at_its_rate():
    """Clutter reads ID −1 in the observation and in the truth, lies inside the
    sensor's footprint, and marks no landmark as seen."""
    env = gym.make(RAW, clutter_rate=0.4, fov=math.pi / 2)
    _, info = env.reset(seed=5)
    detected = info["seen"].copy()
    clutter, n = 0, 1500
    for _ in range(n):
        obs, *_, info = env.step(np.array([0.5, 0.3], dtype=np.float32))
        z, ids = unpack_detections(obs)
        unlabelled = ids < 0
        assert unlabelled.sum() <= 1
        np.testing.assert_array_equal(info["detection_ids"][: ids.size], ids)
        if unlabelled.any():
            r, phi = z[unlabelled][0]
            assert 0.5 <= r <= 5.0 + 1e-5 and abs(phi) <= math.pi / 4 + 1e-6
        detected[ids[~unlabelled]] = True
        np.testing.assert_array_equal(info["seen"], detected)
        clutter += int(unlabelled.any())
    rate = 0.4
    assert abs(clutter / n - rate) < 4 * math.sqrt(rate * (1 - rate) / n)


def test_clutter_off_leaves_every_fault_stream_unchanged():
    assert rollout_digest(RAW, seed=3, steps=150, outlier_rate=0.3, clutter_rate=0.0) == (
        rollout_digest(RAW, seed=3, steps=150, outlier_rate=0.3)
    )


def run_episode(steps: int, seed: int, **options) -> dict:
    env = gym.make(ACTIVE, max_episode_steps=steps, **options)
    obs, info = env.reset(seed=seed)
    totals = dict.fromkeys(SCORES[:3], 0)
    for action in _smooth_actions(np.random.default_rng(seed), steps):
        obs, _, terminated, truncated, info = env.step(action)
        assert env.observation_space.contains(obs)
        for key in totals:
            totals[key] += info["association"][key]
        if terminated or truncated:
            break
    for key in totals:  # the episode's sums are the steps' sums
        assert info["association_episode"][key] == totals[key]
    return info


def test_jcbb_without_ids_maps_like_the_known_ids_filter():
    """Clean default world, IDs hidden: every association right, no duplicate, the map
    error that of the filter told the IDs."""
    for seed in (1, 2):
        info = run_episode(300, seed, report_ids=False, data_association="jcbb")
        known = run_episode_known(300, seed)
        score = info["association_episode"]
        assert score["wrong"] == 0 and score["duplicated"] == 0
        assert score["correct"] >= 0.99 * (score["correct"] + score["missed"])
        assert info["landmarks_known"] == known["landmarks_known"]
        assert info["map_rmse"] == pytest.approx(known["map_rmse"], rel=0.2)


def run_episode_known(steps: int, seed: int) -> dict:
    env = gym.make(ACTIVE, max_episode_steps=steps)
    env.reset(seed=seed)
    for action in _smooth_actions(np.random.default_rng(seed), steps):
        *_, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert "association" not in info  # the IDs were given: nothing to score
    return info


def test_a_second_sighting_keeps_clutter_out_of_the_map():
    """With heavy clutter, landmarks started at the first sighting include clutter;
    with a second sighting required, none does."""
    options = dict(report_ids=False, data_association="jcbb", clutter_rate=0.5)
    once = run_episode(300, 3, **options)["association_episode"]
    twice = run_episode(300, 3, new_landmark_sightings=2, **options)["association_episode"]
    assert once["wrong"] > 10
    assert twice["wrong"] <= 1
    assert twice["correct"] >= 0.97 * (twice["correct"] + twice["missed"])


def test_the_native_vector_env_scores_every_sub_env_like_the_single_env():
    options = dict(report_ids=False, data_association="nearest_neighbor", clutter_rate=0.2)
    vec = gym.make_vec(ACTIVE, num_envs=2, vectorization_mode="vector_entry_point", **options)
    vec.reset(seed=[7, 8])
    singles = [gym.make(ACTIVE, **options) for _ in range(2)]
    for env, seed in zip(singles, (7, 8), strict=True):
        env.reset(seed=seed)
    rng = np.random.default_rng(0)
    for _ in range(60):
        actions = rng.uniform(-1, 1, (2, 2)).astype(np.float32)
        *_, infos = vec.step(actions)
        for b, env in enumerate(singles):
            *_, info = env.step(actions[b])
            for key in SCORES:
                assert infos["association_episode"][key][b] == info["association_episode"][key]
            np.testing.assert_array_equal(infos["detection_ids"][b], info["detection_ids"])


@pytest.mark.parametrize("sightings", [0, 3, True, "2"])
def test_new_landmark_sightings_is_one_or_two(sightings):
    with pytest.raises(ValueError, match="new_landmark_sightings must be 1 or 2"):
        gym.make(ACTIVE, data_association="jcbb", new_landmark_sightings=sightings)
