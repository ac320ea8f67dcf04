"""A filter's options: every bad one refused with a TypeError/ValueError naming it
(through the public constructor, which :func:`~slam_env.ekf.configuration.checked_config`
serves), and the checked options encoded as the kernels take them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.ekf import EKFSLAM, kernel_config
from slam_env.ekf.models import MEASUREMENT_MODELS, MOTION_MODELS
from slam_env.kernels.ekf import codes as ekf_codes
from tests.ekf.filter_options import GOOD, Q, with_


@pytest.mark.parametrize(
    ("changes", "error", "match"),
    [
        (dict(motion_model="ackermann"), ValueError, "motion_model must be one of"),
        (dict(measurement_model="bearing_only"), ValueError, "measurement_model must be one of"),
        (dict(correction="parallel"), ValueError, "correction must be one of"),
        (dict(alphas=(0.1, -0.01, 0.1, 0.1)), ValueError, r"alphas\[1\] must be >= 0"),
        (dict(alphas=(0.1, 0.1, 0.1)), ValueError, "alphas must have 4 entries"),
        (dict(alphas=(0.1, "a", 0.1, 0.1)), TypeError, r"alphas\[1\] must be a number"),
        (dict(alphas=(0.1, math.nan, 0.1, 0.1)), ValueError, r"alphas\[1\] must be finite"),
        (dict(alphas=0.1), TypeError, "alphas must be a sequence"),
        (dict(alphas=None), ValueError, "alphas .* required for motion_model='odometry'"),
        (
            dict(motion_model="velocity", control_noise=None),
            ValueError,
            "control_noise .* required for motion_model='velocity'",
        ),
        (dict(control_noise=(0.1, 0.1, -1.0, 0.1)), ValueError, r"control_noise\[2\] must be >= 0"),
        (dict(measurement_cov=np.eye(3)), ValueError, r"measurement_cov must have shape \(2, 2\)"),
        (
            dict(measurement_cov=[[1.0, 0.5], [0.0, 1.0]]),
            ValueError,
            "measurement_cov must be symmetric",
        ),
        (
            dict(measurement_cov=np.diag([1.0, -1.0])),
            ValueError,
            "measurement_cov must be symmetric positive definite",
        ),
        (
            dict(measurement_cov=np.diag([1.0, 0.0])),
            ValueError,
            "measurement_cov must be symmetric positive definite",
        ),
        (
            dict(measurement_cov=np.diag([1.0, math.inf])),
            ValueError,
            "measurement_cov must be finite",
        ),
        (dict(measurement_cov="Q"), TypeError, "measurement_cov must be an array of numbers"),
        (
            dict(initial_pose_cov=np.diag([1.0, 1.0, -1e-3])),
            ValueError,
            "initial_pose_cov must be positive semi-definite",
        ),
        (
            dict(initial_pose_cov=np.eye(2)),
            ValueError,
            r"initial_pose_cov must have shape \(3, 3\)",
        ),
        (dict(initial_pose=(0.0, 0.0)), ValueError, r"initial_pose must have shape \(3,\)"),
        (dict(initial_pose=(0.0, math.nan, 0.0)), ValueError, "initial_pose must be finite"),
        (dict(max_landmarks=-1), ValueError, "max_landmarks must be >= 0"),
        (dict(max_landmarks=5.0), TypeError, "max_landmarks must be an int"),
        (dict(max_landmarks=True), TypeError, "max_landmarks must be an int"),
        (dict(gate=0.0), ValueError, "gate must be > 0"),
        (dict(gate=-3.0), ValueError, "gate must be > 0"),
        (dict(gate=math.inf), ValueError, "gate must be finite"),
        (dict(gate="5"), TypeError, "gate must be a number"),
    ],
)
def test_bad_configuration_is_refused(changes, error, match):
    with pytest.raises(error, match=match):
        EKFSLAM(**with_(**changes))


def test_any_positive_gate_is_a_gate():
    assert EKFSLAM(**with_(gate=0.5)).gate == 0.5  # below 1 still a χ² threshold
    assert EKFSLAM(**with_(gate=1e-9)).gate == 1e-9
    association = with_(data_association="jcbb", match_gate=0.5, new_landmark_gate=0.7)
    assert EKFSLAM(**association).association_gates == (0.5, 0.7)
    # equal gates leave no band between them: a detection is paired or starts a landmark
    association = with_(data_association="jcbb", match_gate=9.0, new_landmark_gate=9.0)
    assert EKFSLAM(**association).association_gates == (9.0, 9.0)


def test_unknown_keyword_is_refused():
    with pytest.raises(TypeError, match="unexpected keyword argument 'alpha'"):
        EKFSLAM(**GOOD, alpha=(0.1, 0.1, 0.1, 0.1))


def test_a_zero_initial_pose_covariance_and_the_unused_noise_are_allowed():
    f = EKFSLAM(**with_(initial_pose_cov=np.zeros((3, 3)), control_noise=None))
    np.testing.assert_array_equal(f.pose_cov, np.zeros((3, 3)))
    g = EKFSLAM(**with_(motion_model="velocity", alphas=None, max_landmarks=0))
    g.predict((0.5, 0.1))
    assert g.n_landmarks == 0


@pytest.mark.parametrize(
    ("changes", "error", "match"),
    [
        (dict(gate=np.complex128(5.0)), TypeError, "gate must be a number"),
        (dict(alphas=(0.1, 0.1, 1j, 0.1)), TypeError, r"alphas\[2\] must be a number"),
        (dict(measurement_cov=np.eye(2) + 0j), TypeError, "measurement_cov must be an array"),
        (dict(initial_pose=np.zeros(3, dtype=bool)), TypeError, "initial_pose must be an array"),
        (dict(measurement_cov=np.eye(2) * 1e301), ValueError, "overflow"),
        (dict(initial_pose_cov=np.eye(3) * 1e305), ValueError, "overflow"),
    ],
)
def test_configurations_that_are_not_real_or_overflow_are_refused(changes, error, match):
    with pytest.raises(error, match=match):
        EKFSLAM(**with_(**changes))


def test_the_kernels_row_holds_each_option_in_its_place():
    Qc = np.array([[0.04, 0.001], [0.001, 0.0003]])
    params, modes = kernel_config(
        "odometry", "range_bearing", "batch", (0.1, 0.2, 0.3, 0.4), Qc, 9.0,
        "jcbb", "fej", (5.0, 7.0), 2, 3,
    )  # fmt: skip
    assert params.dtype == np.float64 and modes.dtype == np.int64
    assert params.tolist() == [0.1, 0.2, 0.3, 0.4, 0.04, 0.001, 0.0003, 9.0, 5.0, 7.0, 2, 3]
    assert modes.tolist() == [
        MOTION_MODELS["odometry"].code,
        MEASUREMENT_MODELS["range_bearing"].code,
        ekf_codes.BATCH,
        ekf_codes.JCBB,
        ekf_codes.FEJ,
    ]


def test_a_kernel_row_without_association_options_associates_nothing():
    """The defaults are today's filter: known IDs, the standard linearisation, no gate
    (∞), every sighting a landmark, every pairing at once."""
    params, modes = kernel_config("velocity", "range_bearing", "sequential", (1, 2, 3, 4), Q, None)
    assert params[7:].tolist() == [math.inf, math.inf, math.inf, 1, 1]
    assert modes.tolist() == [
        MOTION_MODELS["velocity"].code,
        MEASUREMENT_MODELS["range_bearing"].code,
        ekf_codes.SEQUENTIAL,
        ekf_codes.KNOWN,
        ekf_codes.STANDARD,
    ]
