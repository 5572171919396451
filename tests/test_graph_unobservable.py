"""graph.unobservable_directions against an independent count on a tiny graph.

Three poses joined by odometry, two landmarks each read from every pose, no prior, all in
GTSAM's z-up frame. The independent count: the rank of a central-difference Jacobian of
the whitened residuals, written here with numpy in plain additive coordinates
([x, y, theta] per pose, [x, y] per landmark). GTSAM perturbs a pose in its own frame and
writes the odometry error with Pose2's logarithm; both are invertible changes of
coordinates (of the variables and of each factor's residual), which change the Jacobian's
singular values but not its rank, so the two counts must agree.
"""

import gtsam
import numpy as np
import pytest

from slamlib import graph

POSES = np.array([[0.0, 0.0, 0.1], [1.0, 0.2, 0.5], [1.8, 1.0, 1.1]])
LANDMARKS = np.array([[2.0, -0.5], [0.5, 2.0]])
ODO_COV = np.array([[0.05 ** 2, 0.0004, 0.0], [0.0004, 0.03 ** 2, 0.0], [0.0, 0.0, 0.02 ** 2]])
READING_COV = np.diag([0.02, 0.05]) ** 2            # GTSAM's order: bearing (rad), range (m)
#: each reading of landmark 0 linearised at its own copy of it, a few cm off (EKF-like)
OFFSETS = {(0, 0): np.array([0.03, -0.01]), (1, 0): np.array([-0.02, 0.04]),
           (2, 0): np.array([0.01, 0.02])}


def wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def measurements():
    """Noisy odometry and readings (the Jacobians are taken at the truth, which is not
    their solution: no zero residual helps the count)."""
    rng = np.random.default_rng(5)
    odo = []
    for a, b in zip(POSES[:-1], POSES[1:]):
        c, s = np.cos(a[2]), np.sin(a[2])
        d = b[:2] - a[:2]
        odo.append(np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], b[2] - a[2]])
                   + rng.normal(0.0, 0.02, 3))
    reads = {}
    for i, p in enumerate(POSES):
        for m, q in enumerate(LANDMARKS):
            d = q - p[:2]
            reads[i, m] = np.array([np.arctan2(d[1], d[0]) - p[2], np.hypot(*d)]) \
                + rng.normal(0.0, 0.01, 2)
    return odo, reads


def gtsam_factors():
    odo, reads = measurements()
    out = [gtsam.BetweenFactorPose2(graph.pose_key(i), graph.pose_key(i + 1), gtsam.Pose2(*d),
                                    gtsam.noiseModel.Gaussian.Covariance(ODO_COV))
           for i, d in enumerate(odo)]
    for (i, m), (bearing, rho) in reads.items():
        out.append(gtsam.BearingRangeFactor2D(graph.pose_key(i), graph.landmark_key(m),
                                              gtsam.Rot2(bearing), rho,
                                              gtsam.noiseModel.Gaussian.Covariance(READING_COV)))
    return out


def truth_values(offset=(0.0, 0.0), landmark=None) -> gtsam.Values:
    v = gtsam.Values()
    for i, p in enumerate(POSES):
        v.insert(graph.pose_key(i), gtsam.Pose2(*p))
    for m, q in enumerate(LANDMARKS):
        v.insert(graph.landmark_key(m), q + (np.asarray(offset) if m == landmark else 0.0))
    return v


def own_point(fac) -> gtsam.Values:
    """The truth, with landmark 0 moved to this reading's own copy of it."""
    pose, lm = (gtsam.Symbol(k).index() for k in fac.keys())
    if gtsam.Symbol(fac.keys()[1]).chr() == ord("l") and (pose, lm) in OFFSETS:
        return truth_values(OFFSETS[pose, lm], landmark=lm)
    return truth_values()


def keys():
    return [graph.pose_key(i) for i in range(len(POSES))] + \
        [graph.landmark_key(m) for m in range(len(LANDMARKS))]


def whitened_residuals(state, offsets=None) -> np.ndarray:
    """Every factor's residual times the inverse Cholesky factor of its covariance;
    ``offsets[(i, m)]``: the shift of landmark m in pose i's reading of it."""
    n = len(POSES)
    X, L = state[:3 * n].reshape(n, 3), state[3 * n:].reshape(-1, 2)
    odo, reads = measurements()
    w_odo = np.linalg.inv(np.linalg.cholesky(ODO_COV))
    w_read = np.linalg.inv(np.linalg.cholesky(READING_COV))
    out = []
    for i, d in enumerate(odo):
        a, b = X[i], X[i + 1]
        rel = np.array([[np.cos(a[2]), np.sin(a[2])], [-np.sin(a[2]), np.cos(a[2])]]) \
            @ (b[:2] - a[:2])
        out.append(w_odo @ np.concatenate([rel - d[:2], [wrap(b[2] - a[2] - d[2])]]))
    for (i, m), z in reads.items():
        q = L[m] + (offsets or {}).get((i, m), 0.0)
        dx, dy = q - X[i, :2]
        out.append(w_read @ np.array([wrap(np.arctan2(dy, dx) - X[i, 2] - z[0]),
                                      np.hypot(dx, dy) - z[1]]))
    return np.concatenate(out)


def fd_jacobian(offsets=None, eps=1e-6) -> np.ndarray:
    s0 = np.concatenate([POSES.ravel(), LANDMARKS.ravel()])
    cols = []
    for k in range(s0.size):
        e = np.zeros_like(s0)
        e[k] = eps
        cols.append((whitened_residuals(s0 + e, offsets) - whitened_residuals(s0 - e, offsets))
                    / (2.0 * eps))
    return np.column_stack(cols)


def nullity(J, rtol=1e-6) -> int:
    sv = np.linalg.svd(J, compute_uv=False)
    # the gap is wide: the count does not hang on the tolerance
    assert np.all((sv / sv[0] < 1e-8) | (sv / sv[0] > 1e-4)), sv / sv[0]
    return int(np.sum(sv < rtol * sv[0]))


def rigid(kind: str) -> np.ndarray:
    """A shift along x or y, or a turn about the origin, of the whole estimate."""
    if kind == "turn":
        poses = np.column_stack([-POSES[:, 1], POSES[:, 0], np.ones(len(POSES))])
        lms = np.column_stack([-LANDMARKS[:, 1], LANDMARKS[:, 0]])
    else:
        t = np.array([1.0, 0.0]) if kind == "x" else np.array([0.0, 1.0])
        poses = np.tile(np.append(t, 0.0), (len(POSES), 1))
        lms = np.tile(t, (len(LANDMARKS), 1))
    return np.concatenate([poses.ravel(), lms.ravel()])


def test_one_point_leaves_the_three_rigid_motions_unobservable():
    J = fd_jacobian()
    assert nullity(J) == 3
    for kind in ("x", "y", "turn"):
        assert np.max(np.abs(J @ rigid(kind))) < 1e-7, kind
    n, smallest = graph.unobservable_directions(gtsam_factors(), truth_values(), keys())
    assert n == 3
    assert smallest.shape == (4,) and np.all(np.diff(smallest) <= 0)
    assert smallest[0] > 1e-4 and np.all(smallest[1:] < 1e-10)


def test_a_landmark_read_at_different_points_makes_the_turn_observable():
    J = fd_jacobian(OFFSETS)
    assert nullity(J) == 2
    assert np.max(np.abs(J @ rigid("x"))) < 1e-7 and np.max(np.abs(J @ rigid("y"))) < 1e-7
    assert np.max(np.abs(J @ rigid("turn"))) > 1e-3
    n, smallest = graph.unobservable_directions(gtsam_factors(), own_point, keys())
    assert n == 2
    assert smallest[1] > 1e-10 and np.all(smallest[2:] < 1e-10)


def test_the_same_offsets_on_every_factor_are_one_point_again():
    # moving landmark 0 by the same amount in all its readings is a consistent point
    n, _ = graph.unobservable_directions(gtsam_factors(),
                                         truth_values(OFFSETS[0, 0], landmark=0), keys())
    assert n == 3 and nullity(fd_jacobian({k: OFFSETS[0, 0] for k in OFFSETS})) == 3


def test_graph_and_ordering_inputs_and_the_prior():
    fg = gtsam.NonlinearFactorGraph()
    for fac in gtsam_factors():
        fg.add(fac)
    order = gtsam.Ordering()
    for k in reversed(keys()):
        order.push_back(k)
    n, _ = graph.unobservable_directions(fg, truth_values(), order)
    assert n == 3
    fg.add(gtsam.PriorFactorPose2(graph.pose_key(0), gtsam.Pose2(*POSES[0]),
                                  gtsam.noiseModel.Isotropic.Sigma(3, 0.1)))
    n, smallest = graph.unobservable_directions(fg, truth_values(), keys(), n_smallest=2)
    assert n == 0 and smallest.shape == (2,) and np.all(smallest > 1e-6)


def test_bad_arguments():
    facs = gtsam_factors()
    with pytest.raises(ValueError, match="factors"):
        graph.unobservable_directions([], truth_values(), keys())
    with pytest.raises(ValueError, match="ordering"):
        graph.unobservable_directions(facs, truth_values(), keys()[:-1])
    with pytest.raises(ValueError, match="ordering"):
        graph.unobservable_directions(facs, truth_values(), keys() + [keys()[0]])
    with pytest.raises(ValueError, match="rtol"):
        graph.unobservable_directions(facs, truth_values(), keys(), rtol=0.0)
    with pytest.raises(ValueError, match="n_smallest"):
        graph.unobservable_directions(facs, truth_values(), keys(), n_smallest=14)
