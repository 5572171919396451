"""slamlib.course.student_filter: the student's functions drive the arena loop (chapter 05)."""

import numpy as np
import pytest

from slamlib import ekf_textbook as tb
from slamlib import runner
from slamlib.course import student_filter as sf
from slamlib.runs import load_run


@pytest.fixture(scope="module")
def run():
    return load_run("arena_loop")


def joint_update_mirror(x, P, z, z_pred, H, R):
    # written out independently of ekf_textbook: the information form of the update
    y = (z - z_pred).reshape(-1)
    y[1::2] = (y[1::2] + np.pi) % (2 * np.pi) - np.pi
    P_post = np.linalg.inv(np.linalg.inv(P) + H.T @ np.linalg.solve(R, H))
    x_new = x + P_post @ H.T @ np.linalg.solve(R, y)
    x_new[2] = (x_new[2] + np.pi) % (2 * np.pi) - np.pi
    return x_new, 0.5 * (P_post + P_post.T)


def test_right_functions_reproduce_the_library_filter(run):
    lib = runner.slam(run, gate=0.95, max_time=30.0)
    mine = sf.drive(run, joint_update=joint_update_mirror, stacked_jacobian=tb.stacked_jacobian,
                    max_time=30.0, verbose=False)
    assert mine.filter.functions["joint_update"] is joint_update_mirror
    d = sf.difference(mine, lib)
    assert mine.filter.n_landmarks >= 5
    assert d["pose"] < 1e-8 and d["state"] < 1e-8 and d["cov"] < 1e-10


def test_stubs_fall_back_to_the_textbook_and_say_so(run, capsys):
    def my_joint_update(x, P, z, z_pred, H, R):
        return None

    mine = sf.drive(run, joint_update=my_joint_update, max_time=5.0)
    out = capsys.readouterr().out
    assert "my_joint_update does not pass check_joint_update" in out
    assert mine.filter.functions["joint_update"] is tb.joint_update
    lib = runner.slam(run, gate=0.95, max_time=5.0)
    assert sf.difference(mine, lib)["state"] < 1e-12


def test_a_wrong_function_is_not_used(run, capsys):
    def no_cross_covariance(x, P, z, R):
        x_new, P_new = tb.augment(x, P, z, R)
        n = x.size
        P_new[n:, :n] = 0.0
        P_new[:n, n:] = 0.0
        return x_new, P_new

    mine = sf.drive(run, augment=no_cross_covariance, max_time=5.0)
    assert "no_cross_covariance does not pass check_augment" in capsys.readouterr().out
    assert mine.filter.functions["augment"] is tb.augment


def test_unknown_function_name_is_a_value_error():
    with pytest.raises(ValueError, match="functions"):
        sf.choose(update=tb.update)
