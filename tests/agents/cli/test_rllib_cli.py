"""The RLlib engine's edges that need no Ray (the default suite): a clear error naming
the extra when Ray RLlib is missing, flags refused where they mean nothing, configs
that RLlib cannot honour refused before any cluster is reached, ``rllib:`` specs."""

from __future__ import annotations

import sys

import pytest

import agents.cli.main
from agents.cli.main import main
from agents.learning.config import ConfigError, config_from_dict
from agents.learning.rllib.config import (
    RLlibSettings,
    check_reachable,
    check_rllib_config,
    log_slam_metrics,
)
from agents.learning.rllib.env import RLLIB_INSTALL, RLlibNotInstalledError, require_rllib
from agents.registry import agent_label, parse_agent_specs


@pytest.fixture
def no_ray(monkeypatch):
    """Ray hidden, as in the default install (``import ray`` fails)."""
    for name in [m for m in sys.modules if m == "ray" or m.startswith("ray.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "ray", None)


def test_require_rllib_names_the_extra(no_ray):
    with pytest.raises(RLlibNotInstalledError, match=r"pip install -e '\.\[rllib\]'"):
        require_rllib("--engine rllib")
    assert issubclass(RLlibNotInstalledError, ImportError)


@pytest.mark.parametrize(
    "argv",
    [
        ["train", "--engine", "rllib", "--total-steps", "64"],
        ["evaluate", "--agents", "random,rllib:runs/rllib/model", "--episodes", "1"],
    ],
)
def test_missing_ray_is_one_line_naming_the_extra(argv, no_ray, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--out", str(tmp_path / "out")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert RLLIB_INSTALL in err and "Ray RLlib" in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()  # nothing ran


def test_default_engine_is_sb3_and_the_cli_never_imports_ray(no_ray):
    args = agents.cli.main.build_parser().parse_args(["train"])
    assert args.engine == "sb3"
    assert agents.cli.main._rllib_settings(args) is None


@pytest.mark.parametrize(
    "flags",
    [
        ["--address", "127.0.0.1:6379"],
        ["--num-env-runners", "2"],
        ["--num-envs-per-runner", "4"],
        ["--learner-device", "gpu"],
        ["--num-learners", "1"],
    ],
)
def test_rllib_flags_without_the_rllib_engine_are_refused(flags, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["train", *flags, "--out", str(tmp_path / "out")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert flags[0] in err and "--engine rllib" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("ppo", "key"),
    [
        ({"target_kl": 0.02}, "target_kl"),
        ({"normalize_advantage": False}, "normalize_advantage"),
        ({"log_std_init": -0.5}, "log_std_init"),
    ],
)
def test_settings_rllib_cannot_honour_are_refused(ppo, key):
    with pytest.raises(ConfigError, match=key):
        check_rllib_config(config_from_dict({"ppo": ppo}))


@pytest.mark.parametrize(
    ("config", "key"),
    [
        ({"env_options": {"observation": "local"}, "worlds": {}}, "worlds"),
        ({"n_envs": 2, "world_groups": 1}, "world_groups"),
        ({"env_options": {"observation": "local"}}, "observation"),
        ({"decisions": "goals", "vectorization": "dummy"}, "decisions: goals"),
    ],
)
def test_what_the_rllib_engine_does_not_do_yet_is_refused(config, key):
    with pytest.raises(ConfigError, match=key):
        check_rllib_config(config_from_dict(config))


def test_the_default_config_suits_rllib():
    check_rllib_config(config_from_dict(None))  # raises nothing


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"num_env_runners": -1}, "num_env_runners"),
        ({"num_learners": True}, "num_learners"),
        ({"num_envs_per_runner": 0}, "num_envs_per_runner"),
        ({"learner_device": "tpu"}, "learner_device"),
        ({"address": ""}, "address"),
    ],
)
def test_bad_rllib_settings_are_value_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        RLlibSettings(**kwargs)


def test_rllib_specs():
    assert agent_label("rllib:runs/rllib/ppo_active_slam/") == "rllib:ppo_active_slam"
    assert parse_agent_specs("random, rllib:a/model") == ["random", "rllib:a/model"]
    with pytest.raises(ValueError, match="given twice"):
        parse_agent_specs("rllib:a/model,rllib:b/model")


def test_an_address_where_no_cluster_answers_is_refused():
    import socket

    with socket.socket() as free:  # a port nobody listens on once closed
        free.bind(("127.0.0.1", 0))
        port = free.getsockname()[1]
    with pytest.raises(ValueError, match=f"no Ray cluster answers at 127.0.0.1:{port}"):
        check_reachable(f"127.0.0.1:{port}", timeout_s=5)
    check_reachable("auto")  # left to Ray: raises nothing here


def test_an_address_where_something_listens_passes():
    import socket

    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        check_reachable(f"127.0.0.1:{server.getsockname()[1]}", timeout_s=5)


class _Episode:
    """What ``log_slam_metrics`` reads of an RLlib episode: its infos, reset first."""

    def __init__(self, infos):
        self._infos = infos

    def get_infos(self):
        return list(self._infos)


class _MetricsLogger:
    def __init__(self):
        self.logged = {}

    def log_value(self, key, value, reduce):
        assert reduce == "mean"
        self.logged[key] = value


def test_the_episode_end_logs_the_slam_metrics_of_the_steps_taken():
    def step(collision, known, **final):
        return {"collision": collision, "pose_nees": 2.0, "landmarks_known": known, **final}

    final = {"landmark_ids": [0, 1, 2, 3], "entropy": -5.0, "map_rmse": 0.25, "diverged": False}
    infos = [
        step(True, 0, **final),  # the reset's info: not a step, its contact not counted
        step(True, 1),
        step(False, 3),
        step(True, 4, **final),  # the last step's info holds the end figures
    ]
    logger = _MetricsLogger()
    log_slam_metrics(episode=_Episode(infos), metrics_logger=logger, env_runner=None)
    assert logger.logged["slam/collisions"] == 2
    assert logger.logged["slam/mapped_share"] == 1.0  # the last info's 4 of 4
    assert logger.logged["slam/final_entropy"] == -5.0
    assert logger.logged["slam/map_rmse"] == 0.25
    assert logger.logged["slam/mean_pose_nees"] == 2.0
    assert logger.logged["slam/steps_to_90pct_mapped"] == 3


def test_valid_rllib_settings_are_kept():
    settings = RLlibSettings(
        address="10.0.0.1:6379", num_env_runners=0, num_envs_per_runner=1, num_learners=2
    )
    assert (settings.num_envs_per_runner, settings.num_learners) == (1, 2)
    assert RLlibSettings().num_learners == 0  # the learner in the command's process
