"""Evaluation suites: the metrics, the settings, and ``--suite`` end to end."""

from __future__ import annotations

import json

import numpy as np
import pytest

from agents.cli.main import main
from agents.evaluation.suite import SUITES, chosen_settings, run_suite, suite_settings
from agents.rollouts.records import EpisodeRecord
from agents.rollouts.suite_metrics import steps_to_share, suite_metrics


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
    options = {s.name: s.env_options for s in suite_settings("default")}
    assert options["default"] == {}
    assert [options[p]["preset"] for p in ("open", "cluttered", "rooms")] == [
        "open", "cluttered", "rooms"
    ]  # fmt: skip
    assert (options["arena_8m"]["width"], options["arena_32m"]["height"]) == (8.0, 32.0)
    assert (options["landmarks_10"], options["landmarks_60"]) == (
        {"n_landmarks": 10}, {"n_landmarks": 60}
    )  # fmt: skip
    assert options["short_range"] == {"max_range": 2.5}
    assert options["sensor_360"]["fov"] == pytest.approx(2.0 * np.pi)
    assert set(SUITES) >= {"default", "smoke"}
    with pytest.raises(ValueError, match="unknown suite"):
        suite_settings("huge")


def test_the_table_marks_each_settings_best_and_counts_wins_head_to_head():
    from agents.evaluation.suite import suite_markdown

    def row(setting, agent, s90, h):
        return {"setting": setting, "agent": agent, "steps_to_90": s90, "final_entropy": h,
                "mapped_share": 1.0, "steps_to_50": 1.0, "steps_to_100": 2.0,
                "entropy_auc": 0.0, "collisions_per_100": 0.0, "map_rmse": 0.1}  # fmt: skip

    rows = [
        row("a", "x", 100.0, -5.0), row("a", "y", 120.0, -7.0),
        row("b", "x", 90.0, -3.0), row("b", "y", 80.0, -3.0),
        row("c", "x", 50.0, -1.0), row("c", "y", 60.0, -2.0),
    ]  # fmt: skip
    table = suite_markdown(rows, ["x", "y"], "t")
    lines = {tuple(c.strip() for c in ln.split("|")[1:3]): ln for ln in table.splitlines()}
    assert "**100**" in lines[("a", "x")] and "**-7.0**" in lines[("a", "y")]
    assert "**120**" not in lines[("a", "y")] and "**-5.0**" not in lines[("a", "x")]
    assert "**80**" in lines[("b", "y")] and "**-3.0**" not in lines[("b", "y")]  # tied: none
    head = table[table.index("Head to head") :]
    assert "| x | – | 2 / 0 |" in head  # x faster in a and c, never less certain
    assert "| y | 1 / 2 | – |" in head  # y faster in b, less certain in a and c


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


def test_cli_suite_takes_more_episodes_and_other_seeds(tmp_path):
    out = tmp_path / "suite"
    assert main(["evaluate", "--agents", "random", "--suite", "smoke", "--episodes", "2",
                 "--seed", "7", "--out", str(out), "--no-progress"]) == 0  # fmt: skip
    results = json.loads((out / "results.json").read_text())
    assert results["seed"] == 7
    assert [s["episodes"] for s in results["settings"]] == [2] * len(SUITES["smoke"]())
    assert [r["episodes"] for r in results["rows"]] == [2] * len(SUITES["smoke"]())
    for setting in SUITES["smoke"]():
        seeds = [e["seed"] for e in results["episodes"] if e["setting"] == setting.name]
        assert seeds == [7, 8], setting.name


def test_cli_suite_runs_only_the_settings_it_is_given(tmp_path):
    out = tmp_path / "suite"
    assert main(["evaluate", "--agents", "random", "--suite", "smoke", "--settings", " rooms",
                 "--out", str(out), "--no-progress"]) == 0  # fmt: skip
    results = json.loads((out / "results.json").read_text())
    assert [s["name"] for s in results["settings"]] == ["rooms"]
    assert {e["setting"] for e in results["episodes"]} == {"rooms"}
    both = chosen_settings("smoke", ["rooms", "default"])
    assert [s.name for s in both] == ["default", "rooms"]  # the suite's order
    assert chosen_settings("smoke", None) == SUITES["smoke"]()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--suite", "smoke", "--settings", "default,nope"], "has no setting 'nope'"),
        (["--suite", "smoke", "--settings", ""], "has no setting ''"),
        (["--settings", "default"], "give --suite too"),
    ],
)
def test_cli_suite_refuses_settings_it_does_not_have(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--agents", "random", "--out", str(tmp_path / "x"), *argv])
    assert exc.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "x" / "suite.csv").exists()
    with pytest.raises(ValueError, match="no settings given"):
        chosen_settings("smoke", [])
    with pytest.raises(TypeError, match="not a str"):
        chosen_settings("smoke", "rooms")


@pytest.mark.parametrize(
    ("counts", "message"),
    [
        ({"episodes": 0}, "episodes must be an int >= 1"),
        ({"episodes": True}, "episodes must be an int >= 1"),
        ({"episodes": 2.0}, "episodes must be an int >= 1"),
        ({"seed": -1}, "seed must be an int >= 0"),
        ({"seed": "7"}, "seed must be an int >= 0"),
    ],
)
def test_run_suite_refuses_bad_counts_before_anything_runs(tmp_path, counts, message):
    from agents.evaluation.suite import run_suite

    with pytest.raises(ValueError, match=message):
        run_suite(["random"], "smoke", tmp_path, progress=False, verbose=False, **counts)
    assert not any(tmp_path.iterdir())


def test_cli_evaluate_leaves_the_counts_it_was_not_given_to_the_runners(monkeypatch, tmp_path):
    import agents.evaluation.compare
    import agents.evaluation.suite

    calls = []

    def record(name):
        def run(*args, **kwargs):
            calls.append((name, {k: kwargs[k] for k in ("episodes", "seed") if k in kwargs}))
            raise SystemExit(0)

        return run

    monkeypatch.setattr(agents.evaluation.compare, "evaluate", record("evaluate"))
    monkeypatch.setattr(agents.evaluation.suite, "run_suite", record("suite"))
    argv = ["evaluate", "--agents", "random", "--out", str(tmp_path)]
    for extra in ([], ["--suite", "smoke"], ["--episodes", "4", "--seed", "9"]):
        with pytest.raises(SystemExit):
            main([*argv, *extra])
    assert calls == [
        ("evaluate", {}),  # evaluate's own defaults: 20 episodes from seed 0
        ("suite", {"episodes": None, "seed": None}),  # the suite's own: 3 from 10000
        ("evaluate", {"episodes": 4, "seed": 9}),
    ]


def test_cli_suite_refuses_bad_input(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--agents", "random", "--suite", "nope", "--out", str(tmp_path)])
    assert exc.value.code == 2 and "unknown suite" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["evaluate", "--agents", "random", "--suite", "smoke", "--max-steps", "5",
              "--out", str(tmp_path)])  # fmt: skip
    assert "--suite fixes" in capsys.readouterr().err


def test_a_policy_tied_to_its_landmark_count_is_refused_before_anything_runs(tmp_path):
    from agents.evaluation.suite import run_suite

    # The shipped egocentric policy has 20 landmark slots; the smoke suite's rooms 6.
    with pytest.raises(ValueError, match="setting 'rooms'"):
        run_suite(["random", "ppo"], "smoke", tmp_path, progress=False, verbose=False)
    assert not (tmp_path / "suite.csv").exists()


def test_cli_suite_runs_every_setting_on_the_belief_it_is_given(tmp_path):
    pytest.importorskip("gtsam", reason="belief='isam2' needs the 'gtsam' extra")
    out = {belief: tmp_path / belief for belief in ("ekf", "isam2")}
    for belief, folder in out.items():
        assert main(["evaluate", "--agents", "frontier", "--suite", "smoke", "--belief", belief,
                     "--episodes", "1", "--out", str(folder), "--no-progress"]) == 0  # fmt: skip
    ekf, isam2 = (json.loads((out[b] / "results.json").read_text()) for b in ("ekf", "isam2"))
    assert (ekf["belief"], isam2["belief"]) == ("ekf", "isam2")
    assert all(s["env_options"]["belief"] == "isam2" for s in isam2["settings"])
    assert all("belief" not in s["env_options"] for s in ekf["settings"])
    assert "on the `isam2` belief" in (out["isam2"] / "suite.md").read_text()
    # The same worlds and agent; the beliefs differ, and so do their map errors.
    assert [e["seed"] for e in ekf["episodes"]] == [e["seed"] for e in isam2["episodes"]]
    assert [e["map_rmse"] for e in ekf["episodes"]] != [e["map_rmse"] for e in isam2["episodes"]]


def test_cli_evaluate_takes_the_belief_once(tmp_path, capsys):
    argv = ["evaluate", "--agents", "random", "--episodes", "1", "--out", str(tmp_path)]
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--belief", "isam2", "--env-option", "belief=ekf"])
    assert exc.value.code == 2 and "give the belief once" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--belief", "gtsam"])
    assert exc.value.code == 2 and "invalid choice" in capsys.readouterr().err


def test_run_suite_refuses_an_unknown_belief(tmp_path):
    with pytest.raises(ValueError, match="belief must be one of"):
        run_suite("random", "smoke", tmp_path, belief="gtsam")


def test_every_agent_acts_on_the_smoothing_belief(tmp_path):
    """The planners read the belief (and infogain, lookahead copy and predict it), the
    policies its observation: all of them run on belief='isam2' unchanged."""
    pytest.importorskip("gtsam", reason="belief='isam2' needs the 'gtsam' extra")
    agents = "random,frontier,infogain,ppo,goals,lookahead"
    assert main(["evaluate", "--agents", agents, "--episodes", "1", "--max-steps", "25",
                 "--belief", "isam2", "--out", str(tmp_path), "--no-progress"]) == 0  # fmt: skip
    results = json.loads((tmp_path / "results.json").read_text())
    assert results["settings"]["env_options"] == {"belief": "isam2"}
    assert [e["agent"] for e in results["episodes"]] == agents.split(",")
    assert all(e["steps"] == 25 and np.isfinite(e["final_entropy"]) for e in results["episodes"])
