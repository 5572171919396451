"""slamlib.metrics against closed forms and Monte-Carlo."""

import math

import numpy as np
import pytest
from scipy.stats import chi2

from slamlib.metrics import (
    ate,
    average_nees,
    chi2_band,
    chi2_quantile,
    mahalanobis2,
    nees,
    nis,
    pose_error,
)


def random_spd(rng, d):
    A = rng.normal(size=(d, d))
    return A @ A.T + d * np.eye(d) * 0.1


def test_pose_error_wraps_the_heading():
    e = pose_error([1.0, 2.0, math.pi - 0.01], [0.5, 2.5, -math.pi + 0.01])
    np.testing.assert_allclose(e, [0.5, -0.5, -0.02], atol=1e-12)
    traj = pose_error(np.zeros((4, 3)), np.tile([0.0, 0.0, 3 * math.pi / 2], (4, 1)))
    np.testing.assert_allclose(traj[:, 2], math.pi / 2)
    with pytest.raises(ValueError, match="estimate, truth"):
        pose_error(np.zeros(3), np.zeros(2))
    with pytest.raises(ValueError, match="truth"):
        pose_error(np.zeros(3), [0, np.nan, 0])


def test_mahalanobis_closed_forms():
    assert nees([3.0, 4.0], np.eye(2)) == pytest.approx(25.0)
    assert nees([3.0, 4.0], np.diag([9.0, 16.0])) == pytest.approx(2.0)
    assert nis([1.0, 1.0], np.diag([0.5, 2.0])) == pytest.approx(2.5)
    # correlated: d^T C^-1 d by the explicit inverse
    rng = np.random.default_rng(0)
    C = random_spd(rng, 4)
    d = rng.normal(size=4)
    assert mahalanobis2(d, C) == pytest.approx(d @ np.linalg.inv(C) @ d, rel=1e-12)
    # batches: (N, d) against one (d, d), and against (N, d, d)
    D = rng.normal(size=(5, 4))
    Cs = np.stack([random_spd(rng, 4) for _ in range(5)])
    np.testing.assert_allclose(nees(D, C), [x @ np.linalg.solve(C, x) for x in D], rtol=1e-12)
    np.testing.assert_allclose(nees(D, Cs), [x @ np.linalg.solve(c, x) for x, c in zip(D, Cs)],
                               rtol=1e-12)


@pytest.mark.parametrize("args,word", [
    (([1.0, 2.0], np.eye(3)), "P"),
    (([1.0, 2.0], np.diag([1.0, -1.0])), "positive-definite"),
    (([1.0, np.nan], np.eye(2)), "error"),
    (([1.0, 2.0], np.full((2, 2), np.inf)), "P"),
])
def test_nees_bad_input_names_the_argument(args, word):
    with pytest.raises(ValueError, match=word):
        nees(*args)


def test_chi2_band_closed_forms():
    # two degrees of freedom: the CDF is 1 - exp(-x/2)
    lo, hi = chi2_band(2, 1, 0.95)
    assert lo == pytest.approx(-2 * math.log(1 - 0.025), rel=1e-12)
    assert hi == pytest.approx(-2 * math.log(0.025), rel=1e-12)
    assert chi2_quantile(0.95, 2) == pytest.approx(-2 * math.log(0.05), rel=1e-12)
    lo, hi = chi2_band(3, 50, 0.95)
    assert lo == pytest.approx(chi2.ppf(0.025, 150) / 50)
    assert hi == pytest.approx(chi2.ppf(0.975, 150) / 50)
    assert lo < 3 < hi
    # the band narrows like 1/sqrt(N) around the dof
    w20 = np.diff(chi2_band(3, 20))[0]
    w80 = np.diff(chi2_band(3, 80))[0]
    assert w80 == pytest.approx(w20 / 2, rel=0.05)
    for bad in ({"n_runs": 0}, {"n_runs": 2.5}, {"prob": 1.0}, {"dof": -1}):
        with pytest.raises(ValueError):
            chi2_band(**({"dof": 3} | bad))


def test_average_nees_of_correct_covariances_stays_in_the_band_monte_carlo():
    """Errors drawn from the covariances themselves: a 'consistent filter'."""
    rng = np.random.default_rng(42)
    N, T, d = 30, 200, 3
    covs = np.stack([random_spd(rng, d) for _ in range(T)])
    L = np.linalg.cholesky(covs)
    errors = np.einsum("tij,ntj->nti", L, rng.normal(size=(N, T, d)))
    avg = average_nees(errors, np.broadcast_to(covs, (N, T, d, d)))
    lo, hi = chi2_band(d, N, 0.95)
    inside = np.mean((avg > lo) & (avg < hi))
    assert 0.90 < inside <= 1.0          # 95 % expected; binomial spread over 200 steps
    assert np.mean(avg) == pytest.approx(d, rel=0.03)
    # too small covariances (an overconfident filter): far outside
    over = average_nees(errors, np.broadcast_to(covs / 4, (N, T, d, d)))
    assert np.mean(over > hi) > 0.99


def test_nis_is_chi_square_monte_carlo():
    rng = np.random.default_rng(7)
    S = random_spd(rng, 2)
    y = rng.multivariate_normal(np.zeros(2), S, size=20000)
    v = nis(y, S)
    assert np.mean(v) == pytest.approx(2.0, rel=0.03)
    assert np.mean(v < chi2_quantile(0.95, 2)) == pytest.approx(0.95, abs=0.005)


def test_ate_closed_forms():
    T = 10
    truth = np.column_stack([np.arange(T), np.zeros(T), np.full(T, math.pi - 0.05)])
    est = truth + [0.3, 0.4, 0.1]               # heading crosses the seam: error 0.1, not 2pi-0.1
    a = ate(est, truth)
    assert a.position == pytest.approx(0.5)
    assert a.heading == pytest.approx(0.1)
    half = truth.copy()
    half[::2, 0] += 1.0                          # error 1 on half the poses
    assert ate(half, truth).position == pytest.approx(math.sqrt(0.5))
    with pytest.raises(ValueError, match="trajectory"):
        ate(np.zeros(3), np.zeros(3))


def test_kl_gaussian_closed_forms():
    from slamlib.metrics import kl_gaussian

    # 1-D: ln(s1/s0) + (s0^2 + (m0 - m1)^2) / (2 s1^2) - 1/2
    for m0, s0, m1, s1 in [(0.0, 1.0, 0.0, 1.0), (0.3, 0.5, -1.2, 2.0), (2.0, 3.0, 2.5, 0.7)]:
        want = np.log(s1 / s0) + (s0**2 + (m0 - m1) ** 2) / (2 * s1**2) - 0.5
        got = kl_gaussian([m0], [[s0**2]], [m1], [[s1**2]])
        assert got == pytest.approx(want, rel=1e-12, abs=1e-15)
    # independent coordinates: the divergences add up
    a = kl_gaussian([0.3], [[0.25]], [-1.2], [[4.0]])
    b = kl_gaussian([2.0], [[9.0]], [2.5], [[0.49]])
    assert kl_gaussian([0.3, 2.0], np.diag([0.25, 9.0]), [-1.2, 2.5], np.diag([4.0, 0.49])) \
        == pytest.approx(a + b, rel=1e-12)
    # invariant under a common linear change of coordinates, zero for equal Gaussians
    rng = np.random.default_rng(0)
    T = rng.normal(size=(2, 2)) + 2 * np.eye(2)
    m0, m1 = np.array([0.3, 2.0]), np.array([-1.2, 2.5])
    C0, C1 = np.diag([0.25, 9.0]), np.diag([4.0, 0.49])
    assert kl_gaussian(T @ m0, T @ C0 @ T.T, T @ m1, T @ C1 @ T.T) == pytest.approx(a + b, rel=1e-9)
    assert kl_gaussian(m0, C0, m0, C0) == pytest.approx(0.0, abs=1e-14)


def test_kl_gaussian_bad_input_names_the_argument():
    from slamlib.metrics import kl_gaussian

    with pytest.raises(ValueError, match="C1"):
        kl_gaussian([0, 0], np.eye(2), [0, 0], np.diag([1.0, -1.0]))
    with pytest.raises(ValueError, match="m0, m1"):
        kl_gaussian([0, 0], np.eye(2), [0, 0, 0], np.eye(3))
    with pytest.raises(ValueError, match="C0"):
        kl_gaussian([0, 0], np.eye(3), [0, 0], np.eye(2))
