"""Chapter 06's stored gate study (data/studies/ch06_gate.json) and robust_summary.

A sample of seeds is recomputed and compared number for number; the gate study's
end-of-run NEES and loop closures agree with the independent consistency study
(data/studies/ch06_consistency.json, another code path: studies.monte_carlo);
the gate's counts are checked against the reports of one run recounted here."""

from __future__ import annotations

import numpy as np
import pytest
from same_record import assert_same_record

from slamlib import runner, sim
from slamlib.course import studies_ch06

GATE = studies_ch06.load_gate_study()
STORED = studies_ch06.load_ch06_studies()


def test_the_file_describes_the_study_of_the_code():
    assert GATE["seeds"] == list(studies_ch06.CH06_SEEDS)
    assert GATE["study"]["methods"] == list(studies_ch06.GATE_METHODS)
    assert tuple(GATE["study"]["sigmas"]) == studies_ch06.GATE_STUDY["sigmas"]
    for sigma in studies_ch06.GATE_STUDY["sigmas"]:
        runs = GATE["runs"][f"{sigma:.2f}"]
        assert [r["seed"] for r in runs] == list(studies_ch06.CH06_SEEDS)
        for r in runs:
            for m in studies_ch06.GATE_METHODS:
                c = r[m]
                assert 0 <= c["rejected"] <= c["gated"]
                assert c["rejected_low"] <= c["gated_low"] <= c["gated"]
                assert c["rejected_before"] <= c["gated_before"] <= c["gated"]


@pytest.mark.parametrize("sigma, seed", [(0.10, 1017), (0.14, 1088)])
def test_a_sample_of_seeds_is_recomputed_exactly(sigma, seed):
    g = studies_ch06.GATE_STUDY
    mine = studies_ch06.gate_readings((g["scenario"], seed, sigma, g["gate"], g["t_end"],
                                       studies_ch06.GATE_METHODS))
    assert_same_record(mine, GATE["runs"][f"{sigma:.2f}"][seed - studies_ch06.CH06_SEEDS[0]],
                       f"{sigma} {seed}")


@pytest.mark.parametrize("sigma", (0.02, 0.10, 0.14))
def test_it_agrees_with_the_consistency_study_run_by_run(sigma):
    stored = STORED["studies"][f"arena_{sigma:.2f}"]["methods"]
    # the consistency study's grid ends at its shortest run (58.5 s at sigma 0.10 and 0.14,
    # 59.5 s at 0.02); the gate study's at 58.5 s: the NEES are compared where they agree
    same_grid = stored["slam"]["t"][-1] == studies_ch06.GATE_STUDY["t_end"]
    assert same_grid == (sigma != 0.02)
    for m in ("slam", "fej", "ideal"):
        for mine, theirs in zip(GATE["runs"][f"{sigma:.2f}"], stored[m]["runs"]):
            assert mine["seed"] == theirs["seed"]
            assert mine[m]["closure_status"] == theirs["closure_status"]
            assert mine[m]["closed"] == theirs["closed"]
            if same_grid:
                assert mine[m]["final_nees"] == pytest.approx(theirs["final_nees"], rel=1e-9)
                assert mine[m]["mean_nees"] == pytest.approx(theirs["mean_nees"], rel=1e-9)


def test_the_counts_are_the_reports_recounted():
    run = sim.scenario("arena_loop", seed=1003, sigma_wheel=0.10)
    tr = runner.slam(run)
    gated = rejected = 0
    for _, rep in tr.reports:
        for status, d2 in zip(rep.status, rep.d2):
            if status in ("accepted", "rejected"):
                assert np.isfinite(d2)
                gated += 1
                rejected += status == "rejected"
    g = studies_ch06.GATE_STUDY
    mine = studies_ch06.gate_readings((g["scenario"], 1003, 0.10, g["gate"], g["t_end"],
                                       ("slam",)))["slam"]
    assert (mine["gated"], mine["rejected"]) == (gated, rejected)
    assert mine["gated"] > 300 and mine["rejected"] > 0


def test_robust_summary_names_the_run_that_carries_a_mean():
    v = np.r_[np.full(99, 3.0) + np.linspace(-0.5, 0.5, 99), 130.0]
    r = studies_ch06.robust_summary(v, np.arange(1000, 1100))
    assert (r.top_seed, r.top_value) == (1099, 130.0)
    assert r.mean == pytest.approx(v.mean()) and r.median == pytest.approx(3.0, abs=0.01)
    assert r.mean_without_top == pytest.approx(3.0)
    assert r.dominated
    calm = studies_ch06.robust_summary(np.random.default_rng(0).chisquare(3, 100),
                                       np.arange(100))
    assert not calm.dominated
    with pytest.raises(ValueError, match="seeds"):
        studies_ch06.robust_summary(v, np.arange(5))


def test_gate_rates_pool_the_runs():
    def run(g, r, gl, rl, gb, rb, d2, status):
        return {"slam": {"gated": g, "rejected": r, "gated_low": gl, "rejected_low": rl,
                         "gated_before": gb, "rejected_before": rb, "d2_sum": d2,
                         "closure_status": status}}
    runs = [run(100, 10, 50, 1, 80, 2, 300.0, "rejected"), run(300, 10, 250, 9, 200, 8, 500.0,
                                                               "accepted")]
    g = studies_ch06.gate_rates(runs, "slam")
    assert g["per_run"] == 200 and g["rejected"] == pytest.approx(20 / 400)
    assert g["mean_d2"] == pytest.approx(2.0) and g["low"] == pytest.approx(300 / 400)
    assert g["rejected_low"] == pytest.approx(10 / 300)
    assert g["rejected_before"] == pytest.approx(10 / 280)
    assert g["rejected_after"] == pytest.approx(10 / 120)
    assert g["first_rejected"] == 1


def test_band_shares_against_the_chi_square_quantiles():
    from scipy.stats import chi2

    lo, hi = chi2.ppf(0.025, 300) / 100, chi2.ppf(0.975, 300) / 100      # 2.54, 3.50
    avg = np.array([2.0, lo + 0.01, 3.0, hi - 0.01, 3.6, 4.0, 5.0, 3.2])
    s = studies_ch06.band_shares(avg, 100)
    assert s["band"] == pytest.approx((lo, hi), rel=1e-9)
    assert (s["below"], s["inside"], s["above"]) == pytest.approx((1 / 8, 4 / 8, 3 / 8))
    # raised by 0.35: 3.2 and hi - 0.01 leave the band, 2.0 stays below, lo + 0.01 and 3.0 stay in
    r = studies_ch06.band_shares(avg, 100, shift=0.35)
    assert (r["below"], r["inside"], r["above"]) == pytest.approx((1 / 8, 2 / 8, 5 / 8))
    # the heading's band (1 degree of freedom) is another band
    h = studies_ch06.band_shares(np.array([1.0, 1.4]), 100, dof=1)
    assert h["band"][1] == pytest.approx(chi2.ppf(0.975, 100) / 100)
    assert h["above"] == pytest.approx(0.5)
    with pytest.raises(ValueError, match="avg"):
        studies_ch06.band_shares(np.array([np.nan]), 100)
    with pytest.raises(ValueError, match="n_runs"):
        studies_ch06.band_shares(avg, 0)
