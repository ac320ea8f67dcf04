"""The evaluator: Student-t statistics, per-episode metrics, files, fairness, determinism."""

from __future__ import annotations

import csv
import gzip
import importlib.util
import json
import math
from statistics import NormalDist

import numpy as np
import pytest

from agents.common.base import RandomAgent
from agents.common.env import make_env
from agents.evaluation.compare import STEP_COLUMNS, episode_columns, evaluate, summary_columns
from agents.evaluation.statistics import mean_ci, t_quantile
from agents.rollouts.episodes import run_episode
from agents.rollouts.records import METRICS, EpisodeRecord
from slam_env.belief.metrics import averaged_nees, nees_band

SMALL_WORLD = {"n_landmarks": 6, "width": 8.0, "height": 8.0, "n_obstacles": 1}
HEURISTICS = [
    name for name in ("frontier", "infogain") if importlib.util.find_spec(f"agents.{name}")
]
AGENTS = ["random", *HEURISTICS]

# Two-sided Student-t critical values (published tables, 6 significant digits).
T_TABLE = [
    (0.975, 1, 12.7062),
    (0.975, 2, 4.30265),
    (0.975, 3, 3.18245),
    (0.975, 4, 2.77645),
    (0.975, 9, 2.26216),
    (0.975, 19, 2.09302),
    (0.975, 29, 2.04523),
    (0.975, 100, 1.98397),
    (0.975, 1000, 1.96234),
    (0.995, 5, 4.03214),
    (0.95, 10, 1.81246),
    (0.9, 10, 1.37218),
]


# ---------------------------------------------------------------------- statistics
@pytest.mark.parametrize(("p", "dof", "expected"), T_TABLE)
def test_t_quantile_matches_tables(p, dof, expected):
    assert t_quantile(p, dof) == pytest.approx(expected, abs=6e-5)


@pytest.mark.parametrize("p", [0.6, 0.9, 0.975, 0.999])
def test_t_quantile_matches_closed_forms(p):
    # dof 1 (Cauchy) and dof 2 have closed-form quantiles.
    assert t_quantile(p, 1) == pytest.approx(math.tan(math.pi * (p - 0.5)), rel=1e-9)
    assert t_quantile(p, 2) == pytest.approx((2 * p - 1) / math.sqrt(2 * p * (1 - p)), rel=1e-9)
    assert t_quantile(1 - p, 7.5) == pytest.approx(-t_quantile(p, 7.5), rel=1e-12)
    assert t_quantile(p, 7.5) > NormalDist().inv_cdf(p)  # heavier tails than the normal


def test_t_quantile_tends_to_the_normal():
    z = NormalDist().inv_cdf(0.975)
    assert t_quantile(0.975, 1e7) == pytest.approx(z, abs=1e-6)
    assert t_quantile(0.975, math.inf) == pytest.approx(z, rel=1e-12)


@pytest.mark.parametrize(
    ("p", "dof"), [(0.0, 3), (1.0, 3), (-0.1, 3), (0.9, 0), (0.9, -2), (0.9, math.nan)]
)
def test_t_quantile_rejects_bad_arguments(p, dof):
    with pytest.raises(ValueError):
        t_quantile(p, dof)


def test_mean_ci():
    mean, half, n = mean_ci([1.0, 2.0, 3.0, 4.0, 5.0])
    assert (mean, n) == (3.0, 5)
    assert half == pytest.approx(2.7764451 * math.sqrt(2.5) / math.sqrt(5), rel=1e-7)
    mean, half, n = mean_ci([2.0, math.nan, 4.0, math.inf])  # non-finite values are dropped
    assert (mean, n) == (3.0, 2)
    assert half == pytest.approx(12.7062047 * math.sqrt(2.0) / math.sqrt(2), rel=1e-7)
    assert mean_ci([7.0, 7.0, 7.0])[1] == 0.0
    mean, half, n = mean_ci([4.0])
    assert mean == 4.0 and math.isnan(half) and n == 1
    assert mean_ci([])[2] == 0


def test_mean_ci_covers_the_true_mean_95_percent_of_the_time():
    rng = np.random.default_rng(0)
    samples = rng.normal(1.0, 2.0, size=(4000, 5))
    hits = 0
    for row in samples:
        mean, half, _ = mean_ci(row)
        hits += abs(mean - 1.0) <= half
    assert hits / len(samples) == pytest.approx(0.95, abs=0.012)


# ---------------------------------------------------------------------- per-episode metrics
def test_episode_metrics_from_a_known_record():
    poses = np.array([[0, 0, 0], [3, 4, 0], [3, 4, 1], [6, 8, 0]], dtype=float)  # 5 + 0 + 5 m
    rec = EpisodeRecord(
        seed=3,
        n_landmarks=4,
        true_poses=poses,
        est_poses=poses,
        entropy=np.array([10.0, 8.0, 6.0, 5.0]),
        landmarks_known=np.array([1, 2, 3, 3]),
        pose_error=np.array([0.0, 1.0, 2.0, 2.0]),
        pose_nees=np.array([math.inf, 1.0, 3.0, math.nan]),
        map_rmse=np.array([0.1, 0.2, 0.3, 0.25]),
        collision=np.array([True, False, True, True]),
        rewards=np.array([1.0, -0.5, 2.0]),
    )
    m = rec.metrics()
    assert set(m) == set(METRICS)
    assert m["mapped_share"] == 0.75
    assert m["final_entropy"] == 5.0
    assert m["map_rmse"] == 0.25
    assert m["pose_rmse"] == pytest.approx(math.sqrt((1 + 4 + 4) / 3))  # reset step left out
    assert m["mean_pose_nees"] == 2.0  # non-finite NEES left out
    assert m["collisions"] == 2  # the reset step is not a step taken
    assert m["path_length"] == pytest.approx(10.0)
    assert m["return"] == 2.5
    assert m["steps"] == 3


# ---------------------------------------------------------------------- evaluate
def _read_csv(path):
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        return reader.fieldnames, list(reader)


def evaluate_tiny(out_dir):
    """Every agent, 2 short episodes on the small world, seed 5, quietly."""
    return evaluate(
        AGENTS,
        episodes=2,
        seed=5,
        env_options=SMALL_WORLD,
        out_dir=out_dir,
        max_steps=30,
        progress=False,
        verbose=False,
    )


@pytest.fixture(scope="module")
def tiny_eval(tmp_path_factory):
    out = tmp_path_factory.mktemp("eval")
    return out, evaluate_tiny(out)


def test_evaluate_writes_tables_and_plots(tiny_eval):
    out, _ = tiny_eval
    names = ["summary.csv", "episodes.csv", "results.json", "trajectories.png"]
    names.append("metrics_over_time.png")
    for name in names:
        assert (out / name).is_file(), name
    for png in ("trajectories.png", "metrics_over_time.png"):
        data = (out / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000

    columns, rows = _read_csv(out / "summary.csv")
    assert columns == summary_columns()
    assert [r["agent"] for r in rows] == AGENTS
    assert all(r["episodes"] == "2" for r in rows)

    columns, rows = _read_csv(out / "episodes.csv")
    assert columns == episode_columns()
    assert len(rows) == 2 * len(AGENTS)
    for row in rows:
        assert row["steps"] == "30"
        assert 0.0 <= float(row["mapped_share"]) <= 1.0
        assert float(row["final_entropy"]) == pytest.approx(float(row["final_entropy"]))

    payload = json.loads((out / "results.json").read_text())
    assert payload["settings"]["seeds"] == [5, 6]
    assert payload["settings"]["env_options"] == SMALL_WORLD
    assert [r["agent"] for r in payload["summary"]] == AGENTS
    assert len(payload["episodes"]) == 2 * len(AGENTS)


def test_evaluate_writes_every_step(tiny_eval):
    out, result = tiny_eval
    with gzip.open(out / "steps.csv.gz", "rt", newline="") as fh:
        reader = csv.DictReader(fh)
        assert reader.fieldnames == STEP_COLUMNS
        rows = list(reader)
    assert len(rows) == len(AGENTS) * 2 * 31  # reset + 30 steps per episode
    assert [r["step"] for r in rows[:31]] == [str(t) for t in range(31)]
    assert rows[0]["reward"] == "" and rows[1]["reward"] != ""
    for ep in result.episodes:  # the last step of each episode matches its metrics
        last = [r for r in rows if (r["agent"], r["episode"]) == (ep["agent"], str(ep["episode"]))][
            -1
        ]
        assert int(last["landmarks_known"]) == round(ep["mapped_share"] * 6)
        assert float(last["entropy"]) == ep["final_entropy"]


def test_evaluate_gives_every_agent_the_same_worlds(tiny_eval):
    _, result = tiny_eval
    by_agent = {a: [r for r in result.episodes if r["agent"] == a] for a in AGENTS}
    for rows in by_agent.values():
        assert [r["seed"] for r in rows] == [5, 6]
    worlds = {a: [r["world"] for r in rows] for a, rows in by_agent.items()}
    assert worlds["random"][0] != worlds["random"][1]  # two different worlds...
    assert all(w == worlds["random"] for w in worlds.values())  # ...the same for everyone
    for a in AGENTS:  # and the same start pose
        start = [rec.true_poses[0] for rec in result.records[a]]
        np.testing.assert_array_equal(start, [r.true_poses[0] for r in result.records["random"]])


def test_evaluate_summary_is_the_mean_of_the_episodes(tiny_eval):
    _, result = tiny_eval
    for row in result.summary:
        eps = [r for r in result.episodes if r["agent"] == row["agent"]]
        for name in ("mapped_share", "path_length", "pose_rmse"):
            assert row[f"{name}_mean"] == pytest.approx(np.mean([r[name] for r in eps]))


def test_evaluate_summary_has_the_share_of_steps_in_the_nees_band(tiny_eval):
    out, result = tiny_eval
    for row in result.summary:
        nees = [r.pose_nees for r in result.records[row["agent"]]]
        mean, runs = averaged_nees(nees)
        lower, upper = nees_band(3, 2)  # both episodes reach every step
        assert np.all(runs[1:] <= 2)
        ok = np.isfinite(mean[1:])
        inside = (mean[1:][ok] >= lower) & (mean[1:][ok] <= upper)
        assert row["nees_in_band"] == pytest.approx(inside.mean())
    _, rows = _read_csv(out / "summary.csv")
    assert [float(r["nees_in_band"]) for r in rows] == [r["nees_in_band"] for r in result.summary]
    data = (out / "consistency.png").read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_evaluate_is_deterministic(tiny_eval, tmp_path):
    out, _ = tiny_eval
    evaluate_tiny(tmp_path)
    assert (tmp_path / "episodes.csv").read_text() == (out / "episodes.csv").read_text()
    assert (tmp_path / "summary.csv").read_text() == (out / "summary.csv").read_text()
    assert (tmp_path / "steps.csv.gz").read_bytes() == (out / "steps.csv.gz").read_bytes()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"agent_specs": ["random", "random"]}, "given twice"),
        ({"agent_specs": ["random", "teleport"]}, "unknown agent 'teleport'"),
        ({"agent_specs": "random,"}, "empty agent spec"),
        ({"agent_specs": [], "episodes": 1}, "no agent"),
        ({"agent_specs": ["random"], "episodes": 0}, "episodes"),
        ({"agent_specs": ["random"], "plot_episode": 3}, "plot_episode"),
        ({"agent_specs": ["random"], "env_options": {"n_landmark": 3}}, "n_landmark"),
    ],
)
def test_evaluate_rejects_bad_arguments(kwargs, match, tmp_path):
    kwargs = {"episodes": 2, "out_dir": tmp_path, "progress": False, "verbose": False, **kwargs}
    with pytest.raises(ValueError, match=match):
        evaluate(**kwargs)
    assert not (tmp_path / "summary.csv").exists()


def test_an_episode_without_a_mapped_landmark_has_no_map_error():
    """The env leaves map_rmse out of info until a landmark is mapped; the record holds
    NaN for those steps, which the summary leaves out of the mean."""
    env = make_env({"n_landmarks": 1, "max_range": 1.0}, max_steps=5)
    record = run_episode(env, RandomAgent(env, seed=0), seed=2)
    env.close()
    assert record.landmarks_known[-1] == 0 and np.isnan(record.map_rmse).all()
    assert math.isnan(record.metrics()["map_rmse"])
    assert mean_ci([record.metrics()["map_rmse"], 0.2, 0.4])[:1] == (pytest.approx(0.3),)


def test_the_episode_memory_budget_is_checked_at_its_edge():
    from agents.rollouts.records import STEP_BYTES_KEPT, STEP_BYTES_RUNNING, check_episode_memory
    from slam_env.budget import MAX_MEMORY_BYTES

    steps = 499
    fits = (MAX_MEMORY_BYTES // (steps + 1) - STEP_BYTES_RUNNING) // STEP_BYTES_KEPT
    check_episode_memory(steps, fits, "x")  # exactly within
    with pytest.raises(ValueError, match=f"x: {fits + 1} episode records of 499 steps"):
        check_episode_memory(steps, fits + 1, "x")
    fits = (MAX_MEMORY_BYTES // 501 - STEP_BYTES_RUNNING) // STEP_BYTES_KEPT
    check_episode_memory(None, fits, "x")  # None: the envs' default 500 steps, 501 rows
    with pytest.raises(ValueError, match="of 500 steps"):
        check_episode_memory(None, fits + 1, "x")
