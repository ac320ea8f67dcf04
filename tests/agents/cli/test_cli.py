"""``slam-env train/evaluate/demo`` end to end on tiny settings, the agent registry,
and clear errors for bad arguments."""

from __future__ import annotations

import csv
import importlib.util
import json
import subprocess
import sys

import imageio.v3 as iio
import pytest
import yaml

import agents.evaluation.demo as demo_module
import slam_env
from agents.cli.main import _env_option, main
from agents.common.base import RandomAgent
from agents.common.env import make_env
from agents.registry import agent_label, make_agent, parse_agent_specs

SMALL = ["n_landmarks=5", "width=8.0", "height=8.0", "n_obstacles=1"]
SMALL_ARGS = [arg for option in SMALL for arg in ("--env-option", option)]
HEURISTICS = [
    name for name in ("frontier", "infogain") if importlib.util.find_spec(f"agents.{name}")
]


def test_python_m_agents_help():
    done = subprocess.run(
        [sys.executable, "-m", "agents", "--help"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage: slam-env")
    for command in ("train", "evaluate", "demo"):
        assert command in done.stdout


def test_cli_evaluate(tmp_path, capsys):
    agents = ",".join(["random", *HEURISTICS])
    argv = ["evaluate", "--agents", agents, "--episodes", "2", "--seed", "3"]
    argv += ["--max-steps", "15", "--out", str(tmp_path), "--no-progress", *SMALL_ARGS]
    # YAML 1.2 numbers: PyYAML alone reads 2e-1 as a string.
    argv += ["--env-option", "dt=2e-1", "--env-option", "range_std=5E-2"]
    assert main(argv) == 0
    with open(tmp_path / "episodes.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["agent"], r["seed"]) for r in rows] == [
        (a, s) for a in agents.split(",") for s in ("3", "4")
    ]
    assert {r["steps"] for r in rows} == {"15"}
    settings = json.loads((tmp_path / "results.json").read_text())["settings"]
    assert settings["env_options"] == {
        "n_landmarks": 5,
        "width": 8.0,
        "height": 8.0,
        "n_obstacles": 1,
        "dt": 0.2,
        "range_std": 0.05,
    }
    assert (tmp_path / "trajectories.png").is_file()
    assert (tmp_path / "metrics_over_time.png").is_file()
    out = capsys.readouterr().out
    assert "mapped_share" in out and "summary_csv" in out


def test_cli_demo_writes_gif_map_and_metrics(tmp_path, capsys):
    argv = ["demo", "--agent", "random", "--seed", "2", "--max-steps", "12"]
    assert main([*argv, "--out", str(tmp_path), *SMALL_ARGS]) == 0
    frames = iio.imread(tmp_path / "demo.gif", index=None)
    assert frames.shape[0] == 13  # reset + 12 steps (short episodes keep every frame)
    assert frames.shape[-1] == 3 and frames.shape[1] >= 100
    assert (tmp_path / "final_map.png").read_bytes()[:4] == b"\x89PNG"
    metrics = json.loads((tmp_path / "demo_metrics.json").read_text())
    assert metrics["agent"] == "random" and metrics["seed"] == 2
    assert metrics["metrics"]["steps"] == 12
    assert 0.0 <= metrics["metrics"]["nees_in_band"] <= 1.0
    assert (tmp_path / "demo_consistency.png").read_bytes()[:4] == b"\x89PNG"
    printed = capsys.readouterr().out
    assert "mapped_share" in printed and "nees_in_band" in printed


def test_cli_demo_subsamples_long_episodes_and_no_gif(tmp_path):
    result = demo_module.demo(
        "random",
        seed=0,
        out_dir=tmp_path,
        max_steps=30,
        env_options={"n_landmarks": 5, "width": 8.0, "height": 8.0, "n_obstacles": 1},
        gif_max_frames=6,
        verbose=False,
    )
    frames = iio.imread(result.files["gif"], index=None)
    assert frames.shape[0] == 6  # every 6th step of 30, first and last included
    argv = ["demo", "--agent", "random", "--max-steps", "5", "--no-gif"]
    assert main([*argv, "--out", str(tmp_path / "nogif"), *SMALL_ARGS]) == 0
    assert not (tmp_path / "nogif" / "demo.gif").exists()
    assert (tmp_path / "nogif" / "final_map.png").is_file()


def test_demo_default_agent_runs(tmp_path):
    spec = demo_module.default_agent_spec()
    result = demo_module.demo(
        None,
        out_dir=tmp_path,
        max_steps=10,
        gif=False,
        verbose=False,
        env_options={"n_landmarks": 5, "width": 8.0, "height": 8.0, "n_obstacles": 1},
    )
    assert result.spec == spec and result.metrics["steps"] == 10


def test_demo_default_agent_falls_back_without_a_shipped_policy(monkeypatch, tmp_path):
    assert demo_module.default_agent_spec() == demo_module.DEFAULT_AGENT
    monkeypatch.setattr(demo_module, "DEFAULT_AGENT", "ppo")
    monkeypatch.setattr(demo_module, "SHIPPED_POLICY", tmp_path / "none.zip")
    assert demo_module.default_agent_spec() == demo_module.BEST_HEURISTIC
    (tmp_path / "none.zip").write_bytes(b"")
    assert demo_module.default_agent_spec() == "ppo"


def test_cli_train(tmp_path, capsys):
    config = tmp_path / "tiny.yaml"
    config.write_text(
        yaml.safe_dump(
            {
                "env_options": {"n_landmarks": 5, "width": 8.0, "height": 8.0, "n_obstacles": 1},
                "max_episode_steps": 30,
                "checkpoint_freq": 0,
                "eval_freq": 0,
                "tensorboard": False,
                "ppo": {"n_steps": 64, "batch_size": 32, "n_epochs": 1, "net_arch": [8]},
            }
        )
    )
    out = tmp_path / "run"
    argv = ["train", "--config", str(config), "--total-steps", "64", "--n-envs", "1"]
    assert main([*argv, "--seed", "4", "--out", str(out), "--no-progress"]) == 0
    assert (out / "ppo_active_slam.zip").is_file()
    saved = yaml.safe_load((out / "ppo_active_slam.yaml").read_text())
    assert (saved["total_timesteps"], saved["n_envs"], saved["seed"]) == (64, 1, 4)
    assert saved["out_dir"] == str(out) and saved["progress_bar"] is False
    assert not (out / "checkpoints").exists() and not (out / "tb").exists()
    printed = capsys.readouterr().out
    assert "steps/s" in printed
    assert "sampler: 1 thread over 1 envs; learner: torch on 1 thread" in printed


# ---------------------------------------------------------------------- bad arguments
@pytest.mark.parametrize(
    ("argv", "message"),
    [
        ([], "required: {train,evaluate,demo}"),
        (["explore"], "invalid choice: 'explore'"),
        (["evaluate"], "the following arguments are required: --agents"),
        (["evaluate", "--agents", "random", "--episodes", "0"], "--episodes: must be >= 1"),
        (["evaluate", "--agents", "random", "--seed", "x"], "--seed: expected an integer"),
        (["evaluate", "--agents", "teleport"], "unknown agent 'teleport'"),
        (["evaluate", "--agents", "random,random"], "given twice: random"),
        (["evaluate", "--agents", "random", "--env-option", "n_landmarks"], "KEY=VALUE"),
        (["evaluate", "--agents", "random", "--env-option", "n_landmark=3"], "n_landmark"),
        (["demo", "--agent", "ppo:/no/such/policy.zip"], "PPO policy file not found"),
        (["train", "--n-envs", "0"], "--n-envs: must be >= 1"),
        (["train", "--config", "/no/such/config.yaml"], "config file not found"),
        # Absurd magnitudes: the episode records would not fit in memory.
        (
            ["evaluate", "--agents", "random", "--episodes", "1000000000"],
            "1000000000 episode records of 500 steps need about",
        ),
        (["evaluate", "--agents", "random", "--max-steps", "1000000000"], "over the budget"),
        (
            ["evaluate", "--agents", "random", "--suite", "smoke", "--episodes", "100000000"],
            "suite setting default: 100000000 episode records of 30 steps",
        ),
        (["demo", "--max-steps", "100000000"], "demo: 1 episode records of 100000000 steps"),
    ],
)
def test_bad_arguments_exit_2_with_a_message(argv, message, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main([*argv, *(["--out", str(tmp_path)] if len(argv) > 1 else [])])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err
    assert len(err.splitlines()) == 1, err  # one line, no usage block
    assert not any(tmp_path.iterdir())  # nothing written


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("2e-1", 0.2),
        ("1e-3", 0.001),
        ("-1.5E+2", -150.0),
        (".5", 0.5),
        ("12", 12),
        ("true", True),
        ("[1, 2e-1]", [1, 0.2]),
        ("rooms", "rooms"),
        ("", None),
    ],
)
def test_env_option_values_are_yaml_scalars(text, value):
    assert _env_option(f"key={text}") == ("key", value)
    assert type(_env_option(f"key={text}")[1]) is type(value)


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"slam-env {slam_env.__version__}"


def _user_error(argv, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    return err


def test_a_bad_layout_file_is_a_usage_error(tmp_path, capsys):
    layout = tmp_path / "world.yaml"
    layout.write_text("width: 10\nheight: [8,\n")
    argv = ["evaluate", "--agents", "random", "--out", str(tmp_path / "out")]
    err = _user_error([*argv, "--env-option", f"layout={layout}"], capsys)
    assert "world.yaml', line 3: not valid YAML" in err
    err = _user_error([*argv, "--env-option", f"layout={tmp_path / 'none.json'}"], capsys)
    assert "none.json' cannot be read: No such file" in err


def test_a_garbage_policy_file_is_a_usage_error(tmp_path, capsys):
    policy = tmp_path / "policy.zip"
    policy.write_bytes(b"not a zip file at all")
    argv = ["demo", "--agent", f"ppo:{policy}", "--out", str(tmp_path / "out"), *SMALL_ARGS]
    err = _user_error(argv, capsys)
    assert "policy.zip is not a stable-baselines3 PPO model" in err


@pytest.mark.parametrize("command", ["evaluate", "demo", "train"])
@pytest.mark.parametrize("where", ["under-a-file", "read-only-filesystem"])
def test_an_unwritable_out_is_refused_before_anything_runs(
    command, where, tmp_path, capsys, monkeypatch
):
    import agents.evaluation.compare
    import agents.evaluation.demo
    import agents.learning.sb3.training

    def ran(*args, **kwargs):
        raise AssertionError("ran before checking --out")

    monkeypatch.setattr(agents.evaluation.compare, "evaluate", ran)
    monkeypatch.setattr(agents.evaluation.demo, "demo", ran)
    monkeypatch.setattr(agents.learning.sb3.training, "train", ran)
    (tmp_path / "file").write_text("")
    out = str(tmp_path / "file" / "out") if where == "under-a-file" else "/proc/slam_env_out"
    argv = {
        "evaluate": ["evaluate", "--agents", "random"],
        "demo": ["demo"],
        "train": ["train"],
    }[command]
    err = _user_error([*argv, "--out", out], capsys)
    assert f"--out {out!r}" in err


def test_train_config_with_unknown_key_is_a_usage_error(tmp_path, capsys):
    config = tmp_path / "bad.yaml"
    config.write_text("total_timesteps: 64\nlearning_rate: 0.1\n")  # belongs under ppo:
    with pytest.raises(SystemExit) as exc:
        main(["train", "--config", str(config), "--out", str(tmp_path / "run")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "unknown config key(s) ['learning_rate']" in err
    assert not (tmp_path / "run").exists()


# ---------------------------------------------------------------------- registry
def test_registry():
    env = make_env({"n_landmarks": 5, "width": 8.0, "height": 8.0})
    agent = make_agent("random", env, seed=1)
    assert isinstance(agent, RandomAgent)
    for name in HEURISTICS:
        heuristic = make_agent(name, env, seed=1)
        obs, _ = env.reset(seed=0)
        action, _ = heuristic.predict(obs, episode_start=True, deterministic=True)
        assert env.action_space.contains(action)
    with pytest.raises(ValueError, match="unknown agent 'Random'"):
        make_agent("Random", env)
    env.close()
    assert agent_label("ppo:runs/a/model.zip") == "ppo:model"
    assert parse_agent_specs(" random , ppo:x.zip") == ["random", "ppo:x.zip"]
    with pytest.raises(ValueError, match="given twice"):
        parse_agent_specs("ppo:a/m.zip,ppo:b/m.zip")  # same label: ambiguous tables
    with pytest.raises(ValueError, match="is set by the caller"):
        make_env({"max_episode_steps": 3})


def test_registry_reports_a_missing_heuristic(monkeypatch):
    import agents.registry as registry

    monkeypatch.setitem(registry._HEURISTICS, "frontier", ("agents.no_such_module", "X"))
    env = make_env({"n_landmarks": 5, "width": 8.0, "height": 8.0})
    with pytest.raises(ValueError, match="agent 'frontier' is not available"):
        make_agent("frontier", env)
    env.close()


@pytest.mark.parametrize("association", ["nearest_neighbor", "jcbb"])
def test_cli_evaluate_runs_infogain_where_the_filter_associates(association, tmp_path):
    argv = ["evaluate", "--agents", "random,infogain", "--episodes", "1", "--max-steps", "8"]
    argv += ["--out", str(tmp_path), "--no-progress", *SMALL_ARGS]
    assert main([*argv, "--env-option", f"data_association={association}"]) == 0
    with open(tmp_path / "episodes.csv", newline="") as fh:
        assert [r["agent"] for r in csv.DictReader(fh)] == ["random", "infogain"]


def test_a_world_setting_that_cannot_run_is_a_usage_error(tmp_path, capsys):
    config = tmp_path / "worlds.yaml"
    worlds = {"fovs": [2.0944, 360]}
    config.write_text(yaml.safe_dump({"env_options": {"observation": "local"}, "worlds": worlds}))
    with pytest.raises(SystemExit) as exc:
        main(["train", "--config", str(config), "--out", str(tmp_path / "run")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "worlds.fovs value 360.0 cannot run" in err
    assert not (tmp_path / "run").exists()


def test_the_command_line_imports_neither_the_filter_nor_numba_to_parse():
    """``slam-env --help`` and its parser's choices (``--belief``) stay light: the
    kernels are imported by a command that runs, not by the parser."""
    code = (
        "import sys, agents.cli.main as m\n"
        "m.build_parser()\n"
        "heavy = [n for n in ('numba', 'slam_env.ekf', 'torch') if n in sys.modules]\n"
        "assert not heavy, heavy\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=300)
