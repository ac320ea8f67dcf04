"""Gymnasium's whole vector API on the native vector envs of both IDs, checked as
Gymnasium's own env and vector test suites check theirs (``tests/envs/test_envs.py``,
``tests/vector/test_autoreset_mode.py``, ``tests/vector/test_vector_env.py``,
``tests/envs/registration/test_make_vec.py``): every autoreset mode and ``reset_mask``
bit for bit against :class:`gymnasium.vector.SyncVectorEnv` over the same IDs, refused
calls that change nothing, the frames of the single env, determinism, pickling, the
render modes and the spec's kwargs."""

from __future__ import annotations

import copy
import pickle
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import slam_env  # noqa: F401  (registers the env IDs)
from slam_env.envs.vector import SlamVectorEnv
from tests.streams import digest

LANDMARKS = "slam_env/Landmarks-v0"
ACTIVE = "slam_env/ActiveSLAM-v0"
IDS = [LANDMARKS, ACTIVE]
MODES = [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP, AutoresetMode.DISABLED]
# One landmark and a 3 m range: seeds 1, 2 and 4 find it at different times, so that
# the vector info's map_rmse mask differs between sub-envs and over time.
FEW = {"n_landmarks": 1, "max_range": 3.0}


def assert_equal(a: Any, b: Any, where: str = "") -> None:
    """``a`` and ``b`` (observations, rewards, flags, infos, nested in dicts, tuples and
    object arrays) equal bit for bit, of the same Python types and numpy dtypes."""
    assert type(a) is type(b), (where, type(a), type(b))
    if isinstance(a, dict):
        assert a.keys() == b.keys(), (where, sorted(set(a) ^ set(b)))
        for key in a:
            assert_equal(a[key], b[key], f"{where}/{key}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_equal(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        assert (a.dtype, a.shape) == (b.dtype, b.shape), (where, a.dtype, b.dtype, a.shape)
        if a.dtype == object:
            for i, (x, y) in enumerate(zip(a.ravel(), b.ravel(), strict=True)):
                assert_equal(x, y, f"{where}[{i}]")
        else:
            assert np.array_equal(a, b), (where, a, b)
    else:
        assert a == b, (where, a, b)


def native(env_id: str, num_envs: int, **kwargs: Any) -> SlamVectorEnv:
    return gym.make_vec(
        env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs
    )


def sync(env_id: str, num_envs: int, autoreset_mode: AutoresetMode, **kwargs: Any) -> Any:
    return gym.make_vec(
        env_id,
        num_envs=num_envs,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": autoreset_mode},
        **kwargs,
    )


def _state(venv: SlamVectorEnv) -> str:
    """A digest of what a vector env would do next: its sub-envs' generators and the
    next 40 steps of a twin (a pickled copy, so that the env itself is not moved)."""
    twin = pickle.loads(pickle.dumps(venv))
    rngs = [rng.bit_generator.state for rng in venv.core.rngs]
    twin.action_space.seed(0)
    steps = []
    if twin._autoreset.any() and twin.metadata["autoreset_mode"] == AutoresetMode.DISABLED:
        steps.append(twin.reset(options={"reset_mask": twin._autoreset.copy()}))
    for _ in range(40):
        out = twin.step(twin.action_space.sample())
        steps.append(out)
        done = out[2] | out[3]
        if twin.metadata["autoreset_mode"] == AutoresetMode.DISABLED and done.any():
            steps.append(twin.reset(options={"reset_mask": done}))
    return digest(repr(rngs), steps)


# ---------------------------------------------------------------------- autoreset modes
@pytest.mark.parametrize("mode", MODES)
def test_the_autoreset_mode_is_an_attribute_and_in_the_metadata(mode: AutoresetMode) -> None:
    for given in (mode, mode.value):
        venv = native(LANDMARKS, 2, autoreset_mode=given)
        assert venv.autoreset_mode is mode
        assert venv.metadata["autoreset_mode"] is mode
        venv.close()
    with pytest.raises(ValueError, match="autoreset_mode"):
        native(LANDMARKS, 2, autoreset_mode="sometimes")


# The masked resets of the NEXT_STEP and SAME_STEP runs: (after step t, mask), staggering
# the sub-envs' episodes; the one after step 15 comes as all three end at once.
SCHEDULE = {
    5: [True, False, False],
    15: [False, True, True],
    31: [True, False, True],
    44: [False, False, True],
}


@pytest.mark.parametrize("mode", MODES, ids=[m.value for m in MODES])
@pytest.mark.parametrize(
    ("env_id", "options"),
    [
        (LANDMARKS, {}),
        (LANDMARKS, {"kidnap_rate": 0.05, "outlier_rate": 0.2, "scan_beams": 4}),
        (ACTIVE, FEW),
        (ACTIVE, {**FEW, "observation": "full"}),
    ],
)
def test_every_autoreset_mode_and_reset_mask_match_sync_vector_env(
    env_id: str, options: dict, mode: AutoresetMode
) -> None:
    """Observations, rewards, flags and infos (with their ``_key`` masks, and
    ``final_obs``/``final_info`` in SAME_STEP) equal SyncVectorEnv's bit for bit over
    60 steps with short episodes, masked resets (with and without seeds) in every
    mode, and in DISABLED mode the ended sub-envs reset by the user with a mask."""
    b, episode = 3, 15
    ours = native(env_id, b, autoreset_mode=mode, max_episode_steps=episode, **options)
    theirs = sync(env_id, b, mode, max_episode_steps=episode, **options)
    assert isinstance(theirs, SyncVectorEnv)
    assert ours.metadata["autoreset_mode"] == theirs.metadata["autoreset_mode"] == mode
    assert_equal(ours.reset(seed=[1, 2, 4]), theirs.reset(seed=[1, 2, 4]), "reset")
    ours.action_space.seed(3)
    ended = np.zeros(b, dtype=int)
    masked = 0
    for t in range(1, 61):
        actions = ours.action_space.sample()
        step = ours.step(actions)
        assert_equal(step, theirs.step(actions), f"step {t}")
        assert ours.observation_space.contains(step[0])
        done = step[2] | step[3]
        ended += done
        mask = np.array(SCHEDULE.get(t, [False] * b))
        if mode == AutoresetMode.DISABLED:
            mask |= done  # the user resets what ended
        if mask.any():
            # Seeds for some (those not masked are not used), or none.
            seed = [10 * t + i if i % 2 else None for i in range(b)] if t % 2 else None
            got = ours.reset(seed=seed, options={"reset_mask": mask.copy()})
            want = theirs.reset(seed=seed, options={"reset_mask": mask.copy()})
            assert_equal(got, want, f"masked reset after step {t}")
            masked += 1
    assert (ended >= 2).all() and masked >= 4  # every sub-env's episodes ended twice
    ours.close()
    theirs.close()


def test_reset_mask_resets_only_those_sub_envs() -> None:
    """The masked sub-env starts anew as the single env seeded so; the others keep
    their observations and episodes, and the info reports only the masked one."""
    venv = native(LANDMARKS, 3)
    venv.reset(seed=0)
    venv.action_space.seed(0)
    for _ in range(10):
        before = venv.step(venv.action_space.sample())[0]
    mask = np.array([False, True, False])
    obs, info = venv.reset(seed=[None, 40, None], options={"reset_mask": mask})
    single, single_info = gym.make(LANDMARKS).reset(seed=40)
    for key in obs:
        np.testing.assert_array_equal(obs[key][[0, 2]], before[key][[0, 2]])
        np.testing.assert_array_equal(obs[key][1], single[key])
    for key in single_info:
        np.testing.assert_array_equal(info[f"_{key}"], mask)
    np.testing.assert_array_equal(info["pose"][1], single_info["pose"])
    assert not info["pose"][[0, 2]].any()  # zeros, as Gymnasium fills what is not reported
    # The other sub-envs' episodes go on: they truncate 500 steps after their reset.
    for t in range(11, 501):
        _, _, _, truncated, _ = venv.step(np.zeros((3, 2), np.float32))
        assert list(truncated) == [t == 500, False, t == 500]


def test_disabled_mode_refuses_to_step_an_ended_sub_env_until_it_is_reset() -> None:
    venv = native(LANDMARKS, 2, autoreset_mode="Disabled", max_episode_steps=3)
    venv.reset(seed=0)
    idle = np.zeros((2, 2), np.float32)
    for _ in range(3):
        _, _, _, truncated, _ = venv.step(idle)
    assert truncated.all()
    before = _state(venv)
    with pytest.raises(ResetNeeded, match=r"sub-envs \[0, 1\].*reset_mask"):
        venv.step(idle)
    assert _state(venv) == before
    venv.reset(options={"reset_mask": np.array([True, False])})
    with pytest.raises(ResetNeeded, match=r"sub-envs \[1\]"):
        venv.step(idle)
    venv.reset(options={"reset_mask": np.array([False, True])})
    _, _, _, truncated, _ = venv.step(idle)
    assert not truncated.any()


# ---------------------------------------------------------------------- refused resets
BAD_OPTIONS = [
    ({"reset_mask": [True, False, True]}, TypeError, "numpy array"),
    ({"reset_mask": np.array([1, 0, 1])}, TypeError, "dtype"),
    ({"reset_mask": np.array([True, False])}, ValueError, r"shape \(3,\)"),
    ({"reset_mask": np.array([[True, False, True]])}, ValueError, r"shape \(3,\)"),
    ({"reset_mask": np.zeros(3, bool)}, ValueError, "at least one"),
    ({"reset_mask": np.ones(3, bool), "x": 1}, ValueError, r"only reset_mask.*\['x'\]"),
    ({"difficulty": 2}, ValueError, r"only reset_mask.*\['difficulty'\]"),
    ([("reset_mask", np.ones(3, bool))], TypeError, "dict"),
]


@pytest.mark.parametrize(("options", "error", "match"), BAD_OPTIONS)
def test_a_refused_reset_option_changes_nothing(options: Any, error: type, match: str) -> None:
    venv = native(LANDMARKS, 3, max_episode_steps=20)
    venv.reset(seed=0)
    venv.action_space.seed(1)
    for _ in range(7):
        venv.step(venv.action_space.sample())
    before = _state(venv)
    given = copy.deepcopy(options)
    with pytest.raises(error, match=match):
        venv.reset(seed=5, options=options)
    assert _state(venv) == before
    assert repr(options) == repr(given)  # the caller's options are left as they were


def test_issue_48_a_bad_seed_mid_list_reseeds_no_sub_env() -> None:
    """The report's case: ``reset(seed=[5, -1, 7])`` mid-episode raises, and sub-env 0,
    whose seed came before the bad one, goes on as if the call had not been made."""
    venv = native(LANDMARKS, 3)
    venv.reset(seed=0)
    venv.action_space.seed(1)
    for _ in range(7):
        venv.step(venv.action_space.sample())
    before = _state(venv)
    with pytest.raises(gym.error.Error):
        venv.reset(seed=[5, -1, 7])
    assert _state(venv) == before


BAD_SEEDS = [
    ([5, -1, 7], gym.error.Error, r"seed\[1\] \(sub-env 1\).*greater or equal to zero"),
    ([5, 6, 1.5], gym.error.Error, r"seed\[2\] \(sub-env 2\).*integer"),
    ([5, "6", 7], gym.error.Error, r"seed\[1\] \(sub-env 1\).*integer"),
    ([5, 6], ValueError, "3 seeds"),
    (-2, gym.error.Error, r"seed\[0\] \(sub-env 0\).*greater or equal to zero"),
    ("seven", TypeError, "seed must be"),
]


@pytest.mark.parametrize(("seed", "error", "match"), BAD_SEEDS)
@pytest.mark.parametrize("masked", [False, True])
def test_a_refused_seed_changes_nothing(seed: Any, error: type, match: str, masked: bool) -> None:
    """Issue #48: ``reset(seed=[5, -1, 7])`` mid-episode used to reseed sub-env 0
    before it met the bad seed; every seed is now checked before anything moves."""
    venv = native(ACTIVE, 3, max_episode_steps=20)
    venv.reset(seed=0)
    venv.action_space.seed(1)
    for _ in range(7):
        venv.step(venv.action_space.sample())
    before = _state(venv)
    options = {"reset_mask": np.array([True, True, True])} if masked else None
    with pytest.raises(error, match=match):
        venv.reset(seed=seed, options=options)
    assert _state(venv) == before


def test_a_partial_reset_before_the_first_reset_is_refused() -> None:
    venv = native(LANDMARKS, 2)
    with pytest.raises(ResetNeeded, match="reset"):
        venv.reset(options={"reset_mask": np.array([True, False])})
    with pytest.raises(ResetNeeded):
        venv.step(np.zeros((2, 2), np.float32))
    obs, _ = venv.reset(seed=3, options={"reset_mask": np.array([True, True])})  # all: fine
    assert_equal(obs, native(LANDMARKS, 2).reset(seed=3)[0])


# ---------------------------------------------------------------------- filter
def test_filter_takes_an_index_as_python_sequences_do() -> None:
    venv = native(ACTIVE, 3)
    venv.reset(seed=0)
    for _ in range(5):
        venv.step(venv.action_space.sample())
    for index in range(-3, 3):
        np.testing.assert_array_equal(venv.filter(index).mean, venv.filter(index % 3).mean)
    assert venv.filter(np.int64(-1)).mean.tolist() == venv.filter(2).mean.tolist()
    assert not np.array_equal(venv.filter(0).mean, venv.filter(1).mean)
    for index in (3, -4, 100):
        with pytest.raises(IndexError, match=r"3 sub-envs.*-3 to 2"):
            venv.filter(index)
    for index in (1.0, "0", True, None):
        with pytest.raises(TypeError, match="integer"):
            venv.filter(index)


# ---------------------------------------------------------------------- render
@pytest.mark.parametrize("env_id", IDS)
def test_a_sub_env_frame_is_the_single_env_frame(env_id: str) -> None:
    """Pixel for pixel, for the frames of 150 steps that cross an episode end (the
    step counter, the live figures, the estimated path, the occluded wedge)."""
    b, seed, episode = 2, 3, 100
    venv = native(env_id, b, render_mode="rgb_array", max_episode_steps=episode)
    singles = [gym.make(env_id, render_mode="rgb_array", max_episode_steps=episode)]
    singles.append(gym.make(env_id, render_mode="rgb_array", max_episode_steps=episode))
    venv.reset(seed=seed)
    for i, env in enumerate(singles):
        env.reset(seed=seed + i)
    venv.action_space.seed(seed)
    done = [False] * b
    checked = 0
    for t in range(151):
        if t:
            actions = venv.action_space.sample()
            venv.step(actions)
            for i, env in enumerate(singles):
                if done[i]:
                    env.reset()
                    done[i] = False
                else:
                    _, _, terminated, truncated, _ = env.step(actions[i])
                    done[i] = terminated or truncated
        if t in (0, 1, 60, episode, episode + 1, 150):
            frames = venv.render()
            assert isinstance(frames, tuple) and len(frames) == b
            for i, env in enumerate(singles):
                np.testing.assert_array_equal(frames[i], env.render(), f"t={t} sub-env {i}")
            checked += 1
    assert checked == 6


def _check_rendered(frame: Any) -> None:
    assert isinstance(frame, np.ndarray) and frame.dtype == np.uint8
    assert frame.ndim == 3 and frame.shape[2] == 3


@pytest.mark.parametrize("env_id", IDS)
def test_every_render_mode(env_id: str) -> None:
    """As Gymnasium's test_render_modes: each declared mode renders after the reset
    and after a step (``"human"`` into a window, returning None); the vector env
    returns a frame per sub-env, and None (with a warning) without a render mode."""
    for mode in gym.make(env_id).metadata["render_modes"]:
        env = gym.make(env_id, render_mode=mode)
        env.reset(seed=0)
        for _ in range(2):
            rendered = env.render()
            if mode == "human":
                assert rendered is None
            else:
                _check_rendered(rendered)
            env.step(env.action_space.sample())
        env.close()
    assert native(env_id, 2).metadata["render_modes"] == ["rgb_array"]
    venv = native(env_id, 2, render_mode="rgb_array")
    with pytest.raises(ResetNeeded):
        venv.render()
    venv.reset(seed=0)
    for _ in range(2):
        frames = venv.render()
        assert isinstance(frames, tuple) and len(frames) == 2
        for frame in frames:
            _check_rendered(frame)
        venv.step(venv.action_space.sample())
    venv.close()
    assert len(venv.render()) == 2  # as the single env: close releases, render reopens
    plain = native(env_id, 2)
    plain.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert plain.render() is None
    with pytest.raises(ValueError, match="render_mode"):
        native(env_id, 2, render_mode="human")


# ---------------------------------------------------------------------- determinism
def _rollout(env: Any, steps: int, seed: int = 0) -> list[Any]:
    """Gymnasium's test_env_determinism_rollout: a seeded reset and seeded actions,
    a reset with the seed where a single env's episode ends."""
    env.action_space.seed(seed)
    out = [env.reset(seed=seed)]
    for _ in range(steps):
        step = env.step(env.action_space.sample())
        assert env.observation_space.contains(step[0])
        out.append(step)
        if not isinstance(env, gym.vector.VectorEnv) and (step[2] or step[3]):
            out.append(env.reset(seed=seed))
    env.close()
    return out


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("kind", ["single", "vector"])
def test_the_same_seed_gives_the_same_stream(env_id: str, kind: str) -> None:
    def make() -> Any:
        if kind == "single":
            return gym.make(env_id, max_episode_steps=30)
        return native(env_id, 3, max_episode_steps=30)

    first, second = _rollout(make(), 80), _rollout(make(), 80)
    assert_equal(first, second)
    assert digest(first) != digest(_rollout(make(), 80, seed=1))


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("kind", ["single", "vector"])
def test_a_pickled_env_continues_identically_mid_episode(env_id: str, kind: str) -> None:
    """Gymnasium's test_pickle_env, mid-episode and with the pictures: the copy's
    steps and frames (its path so far included) are the original's."""
    if kind == "single":
        env = gym.make(env_id, render_mode="rgb_array", max_episode_steps=40)
    else:
        env = native(env_id, 2, render_mode="rgb_array", max_episode_steps=40)
    env.action_space.seed(4)
    env.reset(seed=4)
    for _ in range(25):
        env.step(env.action_space.sample())
    env.render()
    twin = pickle.loads(pickle.dumps(env))
    assert_equal(twin.render(), env.render())
    for _ in range(30):  # across the end of the episode
        action = env.action_space.sample()
        step = env.step(action)
        assert_equal(twin.step(action), step)
        if kind == "single" and (step[2] or step[3]):
            assert_equal(twin.reset(), env.reset())
    assert_equal(twin.render(), env.render())


def _containers(data: Any, found: list) -> list:
    """Every dict, list and array inside ``data``, object arrays' items too."""
    if isinstance(data, (dict, list, np.ndarray)):
        found.append(data)
    if isinstance(data, dict):
        data = list(data.values())
    elif isinstance(data, np.ndarray) and data.dtype == object:
        data = data.ravel().tolist()
    if isinstance(data, (list, tuple)):
        for value in data:
            _containers(value, found)
    return found


@pytest.mark.parametrize("mode", MODES, ids=[m.value for m in MODES])
@pytest.mark.parametrize("env_id", IDS)
def test_returned_data_is_never_reused(env_id: str, mode: AutoresetMode) -> None:
    """Gymnasium's check_returned_data_not_reused, for a vector env: no two calls
    (resets, steps that end episodes or reset sub-envs, masked resets) return
    observations or infos that share an array, a dict or a list."""
    venv = native(env_id, 2, autoreset_mode=mode, max_episode_steps=2)
    venv.action_space.seed(0)
    calls = [venv.reset(seed=0)]
    for _ in range(6):
        obs, _, terminated, truncated, info = venv.step(venv.action_space.sample())
        calls.append((obs, info))
        done = terminated | truncated
        if mode == AutoresetMode.DISABLED and done.any():
            calls.append(venv.reset(options={"reset_mask": done}))
    calls.append(venv.reset(options={"reset_mask": np.array([True, False])}))
    calls.append(venv.reset(seed=0))
    held = [_containers(call, []) for call in calls]
    for i, first in enumerate(held):
        for second in held[i + 1 :]:
            for a in first:
                for b in second:
                    shared = a is b or (
                        isinstance(a, np.ndarray)
                        and isinstance(b, np.ndarray)
                        and a.dtype != object
                        and np.shares_memory(a, b)
                    )
                    assert not shared, f"calls {i} and later share a {type(a).__name__}"
    venv.close()


# ---------------------------------------------------------------------- the spec
@pytest.mark.parametrize("env_id", IDS)
def test_the_spec_kwargs_reach_the_env_and_remake_it(env_id: str) -> None:
    """gym.spec(ID).kwargs are the options of every env made from the spec, the
    native vector env's too; make_vec's spec remakes the same env (options, render
    mode, autoreset mode and episode length), as Gymnasium's test_make_vec_with_spec."""
    spec = gym.spec(env_id)
    assert spec.kwargs == {} and spec.vector_entry_point is not None
    options = {"n_landmarks": 5, "max_range": 3.0}
    custom = copy.deepcopy(spec)
    custom.kwargs = dict(options)
    assert gym.make(custom).unwrapped.n_landmarks == 5
    from_spec = gym.make_vec(custom, num_envs=2)
    assert isinstance(from_spec, SlamVectorEnv) and from_spec.core.n_landmarks == 5
    stream = _rollout(from_spec, 20)
    assert_equal(stream, _rollout(native(env_id, 2, **options), 20))
    synced = gym.make_vec(custom, num_envs=2, vectorization_mode="sync")
    assert_equal(stream, _rollout(synced, 20))

    kwargs = {
        "max_episode_steps": 7,
        "autoreset_mode": AutoresetMode.SAME_STEP,
        "render_mode": "rgb_array",
        **options,
    }
    venv = native(env_id, 2, **kwargs)
    assert venv.spec is not None and venv.spec.kwargs == {
        **kwargs,
        "num_envs": 2,
        "vectorization_mode": "vector_entry_point",
    }
    again = gym.make_vec(venv.spec)
    assert type(again) is type(venv) and again.spec == venv.spec
    assert (again.num_envs, again.autoreset_mode, again.render_mode) == (
        2,
        kwargs["autoreset_mode"],
        "rgb_array",
    )
    assert again.observation_space == venv.observation_space
    assert again.single_action_space == venv.single_action_space
    assert_equal(_rollout(again, 20), _rollout(venv, 20))


def test_make_vec_warns_of_nothing() -> None:
    """Gymnasium's make_vec warns of a vector env without an AutoresetMode in its
    metadata; ours has one in every mode."""
    for mode in MODES:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            native(ACTIVE, 2, autoreset_mode=mode).close()


# ---------------------------------------------------------------------- the rest of Gymnasium's
# What tests/envs/test_envs.py, tests/envs/registration/test_env_spec.py and
# tests/vector/test_vector_env.py of Gymnasium check that the tests above do not.
@pytest.mark.parametrize("env_id", IDS)
def test_the_passive_checker_of_gym_make_warns_of_nothing(env_id: str) -> None:
    """Gymnasium's test_all_env_passive_env_checker: gym.make wraps the env in its
    passive checker, which finds nothing to warn of in a reset and steps."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gym.make(env_id)
        env.reset(seed=0)
        for _ in range(3):
            env.step(env.action_space.sample())
        env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_every_spec_round_trips_through_json(env_id: str) -> None:
    """Gymnasium's test_env_spec_to_from_json: the registered spec, a made env's (with
    options) and the native vector env's."""
    specs = [
        gym.spec(env_id),
        gym.make(env_id, n_landmarks=5, max_range=3.0).spec,
        # The mode by its value: JSON takes no AutoresetMode (Gymnasium's own limit).
        native(env_id, 2, autoreset_mode=AutoresetMode.SAME_STEP.value, n_landmarks=5).spec,
    ]
    for spec in specs:
        assert spec is not None
        assert gym.envs.registration.EnvSpec.from_json(spec.to_json()) == spec


@pytest.mark.parametrize("env_id", IDS)
def test_np_random_seed_is_each_sub_envs_as_sync_vector_envs(env_id: str) -> None:
    """Gymnasium's test_random_seeding_basics: after reset(seed=42) the seeds are
    (42, 43, 44), as SyncVectorEnv's; reset(seed=None) keeps them; a list sets each."""
    ours = native(env_id, 3, **FEW)
    theirs = sync(env_id, 3, AutoresetMode.NEXT_STEP, **FEW)
    for venv in (ours, theirs):
        venv.reset(seed=42)
        assert venv.np_random_seed == (42, 43, 44)
        venv.reset(seed=None)
        assert venv.np_random_seed == (42, 43, 44)
        venv.reset(seed=[7, None, 9])
        assert venv.np_random_seed == (7, 43, 9)
        venv.reset(seed=[1, 2, 3], options={"reset_mask": np.array([False, True, False])})
        assert venv.np_random_seed == (7, 2, 9)


def test_np_random_seed_before_a_reset_is_the_generator_the_reset_continues() -> None:
    """As Env.np_random_seed: asked before any seeded reset, each sub-env draws its
    generator from fresh entropy, and reset(seed=None) continues that generator: the
    stream is the one reset(seed=np_random_seed) gives."""
    venv = native(LANDMARKS, 2)
    seeds = venv.np_random_seed
    assert len(seeds) == 2 and len(set(seeds)) == 2
    assert all(isinstance(s, int) and s >= 0 for s in seeds)
    assert venv.np_random_seed == seeds
    assert_equal(venv.reset(), native(LANDMARKS, 2).reset(seed=list(seeds)))


@pytest.mark.parametrize("env_id", IDS)
def test_the_spaces_are_the_single_envs_batched(env_id: str) -> None:
    """Gymnasium's test_vector_obs_action_spaces: the vector spaces batch the single
    env's, and what reset and step return lies in them."""
    venv = native(env_id, 3, **FEW)
    single = gym.make(env_id, **FEW)
    assert venv.single_observation_space == single.observation_space
    assert venv.single_action_space == single.action_space
    assert venv.observation_space == gym.vector.utils.batch_space(single.observation_space, 3)
    assert venv.action_space == gym.vector.utils.batch_space(single.action_space, 3)
    obs, _ = venv.reset(seed=0)
    assert obs in venv.observation_space
    assert venv.step(venv.action_space.sample())[0] in venv.observation_space
