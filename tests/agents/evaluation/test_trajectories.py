"""The evaluation's trajectories as evo reads them: TUM files that evo's own file
interface reads back as the episode's poses, an APE (translation, no alignment) equal
to the episode's ``pose_rmse``, the map as CSV, and ``slam-env evaluate
--export-trajectories``; bad input refused before a file is written."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from evo.core import metrics
from evo.tools import file_interface

from agents.cli.main import main
from agents.evaluation.compare import evaluate
from slam_env.belief.trajectory_files import planar_tum_rows, write_map_csv, write_tum

SMALL_WORLD = {"n_landmarks": 6, "width": 8.0, "height": 8.0, "n_obstacles": 1, "dt": 0.25}
DT = SMALL_WORLD["dt"]


def _ape_rmse(true_path: Path, est_path: Path, t_start: float | None = None) -> float:
    ref = file_interface.read_tum_trajectory_file(true_path)
    est = file_interface.read_tum_trajectory_file(est_path)
    if t_start is not None:
        ref.reduce_to_time_range(t_start)
        est.reduce_to_time_range(t_start)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    return ape.get_statistic(metrics.StatisticsType.rmse)


@pytest.fixture(scope="module")
def evaluation(tmp_path_factory):
    out = tmp_path_factory.mktemp("eval")
    result = evaluate(
        ["random"],
        episodes=2,
        seed=5,
        env_options=SMALL_WORLD,
        out_dir=out,
        max_steps=25,
        progress=False,
        verbose=False,
        trajectories_dir=out / "trajectories",
    )
    return result, out / "trajectories" / "random"


def test_evo_reads_back_the_true_and_estimated_poses(evaluation):
    result, folder = evaluation
    for i, record in enumerate(result.records["random"]):
        for kind, poses in (("true", record.true_poses), ("est", record.est_poses)):
            traj = file_interface.read_tum_trajectory_file(folder / f"episode_{i:03d}_{kind}.tum")
            np.testing.assert_array_equal(traj.timestamps, np.arange(26) * DT)
            np.testing.assert_array_equal(traj.positions_xyz[:, :2], poses[:, :2])
            assert not traj.positions_xyz[:, 2].any()  # planar: z = 0
            # The heading, from the quaternion evo read (w, x, y, z).
            w, x, y, z = traj.orientations_quat_wxyz.T
            np.testing.assert_array_equal(x, 0.0)
            np.testing.assert_array_equal(y, 0.0)
            heading = 2.0 * np.arctan2(z, w)
            np.testing.assert_allclose(
                np.angle(np.exp(1j * (heading - poses[:, 2]))), 0.0, atol=1e-12
            )


def test_evo_ape_equals_the_episodes_pose_rmse(evaluation):
    result, folder = evaluation
    rows = [r for r in result.episodes if r["agent"] == "random"]
    for i, (row, record) in enumerate(zip(rows, result.records["random"], strict=True)):
        true, est = folder / f"episode_{i:03d}_true.tum", folder / f"episode_{i:03d}_est.tum"
        assert row["pose_rmse"] > 0.0  # a real comparison: the estimate drifted
        # pose_rmse runs over the steps after the reset: evo from t = dt on.
        assert _ape_rmse(true, est, t_start=DT) == pytest.approx(row["pose_rmse"], abs=1e-6)
        # The whole file also counts the start, where the error is 0.
        whole = math.sqrt(np.mean(record.pose_error**2))
        assert _ape_rmse(true, est) == pytest.approx(whole, abs=1e-6)


def test_the_documented_evo_ape_command_reports_pose_rmse(evaluation, tmp_path):
    result, folder = evaluation
    evo_ape = Path(sys.executable).with_name("evo_ape")
    zipped = tmp_path / "ape.zip"
    done = subprocess.run(
        [str(evo_ape), "tum", str(folder / "episode_000_true.tum"),
         str(folder / "episode_000_est.tum"), "--t_start", str(DT),
         "--save_results", str(zipped), "--no_warnings"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    stats = file_interface.load_res_file(zipped).stats
    assert stats["rmse"] == pytest.approx(result.episodes[0]["pose_rmse"], abs=1e-6)


def test_the_map_csv_holds_each_landmarks_truth_and_estimate(evaluation):
    result, folder = evaluation
    record = result.records["random"][0]
    with open(folder / "episode_000_map.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    layout, belief = record.layout, record.belief
    assert [int(r["id"]) for r in rows] == sorted(layout.landmark_ids)
    truth = dict(zip(layout.landmark_ids, layout.landmark_positions, strict=True))
    estimate = dict(zip(belief.landmark_ids.tolist(), belief.landmark_means, strict=True))
    assert estimate, "the episode mapped no landmark: nothing compared"
    for r in rows:
        lid = int(r["id"])
        assert (float(r["true_x"]), float(r["true_y"])) == tuple(truth[lid])
        if lid in estimate:
            assert (float(r["est_x"]), float(r["est_y"])) == tuple(estimate[lid])
        else:
            assert (r["est_x"], r["est_y"]) == ("", "")


def test_cli_evaluate_exports_trajectories(tmp_path, capsys):
    argv = ["evaluate", "--agents", "random", "--episodes", "1", "--max-steps", "10"]
    argv += ["--out", str(tmp_path / "eval"), "--no-progress"]
    argv += ["--export-trajectories", str(tmp_path / "traj")]
    assert main(argv) == 0
    written = sorted(p.name for p in (tmp_path / "traj" / "random").iterdir())
    assert written == ["episode_000_est.tum", "episode_000_map.csv", "episode_000_true.tum"]
    assert f"trajectories_dir: {tmp_path / 'traj'}" in capsys.readouterr().out
    traj = file_interface.read_tum_trajectory_file(tmp_path / "traj/random/episode_000_true.tum")
    assert traj.num_poses == 11


def test_cli_refuses_export_trajectories_with_a_suite(tmp_path, capsys):
    argv = ["evaluate", "--agents", "random", "--suite", "smoke", "--out", str(tmp_path)]
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--export-trajectories", str(tmp_path / "traj")])
    assert exc.value.code == 2
    assert "--export-trajectories" in capsys.readouterr().err
    assert not (tmp_path / "traj").exists()


def test_planar_quaternion_of_a_heading():
    rows = planar_tum_rows([0.0, 0.5], [[1.0, 2.0, math.pi / 2], [3.0, 4.0, -math.pi]])
    np.testing.assert_allclose(rows[0], [0, 1, 2, 0, 0, 0, math.sqrt(0.5), math.sqrt(0.5)])
    np.testing.assert_allclose(rows[1], [0.5, 3, 4, 0, 0, 0, -1, 0], atol=1e-15)


@pytest.mark.parametrize(
    ("timestamps", "poses", "message"),
    [
        ([0.0, 1.0], [[0.0, 0.0, 0.0]], "timestamps must have shape"),
        ([0.0], [[0.0, 0.0]], "poses must have shape"),
        ([0.0, 1.0], [[0.0, 0.0, 0.0], [math.nan, 0.0, 0.0]], "poses must be finite"),
        ([0.0, 0.0], [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], "strictly increasing"),
    ],
)
def test_bad_trajectories_are_refused_before_a_file_is_written(
    tmp_path, timestamps, poses, message
):
    path = tmp_path / "t.tum"
    with pytest.raises(ValueError, match=message):
        write_tum(path, timestamps, poses)
    assert not path.exists()


@pytest.mark.parametrize("poses", [[[True, False, True]], [["0", "0", "0"]], [[0.0, 0.0, 1j]]])
def test_trajectories_of_anything_but_real_numbers_are_refused(tmp_path, poses):
    path = tmp_path / "t.tum"
    with pytest.raises(TypeError, match="poses must be an array of numbers"):
        write_tum(path, [0.0], poses)
    assert not path.exists()


def test_bad_maps_are_refused_before_a_file_is_written(tmp_path):
    path = tmp_path / "map.csv"
    with pytest.raises(ValueError, match="must not repeat an ID"):
        write_map_csv(path, [1, 1], [[0, 0], [1, 1]], [], np.zeros((0, 2)))
    with pytest.raises(ValueError, match="one per position"):
        write_map_csv(path, [1, 2], [[0, 0], [1, 1]], [3], np.zeros((2, 2)))
    assert not path.exists()


def test_an_estimate_of_no_true_landmark_has_an_empty_truth(tmp_path):
    path = write_map_csv(tmp_path / "map.csv", [0], [[1.0, 2.0]], [0, 7], [[1.5, 2.5], [3.0, 3.0]])
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows == [
        ["id", "true_x", "true_y", "est_x", "est_y"],
        ["0", "1.0", "2.0", "1.5", "2.5"],
        ["7", "", "", "3.0", "3.0"],
    ]
