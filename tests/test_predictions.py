"""slamlib.course.predictions.check_prediction: commit first, then measure, then explain."""

from slamlib.course.predictions import check_prediction


def measured(value, log):
    def measure():
        log.append("measured")
        return value, "3 seeded runs"
    return measure


def test_a_stub_is_not_written_yet_and_measures_nothing(capsys):
    log = []
    assert not check_prediction(None, measured(1.0, log), (0.5, 2.0), "because.")
    out = capsys.readouterr().out
    assert "not written yet" in out and log == [] and "1" not in out.split("(")[0]


def test_a_number_inside_the_range_is_right_and_outside_is_explained(capsys):
    log = []
    assert check_prediction(1.5, measured(1.2, log), (1.0, 2.0), "Sigma scales with sqrt(Q).",
                            unit="deg")
    out = capsys.readouterr().out
    assert "Right" in out and "1.2 deg" in out and "sqrt(Q)" in out and "3 seeded runs" in out
    assert not check_prediction(3.0, measured(1.2, log), (1.0, 2.0), "Sigma scales with sqrt(Q).")
    out = capsys.readouterr().out
    assert "Not quite" in out and "1 to 2" in out and "sqrt(Q)" in out
    assert log == ["measured", "measured"]


def test_choices_are_checked_and_a_wrong_type_is_named(capsys):
    log = []
    opts = ("shrinks", "stays", "grows")
    assert check_prediction("stays", measured("stays", log), {"stays"}, "No new information.",
                            choices=opts)
    assert "Right" in capsys.readouterr().out
    assert not check_prediction("grows", measured("stays", log), {"stays"}, "x", choices=opts)
    assert "Not quite" in capsys.readouterr().out
    assert not check_prediction("maybe", measured("stays", log), {"stays"}, "x", choices=opts)
    assert "expected one of 'shrinks', 'stays', 'grows'" in capsys.readouterr().out
    assert not check_prediction("12", measured(1.0, log), (0, 2), "x")
    assert "expected a number" in capsys.readouterr().out
    assert log == ["measured", "measured"]


# --------------------------------------------------------------------------- the chapters' own
def test_chapter_03_nees_prediction_reads_the_stored_study(capsys):
    """The measured value is the mean, over the stored runs, of each run's NEES sum / count
    of the filter that assumes twice the camera's noise: recomputed here from the JSON file."""
    import json

    import numpy as np

    from slamlib.course.checkers_ch03 import check_nees_prediction
    from slamlib.course.evidence import EVIDENCE_DIR

    assert not check_nees_prediction(None)
    out = capsys.readouterr().out
    assert "not written yet" in out and "2.9" not in out
    runs = json.loads((EVIDENCE_DIR / "arena_localization.json").read_text())["runs"]
    want = np.mean([r["assumed/2"]["nees_sum"] / r["assumed/2"]["n"] for r in runs])
    assert check_nees_prediction(float(want))
    out = capsys.readouterr().out
    assert f"measured {want:.4g}" in out and "Right" in out
    assert not check_nees_prediction(3.0)
    assert "Not quite: a justified prediction is 0.75 to 2.9" in capsys.readouterr().out


def test_chapter_04_second_reading_kept_leaves_the_heading_sigma(capsys):
    """With the cross-covariances, the second reading from the same pose changes no robot
    variance: checked with a dense augmentation G_x P G_x^T + G_z R G_z^T and a plain Kalman
    update written here; dropped, the heading variance shrinks."""
    import numpy as np

    from slamlib.course.checkers_ch04 import check_second_reading_prediction, heading_sigma_ratio
    from slamlib.models import inverse_observation_jacobians, inverse_observe, observation_jacobians

    assert not check_second_reading_prediction(None)
    assert "stays the same" not in capsys.readouterr().out.split("(")[0]
    rng = np.random.default_rng(5)
    R = np.diag([0.05 ** 2, np.radians(2.0) ** 2])
    for _ in range(5):
        x = np.r_[rng.uniform(-2, 2, 2), rng.uniform(-3, 3), rng.uniform(-3, 3, 4)]
        M = rng.normal(0, 0.05, (7, 7))
        P = M @ M.T + 1e-3 * np.eye(7)
        z = np.array([rng.uniform(0.5, 4.0), rng.uniform(-0.5, 0.5)])
        J1, J2 = inverse_observation_jacobians(x[:3], z)
        Gx = np.vstack([np.eye(7), np.hstack([J1, np.zeros((2, 4))])])
        Gz = np.vstack([np.zeros((7, 2)), J2])
        Pa = Gx @ P @ Gx.T + Gz @ R @ Gz.T
        m = inverse_observe(x[:3], z)
        Hp, Hl = observation_jacobians(x[:3], m)
        H = np.hstack([Hp, np.zeros((2, 4)), Hl])
        for drop in (False, True):
            Pd = Pa.copy()
            if drop:
                Pd[7:, :7] = 0.0
                Pd[:7, 7:] = 0.0
            K = Pd @ H.T @ np.linalg.inv(H @ Pd @ H.T + R)
            P1 = Pd - K @ H @ Pd
            want = np.sqrt(P1[2, 2] / Pd[2, 2])
            got = heading_sigma_ratio(x, P, z, R, drop=drop)
            assert np.isclose(got, want, rtol=1e-9, atol=1e-12)
            assert (want < 0.999) if drop else np.isclose(want, 1.0, atol=1e-9)
    assert check_second_reading_prediction("stays the same")
    assert not check_second_reading_prediction("shrinks a little")
