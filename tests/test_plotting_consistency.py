"""The band of one chi-square sample (metrics.chi2_band, one run) behind chapter 03's NIS plots."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402


def test_band_of_one_sample_has_the_closed_form_for_two_dof():
    # chi-square with 2 dof: CDF 1 - exp(-x/2), so the quantile of p is -2 ln(1 - p)
    from slamlib.metrics import chi2_band

    lo, hi = chi2_band(2, 1, 0.95)
    assert lo == pytest.approx(-2 * np.log(1 - 0.025), rel=1e-12)
    assert hi == pytest.approx(-2 * np.log(0.025), rel=1e-12)
    lo, hi = chi2_band([2, 4, 6], 1, 0.9)
    assert lo.shape == (3,) and np.all(np.diff(lo) > 0) and np.all(np.diff(hi) > 0)


def test_band_holds_its_probability_by_monte_carlo():
    from slamlib.metrics import chi2_band

    rng = np.random.default_rng(0)
    x = rng.chisquare(3, size=200_000)
    lo, hi = chi2_band(3, 1, 0.95)
    assert np.mean((x < lo) | (x > hi)) == pytest.approx(0.05, abs=0.003)
    assert np.mean(x < lo) == pytest.approx(0.025, abs=0.002)


def test_plot_chi2_series_returns_the_fraction_outside():
    from slamlib.course.plots_ch03 import plot_chi2_series

    rng = np.random.default_rng(1)
    dof = rng.choice([2, 4, 6], size=500)
    v = rng.chisquare(dof)
    v[:10] = 1e3                    # surely above the band
    fig, ax = plt.subplots()
    frac = plot_chi2_series(ax, np.arange(500.0), v, dof, per_dof=True)
    plt.close(fig)
    from scipy.stats import chi2
    expected = np.mean((v < chi2.ppf(0.025, dof)) | (v > chi2.ppf(0.975, dof)))
    assert frac == pytest.approx(expected, abs=0)
    assert frac >= 10 / 500


def test_plot_chi2_series_rejects_bad_input():
    from slamlib.course.plots_ch03 import plot_chi2_series
    from slamlib.metrics import chi2_band

    fig, ax = plt.subplots()
    with pytest.raises(ValueError, match="t, values"):
        plot_chi2_series(ax, np.arange(3.0), np.ones(4), 2)
    with pytest.raises(ValueError, match="dof"):
        chi2_band(0)
    with pytest.raises(ValueError, match="prob"):
        chi2_band(2, 1, 1.5)
    plt.close(fig)
