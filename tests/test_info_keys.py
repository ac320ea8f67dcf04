"""The info-key tables (``slam_env.info_keys``): every env reports exactly the keys its
table names, each key when its table entry says, in the single env, the native vector
env and the composable wrappers alike."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from slam_env.belief import metrics
from slam_env.belief.coverage_wrapper import CoverageWrapper
from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.belief.reward_wrapper import ActiveSLAMReward
from slam_env.envs.landmarks import LandmarksEnv
from slam_env.info_keys import ACTIVE_INFO, ALWAYS, BELIEF_INFO, RAW_INFO, info_row, names
from tests.pinned_streams import ACTIVE, OPTION_SETS

STEPS = 120


def nees_defined(env: gym.Env, info: dict) -> bool:
    """Whether the pose NEES of an ActiveSLAM-v0 env's belief is defined (finite)."""
    f = env.unwrapped.filter
    return math.isfinite(metrics.nees(metrics.pose_error(f.mean, info["pose"]), f.pose_cov))


def expected(env_id: str, options: dict, info: dict, nees: bool = True) -> set[str]:
    """The keys the tables say this step's info holds (``nees``: whether the pose
    NEES is defined)."""
    table = ACTIVE_INFO if env_id == ACTIVE else RAW_INFO
    faults = any(
        options.get(k) for k in ("outlier_rate", "clutter_rate", "scan_dropout", "kidnap_rate")
    ) or any(options.get(k) is not None for k in ("odometry_bias", "odometry_dropout"))
    conditions = {
        ALWAYS: True,
        "a fault is on": faults,
        "report_ids=False, or clutter_rate > 0": (
            options.get("report_ids") is False or options.get("clutter_rate", 0) > 0
        ),
        "a landmark is in the belief": info.get("landmarks_known", 0) > 0,
        "it is defined: finite (a pose covariance singular along the error has none)": nees,
        "coverage=True": options.get("coverage", True),
        "data_association is not 'known'": options.get("data_association", "known") != "known",
    }
    return {key.name for key in table if conditions[key.when]}


@pytest.mark.parametrize("name", sorted(OPTION_SETS))
def test_each_step_reports_the_keys_its_table_says(name: str) -> None:
    env_id, options = OPTION_SETS[name]
    env = gym.make(env_id, max_episode_steps=60, **options)
    env.action_space.seed(0)
    _, info = env.reset(seed=3)
    seen: set[str] = set()
    for _ in range(STEPS):
        nees = env_id != ACTIVE or nees_defined(env, info)
        assert set(info) == expected(env_id, options, info, nees), name
        seen |= set(info)
        _, _, terminated, truncated, info = env.step(env.action_space.sample())
        if terminated or truncated:
            _, info = env.reset()
    assert "reward_terms" in seen


def test_the_vector_env_reports_the_same_keys_with_their_masks() -> None:
    venv = gym.make_vec(ACTIVE, num_envs=2, vectorization_mode="vector_entry_point")
    venv.action_space.seed(0)
    venv.reset(seed=0)
    for _ in range(20):
        *_, info = venv.step(venv.action_space.sample())
        reported = {k for k in info if not k.startswith("_")}
        for i in range(2):
            row = {k for k in reported if info[f"_{k}"][i]}
            known = {"landmarks_known": info["landmarks_known"][i]}
            assert row == expected(ACTIVE, {}, known)
    assert all(f"_{k}" in info for k in info if not k.startswith("_"))


def test_the_wrappers_report_the_active_tables_keys() -> None:
    """The wrapper stack over the raw env reports the same keys as ActiveSLAM-v0 (the
    keys of the raw env, the belief's, the coverage's and the reward's)."""
    stack = ActiveSLAMReward(CoverageWrapper(EKFSLAMWrapper(LandmarksEnv(n_landmarks=6))))
    _, info = stack.reset(seed=0)
    stack.step(np.zeros(2, dtype=np.float32))
    _, _, _, _, info = stack.step(np.array([0.5, 0.0], dtype=np.float32))
    core = gym.make(ACTIVE, n_landmarks=6, scan_beams=0, bumper=False)
    core.reset(seed=0)
    core.step(np.zeros(2, dtype=np.float32))
    _, _, _, _, core_info = core.step(np.array([0.5, 0.0], dtype=np.float32))
    assert set(info) == set(core_info)
    assert set(names(BELIEF_INFO)) <= set(info) - set(names(RAW_INFO)) | {"map_rmse"}


def test_a_row_of_a_stacked_info_is_the_single_envs_info() -> None:
    stacked = {
        "pose": np.arange(6.0).reshape(2, 3),
        "collision": np.array([True, False]),
        "count": np.array([3, 4]),
        "maybe": np.array([0.5, 0.0]),
        "terms": {"a": np.array([1.0, 2.0])},
    }
    masks = {"maybe": np.array([True, False])}
    row = info_row(stacked, masks, 1)
    assert row.keys() == {"pose", "collision", "count", "terms"}  # maybe: not sub-env 1's
    assert type(row["collision"]) is bool and type(row["count"]) is int
    assert row["terms"] == {"a": 2.0} and type(row["terms"]["a"]) is float
    np.testing.assert_array_equal(row["pose"], [3.0, 4.0, 5.0])
    assert info_row(stacked, masks, 0)["maybe"] == 0.5


def test_every_key_has_a_meaning() -> None:
    for key in (*RAW_INFO, *ACTIVE_INFO):
        assert key.meaning and key.when
    assert len(set(names(ACTIVE_INFO))) == len(ACTIVE_INFO)  # no key twice
