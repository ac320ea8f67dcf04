"""Evaluation suites: the metrics, the settings, and ``--suite`` end to end."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.cli import main
from agents.evaluation import EpisodeRecord
from agents.suite import SUITES, suite_settings
from agents.suite_metrics import steps_to_share, suite_metrics


def _record(known, entropy, collision, n=4, map_rmse=None):
    t = len(known)
    return EpisodeRecord(
        seed=0,
        n_landmarks=n,
        true_poses=np.zeros((t, 3)),
        est_poses=np.zeros((t, 3)),
        entropy=np.asarray(entropy, float),
        landmarks_known=np.asarray(known, float),
        pose_error=np.zeros(t),
        pose_nees=np.zeros(t),
        map_rmse=np.full(t, 0.1) if map_rmse is None else np.asarray(map_rmse, float),
        collision=np.asarray(collision, bool),
        rewards=np.zeros(t - 1),
    )


def test_steps_to_a_share_are_censored_at_the_episode_length():
    known = np.array([0, 1, 2, 2, 3, 3])
    assert steps_to_share(known, 4, 0.5) == (2, True)
    assert steps_to_share(known, 4, 0.75) == (4, True)
    assert steps_to_share(known, 4, 1.0) == (5, False)  # never: the length, censored
    assert steps_to_share(np.zeros(3), 1, 0.5) == (2, False)  # at least one landmark


def test_suite_metrics_of_a_record():
    rec = _record([0, 2, 4, 4, 4], [10, 8, 4, 4, 2], [0, 1, 0, 1, 0])
    m = suite_metrics(rec)
    assert (m["steps_to_50"], m["steps_to_90"], m["steps_to_100"]) == (1, 2, 2)
    assert m["reached_100"] == 1.0 and m["mapped_share"] == 1.0
    assert m["entropy_auc"] == pytest.approx((9 + 6 + 4 + 3) / 4)  # trapezoids / steps
    assert m["collisions_per_100"] == pytest.approx(50.0)  # step 0 (the reset) not counted
    assert (m["final_entropy"], m["map_rmse"]) == (2.0, 0.1)


def test_suite_metrics_read_the_last_step():
    rec = _record([0, 1, 3], [5, 4, 3], [0, 0, 0], map_rmse=[np.nan, 0.4, 0.2])
    m = suite_metrics(rec)
    assert m["mapped_share"] == 0.75  # the landmark found on the last step counts
    assert m["map_rmse"] == 0.2  # the final map, not an earlier one
    assert (m["steps_to_50"], m["steps_to_90"]) == (2, 2)
    assert m["reached_90"] == 0.0  # 3 of 4 is below 90%: censored at the length


@pytest.mark.parametrize(
    ("known", "entropy", "collision", "auc", "per_100"),
    [
        ([1], [7.0], [1], 7.0, 0.0),  # no step: the entropy after reset, no collision
        ([1, 2], [7.0, 3.0], [1, 1], 5.0, 100.0),  # one step: one trapezoid
    ],
)
def test_suite_metrics_of_the_shortest_episodes(known, entropy, collision, auc, per_100):
    m = suite_metrics(_record(known, entropy, collision, n=2))
    assert m["entropy_auc"] == auc
    assert m["collisions_per_100"] == per_100
    assert m["final_entropy"] == entropy[-1]


def test_the_default_suite_covers_the_issue_settings():
    names = [s.name for s in suite_settings("default")]
    assert names == [
        "default", "open", "cluttered", "rooms", "arena_8m", "arena_32m",
        "landmarks_10", "landmarks_60", "short_range", "sensor_360",
    ]  # fmt: skip
    steps = {s.name: s.steps for s in suite_settings("default")}
    assert (steps["arena_8m"], steps["default"], steps["arena_32m"]) == (250, 500, 1000)
    assert set(SUITES) >= {"default", "smoke"}
    with pytest.raises(ValueError, match="unknown suite"):
        suite_settings("huge")


def test_cli_suite_runs_end_to_end_and_writes_its_files(tmp_path, capsys):
    out = tmp_path / "suite"
    assert main(["evaluate", "--agents", "random,frontier", "--suite", "smoke",
                 "--out", str(out), "--no-progress"]) == 0  # fmt: skip
    for name in ("suite.csv", "suite_episodes.csv", "suite.md", "results.json",
                 "suite_steps_to_90.png", "suite_final_entropy.png"):  # fmt: skip
        assert (out / name).stat().st_size > 0, name
    results = json.loads((out / "results.json").read_text())
    settings = [s["name"] for s in results["settings"]]
    assert len(results["rows"]) == 2 * len(settings)
    assert {r["agent"] for r in results["rows"]} == {"random", "frontier"}
    table = (out / "suite.md").read_text()
    assert "| default | frontier |" in table and "Head to head" in table
    assert "suite_md:" in capsys.readouterr().out


def test_cli_suite_refuses_bad_input(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--agents", "random", "--suite", "nope", "--out", str(tmp_path)])
    assert exc.value.code == 2 and "unknown suite" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["evaluate", "--agents", "random", "--suite", "smoke", "--max-steps", "5",
              "--out", str(tmp_path)])  # fmt: skip
    assert "--suite fixes" in capsys.readouterr().err


def test_a_policy_tied_to_its_landmark_count_is_refused_before_anything_runs(tmp_path):
    from agents.suite import run_suite

    # The shipped egocentric policy has 20 landmark slots; the smoke suite's rooms 6.
    with pytest.raises(ValueError, match="setting 'rooms'"):
        run_suite(["random", "ppo"], "smoke", tmp_path, progress=False, verbose=False)
    assert not (tmp_path / "suite.csv").exists()
