"""The NEES consistency band: χ² quantiles for the number of episodes averaged, the share
of steps inside it, and its plot."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam_env.belief.metrics import averaged_nees, nees_band, nees_bands, share_in_nees_band
from slam_env.render.plots import plot_consistency

# χ²(k) quantiles at 0.025 and 0.975 (published tables, 6 decimals).
CHI2_95 = {
    2: (0.050636, 7.377759),
    3: (0.215795, 9.348404),
    4: (0.484419, 11.143287),
    6: (1.237344, 14.449375),
    10: (3.246973, 20.483177),
    15: (6.262138, 27.488393),
    40: (24.433039, 59.341707),
    60: (40.481748, 83.297675),
    100: (74.221927, 129.561197),
    150: (117.984515, 185.800447),
}


@pytest.mark.parametrize("runs", [1, 2, 5, 20, 50])
@pytest.mark.parametrize("dof", [2, 3])
def test_band_is_the_chi2_quantile_for_the_number_of_episodes(runs, dof):
    # The sum of `runs` NEES values of a consistent filter is χ²(runs · dof).
    lower, upper = nees_band(dof, runs, 0.95)
    low_sum, high_sum = CHI2_95[runs * dof]
    assert lower == pytest.approx(low_sum / runs, abs=2e-6)
    assert upper == pytest.approx(high_sum / runs, abs=2e-6)


def test_bands_per_step_follow_the_episodes_counted():
    lower, upper = nees_bands(3, np.array([4, 4, 2, 0, 1]))
    for k, runs in enumerate([4, 4, 2]):
        assert (lower[k], upper[k]) == nees_band(3, runs)
    assert math.isnan(lower[3]) and math.isnan(upper[3])
    assert (lower[4], upper[4]) == nees_band(3, 1)
    assert upper[4] - lower[4] > upper[0] - lower[0]  # fewer episodes, a wider band


def test_averaged_nees_over_ragged_episodes():
    mean, runs = averaged_nees([[0.0, 2.0, math.inf, 4.0], [0.0, 4.0, 6.0]])
    np.testing.assert_array_equal(runs, [2, 2, 1, 1])  # inf is not averaged
    np.testing.assert_allclose(mean, [0.0, 3.0, 6.0, 4.0])
    mean, runs = averaged_nees([[math.nan, 1.0]])
    assert math.isnan(mean[0]) and runs[0] == 0


def test_share_in_band_of_a_consistent_and_an_overconfident_filter():
    rng = np.random.default_rng(0)
    consistent = [np.concatenate([[0.0], rng.chisquare(3, 400)]) for _ in range(10)]
    share = share_in_nees_band(consistent)
    assert 0.92 < share < 0.98  # 0.95 expected; σ ≈ 0.011 over 400 steps
    overconfident = [10.0 * e for e in consistent]
    assert share_in_nees_band(overconfident) < 0.05
    # The reset (step 0, NEES 0) is left out; a constant NEES of 3 is always inside.
    assert share_in_nees_band([np.r_[0.0, np.full(50, 3.0)]] * 4) == 1.0
    assert share_in_nees_band([np.r_[0.0, np.full(50, 3.0)]], first_step=0) == 50 / 51
    assert math.isnan(share_in_nees_band([[0.0]]))
    # Step 1 is the first counted: out of band there, inside at step 2.
    assert share_in_nees_band([[0.0, 100.0, 3.0]]) == 0.5


def _band_patch(ax):
    (band,) = [c for c in ax.collections if c.get_label().startswith("95% χ² band")]
    return band


def test_consistency_plot_shades_the_band_for_the_episodes(tmp_path):
    rng = np.random.default_rng(1)
    episodes = [np.r_[0.0, rng.chisquare(3, 60)] for _ in range(8)]
    rmse = [np.r_[np.nan, np.linspace(0.1, 0.2, 60)] for _ in range(8)]
    path = tmp_path / "consistency.png"
    fig = plot_consistency({"a": {"pose_nees": episodes, "map_rmse": rmse}}, path)
    assert path.stat().st_size > 10_000
    nees_ax, rmse_ax = fig.axes
    band = _band_patch(nees_ax)
    assert "8 episodes" in band.get_label()
    ys = band.get_paths()[0].vertices[:, 1]
    lower, upper = nees_band(3, 8)
    assert ys.min() == pytest.approx(lower) and ys.max() == pytest.approx(upper)
    (mean_line,) = [ln for ln in nees_ax.lines if ln.get_label() == "a"]
    np.testing.assert_allclose(mean_line.get_ydata(), np.mean(episodes, axis=0)[1:])
    np.testing.assert_array_equal(mean_line.get_xdata(), np.arange(1, 61))  # no reset
    assert nees_ax.get_yscale() == "log"
    assert "[m]" in rmse_ax.get_ylabel() and "[steps]" in rmse_ax.get_xlabel()


def test_consistency_plot_with_uneven_episodes_draws_a_band_per_agent():
    series = {
        "a": {"pose_nees": [np.full(30, 3.0)] * 4, "map_rmse": [np.full(30, 0.1)] * 4},
        "b": {"pose_nees": [np.full(30, 3.0)] * 2, "map_rmse": [np.full(30, 0.1)] * 2},
    }
    fig = plot_consistency(series)
    dotted = [ln for ln in fig.axes[0].lines if ln.get_linestyle() == ":" and len(ln.get_ydata())]
    bounds = sorted({round(float(ln.get_ydata()[0]), 9) for ln in dotted})
    expected = sorted(round(v, 9) for runs in (4, 2) for v in nees_band(3, runs))
    assert bounds == expected


def test_share_in_band_at_its_edges():
    lower, upper = nees_band(3, 1)
    # The band is closed: a mean on either bound is inside.
    assert share_in_nees_band([[0.0, lower, upper]]) == 1.0
    # A step no episode reached with a finite NEES is not counted.
    assert share_in_nees_band([[0.0, math.inf, 3.0, upper * 2]]) == 0.5
    mean, runs = averaged_nees([])
    assert mean.shape == runs.shape == (0,)
