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


# ------------------------------------------------------- nothing lost, every failure named
class _FakeClient:
    """NotebookClient without a kernel: every code cell prints 'ran'."""

    def __init__(self, nb, **kwargs):
        self.nb = nb
        self.on_cell_start = None

    def execute(self):
        for i, cell in enumerate(self.nb.cells):
            if cell.cell_type == "code":
                self.on_cell_start(cell=cell, cell_index=i)
                cell.outputs = _out("ran\n")
                cell.execution_count = i + 1


def _write(path, text):
    path.write_text(text, encoding="utf-8")
    return path


def test_unreadable_notebooks_fail_alone_with_one_line_each(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(ex, "NotebookClient", _FakeClient)
    good = _write(tmp_path / "good.ipynb", _nb(_out("ran\n"), []) + "\n")
    missing = tmp_path / "missing.ipynb"
    empty = _write(tmp_path / "empty.ipynb", "")
    cut = _write(tmp_path / "my chapter.ipynb", _nb([], [])[:100])
    assert ex.main([str(missing), str(empty), str(cut), str(good)]) == 1
    lines = capsys.readouterr().out.splitlines()
    for p, reason in ((missing, "no such file"), (empty, "empty file"),
                      (cut, "not valid JSON")):
        hit = [ln for ln in lines if ln.startswith(f"FAILED {p}: ")]
        assert len(hit) == 1 and reason in hit[0], lines
    assert any(ln.startswith(f"{good}: ") for ln in lines), lines     # the others still ran
    assert ex.FAILED_LIST.read_text().splitlines() == [str(missing), str(empty), str(cut)]
    # --failed reads the list back, a path with spaces as one path
    _write(cut, _nb([], []) + "\n")
    missing.unlink(missing_ok=True)
    ex.FAILED_LIST.write_text(f"{cut}\n")
    assert ex.main(["--failed"]) == 0, capsys.readouterr().out
    assert "my chapter.ipynb: rewritten" in capsys.readouterr().out
    assert not ex.FAILED_LIST.exists()


def test_check_does_not_write_the_failed_list(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(ex, "NotebookClient", _FakeClient)
    bad = _write(tmp_path / "bad.ipynb", "{")
    assert ex.main(["--check", str(bad)]) == 1
    assert "FAILED" in capsys.readouterr().out and not ex.FAILED_LIST.exists()
    ex.FAILED_LIST.write_text("earlier.ipynb\n")
    assert ex.main(["--check", str(bad)]) == 1
    assert ex.FAILED_LIST.read_text() == "earlier.ipynb\n"


def test_a_full_disk_leaves_the_notebook_as_it_was(tmp_path):
    # RLIMIT_FSIZE makes every write beyond 40,000 bytes fail (EFBIG), as a full disk would
    # (the audit's notebook was cut at 61,440 bytes): the notebook must stay whole.
    import subprocess
    import sys

    nb_path = tmp_path / "nb.ipynb"
    old = _nb(_out("short\n"), []) + "\n"
    nb_path.write_text(old, encoding="utf-8")
    nb_path.chmod(0o644)
    script = tmp_path / "drive.py"
    script.write_text(f"""
import importlib.util, resource, signal, sys
import nbformat
sys.path.insert(0, {str(ROOT / "tools")!r})
spec = importlib.util.spec_from_file_location(
    "ex", {str(ROOT / "tools" / "execute_notebooks.py")!r})
ex = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ex)
def run(path, timeout):
    nb = nbformat.read(path, as_version=4)
    nb.cells[0].outputs = [nbformat.v4.new_output("stream", name="stdout", text="x" * 100000)]
    return nb
ex.run = run
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (40000, 40000))
sys.exit(ex.main([{str(nb_path)!r}]))
""")
    res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         cwd=tmp_path, timeout=300)
    assert res.returncode == 1, res.stdout + res.stderr
    assert nb_path.read_text(encoding="utf-8") == old
    assert oct(nb_path.stat().st_mode & 0o777) == oct(0o644)
    assert f"FAILED {nb_path}: " in res.stdout and "as it was" in res.stdout, res.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == [".notebooks-failed", "drive.py",
                                                          "nb.ipynb"]


def test_a_rewritten_notebook_keeps_its_permissions(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(ex, "NotebookClient", _FakeClient)
    p = _write(tmp_path / "nb.ipynb", _nb(_out("old\n"), []) + "\n")
    p.chmod(0o640)
    assert ex.main([str(p)]) == 0
    assert "ran" in p.read_text() and p.stat().st_mode & 0o777 == 0o640
    assert [q.name for q in tmp_path.iterdir()] == ["nb.ipynb"]


def test_timeouts_and_errors_are_named_plainly(tmp_path, monkeypatch, capsys):
    # a real kernel: the timeout names itself, a cell's error is its type and message,
    # without the traceback's colour codes
    monkeypatch.chdir(tmp_path)
    slow, bad = nbformat.v4.new_notebook(), nbformat.v4.new_notebook()
    slow.cells = [nbformat.v4.new_code_cell("import time\ntime.sleep(60)")]
    bad.cells = [nbformat.v4.new_code_cell("x = 1"),
                 nbformat.v4.new_code_cell("raise ValueError('the reason')")]
    nbformat.write(slow, tmp_path / "slow.ipynb")
    nbformat.write(bad, tmp_path / "bad.ipynb")
    assert ex.main(["--timeout", "3", "slow.ipynb", "bad.ipynb"]) == 1
    out = capsys.readouterr().out
    assert "\x1b" not in out
    lines = out.splitlines()
    (s,) = [ln for ln in lines if ln.startswith("FAILED slow.ipynb")]
    assert "cell 0" in s and "timed out after 3 s" in s and "--timeout" in s, s
    assert "---" not in s
    (b,) = [ln for ln in lines if ln.startswith("FAILED bad.ipynb")]
    assert "cell 1" in b and b.endswith("ValueError: the reason"), b
