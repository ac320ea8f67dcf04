"""The raw env, slam_env/Landmarks-v0: spaces, checkers, determinism, vector envs."""

from __future__ import annotations

import math
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

from slam_env.sensing.raw_observation import unpack_detections
from tests.streams import digest, pickled_twin_digests, rollout_digest

ENV_ID = "slam_env/Landmarks-v0"

NON_DEFAULT_CONFIGS = [
    {"n_landmarks": 5, "n_obstacles": 0, "max_range": 3.0},
    {"motion_model": "velocity", "measurement_model": "cartesian"},
    {"preset": "rooms", "action_type": "discrete"},
    {"preset": "open", "max_detections": 3, "detection_prob": 0.7, "fov": 6.283185307179586},
]


@pytest.mark.parametrize("kwargs", [{}, *NON_DEFAULT_CONFIGS])
def test_env_checkers_pass_without_warnings(kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(ENV_ID, **kwargs)
        gym_check_env(env.unwrapped)
        sb3_check_env(env.unwrapped, warn=True)
        env.close()


@pytest.mark.parametrize("kwargs", [{}, NON_DEFAULT_CONFIGS[1], NON_DEFAULT_CONFIGS[3]])
def test_random_rollout_stays_inside_the_space(kwargs):
    env = gym.make(ENV_ID, **kwargs)
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    seen_detection = False
    for _ in range(1000):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs), obs
        assert type(reward) is float
        assert type(terminated) is bool and type(truncated) is bool
        assert type(info["collision"]) is bool
        seen_detection |= bool(obs["mask"].any())
        if terminated or truncated:
            env.reset()
    assert seen_detection


def test_observation_encoding_matches_the_docstring():
    env = gym.make(ENV_ID, n_landmarks=8, range_std=0.0, bearing_std=0.0)
    obs, info = env.reset(seed=3)
    for _ in range(30):
        if obs["mask"].any():
            break
        obs, *_, info = env.step(np.array([0.0, 1.0], dtype=np.float32))
    mask = obs["mask"].astype(bool)
    assert mask.any()
    k = int(mask.sum())
    assert mask[:k].all() and not mask[k:].any()  # detections first, then padding
    ids = obs["ids"][mask].astype(int)
    assert (obs["ids"][~mask] == -1).all()
    assert np.all(np.diff(ids) > 0)  # sorted by ID
    # With noise off, [r, φ] are the exact geometry of the true landmark.
    x, y, th = info["pose"]
    truth = dict(zip(info["landmark_ids"].tolist(), info["landmark_positions"], strict=True))
    for (r, phi), lid in zip(obs["detections"].reshape(-1, 2)[mask], ids, strict=True):
        dx, dy = truth[lid] - np.array([x, y])
        assert r == pytest.approx(np.hypot(dx, dy), abs=1e-5)
        expected = (np.arctan2(dy, dx) - th + np.pi) % (2 * np.pi) - np.pi
        assert phi == pytest.approx(expected, abs=1e-5)


def test_detections_are_sorted_by_id_when_the_layout_lists_ids_out_of_order():
    """A user layout's rows need not be in ID order: the observation still lists the
    detections by ascending ID, the same ones the public sensor API finds."""
    rng = np.random.default_rng(11)
    ids = rng.permutation(np.arange(3, 15)).tolist()
    xy = rng.uniform(1.0, 9.0, (len(ids), 2)).tolist()
    landmarks = [{"id": i, "x": x, "y": y} for i, (x, y) in zip(ids, xy, strict=True)]
    layout = {"width": 10.0, "height": 10.0, "landmarks": landmarks, "start": [5, 5, 0]}
    env = gym.make(ENV_ID, layout=layout, range_std=0.0, bearing_std=0.0, fov=2 * math.pi)
    env.action_space.seed(1)
    env.reset(seed=1)
    raw = env.unwrapped
    found = 0
    for _ in range(40):
        obs, _, _, _, info = env.step(env.action_space.sample())
        z, got = unpack_detections(obs)
        assert got.tolist() == sorted(got.tolist())
        det = raw.sensor.sense(
            info["pose"],
            info["landmark_positions"],
            info["landmark_ids"],
            np.random.default_rng(0),
            line_of_sight=raw.world.line_of_sight,
        )
        assert got.tolist() == det.ids.tolist()
        assert np.array_equal(z, det.z.astype(np.float32).astype(np.float64))
        found += len(got) > 1
    assert found > 10  # several detections at once, in an order to fix


def test_info_carries_ground_truth_and_the_observation_does_not():
    env = gym.make(ENV_ID)
    obs, info = env.reset(seed=1)
    assert set(obs) == {"odometry", "detections", "ids", "mask"}
    assert info["pose"].shape == (3,)
    assert info["landmark_positions"].shape == (20, 2)
    assert sorted(info["landmark_ids"].tolist()) == list(range(20))
    # Fresh copies: mutating what we got does not change the env.
    info["landmark_positions"][:] = 0
    _, _, _, _, info2 = env.step(env.action_space.sample())
    assert np.abs(info2["landmark_positions"]).sum() > 0


def test_seeded_rollouts_are_bit_identical_in_process():
    a = rollout_digest(ENV_ID, seed=7, steps=300)
    b = rollout_digest(ENV_ID, seed=7, steps=300)
    c = rollout_digest(ENV_ID, seed=8, steps=300)
    assert a == b
    assert a != c


def test_seeded_rollouts_are_bit_identical_across_processes():
    code = (
        "from tests.streams import rollout_digest;"
        f"print(rollout_digest({ENV_ID!r}, seed=7, steps=300))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert out == rollout_digest(ENV_ID, seed=7, steps=300)


def test_pickle_mid_episode_continues_identically():
    original, copy = pickled_twin_digests(ENV_ID, seed=5, warmup=40)
    assert original == copy


def test_reset_draws_a_new_random_world_and_same_seed_gives_same_world():
    env = gym.make(ENV_ID)
    _, a = env.reset(seed=11)
    _, b = env.reset(seed=12)
    _, c = env.reset(seed=11)
    assert not np.allclose(a["landmark_positions"], b["landmark_positions"])
    np.testing.assert_array_equal(a["landmark_positions"], c["landmark_positions"])


def test_first_detection_bonus_and_collision_penalty():
    env = gym.make(ENV_ID, preset="open", collision_penalty=0.5, new_landmark_bonus=2.0)
    env.reset(seed=0)
    rewards, terms, collisions = [], [], []
    for _ in range(150):
        _, r, _, _, info = env.step(np.array([1.0, 0.3], dtype=np.float32))
        rewards.append(r)
        terms.append(info["reward_terms"])
        collisions.append(info["collision"])
    for r, t, c in zip(rewards, terms, collisions, strict=True):
        assert r == pytest.approx(sum(t.values()))
        assert t["collision"] == (-0.5 if c else 0.0)
        assert t["new_landmarks"] % 2.0 == 0.0
    assert sum(t["new_landmarks"] for t in terms) > 0


def test_terminates_when_all_detected_if_asked():
    # A narrow, long-range sensor turning in place sweeps the whole arena in one turn.
    options = {"n_landmarks": 3, "n_obstacles": 0, "max_range": 30.0, "fov": 0.5}
    env = gym.make(ENV_ID, terminate_when_all_detected=True, **options)
    _, info = env.reset(seed=2)
    turn = np.array([0.0, 1.0], dtype=np.float32)
    for _ in range(60):
        _, _, terminated, truncated, info = env.step(turn)
        assert not truncated
        assert terminated == (int(info["seen"].sum()) == 3)
        if terminated:
            break
    assert terminated
    # Without the option the same run goes on.
    plain = gym.make(ENV_ID, **options)
    plain.reset(seed=2)
    assert not any(plain.step(turn)[2] for _ in range(60))


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_make_vec(mode):
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode=mode)
    obs, _ = envs.reset(seed=[1, 2])
    assert obs["detections"].shape == (2, 40)
    for _ in range(20):
        obs, _rewards, _term, _trunc, _info = envs.step(envs.action_space.sample())
        assert envs.observation_space.contains(obs)
    envs.close()


def test_subproc_vec_env():
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import SubprocVecEnv

    # Worker processes start fresh: the "module:" prefix imports slam_env there.
    venv = make_vec_env(f"slam_env:{ENV_ID}", n_envs=2, seed=0, vec_env_cls=SubprocVecEnv)
    obs = venv.reset()
    assert obs["mask"].shape == (2, 20)
    for _ in range(10):
        obs, rewards, _dones, _infos = venv.step(np.stack([venv.action_space.sample()] * 2))
        assert rewards.shape == (2,)
    venv.close()


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    ("action", "error", "match"),
    [
        (np.array([np.nan, 0.0]), ValueError, "finite"),
        (np.array([0.0, np.inf]), ValueError, "finite"),
        (np.zeros(3), ValueError, "shape"),
        (np.zeros((1, 2)), ValueError, "shape"),
        ("forward", TypeError, "numeric"),
    ],
)
def test_bad_actions_raise(action, error, match):
    env = gym.make(ENV_ID)
    env.reset(seed=0)
    with pytest.raises(error, match=match):
        env.unwrapped.step(action)
    # A rejected action leaves the env usable.
    _, r, *_ = env.step(np.zeros(2, dtype=np.float32))
    assert type(r) is float


def test_out_of_range_actions_are_clipped():
    a = gym.make(ENV_ID)
    b = gym.make(ENV_ID)
    a.reset(seed=4)
    b.reset(seed=4)
    oa = a.step(np.array([5.0, -3.0]))
    ob = b.step(np.array([1.0, -1.0]))
    assert digest(oa) == digest(ob)


@pytest.mark.parametrize("action", [7, -1, 2.5, np.array([1, 2])])
def test_bad_discrete_actions_raise(action):
    env = gym.make(ENV_ID, action_type="discrete")
    env.reset(seed=0)
    with pytest.raises((ValueError, TypeError), match="discrete action"):
        env.unwrapped.step(action)


def test_misspelt_option_is_an_error():
    with pytest.raises(TypeError, match="unexpected keyword argument 'n_landmark'"):
        gym.make(ENV_ID, n_landmark=5)
    with pytest.raises(TypeError, match="unknown sensor option 'range'"):
        gym.make(ENV_ID, sensor={"range": 3.0})


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_range": -1.0}, "max_range"),
        ({"n_landmarks": 0}, "n_landmarks"),
        ({"dt": float("nan")}, "dt"),
        ({"preset": "maze"}, "preset"),
        ({"alphas": (0.1, 0.1, 0.1)}, "alphas"),
        ({"detection_prob": 1.5}, "detection_prob"),
        ({"bumper": 1}, "bumper must be a bool"),
        ({"render_mode": "ascii"}, "render_mode"),
    ],
)
@pytest.mark.filterwarnings("ignore:.*render_mode:UserWarning")  # gym.make's own notice
def test_invalid_configs_raise(kwargs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        gym.make(ENV_ID, **kwargs)


def test_a_world_without_landmarks_is_refused():
    with pytest.raises(ValueError, match="no landmarks"):
        gym.make(ENV_ID, layout={"width": 5.0, "height": 5.0, "landmarks": [], "start": [1, 1, 0]})


@pytest.mark.parametrize("kwargs", [{}, *NON_DEFAULT_CONFIGS])
def test_returned_arrays_are_fresh_and_typed(kwargs):
    """Every array in an observation or info is new: scribbling over all of them after
    each step changes nothing the env does next (no aliasing of its buffers)."""
    clean, dirty = gym.make(ENV_ID, **kwargs), gym.make(ENV_ID, **kwargs)
    clean.action_space.seed(8)
    actions = [clean.action_space.sample() for _ in range(120)]
    outputs = {}
    for name, env in (("clean", clean), ("dirty", dirty)):
        obs, info = env.reset(seed=8)
        trace = [digest(obs, info)]
        for action in actions:
            if name == "dirty":
                for value in [*obs.values(), *info.values()]:
                    if isinstance(value, np.ndarray):
                        value[...] = 7
            obs, reward, terminated, truncated, info = env.step(action)
            assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
            assert all(v.dtype == np.float32 for v in obs.values())
            assert env.observation_space.contains(obs)
            trace.append(digest(obs, reward, terminated, truncated, info))
        outputs[name] = trace
    assert outputs["clean"] == outputs["dirty"]


def test_proximity_scan_is_optional_and_normalised():
    assert "scan" not in gym.make(ENV_ID).observation_space.spaces
    layout = {"width": 10.0, "height": 10.0, "landmarks": [[9.5, 9.5]], "start": [3.0, 5.0, 0.4]}
    env = gym.make(ENV_ID, layout=layout, scan_beams=8, scan_range=4.0)
    obs, _ = env.reset(seed=0)
    assert obs["scan"].shape == (8,) and env.observation_space.contains(obs)
    # Beam i points at −π + 2π(i + ½)/8 from the heading; only the arena's walls are
    # near, so each reading is the distance to the boundary (capped at the range).
    for i, reading in enumerate(obs["scan"].tolist()):
        a = 0.4 - math.pi + 2 * math.pi * (i + 0.5) / 8
        c, s = math.cos(a), math.sin(a)
        to_x = (0.0 - 3.0) / c if c < 0 else (10.0 - 3.0) / c
        to_y = (0.0 - 5.0) / s if s < 0 else (10.0 - 5.0) / s
        assert reading == pytest.approx(min(to_x, to_y, 4.0) / 4.0, abs=1e-6)


def test_bumper_reports_the_blocked_steps():
    assert "bumper" not in gym.make(ENV_ID).observation_space.spaces
    layout = {"width": 6.0, "height": 6.0, "landmarks": [[5.5, 5.5]], "start": [4.5, 3.0, 0.0]}
    env = gym.make(ENV_ID, layout=layout, bumper=True)
    obs, _ = env.reset(seed=0)
    assert obs["bumper"].tolist() == [0.0]
    readings, collisions = [], []
    for _ in range(15):  # into the east wall, then away from it
        obs, _, _, _, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        assert env.observation_space.contains(obs)
        readings.append(obs["bumper"][0])
        collisions.append(info["collision"])
    obs, _, _, _, info = env.step(np.array([-1.0, 0.0], dtype=np.float32))
    readings.append(obs["bumper"][0])
    collisions.append(info["collision"])
    assert readings == [float(c) for c in collisions]
    assert collisions[0] is False and collisions[-2] is True and collisions[-1] is False


def test_record_video_of_the_env(tmp_path):
    from gymnasium.wrappers import RecordVideo

    env = RecordVideo(
        gym.make(ENV_ID, render_mode="rgb_array", max_episode_steps=12),
        str(tmp_path / "videos"),
        episode_trigger=lambda episode: True,
        disable_logger=True,
    )
    env.reset(seed=0)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        done = terminated or truncated
    env.close()
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000


@pytest.mark.parametrize("motion_model", ["odometry", "velocity"])
def test_the_odometry_reads_the_first_uniforms_of_its_step(motion_model) -> None:
    # A step's uniforms are laid out as the odometry reading's, then the scan's, then
    # the faults' (RawCore): the reading is the model's noisy control at the first ones.
    from slam_env.kernels.stream.odometry import noisy_control

    env = gym.make(ENV_ID, motion_model=motion_model)
    env.reset(seed=4)
    core = env.unwrapped._core
    rng = np.random.default_rng(4)
    for _ in range(40):
        env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32))
        true = core.control_true[0].tolist() + [0.0] * (3 - core.control_dim)
        expected = noisy_control(
            core.velocity_model, *true, core._noise, core.blocks.uniforms[0], 0
        )
        assert core.control[0].tolist() == list(expected[: core.control_dim])
