"""metrics.mean_interval: the seeded percentile bootstrap of a mean, checked against the
t-interval on normal data and by its coverage over many Monte-Carlo samples."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from slamlib.metrics import mean_interval


def test_mean_and_median_are_the_sample_s():
    v = np.array([1.0, 2.0, 3.0, 10.0])
    r = mean_interval(v, n_boot=200)
    assert r.mean == pytest.approx(4.0) and r.median == pytest.approx(2.5)
    assert r.lo < r.mean < r.hi


def test_close_to_the_t_interval_on_normal_data():
    v = np.random.default_rng(7).normal(3.0, 2.0, size=400)
    r = mean_interval(v, level=0.95, n_boot=20000, seed=1)
    half = stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size)
    # the bootstrap's standard error uses 1/n, not 1/(n-1), and has Monte-Carlo noise
    # of about 1 % at 20 000 resamples: 5 % of the half-width is a tight tolerance
    assert r.lo == pytest.approx(v.mean() - half, abs=0.05 * half)
    assert r.hi == pytest.approx(v.mean() + half, abs=0.05 * half)


def test_coverage_of_the_true_mean_by_monte_carlo():
    rng = np.random.default_rng(11)
    covered = 0
    trials = 400
    for k in range(trials):
        v = rng.normal(1.0, 1.0, size=60)
        r = mean_interval(v, level=0.9, n_boot=1000, seed=k)
        covered += r.lo <= 1.0 <= r.hi
    # a 90 % interval: Binomial(400, 0.9) has standard deviation 6; the percentile bootstrap
    # under-covers slightly at n = 60 (about 89 %). 0.84-0.95 fails for a wrong level (0.95 or
    # 0.8 would give about 94-95 % or 79 %) or a standard error off by sqrt(n).
    assert 0.84 <= covered / trials <= 0.95


def test_skewed_data_give_an_interval_wider_towards_the_tail():
    v = np.random.default_rng(3).chisquare(3, size=100) ** 2
    r = mean_interval(v)
    assert r.median < r.mean
    assert r.hi - r.mean > r.mean - r.lo


def test_same_seed_same_numbers_other_seed_other_numbers():
    v = np.random.default_rng(5).exponential(size=50)
    assert mean_interval(v, seed=3) == mean_interval(v, seed=3)
    assert mean_interval(v, seed=3) != mean_interval(v, seed=4)


@pytest.mark.parametrize("kwargs, word", [({"values": [1.0]}, "values"),
                                          ({"values": [[1.0, 2.0]]}, "values"),
                                          ({"values": [1.0, np.nan]}, "values"),
                                          ({"values": [1.0, 2.0], "level": 1.0}, "level"),
                                          ({"values": [1.0, 2.0], "n_boot": 10}, "n_boot"),
                                          ({"values": [1.0, 2.0], "n_boot": 1e3}, "n_boot")])
def test_bad_input_names_the_argument(kwargs, word):
    with pytest.raises(ValueError, match=word):
        mean_interval(**kwargs)


def test_mean_interval_covers_the_mean_of_a_skewed_law():
    """Coverage of the true mean of an exponential law (mean 1), 300 samples of 60."""
    rng = np.random.default_rng(11)
    hits = [r.lo <= 1.0 <= r.hi for r in
            (mean_interval(rng.exponential(1.0, 60), n_boot=1000, seed=k) for k in range(300))]
    assert 0.89 <= np.mean(hits) <= 0.98


def test_seed_spread_names_the_runs_that_carry_the_mean():
    from slamlib.metrics import seed_spread

    v = np.array([1.0, 2.0, 30.0, 3.0, 2.0])
    s = seed_spread(v, [10, 11, 12, 13, 14])
    assert s.top == ((12, 30.0), (13, 3.0), (11, 2.0)) and s.top_seed == 12
    assert s.mean == pytest.approx(7.6) and s.median == 2.0
    assert s.mean_without_top == pytest.approx(2.0) and s.dominated
    assert s.se == pytest.approx(np.std(v, ddof=1) / np.sqrt(5))
    assert s.interval == mean_interval(v)[2:]
    assert not seed_spread(np.random.default_rng(0).normal(5, 1, 100), range(100)).dominated
    with pytest.raises(ValueError, match="seeds"):
        seed_spread(v, [1, 2])


def test_both_intervals_under_cover_the_mean_of_a_heavy_tail_on_the_upper_side():
    """100 lognormal(0, 1.5) values (a mean a few runs can carry): the true mean exp(1.125)
    lies above a nominal 95 % interval far more often than 2.5 %, for the percentile and for
    the BCa interval (what chapters 06 and 11 say beside their intervals)."""
    mu = np.exp(1.5 ** 2 / 2)
    above = {"percentile": 0, "BCa": 0}
    for k in range(200):
        v = np.random.default_rng(100 + k).lognormal(0.0, 1.5, 100)
        for method in above:
            r = mean_interval(v, n_boot=1000, seed=k, method=method)
            above[method] += mu > r.hi
            assert r.lo < r.mean < r.hi
    assert above["percentile"] / 200 > 0.08 and above["BCa"] / 200 > 0.06
    with pytest.raises(ValueError, match="method"):
        mean_interval([1.0, 2.0], method="bca")


def test_bca_interval_of_a_normal_sample_is_the_t_interval():
    from scipy.stats import t

    v = np.random.default_rng(5).normal(10.0, 2.0, 400)
    r = mean_interval(v, n_boot=20000, seed=1, method="BCa")
    half = t.ppf(0.975, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size)
    assert r.lo == pytest.approx(v.mean() - half, abs=0.02)
    assert r.hi == pytest.approx(v.mean() + half, abs=0.02)


def test_consistent_runs_are_means_of_t_eff_chi_square_draws():
    from scipy.stats import chi2, ks_2samp

    from slamlib.metrics import consistent_runs

    x = consistent_runs(50, dof=3, t_eff=2.5, n_sets=400, seed=1).ravel()
    assert x.mean() == pytest.approx(3.0, rel=0.01)
    assert x.var() == pytest.approx(2 * 3 / 2.5, rel=0.03)        # 2 dof / t_eff
    # an integer t_eff: the mean of 4 independent chi-square(3) draws, by simulation
    y = consistent_runs(20000, dof=3, t_eff=4.0, n_sets=1, seed=2).ravel()
    direct = chi2.rvs(3, size=(20000, 4), random_state=np.random.default_rng(3)).mean(axis=1)
    assert ks_2samp(y, direct).pvalue > 0.01
    assert np.array_equal(consistent_runs(5, seed=7), consistent_runs(5, seed=7))
    for kwargs, word in (({"n_runs": 0}, "n_runs"), ({"n_runs": 5, "t_eff": 0.0}, "t_eff"),
                         ({"n_runs": 5, "dof": 1.5}, "dof")):
        with pytest.raises(ValueError, match=word):
            consistent_runs(**kwargs)


def test_consistent_reference_of_the_mean_is_the_chi_square_band():
    """The mean of N run averages, each worth t_eff instants, is chi-square(d N t_eff) / (N
    t_eff): the simulated reference of ``np.mean`` matches that band (closed form)."""
    from slamlib.metrics import chi2_band, consistent_reference

    ref = consistent_reference(np.mean, 100, dof=3, t_eff=2.5, prob=0.9, n_sets=20000)
    lo, hi = chi2_band(3, 250, 0.9)
    assert ref.lo == pytest.approx(lo, abs=0.01) and ref.hi == pytest.approx(hi, abs=0.01)
    assert ref.median == pytest.approx(3.0, abs=0.01)
    trimmed = consistent_reference(lambda v: np.sort(v)[:-5].mean(), 100, t_eff=2.5)
    assert trimmed.hi < 3.1 and trimmed.median < 2.85         # trimming lowers a consistent mean
    with pytest.raises(ValueError, match="statistic"):
        consistent_reference(None, 10)
