"""The chapters' main lines meet the Teach-first bar (COURSE.md), measured by tools/main_line.py."""

import importlib.util
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("main_line", ROOT / "tools" / "main_line.py")
main_line = importlib.util.module_from_spec(_spec)
sys.modules["main_line"] = main_line
_spec.loader.exec_module(main_line)

CHAPTERS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def _nb(*cells):
    return {"cells": [{"cell_type": t, "metadata": {"tags": tags}, "source": s}
                      for t, tags, s in cells]}


def test_folds_math_fenced_code_and_tables_are_not_main_line():
    text = main_line.main_line_text(_nb(
        ("markdown", [], "Words here. <details><summary>More</summary>hidden 12 34</details> "
                         "after"),
        ("markdown", ["evidence"], "folded evidence 99"),
        ("markdown", ["answer"], "<details><summary>Show answer</summary>\n\nfolded answer 98\n\n"
                                 "</details>"),
        ("code", [], "print(1)"),
        ("markdown", [], "Math $x_1 = 2$ and $$y = 3$$ and $a +\nb_5$ and\n```\ncode 4\n```\n"
                         "| a | 5 |\n|---|---|\nend"),
    ))
    words = text.split()
    assert "hidden" not in words and "folded" not in words and "print(1)" not in words
    assert not any(ch.isdigit() for ch in text)   # every number was in math, code or folds
    assert {"Words", "after", "Math", "end"} <= set(words)


def test_summaries_headings_links_and_inline_code_are_main_line():
    text = main_line.main_line_text(_nb(
        ("markdown", [], "## Heading 1\n<details><summary>Seen 2</summary>unseen 3</details>\n"
                         "See [chapter 5](05_ekf_slam.ipynb) and `ekf.predict` x"),
    ))
    words = [w.strip("[](),.*") for w in main_line._WORD.findall(text)]
    assert {"Heading", "1", "Seen", "2", "chapter", "5", "ekf.predict"} <= set(words)
    assert "unseen" not in words and "05_ekf_slam.ipynb" not in text


def test_a_details_tag_with_attributes_is_not_read_as_a_fold():
    text = main_line.main_line_text(_nb(("markdown", [], '<details class="x"><summary>S</summary>'
                                                         "\n\ninside 5\n\n</details>")))
    assert "inside" in text.split()


def test_an_answer_cell_counts_unless_its_text_is_folded_in_the_markdown():
    # the tag folds it in JupyterLab and the web edition, not in every viewer
    text = main_line.main_line_text(_nb(("markdown", ["answer"], "**Answers.** open 7")))
    assert text.split() == ["**Answers.**", "open", "7"]


def test_numbers_are_counted_per_hundred_words(tmp_path):
    p = tmp_path / "nb.ipynb"
    p.write_text(json.dumps(_nb(("markdown", [], "one two three 4 five six (seven) 8.5, x_B — "
                                                 "nine 10% -- ;"))))
    m = main_line.measure(p)   # words hold a letter or a digit: "—", "--" and ";" are not words
    assert (m.words, m.numbers) == (11, 3)
    assert m.numbers_per_100 == pytest.approx(300 / 11)


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_answer_cells_are_folded_in_their_markdown(path):
    nb = json.loads(path.read_text(encoding="utf-8"))
    for cell in nb["cells"]:
        if cell["cell_type"] == "markdown" and "answer" in cell["metadata"].get("tags", []):
            source = "".join(cell["source"])
            # a bare <details>: what the end-of-session count takes for a fold (the web edition
            # adds its class, build_book._fold)
            assert source.startswith("<details><summary>Show answer")
            assert source.rstrip().endswith("</details>")


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_chapter_main_line_meets_the_bar(path):
    m = main_line.measure(path)
    assert m.words <= main_line.MAX_WORDS, f"{path.name}: {m.words} words of main line"
    assert m.numbers_per_100 <= main_line.MAX_NUMBERS_PER_100, (
        f"{path.name}: {m.numbers_per_100:.1f} numbers per 100 words of main line")
