"""The training's own budget (agents/learning/budget.py) and its model path: what
would exhaust memory or the CPUs, or save elsewhere than said, is refused before
anything is built, naming the option; from the command line on one line, status 2."""

from __future__ import annotations

import os

import gymnasium as gym
import pytest

from agents.cli.main import main
from agents.learning import budget
from agents.learning.config import ConfigError, config_from_dict
from agents.learning.sb3.training import train
from tests.agents.learning.test_ppo import tiny_config


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"n_envs": 6000, "ppo": {"n_steps": 1024}}, r"rollout buffer = n_envs 6000 .*budget"),
        ({"ppo": {"n_steps": 1_000_000_000}}, r"rollout buffer .*ppo.n_steps 1000000000"),
        ({"ppo": {"net_arch": [100_000_000]}}, r"policy parameters .*ppo.net_arch"),
        (
            {"ppo": {"net_arch": [4096] * 8}, "decisions": "goals", "vectorization": "dummy"},
            r"policy parameters .*ppo.net_arch",
        ),
    ],
)
def test_training_that_would_exhaust_memory_is_refused_before_anything_is_built(
    tmp_path, overrides, match
):
    cfg = tiny_config(tmp_path / "run", **{k: v for k, v in overrides.items() if k != "ppo"})
    cfg["ppo"].update(overrides.get("ppo", {}))
    with pytest.raises(ConfigError, match=match):
        train(cfg)
    assert not (tmp_path / "run").exists()  # refused before anything was written


def test_the_budget_counts_the_rollout_buffer_and_the_networks():
    obs, act = gym.spaces.Box(-1, 1, (10,)), gym.spaces.Box(-1, 1, (2,))
    # 10 obs floats + 2 action floats + the per-step scalars, float32, both copies.
    per_step = (10 + 2 + budget.PER_STEP_FLOATS) * 4 * budget.ROLLOUT_COPIES
    assert budget.rollout_bytes(3, 7, obs, act) == 3 * 7 * per_step
    # pi: 10→4→2 and log σ (2); vf: 10→4→1.
    assert budget.policy_parameters([4], obs, act) == (11 * 4 + 5 * 2 + 2) + (11 * 4 + 5 * 1)
    assert budget.policy_parameters([4], obs, gym.spaces.Discrete(3)) == (
        (11 * 4 + 5 * 3) + (11 * 4 + 5 * 1)
    )


def test_more_torch_threads_than_cpus_are_refused():
    cpus = os.cpu_count() or 1
    with pytest.raises(ConfigError, match=rf"torch_threads.*\[1, {cpus}\]"):
        config_from_dict({"torch_threads": 100_000})
    assert config_from_dict({"torch_threads": cpus}).torch_threads == cpus


@pytest.mark.parametrize(
    "argv",
    [
        ["--n-envs", "6000"],
        ["--config", "{config}"],
    ],
)
def test_the_command_line_refuses_them_on_one_line(tmp_path, capsys, argv):
    config = tmp_path / "threads.yaml"
    config.write_text("torch_threads: 100000\n")
    argv = [a.format(config=config) for a in argv]
    with pytest.raises(SystemExit) as exc:
        main(["train", *argv, "--out", str(tmp_path / "run"), "--no-progress"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ("rollout buffer" in err or "torch_threads" in err)


def test_a_folder_where_the_model_goes_is_refused_before_training(tmp_path, capsys):
    out = tmp_path / "run"
    (out / "ppo_active_slam.zip").mkdir(parents=True)
    with pytest.raises(ConfigError, match=r"ppo_active_slam.zip.* is not a file"):
        train(tiny_config(out))
    assert sorted(p.name for p in out.iterdir()) == ["ppo_active_slam.zip"]  # nothing run
    with pytest.raises(SystemExit) as exc:
        main(["train", "--out", str(out), "--no-progress"])
    assert exc.value.code == 2
    assert "ppo_active_slam.zip" in capsys.readouterr().err
