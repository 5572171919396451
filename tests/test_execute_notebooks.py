"""tools/execute_notebooks.py: the byte comparison of --check, and the list of failed notebooks."""

import importlib.util
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("execute_notebooks",
                                              ROOT / "tools" / "execute_notebooks.py")
ex = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ex)


def _nb(outputs_a, outputs_b, tag_b=True):
    nb = nbformat.v4.new_notebook()
    a = nbformat.v4.new_code_cell("print(1)", outputs=outputs_a, id="cell-a")
    b = nbformat.v4.new_code_cell("timing()", outputs=outputs_b, id="cell-b")
    if tag_b:
        b.metadata["tags"] = ["nbval-ignore-output"]
    nb.cells = [a, b]
    return nbformat.writes(nb)


def _out(text):
    return [nbformat.v4.new_output("stream", name="stdout", text=text)]


def test_comparable_ignores_only_tagged_outputs():
    base = _nb(_out("1\n"), _out("12 ms\n"))
    assert ex.comparable(base) == ex.comparable(_nb(_out("1\n"), _out("15 ms\n")))
    assert ex.comparable(base) != ex.comparable(_nb(_out("2\n"), _out("12 ms\n")))
    untagged = _nb(_out("1\n"), _out("12 ms\n"), tag_b=False)
    assert ex.comparable(untagged) != ex.comparable(_nb(_out("1\n"), _out("15 ms\n"), False))


def test_failed_notebooks_are_listed_and_rerun(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    good, bad = tmp_path / "good.ipynb", tmp_path / "bad.ipynb"
    for p in (good, bad):
        p.write_text(_nb(_out("1\n"), []) + "\n")
    seen = []

    def fake_run(path, timeout):
        seen.append((path.name, timeout))
        if path.name == "bad.ipynb":
            raise ex.NotebookFailed(f"{path}: cell 1 ('timing()') failed: CellTimeoutError: 7 s")
        return nbformat.read(path, as_version=4)

    monkeypatch.setattr(ex, "run", fake_run)
    assert ex.main([str(good), str(bad), "--timeout", "7"]) == 1
    out = capsys.readouterr().out
    assert "FAILED" in out and "bad.ipynb: cell 1" in out and "make notebooks-failed" in out
    assert ex.FAILED_LIST.read_text().split() == [str(bad)]
    seen.clear()
    assert ex.main(["--failed"]) == 1
    assert [s[0] for s in seen] == ["bad.ipynb"]


def test_check_reports_a_notebook_that_would_change(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    p = tmp_path / "nb.ipynb"
    p.write_text(_nb(_out("1\n"), []) + "\n")
    committed = p.read_text()
    monkeypatch.setattr(ex, "run", lambda path, timeout: nbformat.reads(
        _nb(_out("2\n"), []), as_version=4))
    assert ex.main(["--check", str(p)]) == 1
    assert "would change" in capsys.readouterr().out
    assert p.read_text() == committed           # --check writes nothing
    monkeypatch.setattr(ex, "run", lambda path, timeout: nbformat.reads(
        _nb(_out("1\n"), _out("3 ms\n")), as_version=4))
    assert ex.main(["--check", str(p)]) == 0


def test_no_arguments_prints_usage():
    with pytest.raises(SystemExit):
        ex.main(["--no-such-flag"])
