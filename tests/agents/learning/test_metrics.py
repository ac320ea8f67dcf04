"""SLAM metrics of training episodes: the tally, the metrics, and what training logs."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping
from types import SimpleNamespace
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from agents.common.env import make_env
from agents.common.info_rows import InfoRow
from agents.learning.metrics import (
    SLAM_METRICS,
    STEP_KEYS,
    EpisodeTallies,
    evaluation_score,
    mean_metrics,
)
from agents.learning.sb3.callbacks import (
    EVAL_PREFIX,
    TRAIN_PREFIX,
    SlamMetricsCallback,
    vector_columns,
)
from agents.learning.sb3.training import train
from agents.registry import make_agent
from agents.rollouts.episodes import run_episode

# A world mapped at the first look (a sensor all around that reaches every corner), so
# that every metric, the time to 90% mapped included, is defined in a short run.
SEE_ALL = {
    "n_landmarks": 4,
    "width": 8.0,
    "height": 8.0,
    "n_obstacles": 0,
    "fov": 2.0 * math.pi,
    "max_range": 12.0,
}


class ReadKeys(Mapping):
    """A step info that records which keys were read."""

    def __init__(self, data: dict[str, Any]) -> None:
        self.data = data
        self.read: set[str] = set()

    def __getitem__(self, key: str) -> Any:
        self.read.add(key)
        return self.data[key]

    def __iter__(self) -> Iterator[str]:
        raise AssertionError("the tally must not iterate an info (lazy infos)")

    def __len__(self) -> int:
        return len(self.data)


def step_info(known: int, nees: float = 3.0, collision: bool = False, **extra: Any) -> dict:
    return {"landmarks_known": known, "pose_nees": nees, "collision": collision, **extra}


# ---------------------------------------------------------------------- the tally
def test_a_tally_reads_three_keys_per_step():
    info = ReadKeys(step_info(2, entropy=1.0, pose=np.zeros(3)))
    EpisodeTallies(1).add_infos([info])
    assert info.read == set(STEP_KEYS) == {"collision", "pose_nees", "landmarks_known"}


KNOWN_EPISODE = [  # 10 landmarks: 90% is 9, first mapped at step 5
    step_info(0, 2.0),
    step_info(2, math.inf, collision=True),  # a singular pose covariance: not averaged
    step_info(2, 4.0, collision=True),
    step_info(8, 6.0),
    step_info(9, 1.0),
    step_info(10, 2.0),
]
KNOWN_END = {"landmark_ids": np.arange(10), "entropy": -12.5, "map_rmse": 0.25, "diverged": False}


@pytest.mark.parametrize("block", [1, 4, 256])  # counted step by step, or in blocks
def test_episode_metrics_of_a_known_episode(block):
    tallies = EpisodeTallies(1, block=block)
    for info in KNOWN_EPISODE:
        tallies.add_infos([info])
    m = tallies.finish(0, {**KNOWN_EPISODE[-1], **KNOWN_END})
    assert list(m) == list(SLAM_METRICS)
    assert m["mapped_share"] == 1.0
    assert m["steps_to_90pct_mapped"] == 5.0 and m["reached_90pct_mapped"] == 1.0
    assert m["final_entropy"] == -12.5 and m["map_rmse"] == 0.25
    assert m["mean_pose_nees"] == pytest.approx((2.0 + 4.0 + 6.0 + 1.0 + 2.0) / 5)
    assert m["collisions"] == 2.0 and m["diverged"] == 0.0
    # finish() started the next episode; one that never maps 90% has no time.
    tallies.add_infos([step_info(3)])
    end = {**step_info(3), **KNOWN_END, "map_rmse": math.nan, "diverged": True}
    m = tallies.finish(0, end)
    assert m["mapped_share"] == 0.3 and m["reached_90pct_mapped"] == 0.0
    assert math.isnan(m["steps_to_90pct_mapped"]) and math.isnan(m["map_rmse"])
    assert m["collisions"] == 0.0 and m["diverged"] == 1.0 and m["mean_pose_nees"] == 3.0


def test_sub_envs_are_tallied_apart():
    # Sub-env 1 runs the known episode; sub-env 0 idles and ends at another time.
    tallies = EpisodeTallies(2, block=4)
    idle = step_info(1, 5.0)
    for t, info in enumerate(KNOWN_EPISODE):
        tallies.add_infos([idle, info])
        if t == 2:
            idle_metrics = tallies.finish(0, {**idle, **KNOWN_END})
    m = tallies.finish(1, {**KNOWN_EPISODE[-1], **KNOWN_END})
    assert m["steps_to_90pct_mapped"] == 5.0 and m["collisions"] == 2.0
    assert idle_metrics["mean_pose_nees"] == 5.0 and idle_metrics["mapped_share"] == 0.1
    alone = EpisodeTallies(1)
    for info in KNOWN_EPISODE:
        alone.add_infos([info])
    assert alone.finish(0, {**KNOWN_EPISODE[-1], **KNOWN_END}) == m


def vector_step(rows: list[dict], done: list[bool], finals: list[dict]) -> list:
    """Step infos as SB3VectorEnv gives them: lazy rows of one vector info, a finished
    sub-env's row read from the vector final info."""
    b = len(rows)
    mask = np.ones(b, dtype=bool)
    info = {}
    for key in rows[0]:
        info[key], info[f"_{key}"] = np.array([r[key] for r in rows]), mask
    final = {}
    for key in finals[0]:
        final[key] = np.array([f[key] for f in finals])
        final[f"_{key}"] = np.array(done)
    return [InfoRow(final, i) if done[i] else InfoRow(info, i) for i in range(b)]


def test_vector_columns_match_a_row_by_row_read():
    rows = [step_info(k, 1.0 + k, collision=k % 2 == 0) for k in range(4)]
    finals = [step_info(9, 7.0, collision=True)] * 4
    done = [False, True, False, False]
    infos = vector_step(rows, done, finals)
    expected = [[info[key] for info in infos] for key in STEP_KEYS]
    columns, reported = vector_columns(infos, [1], STEP_KEYS)
    for column, values in zip(columns, expected, strict=True):
        assert column.tolist() == values
    assert columns[2][1] == 9 and columns[1][1] == 7.0  # the finished row: its final info
    assert all(mask.tolist() == [True] * 3 for mask in reported)  # the going rows'
    # A finished row made a plain dict (as VecMonitor does) is read as well.
    infos[1] = infos[1].copy()
    for column, values in zip(vector_columns(infos, [1], STEP_KEYS)[0], expected, strict=True):
        assert column.tolist() == values
    # With no sub-env finished, the columns are the vector info's own arrays.
    infos = vector_step(rows, [False] * 4, finals)
    columns, _ = vector_columns(infos, [], STEP_KEYS)
    assert columns[0] is infos[0].vector_info["collision"]
    # Plain dicts (DummyVecEnv's rows), or a row that reads another vector info, are
    # left to be read row by row.
    assert vector_columns([dict(r) for r in rows], [], STEP_KEYS) is None
    infos[2] = InfoRow(dict(infos[2].vector_info), 2)
    assert vector_columns(infos, [], STEP_KEYS) is None


def test_an_undefined_nees_is_absent_and_not_averaged():
    # The env leaves pose_nees out where it is undefined; row by row and in columns
    # it is read as NaN, never as the vector info's fill value 0.
    rows = [step_info(1, 2.0), step_info(1, 4.0)]
    infos = vector_step(rows, [False, False], rows)
    vector = infos[0].vector_info
    vector["_pose_nees"] = np.array([True, False])
    columns, reported = vector_columns(infos, [], STEP_KEYS)
    assert np.isnan(columns[1][1]) and columns[1][0] == 2.0
    assert len(reported) == 2  # the masks of collision and landmarks_known only
    del vector["pose_nees"], vector["_pose_nees"]
    assert np.isnan(vector_columns(infos, [], STEP_KEYS)[0][1]).all()
    tallies = EpisodeTallies(1)
    tallies.add_infos([step_info(1, 2.0)])
    tallies.add_infos([{"landmarks_known": 1, "collision": False}])
    end = {"landmark_ids": np.arange(4), "landmarks_known": 1, "entropy": 0.0}
    m = tallies.finish(0, {**end, "diverged": False})
    assert m["mean_pose_nees"] == 2.0 and math.isnan(m["map_rmse"])


class RecordingLogger:
    def __init__(self) -> None:
        self.values: list[tuple[str, float]] = []

    def record_mean(self, key: str, value: float) -> None:
        self.values.append((key, value))


def run_callback(script: list, vector: bool, num_envs: int) -> list[tuple[str, float]]:
    """Feed SlamMetricsCallback one scripted step at a time, as PPO would."""
    logger = RecordingLogger()
    env = SimpleNamespace(num_envs=num_envs)
    model = SimpleNamespace(logger=logger, get_env=lambda: env, num_timesteps=0)
    callback = SlamMetricsCallback()
    callback.init_callback(model)
    for rows, done in script:
        if vector:  # a finished sub-env's step row holds its reset, its final info the end
            reset = {**rows[0], **step_info(0, 0.0)}
            step_rows = [reset if done[i] else row for i, row in enumerate(rows)]
            infos = vector_step(step_rows, done, rows)
        else:
            infos = [dict(row) for row in rows]
        callback.update_locals({"infos": infos, "dones": np.array(done)})
        callback.on_step()
    return logger.values


def test_the_callback_reads_vector_infos_as_it_reads_rows():
    rng = np.random.default_rng(5)
    b, ends = 3, {(7, 0), (20, 2), (33, 1), (39, 0), (39, 1), (39, 2)}
    end = {"landmark_ids": np.arange(5), "entropy": 1.0, "map_rmse": 0.1, "diverged": False}
    known, script = np.zeros(b, dtype=int), []
    for t in range(40):
        known = np.minimum(known + rng.integers(0, 2, b), 5)
        nees = rng.chisquare(3, b)
        nees[rng.random(b) < 0.05] = math.inf
        hits = rng.random(b) < 0.2
        rows = [{**step_info(int(known[i]), nees[i], bool(hits[i])), **end} for i in range(b)]
        done = [(t, i) in ends for i in range(b)]
        script.append((rows, done))
        known[done] = 0
    by_rows = run_callback(script, vector=False, num_envs=b)
    assert len(by_rows) >= 6 * 7  # six episodes, their metrics (NaN ones left out)
    assert run_callback(script, vector=True, num_envs=b) == by_rows


class RecordInfos(gym.Wrapper):
    """Keeps the step infos (not the reset's) of the episode it runs."""

    def reset(self, **kwargs: Any) -> Any:
        self.infos: list[dict] = []
        return self.env.reset(**kwargs)

    def step(self, action: Any) -> Any:
        out = self.env.step(action)
        self.infos.append(out[4])
        return out


def test_episode_metrics_agree_with_the_evaluator():
    env = RecordInfos(make_env({"n_landmarks": 6, "width": 8.0, "height": 8.0}, 60))
    record = run_episode(env, make_agent("random", env, seed=3), seed=3)
    tallies = EpisodeTallies(1)
    for info in env.infos:
        tallies.add_infos([info])
    ours = tallies.finish(0, env.infos[-1])
    theirs = record.metrics()
    for name in ("mapped_share", "final_entropy", "mean_pose_nees", "collisions"):
        assert ours[name] == pytest.approx(theirs[name]), name
    assert ours["map_rmse"] == pytest.approx(theirs["map_rmse"], nan_ok=True)
    known = record.landmarks_known[1:]
    reached = np.flatnonzero(known >= math.ceil(0.9 * 6))
    if reached.size:
        assert ours["steps_to_90pct_mapped"] == reached[0] + 1
    else:
        assert math.isnan(ours["steps_to_90pct_mapped"])
    env.close()


def test_mean_metrics_skip_undefined_values():
    base = dict.fromkeys(SLAM_METRICS, 1.0)
    means = mean_metrics([{**base, "map_rmse": math.nan}, {**base, "map_rmse": 0.5}])
    assert means["map_rmse"] == 0.5 and means["mapped_share"] == 1.0
    assert math.isnan(mean_metrics([{**base, "map_rmse": math.nan}])["map_rmse"])


def test_evaluation_score_prefers_mapping_then_low_entropy():
    def score(mapped: float, entropy: float) -> tuple[float, float]:
        return evaluation_score({"mapped_share": mapped, "final_entropy": entropy})

    assert score(0.9, 50.0) > score(0.8, -100.0)  # more landmarks first
    assert score(0.8, -100.0) > score(0.8, -90.0)  # then a tighter belief
    assert score(0.1 + 0.2, 0.0) == score(0.3, 0.0)  # equal shares tie despite rounding
    assert score(0.0, 0.0) > score(math.nan, -100.0)  # undefined ranks last


# ---------------------------------------------------------------------- training logs
@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("slam_tb")
    cfg = {
        "total_timesteps": 192,
        "n_envs": 1,
        "seed": 4,
        "env_options": SEE_ALL,
        "max_episode_steps": 30,
        "progress_bar": False,
        "checkpoint_freq": 0,
        "eval_freq": 64,
        "eval_episodes": 2,
        "out_dir": str(out),
        "ppo": {"n_steps": 64, "batch_size": 32, "n_epochs": 1, "net_arch": [16]},
    }
    train(cfg)
    return out


def read_scalars(out) -> dict[str, list[tuple[int, float]]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    (events,) = (out / "tb").rglob("events.out.tfevents.*")
    acc = EventAccumulator(str(events))
    acc.Reload()
    return {tag: [(e.step, e.value) for e in acc.Scalars(tag)] for tag in acc.Tags()["scalars"]}


def test_tensorboard_holds_the_slam_metrics_of_training_and_evaluation(trained):
    scalars = read_scalars(trained)
    for prefix in (TRAIN_PREFIX, EVAL_PREFIX):
        for name in SLAM_METRICS:
            assert prefix + name in scalars, prefix + name
    # 30-step episodes: some end in every 64-step rollout.
    assert [step for step, _ in scalars["slam/mapped_share"]] == [64, 128, 192]
    for _, value in scalars["slam/mapped_share"] + scalars["slam_eval/mapped_share"]:
        assert value == 1.0  # the sensor sees the whole world from the start
    for _, value in scalars["slam/steps_to_90pct_mapped"]:
        assert 1.0 <= value <= 30.0  # a post can hide a landmark for a few steps
    for _, value in scalars["slam/collisions"]:
        assert 0.0 <= value <= 30.0


def test_evaluations_log_their_episodes_and_keep_the_best_model(trained):
    scalars = read_scalars(trained)
    evals = np.load(trained / "eval" / "evaluations.npz")
    steps = list(evals["timesteps"])
    assert steps == [64, 128, 192]
    assert evals["slam_final_entropy"].shape == (3, 2)  # evaluations x episodes
    # TensorBoard's evaluation figures are the means of the episodes in the file.
    logged = dict(scalars["slam_eval/final_entropy"])
    for step, row in zip(steps, evals["slam_final_entropy"], strict=True):
        assert logged[step] == pytest.approx(row.mean(), rel=1e-6)
    # The best model is the evaluation ranked first by the documented criterion.
    ranks = [
        evaluation_score({"mapped_share": m.mean(), "final_entropy": h.mean()})
        for m, h in zip(evals["slam_mapped_share"], evals["slam_final_entropy"], strict=True)
    ]
    summary = json.loads((trained / "training_summary.json").read_text())
    best = max(range(len(ranks)), key=ranks.__getitem__)  # the first of equals
    assert summary["best_eval_slam"]["timesteps"] == steps[best]
    assert summary["last_eval_slam"]["timesteps"] == steps[-1]
    assert "mapped" in summary["best_model_criterion"]
    assert (trained / "eval" / "best_model.zip").is_file()
