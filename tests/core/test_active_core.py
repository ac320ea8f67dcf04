"""ActiveSLAM-v0 (the batched core as a batch of one) computes exactly what the
composable wrappers compute over the raw env: LandmarksEnv → EKFSLAMWrapper →
CoverageWrapper → ActiveSLAMReward, with the same options."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.belief.coverage_wrapper import CoverageWrapper
from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.belief.reward_wrapper import ActiveSLAMReward
from slam_env.core.active_options import ACTIVE_SLAM_DEFAULTS
from slam_env.envs.landmarks import LandmarksEnv
from tests.streams import assert_same

# (the belief's options, the world's options)
CONFIGS = [
    ({}, {}),
    ({"observation": "full", "correction": "batch"}, {"n_landmarks": 8}),
    (
        {"coverage": False, "reward_weights": {"coverage": 0.0, "step": 0.3}},
        {"motion_model": "velocity", "measurement_model": "cartesian"},
    ),
    (
        {"filter_alphas": (0.02, 0.01, 0.02, 0.01), "gate": 5.0},
        {"outlier_rate": 0.3, "kidnap_rate": 0.01, "preset": "cluttered"},
    ),
    ({"reward_weights": {"coverage": 20.0}}, {"scan_beams": 0, "bumper": False}),
    # FEJ, OC and the invariant EKF, and clutter, which a filter told the IDs leaves out.
    ({"linearization": "fej"}, {"clutter_rate": 0.3}),
    ({"linearization": "oc", "correction": "batch"}, {"motion_model": "velocity"}),
    ({"linearization": "invariant"}, {"measurement_model": "cartesian"}),
]


def wrapper_stack(belief: dict[str, Any], world: dict[str, Any]) -> gym.Env:
    raw = LandmarksEnv(**{**ACTIVE_SLAM_DEFAULTS, **world})
    env: gym.Env = EKFSLAMWrapper(
        raw,
        observation=belief.get("observation", "egocentric"),
        correction=belief.get("correction", "sequential"),
        gate=belief.get("gate", EKFSLAMWrapper.__init__.__defaults__[2]),
        alphas=belief.get("filter_alphas"),
        linearization=belief.get("linearization", "standard"),
    )
    if belief.get("coverage", True):
        env = CoverageWrapper(env)
    weights = ActiveSLAMRewardWeights(**belief.get("reward_weights", {}))
    return ActiveSLAMReward(env, weights)


@pytest.mark.parametrize(("belief", "world"), CONFIGS)
def test_the_core_is_the_wrapper_stack_bit_for_bit(belief, world) -> None:
    core = gym.make("slam_env/ActiveSLAM-v0", max_episode_steps=None, **belief, **world)
    stack = wrapper_stack(belief, world)
    assert core.observation_space == stack.observation_space
    rng = np.random.default_rng(0)
    for episode in range(2):
        assert_same(core.reset(seed=episode), stack.reset(seed=episode), f"reset {episode}")
        for t in range(250):
            action = np.array([rng.uniform(-0.3, 1.0), rng.uniform(-1, 1)], np.float32)
            assert_same(list(core.step(action)), list(stack.step(action)), f"step {episode}.{t}")
    assert core.unwrapped.filter.n_landmarks > 0


@pytest.mark.parametrize("association", ["known", "jcbb"])
def test_the_step_filters_as_the_standalone_filter_fed_the_same_readings(association) -> None:
    """30 landmarks all around: the first scan has more detections than the step's
    first workspaces hold, so they grow and the step is made again; each filter equals
    an EKFSLAM fed the raw readings the step read, mean and covariance bit for bit."""
    options: dict[str, Any] = {"n_landmarks": 30, "max_range": 8.0, "fov": 6.28}
    if association != "known":
        options |= {"data_association": association, "report_ids": False}
    env = gym.make("slam_env/ActiveSLAM-v0", max_episode_steps=None, **options)
    env.reset(seed=3)
    core = env.unwrapped._core
    out, counts = core.raw.out, core.raw.det_count
    reference = core.filters.template.copy()
    reference.reset(initial_pose=core.raw.worlds.poses[0].copy())

    def fold_in_the_scan() -> None:
        k = int(counts[0])
        z = out.detections[0, : 2 * k].astype(np.float64).reshape(k, 2)
        ids = out.ids[0, :k].astype(np.int64)
        if association == "known":
            reference.update(z[ids >= 0], ids[ids >= 0])
        else:
            reference.update(z, None)

    fold_in_the_scan()
    assert counts[0] > 8  # past the first workspaces
    rng = np.random.default_rng(1)
    for t in range(60):
        env.step(np.array([rng.uniform(0.0, 1.0), rng.uniform(-1, 1)], np.float32))
        reference.predict(out.odometry[0].astype(np.float64))
        fold_in_the_scan()
        d = reference.dim
        assert np.array_equal(core.filters.x[0, :d], reference.mean), t
        assert np.array_equal(core.filters.P[0, :d, :d], reference.cov), t
    assert reference.n_landmarks > 8


@pytest.mark.parametrize(("num_envs", "threads", "index"), [(1, 1, 0), (4, 2, 3)])
def test_an_entropy_left_to_the_eigenvalues_is_paid_once_known(
    num_envs: int, threads: int, index: int
) -> None:
    """A covariance that round-off left not positive definite to the entropy kernel's
    Cholesky factor: its entropy comes from the eigenvalues, and the step's reward is
    paid on that entropy (in a single env, and in a threaded vector env's chunk)."""
    venv = gym.make_vec(
        "slam_env/ActiveSLAM-v0",
        num_envs=num_envs,
        vectorization_mode="vector_entry_point",
        num_threads=threads,
    )
    venv.reset(seed=0)
    for _ in range(5):
        venv.step(np.tile(np.array([0.5, 0.1], np.float32), (num_envs, 1)))
    core = venv.unwrapped.core
    filters = core.filters
    d = 3 + 2 * int(filters.n[index])
    filters.P[index, 2, 2] = -1.0  # a negative heading variance: no Cholesky factor
    baseline = core.last[index, 0]
    others = core.entropy.copy()
    assert core._touched.all() and core.raw._stepping.all()  # as the last step left them
    core._outputs(threads - 1)  # the chunk holding sub-env `index`
    assert not core._entropy_ok[index]
    expected = core._entropy_of(filters.P[index, :d, :d])
    assert math.isfinite(expected)
    assert core.entropy[index] == expected
    weight = ActiveSLAMRewardWeights().information_gain
    assert core.terms[index, 0] == weight * (baseline - expected)
    assert core.rewards[index] == sum(core.terms[index].tolist())
    assert core._entropy_ok[:index].all() and (core.entropy[:index] == others[:index]).all()
    venv.close()


@pytest.mark.parametrize("env_id", ["slam_env/ActiveSLAM-v0", "slam_env/Landmarks-v0"])
def test_a_copy_steps_its_own_arrays(env_id) -> None:
    # The cores keep their kernels' arguments between steps; a pickled copy must build
    # its own, over its own arrays (the coverage grid's included), not step detached
    # copies of the original's.
    import pickle

    env = gym.make(env_id)
    env.reset(seed=3)
    env.action_space.seed(3)
    actions = [env.action_space.sample() for _ in range(60)]
    for action in actions[:30]:
        env.step(action)
    clone = pickle.loads(pickle.dumps(env))
    core, twin = env.unwrapped._core, clone.unwrapped._core
    coverage = getattr(core, "coverage", None)
    swept_before = None if coverage is None else coverage.padded.sum()
    for action in actions[30:]:
        assert_same(env.step(action), clone.step(action))
    poses = core.worlds.poses if coverage is None else core.raw.worlds.poses
    twin_poses = twin.worlds.poses if coverage is None else twin.raw.worlds.poses
    assert np.array_equal(poses, twin_poses)
    assert not np.shares_memory(poses, twin_poses)
    if coverage is not None:
        assert twin.coverage.padded.sum() > swept_before  # the copy's grid was swept
        assert np.array_equal(coverage.padded, twin.coverage.padded)
