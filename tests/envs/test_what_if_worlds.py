"""What-if worlds: moving landmarks mid-episode (``CoreEnv.move_landmarks``) and noise
of a copy's own (setting ``np_random`` mid-episode)."""

from __future__ import annotations

import copy
import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.sensing.raw_observation import unpack_detections
from tests.streams import digest

ENV_ID = "slam_env/Landmarks-v0"


def rollout(env: gym.Env, steps: int, seed: int = 7) -> str:
    rng = np.random.default_rng(seed)
    return digest(*(env.step(rng.uniform(-1, 1, 2).astype(np.float32)) for _ in range(steps)))


def started(env_id: str = ENV_ID, steps: int = 15, **kwargs) -> gym.Env:
    env = gym.make(env_id, **kwargs)
    env.reset(seed=3)
    rollout(env, steps, seed=1)
    return env


def point_ahead(env: gym.Env, distance: float) -> tuple[float, float]:
    x, y, theta = env.unwrapped.world.pose
    return x + distance * math.cos(theta), y + distance * math.sin(theta)


def farthest_landmark(env: gym.Env) -> int:
    world = env.unwrapped.world
    x, y, _ = world.pose
    d = np.hypot(*(world.landmark_positions - (x, y)).T)
    return int(world.landmark_ids[int(np.argmax(d))])


@pytest.mark.parametrize("env_id", [ENV_ID, "slam_env/ActiveSLAM-v0"])
def test_moving_landmarks_where_they_are_changes_nothing(env_id):
    env = started(env_id)
    twin = copy.deepcopy(env)
    world = env.unwrapped.world
    env.unwrapped.move_landmarks(
        {int(i): p for i, p in zip(world.landmark_ids, world.landmark_positions, strict=True)}
    )
    assert rollout(env, 60) == rollout(twin, 60)


def test_a_moved_landmark_is_seen_where_it_was_put_and_the_original_is_untouched():
    env = started(preset="open")
    lid = farthest_landmark(env)
    before = env.unwrapped.world.landmark_positions.copy()
    pose = env.unwrapped.world.pose
    twin = copy.deepcopy(env)
    spot = point_ahead(twin, 1.5)
    twin.unwrapped.move_landmarks({lid: spot})
    assert twin.unwrapped.world.pose == pose  # the robot stays
    k = list(twin.unwrapped.layout.landmark_ids).index(lid)
    assert twin.unwrapped.layout.landmark_positions[k] == spot
    assert np.array_equal(env.unwrapped.world.landmark_positions, before)
    stop = np.zeros(2, dtype=np.float32)
    obs, *_, info = twin.step(stop)
    z, ids = unpack_detections(obs)
    assert lid in ids.tolist()
    assert abs(z[ids.tolist().index(lid)][0] - 1.5) < 0.3  # range, within its noise
    assert np.allclose(info["landmark_positions"][info["landmark_ids"] == lid], spot)
    obs, *_ = env.step(stop)
    assert lid not in unpack_detections(obs)[1].tolist()


def test_moved_posts_block_the_robot():
    env = started(preset="open")
    lid = farthest_landmark(env)
    env.unwrapped.move_landmarks({lid: point_ahead(env, 0.6)})
    collided = 0
    for _ in range(20):
        *_, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        collided += bool(info["collision"])
    x, y, _ = env.unwrapped.world.pose
    k = list(env.unwrapped.layout.landmark_ids).index(lid)
    post = env.unwrapped.layout.landmark_positions[k]
    assert collided and math.dist((x, y), post) >= env.unwrapped.config.robot.radius


@pytest.mark.parametrize(
    ("positions", "error", "match"),
    [
        ([(1.0, 1.0)], TypeError, "mapping"),
        ({"0": (1.0, 1.0)}, TypeError, "landmark ID"),
        ({True: (1.0, 1.0)}, TypeError, "landmark ID"),
        ({999: (1.0, 1.0)}, ValueError, "ID 999"),
        ({0: (1.0,)}, ValueError, "2 numbers"),
        ({0: "ab"}, TypeError, "positions"),
        ({0: (math.nan, 1.0)}, ValueError, "non-finite"),
        ({0: (1e300, 1.0)}, ValueError, "outside the arena"),
        ({0: (-3.0, 1.0)}, ValueError, "outside the arena"),
    ],
)
def test_bad_positions_are_refused_and_nothing_moves(positions, error, match):
    env = started()
    twin = copy.deepcopy(env)
    with pytest.raises(error, match=match):
        env.unwrapped.move_landmarks(positions)
    assert rollout(env, 40) == rollout(twin, 40)


def test_a_landmark_into_an_obstacle_another_post_or_the_robot_is_refused():
    env = started(preset="cluttered")
    twin = copy.deepcopy(env)
    layout = env.unwrapped.layout
    a, b = layout.landmark_ids[:2]
    centre = np.mean(layout.obstacles[0], axis=0)
    near_b = np.add(layout.landmark_positions[1], (0.05, 0.0))
    x, y, _ = env.unwrapped.world.pose
    for where, match in [(centre, "obstacle"), (near_b, "post"), ((x, y), "start pose")]:
        with pytest.raises(ValueError, match=match):
            env.unwrapped.move_landmarks({a: where})
    assert rollout(env, 40) == rollout(twin, 40)
    assert b != a


@pytest.mark.parametrize("env_id", [ENV_ID, "slam_env/ActiveSLAM-v0"])
def test_moving_the_robot_where_it_is_changes_nothing(env_id):
    env = started(env_id)
    twin = copy.deepcopy(env)
    env.unwrapped.move_landmarks({}, robot_pose=env.unwrapped.world.pose)
    assert rollout(env, 60) == rollout(twin, 60)


def test_a_moved_robot_drives_and_sees_from_its_new_pose_and_the_belief_stays():
    env = started("slam_env/ActiveSLAM-v0", preset="open")
    base = env.unwrapped
    lid = farthest_landmark(env)
    lx, ly = base.layout.landmark_positions[list(base.layout.landmark_ids).index(lid)]
    x, y, _ = base.world.pose
    heading = math.atan2(ly - y, lx - x)  # 1.5 m short of it, facing it
    d = math.dist((x, y), (lx, ly)) - 1.5
    pose = (x + d * math.cos(heading), y + d * math.sin(heading), heading + 2 * math.pi)
    mean, cov = base.filter.mean.copy(), base.filter.cov.copy()
    base.move_landmarks({}, robot_pose=pose)
    assert np.allclose(base.world.pose, (*pose[:2], heading))  # the heading wrapped
    assert np.array_equal(base.filter.mean, mean) and np.array_equal(base.filter.cov, cov)
    *_, info = env.step(np.zeros(2, dtype=np.float32))
    assert np.array_equal(info["odometry_true"], np.zeros(3))  # no jump in the odometry
    assert np.allclose(info["pose"], base.world.pose) and info["pose_error"] > d / 2
    assert lid in base.filter.belief_views()[2].tolist()  # seen from there


@pytest.mark.parametrize(
    ("robot_pose", "error", "match"),
    [
        ((1.0, 1.0), ValueError, "3 numbers"),
        ("abc", TypeError, "robot_pose"),
        ((math.nan, 1.0, 0.0), ValueError, "start_pose is not finite"),
        ((1e300, 1.0, 0.0), ValueError, "start pose is robot_pose"),
        ((-3.0, 1.0, 0.0), ValueError, "start pose is robot_pose"),
    ],
)
def test_bad_robot_poses_are_refused_and_nothing_moves(robot_pose, error, match):
    env = started()
    twin = copy.deepcopy(env)
    lid = farthest_landmark(env)
    with pytest.raises(error, match=match):
        env.unwrapped.move_landmarks({lid: point_ahead(env, 1.0)}, robot_pose=robot_pose)
    assert rollout(env, 40) == rollout(twin, 40)


def test_a_robot_into_an_obstacle_or_a_post_is_refused_and_one_move_checks_both():
    env = started(preset="cluttered")
    twin = copy.deepcopy(env)
    base = env.unwrapped
    layout = base.layout
    centre = (*np.mean(layout.obstacles[0], axis=0), 0.0)
    post = (*layout.landmark_positions[0], 0.0)
    for where, match in [(centre, "obstacle"), (post, "post")]:
        with pytest.raises(ValueError, match=match):
            base.move_landmarks({}, robot_pose=where)
    assert rollout(env, 40) == rollout(twin, 40)
    # The landmark leaves as the robot comes: valid together, not one by one.
    lid = int(layout.landmark_ids[0])
    here = base.world.pose
    base.move_landmarks({lid: here[:2]}, robot_pose=post)
    assert np.allclose(base.world.pose[:2], post[:2])


def test_moving_landmarks_needs_a_reset_first():
    env = gym.make(ENV_ID)
    with pytest.raises(ResetNeeded):
        env.unwrapped.move_landmarks({})


def uniforms_after_a_step(env: gym.Env) -> np.ndarray:
    env.step(np.zeros(2, dtype=np.float32))
    return env.unwrapped._core.blocks.uniforms[0].copy()


@pytest.mark.parametrize("env_id", [ENV_ID, "slam_env/ActiveSLAM-v0"])
def test_a_new_generator_gives_the_noise_from_the_next_step(env_id):
    env = started(env_id, steps=3)  # mid-block: the block holds more steps
    same, other = copy.deepcopy(env), copy.deepcopy(env)
    env.np_random = np.random.default_rng(11)  # through the wrappers
    same.np_random = np.random.default_rng(11)
    first = uniforms_after_a_step(env)
    assert np.array_equal(first, uniforms_after_a_step(same))
    assert not np.array_equal(first, uniforms_after_a_step(other))
    assert rollout(env, 50) == rollout(same, 50)
    assert rollout(env, 10) != rollout(other, 10)


def test_np_random_must_be_a_generator():
    env = started()
    twin = copy.deepcopy(env)
    with pytest.raises(TypeError, match="numpy Generator"):
        env.unwrapped.np_random = 42
    assert rollout(env, 30) == rollout(twin, 30)
