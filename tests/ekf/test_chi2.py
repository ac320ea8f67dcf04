"""The χ² quantiles come from scipy.special (importing scipy.stats costs a process a
second): they must be scipy.stats' floats exactly, so gates and bands are unchanged."""

import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from agents.evaluation.statistics import t_quantile
from slam_env.ekf.chi2 import QUANTILES, chi2_ppf, joint_gates

PROBABILITIES = [1e-9, 0.001, 0.025, 0.5, 0.95, 0.975, 0.99, 0.999, 1 - 1e-12]


@pytest.mark.parametrize("p", PROBABILITIES)
@pytest.mark.parametrize("dof", [1, 2, 3, 7, 150, 3000])
def test_chi2_ppf_is_scipy_stats_bit_for_bit(p, dof):
    assert chi2_ppf(p, dof) == float(stats.chi2.ppf(p, dof))


@pytest.mark.parametrize("gate", [0.5, 5.991, 13.8155, 40.0])
def test_joint_gates_are_scipy_stats_bit_for_bit(gate):
    p = float(stats.chi2.cdf(gate, 2))
    expected = np.concatenate([[np.inf], stats.chi2.ppf(p, 2 * np.arange(1, 41))])
    np.testing.assert_array_equal(joint_gates(gate, 40), expected)


@pytest.mark.parametrize("p", PROBABILITIES)
@pytest.mark.parametrize("dof", [1, 2, 4.5, 29, 1e6])
def test_t_quantile_is_scipy_stats_bit_for_bit(p, dof):
    assert t_quantile(p, dof) == float(stats.t.ppf(p, dof))


def test_making_an_env_does_not_import_scipy_stats():
    code = (
        "import sys, gymnasium as gym, slam_env, agents.evaluation.statistics\n"
        "gym.make('slam_env/ActiveSLAM-v0')\n"
        "assert 'scipy.stats' not in sys.modules, 'scipy.stats was imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=600)


@pytest.mark.parametrize(("p", "dof"), sorted(QUANTILES))
def test_the_stored_quantiles_are_scipys(p, dof):
    assert QUANTILES[p, dof] == float(stats.chi2.ppf(p, dof))


def test_making_and_stepping_an_env_with_its_default_gates_imports_no_scipy_special():
    code = (
        "import sys, gymnasium as gym, slam_env\n"
        "env = gym.make('slam_env/ActiveSLAM-v0')\n"
        "env.reset(seed=0)\n"
        "env.step(env.action_space.sample())\n"
        "assert 'scipy.special' not in sys.modules, 'scipy.special was imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=600)
