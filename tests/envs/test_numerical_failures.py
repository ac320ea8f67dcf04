"""ActiveSLAM-v0 reports a numerical breakdown of its filter as ``diverged``, whatever
the filter raises for it, and never lets it out of ``step``."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.envs.landmarks import LandmarksEnv
from slam_env.kernels.ekf import codes as ekf_codes

ACTIVE = "slam_env/ActiveSLAM-v0"
FORWARD = np.array([0.8, 0.2], dtype=np.float32)
NUMERICAL = [
    FloatingPointError("innovation covariance S is not positive definite"),
    ValueError("math domain error"),
    np.linalg.LinAlgError("Matrix is not positive definite"),
    OverflowError("(34, 'Numerical result out of range')"),
    ZeroDivisionError("float division by zero"),
]


def _failing(exc: Exception):
    def fail(*args, **kwargs):
        raise exc

    return fail


def _wrapper_stack():
    """The composable wrapper over the raw env, whose filter raises on a failure."""
    return EKFSLAMWrapper(LandmarksEnv(n_landmarks=8, max_range=8.0, fov=6.28))


@pytest.mark.parametrize("call", ["predict", "update"])
@pytest.mark.parametrize("exc", NUMERICAL, ids=lambda e: type(e).__name__)
def test_a_numerical_failure_is_reported_as_diverged_by_the_wrapper(call, exc, monkeypatch):
    env = _wrapper_stack()
    env.reset(seed=0)
    _, _, _, _, info = env.step(FORWARD)
    assert not info["diverged"] and info["landmarks_known"] > 0
    monkeypatch.setattr(env.filter, call, _failing(exc))
    for _ in range(3):
        obs, reward, _, _, info = env.step(FORWARD)
        assert env.observation_space.contains(obs) and math.isfinite(reward)
        assert info["diverged"]
    monkeypatch.undo()
    env.step(FORWARD)
    _, info = env.reset(seed=1)  # a new episode starts with a sound belief
    assert not info["diverged"]


def test_other_exceptions_from_the_filter_are_not_hidden(monkeypatch):
    env = _wrapper_stack()
    env.reset(seed=0)
    monkeypatch.setattr(env.filter, "predict", _failing(KeyError("a bug")))
    with pytest.raises(KeyError):
        env.step(FORWARD)


# A real failure of each call of the compiled filter step, by its parameters: the
# prediction's noise beyond any covariance overflows it; a negative measurement noise
# leaves the innovation covariance not positive definite.
SABOTAGE = {
    "predict": ([ekf_codes.NOISE + i for i in range(4)], 1e308),
    "update": ([ekf_codes.Q00, ekf_codes.Q11], -1e6),
}


@pytest.mark.parametrize("call", ["predict", "update"])
def test_a_kernel_failure_is_reported_as_diverged_by_the_env(call):
    """ActiveSLAM-v0's filters report a failure by an error code (their state as it
    was): the env reports ``diverged`` until the next reset, and never raises."""
    env = gym.make(ACTIVE, n_landmarks=8, max_range=8.0, fov=6.28)
    env.reset(seed=0)
    _, _, _, _, info = env.step(FORWARD)
    assert not info["diverged"] and info["landmarks_known"] > 0
    filters = env.unwrapped._core.filters
    columns, value = SABOTAGE[call]
    sound = filters.params.copy()
    filters.params[:, columns] = value
    for _ in range(3):
        before = (filters.x.copy(), filters.P.copy())
        obs, reward, _, _, info = env.step(FORWARD)
        assert env.observation_space.contains(obs) and math.isfinite(reward)
        assert info["diverged"]
        if call == "update":  # the update was refused: the prediction alone moved P
            assert filters.error[0] == ekf_codes.NOT_POSITIVE_DEFINITE
            assert np.array_equal(filters.P[0, 3:, 3:], before[1][0, 3:, 3:])
        else:  # the prediction was refused: the pose's variance did not grow
            assert filters.P[0, 0, 0] <= before[1][0, 0, 0]
    filters.params[:] = sound
    _, _, _, _, info = env.step(FORWARD)
    assert info["diverged"]  # until the next reset
    _, info = env.reset(seed=1)
    assert not info["diverged"]


@pytest.mark.parametrize(
    "options",
    [
        {"alphas": (1e12,) * 4},
        {"alphas": (1e29,) * 4},
        {"motion_model": "velocity", "velocity_noise": (1e12, 1e12, 1e12, 1e12)},
    ],
)
def test_absurd_filter_noise_never_raises_out_of_step(options):
    env = gym.make(ACTIVE, **options)
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(30):
        obs, reward, _, _, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
        assert type(reward) is float and math.isfinite(reward)
        assert math.isfinite(info["entropy"])
