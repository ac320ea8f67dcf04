"""EKFSLAM calls its kernels' compiled code pinned to its own arrays
(:mod:`slam_env.kernels.base.pinning`): code that trusts its arguments. So the arrays of
each call must be of the pinned types whatever the caller passed, and every filter (a
copy, an unpickled one, a view over a batch, one whose workspaces grew) must step
through calls pinned to its own arrays, not to those of the filter it came from."""

from __future__ import annotations

import copy
import math
import pickle

import numba
import numpy as np
import pytest

from slam_env.ekf import EKFSLAM, checks
from slam_env.ekf.batch import FilterBatch
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS

Z = np.array([[2.0, 0.1], [3.0, -0.4], [1.5, 1.2]])
IDS = np.array([4, 0, 2])


def odd_observations() -> list[tuple[str, object, object]]:
    readonly = Z.copy()
    readonly.flags.writeable = False
    # Writable but one byte off the alignment of its float64s.
    unaligned = np.frombuffer(bytearray(Z.nbytes + 1), dtype=np.float64, offset=1)
    unaligned = unaligned.reshape(Z.shape)
    unaligned[...] = Z
    wide = np.zeros((3, 4))
    wide[:, ::2] = Z
    return [
        ("lists", Z.tolist(), IDS.tolist()),
        ("float32 z, uint8 ids", Z.astype(np.float32), IDS.astype(np.uint8)),
        ("read-only z", readonly, IDS),
        ("unaligned z", unaligned, IDS),
        ("Fortran-ordered z", np.asfortranarray(Z), IDS),
        ("strided z and ids", wide[:, ::2], np.repeat(IDS, 2)[::2]),
        ("reversed", Z[::-1], IDS[::-1]),
        ("big-endian", Z.astype(">f8"), IDS.astype(">i8")),
        ("int32 ids", Z, IDS.astype(np.int32)),
        ("no ids", Z, None),
        ("none at all", np.zeros((0, 2)), []),
    ]


@pytest.mark.parametrize(("case", "z", "ids"), odd_observations(), ids=lambda c: str(c))
def test_observations_are_always_of_the_one_pinned_type(case, z, ids):
    reference = checks.observations(np.empty((0, 2)), np.empty(0, dtype=np.int64))
    zk, idk = checks.observations(z, ids)
    assert [numba.typeof(a) for a in (zk, idk)] == [numba.typeof(a) for a in reference]
    # numba types an unaligned array as aligned, and the compiled code assumes it is.
    assert zk.flags.carray and idk.flags.carray
    np.testing.assert_array_equal(zk, np.asarray(z, dtype=np.float64).reshape(-1, 2))
    expected = np.full(zk.shape[0], -1) if ids is None else np.asarray(ids)
    np.testing.assert_array_equal(idk, expected)
    if ids is not None and isinstance(ids, np.ndarray):
        assert not np.shares_memory(idk, ids)  # the filter writes it and returns it


# 14 landmarks on a grid; an update of 12 at once outgrows the workspaces' first room (8).
GRID = np.stack(np.meshgrid(np.arange(7) * 2.0 - 6.0, [-3.0, 3.0]), axis=-1).reshape(-1, 2)
Q = np.diag([0.03**2, math.radians(0.5) ** 2])


def make(association: str) -> EKFSLAM:
    return EKFSLAM(
        alphas=(0.002, 0.001, 0.002, 0.001),
        measurement_cov=Q,
        max_landmarks=len(GRID),
        initial_pose_cov=np.diag([1e-3, 1e-3, 1e-4]),
        data_association=association,
    )


def observe(f: EKFSLAM, pose: np.ndarray, ids: np.ndarray):
    z = MEASUREMENT_MODELS["range_bearing"].h(pose, GRID[ids])
    return f.update(z, ids if f.data_association == "known" else None)


def start(f: EKFSLAM) -> None:
    """A first update of three landmarks (the workspaces keep their first room)."""
    observe(f, np.zeros(3), np.array([3, 10, 5]))


def clone(f: EKFSLAM, how: str) -> EKFSLAM:
    if how == "copy":
        return f.copy()
    if how == "deepcopy":
        return copy.deepcopy(f)
    if how == "pickle":
        return pickle.loads(pickle.dumps(f))
    batch = FilterBatch(2, f, max_observations=len(GRID))  # a view over row 1
    view = batch.filter(1)
    view.reset()
    start(view)
    return view


@pytest.mark.parametrize("association", ["known", "jcbb"])
@pytest.mark.parametrize("how", ["copy", "deepcopy", "pickle", "batch view"])
def test_every_filter_steps_through_calls_pinned_to_its_own_arrays(how, association):
    """A clone, and its workspaces grown, steps bit for bit as a twin that was never
    cloned, and leaves the filter it came from as it was."""
    original, twin = make(association), make(association)
    start(original)
    start(twin)
    g = clone(original, how)
    before = original.mean, original.cov, original.id_to_state
    rng = np.random.default_rng(7)
    pose = np.zeros(3)
    for step in range(4):
        u = np.array([0.05, 0.2, -0.03])
        pose = MOTION_MODELS["odometry"].motion(pose, u)
        ids = rng.permutation(len(GRID))[: 12 if step == 0 else 5]
        for f in (g, twin):
            f.predict(tuple(u.tolist()) if step % 2 else u)  # the tuples' own short path
        got, expected = observe(g, pose, ids), observe(twin, pose, ids)
        for name in ("ids", "status", "nis", "nearest"):
            np.testing.assert_array_equal(getattr(got, name), getattr(expected, name))
        np.testing.assert_array_equal(g.mean, twin.mean)
        np.testing.assert_array_equal(g.cov, twin.cov)
        np.testing.assert_array_equal(g.state_to_id, twin.state_to_id)
    assert g._max_obs == 12  # the workspaces grew on the way
    for now, then in zip((original.mean, original.cov, original.id_to_state), before, strict=True):
        np.testing.assert_array_equal(now, then)


@pytest.mark.parametrize(
    ("model", "floats", "ints"),
    [("odometry", (0.25, 0.5, -0.125), (1, 2, 0)), ("velocity", (0.5, -0.125), (2, 1))],
)
def test_a_control_predicts_the_same_in_every_form(model, floats, ints):
    """A tuple of floats takes a short path of its own (the kernel gets the numbers,
    not an array): it predicts bit for bit what the same control as an array does, and
    so do the forms that take the long path (lists, numpy scalars and arrays, ints)."""

    def predicted(u):
        f = EKFSLAM(
            motion_model=model,
            alphas=(0.01, 0.005, 0.01, 0.005) if model == "odometry" else None,
            control_noise=None if model == "odometry" else (0.01, 0.01, 0.002, 0.002),
            measurement_cov=Q,
            max_landmarks=3,
            initial_pose_cov=np.diag([1e-3, 1e-3, 1e-4]),
        )
        f.update(np.array([[2.0, 0.1], [3.0, -0.4]]), np.array([0, 2]))
        f.predict(u)
        return f.mean, f.cov

    reference = predicted(np.array(floats))
    for u in (floats, list(floats), tuple(map(np.float64, floats)), np.float32(floats)):
        for got, expected in zip(predicted(u), reference, strict=True):
            np.testing.assert_array_equal(got, expected)
    for got, expected in zip(predicted(ints), predicted(np.array(ints, float)), strict=True):
        np.testing.assert_array_equal(got, expected)


def test_a_filter_pins_its_kernels_at_their_first_call_not_when_made(monkeypatch):
    # The env makes a template filter it never steps: making and stepping the env pins
    # none of the single filter's kernels (so loads none from the cache), which the
    # first prediction, association and update of a filter then do.
    import gymnasium as gym

    from slam_env.ekf import filter as filter_module
    from slam_env.kernels.ekf import association
    from slam_env.kernels.ekf import filter as ekf

    pinned = []

    def recording_pin(kernel, *args):
        pinned.append(kernel)
        return pin(kernel, *args)

    pin = filter_module.pin
    monkeypatch.setattr(filter_module, "pin", recording_pin)
    env = gym.make("slam_env/ActiveSLAM-v0", data_association="nearest_neighbor")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert pinned == []
    f = env.unwrapped.filter.copy()
    f.predict((0.1, 0.5, 0.0))
    f.predict((0.1, 0.5, 0.0))
    assert pinned == [ekf.predict_one]
    f.update([[2.0, 0.3]])
    f.update([[2.0, 0.3]])
    assert pinned == [ekf.predict_one, association.associate, ekf.update_one]
    env.close()
