"""slamlib.course.tables: aligned result tables for the chapters' printed output."""

import numpy as np
import pytest

from slamlib.course.tables import format_table, print_table


def test_columns_are_aligned_and_formatted():
    rows = [("clean", 0.0521, 3.3012, 7), ("misreads, gate none", 0.0, 851.86, 2172)]
    out = format_table(["run", "rejected", "mean\nNEES", "n"], rows, ["s", ".1%", ".2f", "d"])
    lines = out.splitlines()
    assert lines == ["                                 mean",
                     "run                  rejected    NEES     n",
                     "clean                    5.2%    3.30     7",
                     "misreads, gate none      0.0%  851.86  2172"]
    # a right-aligned column ends at the same place on every line
    for col_end in (lines[1].index("rejected") + 8, len(lines[1])):
        assert all(ln[col_end - 1] != " " and (col_end == len(ln) or ln[col_end] == " ")
                   for ln in lines[1:])


def test_missing_values_callables_and_numpy_numbers():
    rows = [(np.int64(3), np.float64(np.nan), None), (12, np.float64(0.5), 2.0)]
    out = format_table(["k", "d2", "x"], rows, [None, ".3f", lambda v: f"<{v:g}>"], missing="--")
    assert out.splitlines() == [" k     d2    x", " 3     --   --", "12  0.500  <2>"]
    assert "np.float64" not in out


def test_a_format_can_force_the_alignment():
    out = format_table(["name", "n"], [("a", 1), ("bbb", 22)], [">s", "<d"])
    assert out.splitlines() == ["name  n", "   a  1", " bbb  22"]


def test_print_table_prints_the_same(capsys):
    rows = [(1.0, "a")]
    print_table(["t", "what"], rows, [".1f", "s"])
    assert capsys.readouterr().out == format_table(["t", "what"], rows, [".1f", "s"]) + "\n"


def test_bad_shapes_name_the_argument():
    with pytest.raises(ValueError, match=r"rows\[1\]"):
        format_table(["a", "b"], [(1, 2), (3,)])
    with pytest.raises(ValueError, match="formats"):
        format_table(["a", "b"], [(1, 2)], [".1f"])
    with pytest.raises(ValueError, match="headers"):
        format_table([], [])
