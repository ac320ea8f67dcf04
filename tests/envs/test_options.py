"""One meaning per option: the flat and nested forms are the same request, an option
given twice is refused, numpy scalars are taken as the Python values they hold, and
errors list every name an env ID accepts."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import slam_env
from slam_env.config import _SECTIONS, make_config, option_names
from slam_env.core.active_options import ACTIVE_SLAM_DEFAULTS, ActiveSLAMOptions
from slam_env.ekf import EKFSLAM
from slam_env.envs.active_slam import ActiveSLAMEnv
from slam_env.envs.landmarks import LandmarksEnv
from slam_env.envs.options import ACTIVE_ARGUMENTS, ENV_ARGUMENTS
from tests.streams import digest

RAW, ACTIVE = "slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0"

# A valid value other than the default for every flat option, by section.
ALTERNATIVES = {
    "preset": "open",
    "width": 17.0,
    "height": 15.0,
    "n_landmarks": 12,
    "n_obstacles": 4,
    "obstacle_size": (0.5, 1.5),
    "landmark_spacing": 1.2,
    "clearance": 0.5,
    "wall_thickness": 0.2,
    "radius": 0.3,
    "max_speed": 1.2,
    "max_turn_rate": 1.0,
    "mass": 12.0,
    "measurement_model": "cartesian",
    "max_range": 4.0,
    "fov": 2.5,
    "range_std": 0.06,
    "bearing_std": 0.02,
    "cartesian_std": 0.07,
    "detection_prob": 0.9,
    "max_detections": 5,
    "scan_beams": 8,
    "scan_range": 2.5,
    "bumper": False,
    "report_ids": False,
    "motion_model": "velocity",
    "alphas": (0.01, 0.003, 0.02, 0.002),
    "velocity_noise": (0.01, 0.01, 0.02, 0.03),
    "new_landmark_bonus": 2.0,
    "collision_penalty": 0.2,
    "outlier_rate": 0.1,
    "clutter_rate": 0.1,
    "scan_dropout": 0.1,
    "odometry_dropout": 0.1,
    "odometry_bias": (0.01, 0.02, 0.0),
    "kidnap_rate": 0.01,
}
SECTION_OF = {f.name: s for s, cls in _SECTIONS.items() for f in dataclasses.fields(cls)}
NUMERIC = {
    name: value for name, value in ALTERNATIVES.items() if not isinstance(value, (bool, str))
}


def test_the_table_covers_every_flat_option():
    assert set(ALTERNATIVES) == set(SECTION_OF)
    assert set(SECTION_OF) <= set(option_names())


@pytest.mark.parametrize("name", sorted(ALTERNATIVES))
def test_nested_is_flat(name):
    """Same config, hence the same raw env; and ActiveSLAM-v0 built from either form has
    the same config (its own defaults included) and the same spaces."""
    value = ALTERNATIVES[name]
    nested = {SECTION_OF[name]: {name: value}}
    assert make_config(**{name: value}) == make_config(**nested)
    # Hidden IDs need a filter that associates by itself.
    own = {"data_association": "jcbb"} if name == "report_ids" else {}
    flat_env = ActiveSLAMEnv(**{name: value}, **own)
    nested_env = ActiveSLAMEnv(**nested, **own)
    assert flat_env.config == nested_env.config
    assert getattr(flat_env.config, SECTION_OF[name]).__dict__[name] == value
    assert flat_env.observation_space == nested_env.observation_space


@pytest.mark.parametrize("form", ["flat", "nested"])
def test_active_slam_defaults_survive_either_form(form):
    options = {"fov": 2.5} if form == "flat" else {"sensor": {"fov": 2.5}}
    env = gym.make(ACTIVE, **options).unwrapped
    sensor = env.config.sensor
    assert (sensor.fov, sensor.scan_beams, sensor.bumper) == (2.5, 16, True)
    assert env.observation_space.shape == gym.make(ACTIVE).observation_space.shape == (129,)
    assert ACTIVE_SLAM_DEFAULTS == {"scan_beams": 16, "bumper": True}
    # An explicit setting wins in either form.
    off = {"scan_beams": 0} if form == "flat" else {"sensor": {"scan_beams": 0}}
    assert gym.make(ACTIVE, **off).unwrapped.config.sensor.scan_beams == 0


@pytest.mark.parametrize("name", sorted(ALTERNATIVES))
def test_an_option_given_twice_is_refused(name):
    value = ALTERNATIVES[name]
    with pytest.raises(ValueError, match=f"option '{name}' given twice"):
        make_config(**{name: value, SECTION_OF[name]: {name: value}})


@pytest.mark.parametrize("env_id", [RAW, ACTIVE])
def test_a_conflict_is_refused_by_the_envs(env_id):
    with pytest.raises(ValueError, match="'max_range' given twice"):
        gym.make(env_id, max_range=3.0, sensor={"max_range": 6.0})


def _as_numpy(value, kind):
    if isinstance(value, tuple):
        return np.array(value)
    if kind == "0-d":
        return np.array(value)
    return np.int64(value) if isinstance(value, int) else np.float32(value)


@pytest.mark.parametrize("kind", ["scalar", "0-d"])
@pytest.mark.parametrize("name", sorted(NUMERIC))
def test_numpy_scalars_and_arrays_are_taken_as_python_values(name, kind):
    value = NUMERIC[name]
    converted = make_config(**{name: _as_numpy(value, kind)})
    expected = make_config(**{name: value})
    got = getattr(converted, SECTION_OF[name]).__dict__[name]
    want = getattr(expected, SECTION_OF[name]).__dict__[name]
    # float32 rounds: equal to the float32 of the value, and a Python number or tuple.
    assert type(got) is type(want)
    np.testing.assert_allclose(np.asarray(got, float), np.asarray(want, float), rtol=1e-6)


def test_numpy_values_through_the_envs():
    env = gym.make(
        ACTIVE,
        n_landmarks=np.int64(12),
        max_range=np.float32(4.0),
        bumper=np.bool_(False),
        alphas=np.array([0.01, 0.003, 0.02, 0.002]),
        gate=np.float32(9.0),
        coverage=np.bool_(True),
        reward_weights={"step": np.float32(0.02)},
        filter_alphas=np.array([0.01, 0.003, 0.02, 0.002]),
    ).unwrapped
    cfg = env.config
    assert type(cfg.world.n_landmarks) is int and cfg.world.n_landmarks == 12
    assert cfg.sensor.bumper is False
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    raw = gym.make(RAW, n_landmarks=np.array(7), max_range=np.array(3.5))
    assert raw.unwrapped.config.world.n_landmarks == 7


@pytest.mark.parametrize("flag", [True, np.bool_(True)])
@pytest.mark.parametrize("name", sorted(n for n, v in NUMERIC.items() if not isinstance(v, tuple)))
def test_a_bool_is_still_refused_where_a_number_is_expected(name, flag):
    with pytest.raises(TypeError, match=name):
        make_config(**{name: flag})


@pytest.mark.parametrize(
    ("option", "error"),
    [
        ({"gate": True}, TypeError),
        ({"coverage": 1}, TypeError),
        ({"filter_alphas": (0.1, 0.1, 0.1)}, ValueError),
        ({"filter_control_noise": (0.1, -0.1, 0.1, 0.1)}, ValueError),
        ({"filter_measurement_cov": [[1.0, 0.5], [0.4, 1.0]]}, ValueError),
        ({"reward_weights": {"step": -1.0}}, ValueError),
        ({"reward_weights": {"step": True}}, TypeError),
    ],
)
def test_active_slam_options_are_named_in_their_errors(option, error):
    (name,) = option
    with pytest.raises(error, match=name):
        gym.make(ACTIVE, **option)


@pytest.mark.parametrize(
    ("env_class", "own"),
    [(LandmarksEnv, ENV_ARGUMENTS), (ActiveSLAMEnv, ACTIVE_ARGUMENTS)],
)
def test_an_unknown_option_lists_every_name_the_id_accepts(env_class, own):
    with pytest.raises(TypeError, match="unexpected keyword argument 'fvo'") as exc:
        env_class(fvo=2.0)
    listed = set(str(exc.value).split("valid options: ")[1].split(", "))
    assert listed == set(option_names()) | set(own)
    if env_class is ActiveSLAMEnv:
        assert {"observation", "gate", "filter_alphas", "coverage", "reward_weights"} <= listed


def _make_single(env_id, **kwargs):
    return gym.make(env_id, **kwargs)


def _make_vector(env_id, **kwargs):
    return gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)


@pytest.mark.parametrize(
    ("env_id", "make", "owner"),
    [
        (RAW, _make_single, "LandmarksEnv"),
        (ACTIVE, _make_single, "ActiveSLAMEnv"),
        (RAW, _make_vector, "LandmarksVectorEnv"),
        (ACTIVE, _make_vector, "ActiveSLAMVectorEnv"),
    ],
)
def test_an_unknown_keyword_is_refused_in_pythons_own_words(env_id, make, owner):
    # torchrl's GymEnv passes frameskip=1 and drops it only when the TypeError says
    # "unexpected keyword argument 'frameskip'", as Python's own does.
    with pytest.raises(TypeError) as exc:
        make(env_id, frameskip=1)
    message = str(exc.value)
    assert message.startswith(
        f"{owner}.__init__() got an unexpected keyword argument 'frameskip'; valid options: "
    )
    assert "max_range" in message.split("valid options: ")[1].split(", ")


def test_an_unknown_keyword_of_make_config_and_of_the_filter_reads_as_pythons():
    with pytest.raises(
        TypeError, match=r"^make_config\(\) got an unexpected keyword argument 'fvo'"
    ):
        make_config(fvo=1.0)
    # EKFSLAM takes no **kwargs: Python itself refuses.
    with pytest.raises(TypeError, match=r"__init__\(\) got an unexpected keyword argument 'fvo'"):
        EKFSLAM(fvo=1.0)


@pytest.mark.parametrize("env_id", [RAW, ACTIVE])
@pytest.mark.parametrize(
    ("options", "error", "message"),
    [(7, TypeError, "must be a dict or None, got int"), ({"x": 1}, ValueError, "no options")],
)
def test_reset_options_are_refused_clearly_and_change_nothing(env_id, options, error, message):
    env, twin = gym.make(env_id), gym.make(env_id)
    env.reset(seed=1)
    twin.reset(seed=1)
    with pytest.raises(error, match=message):
        env.reset(seed=2, options=options)  # refused before the seed is applied
    a = np.array([0.6, 0.2], dtype=np.float32)
    assert digest([env.step(a) for _ in range(5)]) == digest([twin.step(a) for _ in range(5)])
    env.reset(options={})  # an empty mapping is no options
    assert slam_env.__version__


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"gate": 0.0}, ValueError, "gate must be > 0"),
        ({"gate": "9"}, TypeError, "gate must be a number"),
        ({"filter_measurement_cov": [[1.0, 1.0], [1.0, 1.0]]}, ValueError, "positive definite"),
        ({"filter_measurement_cov": [[0.0, 0.0], [0.0, 1.0]]}, ValueError, "positive definite"),
        ({"filter_measurement_cov": [[1.0, 0.0]]}, ValueError, "2×2"),
        ({"observation": "pixels"}, ValueError, "observation must be one of"),
        ({"correction": "ukf"}, ValueError, "correction must be one of"),
    ],
)
def test_active_slam_options_are_checked(options, error, message):
    with pytest.raises(error, match=message):
        ActiveSLAMOptions(**options)


def test_active_slam_options_accept_what_is_valid():
    opts = ActiveSLAMOptions(
        gate=np.float32(5.0), filter_measurement_cov=np.diag([0.5, 0.25]), coverage=np.bool_(0)
    )
    assert opts.gate == 5.0 and opts.coverage is False
    assert opts.filter_measurement_cov == ((0.5, 0.0), (0.0, 0.25))


@pytest.mark.parametrize(
    ("options", "names"),
    [
        ({"range_std": 0.0}, "range_std and bearing_std"),
        ({"bearing_std": 1e-200}, "range_std and bearing_std"),  # its square underflows
        ({"measurement_model": "cartesian", "cartesian_std": 0.0}, "cartesian_std"),
    ],
)
def test_a_noise_free_sensor_needs_a_filter_covariance(options, names):
    config = make_config(**options)
    with pytest.raises(ValueError, match=f"{names} must be > 0"):
        ActiveSLAMOptions().check_against(config)
    ActiveSLAMOptions(filter_measurement_cov=np.eye(2)).check_against(config)
    ActiveSLAMOptions().check_against(make_config(range_std=1e-100, bearing_std=1e-100))


def test_hidden_ids_need_a_filter_that_associates():
    with pytest.raises(ValueError, match="report_ids=False hides the landmark IDs"):
        ActiveSLAMEnv(report_ids=False)
    for association in ("nearest_neighbor", "jcbb"):
        assert ActiveSLAMEnv(report_ids=False, data_association=association).filter.associates


@pytest.mark.parametrize(
    ("name", "value"), [("data_association", "greedy"), ("linearization", "exact")]
)
def test_the_filter_options_refuse_unknown_choices(name, value):
    with pytest.raises(ValueError, match=f"{name} must be one of"):
        ActiveSLAMEnv(**{name: value})
