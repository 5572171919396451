"""Print library code in a chapter: the running source, without its docstring.

A chapter prints the code the filters run (COURSE.md, "Readable"). A docstring
repeats in prose what the chapter has just derived, so a listing that keeps it
buries the few lines the student came to read. :func:`without_docstring` returns
``inspect.getsource(obj)`` with exactly the lines of the object's own docstring
removed: every other line (decorators, signature, comments, blank lines) is
returned as it stands in the file the interpreter loaded.
"""

from __future__ import annotations

import ast
import inspect

__all__ = ["without_docstring"]


def _definition(src: str) -> tuple[ast.AST, int]:
    """The function or class node of ``src`` and the number of lines put in front of it."""
    if src[:1] in (" ", "\t"):        # a method or a nested function: indented source
        tree, shift = ast.parse("if 1:\n" + src), 1
        node = tree.body[0].body[0]
    else:
        tree, shift = ast.parse(src), 0
        node = tree.body[0]
    if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
        raise TypeError(f"obj: expected a function, method or class, got source starting with "
                        f"{src.splitlines()[0]!r}")
    return node, shift


def without_docstring(obj) -> str:
    """The source of ``obj`` (as :func:`inspect.getsource` gives it) minus its docstring's lines.

    Only ``obj``'s own docstring goes (for a class, not its methods'). The
    docstring must stand on lines of its own, as in slamlib; one that shares a
    line with other code raises ``ValueError`` rather than print a cut line.

    Parameters
    ----------
    obj : function, method or class (numba-compiled functions included)

    Returns
    -------
    str
        The source lines, each ending in a newline; unchanged if there is no docstring.
    """
    src = inspect.getsource(obj)
    node, shift = _definition(src)
    first = node.body[0]
    if not (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
            and isinstance(first.value.value, str)):
        return src
    lines = src.splitlines(keepends=True)
    start, end = first.lineno - 1 - shift, first.end_lineno - 1 - shift   # 0-based, in src
    before = lines[start].encode()[:first.col_offset]        # ast's offsets count UTF-8 bytes
    after = lines[end].encode()[first.end_col_offset:]
    if before.strip() or after.strip() or (len(node.body) > 1
                                           and node.body[1].lineno - 1 - shift <= end):
        raise ValueError(f"obj: the docstring of {getattr(obj, '__qualname__', obj)!r} shares "
                         "a line with other code; expected it on lines of its own")
    return "".join(lines[:start] + lines[end + 1:])
