"""Chapter 06's stored studies (data/studies/ch06_consistency.json) are what the code computes:
a sample of them is recomputed here and compared number for number (``make studies``
regenerates the whole file bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest
from same_record import assert_same_record

from slamlib import studies
from slamlib.course import studies_ch06

STORED = studies_ch06.load_ch06_studies()


def test_the_file_describes_the_studies_of_the_code():
    assert STORED["seeds"] == list(studies_ch06.CH06_SEEDS)
    assert set(STORED["studies"]) == set(studies_ch06.CH06_STUDIES)
    for key, (scenario, sigma, q, gate, methods) in studies_ch06.CH06_STUDIES.items():
        st = STORED["studies"][key]
        assert (st["scenario"], st["sigma_wheel"], st["Q"], st["gate"]) == (scenario, sigma, q,
                                                                             gate)
        assert tuple(st["methods"]) == methods
        for m in methods:
            s = st["methods"][m]
            assert len(s["runs"]) == len(studies_ch06.CH06_SEEDS)
            assert len(s["t"]) == len(s["avg"]) == len(s["avg_heading"])
            # the stored average is the mean of the runs' curves: its time mean is the mean
            # of the runs' time means
            means = [r["mean_nees"] for r in s["runs"]]
            assert np.isclose(np.mean(s["avg"]), np.mean(means), rtol=1e-12)


@pytest.mark.parametrize("key, seeds", [("arena_0.14_nominalQ", (1000, 1061)),
                                        ("arena_0.10", (1017,)),
                                        ("laps_0.10", (1042,))])
def test_a_sample_of_the_stored_runs_is_recomputed_exactly(key, seeds):
    stored = STORED["studies"][key]["methods"]
    t_end = stored["slam"]["t"][-1]
    scenario, sigma, q, gate, methods = studies_ch06.CH06_STUDIES[key]
    Q = studies_ch06.nominal_Q(scenario) if q == "nominal" else None
    res = studies.monte_carlo(scenario, methods, seeds, sigma_wheel=sigma, gate=gate, Q=Q,
                              t_end=t_end)
    for m in methods:
        mine = studies_ch06.summarise(res[m])
        assert mine["t"] == stored[m]["t"]
        for seed, run in zip(seeds, mine["runs"]):
            assert_same_record(run, stored[m]["runs"][seed - studies_ch06.CH06_SEEDS[0]],
                               f"{m} {seed}")


@pytest.mark.parametrize("name, rows", [("mrclam_heldout", "splits"), ("graph_mrclam", "robots")])
def test_save_rows_writes_the_shipped_files_byte_for_byte(tmp_path, name, rows):
    """The one writer of the row-per-line studies: what it writes parses back to the data,
    and the shipped files are exactly what it writes of them."""
    import json
    from pathlib import Path

    from slamlib.course.stored import save_rows

    shipped = Path(__file__).resolve().parents[1] / "data" / "studies" / f"{name}.json"
    data = json.loads(shipped.read_text(encoding="utf-8"))
    save_rows(data, rows, tmp_path / "a.json")
    assert (tmp_path / "a.json").read_bytes() == shipped.read_bytes()
    small = {"format": "x", "n": 2, "rows": [{"a": 1.5}, [1, 2]], "empty": {}}
    save_rows(small, "rows", tmp_path / "b.json")
    text = (tmp_path / "b.json").read_text(encoding="utf-8")
    assert json.loads(text) == small and text.count("\n") == 9
