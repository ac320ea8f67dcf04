"""The option fuzz behind tests/envs/test_option_fuzz.py, run in its own process under an
address-space limit: ``python -m tests.envs.option_fuzz ENV_ID``.

For every numeric option of the env ID (derived from the config dataclasses and the
env's own arguments, so that a new option is fuzzed too), hypothesis draws values from
1e-12 to 1e12 in magnitude, zero and negatives included. Each example must, within
:data:`EXAMPLE_CPU_SECONDS` of CPU time, either be refused at construction or first
reset with a ``ValueError``/``TypeError`` naming the option, or run 20 steps with every
observation inside its space, Python float rewards that are finite and no NaN in
``info``. A memory blow-up hits the address-space limit as a ``MemoryError`` and fails
the example instead of the machine. Prints one line per failure; exits 1 on any.
"""

from __future__ import annotations

import dataclasses
import math
import resource
import signal
import sys
import time
import warnings
from collections.abc import Callable
from typing import Any

ADDRESS_SPACE_BYTES = 4 * 2**30  # the budget's 2 GiB and the interpreter's ~0.2 GiB
EXAMPLE_CPU_SECONDS = 2.0
EXAMPLES_PER_OPTION = 8
STEPS = 20


def numeric_options(env_id: str) -> dict[str, str]:
    """Every numeric option of ``env_id`` → its kind: "int", "float", "tupleN" (N
    numbers), "cov" (a 2×2 matrix) or "weight" (an entry of ``reward_weights``)."""
    from slam_env.belief.reward import ActiveSLAMRewardWeights
    from slam_env.config import _SECTIONS, EnvConfig
    from slam_env.core.active_options import ActiveSLAMOptions

    kinds: dict[str, str] = {}
    fields = [f for cls in _SECTIONS.values() for f in dataclasses.fields(cls)]
    fields += [f for f in dataclasses.fields(EnvConfig) if f.name not in _SECTIONS]
    for f in fields:
        default = f.default
        if isinstance(default, (bool, str)) or f.name == "layout":
            continue
        if isinstance(default, (int, float)):
            kinds[f.name] = type(default).__name__
        elif isinstance(default, tuple):
            kinds[f.name] = f"tuple{len(default)}"
        elif "int" in str(f.type):  # None by default: max_detections
            kinds[f.name] = "int"
        elif "tuple" in str(f.type):  # None by default: odometry_bias
            kinds[f.name] = "tuple3"
    if env_id.endswith("ActiveSLAM-v0"):
        kinds.update(gate="float", filter_alphas="tuple4", filter_control_noise="tuple4")
        kinds["filter_measurement_cov"] = "cov"
        for f in dataclasses.fields(ActiveSLAMRewardWeights):
            kinds[f"reward_weights.{f.name}"] = "weight"
        assert {"gate", "filter_alphas"} <= {f.name for f in dataclasses.fields(ActiveSLAMOptions)}
    return kinds


def _options(name: str, kind: str, magnitude: float, entry: int | None) -> dict[str, Any]:
    """The env options that set ``name`` to ``magnitude`` (in every entry of a tuple, or
    in entry ``entry``), with the models that make it matter."""
    if kind == "int":
        value: Any = (
            int(magnitude) if abs(magnitude) < 2**62 else int(math.copysign(2**62, magnitude))
        )
    elif kind.startswith("tuple"):
        n = int(kind[len("tuple") :])
        base = [0.01] * n if name != "obstacle_size" else [0.6, 2.0]
        value = tuple(
            magnitude if entry is None or i == entry % n else b for i, b in enumerate(base)
        )
    elif kind == "cov":
        value = [[magnitude, 0.0], [0.0, magnitude]]
    else:
        value = float(magnitude)
    if kind == "weight":
        return {"reward_weights": {name.split(".")[1]: value}}
    options: dict[str, Any] = {name: value}
    if name in ("velocity_noise", "filter_control_noise"):
        options["motion_model"] = "velocity"
    if name == "cartesian_std":
        options["measurement_model"] = "cartesian"
    return options


def _nan_in(value: Any) -> bool:
    import numpy as np

    if isinstance(value, float):
        return math.isnan(value)
    if isinstance(value, np.ndarray) and value.dtype.kind in "fc":
        return bool(np.isnan(value).any())
    if isinstance(value, dict):
        return any(_nan_in(v) for v in value.values())
    return False


OUTCOMES = {"refused": 0, "ran": 0}  # how the examples that held ended


def run_example(env_id: str, name: str, options: dict[str, Any]) -> str | None:
    """None when the example holds, else what went wrong."""
    import gymnasium as gym

    named = name.split(".")[0]
    start = time.process_time()
    try:
        env = gym.make(env_id, **options)
        obs, info = env.reset(seed=0)
    except (ValueError, TypeError) as exc:
        if named not in str(exc):
            return f"refused without naming {named!r}: {type(exc).__name__}: {exc}"
        OUTCOMES["refused"] += 1
        return None
    env.action_space.seed(0)
    space = env.observation_space
    if not space.contains(obs) or _nan_in(info):
        return "the reset observation is outside its space or info holds NaN"
    for step in range(STEPS):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        if not space.contains(obs):
            return f"step {step}: observation outside its space"
        if type(reward) is not float or not math.isfinite(reward):
            return f"step {step}: reward {reward!r}"
        if _nan_in(info):
            return f"step {step}: NaN in info"
        if terminated or truncated:
            obs, info = env.reset()
    env.close()
    spent = time.process_time() - start
    if spent > EXAMPLE_CPU_SECONDS:
        return f"took {spent:.2f} s of CPU time"
    OUTCOMES["ran"] += 1
    return None


def _magnitudes() -> Any:
    from hypothesis import strategies as st

    return st.one_of(
        st.sampled_from([0.0, -1.0, 1e-12, 1e12]),
        st.builds(
            lambda sign, exponent, mantissa: sign * mantissa * 10.0**exponent,
            st.sampled_from([1.0, 1.0, -1.0]),
            st.integers(-12, 11),
            st.floats(1.0, 10.0),
        ),
    )


def _on_cpu_timer(signum: int, frame: Any) -> None:
    raise TimeoutError(f"still running after {EXAMPLE_CPU_SECONDS + 1.0:g} s of CPU time")


def _property(env_id: str, name: str, kind: str, found: list[str]) -> Callable[[], None]:
    """The hypothesis test of one option; a failing example's text goes to ``found``."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    @settings(
        max_examples=EXAMPLES_PER_OPTION,
        derandomize=True,
        database=None,
        deadline=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(magnitude=_magnitudes(), entry=st.one_of(st.none(), st.integers(0, 3)))
    def example(magnitude: float, entry: int | None) -> None:
        options = _options(name, kind, magnitude, entry)
        # A hang becomes a failed example: the CPU-time timer interrupts it.
        signal.setitimer(signal.ITIMER_PROF, EXAMPLE_CPU_SECONDS + 1.0)
        try:
            problem = run_example(env_id, name, options)
        except Exception as exc:  # anything else escaping the env is a failure
            problem = f"{type(exc).__name__}: {exc}"
        finally:
            signal.setitimer(signal.ITIMER_PROF, 0.0)
        if problem is not None:
            found.append(f"{env_id} {options}: {problem}")
            raise AssertionError(problem)

    return example


def warm_up(env_id: str) -> None:
    """Compile (or load) the kernels of every path the options can take, before any
    example is timed: the option sets of the pinned streams cover them."""
    import gymnasium as gym

    from tests.pinned_streams import OPTION_SETS

    for pinned_id, options in OPTION_SETS.values():
        if pinned_id == env_id:
            env = gym.make(env_id, **options)
            env.reset(seed=0)
            for _ in range(3):
                env.step(env.action_space.sample())


def fuzz(env_id: str, report: Callable[[str], None]) -> int:
    """Fuzz every numeric option of ``env_id``; report each failing option's shrunk
    example and return how many options failed."""
    failures = 0
    for name, kind in numeric_options(env_id).items():
        found: list[str] = []
        try:
            _property(env_id, name, kind, found)()
        except Exception:  # hypothesis raises a group when examples fail differently
            failures += 1
            report(found[-1])
    return failures


def main(argv: list[str]) -> int:
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_BYTES, ADDRESS_SPACE_BYTES))
    signal.signal(signal.SIGPROF, _on_cpu_timer)
    warnings.simplefilter("ignore")  # the checkers' warnings are not this test's subject
    import slam_env  # noqa: F401  (registers the IDs)

    warm_up(argv[0])
    failures = fuzz(argv[0], lambda line: print(line, flush=True))
    print(f"{failures} option(s) failed; of the examples that held, {OUTCOMES}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
