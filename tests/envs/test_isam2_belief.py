"""``ActiveSLAM-v0`` with ``belief="isam2"``: the smoothing belief handed on through the
filter's arrays (slam_env.smoothing.batch). It is ISAM2SLAM's on the env's own stream;
the observation, entropy and metrics read it; both env checkers pass; the native vector
env replays the single envs on 1 and 2 threads; pickles replay; hidden IDs are
associated by the filter's NN and JCBB against the smoother's marginal; bad options are
refused."""

from __future__ import annotations

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip(
    "gtsam", reason="belief='isam2' needs GTSAM (the 'gtsam' extra: pip install 'slam_env[gtsam]')"
)

from gymnasium.utils.env_checker import check_env as gym_check_env
from gymnasium.utils.env_checker import check_step_determinism
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.belief.encodings import unpack_full_belief
from slam_env.budget import MAX_MEMORY_BYTES, SMOOTHER_BYTES_PER_UPDATE, smoother_updates
from slam_env.ekf import Status
from slam_env.sensing.raw_observation import unpack_detections
from slam_env.smoothing import ISAM2SLAM
from tests.envs.test_vector import replay_against_singles
from tests.streams import assert_same

ACTIVE, RAW = "slam_env/ActiveSLAM-v0", "slam_env/Landmarks-v0"
ISAM2 = {"belief": "isam2"}


def _drive(env: gym.Env, steps: int, seed: int = 0) -> list:
    env.action_space.seed(seed)
    out = [env.reset(seed=seed)]
    for _ in range(steps):
        out.append(env.step(env.action_space.sample()))
    return out


def test_the_belief_is_isam2slams_on_the_envs_own_stream() -> None:
    """With no gate (every known detection used), the env's smoother is an ISAM2SLAM
    fed the raw env's odometry and detections, and the belief the agent sees (the
    full observation, the filter view) is its mean and joint marginal."""
    options = {"gate": None, "observation": "full", "max_episode_steps": 400}
    env = gym.make(ACTIVE, **ISAM2, **options)
    raw = gym.make(RAW, scan_beams=16, bumper=True, max_episode_steps=400)
    env.action_space.seed(3)
    obs, info = env.reset(seed=3)
    raw_obs, raw_info = raw.reset(seed=3)
    core = env.unwrapped
    ref = ISAM2SLAM(
        alphas=core.config.odometry.alphas,
        measurement_cov=core.config.sensor.measurement_cov,
        max_landmarks=core.filter.max_landmarks,
        initial_pose=raw_info["pose"],
    )

    def fold(raw_obs: dict) -> None:
        z, ids = unpack_detections(raw_obs)
        ref.update(z[ids >= 0], ids[ids >= 0])

    fold(raw_obs)
    for t in range(300):
        action = env.action_space.sample()
        obs, *_, info = env.step(action)
        raw_obs, *_ = raw.step(action)
        ref.predict(raw_obs["odometry"])
        fold(raw_obs)
        smoother = core.smoother
        assert smoother.n_poses == ref.n_poses == t + 2
        np.testing.assert_array_equal(smoother.state_to_id, ref.state_to_id)
        np.testing.assert_allclose(smoother.mean, ref.mean, rtol=0, atol=1e-12)
        if t % 50 == 0:
            np.testing.assert_allclose(smoother.cov, ref.cov, rtol=0, atol=1e-12)
    # What the agent sees is the smoother's belief, slotted by ID as the filter's.
    mean, cov, known = unpack_full_belief(obs)
    ids = ref.state_to_id
    assert known.sum() == ref.n_landmarks == info["landmarks_known"] >= 5
    np.testing.assert_allclose(mean[:3], ref.mean[:3], atol=1e-5)
    slots = np.concatenate([[0, 1, 2], (3 + 2 * ids[:, None] + [0, 1]).ravel()])
    order = np.concatenate([[0, 1, 2], (3 + 2 * np.arange(len(ids))[:, None] + [0, 1]).ravel()])
    np.testing.assert_allclose(cov[np.ix_(slots, slots)], ref.cov[np.ix_(order, order)], atol=1e-6)
    np.testing.assert_array_equal(core.filter.mean, smoother.mean)
    np.testing.assert_array_equal(core.filter.cov, smoother.cov)
    assert info["pose_error"] == pytest.approx(
        float(np.hypot(*(smoother.pose[:2] - info["pose"][:2])))
    )


def test_the_smoothing_map_is_closer_to_the_truth_than_the_filters() -> None:
    """Same worlds, same actions, the default options but the belief: over 10
    episodes of 300 steps the smoother's final map error is below the EKF's on most
    and in the mean (it relinearises what the filter linearised once)."""
    errors = {}
    for belief in ("ekf", "isam2"):
        env = gym.make(ACTIVE, belief=belief)
        errors[belief] = []
        for seed in range(10):
            info = _drive(env, 300, seed)[-1][-1]
            errors[belief].append(info["map_rmse"])
    ekf, isam2 = np.array(errors["ekf"]), np.array(errors["isam2"])
    assert isam2.mean() < ekf.mean()
    assert (isam2 < ekf).sum() >= 6, (ekf, isam2)


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"n_landmarks": 1, "max_range": 1.0, "observation": "full", "fov": 0.5},
        {"observation": "local", "motion_model": "velocity", "measurement_model": "cartesian"},
        {"report_ids": False, "data_association": "jcbb", "smoothing_keyframes": 3},
    ],
)
def test_both_checkers_pass(options: dict) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(ACTIVE, render_mode="rgb_array", **ISAM2, **options)
        gym_check_env(env.unwrapped, skip_render_check=False, skip_close_check=False)
        for seed in range(3):
            check_step_determinism(env.unwrapped, seed=seed)
        sb3_check_env(env.unwrapped, warn=True, skip_render_check=False)
        env.close()


@pytest.mark.parametrize(
    "options",
    [
        {},
        {"report_ids": False, "data_association": "nearest_neighbor", "outlier_rate": 0.1},
        {"smoothing_window": 20, "observation": "full", "n_landmarks": 6},
    ],
)
def test_the_native_vector_env_replays_the_single_envs(options: dict) -> None:
    """Sub-env i equals the single env seeded s + i, on 1 and 2 threads, over 240
    steps that cross episode ends."""
    kwargs = {**ISAM2, **options}
    ends = replay_against_singles(
        ACTIVE, kwargs, b=3, seed=5, steps=240, episode=80, threads=(1, 2), action_seed=1
    )
    assert ends >= 3


def test_a_pickle_continues_the_same_stream() -> None:
    """Pickled mid-episode (the smoothers replay their factors), the copy and the
    original step on to the same observations and infos, bit for bit."""
    env = gym.make(ACTIVE, **ISAM2, observation="full")
    _drive(env, 60, seed=2)
    copy = pickle.loads(pickle.dumps(env))
    assert copy.unwrapped.smoother.n_poses == env.unwrapped.smoother.n_poses == 61
    env.action_space.seed(4)
    for t in range(60):
        action = env.action_space.sample()
        a, b = env.step(action), copy.step(action)
        assert_same(list(a), list(b), f"step {t}")


def test_reset_starts_a_fresh_graph() -> None:
    env = gym.make(ACTIVE, **ISAM2)
    _drive(env, 50, seed=1)
    env.reset(seed=1)
    smoother = env.unwrapped.smoother
    assert smoother.n_poses == 1 and smoother.n_rejected == 0
    np.testing.assert_allclose(smoother.pose, env.unwrapped.filter.pose)
    filters, n = env.unwrapped._core.filters, smoother.n_landmarks
    assert (filters.slot_to_id[0, n:] == -1).all() and (filters.id_to_slot[0] >= -1).all()
    first = gym.make(ACTIVE, **ISAM2)
    first.reset(seed=1)
    np.testing.assert_array_equal(smoother.mean, first.unwrapped.smoother.mean)


@pytest.mark.parametrize("association", ["nearest_neighbor", "jcbb"])
def test_hidden_ids_are_associated_against_the_smoothers_marginal(association: str) -> None:
    """The filter's association runs on the smoothing belief: its IDs are the
    smoother's slots, its scores are reported, and with the default noise it makes
    (almost) no wrong pairing."""
    env = gym.make(ACTIVE, **ISAM2, report_ids=False, data_association=association)
    info = _drive(env, 300, seed=0)[-1][-1]
    smoother = env.unwrapped.smoother
    np.testing.assert_array_equal(smoother.state_to_id, np.arange(smoother.n_landmarks))
    assert info["landmarks_known"] == smoother.n_landmarks >= 5
    scores = info["association_episode"]
    assert scores["correct"] > 100
    assert scores["wrong"] <= 0.01 * scores["correct"]
    assert info["map_rmse"] < 0.2


def test_keyframes_and_window_bound_the_graph() -> None:
    keyed = gym.make(ACTIVE, **ISAM2, smoothing_keyframes=5)
    _drive(keyed, 200, seed=0)
    assert keyed.unwrapped.smoother.n_poses <= 200 // 5 + keyed.unwrapped.smoother.n_landmarks + 1
    windowed = gym.make(ACTIVE, **ISAM2, smoothing_window=10)
    _drive(windowed, 100, seed=0)
    steps, poses = windowed.unwrapped.smoother.trajectory()
    assert poses.shape == (10, 3) and steps[-1] == 100


@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ({"belief": "gtsam"}, ValueError, "belief must be one of"),
        ({**ISAM2, "linearization": "fej"}, ValueError, "relinearises its whole graph"),
        ({"smoothing_window": 5}, ValueError, "applies to belief='isam2'"),
        ({**ISAM2, "smoothing_keyframes": 0}, ValueError, "smoothing_keyframes"),
        ({**ISAM2, "smoothing_window": 2.5}, TypeError, "smoothing_window"),
        ({**ISAM2, "smoothing_relinearize_threshold": -1.0}, ValueError, "relinearize_threshold"),
        ({**ISAM2, "smoothing_relinearize_skip": True}, TypeError, "relinearize_skip"),
    ],
)
def test_bad_options_are_refused(options: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        gym.make(ACTIVE, **options)


def test_the_ekf_belief_has_no_smoother() -> None:
    env = gym.make(ACTIVE)
    with pytest.raises(ValueError, match="no smoother"):
        _ = env.unwrapped.smoother


def test_a_belief_at_its_share_of_the_budget_refuses_the_step_and_changes_nothing() -> None:
    """The smoothing belief records every update of its episode; at its share of the
    memory budget (here lowered to 30 updates) a step is refused before anything
    changes, in the single env and in every chunk of a threaded vector env."""
    env = gym.make(ACTIVE, **ISAM2)
    env.reset(seed=0)
    smoothers = env.unwrapped._core.smoothers
    assert smoothers.max_updates == MAX_MEMORY_BYTES // SMOOTHER_BYTES_PER_UPDATE
    assert smoothers.max_updates == 262_144  # 2 GiB at 8 KB an update (the docs' figure)
    smoothers.max_updates = 30
    action = np.zeros(2, dtype=np.float32)
    while env.unwrapped.smoother.n_updates < 30:
        env.step(action)
    before = pickle.dumps(env.unwrapped._core)
    with pytest.raises(RuntimeError, match="holds 30 updates this episode"):
        env.step(action)
    assert pickle.dumps(env.unwrapped._core) == before
    env.reset(seed=1)  # a new episode starts a new record
    env.step(action)

    venv = gym.make_vec(ACTIVE, num_envs=4, vectorization_mode="vector_entry_point",
                        num_threads=2, **ISAM2)  # fmt: skip
    venv.reset(seed=0)
    assert isinstance(venv.unwrapped.smoother(-1), ISAM2SLAM)
    core = venv.unwrapped.core
    assert core.smoothers.max_updates == smoother_updates(4) == 262_144 // 4
    for _ in range(3):
        venv.step(np.ones((4, 2), dtype=np.float32) * [[0.0], [1.0], [0.0], [1.0]])
    held = [venv.unwrapped.smoother(b).n_updates for b in range(4)]
    core.smoothers.max_updates = most = max(held)  # the first sub-env at it is refused
    poses = core.worlds.poses.copy()
    state = pickle.dumps(core)
    with pytest.raises(RuntimeError, match=f"sub-env {held.index(most)} holds {most} updates"):
        venv.step(np.zeros((4, 2), dtype=np.float32))
    np.testing.assert_array_equal(core.worlds.poses, poses)  # no chunk stepped
    assert pickle.dumps(core) == state
    venv.close()


@pytest.mark.parametrize("refused", [False, True])
def test_a_smoother_takes_only_what_the_filter_step_used(refused: bool) -> None:
    """An observation the filter step initialised reaches the smoother; where that
    step failed (an error code), none does, and the odometry still does."""
    env = gym.make(ACTIVE, **ISAM2, n_landmarks=20)
    env.reset(seed=0)
    core = env.unwrapped._core
    filters, smoothers = core.filters, core.smoothers
    smoother = smoothers[0]
    unseen = next(i for i in range(filters.template.max_landmarks) if smoother.id_to_state[i] < 0)
    had, poses = smoother.n_landmarks, smoother.n_poses
    filters.u[0] = (0.0, 0.1, 0.0)
    filters.counts[0] = 1
    filters.z[0, 0] = (2.0, 0.1)
    filters.ids[0, 0] = unseen
    filters.status[0, 0] = int(Status.INITIALISED)
    filters.error[0] = int(refused)
    failed = np.zeros(1, dtype=bool)
    smoothers.follow(filters, np.ones(1, bool), np.ones(1, bool), failed)
    assert smoother.n_poses == poses + 1  # the odometry, either way
    assert smoother.n_landmarks == had + (not refused)
    assert filters.n[0] == smoother.n_landmarks and not failed[0]
