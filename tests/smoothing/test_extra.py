"""The smoothing layer without GTSAM: importing it needs only numpy, and building an
estimator names the missing extra in one line (these run whether GTSAM is installed
or not)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import numpy as np
import pytest

from slam_env.extras import MissingExtra, require
from slam_env.smoothing import ISAM2SLAM


def test_importing_the_layer_imports_no_gtsam():
    # (gymnasium and pymunk: the import contracts' business, as for slam_env.ekf)
    code = (
        "import sys, slam_env.smoothing; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in "
        "('gtsam', 'gtsam_unstable')))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


@pytest.fixture
def no_gtsam(monkeypatch):
    """A Python that cannot find GTSAM."""
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "gtsam" else find_spec(name, *a),
    )


def test_a_missing_gtsam_is_one_line_naming_the_extra(no_gtsam):
    with pytest.raises(MissingExtra) as info:
        require("gtsam", "ISAM2SLAM")
    assert str(info.value) == (
        "ISAM2SLAM needs the 'gtsam' extra (gtsam not installed): pip install 'slam_env[gtsam]'"
    )
    with pytest.raises(MissingExtra, match="ISAM2SLAM needs the 'gtsam' extra"):
        ISAM2SLAM(alphas=(0.01,) * 4, measurement_cov=np.eye(2) * 0.01, max_landmarks=3)


def test_the_env_with_the_smoothing_belief_names_the_missing_extra(no_gtsam):
    import gymnasium as gym

    import slam_env  # noqa: F401  (registers the env IDs)

    with pytest.raises(MissingExtra, match="ISAM2SLAM needs the 'gtsam' extra"):
        gym.make("slam_env/ActiveSLAM-v0", belief="isam2")
    gym.make("slam_env/ActiveSLAM-v0").reset(seed=0)  # the filter's belief needs none
