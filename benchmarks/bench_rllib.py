"""Sampling throughput: RLlib's EnvRunners (1 and 2) beside the stable-baselines3 path.

    .venv-rllib/bin/python -m benchmarks.bench_rllib [--steps 4096] [--repeats 3] [--n-envs K]

Env steps/s of collecting rollouts with the policy acting (no gradient updates), on
``slam_env/ActiveSLAM-v0`` with the default config's env options, sub-envs and
policy net (``agents/configs/ppo_default.yaml``; ``--n-envs`` sets the sub-envs of every
sampler), on one machine, in one run:

* ``sb3``: ``slam-env train``'s path, stable-baselines3's ``collect_rollouts`` on the
  native vector env of ``n_envs`` sub-envs, in this process;
* ``rllib, 1 EnvRunner`` and ``rllib, 2 EnvRunners``: ``slam-env train --engine
  rllib``'s EnvRunners (each stepping its own native vector env of ``n_envs``
  sub-envs, in its own Ray worker process) sampling ``--steps`` env steps each, in
  parallel, timed from this process around the call (Ray's dispatch included).

The rows take turns (``--repeats`` rounds) so that a slow spell of a shared machine
hits all of them; warm-up samples (compilation, first resets) come first and are not
timed. Needs the 'rllib' extra (``make setup-rllib``).
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

from agents.common.arguments import positive_int
from agents.learning.config import load_config
from agents.learning.sb3.runs import make_train_vec_env


def sb3_sampler(cfg: Any, steps: int) -> Any:
    """A function that collects ``steps`` env steps with SB3's PPO (default config)."""
    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(cfg.torch_threads)
    p = cfg.ppo
    model = PPO(
        "MlpPolicy",
        make_train_vec_env(cfg, cfg.n_envs, cfg.seed),
        n_steps=max(steps // cfg.n_envs, 1),
        batch_size=p.batch_size,
        policy_kwargs={
            "net_arch": {"pi": list(p.net_arch), "vf": list(p.net_arch)},
            "activation_fn": {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[p.activation],
        },
        seed=cfg.seed,
        device="cpu",
    )
    _, callback = model._setup_learn(10**9, None)

    def sample() -> int:
        model.collect_rollouts(model.env, callback, model.rollout_buffer, model.n_steps)
        return model.n_steps * cfg.n_envs

    return sample


def rllib_algo(cfg: Any, runners: int) -> Any:
    """An RLlib PPO of ``slam-env train --engine rllib`` with ``runners`` EnvRunners."""
    from agents.learning.rllib.config import RLlibSettings, ppo_config
    from agents.learning.rllib.env import register_rllib_envs

    register_rllib_envs()
    return ppo_config(cfg, RLlibSettings(num_env_runners=runners)).build_algo()


def rllib_sampler(algo: Any, runners: int, steps: int) -> Any:
    """A function that has the first ``runners`` EnvRunners sample ``steps`` each."""
    ids = list(range(1, runners + 1))

    def sample() -> int:
        counts = algo.env_runner_group.foreach_env_runner(
            lambda runner: sum(len(e) for e in runner.sample(num_timesteps=steps)),
            remote_worker_ids=ids,
            local_env_runner=False,
        )
        return int(sum(counts))

    return sample


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--steps", type=positive_int, default=4096, help="env steps per sampler a run"
    )
    parser.add_argument("--repeats", type=positive_int, default=3, help="runs per row")
    parser.add_argument(
        "--n-envs", type=positive_int, help="sub-envs per sampler (the config's n_envs)"
    )
    args = parser.parse_args(argv)

    import ray

    from agents.learning.rllib.training import stop_algorithm

    cfg = load_config(checkpoint_freq=0, eval_freq=0, progress_bar=False, n_envs=args.n_envs)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        algo = rllib_algo(cfg, runners=2)
        rows = {
            f"sb3, 1 process ({cfg.n_envs} sub-envs, native)": sb3_sampler(cfg, args.steps),
            f"rllib, 1 EnvRunner ({cfg.n_envs} sub-envs, native)": rllib_sampler(
                algo, 1, args.steps
            ),
            f"rllib, 2 EnvRunners ({cfg.n_envs} sub-envs each, native)": rllib_sampler(
                algo, 2, args.steps
            ),
        }
        for sample in rows.values():
            sample()  # warm-up: compiled kernels loaded, envs reset
        rates: dict[str, list[float]] = {label: [] for label in rows}
        for _ in range(args.repeats):
            for label, sample in rows.items():
                start = time.perf_counter()
                done = sample()
                rates[label].append(done / (time.perf_counter() - start))
        stop_algorithm(algo)
    finally:
        ray.shutdown()

    base = statistics.mean(next(iter(rates.values())))
    print(
        f"sampling (policy acting, no updates), slam_env/ActiveSLAM-v0, default config, "
        f"{args.steps:,} env steps per sampler per run, mean of {args.repeats} runs per row, "
        "taking turns:"
    )
    print("| sampler | env steps/s | × sb3 |")
    print("|---|---:|---:|")
    for label, values in rates.items():
        mean = statistics.mean(values)
        print(f"| {label} | {mean:,.0f} | {mean / base:.2f} |")


if __name__ == "__main__":
    main()
