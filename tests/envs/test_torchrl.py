"""torchrl's Gym wrappers over both IDs: ``GymEnv`` builds them (it tries
``frameskip=1`` and drops it on Python's own wording of the refusal), its spec checker
passes, and a ``ParallelEnv`` of two worker processes steps them."""

from __future__ import annotations

import pytest
import torch
from torchrl.envs import GymEnv, ParallelEnv
from torchrl.envs.utils import check_env_specs

import slam_env  # noqa: F401  (registers the IDs)

IDS = ["slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0"]


@pytest.mark.parametrize("env_id", IDS)
def test_gym_env_builds_each_id_and_its_specs_check(env_id):
    env = GymEnv(env_id)
    try:
        check_env_specs(env, seed=0)
        rollout = env.rollout(3)
        assert rollout.batch_size == torch.Size([3])
        assert torch.isfinite(rollout["next", "reward"]).all()
        # frameskip was dropped by torchrl (not applied twice by the env).
        assert env.wrapper_frame_skip == 1
    finally:
        env.close()


def _active_slam() -> GymEnv:
    # A spawned worker unpickles this function by importing this module, and with it
    # slam_env, which registers the IDs.
    return GymEnv("slam_env/ActiveSLAM-v0")


@pytest.mark.parametrize(
    "start_method",
    [
        # Forked workers start in a second: the default suite's.
        "fork",
        # torchrl's default: each worker a fresh Python that imports torch, torchrl and
        # slam_env (about 25 s on two loaded cores), so a long run.
        pytest.param("spawn", marks=pytest.mark.slow),
    ],
)
def test_parallel_env_of_two_workers_steps(start_method):
    env = ParallelEnv(2, _active_slam, mp_start_method=start_method)
    try:
        env.set_seed(0)
        rollout = env.rollout(4)
        assert rollout.batch_size == torch.Size([2, 4])
        observations = rollout["next", "observation"]
        assert observations.dtype == torch.float32
        assert torch.isfinite(observations).all()
        # Two workers seeded 0 and 1: two different worlds, so different beliefs.
        assert not torch.equal(observations[0], observations[1])
    finally:
        env.close()
