"""Ray RLlib on slam_env (marked ``rllib``: run by ``make test-rllib``, which installs the
'rllib' extra into its own virtual environment; the default suite deselects them).

The end-to-end test starts a local two-node Ray cluster, trains PPO with an EnvRunner
on each node through ``slam-env train --engine rllib``, evaluates the checkpoint
through ``slam-env evaluate --agents rllib:PATH`` and checks that no Ray process
outlives the cluster."""

from __future__ import annotations

import contextlib
import csv
import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

from agents.cli.main import main
from agents.common.env import make_env
from agents.learning.config import config_from_dict
from agents.learning.rllib.agent import load_rllib_agent
from agents.learning.rllib.config import RLlibSettings, check_gpus, ppo_config
from agents.learning.rllib.env import RLLIB_ENV_IDS, make_rllib_env
from slam_env.envs.vector import ActiveSLAMVectorEnv

pytestmark = pytest.mark.rllib

ROOT = Path(__file__).resolve().parents[3]
# Tiny: a few landmarks, short episodes, one 256-step update (2 runners × 2 sub-envs × 64).
TINY = {
    "total_timesteps": 256,
    "n_envs": 2,
    "env_options": {"n_landmarks": 5, "width": 8.0, "height": 8.0, "n_obstacles": 1},
    "max_episode_steps": 40,
    "checkpoint_freq": 256,
    "eval_freq": 256,
    "eval_episodes": 2,
    "progress_bar": False,
    "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 1, "net_arch": [16, 16]},
}
OBJECT_STORE_BYTES = 80 * 2**20  # Ray's floor is 75 MiB; its default, 30% of the memory


def _ray_processes() -> set[int]:
    """The PIDs of the Ray processes on this machine (daemons and workers)."""
    import psutil

    found = set()
    for proc in psutil.process_iter(["name", "cmdline"]):
        name = proc.info["name"] or ""
        cmdline = " ".join(proc.info["cmdline"] or [])
        if (
            name in ("raylet", "gcs_server")
            or cmdline.startswith("ray::")
            or "ray/_private" in cmdline
            or "ray/dashboard" in cmdline
            or "ray/autoscaler" in cmdline
            or "default_worker.py" in cmdline
        ):
            found.add(proc.pid)
    return found


@contextlib.contextmanager
def two_node_cluster() -> Iterator[object]:
    """A local Ray cluster of a head and a worker node, one CPU each (so that two
    EnvRunners of one CPU each must take one node each), shut down on the way out."""
    from ray.cluster_utils import Cluster

    node = {"num_cpus": 1, "object_store_memory": OBJECT_STORE_BYTES}
    cluster = Cluster(initialize_head=True, head_node_args={**node, "include_dashboard": False})
    try:
        cluster.add_node(**node)
        cluster.wait_for_nodes()
        yield cluster
    finally:
        cluster.shutdown()


def _wait_gone(pids: set[int], patience_s: float = 120.0) -> set[int]:
    """The PIDs among ``pids`` still alive after up to ``patience_s`` (processes take
    a moment to exit after their cluster is shut down: over 30 s on a loaded 2-core
    machine)."""
    import psutil

    deadline = time.monotonic() + patience_s
    alive = {p for p in pids if psutil.pid_exists(p)}
    while alive and time.monotonic() < deadline:
        time.sleep(0.2)
        alive = {
            p
            for p in alive
            if psutil.pid_exists(p) and psutil.Process(p).status() != psutil.STATUS_ZOMBIE
        }
    return alive


def test_train_on_two_nodes_then_evaluate_the_checkpoint(tmp_path, capsys):
    config = tmp_path / "tiny.yaml"
    config.write_text(yaml.safe_dump(TINY))
    out = tmp_path / "run"
    before = _ray_processes()
    try:
        with two_node_cluster() as cluster:
            node_ids = {n.node_id for n in cluster.list_all_nodes()}
            assert len(node_ids) == 2
            # The command a user runs, in its own process, joining the cluster.
            command = [sys.executable, "-m", "agents", "train", "--engine", "rllib"]
            command += ["--config", str(config), "--out", str(out), "--seed", "3"]
            command += ["--address", cluster.address, "--num-env-runners", "2"]
            env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
            env["PYTHONPATH"] = str(ROOT)
            done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=540)
            assert done.returncode == 0, done.stderr[-3000:]
            printed = "".join(done.stdout.split())  # rich wraps long lines
            assert f"model:{out / 'ppo_active_slam'}" in printed
    finally:
        leftovers = _wait_gone(_ray_processes() - before)
    assert not leftovers, f"Ray processes outlived the cluster: {sorted(leftovers)}"

    summary = json.loads((out / "training_summary.json").read_text())
    assert summary["engine"] == "rllib"
    assert summary["timesteps"] >= TINY["total_timesteps"]
    # One EnvRunner on each node, each stepping the native vector env of the plain ID.
    assert {r["node_id"] for r in summary["env_runners"]} == node_ids
    assert {r["env"] for r in summary["env_runners"]} == {ActiveSLAMVectorEnv.__name__}
    assert (out / "ppo_active_slam.yaml").is_file()
    assert (out / "checkpoints" / f"ppo_active_slam_{summary['timesteps']}_steps").is_dir()
    assert (out / "eval" / "best_model").is_dir() and (out / "eval" / "evaluations.npz").is_file()
    assert summary["last_eval_slam"]["steps"] == TINY["max_episode_steps"]
    tags = _tensorboard_tags(out / "tb")
    for tag in ("slam/mapped_share", "slam_eval/mapped_share", "env_runners/episode_return_mean"):
        assert tag in tags

    # The checkpoint as an agent, in the evaluation table beside another agent.
    argv = ["evaluate", "--agents", f"rllib:{out / 'ppo_active_slam'},random"]
    argv += ["--episodes", "2", "--seed", "5", "--max-steps", "30", "--no-progress"]
    argv += ["--out", str(tmp_path / "eval")]
    for key, value in TINY["env_options"].items():
        argv += ["--env-option", f"{key}={value}"]
    assert main(argv) == 0
    with open(tmp_path / "eval" / "episodes.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    ours = [r for r in rows if r["agent"] == "rllib:ppo_active_slam"]
    assert [r["seed"] for r in ours] == ["5", "6"]
    assert all(r["steps"] == "30" and 0.0 <= float(r["mapped_share"]) <= 1.0 for r in ours)


def _tensorboard_tags(root: Path) -> set[str]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    (run,) = root.iterdir()
    events = EventAccumulator(str(run))
    events.Reload()
    return set(events.Tags()["scalars"])


@pytest.mark.parametrize("env_id", RLLIB_ENV_IDS)
def test_the_creator_gives_the_native_vector_env_or_the_single_env(env_id):
    options = {"n_landmarks": 4, "max_episode_steps": 7}
    vec = make_rllib_env(env_id, {**options, "num_envs": 3})
    single = make_rllib_env(env_id, options)
    try:
        assert vec.num_envs == 3 and vec.unwrapped.spec.id == env_id
        assert vec.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
        assert isinstance(single, gym.Env) and single.spec.max_episode_steps == 7
        # Sub-env 0 of the vector env seeded s is the single env seeded s.
        obs_vec, _ = vec.reset(seed=11)
        obs_single, _ = single.reset(seed=11)
        leaves_vec = gym.spaces.flatten(vec.single_observation_space, _row(obs_vec, 0))
        leaves_single = gym.spaces.flatten(single.observation_space, obs_single)
        np.testing.assert_array_equal(leaves_vec, leaves_single)
    finally:
        vec.close()
        single.close()


def _row(obs, index):
    if isinstance(obs, dict):
        return {k: _row(v, index) for k, v in obs.items()}
    return obs[index]


def test_the_ppo_config_means_what_the_sb3_config_means():
    cfg = config_from_dict(
        {
            "n_envs": 4,
            "vectorization": "subproc",
            "ppo": {"n_steps": 32, "batch_size": 64, "net_arch": [8, 16], "activation": "relu"},
        }
    )
    algo = ppo_config(cfg, RLlibSettings(num_env_runners=3, num_learners=2))
    assert algo.env == "slam_env/ActiveSLAM-v0"  # the plain ID
    assert algo.num_envs_per_env_runner == 4 and algo.num_env_runners == 3
    assert algo.rollout_fragment_length == 32
    assert algo.train_batch_size_per_learner == 32 * 4 * 3 // 2  # the rollout, per learner
    assert algo.minibatch_size == 64 and algo.num_epochs == cfg.ppo.n_epochs
    assert algo.gym_env_vectorize_mode == "async"
    assert (algo.lr, algo.gamma, algo.lambda_) == (
        cfg.ppo.learning_rate,
        cfg.ppo.gamma,
        cfg.ppo.gae_lambda,
    )
    assert (algo.clip_param, algo.grad_clip) == (cfg.ppo.clip_range, cfg.ppo.max_grad_norm)
    assert not algo.use_kl_loss and algo.vf_clip_param == float("inf")
    model = algo.model_config
    assert model["fcnet_hiddens"] == [8, 16] and model["fcnet_activation"] == "relu"
    assert not model["vf_share_layers"] and model["free_log_std"]
    assert algo.num_learners == 2 and algo.num_gpus_per_learner == 0
    native = ppo_config(config_from_dict(None), RLlibSettings())
    assert native.gym_env_vectorize_mode == "vector_entry_point"
    assert native.num_envs_per_env_runner == 2  # the config's n_envs
    assert native.num_learners == 0  # the learner in the command's process
    gpu = ppo_config(config_from_dict(None), RLlibSettings(learner_device="gpu"))
    assert gpu.num_gpus_per_learner == 1


def test_a_minibatch_larger_than_the_rollout_is_refused():
    cfg = config_from_dict({"n_envs": 1, "ppo": {"n_steps": 16, "batch_size": 64}})
    with pytest.raises(ValueError, match="batch_size"):
        ppo_config(cfg, RLlibSettings(num_env_runners=1))
    # One minibatch of the whole rollout (16 steps × 2 sub-envs × 2 EnvRunners) is fine.
    whole = config_from_dict({"n_envs": 2, "ppo": {"n_steps": 16, "batch_size": 64}})
    assert ppo_config(whole, RLlibSettings(num_env_runners=2)).minibatch_size == 64


@pytest.fixture
def saved_module(tmp_path):
    """An untrained RLModule of the RLlib engine's PPO, saved as RLlib saves one, and
    the env it fits."""
    import torch

    cfg = config_from_dict({"env_options": {"n_landmarks": 4}, "ppo": {"net_arch": [8]}})
    env = make_env(cfg.env_options, max_steps=20)
    spec = ppo_config(cfg, RLlibSettings(num_env_runners=0)).get_rl_module_spec(env=env)
    torch.manual_seed(0)  # the module's initial weights
    module = spec.build()
    module.save_to_path(str(tmp_path / "module"))
    yield tmp_path / "module", module, env
    env.close()


def test_the_policy_acts_as_its_module_says_one_or_many_at_a_time(saved_module):
    import torch

    path, module, env = saved_module
    agent = load_rllib_agent(path, env)
    assert agent.acts_on_batches  # evaluate batches its episodes
    obs = np.stack([env.reset(seed=s)[0] for s in range(3)])
    actions, state = agent.predict(obs[0])
    assert state is None and actions.shape == (2,) and actions.dtype == np.float32
    assert env.action_space.contains(actions)
    with torch.no_grad():
        out = module.forward_inference({"obs": torch.from_numpy(obs)})
    mean = out["action_dist_inputs"][:, :2].numpy()  # the Gaussian's mean, then log σ
    np.testing.assert_allclose(agent.predict(obs)[0], np.clip(mean, -1, 1), rtol=0, atol=1e-6)
    # One row at a time: the same actions but for float rounding (BLAS takes another
    # kernel for a single row).
    singles = np.stack([agent.predict(o)[0] for o in obs])
    np.testing.assert_allclose(agent.predict(obs)[0], singles, rtol=0, atol=1e-6)
    sampled = np.stack([agent.predict(obs[0], deterministic=False)[0] for _ in range(5)])
    assert np.ptp(sampled, axis=0).max() > 0  # a stochastic policy when asked
    with pytest.raises(ValueError, match="does not fit"):
        agent.predict(obs[:, :-1])


def test_a_policy_for_another_env_or_no_checkpoint_is_refused(saved_module, tmp_path):
    path, _, _ = saved_module
    other = make_env({"n_landmarks": 7})
    try:
        with pytest.raises(ValueError, match="does not fit this env"):
            load_rllib_agent(path, other)
    finally:
        other.close()
    with pytest.raises(ValueError, match="not found"):
        load_rllib_agent(tmp_path / "nothing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="not an RLlib checkpoint"):
        load_rllib_agent(tmp_path / "empty")
    (tmp_path / "half").mkdir()  # a module's constructor without its weights
    (tmp_path / "half" / "class_and_ctor_args.pkl").write_bytes(
        (path / "class_and_ctor_args.pkl").read_bytes()
    )
    with pytest.raises(ValueError, match="not an RLlib checkpoint"):
        load_rllib_agent(tmp_path / "half")


def test_a_gpu_learner_needs_a_gpu_in_the_cluster(monkeypatch):
    import ray

    settings = RLlibSettings(learner_device="gpu", num_learners=2)
    monkeypatch.setattr(ray, "cluster_resources", lambda: {"CPU": 16.0, "GPU": 1.0})
    with pytest.raises(ValueError, match="needs 2 GPU"):
        check_gpus(settings)
    monkeypatch.setattr(ray, "cluster_resources", lambda: {"CPU": 16.0, "GPU": 2.0})
    check_gpus(settings)  # raises nothing
    check_gpus(RLlibSettings())  # a CPU learner asks for none
