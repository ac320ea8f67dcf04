"""The native vector envs: sub-env i replays the single env seeded s + i, Gymnasium's
vector conventions (spaces, autoreset, seeding, info masks), and the other modes."""

from __future__ import annotations

import pickle
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.envs.vector import SlamVectorEnv
from tests.streams import assert_same, digest

LANDMARKS = "slam_env/Landmarks-v0"
ACTIVE = "slam_env/ActiveSLAM-v0"

# (env ID, options): the default world and non-default configs of every kind.
CONFIGS = [
    (LANDMARKS, {}),
    (
        LANDMARKS,
        {
            "outlier_rate": 0.3,
            "scan_dropout": 0.1,
            "odometry_dropout": 0.1,
            "kidnap_rate": 0.02,
            "odometry_bias": (0.01, 0.0, -0.01),
            "scan_beams": 8,
            "bumper": True,
        },
    ),
    (LANDMARKS, {"motion_model": "velocity", "measurement_model": "cartesian"}),
    (LANDMARKS, {"preset": "rooms", "action_type": "discrete"}),
    (LANDMARKS, {"preset": "open", "max_detections": 3, "detection_prob": 0.7, "fov": 6.28}),
    (ACTIVE, {}),
    (ACTIVE, {"observation": "full", "n_landmarks": 6, "outlier_rate": 0.2, "kidnap_rate": 0.01}),
    (ACTIVE, {"motion_model": "velocity", "measurement_model": "cartesian"}),
    (
        ACTIVE,
        {
            "action_type": "discrete",
            "correction": "batch",
            "preset": "rooms",
            "linearization": "invariant",
        },
    ),
    (ACTIVE, {"observation": "local", "n_landmarks": 6, "outlier_rate": 0.2}),
]


# The thread counts the streams are compared across (T = 1: one core, today's path).
THREADS = (1, 2, 3)


def _row(tree: Any, i: int) -> Any:
    """Sub-env i's part of a batched observation or vector info: the keys its masks
    say it reported (the masks themselves dropped)."""
    if isinstance(tree, dict):
        return {
            k: _row(v, i)
            for k, v in tree.items()
            if not k.startswith("_") and (f"_{k}" not in tree or tree[f"_{k}"][i])
        }
    return tree[i]


def replay_against_singles(
    env_id: str,
    options: dict,
    b: int,
    seed: int,
    steps: int,
    episode: int,
    threads: tuple[int, ...] = THREADS,
    action_seed: int = 0,
) -> int:
    """Step vector envs of ``b`` sub-envs on each of ``threads`` in lockstep with ``b``
    single envs (sub-env i against the single env reset with seed ``seed + i``, then
    reset without a seed, as a user would), the same random actions, episodes of
    ``episode`` steps, for ``steps`` steps: observations, rewards, flags and infos must
    be bit-identical. Returns the episode ends the singles crossed."""
    venvs = {
        t: gym.make_vec(
            env_id,
            num_envs=b,
            vectorization_mode="vector_entry_point",
            max_episode_steps=episode,
            num_threads=t,
            **options,
        )
        for t in threads
    }
    singles = [gym.make(env_id, max_episode_steps=episode, **options) for _ in range(b)]
    space = venvs[threads[0]].action_space
    space.seed(action_seed)
    results = {t: venv.reset(seed=seed) for t, venv in venvs.items()}
    for i, env in enumerate(singles):
        o, inf = env.reset(seed=seed + i)
        for t, (obs, info) in results.items():
            assert_same(_row(obs, i), o, f"reset obs T={t}", exact_types=False)
            assert_same(_row(info, i), inf, f"reset info T={t}", exact_types=False)
    done = [False] * b
    ends = 0
    for step in range(steps):
        actions = space.sample()
        stepped = {t: venv.step(actions) for t, venv in venvs.items()}
        for i, env in enumerate(singles):
            if done[i]:
                o, inf = env.reset()
                r, te, tr = 0.0, False, False
            else:
                o, r, te, tr, inf = env.step(actions[i])
            done[i] = te or tr
            ends += done[i]
            for t, (obs, rewards, terminated, truncated, info) in stepped.items():
                where = f"t={step} i={i} T={t}"
                assert i or venvs[t].observation_space.contains(obs), where
                assert_same(_row(obs, i), o, f"obs {where}", exact_types=False)
                assert_same(_row(info, i), inf, f"info {where}", exact_types=False)
                assert (rewards[i], terminated[i], truncated[i]) == (r, te, tr), where
    for _, rewards, terminated, truncated, _ in stepped.values():
        assert rewards.dtype == np.float64 and terminated.dtype == truncated.dtype == np.bool_
    for venv in venvs.values():
        venv.close()
    return ends


@pytest.mark.parametrize(("env_id", "options"), CONFIGS)
def test_sub_env_i_replays_the_single_env_seeded_s_plus_i(env_id: str, options: dict) -> None:
    """Observations, rewards, flags and infos bit-identical over 1,000 steps that
    cross several episode ends (short episodes), each sub-env against its own single
    env reset with seed s + i and then reset without a seed, as a user would; for
    vector envs on 1, 2 and 3 threads alike (B = 5: chunks of 5; 3 + 2; 2 + 2 + 1),
    stepped in lockstep with the same actions."""
    b = 5
    ends = replay_against_singles(env_id, options, b, seed=11, steps=1000, episode=150)
    assert ends >= 3 * b  # the streams crossed resets


def _rollout(venv: gym.vector.VectorEnv, steps: int) -> list[Any]:
    venv.action_space.seed(5)
    out = [venv.reset(seed=[3, 9])]
    for _ in range(steps):
        out.append(venv.step(venv.action_space.sample()))
    venv.close()
    return out


@pytest.mark.parametrize("env_id", [LANDMARKS, ACTIVE])
@pytest.mark.parametrize("mode", ["sync", "async"])
def test_sync_and_async_give_the_native_stream(env_id: str, mode: str) -> None:
    native = _rollout(gym.make_vec(env_id, num_envs=2, max_episode_steps=40), 120)
    other = _rollout(
        gym.make_vec(env_id, num_envs=2, vectorization_mode=mode, max_episode_steps=40), 120
    )
    for t, (a, b) in enumerate(zip(native, other, strict=True)):
        assert_same(list(a), list(b), f"step {t}")
    assert digest(native) == digest(other)


def test_the_native_env_is_the_default_mode_and_declares_its_autoreset() -> None:
    venv = gym.make_vec(LANDMARKS, num_envs=2)
    assert isinstance(venv.unwrapped, SlamVectorEnv)
    assert venv.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert venv.single_observation_space == gym.make(LANDMARKS).observation_space
    assert venv.observation_space["mask"].shape == (2, 20)


def test_same_step_autoreset_reports_the_final_observation_and_info() -> None:
    kwargs = {"num_envs": 2, "max_episode_steps": 5}
    same = gym.make_vec(LANDMARKS, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
    sync = gym.make_vec(
        LANDMARKS,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP},
        **kwargs,
    )
    assert same.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    for venv in (same, sync):
        venv.reset(seed=1)
    actions = np.zeros((2, 2), dtype=np.float32)
    for t in range(5):
        a = same.step(actions)
        b = sync.step(actions)
        assert_same([a[0], *a[1:4]], [b[0], *b[1:4]], f"step {t}")
        assert a[4].keys() == b[4].keys()
    info = a[4]
    assert a[3].all() and info["_final_obs"].all()
    for i in range(2):
        assert_same(info["final_obs"][i], b[4]["final_obs"][i], "final_obs")
    assert_same(info["final_info"], b[4]["final_info"], "final_info")
    # the returned observation is the next episode's first one
    assert (a[0]["odometry"] == 0.0).all()


def test_reset_seeds_each_sub_env_and_continues_without_a_seed() -> None:
    venv = gym.make_vec(LANDMARKS, num_envs=3)
    first, _ = venv.reset(seed=[4, None, 6])
    again, _ = venv.reset(seed=[4, 5, 6])
    np.testing.assert_array_equal(first["detections"][[0, 2]], again["detections"][[0, 2]])
    # A reset without a seed continues each sub-env's generator: a new random world.
    _, info_a = venv.reset()
    _, info_b = venv.reset()
    assert not np.array_equal(info_a["landmark_positions"], info_b["landmark_positions"])
    with pytest.raises(ValueError, match="3 seeds"):
        venv.reset(seed=[1, 2])
    with pytest.raises(ValueError, match="options"):
        venv.reset(options={"x": 1})


def test_bad_input_is_refused_clearly() -> None:
    venv = gym.make_vec(LANDMARKS, num_envs=2)
    with pytest.raises(gym.error.ResetNeeded):
        venv.step(np.zeros((2, 2), dtype=np.float32))
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        venv.step(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="finite"):
        venv.step(np.array([[0.0, 0.0], [np.nan, 0.0]]))
    with pytest.raises(ValueError, match="num_envs"):
        gym.make_vec(LANDMARKS, num_envs=0)
    with pytest.raises(TypeError, match="unexpected keyword argument 'n_landmark'"):
        gym.make_vec(LANDMARKS, num_envs=2, n_landmark=3)
    discrete = gym.make_vec(LANDMARKS, num_envs=2, action_type="discrete")
    discrete.reset(seed=0)
    with pytest.raises(ValueError, match="discrete actions"):
        discrete.step(np.array([0, 7]))


def test_pickled_vector_env_continues_identically() -> None:
    venv = gym.make_vec(LANDMARKS, num_envs=2, scan_beams=4)
    venv.action_space.seed(2)
    venv.reset(seed=2)
    for _ in range(30):
        venv.step(venv.action_space.sample())
    twin = pickle.loads(pickle.dumps(venv))
    actions = [venv.action_space.sample() for _ in range(60)]
    assert digest([venv.step(a) for a in actions]) == digest([twin.step(a) for a in actions])


def test_render_returns_a_frame_per_sub_env_and_close_releases_them() -> None:
    venv = gym.make_vec(LANDMARKS, num_envs=2, render_mode="rgb_array")
    venv.reset(seed=0)
    venv.step(venv.action_space.sample())
    frames = venv.render()
    assert len(frames) == 2
    assert all(f.dtype == np.uint8 and f.ndim == 3 and f.shape[2] == 3 for f in frames)
    assert not np.array_equal(frames[0], frames[1])  # two different random worlds
    venv.close()
    assert venv.closed


def test_the_budget_counts_every_sub_env() -> None:
    """One sub-env fits, but the memory of many is refused before anything is built."""
    options = {"n_landmarks": 1000, "width": 100.0, "height": 100.0, "landmark_spacing": 0.5}
    gym.make_vec(LANDMARKS, num_envs=1, **options).close()
    with pytest.raises(ValueError, match="memory"):
        gym.make_vec(LANDMARKS, num_envs=100_000, **options)
