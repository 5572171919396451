"""A frame's readings' R, one 2x2 matrix each, is accepted exactly when as_covariance accepts
each matrix on its own (the compiled check of a frame and the general check agree)."""

import numpy as np
import pytest

from slamlib.validate import as_covariance, as_reading_covariances


def _cases():
    rng = np.random.default_rng(3)
    yield np.array([[1e-10, 0.0], [1e-9, 1e-10]])       # |b - c| within tolerance, but
    #                                                     (m + m')/2 is not positive definite
    yield np.array([[1e-10, 0.0], [1e-11, 1e-10]])      # the same, positive definite
    yield np.array([[4e-4, 0.0], [0.0, 0.0]])           # singular
    yield np.array([[4e-4, 3e-4], [3e-4, 1e-4]])        # indefinite
    yield np.array([[np.nan, 0.0], [0.0, 1.0]])
    yield np.array([[1.0, 0.5], [0.2, 1.0]])            # not symmetric
    for _ in range(300):
        m = rng.normal(size=(2, 2)) * 10.0 ** rng.integers(-8, 2)
        yield m @ m.T if rng.random() < 0.5 else 0.5 * (m + m.T)


@pytest.mark.parametrize("m", list(_cases()))
def test_a_frames_R_is_refused_exactly_when_as_covariance_refuses(m):
    try:
        want = as_covariance("R", m, 2)
    except ValueError:
        want = None
    R = np.stack([np.eye(2) * 1e-4, m])                  # a good reading first
    if want is None:
        with pytest.raises(ValueError, match=r"R\[1\]"):
            as_reading_covariances(R, np.eye(2), 2)
    else:
        assert np.all(np.linalg.eigvalsh(want) > 0.0)    # what is accepted is a covariance
        np.testing.assert_array_equal(as_reading_covariances(R, np.eye(2), 2)[1], want)


def test_a_matrix_whose_symmetric_part_is_not_positive_definite_is_refused():
    # [[1e-10, 0], [1e-9, 1e-10]]: within the symmetry tolerance and a d - b c > 0, but its
    # symmetric part (the matrix returned) has eigenvalues -4e-10 and 6e-10
    m = np.array([[1e-10, 0.0], [1e-9, 1e-10]])
    assert np.linalg.eigvalsh(0.5 * (m + m.T))[0] < 0.0
    with pytest.raises(ValueError, match="positive-definite"):
        as_covariance("R", m, 2)
    with pytest.raises(ValueError, match=r"R\[0\]"):
        as_reading_covariances(m[None], np.eye(2), 1)
