"""Chapter 06's stored one-factor ablation (data/studies/ch06_linearisation.json) is what the code
computes: a sample is recomputed here and compared number for number (``make
linearisation-study`` regenerates the whole file bit for bit); and the observability check
with the initialisation link in the chain."""

from __future__ import annotations

import numpy as np
import pytest
from same_record import assert_same_record

from slamlib import runner, sim
from slamlib.course import linearisation_study as ls
from slamlib.course import studies_ch06
from slamlib.ekf import LinearisedEKFSLAM

STORED = ls.load()


def test_the_file_describes_the_study_of_the_code():
    assert STORED["seeds"] == list(ls.STUDY["seeds"])
    assert (STORED["scenario"], STORED["gate"], STORED["step"], STORED["t_end"]) == (
        ls.STUDY["scenario"], ls.STUDY["gate"], ls.STUDY["step"], ls.STUDY["t_end"])
    assert STORED["instants"] == list(ls.INSTANTS)
    assert {m: v["links"] for m, v in STORED["methods"].items()} == ls.METHODS
    methods = list(ls.METHODS) + [f"{m}_nogate" for m in ls.UNGATED]
    assert list(STORED["studies"]) == [f"{s:.2f}" for s in ls.STUDY["sigmas"]]
    T = int(round(ls.STUDY["t_end"] / ls.STUDY["step"]))
    for block in STORED["studies"].values():
        assert list(block) == methods
        for s in block.values():
            assert len(s["avg"]) == len(s["avg_heading"]) == T
            assert [r["seed"] for r in s["runs"]] == STORED["seeds"]
            # the stored averages are the means of the runs' curves: at the kept instants and
            # at the end they are the means of the runs' kept values, and their time mean is
            # the mean of the runs' time means
            t = np.arange(1, T + 1) * STORED["step"]
            at = np.searchsorted(t, STORED["instants"])
            assert np.allclose(np.asarray(s["avg"])[at],
                               np.mean([r["nees_at"] for r in s["runs"]], axis=0), rtol=1e-12)
            assert np.allclose(np.asarray(s["avg_heading"])[at],
                               np.mean([r["heading_at"] for r in s["runs"]], axis=0), rtol=1e-12)
            assert np.isclose(s["avg"][-1], np.mean([r["final_nees"] for r in s["runs"]]),
                              rtol=1e-12)
            assert np.isclose(np.mean(s["avg"]), np.mean([r["mean_nees"] for r in s["runs"]]),
                              rtol=1e-12)


@pytest.mark.parametrize("sigma, seeds, methods", [
    (0.10, (1000, 1057), ("ekf", "ekf_init_truth", "ekf_obs_first", "fej", "huang")),
    (0.14, (1031,), tuple(ls.METHODS) + ("fej_nogate", "ideal_init_nogate")),
])
def test_a_sample_of_the_stored_runs_is_recomputed_exactly(sigma, seeds, methods):
    res = ls.run_study(seeds, sigmas=(sigma,), methods=methods)[f"{sigma:.2f}"]
    stored = STORED["studies"][f"{sigma:.2f}"]
    for m in methods:
        for seed, run in zip(seeds, res[m]["runs"]):
            assert_same_record(run, stored[m]["runs"][seed - STORED["seeds"][0]], f"{m} {seed}")


def test_the_same_runs_as_the_consistency_study():
    """The ablation's EKF SLAM, FEJ and ideal filters are the consistency study's (same seeds,
    scenario, gate and grid): the same run means, to the last bit."""
    cons = studies_ch06.load_ch06_studies()["studies"]
    for sigma in ("0.10", "0.14"):
        for mine, theirs in (("ekf", "slam"), ("fej", "fej"), ("ideal", "ideal"),
                             ("ideal_init", "ideal_init")):
            a = [r["final_nees"] for r in STORED["studies"][sigma][mine]["runs"]]
            b = [r["final_nees"] for r in cons[f"arena_{sigma}"]["methods"][theirs]["runs"]]
            assert np.allclose(a, b, rtol=1e-12, atol=0), (sigma, mine)


def test_rows_and_t_eff_read_the_file():
    rows = {r["method"]: r for r in ls.ablation_rows(STORED, "0.10")}
    ekf = STORED["studies"]["0.10"]["ekf"]
    assert rows["ekf"]["final_median"] == np.median([r["final_nees"] for r in ekf["runs"]])
    assert 0.0 <= rows["fej"]["rejected"] <= 1.0 and rows["fej_nogate"]["rejected"] == 0.0
    te = ls.t_eff(ekf)
    assert 1.0 < te < 117.0
    with pytest.raises(ValueError, match="method"):
        ls.method_links("ekf_motion_first_nogate")


def test_t_eff_of_independent_instants_is_their_number():
    """Runs of T independent chi-square(3) instants: T_eff = T (closed form); runs that hold one
    value: 1; from the stored moments as from the whole array."""
    from slamlib.metrics import effective_instants

    rng = np.random.default_rng(0)
    X = rng.chisquare(3, (4000, 8))
    summary = {"avg": X.mean(axis=0).tolist(),
               "runs": [{"mean_nees": float(x.mean()), "mean_sq_nees": float(np.mean(x ** 2))}
                        for x in X]}
    assert ls.t_eff(summary) == pytest.approx(8.0, rel=0.05)
    assert ls.t_eff(summary) == pytest.approx(effective_instants(X), rel=1e-9)
    held = np.repeat(rng.chisquare(3, (500, 1)), 6, axis=1) * rng.uniform(0.5, 2.0, (500, 1))
    assert effective_instants(held) == pytest.approx(1.0, rel=1e-9)
    with pytest.raises(ValueError, match="nees"):
        effective_instants(np.ones(5))


@pytest.fixture(scope="module")
def run10():
    return sim.scenario("arena_loop", seed=1000, sigma_wheel=0.10)


def _obs(run, method):
    truth = {"truth": runner.truth_function(run), "landmarks": run.world().landmarks(),
             "t0": float(run.enc_t[0])}
    return studies_ch06.observability(LinearisedEKFSLAM, run, t_end=15.0,
                                      options={**ls.METHODS[method], **truth})


def test_observability_with_and_without_the_initialisation_link(run10):
    """The true system cannot observe a translation or a rotation of everything: FEJ's
    linearised system keeps all three (landmarks as states), EKF SLAM's loses the rotation;
    with the initialisation in the chain the ideal filter keeps it only when its J1, J2 are at
    the truth too."""
    ekf, fej = _obs(run10, "ekf"), _obs(run10, "fej")
    assert ekf.null_dimension() == 2 and fej.null_dimension() == 3
    assert ekf.rotation.max() > 1e-3 and fej.rotation.max() < 1e-12
    assert max(ekf.translation.max(), fej.translation.max()) < 1e-12
    ideal, ideal_init = _obs(run10, "ideal"), _obs(run10, "ideal_init")
    assert ideal.rotation_init.max() > 1e-3 and ideal_init.rotation_init.max() < 1e-12
    assert ekf.rotation_init.max() > 1e-3


def test_the_numbers_do_not_depend_on_the_number_of_workers():
    one = ls.run_study((1044, 1071), workers=1, sigmas=(0.14,), methods=("ekf", "ekf_obs_first"))
    two = ls.run_study((1044, 1071), workers=2, sigmas=(0.14,), methods=("ekf", "ekf_obs_first"))
    assert one == two
