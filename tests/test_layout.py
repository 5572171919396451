"""The layout: the library in slamlib/ never imports the course's machinery (slamlib/course/)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import slamlib

PACKAGE = Path(slamlib.__file__).parent


def imported_modules(source: str, module: str, is_package: bool = False) -> set[str]:
    """Every module an ``import`` or ``from ... import`` in ``source`` names, made absolute.

    ``module`` is the dotted name of the file (``slamlib.ekf``); a ``from`` import also
    yields ``base.name`` for each imported name, since that name may be a submodule
    (``from slamlib import course``).
    """
    package = module if is_package else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1])
                base = f"{base}.{node.module}" if node.module else base
            else:
                base = node.module
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def library_files() -> list[Path]:
    """Every module of the library: slamlib/*.py and its subpackages except course/."""
    files = sorted(PACKAGE.glob("*.py"))
    for sub in sorted(p for p in PACKAGE.iterdir() if p.is_dir() and p.name != "course"):
        files += sorted(sub.rglob("*.py"))
    return [f for f in files if "__pycache__" not in f.parts]


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imports_course(names: set[str]) -> list[str]:
    return sorted(n for n in names if n == "slamlib.course" or n.startswith("slamlib.course."))


def test_the_import_parser_sees_every_way_to_import_the_course():
    for src in ("from .course import plots_ch01", "from . import course",
                "from .course.harness import call", "import slamlib.course.harness",
                "from slamlib import course", "def f():\n    from .course import x\n"):
        assert imports_course(imported_modules(src, "slamlib.ekf")), src
    assert imports_course(imported_modules("from ..course import x", "slamlib.datasets.mrclam"))
    assert imports_course(imported_modules("from ..course import x", "slamlib.vision.camera"))
    assert imports_course(imported_modules("from ..course import x", "slamlib.vision",
                                           is_package=True))
    # inside the package slamlib.vision, "from . import course" is slamlib.vision.course
    assert imports_course(imported_modules("from . import course", "slamlib.vision",
                                           is_package=True)) == []
    for src in ("from .models import observe", "from . import runner as ex",
                "from ..models import wrap_angle", "import numpy as np"):
        assert imports_course(imported_modules(src, "slamlib.datasets.identify")) == [], src


def test_the_files_checked_include_the_subpackages():
    names = {module_name(f) for f in library_files()}
    assert {"slamlib.ekf", "slamlib.models", "slamlib.datasets.mrclam"} <= names
    assert not any(n.startswith("slamlib.course") for n in names)
    if (PACKAGE / "vision").is_dir():
        assert "slamlib.vision" in names and len([n for n in names
                                                  if n.startswith("slamlib.vision.")]) >= 3


@pytest.mark.parametrize("path", library_files(), ids=lambda p: module_name(p))
def test_the_library_never_imports_the_course(path):
    names = imported_modules(path.read_text(encoding="utf-8"), module_name(path),
                             is_package=path.name == "__init__.py")
    assert imports_course(names) == [], f"{module_name(path)} imports the course's machinery"
