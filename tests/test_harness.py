"""The checker harness every exercise shares (slamlib.course.harness)."""

from __future__ import annotations

import operator

import numpy as np
import pytest

from slamlib.course import harness


def test_call_tells_a_stub_a_bug_and_an_answer_apart():
    def stub():
        raise NotImplementedError

    def bug(x):
        return x[5]

    assert harness.call(stub) == (None, "not written yet (it raises NotImplementedError)")
    assert harness.call(lambda: None) == (None, "not written yet (it returns None)")
    out, problem = harness.call(bug, [1, 2])
    assert out is None and problem == "it raised IndexError: list index out of range"
    assert harness.call(lambda a, b: a + b, 2, 3) == (5, None)


def test_not_ready_asks_to_write_a_stub_and_to_fix_a_bug():
    assert harness.not_ready("f", "not written yet (it returns None)", "A and W") == \
        "f: not written yet (it returns None). Write A and W, then run this cell again."
    assert harness.not_ready("f", "it raised KeyError: 3") == \
        "f: it raised KeyError: 3. Fix it, then run this cell again."


def test_printer_and_name_of(capsys):
    harness.printer(False)("hidden")
    harness.printer(True)("shown")
    assert capsys.readouterr().out == "shown\n"

    def my_answer():
        pass

    assert harness.name_of(my_answer) == "my_answer"
    assert harness.name_of(np.ones(2)) == "your function"


def test_shape_problem_and_one_number():
    assert harness.shape_problem("J", np.zeros((2, 3)), (2, 3)) is None
    assert harness.shape_problem("J", [[1.0, 2.0]], (2, 3)) == \
        "J: expected shape (2, 3), got shape (1, 2)"
    assert "got dict" in harness.shape_problem("J", {"a": 1}, (2,))
    assert harness.one_number(np.array([[2.5]])) == 2.5
    with pytest.raises(ValueError, match=r"got shape \(2,\)"):
        harness.one_number([1.0, 2.0])


def test_matching_mistakes_keeps_only_rules_that_fit_every_case():
    cases = [(1, 2), (3, 5), (0, 4)]
    rules = {"added": lambda a, b: a + b, "subtracted": lambda a, b: a - b,
             "largest": lambda a, b: max(a, b)}
    assert harness.matching_mistakes(rules, [3, 8, 4], cases, operator.eq) == ["added"]
    # (0, 4): a + b and max(a, b) agree, the others tell them apart
    assert harness.matching_mistakes(rules, [4], [(0, 4)], operator.eq) == ["added", "largest"]
    assert harness.matching_mistakes(rules, [0, 0, 0], cases, operator.eq) == []


def test_attempt_prints_the_verdict_and_returns_none_unless_there_is_an_answer(capsys):
    def my_jacobians(x):
        raise NotImplementedError

    said = []
    assert harness.attempt(my_jacobians, 1.0, say=said.append, what="A and W") is None
    assert said == ["my_jacobians: not written yet (it raises NotImplementedError). "
                    "Write A and W, then run this cell again."]
    said.clear()
    assert harness.attempt(lambda x: 1 / x, 0.0, say=said.append) is None
    assert said == ["<lambda>: it raised ZeroDivisionError: float division by zero. "
                    "Fix it, then run this cell again."]
    said.clear()
    assert harness.attempt(lambda x: 2 * x, 3.0, say=said.append) == 6.0 and said == []


def test_vector_answer_takes_vectors_and_says_what_is_wrong():
    from slamlib.course.harness import vector_answer

    got, problem = vector_answer([1, 2.5], 2, "[rho, bearing]")
    assert problem is None and got.tolist() == [1.0, 2.5]
    got, problem = vector_answer([1.0, 2.0, 3.0], 2, "[rho, bearing]")
    assert got is None and problem == "expected [rho, bearing] of shape (2,), got 3 value(s)"
    got, problem = vector_answer("ab", 2, "a pair")
    assert got is None and problem.startswith("expected a pair, got 'ab'")
