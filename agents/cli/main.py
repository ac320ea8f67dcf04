"""The ``slam-env`` command (also ``python -m agents``).

    slam-env train    [--config YAML] [--total-steps N] [--n-envs K] [--seed S] [--out DIR]
                      [--vectorization native|subproc|dummy] [--engine sb3|rllib]
                      [--address ADDR] [--num-env-runners R] [--num-envs-per-runner K]
                      [--learner-device cpu|gpu] [--num-learners L]   (the last five: rllib)
    slam-env evaluate --agents random,frontier,infogain,goals,ppo:PATH [--episodes 20]
                      [--seed 0] [--out DIR] [--max-steps N] [--env-option KEY=VALUE ...]
    slam-env evaluate --agents ... --suite default|smoke [--episodes 3] [--seed 10000] [--out DIR]
    slam-env demo     [--agent SPEC] [--seed S] [--out DIR] [--no-gif] [--max-steps N]

    slam-env --version

Every user error (bad arguments, options, files, an unwritable ``--out``) prints one
line naming the problem and exits with status 2, before anything runs.
``--env-option`` values are YAML scalars read as YAML 1.2 reads them: ``2e-1`` and
``1e-3`` are numbers, ``true`` a bool, ``[1, 2]`` a list.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import yaml

import slam_env
from agents.common.arguments import non_negative_int, positive_int
from agents.learning.config import VECTORIZATIONS
from agents.registry import AGENT_NAMES
from slam_env.config import BELIEFS
from slam_env.extras import MissingExtra, require

PROG = "slam-env"


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (status 2)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


class _Yaml12Loader(yaml.SafeLoader):
    """PyYAML's safe loader, which follows YAML 1.1 and reads ``2e-1`` as a string,
    with YAML 1.2's floats: a mantissa without a dot and an exponent is a number."""


_Yaml12Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$"),
    list("-+.0123456789"),
)


def yaml_scalar(text: str) -> Any:
    """A value written in YAML (1.2 numbers): ``2e-1`` → 0.2, ``true`` → True,
    ``[1, 2]`` → [1, 2]; an empty text is None."""
    return yaml.load(text, Loader=_Yaml12Loader) if text.strip() else None  # a SafeLoader


def check_writable_dir(path: str | Path, what: str = "--out") -> None:
    """``ValueError`` unless ``path`` is, or can be created as, a directory one can
    write into: checked by writing (and removing) a file in it or in its nearest
    existing parent, so that nothing runs before a run that could not save."""
    target = Path(path)
    probe = target
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise ValueError(f"{what} {str(target)!r}: {str(probe)!r} is not a directory")
    try:
        with tempfile.TemporaryFile(dir=probe):
            pass
    except OSError as exc:
        raise ValueError(
            f"{what} {str(target)!r} is not writable: cannot write in {str(probe)!r}: "
            f"{exc.strerror or exc}"
        ) from None


def _env_option(text: str) -> tuple[str, Any]:
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE (e.g. n_landmarks=10), got {text!r}")
    try:
        value = yaml_scalar(raw)
    except yaml.YAMLError as exc:
        raise argparse.ArgumentTypeError(f"cannot parse the value of {key!r}: {exc}") from None
    return key, value


def _options(pairs: Sequence[tuple[str, Any]] | None) -> dict[str, Any] | None:
    return dict(pairs) if pairs else None


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog=PROG,
        description="Active SLAM agents on slam_env/ActiveSLAM-v0: train PPO, compare "
        "agents, run the demo.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {slam_env.__version__}")
    sub = parser.add_subparsers(dest="command", metavar="{train,evaluate,demo}")
    sub.required = True
    env_help = "an env option KEY=VALUE (YAML value), e.g. n_landmarks=10; repeatable"

    p = sub.add_parser("train", help="train a PPO policy", description="Train PPO.")
    p.add_argument("--config", type=Path, help="training config YAML (default: ppo_default.yaml)")
    p.add_argument("--total-steps", type=positive_int, help="env steps to train for")
    p.add_argument("--n-envs", type=positive_int, help="sub-envs stepped together")
    p.add_argument(
        "--vectorization",
        choices=VECTORIZATIONS,
        help="native: one vector env steps them all (default); subproc: a process each; "
        "dummy: one after the other",
    )
    p.add_argument("--seed", type=non_negative_int, help="training seed")
    p.add_argument("--out", type=str, help="output folder (model, config, logs)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    _add_rllib_arguments(p)

    p = sub.add_parser(
        "evaluate",
        help="compare agents on the same seeded worlds",
        description="Run every agent on the same seeded worlds; write a table and plots.",
    )
    p.add_argument(
        "--agents",
        required=True,
        help=f"comma-separated agent specs: {', '.join(AGENT_NAMES)}",
    )
    p.add_argument(
        "--episodes",
        type=positive_int,
        help="episodes per agent (default 20); with --suite, per setting (default the "
        "suite's own: 3)",
    )
    p.add_argument(
        "--seed",
        type=non_negative_int,
        help="episode i uses seed+i (default 0; with --suite the suite's own: 10000)",
    )
    p.add_argument("--out", type=str, default="out/eval", help="output folder")
    p.add_argument("--max-steps", type=positive_int, help="episode length (default 500)")
    p.add_argument("--env-option", type=_env_option, action="append", help=env_help)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--suite",
        help="run a fixed suite of world settings × seeds instead (default, smoke; see "
        "agents/evaluation/suite.py); --max-steps and --env-option do not apply",
    )
    p.add_argument(
        "--settings",
        help="with --suite: only these of its settings, comma-separated (e.g. default,rooms)",
    )
    p.add_argument(
        "--belief",
        choices=BELIEFS,
        help="the belief the agents act on, in every setting of a suite too (default: the "
        "env's, 'ekf'; 'isam2': the smoothing belief, the gtsam extra)",
    )
    p.add_argument(
        "--export-trajectories",
        metavar="DIR",
        help="also write each episode's true and estimated trajectories (TUM files, for "
        "evo) and final map (CSV) into DIR/<agent>/",
    )

    p = sub.add_parser(
        "demo",
        help="run the best shipped agent once: GIF, final map, metrics",
        description="One episode of an agent on the default world: GIF, map PNG, metrics.",
    )
    p.add_argument("--agent", type=str, help="agent spec (default: the best shipped agent)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="world seed")
    p.add_argument("--out", type=str, default="out", help="output folder")
    p.add_argument("--no-gif", action="store_true", help="skip the animated GIF")
    p.add_argument("--max-steps", type=positive_int, help="episode length (default 500)")
    p.add_argument("--env-option", type=_env_option, action="append", help=env_help)
    return parser


#: The ``train`` flags that only the RLlib engine reads (dest names).
RLLIB_FLAGS = (
    "address",
    "num_env_runners",
    "num_envs_per_runner",
    "learner_device",
    "num_learners",
)


def _add_rllib_arguments(p: argparse.ArgumentParser) -> None:
    """``train``'s engine choice and the RLlib engine's cluster flags."""
    p.add_argument(
        "--engine",
        choices=("sb3", "rllib"),
        default="sb3",
        help="sb3: stable-baselines3 in this process (default); rllib: Ray RLlib, on a "
        "Ray cluster (needs the 'rllib' extra)",
    )
    p.add_argument(
        "--address", type=str, help="rllib: the Ray cluster to join (default: RAY_ADDRESS or local)"
    )
    p.add_argument("--num-env-runners", type=non_negative_int, help="rllib: EnvRunners (1)")
    p.add_argument(
        "--num-envs-per-runner",
        type=positive_int,
        help="rllib: sub-envs each (the config's n_envs)",
    )
    p.add_argument("--learner-device", choices=("cpu", "gpu"), help="rllib: the learners' device")
    p.add_argument(
        "--num-learners", type=non_negative_int, help="rllib: learner actors (0: in this process)"
    )


def _rllib_settings(args: argparse.Namespace) -> Any:
    """The RLlib engine's settings from the flags (``ValueError`` if given to sb3)."""
    given = [
        f"--{name.replace('_', '-')}" for name in RLLIB_FLAGS if getattr(args, name) is not None
    ]
    if args.engine != "rllib":
        if given:
            raise ValueError(f"{', '.join(given)} only apply with --engine rllib")
        return None
    from agents.learning.rllib.env import require_rllib

    require_rllib("--engine rllib")  # before anything else is read or run
    from agents.learning.rllib.config import RLlibSettings

    chosen = {name: getattr(args, name) for name in RLLIB_FLAGS if getattr(args, name) is not None}
    return RLlibSettings(**chosen)


def _run_train(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.markup import escape

    from agents.learning.config import load_config
    from agents.learning.sb3.training import train

    settings = _rllib_settings(args)
    cfg = load_config(
        args.config,
        total_timesteps=args.total_steps,
        n_envs=args.n_envs,
        vectorization=args.vectorization,
        seed=args.seed,
        out_dir=args.out,
        progress_bar=False if args.no_progress else None,
    )
    check_writable_dir(cfg.out_dir, "--out" if args.out else "the config's out_dir")
    if settings is None:
        path = train(cfg)
    else:
        from agents.learning.rllib.training import train_rllib

        path = train_rllib(cfg, settings)
    console = Console()
    console.print(f"model: {escape(str(path))}")
    summary_file = path.parent / "training_summary.json"
    if summary_file.is_file():
        s = json.loads(summary_file.read_text())
        done, rate, unit = (
            (s["choices"], s["choices_per_s"], "choices")  # decisions: goals
            if "choices" in s
            else (s["timesteps"], s["env_steps_per_s"], "env steps")
        )
        console.print(
            f"{done} {unit} in {s['wall_time_s']:.1f} s "
            f"({rate} {unit}/s with {s['n_envs']} envs, {s['vectorization']})"
        )
        if "sampler_threads" in s:
            workers = "process" if s["vectorization"] == "subproc" else "thread"
            console.print(
                f"sampler: {_count(s['sampler_threads'], workers)} over {s['n_envs']} envs; "
                f"learner: torch on {_count(s['torch_threads'], 'thread')}"
            )
        if s["env_step_share"] is not None:
            console.print(
                f"wall time: {100 * s['env_step_share']:.0f}% env stepping, "
                f"{100 * s['gradient_updates_share']:.0f}% gradient updates, "
                f"{100 * s['other_share']:.0f}% the rest"
            )
    return 0


def _count(n: int, noun: str) -> str:
    """``1 thread``, ``2 threads``, ``2 processes``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}{'es' if noun.endswith('s') else 's'}"


def _run_evaluate(args: argparse.Namespace) -> int:
    from agents.evaluation.compare import evaluate

    check_writable_dir(args.out)
    if args.export_trajectories is not None:
        if args.suite is not None:
            raise ValueError(
                "--export-trajectories writes a plain evaluation's episodes: drop --suite"
            )
        check_writable_dir(args.export_trajectories, "--export-trajectories")
    if args.suite is not None:
        return _run_suite(args)
    if args.settings is not None:
        raise ValueError("--settings chooses settings of a suite: give --suite too")
    given = {"episodes": args.episodes, "seed": args.seed}  # None: evaluate's defaults
    env_options = _options(args.env_option) or {}
    if args.belief is not None:
        if "belief" in env_options:
            raise ValueError("give the belief once: --belief or --env-option belief=...")
        env_options["belief"] = args.belief
    result = evaluate(
        args.agents,
        **{name: value for name, value in given.items() if value is not None},
        env_options=env_options or None,
        out_dir=args.out,
        max_steps=args.max_steps,
        progress=not args.no_progress,
        trajectories_dir=args.export_trajectories,
    )
    for name, path in result.files.items():
        print(f"{name}: {path}")
    return 0


def _run_suite(args: argparse.Namespace) -> int:
    from agents.evaluation.suite import chosen_settings, run_suite

    names = None if args.settings is None else [n.strip() for n in args.settings.split(",")]
    chosen_settings(args.suite, names)  # an unknown name, before anything runs
    if args.env_option or args.max_steps is not None:
        raise ValueError("--suite fixes its settings: drop --env-option and --max-steps")
    result = run_suite(
        args.agents,
        args.suite,
        args.out,
        episodes=args.episodes,
        seed=args.seed,
        settings=names,
        belief=args.belief or "ekf",
        progress=not args.no_progress,
    )
    for name, path in result.files.items():
        print(f"{name}: {path}")
    return 0


def _run_demo(args: argparse.Namespace) -> int:
    from agents.evaluation.demo import demo

    check_writable_dir(args.out)
    demo(
        args.agent,
        seed=args.seed,
        out_dir=args.out,
        gif=not args.no_gif,
        max_steps=args.max_steps,
        env_options=_options(args.env_option),
    )
    return 0


_COMMANDS = {"train": _run_train, "evaluate": _run_evaluate, "demo": _run_demo}
# The extras each command needs beyond the core install (tables, progress, pictures).
_EXTRAS = {"train": ("agents",), "evaluate": ("agents", "render"), "demo": ("agents", "render")}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status (bad arguments raise ``SystemExit(2)``)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        for extra in _EXTRAS[args.command]:
            require(extra, f"{PROG} {args.command}")
        return _COMMANDS[args.command](args)
    except (ValueError, TypeError, OSError, MissingExtra) as exc:
        # Config, agent spec, env option, file or output-folder problems, or an extra
        # not installed: a usage error, on one line.
        message = " ".join(str(exc).split())
        parser.exit(2, f"{PROG} {args.command}: error: {message}\n")
    except KeyboardInterrupt as exc:
        print(f"{PROG} {args.command}: {exc or 'interrupted'}", file=sys.stderr)
        return 130
    return 0  # unreachable: parser.exit raises


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
