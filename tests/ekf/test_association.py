"""Data association in the filter (``data_association="nearest_neighbor" | "jcbb"``):
the known-ID result recovered on clean data, JCBB refusing what only joint compatibility
reveals, the rule for new landmarks, the filter owning its identities, and the scores
against the truth (:mod:`slam_env.kernels.association_score`)."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from slam_env.ekf import DISCARDED, EKFSLAM, INITIALISED, TENTATIVE, chi2_gate
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.kernels import association, ekf
from slam_env.kernels import association_score as score

ALPHAS = (0.002, 0.001, 0.002, 0.001)
Q = {
    "range_bearing": np.diag([0.03**2, math.radians(0.5) ** 2]),
    "cartesian": np.diag([0.03**2, 0.03**2]),
}
ASSOCIATING = ("nearest_neighbor", "jcbb")


def make(association: str, measurement: str = "range_bearing", **kwargs) -> EKFSLAM:
    return EKFSLAM(
        alphas=ALPHAS,
        measurement_model=measurement,
        measurement_cov=Q[measurement],
        max_landmarks=kwargs.pop("max_landmarks", 16),
        data_association=association,
        **kwargs,
    )


def grid_world() -> np.ndarray:
    """16 landmarks 3 m apart: well separated against the noise."""
    xs, ys = np.meshgrid(np.arange(4) * 3.0 - 4.5, np.arange(4) * 3.0 - 4.5)
    return np.stack([xs.ravel(), ys.ravel()], axis=1)


def drive(filters: dict, measurement: str, correction_noise: float, seed: int, steps: int = 80):
    """Drive a circle through the grid, every filter fed the same data; yields each
    step's true IDs and the update results."""
    rng = np.random.default_rng(seed)
    truth = grid_world()
    hm, mm = MEASUREMENT_MODELS[measurement], MOTION_MODELS["odometry"]
    pose = np.array([0.0, -3.0, 0.0])
    for _ in range(steps):
        u = np.array([0.08, 0.35, 0.0])
        pose = mm.motion(pose, u)
        seen = np.flatnonzero(np.hypot(*(truth - pose[:2]).T) < 4.0)
        z = hm.h(pose, truth[seen]) + rng.normal(size=(seen.size, 2)) * correction_noise
        results = {}
        for name, f in filters.items():
            f.predict(u)
            results[name] = f.update(z, seen if name == "known" else None)
        yield seen, results


@pytest.mark.parametrize("measurement", ["range_bearing", "cartesian"])
@pytest.mark.parametrize("correction", ["sequential", "batch"])
def test_association_recovers_the_known_ids_result_on_clean_data(measurement, correction):
    """With well-separated landmarks and data far inside the gates, NN and JCBB give
    every observation to its true landmark and start each landmark once, in the same
    order: the belief is the known-ID filter's, bit for bit."""
    filters = {
        name: make(name, measurement, correction=correction) for name in ("known", *ASSOCIATING)
    }
    scale = np.sqrt(np.diag(Q[measurement])) * 0.1  # clean: a tenth of the modelled noise
    for seen, results in drive(filters, measurement, scale, seed=1):
        known = results["known"]
        slot_of = filters["known"].id_to_state
        for name in ASSOCIATING:
            got = results[name]
            np.testing.assert_array_equal(got.status, known.status)
            np.testing.assert_array_equal(got.ids, slot_of[seen])  # the filter's IDs: slots
    known = filters["known"]
    assert known.n_landmarks == 16
    for name in ASSOCIATING:
        np.testing.assert_array_equal(filters[name].mean, known.mean)
        np.testing.assert_array_equal(filters[name].cov, known.cov)
        np.testing.assert_array_equal(filters[name].state_to_id, np.arange(16))


def heading_uncertain_filter(association: str) -> tuple[EKFSLAM, np.ndarray]:
    """Two landmarks mapped from a known pose, then a turn on the spot that leaves the
    heading uncertain (σθ ≈ 9°) and the position certain."""
    f = EKFSLAM(
        alphas=(0.05, 0.0, 0.0, 0.0),
        measurement_cov=Q["range_bearing"],
        max_landmarks=4,
        data_association=association,
    )
    landmarks = np.array([[3.0, 1.0], [3.0, -1.0]])
    f.update(MEASUREMENT_MODELS["range_bearing"].h(np.zeros(3), landmarks))
    f.predict([0.5, 0.0, -0.5])  # back to heading 0, unsure by how much
    return f, landmarks


def test_jcbb_refuses_a_jointly_incompatible_hypothesis_that_nearest_neighbour_accepts():
    """Each observation, on its own, fits its landmark through the heading's
    uncertainty; together they need the heading off by +0.2 and by −0.2 rad at once.
    NN pairs both; JCBB keeps the one pairing that is jointly compatible and discards
    the other (it lies within the new-landmark gate, so it starts nothing)."""
    z = MEASUREMENT_MODELS["range_bearing"].h(np.zeros(3), np.array([[3.0, 1.0], [3.0, -1.0]]))
    z[0, 1] += 0.2
    z[1, 1] -= 0.2
    nn, _ = heading_uncertain_filter("nearest_neighbor")
    jcbb, _ = heading_uncertain_filter("jcbb")
    gate = nn.association_gates[0]
    before = jcbb.mean, jcbb.cov
    nn_result = nn.update(z.copy())
    jcbb_result = jcbb.update(z.copy())
    assert (nn_result.nearest < gate).all()  # each one individually compatible
    np.testing.assert_array_equal(nn_result.ids, [0, 1])
    assert (jcbb_result.ids >= 0).sum() == 1
    assert jcbb_result.status[jcbb_result.ids < 0].tolist() == [DISCARDED]
    assert jcbb.n_landmarks == 2
    assert not np.array_equal(jcbb.mean, before[0])  # the compatible one corrected


def test_jcbb_pairs_jointly_compatible_observations_that_share_the_heading_error():
    """The same observations shifted together by the same heading error are jointly
    compatible: JCBB pairs both."""
    z = MEASUREMENT_MODELS["range_bearing"].h(np.zeros(3), np.array([[3.0, 1.0], [3.0, -1.0]]))
    z[:, 1] += 0.2
    jcbb, _ = heading_uncertain_filter("jcbb")
    np.testing.assert_array_equal(jcbb.update(z).ids, [0, 1])


@pytest.mark.parametrize("association", ASSOCIATING)
def test_a_new_landmark_starts_only_outside_the_wider_gate(association):
    """Observations at every distance from one mapped landmark: within the match gate
    they are given to it, between the gates discarded, beyond the new-landmark gate
    they start a landmark (the filter's next ID)."""
    rng = np.random.default_rng(2)
    template = make(association, max_landmarks=3)
    template.update(np.array([[3.0, 0.0]]))
    match, new = template.association_gates
    outcomes = {"matched": 0, "discarded": 0, "initialised": 0}
    for _ in range(300):
        f = template.copy()
        z = np.array([[3.0 + rng.normal(0, 0.15), rng.normal(0, 0.05)]])
        result = f.update(z)
        d2 = result.nearest[0]
        if d2 <= match:
            assert result.ids[0] == 0
            outcomes["matched"] += 1
        elif d2 <= new:
            assert result.status[0] == DISCARDED and result.ids[0] == -1
            assert f.n_landmarks == 1
            outcomes["discarded"] += 1
        else:
            assert result.status[0] == INITIALISED and result.ids[0] == 1
            assert f.n_landmarks == 2
            outcomes["initialised"] += 1
    assert min(outcomes.values()) >= 10, outcomes  # every case was exercised


def test_the_default_gates_are_the_chi2_quantiles_and_the_new_gate_is_wider():
    f = make("jcbb")
    assert f.association_gates == (chi2_gate(0.999), chi2_gate(0.99999))
    with pytest.raises(ValueError, match="must be at least match_gate"):
        make("jcbb", match_gate=10.0, new_landmark_gate=5.0)
    for bad in (0.0, -1.0):
        with pytest.raises(ValueError, match="match_gate must be > 0"):
            make("nearest_neighbor", match_gate=bad)
    with pytest.raises(TypeError, match="new_landmark_gate must be a number"):
        make("jcbb", new_landmark_gate="wide")


def test_a_full_map_discards_what_would_start_a_landmark():
    f = make("nearest_neighbor", max_landmarks=2)
    result = f.update(np.array([[2.0, 0.0], [2.0, 1.0], [2.0, -1.0]]))
    assert result.status.tolist() == [INITIALISED, INITIALISED, DISCARDED]
    assert result.ids.tolist() == [0, 1, -1]
    assert f.n_landmarks == 2


def test_a_filter_that_associates_takes_no_ids():
    f = make("jcbb")
    with pytest.raises(ValueError, match="chooses the landmarks itself"):
        f.update(np.array([[2.0, 0.0]]), [3])
    assert f.update(np.array([[2.0, 0.0]]), [-1]).ids.tolist() == [0]
    with pytest.raises(TypeError, match="ids are required"):
        make("known").update(np.array([[2.0, 0.0]]))
    with pytest.raises(ValueError, match="must be finite"):
        f.update(np.array([[np.nan, 0.0]]))
    assert f.n_landmarks == 1


@pytest.mark.parametrize("association", ASSOCIATING)
def test_copies_and_pickles_associate_like_the_original(association):
    filters = {"a": make(association)}
    for _ in drive(filters, "range_bearing", 0.01, seed=3, steps=20):
        pass
    f = filters["a"]
    z = np.array([[2.0, 0.3], [4.0, -0.2]])
    for other in (f.copy(), pickle.loads(pickle.dumps(f))):
        np.testing.assert_array_equal(other.update(z.copy()).ids, f.copy().update(z.copy()).ids)


def test_the_scores_of_a_hand_made_update():
    """One world, map before the update: slot 0 is true landmark 5, slot 1 true 7.
    Observations: of 5 given to slot 0 (correct); of 7 given to slot 0 (wrong); clutter
    discarded (correct); of 9 discarded (missed); of 7 starting slot 2 (missed: a
    duplicate of slot 1); of 0 starting slot 3 (correct); clutter starting slot 4
    (wrong); of 5 rejected by the gate after being given to slot 0 (correct)."""
    M, D = 6, 8
    truth = np.array([[5, 7, -1, 9, 7, 0, -1, 5]])
    assigned = np.array([[0, 0, -1, -1, 2, 3, 4, 0]])
    status = np.array(
        [[ekf.CORRECTED, ekf.CORRECTED, DISCARDED, DISCARDED, INITIALISED, INITIALISED,
          INITIALISED, ekf.REJECTED]], dtype=np.int8,
    )  # fmt: skip
    slot_truth = np.full((1, M), -1)
    slot_truth[0, :2] = (5, 7)
    step = np.zeros((1, 4), dtype=np.int64)
    episode = np.array([[10, 1, 2, 0]])
    score.score_association(
        assigned, status, truth, np.array([D]), np.array([2]), slot_truth,
        np.ones(1, dtype=np.bool_), step, episode,
    )  # fmt: skip
    assert dict(zip(score.SCORE_NAMES, step[0].tolist(), strict=True)) == {
        "correct": 4,
        "wrong": 2,
        "missed": 2,
        "duplicated": 1,
    }
    assert episode[0].tolist() == [14, 3, 4, 1]
    assert slot_truth[0].tolist() == [5, 7, 7, 0, -1, -1]


def test_the_scores_of_landmark_zero_and_of_clutter_given_to_clutter():
    """Slot 0 is true landmark 0, slot 1 was started from clutter: an observation of 0
    given to slot 0 is correct; clutter given to slot 1 is wrong (clutter is no
    landmark, whatever it is given to); a tentative sighting of 0 is missed (0 is
    mapped), one of clutter correct."""
    truth = np.array([[0, -1, 0, -1]])
    assigned = np.array([[0, 1, -2, -2]])
    status = np.array([[ekf.CORRECTED, ekf.CORRECTED, TENTATIVE, TENTATIVE]], dtype=np.int8)
    slot_truth = np.array([[0, -1, -1]])
    step = np.zeros((1, 4), dtype=np.int64)
    score.score_association(
        assigned, status, truth, np.array([4]), np.array([2]), slot_truth,
        np.ones(1, dtype=np.bool_), step, np.zeros((1, 4), dtype=np.int64),
    )  # fmt: skip
    assert step[0].tolist() == [2, 1, 1, 0]


def test_a_second_sighting_starts_a_tentative_landmark_within_the_window():
    """With ``new_landmark_sightings=2`` the first sighting is held (ID −2); a second,
    consistent one within CONFIRM_WINDOW updates starts the landmark; a sighting that
    waited longer lapses and is held again; two sightings in one scan never confirm
    each other."""
    window = association.CONFIRM_WINDOW
    z = np.array([[3.0, 0.4]])
    for quiet, confirmed in ((0, True), (window - 1, True), (window, False)):
        f = make("jcbb", new_landmark_sightings=2)
        first = f.update(z)
        assert first.status.tolist() == [TENTATIVE] and first.ids.tolist() == [-2]
        for _ in range(quiet):
            f.update(np.zeros((0, 2)))
        second = f.update(z + 0.01)
        assert second.status.tolist() == ([INITIALISED] if confirmed else [TENTATIVE])
        assert f.n_landmarks == int(confirmed)
    f = make("nearest_neighbor", new_landmark_sightings=2)
    assert f.update(np.array([[3.0, 0.4], [3.0, 0.4]])).status.tolist() == [TENTATIVE] * 2
    assert f.n_landmarks == 0


def test_an_inconsistent_second_sighting_does_not_confirm():
    f = make("jcbb", new_landmark_sightings=2)
    f.update(np.array([[3.0, 0.4]]))
    assert f.update(np.array([[3.0, -0.4]])).status.tolist() == [TENTATIVE]
    assert f.n_landmarks == 0
    assert f.update(np.array([[3.0, 0.4]])).status.tolist() == [INITIALISED]
