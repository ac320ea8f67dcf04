"""The batched sensing kernels against the single-world sensor and pymunk's queries."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.config import EnvConfig, SensorConfig, WorldConfig
from slam_env.kernels.stream.sensing import (
    proximity_scan,
    scan_uniforms,
    sense_landmarks,
    sensing_scratch,
)
from slam_env.kernels.world.raycast import line_of_sight
from slam_env.sensing.landmark_sensor import LandmarkSensor
from slam_env.world.world_batch import WorldBatch


def _batch(seed: int, b: int, **world: object) -> WorldBatch:
    cfg = EnvConfig(world=WorldConfig(**world))
    batch = WorldBatch(cfg, b)
    for i in range(b):
        batch.reset(i, np.random.default_rng(seed + i))
    return batch


@pytest.mark.parametrize(
    "sensor",
    [
        SensorConfig(),
        SensorConfig(measurement_model="cartesian", detection_prob=0.6, max_detections=4),
        SensorConfig(fov=2 * math.pi, max_range=9.0, max_detections=3),
    ],
)
def test_each_world_of_the_batch_is_what_the_sensor_sees_alone(sensor: SensorConfig) -> None:
    """B worlds in one call equal B single-world scans with the same uniforms and the
    same occlusion, bit for bit."""
    b = 5
    batch = _batch(7, b, n_obstacles=8)
    rng = np.random.default_rng(0)
    single = LandmarkSensor(sensor)
    n = batch.n_landmarks
    d = sensor.max_detections or n
    fields = tuple(single._params._replace(max_detections=d))
    geometry = tuple(batch.geometry)
    out = (np.zeros((b, d, 2)), np.zeros((b, d), np.int64), np.zeros((b, d), np.int64))
    count = np.zeros(b, np.int64)
    for step in range(40):
        batch.poses[:] = np.column_stack(
            [rng.uniform(0.5, 15.5, b), rng.uniform(0.5, 15.5, b), rng.uniform(-4, 4, b)]
        )
        seeds = [1000 * step + i for i in range(b)]
        uniforms = np.stack([np.random.default_rng(s).random(scan_uniforms(n, d)) for s in seeds])
        active = np.ones(b, dtype=bool)
        active[step % b] = False  # an inactive world keeps its last outputs
        kept = [o[step % b].copy() for o in out]
        sense_landmarks(
            batch.poses,
            batch.landmarks,
            batch.landmark_ids,
            batch.id_order,
            geometry,
            fields,
            uniforms,
            0,
            active,
            *out,
            count,
            sensing_scratch(n, batch.geometry.tree.shape[1], 0),
        )
        for i in range(b):
            if not active[i]:
                assert all(np.array_equal(o[i], k) for o, k in zip(out, kept, strict=True))
                continue

            def los(origin, target, row, i=i):
                return line_of_sight(batch.geometry, i, *origin, *target, row)

            det = single.sense(
                batch.poses[i],
                batch.landmarks[i],
                batch.landmark_ids[i],
                np.random.default_rng(seeds[i]),
                los,
            )
            k = int(count[i])
            assert k == len(det)
            assert out[0][i, :k].tobytes() == det.z.tobytes()
            assert out[1][i, :k].tolist() == det.ids.tolist()
            assert out[2][i, :k].tolist() == det.index.tolist()


def test_proximity_scan_is_pymunks_segment_query() -> None:
    batch = _batch(3, 4, n_obstacles=10)
    beams = -math.pi + 2 * math.pi * (np.arange(16) + 0.5) / 16
    reach = 3.0
    out = np.zeros((4, 16), dtype=np.float32)
    rng = np.random.default_rng(1)
    for _ in range(30):
        for i, world in enumerate(batch.worlds):
            world.set_pose(*_free_pose(world, rng))
            batch.poses[i] = world.pose
        scratch = sensing_scratch(batch.n_landmarks, batch.geometry.tree.shape[1], beams.shape[0])
        proximity_scan(
            batch.poses, tuple(batch.geometry), beams, reach, np.ones(4, bool), out, scratch
        )
        for i, world in enumerate(batch.worlds):
            expected = np.array(world.range_scan(*world.pose, tuple(beams), reach)) / reach
            np.testing.assert_allclose(out[i], expected, rtol=0, atol=1e-6)
    assert (out < 1.0).any() and (out == 1.0).any()  # beams that hit and beams that did not


def _free_pose(world, rng: np.random.Generator) -> tuple[float, float, float]:
    while True:
        x, y = rng.uniform(0.3, 15.7, 2)
        if world.is_free(x, y):
            return float(x), float(y), float(rng.uniform(-math.pi, math.pi))
