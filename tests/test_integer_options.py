"""Every integer option of the option tables has an upper bound that the kernels'
integer type holds (:data:`slam_env.kernels.base.integers.MAX_INTEGER`): a larger one is
a ``ValueError`` naming it, at once, from ``gym.make``, from the tables themselves and
from the ``slam-env`` command (issue #48, item 2: ``wide_pairing_scans=10**30`` passed
the checks and then broke the kernels' typing)."""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
import pytest

import slam_env  # noqa: F401  (registers the env IDs)
from agents.cli.main import main
from slam_env.belief.reward import ActiveSLAMRewardWeights
from slam_env.core.active_options import ActiveSLAMOptions
from slam_env.ekf import EKFSLAM
from slam_env.kernels.base.integers import MAX_INTEGER
from tests.test_option_table import TABLES, entries

HUGE = (MAX_INTEGER + 1, 10**30)


def integer_options() -> list[tuple[type, str]]:
    """(table, name) of every integer option of the tables."""
    out = []
    for table in TABLES:
        for f in entries(table):
            if isinstance(f.default, bool):
                continue
            if f.metadata.get("choices") or f.metadata.get("entries"):
                continue
            if isinstance(f.default, int) or "int" in str(f.type):
                out.append((table, f.name))
    return out


INTEGERS = integer_options()
IDS = [f"{t.__name__}.{n}" for t, n in INTEGERS]


def test_the_tables_have_integer_options() -> None:
    names = {name for _, name in INTEGERS}
    assert {"n_landmarks", "max_detections", "wide_pairing_scans"} <= names


@pytest.mark.parametrize(("table", "name"), INTEGERS, ids=IDS)
@pytest.mark.parametrize("value", HUGE, ids=["2**53+1", "10**30"])
def test_the_table_refuses_an_integer_beyond_the_kernels(table, name, value) -> None:
    extra = {"data_association": "jcbb"} if name == "wide_pairing_scans" else {}
    with pytest.raises(ValueError, match=rf"{name} must be .*got {value}") as refused:
        table(**{name: value}, **extra)
    high = table.__dataclass_fields__[name].metadata.get("high")
    assert high is not None or "2**53" in str(refused.value)  # the bound it was held to


ACTIVE_TABLES = (ActiveSLAMOptions, ActiveSLAMRewardWeights)
MAKE_CASES = [
    (env_id, table, name)
    for env_id in ("slam_env/Landmarks-v0", "slam_env/ActiveSLAM-v0")
    for table, name in INTEGERS
    if env_id == "slam_env/ActiveSLAM-v0" or table not in ACTIVE_TABLES
]


@pytest.mark.parametrize(
    ("env_id", "table", "name"), MAKE_CASES, ids=[f"{e}:{n}" for e, _, n in MAKE_CASES]
)
def test_gym_make_refuses_it_at_once(env_id, table, name) -> None:
    extra = {"data_association": "jcbb"} if table is ActiveSLAMOptions else {}
    start = time.perf_counter()
    with pytest.raises(ValueError, match=rf"{name} must be .*got {10**30}"):
        gym.make(env_id, **{name: 10**30}, **extra)
    assert time.perf_counter() - start < 1.0


def test_the_filter_refuses_integers_beyond_the_kernels() -> None:
    base = dict(alphas=(0.0, 0.0, 0.0, 0.0), measurement_cov=np.eye(2), max_landmarks=3)
    for value in HUGE:
        with pytest.raises(ValueError, match=rf"wide_pairing_scans must be .*2\*\*53.*{value}"):
            EKFSLAM(**base, data_association="jcbb", wide_pairing_scans=value)
        with pytest.raises(ValueError, match=rf"max_landmarks must be .*2\*\*53.*{value}"):
            EKFSLAM(**{**base, "max_landmarks": value})
    f = EKFSLAM(**base, data_association="jcbb", wide_pairing_scans=MAX_INTEGER)
    f.update(np.array([[1.0, 0.0]]))  # the largest allowed reaches the kernels and runs
    assert f.n_landmarks == 1


@pytest.mark.parametrize("name", ["wide_pairing_scans", "n_obstacles"])
def test_the_command_exits_2_with_one_line(name, tmp_path, capsys) -> None:
    argv = ["evaluate", "--agents", "random", "--episodes", "1", "--out", str(tmp_path)]
    argv += ["--env-option", "data_association=jcbb", "--env-option", f"{name}={10**30}"]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    assert f"{name} must be" in err and "2**53" in err
