"""Chapter 09's checker: right answers pass, each named mistake gets its hint."""

import numpy as np
import pytest

from slamlib.course.checkers_ch09 import check_joint_distance, joint_distance_cases


def _S(H, P, R):
    m = R.shape[0]
    blocks = np.zeros((2 * m, 2 * m))
    for q in range(m):
        blocks[2 * q:2 * q + 2, 2 * q:2 * q + 2] = R[q]
    return H @ P @ H.T + blocks


def right(y, H, P, R):
    yv = y.reshape(-1)
    return float(yv @ np.linalg.solve(_S(H, P, R), yv))


def right_with_inverse(y, H, P, R):
    yv = y.reshape(-1)
    return yv @ np.linalg.inv(_S(H, P, R)) @ yv


def sum_of_individual(y, H, P, R):
    S = _S(H, P, R)
    return sum(float(y[q] @ np.linalg.solve(S[2 * q:2 * q + 2, 2 * q:2 * q + 2], y[q]))
               for q in range(R.shape[0]))


def no_R(y, H, P, R):
    yv = y.reshape(-1)
    return float(yv @ np.linalg.solve(H @ P @ H.T, yv))


def S_not_inverse(y, H, P, R):
    yv = y.reshape(-1)
    return float(yv @ _S(H, P, R) @ yv)


def distance(y, H, P, R):
    return np.sqrt(right(y, H, P, R))


def one_R(y, H, P, R):
    return right(y, H, P, np.broadcast_to(R[0], R.shape))


def ranges_first(y, H, P, R):
    yv = y.T.reshape(-1)
    return float(yv @ np.linalg.solve(_S(H, P, R), yv))


def stub(y, H, P, R):
    return None


def test_right_answers_pass(capsys):
    assert check_joint_distance(right)
    assert check_joint_distance(right_with_inverse)
    assert "correct" in capsys.readouterr().out


@pytest.mark.parametrize("fn, hint", [
    (sum_of_individual, "SUM of the individual distances"),
    (no_R, "R is missing"),
    (S_not_inverse, "S where S^-1 belongs"),
    (distance, "returns D, not D^2"),
    (one_R, "R[0] for every reading"),
    (ranges_first, "ranges..., bearings..."),
])
def test_each_mistake_is_named(fn, hint, capsys):
    assert not check_joint_distance(fn)
    out = capsys.readouterr().out
    assert "wrong" in out and hint in out


def test_stub_and_errors(capsys):
    assert not check_joint_distance(stub)
    assert "not written yet" in capsys.readouterr().out

    def boom(y, H, P, R):
        raise KeyError("x")
    assert not check_joint_distance(boom)
    assert "raised KeyError" in capsys.readouterr().out


def test_the_cases_make_the_cross_terms_matter():
    # the verdict says the sum of the individual distances would fail at every case
    for y, H, P, R in joint_distance_cases():
        assert not np.isclose(sum_of_individual(y, H, P, R), right(y, H, P, R), rtol=1e-3)


# ------------------------------------------------------------------------------ JCBB's search
from slamlib import association as asc  # noqa: E402
from slamlib.course.checkers_ch09 import _joint, best_hypothesis, check_jcbb, jcbb_cases  # noqa: E402
from slamlib.metrics import chi2_quantile  # noqa: E402


def _cands(d2, gate):
    return [sorted((j for j in range(d2.shape[1]) if d2[i, j] < chi2_quantile(gate, 2)),
                   key=lambda j: d2[i, j]) for i in range(d2.shape[0])]


def jcbb_search(d2, joint, gate, *, tie_break=True, prefix_test=True):
    """A plain recursive JCBB (with switches that make the usual mistakes)."""
    k = d2.shape[0]
    cands = _cands(d2, gate)
    best = {"pairs": [], "D2": 0.0, "n": -1}

    def search(i, pairs, D2):
        if i == k:
            if prefix_test or not pairs or joint(pairs) < chi2_quantile(gate, 2 * len(pairs)):
                better = len(pairs) > best["n"] or (tie_break and len(pairs) == best["n"]
                                                    and D2 < best["D2"])
                if better:
                    best.update(pairs=list(pairs), D2=D2, n=len(pairs))
            return
        for j in cands[i]:
            if any(j == jj for _, jj in pairs):
                continue
            D = joint(pairs + [(i, j)])
            if not prefix_test or D < chi2_quantile(gate, 2 * (len(pairs) + 1)):
                search(i + 1, pairs + [(i, j)], D)
        search(i + 1, pairs, D2)

    search(0, [], 0.0)
    out = np.full(k, -1)
    for i, j in best["pairs"]:
        out[i] = j
    return out


def sequential_nn(d2, joint, gate):
    """The first leaf: each reading in turn to its closest landmark that keeps the set jointly
    compatible, never revisited."""
    pairs = []
    for i, c in enumerate(_cands(d2, gate)):
        for j in c:
            if all(j != jj for _, jj in pairs) and \
                    joint(pairs + [(i, j)]) < chi2_quantile(gate, 2 * (len(pairs) + 1)):
                pairs.append((i, j))
                break
    out = np.full(d2.shape[0], -1)
    for i, j in pairs:
        out[i] = j
    return out


def individual_nn(d2, joint, gate):
    return asc.nearest_neighbour(d2, chi2_quantile(gate, 2))


def test_jcbb_checker_accepts_a_right_search(capsys):
    assert check_jcbb(jcbb_search) is True
    assert "correct" in capsys.readouterr().out


def test_jcbb_checker_reference_is_the_library_answer():
    # two independent answers to the same question: enumeration here, branch and bound there
    for d2, y, C, R in jcbb_cases():
        want = best_hypothesis(d2, lambda p, y=y, C=C, R=R: _joint(y, C, R, p), 0.95)[0]
        assert list(asc.jcbb(y, d2, C, R, 0.95).assignment) == list(want)


def test_jcbb_checker_cases_separate_jcbb_from_nn():
    # section 4's frame, and at least one other, where NN's answer is not JCBB's
    differ = [list(individual_nn(d2, None, 0.95))
              != list(best_hypothesis(d2, lambda p, y=y, C=C, R=R: _joint(y, C, R, p),
                                      0.95)[0])
              for d2, y, C, R in jcbb_cases()]
    assert differ[0] and sum(differ) >= 2


@pytest.mark.parametrize("fn, words", [
    (individual_nn, "section 4's frame"),
    (sequential_nn, "sequential nearest neighbour"),
    (lambda d2, j, g: jcbb_search(d2, j, g, tie_break=False), "smallest D2"),
    (lambda d2, j, g: np.zeros(d2.shape[0] + 1, int), "one landmark index per reading"),
    (lambda d2, j, g: None, "not written yet"),
])
def test_jcbb_checker_names_the_mistake(fn, words, capsys):
    assert check_jcbb(fn) is False
    assert words in capsys.readouterr().out


def test_jcbb_checker_names_a_pair_outside_its_gate_and_a_landmark_used_twice(capsys):
    def everything_to_zero(d2, joint, gate):
        return np.zeros(d2.shape[0], int)
    assert check_jcbb(everything_to_zero) is False
    out = capsys.readouterr().out
    assert "outside its individual gate" in out or "two readings" in out
