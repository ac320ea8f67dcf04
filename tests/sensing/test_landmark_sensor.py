"""Tests for slam_env.sensing.landmark_sensor.LandmarkSensor: visibility, wrapping, exactness, noise
statistics (tests/sensing/sensor_references.py), detection probability and cap, determinism,
and the draws bit for bit. The odometry sensor's are in tests/sensing/test_odometry_sensor.py.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest

from slam_env.config import OdometryConfig, SensorConfig
from slam_env.sensing.landmark_sensor import Detections, LandmarkSensor
from slam_env.world.frames import wrap_angle
from tests.sensing.sensor_references import N_SE, assert_gaussian_errors, box_muller, ref_wrap

PI = math.pi


# ---------------------------------------------------------------- references


def ref_range_bearing(pose, m):
    """Seed 000's h, computed with complex numbers: r = |m − t|, φ = arg((m − t)e^{−iθ})."""
    x, y, th = pose
    v = complex(m[0] - x, m[1] - y)
    phi = cmath.phase(v * cmath.exp(-1j * th))
    return abs(v), (phi - 2 * PI if phi >= PI else phi)


def ref_cartesian(pose, m):
    """Seed 004's h: R(θ)ᵀ(m − t) written out."""
    x, y, th = pose
    dx, dy = m[0] - x, m[1] - y
    return math.cos(th) * dx + math.sin(th) * dy, -math.sin(th) * dx + math.cos(th) * dy


def all_seeing(**kw) -> SensorConfig:
    base = {"fov": 2 * PI, "max_range": 100.0, "range_std": 0.0, "bearing_std": 0.0}
    base.update(kw)
    return SensorConfig(**base)


RNG = np.random.default_rng


# ---------------------------------------------------------------- visibility


def test_range_limit_inclusive_inside_exclusive_outside():
    sensor = LandmarkSensor(all_seeing(max_range=5.0))
    pose = (1.0, -2.0, 0.7)
    # landmarks along various directions at ranges just in and just out
    ranges = [4.9, 5.1, 0.5, 7.0, 4.999, 5.001]
    angles = [0.0, 0.3, 2.5, -1.0, -2.9, 1.7]
    pos = np.array(
        [
            [1.0 + r * math.cos(a), -2.0 + r * math.sin(a)]
            for r, a in zip(ranges, angles, strict=True)
        ]
    )
    ids = np.arange(len(ranges)) + 10
    det = sensor.sense(pose, pos, ids, RNG(0))
    expected = [10 + i for i, r in enumerate(ranges) if r <= 5.0]
    assert det.ids.tolist() == expected
    assert sensor.candidates(pose, pos).tolist() == [i for i, r in enumerate(ranges) if r <= 5.0]


def test_fov_limit_relative_to_heading():
    fov = math.radians(120.0)
    sensor = LandmarkSensor(all_seeing(fov=fov, max_range=10.0))
    theta = 2.5  # heading far from 0 so world angles ≠ bearings
    pose = (3.0, 4.0, theta)
    bearings_deg = [0.0, 50.0, -50.0, 59.0, -59.0, 61.0, -61.0, 90.0, 180.0, -135.0]
    pos = np.array(
        [
            [
                3.0 + 2.0 * math.cos(theta + math.radians(b)),
                4.0 + 2.0 * math.sin(theta + math.radians(b)),
            ]
            for b in bearings_deg
        ]
    )
    ids = np.arange(len(bearings_deg))
    det = sensor.sense(pose, pos, ids, RNG(0))
    expected = [i for i, b in enumerate(bearings_deg) if abs(b) <= 60.0]
    assert det.ids.tolist() == expected
    assert np.allclose(det.z[:, 1], np.radians([bearings_deg[i] for i in expected]), atol=1e-12)


def test_candidates_match_brute_force():
    rng = RNG(1)
    sensor = LandmarkSensor(SensorConfig(max_range=5.0, fov=math.radians(100.0)))
    for _ in range(200):
        pose = (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-PI, PI))
        pos = rng.uniform(-8, 8, size=(20, 2))
        expected = []
        for i, m in enumerate(pos):
            r, phi = ref_range_bearing(pose, m)
            if r <= 5.0 and abs(phi) <= math.radians(50.0):
                expected.append(i)
        got = sensor.candidates(pose, pos)
        assert got.dtype == np.int64
        assert got.tolist() == expected


def test_fake_line_of_sight_blocks_and_is_called_only_for_candidates():
    sensor = LandmarkSensor(SensorConfig(max_range=5.0, fov=math.radians(90.0), range_std=0.0))
    pose = (0.5, 0.5, 0.2)
    rng = RNG(2)
    pos = rng.uniform(-6, 6, size=(30, 2))
    ids = np.arange(100, 130)
    cand = sensor.candidates(pose, pos).tolist()
    assert len(cand) >= 3, "fixture should have several candidates"
    blocked = set(cand[::2])
    calls = []

    def los(origin, target, index):
        calls.append(index)
        assert np.array_equal(origin, [0.5, 0.5])
        assert np.array_equal(target, pos[index])
        return index not in blocked

    det = sensor.sense(pose, pos, ids, RNG(3), line_of_sight=los)
    assert sorted(calls) == cand  # each candidate once, nothing else
    assert det.index.tolist() == [i for i in cand if i not in blocked]
    assert det.ids.tolist() == [100 + i for i in cand if i not in blocked]
    # without an occluder every candidate is reported
    assert sensor.sense(pose, pos, ids, RNG(3)).index.tolist() == cand


def _segments_intersect(p, q, a, b) -> bool:
    """Proper or touching intersection of segments pq and ab (orientation test)."""

    def orient(o, s, t):
        return (s[0] - o[0]) * (t[1] - o[1]) - (s[1] - o[1]) * (t[0] - o[0])

    d1, d2 = orient(a, b, p), orient(a, b, q)
    d3, d4 = orient(p, q, a), orient(p, q, b)
    return (d1 * d2 <= 0) and (d3 * d4 <= 0)


def test_geometric_wall_occludes_landmarks_behind_it():
    # a wall from (2, -1) to (2, 1); the robot at the origin looking along +x
    wall = ((2.0, -1.0), (2.0, 1.0))

    def los(origin, target, index):
        return not _segments_intersect(origin, target, *wall)

    sensor = LandmarkSensor(SensorConfig(max_range=10.0, fov=PI, range_std=0.0, bearing_std=0.0))
    pos = np.array(
        [
            [4.0, 0.0],  # 0: straight behind the wall -> hidden
            [1.5, 0.2],  # 1: in front of the wall -> seen
            [4.0, 1.8],  # 2: ray passes y = 0.9 at x = 2 -> hidden
            [4.0, 2.4],  # 3: ray passes y = 1.2 at x = 2 -> seen
            [3.0, -1.2],  # 4: ray passes y = -0.8 at x = 2 -> hidden
            [0.5, -3.0],  # 5: off to the side, never crosses -> seen
            [-3.0, 0.0],  # 6: behind the robot, outside the 180° FOV -> not seen
        ]
    )
    ids = np.array([7, 3, 9, 1, 4, 8, 2])
    det = sensor.sense((0.0, 0.0, 0.0), pos, ids, RNG(0), line_of_sight=los)
    assert det.ids.tolist() == [1, 3, 8]
    assert det.index.tolist() == [3, 1, 5]
    for row, i in zip(det.z, det.index, strict=True):
        assert np.allclose(row, ref_range_bearing((0.0, 0.0, 0.0), pos[i]), atol=1e-12)


# ---------------------------------------------------------------- wrapping


def test_bearing_directly_behind_and_across_pi():
    sensor = LandmarkSensor(all_seeing())
    cases = [
        ((0.0, 0.0, 0.0), (-1.0, 0.0)),  # exactly behind: −π
        ((0.0, 0.0, 0.0), (-1.0, 1e-9)),  # just left of behind: ≈ +π
        ((0.0, 0.0, 0.0), (-1.0, -1e-9)),  # just right of behind: ≈ −π
        ((1.0, 1.0, -0.5), (1.0 + math.cos(2.9), 1.0 + math.sin(2.9))),  # 2.9 + 0.5 > π
        ((1.0, 1.0, 0.5), (1.0 + math.cos(-2.9), 1.0 + math.sin(-2.9))),  # −2.9 − 0.5 < −π
        ((0.0, 0.0, 4.5e-16), (-1.0, -1e-17)),  # atan2 − θ is a hair below −π
        ((0.0, 0.0, PI), (1.0, 0.0)),  # heading π, landmark straight behind (world +x)
        ((0.0, 0.0, -PI), (-1.0, 0.0)),  # heading −π, landmark straight ahead
    ]
    for pose, m in cases:
        det = sensor.sense(pose, np.array([m]), np.array([0]), RNG(0))
        phi = float(det.z[0, 1])
        assert -PI <= phi < PI, (pose, m, phi)
        r_ref, phi_ref = ref_range_bearing(pose, m)
        assert abs(float(ref_wrap(phi - phi_ref))) < 1e-12, (pose, m, phi, phi_ref)
        assert abs(det.z[0, 0] - r_ref) < 1e-12
    # the specific values away from the seam
    det = sensor.sense(
        (1.0, 1.0, -0.5),
        np.array([[1.0 + math.cos(2.9), 1.0 + math.sin(2.9)]]),
        np.array([0]),
        RNG(0),
    )
    assert det.z[0, 1] == pytest.approx(3.4 - 2 * PI, abs=1e-12)
    det = sensor.sense((0.0, 0.0, 0.0), np.array([[-1.0, 0.0]]), np.array([0]), RNG(0))
    assert det.z[0, 1] == -PI


def test_noisy_bearing_behind_stays_in_range_and_straddles_the_seam():
    sigma = 0.1
    sensor = LandmarkSensor(all_seeing(bearing_std=sigma, range_std=0.01))
    pose = (2.0, -1.0, 0.3)
    m = np.array([[2.0 - 3.0 * math.cos(0.3), -1.0 - 3.0 * math.sin(0.3)]])  # straight behind
    rng = RNG(4)
    n = 4000
    phis = np.array([sensor.sense(pose, m, np.array([5]), rng).z[0, 1] for _ in range(n)])
    assert np.all(phis >= -PI) and np.all(phis < PI)
    err = ref_wrap(phis - PI)  # circular error about the true bearing ±π
    assert abs(err.mean()) <= N_SE * sigma / math.sqrt(n)
    assert abs(err.var(ddof=1) - sigma**2) <= N_SE * sigma**2 * math.sqrt(2 / (n - 1))
    # about half of the draws land on each side of the seam
    frac_pos = float(np.mean(phis > 0))
    assert abs(frac_pos - 0.5) <= N_SE * 0.5 / math.sqrt(n)


# ---------------------------------------------------------------- exactness


@pytest.mark.parametrize("model", ["range_bearing", "cartesian"])
def test_noise_free_measurements_are_exact(model):
    sensor = LandmarkSensor(all_seeing(measurement_model=model, cartesian_std=0.0))
    rng = RNG(5)
    ref = ref_range_bearing if model == "range_bearing" else ref_cartesian
    for _ in range(100):
        pose = (rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-4, 4))
        pos = rng.uniform(-15, 15, size=(20, 2))
        ids = rng.permutation(20)
        det = sensor.sense(pose, pos, ids, rng)
        assert isinstance(det, Detections)
        assert det.z.shape == (20, 2) and det.z.dtype == np.float64
        assert det.ids.dtype == np.int64 and det.index.dtype == np.int64
        assert det.ids.tolist() == list(range(20))
        assert np.array_equal(ids[det.index], det.ids)
        expected = np.array([ref(pose, pos[i]) for i in det.index])
        if model == "range_bearing":
            assert np.allclose(det.z[:, 0], expected[:, 0], rtol=0, atol=1e-12)
            assert np.all(np.abs(ref_wrap(det.z[:, 1] - expected[:, 1])) < 1e-12)
            assert np.all(det.z[:, 1] >= -PI) and np.all(det.z[:, 1] < PI)
        else:
            assert np.allclose(det.z, expected, rtol=0, atol=1e-12)


def test_noise_free_output_draws_nothing_from_rng():
    sensor = LandmarkSensor(all_seeing())
    rng = RNG(6)
    before = rng.bit_generator.state
    sensor.sense((0.0, 0.0, 0.0), RNG(7).uniform(-5, 5, (20, 2)), np.arange(20), rng)
    assert rng.bit_generator.state == before


# ---------------------------------------------------------------- noise statistics


def _scene():
    pose = (1.0, 2.0, 0.4)
    pos = np.array([[4.0, 3.0], [0.0, 5.0], [2.5, -1.0]])
    ids = np.array([11, 4, 7])
    return pose, pos, ids


def test_range_bearing_noise_matches_q():
    sr, sp = 0.1, 0.05
    sensor = LandmarkSensor(all_seeing(range_std=sr, bearing_std=sp))
    assert np.array_equal(sensor.measurement_cov, np.diag([sr**2, sp**2]))
    assert np.array_equal(sensor.measurement_cov, sensor.config.measurement_cov)
    pose, pos, ids = _scene()
    order = np.argsort(ids)
    truth = np.array([ref_range_bearing(pose, pos[i]) for i in order])
    rng = RNG(8)
    n = 20000
    err = np.empty((n, 6))
    for t in range(n):
        det = sensor.sense(pose, pos, ids, rng)
        e = det.z - truth
        e[:, 1] = ref_wrap(e[:, 1])
        err[t] = e.ravel()
    q6 = np.diag([sr**2, sp**2] * 3)  # landmarks independent of each other
    assert_gaussian_errors(err, q6, "range-bearing")


def test_cartesian_noise_matches_sigma_z():
    sz = 0.08
    sensor = LandmarkSensor(all_seeing(measurement_model="cartesian", cartesian_std=sz))
    assert np.array_equal(sensor.measurement_cov, np.diag([sz**2, sz**2]))
    pose, pos, ids = _scene()
    truth = np.array([ref_cartesian(pose, pos[i]) for i in np.argsort(ids)])
    rng = RNG(9)
    n = 20000
    err = np.array([(sensor.sense(pose, pos, ids, rng).z - truth).ravel() for _ in range(n)])
    assert_gaussian_errors(err, np.diag([sz**2] * 6), "cartesian")


def test_statistics_check_detects_wrong_noise():
    """The tolerance is tight enough to catch a 10 % error in σ (guards the tests)."""
    rng = RNG(10)
    n = 20000
    err = rng.standard_normal((n, 2)) * np.array([0.11, 0.05])
    with pytest.raises(AssertionError):
        assert_gaussian_errors(err, np.diag([0.1**2, 0.05**2]), "too-wide")
    with pytest.raises(AssertionError):
        assert_gaussian_errors(rng.uniform(-1, 1, (n, 1)) * math.sqrt(3), np.eye(1), "uniform")


# ---------------------------------------------------------------- detection prob / max


def test_detection_probability_drops_the_right_fraction_independently():
    p, n_lm, n_scans = 0.7, 20, 3000
    sensor = LandmarkSensor(all_seeing(detection_prob=p))
    pos = RNG(11).uniform(-5, 5, (n_lm, 2))
    ids = np.arange(n_lm)
    rng = RNG(12)
    hits = np.zeros((n_scans, n_lm), dtype=bool)
    for t in range(n_scans):
        det = sensor.sense((0.0, 0.0, 0.0), pos, ids, rng)
        assert np.all(np.diff(det.ids) > 0)
        hits[t, det.ids] = True
    total = hits.size
    assert abs(hits.mean() - p) <= N_SE * math.sqrt(p * (1 - p) / total)
    # each landmark separately
    per = hits.mean(axis=0)
    assert np.all(np.abs(per - p) <= N_SE * math.sqrt(p * (1 - p) / n_scans))
    # independence: the count per scan is Binomial(n_lm, p); check its variance,
    # whose sampling SE uses the binomial's 4th central moment
    counts = hits.sum(axis=1)
    var = n_lm * p * (1 - p)
    mu4 = var * (1 + 3 * (n_lm - 2) * p * (1 - p))
    se_var = math.sqrt((mu4 - var**2 * (n_scans - 3) / (n_scans - 1)) / n_scans)
    assert abs(counts.var(ddof=1) - var) <= N_SE * se_var


def test_max_detections_keeps_the_nearest_and_sorts_by_id():
    sensor = LandmarkSensor(all_seeing(max_detections=3))
    ranges = [3.0, 1.0, 5.0, 2.0, 4.0, 1.5]
    ids = np.array([50, 40, 30, 20, 10, 60])
    pos = np.array([[r * math.cos(0.5 * i), r * math.sin(0.5 * i)] for i, r in enumerate(ranges)])
    det = sensor.sense((0.0, 0.0, 0.0), pos, ids, RNG(0))
    # nearest three: ranges 1.0 (id 40), 1.5 (id 60), 2.0 (id 20)
    assert det.ids.tolist() == [20, 40, 60]
    assert np.allclose(det.z[:, 0], [2.0, 1.0, 1.5], atol=1e-12)
    # an occluded landmark does not take a slot: hide id 40
    det = sensor.sense((0.0, 0.0, 0.0), pos, ids, RNG(0), line_of_sight=lambda o, t, i: i != 1)
    assert det.ids.tolist() == [20, 50, 60]
    # fewer visible than the cap: all of them
    few = LandmarkSensor(all_seeing(max_detections=10))
    assert len(few.sense((0.0, 0.0, 0.0), pos, ids, RNG(0))) == 6


def test_max_detections_keeps_the_nearest_by_true_range_in_the_cartesian_model():
    """The cap ranks by the true range, not by the first measurement component (which
    is the range only in the range-bearing model): landmarks far ahead but close in x
    in the robot frame lose to near ones beside the robot."""
    sensor = LandmarkSensor(
        all_seeing(measurement_model="cartesian", cartesian_std=0.0, max_detections=2)
    )
    # robot frame = world frame (pose at the origin, heading 0): z = (x, y)
    pos = np.array([[0.5, 6.0], [1.0, 0.0], [0.2, -5.0], [-1.5, 0.5]])
    ids = np.array([0, 1, 2, 3])
    det = sensor.sense((0.0, 0.0, 0.0), pos, ids, RNG(0))
    assert det.ids.tolist() == [1, 3]  # ranges 1.0 and 1.58; z0 would pick 3 and 2
    np.testing.assert_array_equal(det.z, pos[[1, 3]])


def test_empty_result_has_the_right_shapes():
    sensor = LandmarkSensor(SensorConfig(max_range=1.0))
    det = sensor.sense((0.0, 0.0, 0.0), np.array([[5.0, 0.0]]), np.array([3]), RNG(0))
    assert len(det) == 0
    assert det.z.shape == (0, 2) and det.z.dtype == np.float64
    assert det.ids.shape == (0,) and det.ids.dtype == np.int64
    assert det.index.shape == (0,) and det.index.dtype == np.int64
    det = sensor.sense((0.0, 0.0, 0.0), np.zeros((0, 2)), np.zeros(0, dtype=int), RNG(0))
    assert len(det) == 0
    assert det.z.flags.writeable and det.ids.flags.writeable  # private arrays, not constants


def test_bad_inputs_raise():
    sensor = LandmarkSensor(SensorConfig())
    with pytest.raises(ValueError):
        sensor.sense((0.0, 0.0, 0.0), np.zeros((3, 3)), np.arange(3), RNG(0))
    with pytest.raises(ValueError):
        sensor.sense((0.0, 0.0, 0.0), np.zeros((3, 2)), np.arange(4), RNG(0))
    with pytest.raises(TypeError):
        LandmarkSensor(OdometryConfig())  # type: ignore[arg-type]


# ---------------------------------------------------------------- determinism


def test_same_seed_same_detections_and_permutation_invariance():
    cfg = SensorConfig(max_range=6.0, fov=4.0, detection_prob=0.8, max_detections=6)
    sensor = LandmarkSensor(cfg)
    pos = RNG(13).uniform(-6, 6, (20, 2))
    ids = np.arange(20)

    def los(origin, target, index):
        return target[0] > -3.0

    def run(seed, p=pos, i=ids):
        rng = RNG(seed)
        return [sensor.sense((0.2 * t, 0.1, 0.3 * t), p, i, rng, los) for t in range(30)]

    a, b, c = run(14), run(14), run(15)
    for da, db in zip(a, b, strict=True):
        assert np.array_equal(da.z, db.z) and np.array_equal(da.ids, db.ids)
    assert any(
        len(da) != len(dc) or not np.array_equal(da.z, dc.z) for da, dc in zip(a, c, strict=True)
    ), "a different seed should give different readings"
    # the landmark arrays' order does not matter: draws are made in ID order
    perm = RNG(16).permutation(20)
    d = run(14, pos[perm], ids[perm])
    for da, dd in zip(a, d, strict=True):
        assert np.array_equal(da.ids, dd.ids)
        assert np.allclose(da.z, dd.z, rtol=0, atol=1e-12)
        assert np.array_equal(perm[dd.index], da.index)


# ---------------------------------------------------------------- the draws
# The sensors draw one block of uniforms per call; these tests hold them to a plain
# Python transcription of their documented steps, bit for bit (the seeded stream
# depends on it).


def reference_sense(sensor, pose, pos, ids, rng, los=None):
    """LandmarkSensor.sense as its docstring defines it, step by step in plain Python."""
    x, y, th = pose
    n = len(pos)
    d = sensor.max_detections or n
    std = np.sqrt(np.diag(sensor.measurement_cov)).tolist()
    draws = sensor.detection_prob < 1.0 or any(std)
    u = rng.random(n + 2 * d).tolist() if draws else [0.0] * (n + 2 * d)
    order = sorted(range(n), key=lambda i: ids[i])  # stable
    found = []  # (row, r, z0, z1): the true range and the noise-free measurement
    c, s = math.cos(th), math.sin(th)
    for j, i in enumerate(order):
        dx, dy = pos[i][0] - x, pos[i][1] - y
        r, phi = math.sqrt(dx * dx + dy * dy), wrap_angle(math.atan2(dy, dx) - th)
        if r > sensor.max_range or (sensor.fov < 2 * PI and abs(phi) > sensor.fov / 2):
            continue
        if sensor.detection_prob < 1.0 and not u[j] < sensor.detection_prob:
            continue
        if los is not None and not los(np.array([x, y]), pos[i], i):
            continue
        z = (r, phi) if sensor.model == "range_bearing" else (c * dx + s * dy, -s * dx + c * dy)
        found.append((i, r, *z))
    if len(found) > d:
        nearest = sorted(range(len(found)), key=lambda j: (found[j][1], j))[:d]
        found = [found[j] for j in sorted(nearest)]
    z = []
    for k, (_, _, z0, z1) in enumerate(found):
        e0, e1 = box_muller(u[n + 2 * k], u[n + 2 * k + 1]) if any(std) else (0.0, 0.0)
        z1 += e1 * std[1]
        z.append((z0 + e0 * std[0], wrap_angle(z1) if sensor.model == "range_bearing" else z1))
    rows = [f[0] for f in found]
    return np.array(z, dtype=np.float64).reshape(-1, 2), np.array([ids[i] for i in rows]), rows


@pytest.mark.parametrize("model", ["range_bearing", "cartesian"])
@pytest.mark.parametrize("noisy", [True, False])
def test_sense_is_bitwise_its_documented_steps(model, noisy):
    rng = RNG(300)
    for trial in range(200):
        cfg = SensorConfig(
            measurement_model=model,
            max_range=float(rng.uniform(1.0, 8.0)),
            fov=float(rng.choice([2 * PI, rng.uniform(0.2, 2 * PI)])),
            range_std=0.05 * noisy,
            bearing_std=0.02 * noisy,
            cartesian_std=0.05 * noisy,
            detection_prob=float(rng.choice([1.0, 0.7])),
            max_detections=[None, 2, 5][trial % 3],
        )
        sensor = LandmarkSensor(cfg)
        n = int(rng.integers(0, 30))
        pos = rng.uniform(-6, 6, (n, 2))
        ids = rng.permutation(n) if trial % 2 else np.arange(n)
        pose = tuple(float(v) for v in rng.uniform(-2, 2, 3))
        los = None if trial % 4 else (lambda o, t, i: (i % 3) != 1)
        r1, r2 = RNG(trial), RNG(trial)
        det = sensor.sense(pose, pos, ids, r1, los)
        z, got_ids, rows = reference_sense(sensor, pose, pos.tolist(), ids.tolist(), r2, los)
        assert det.z.tobytes() == z.tobytes(), trial
        assert det.ids.tolist() == got_ids.tolist() and det.index.tolist() == rows
        assert r1.bit_generator.state == r2.bit_generator.state  # same draws


def test_sense_takes_positions_in_any_memory_layout():
    pos = RNG(304).uniform(-6, 6, (25, 2))
    wide = np.zeros((25, 4))
    wide[:, ::2] = pos
    sensor = LandmarkSensor(SensorConfig(max_range=6.0, fov=4.0))
    ids = np.arange(25)
    ref = sensor.sense((0.3, -0.4, 0.8), pos, ids, RNG(0))
    for other in (np.asfortranarray(pos), wide[:, ::2], pos.tolist()):
        det = sensor.sense((0.3, -0.4, 0.8), other, ids, RNG(0))
        assert det.z.tobytes() == ref.z.tobytes() and det.index.tolist() == ref.index.tolist()
