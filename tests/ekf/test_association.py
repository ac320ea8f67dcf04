"""Data association in the filter (``data_association="nearest_neighbor" | "jcbb"``):
the known-ID result recovered on clean data, JCBB refusing what only joint compatibility
reveals, the rule for new landmarks, the filter owning its identities, and the scores
against the truth (:mod:`slam_env.kernels.ekf.association_score`)."""

from __future__ import annotations

import itertools
import math
import pickle

import numpy as np
import pytest

from slam_env.ekf import DISCARDED, EKFSLAM, INITIALISED, TENTATIVE, chi2_gate
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.kernels.ekf import association
from slam_env.kernels.ekf import association_score as score
from slam_env.kernels.ekf import codes as ekf_codes

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
@pytest.mark.parametrize("linearization", ["standard", "invariant"])
def test_association_recovers_the_known_ids_result_on_clean_data(
    measurement, correction, linearization
):
    """With well-separated landmarks and data far inside the gates, NN and JCBB give
    every observation to its true landmark and start each landmark once, in the same
    order: the belief is the known-ID filter's, bit for bit (the invariant filter's
    too: its D² is computed with its own S)."""
    filters = {
        name: make(name, measurement, correction=correction, linearization=linearization)
        for name in ("known", *ASSOCIATING)
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


def hidden_landmark_filter(wide_pairing_scans: int) -> EKFSLAM:
    """Landmark A mapped at (4, 0) from a known pose, then a turn on the spot that
    leaves the heading uncertain (σθ ≈ 9°, so a pairing with A is wide)."""
    f = EKFSLAM(
        alphas=(0.05, 0.0, 0.0, 0.0),
        measurement_cov=Q["range_bearing"],
        max_landmarks=4,
        data_association="jcbb",
        wide_pairing_scans=wide_pairing_scans,
    )
    f.update(MEASUREMENT_MODELS["range_bearing"].h(np.zeros(3), np.array([[4.0, 0.0]])))
    f.predict([0.5, 0.0, -0.5])  # back to heading 0 (truly), unsure by how much
    return f


@pytest.mark.parametrize("wide_pairing_scans", [1, 3])
def test_a_new_landmark_beside_a_hidden_mapped_one_is_not_taken_for_it(wide_pairing_scans):
    """Seed 18 of the consistency benchmark, made small: a new landmark B stands 0.6 m
    beside A, where A is expected within the heading's uncertainty, and A itself is
    not seen (hidden) for two scans, then both are. With wide pairings committed at
    once (``wide_pairing_scans=1``) JCBB gives B's first sighting to A, the heading is
    corrected the wrong way, and A, seen again, starts a second landmark (a duplicate).
    With ``wide_pairing_scans=3`` the wide pairing waits, the third scan shows two
    observations compatible with A (ambiguous: both withdrawn), and nothing is given to
    the wrong landmark or mapped twice."""
    h = MEASUREMENT_MODELS["range_bearing"].h
    truth = np.array([[4.0, 0.0], [4.0 * math.cos(0.15), 4.0 * math.sin(0.15)]])  # A, B
    f = hidden_landmark_filter(wide_pairing_scans)
    given_to = [
        f.update(h(np.zeros(3), scan)).ids.tolist() for scan in (truth[1:], truth[1:], truth)
    ]
    b_given_to = [ids[-1] for ids in given_to]
    if wide_pairing_scans == 1:
        assert b_given_to == [0, 0, 0]  # B taken for A
        assert given_to[2][0] == 1 and f.n_landmarks == 2  # A mapped twice
    else:
        assert b_given_to == [-1, -1, -1]  # held back, then ambiguous
        assert given_to[2] == [-1, -1] and f.n_landmarks == 1
        # Alone again, A's observation is followed and committed after three scans.
        z = h(np.zeros(3), truth[:1])
        assert [f.update(z).ids.tolist() for _ in range(3)] == [[-1], [-1], [0]]
        np.testing.assert_allclose(f.pose, np.zeros(3), atol=0.02)


def test_wide_pairing_scans_is_checked():
    with pytest.raises(ValueError, match="needs data_association='jcbb'"):
        make("nearest_neighbor", wide_pairing_scans=2)
    with pytest.raises(ValueError, match=">= 1"):
        make("jcbb", wide_pairing_scans=0)
    with pytest.raises(TypeError, match="an int"):
        make("jcbb", wide_pairing_scans=True)
    assert make("jcbb", wide_pairing_scans=3).wide_pairing_scans == 3


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
        [[ekf_codes.CORRECTED, ekf_codes.CORRECTED, DISCARDED, DISCARDED, INITIALISED, INITIALISED,
          INITIALISED, ekf_codes.REJECTED]], dtype=np.int8,
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
    status = np.array(
        [[ekf_codes.CORRECTED, ekf_codes.CORRECTED, TENTATIVE, TENTATIVE]], dtype=np.int8
    )
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


# --------------------------------------------------------------------------- references
Q_CORRELATED = np.array([[0.04**2, 1e-4], [1e-4, math.radians(1.5) ** 2]])


def numeric_h_jacobian(pose: np.ndarray, m: np.ndarray, model: str) -> np.ndarray:
    """∂h/∂(pose, m) (2×5) by central differences, bearing differences wrapped."""
    h = MEASUREMENT_MODELS[model].h
    point, cols = np.concatenate([pose, m]), []
    for i in range(5):
        d = np.zeros(5)
        d[i] = 1e-6
        hi, lo = (
            h(point[:3] + d[:3], (point[3:] + d[3:])[None])[0],
            h(point[:3] - d[:3], (point[3:] - d[3:])[None])[0],
        )
        diff = hi - lo
        if model == "range_bearing":
            diff[1] = (diff[1] + np.pi) % (2 * np.pi) - np.pi
        cols.append(diff / 2e-6)
    return np.stack(cols, axis=1)


def dense_terms(f: EKFSLAM, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per observation j and landmark i: ν (k, n, 2) and the full-width H (k, n, 2, d),
    from h and finite differences; and P (d, d)."""
    mean, P = f.mean, f.cov
    d, n = mean.size, f.n_landmarks
    nu, H = np.zeros((len(z), n, 2)), np.zeros((len(z), n, 2, d))
    model = f.measurement_model
    h = MEASUREMENT_MODELS[model].h
    for i in range(n):
        s = 3 + 2 * i
        J = numeric_h_jacobian(mean[:3], mean[s : s + 2], model)
        for j in range(len(z)):
            v = z[j] - h(mean[:3], mean[s : s + 2][None])[0]
            if model == "range_bearing":
                v[1] = (v[1] + np.pi) % (2 * np.pi) - np.pi
            nu[j, i] = v
            H[j, i][:, :3], H[j, i][:, s : s + 2] = J[:, :3], J[:, 3:]
    return nu, H, P


def cluttered_filter(
    rng: np.random.Generator, association: str, n: int = 6, model: str = "range_bearing"
):
    """Landmarks 0.4–0.8 m apart mapped from an uncertain pose, then a turn that leaves
    the heading uncertain: a scan of them is ambiguous."""
    f = EKFSLAM(
        alphas=(0.02, 0.0, 0.0, 0.0),
        measurement_model=model,
        measurement_cov=Q_CORRELATED,
        max_landmarks=12,
        initial_pose_cov=np.diag([0.01, 0.01, 0.002]),
        data_association=association,
    )
    centre = np.array([3.0, 0.0])
    truth = centre + rng.uniform(-0.8, 0.8, size=(n, 2))
    f.update(MEASUREMENT_MODELS[model].h(np.zeros(3), truth))
    f.predict([0.3, 0.0, -0.3])
    return f, truth


@pytest.mark.parametrize("model", ["range_bearing", "cartesian"])
def test_nearest_is_the_smallest_mahalanobis_distance_of_a_dense_computation(model):
    rng = np.random.default_rng(5)
    for _ in range(5):
        f, truth = cluttered_filter(rng, "nearest_neighbor", model=model)
        z = MEASUREMENT_MODELS[model].h(np.zeros(3), truth[:4])
        z += rng.normal(size=z.shape) * [0.05, 0.03]
        nu, H, P = dense_terms(f, z)
        expected = np.full(len(z), np.inf)
        for j in range(len(z)):
            for i in range(f.n_landmarks):
                S = H[j, i] @ P @ H[j, i].T + Q_CORRELATED
                expected[j] = min(expected[j], nu[j, i] @ np.linalg.solve(S, nu[j, i]))
        np.testing.assert_allclose(f.update(z).nearest, expected, rtol=1e-5)


def brute_force_jcbb(f: EKFSLAM, z: np.ndarray) -> tuple[list[int], int]:
    """Every hypothesis (a compatible landmark or none per observation, none twice),
    the most pairings whose joint NIS passes the joint gate, then the smallest NIS; and
    how many observations had more than one compatible landmark."""
    from scipy.stats import chi2

    nu, H, P = dense_terms(f, z)
    match = f.association_gates[0]
    p = chi2.cdf(match, 2)
    options = []
    for j in range(len(z)):
        compatible = [
            i
            for i in range(f.n_landmarks)
            if nu[j, i] @ np.linalg.solve(H[j, i] @ P @ H[j, i].T + Q_CORRELATED, nu[j, i]) <= match
        ]
        options.append([*compatible, -1])
    best, best_key = [-1] * len(z), (0, 0.0)
    for hypothesis in itertools.product(*options):
        paired = [(j, i) for j, i in enumerate(hypothesis) if i >= 0]
        if len({i for _, i in paired}) < len(paired):
            continue
        if not paired:
            continue
        Hh = np.concatenate([H[j, i] for j, i in paired])
        v = np.concatenate([nu[j, i] for j, i in paired])
        S = Hh @ P @ Hh.T + np.kron(np.eye(len(paired)), Q_CORRELATED)
        nis = float(v @ np.linalg.solve(S, v))
        if nis > chi2.ppf(p, 2 * len(paired)):
            continue
        key = (len(paired), -nis)
        if key > best_key:
            best, best_key = list(hypothesis), key
    return best, sum(len(o) > 2 for o in options)


def test_jcbb_finds_the_hypothesis_an_exhaustive_search_finds():
    """On ambiguous scans (landmarks closer than the uncertainty, observations of some
    of them shifted), JCBB's pairing is the exhaustive search's."""
    rng = np.random.default_rng(6)
    ambiguous = refused = 0
    for _ in range(12):
        f, truth = cluttered_filter(rng, "jcbb")
        seen = rng.permutation(len(truth))[:4]
        pose = np.array([0.0, 0.0, rng.normal(0, 0.05)])
        z = MEASUREMENT_MODELS["range_bearing"].h(pose, truth[seen])
        z += rng.normal(size=z.shape) * [0.06, 0.04]
        z[0, 1] += rng.choice([-1, 1]) * 0.15  # alone it fits the heading; with the rest not
        expected, several = brute_force_jcbb(f, z)
        n = f.n_landmarks
        got = f.update(z).ids
        np.testing.assert_array_equal(np.where((got >= 0) & (got < n), got, -1), expected)
        ambiguous += several
        refused += expected.count(-1)
    assert ambiguous >= 10 and refused >= 3, (ambiguous, refused)  # the search had work


def test_a_tentative_sighting_is_confirmed_exactly_within_the_match_gate():
    """The robot moves between the two sightings: the second confirms the first iff
    the χ² distance of their world positions over W₁QW₁ᵀ + W₂QW₂ᵀ (Q correlated) is
    within the match gate."""
    hm = MEASUREMENT_MODELS["range_bearing"]
    first_z = np.array([[3.0, 0.5]])
    pose2 = MOTION_MODELS["odometry"].motion(np.zeros(3), np.array([0.1, 0.5, 0.2]))
    p1 = hm.inverse(np.zeros(3), first_z)[0]
    _, W1 = hm.inverse_jacobians(np.zeros(3), first_z)
    for scale, confirmed in ((0.95, True), (1.05, False)):
        f = EKFSLAM(
            alphas=(0, 0, 0, 0),
            measurement_cov=Q_CORRELATED,
            max_landmarks=4,
            data_association="jcbb",
            new_landmark_sightings=2,
        )
        assert f.update(first_z).tentative.all()
        f.predict([0.1, 0.5, 0.2])
        # A second sighting displaced along a direction, at the gate's distance × scale.
        z2 = hm.h(pose2, p1[None])
        _, W2 = hm.inverse_jacobians(pose2, z2)
        C = W1[0] @ Q_CORRELATED @ W1[0].T + W2[0] @ Q_CORRELATED @ W2[0].T
        direction = np.array([0.6, 0.8])
        step = np.sqrt(f.association_gates[0] / (direction @ np.linalg.solve(C, direction)))
        moved = p1 + scale * step * direction
        z2 = hm.h(pose2, moved[None])
        # What the filter computes from z2 (its own inverse at its pose): the same point.
        np.testing.assert_allclose(hm.inverse(f.pose, z2)[0], moved, atol=1e-9)
        result = f.update(z2)
        assert result.status.tolist() == ([INITIALISED] if confirmed else [TENTATIVE])


@pytest.mark.parametrize("association", ASSOCIATING)
def test_a_copy_with_known_ids_corrects_the_slots_it_is_given(association):
    """What a planner predicting observations of chosen landmarks needs: the copy takes
    the slots' IDs (state_to_id) and corrects those landmarks as the association would
    on the same observations; the original keeps its own association."""
    filters = {"a": make(association)}
    for _ in drive(filters, "range_bearing", 0.01, seed=3, steps=20):
        pass
    f = filters["a"]
    ids = f.state_to_id[:2]
    z = MEASUREMENT_MODELS["range_bearing"].h(f.pose, f.landmark_means()[:2])
    known = f.copy_with_known_ids()
    assert known.data_association == "known" and not known.associates
    assert f.data_association == association
    result = known.update(z, ids)
    np.testing.assert_array_equal(result.ids, ids)
    twin = f.copy()
    assert twin.update(z).ids.tolist() == result.ids.tolist()  # the same slots, by itself
    np.testing.assert_allclose(known.cov, twin.cov, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(f.mean, filters["a"].mean)  # the original untouched


def test_a_copy_with_known_ids_of_a_known_filter_is_a_copy():
    f = make("known")
    f.update(np.array([[2.0, 0.3]]), [5])
    g = f.copy_with_known_ids()
    g.update(np.array([[2.0, 0.3]]), [5])
    assert g.data_association == "known" and g.state_to_id.tolist() == [5]
    assert f.cov[3, 3] > g.cov[3, 3]  # the original untouched
