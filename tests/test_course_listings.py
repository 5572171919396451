"""listings.without_docstring: the running source, exactly, minus the docstring's lines."""

import ast
import inspect
import textwrap

import pytest

from slamlib import association, ekf, models, vision
from slamlib.course.listings import without_docstring
from slamlib.datasets import mrclam


def _plain(obj):
    """The Python function behind a numba-compiled one (its ``py_func``), else ``obj``."""
    return getattr(obj, "py_func", obj)


def _parse(src):
    return ast.parse(textwrap.dedent(src))


def _without_doc_node(src):
    """ast.dump of ``src`` with its definition's docstring node taken out of the body."""
    tree = _parse(src)
    node = tree.body[0]
    if (node.body and isinstance(node.body[0], ast.Expr)
            and isinstance(node.body[0].value, ast.Constant)
            and isinstance(node.body[0].value.value, str)):
        node.body = node.body[1:]
    return ast.dump(tree)


def _check(obj):
    """The printed lines are getsource's, in order, minus one block that is the docstring."""
    src, out = inspect.getsource(obj), without_docstring(obj)
    lines, kept = src.splitlines(keepends=True), out.splitlines(keepends=True)
    doc = inspect.getdoc(_plain(obj)) if _plain(obj).__doc__ else None
    if doc is None:
        assert out == src
        return
    # a prefix and a suffix of the source, with the docstring's lines between them
    n_head = next(i for i, (a, b) in enumerate(zip(lines, kept + [None])) if a != b)
    n_tail = len(kept) - n_head
    assert lines[:n_head] + lines[len(lines) - n_tail:] == kept
    removed = "".join(lines[n_head:len(lines) - n_tail])
    assert ast.literal_eval(removed.strip()) == _plain(obj).__doc__
    # the code that is left is the code that runs: same syntax tree, docstring aside
    assert ast.dump(_parse(out)) == _without_doc_node(src)


def test_chapter_03_listings_are_the_running_functions_without_their_docstrings():
    for f in (models.range_bearing, models.observe_landmarks):
        _check(f)
        out = without_docstring(f)
        assert '"""' not in out and out.startswith("@compiled\ndef ")
    out = without_docstring(models.observe_landmarks)
    assert "H_pose[:, :, :2] = -H_landmark" in out and "return h, H_pose, H_landmark" in out


@pytest.mark.parametrize("obj", [vision.camera_to_range_bearing,                     # chapter 02
                                 models.inverse_observation_jacobians, ekf.augment,   # chapter 04
                                 ekf.landmark_covariance, ekf.predict,
                                 mrclam.commands_to_wheel_speeds])                    # chapter 10
def test_other_chapters_listings_are_the_running_functions_without_their_docstrings(obj):
    _check(obj)
    out = without_docstring(obj)
    assert '"""' not in out and out.startswith(("def ", "@compiled\ndef "))


@pytest.mark.parametrize("module", [models, ekf, association])
def test_every_function_and_class_of_the_library(module):
    objs = [o for _, o in inspect.getmembers(module)
            if getattr(_plain(o), "__module__", None) == module.__name__
            and (inspect.isfunction(_plain(o)) or inspect.isclass(o))]
    assert len(objs) > 5
    for o in objs:
        _check(o)
        if inspect.isclass(o):
            for _, m in inspect.getmembers(o, inspect.isfunction):
                if m.__code__.co_filename == module.__file__:   # not dataclass-generated
                    _check(m)               # methods: indented source


class _Example:
    """A class docstring.

    Two paragraphs.
    """

    def method(self):
        """A method's docstring, with µ and σ."""
        return "σ"                          # non-ASCII after the docstring


def _no_docstring(x):
    # a comment, not a docstring
    return x


def _one_line():
    """One line."""

    return 1


def _shares_a_line():
    """µµµ µµµ"""; return 1                 # noqa: E702


def test_small_cases():
    assert without_docstring(_no_docstring) == inspect.getsource(_no_docstring)
    assert without_docstring(_one_line) == "def _one_line():\n\n    return 1\n"
    assert without_docstring(_Example.method) == (
        "    def method(self):\n        return \"σ\"                          # non-ASCII after "
        "the docstring\n")
    out = without_docstring(_Example)
    assert out.startswith("class _Example:\n\n    def method(self):\n")
    assert "A method's docstring" in out                     # only the class's own goes
    for o in (_no_docstring, _one_line, _Example, _Example.method):
        _check(o)


def test_a_docstring_sharing_a_line_is_refused():
    with pytest.raises(ValueError, match="_shares_a_line.*lines of its own"):
        without_docstring(_shares_a_line)


def test_not_a_definition_is_refused():
    with pytest.raises(TypeError, match="obj: expected a function"):
        without_docstring(models)
