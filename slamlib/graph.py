"""Smoothing and mapping: a run as a factor graph, solved with GTSAM (chapter 11).

EKF SLAM keeps only the current pose and the map, and linearises each step
once, at the estimate of that moment. A factor graph keeps every pose the
robot took at a camera frame, every landmark, and every piece of information
as a factor between them; the least-squares problem they make is solved by
re-linearising as often as needed (Dellaert & Kaess 2017).

The graph of a run (:func:`build_problem`), with the same inputs as
:func:`slamlib.runner.slam`:

- a **prior** on the first pose: the run's start pose with covariance ``P0``;
- one **odometry factor** (``BetweenFactorPose2``) between the poses of
  successive camera frames: the encoders' wheel speeds of the interval are
  integrated with :func:`slamlib.models.motion_model` from the origin, and the
  covariance ``Q`` of each step is propagated with the same Jacobians ``A``, ``W``
  as the EKF's prediction (:func:`integrate_odometry`);
- one **range-bearing factor** (``BearingRangeFactor2D``) per reading, to the
  landmark with the id read (the EKF's association by id), with the covariance
  ``R`` the EKF gives it; optionally with a robust kernel (Huber, Cauchy).

:func:`smooth` solves it in one batch (Levenberg-Marquardt, then the marginal
covariances from :class:`gtsam.Marginals`) or incrementally (iSAM2, one update
per camera frame, Kaess et al. 2012) and returns a :class:`GraphTrace`.

Frames
------
The course's frame N is z-down: y to the right, angles clockwise seen from
above. GTSAM's ``Pose2`` is written for a z-up plane (y to the left, angles
counter-clockwise). The two are the mirror image of each other about x
(:mod:`slamlib.frames`): a pose ``[x, y, theta]`` is ``Pose2(x, -y, -theta)``,
a landmark ``[x, y]`` is ``Point2(x, -y)``, a bearing ``beta`` is ``-beta``.
The mirror is an isometry that maps compositions to compositions, so the
problem solved in GTSAM's frame is the course's problem seen in a mirror, and
the solution mirrored back is the same solution.

Covariances need one more step. The course's covariances are of the additive
error ``[dx, dy, dtheta]`` in N (the EKF's); GTSAM's ``Pose2`` covariances are of
the perturbation ``xi`` in the pose's own frame (``T * Exp(xi)``): to first
order ``d[x, y] = R(theta) xi[:2]``, ``dtheta = xi[2]``. :func:`pose_cov_to_gtsam`
and :func:`pose_cov_from_gtsam` apply this and the mirror ``M = diag(1, -1, -1)``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import gtsam
import numpy as np

from .metrics import ate
from .models import compose_poses, inverse_observe, motion_jacobians, motion_model, wrap_angle
from .runner import DEFAULT_P0, Trace, default_R, map_error, reading_covariances
from .runs import Run
from .validate import as_covariance, as_matrix, as_vector

__all__ = ["pose_to_gtsam", "pose_from_gtsam", "pose_cov_to_gtsam", "pose_cov_from_gtsam",
           "point_to_gtsam", "point_from_gtsam", "point_cov_to_gtsam", "point_cov_from_gtsam",
           "reading_to_gtsam", "integrate_odometry", "Odometry", "Problem", "build_problem",
           "factor_graph", "smooth", "GraphMap", "GraphTrace", "information_matrix", "METHODS",
           "ROBUST", "ROBUST_K", "batch_marginals", "variable_ordering",
           "unobservable_directions"]

#: The solvers of :func:`smooth`.
METHODS = ("batch", "isam2")
#: The robust kernels :func:`smooth` accepts (None: plain least squares).
ROBUST = ("huber", "cauchy")
#: The mirror between the z-down and z-up planes acting on [x, y, theta] (its own inverse).
_M = np.diag([1.0, -1.0, -1.0])
_S = np.diag([1.0, -1.0])


def pose_key(i: int) -> int:
    """GTSAM key of the i-th pose of the graph."""
    return gtsam.symbol("x", int(i))


def landmark_key(marker_id: int) -> int:
    """GTSAM key of the landmark with this marker id."""
    if int(marker_id) < 0:
        raise ValueError(f"marker_id: expected an id >= 0, got {marker_id}")
    return gtsam.symbol("l", int(marker_id))


# --------------------------------------------------------------------------- frames
def pose_to_gtsam(pose) -> gtsam.Pose2:
    """A z-down pose ``[x, y, theta]`` as GTSAM's z-up ``Pose2(x, -y, -theta)``."""
    p = as_vector("pose", pose, 3)
    return gtsam.Pose2(p[0], -p[1], -p[2])


def pose_from_gtsam(pose: gtsam.Pose2) -> np.ndarray:
    """GTSAM's z-up ``Pose2`` as a z-down pose ``[x, -y, -theta]`` (heading wrapped)."""
    return np.array([pose.x(), -pose.y(), wrap_angle(-pose.theta())])


def _frame_jacobian(theta: float) -> np.ndarray:
    """``d[x, y, theta] / d xi`` for ``T * Exp(xi)`` at ``xi = 0``: ``blockdiag(R(theta), 1)``."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def pose_cov_to_gtsam(pose, P) -> np.ndarray:
    """A z-down pose's covariance (additive, in N) as GTSAM's (body-frame perturbation, z-up).

    ``Sigma_xi = M G P G^T M`` with ``G = blockdiag(R(theta)^T, 1)`` and ``M = diag(1, -1, -1)``.
    """
    p = as_vector("pose", pose, 3)
    P = as_covariance("P", P, 3, semidefinite=True)
    G = _frame_jacobian(p[2]).T
    return _M @ G @ P @ G.T @ _M


def pose_cov_from_gtsam(pose, Sigma) -> np.ndarray:
    """GTSAM's covariance of a pose (body-frame perturbation, z-up) in the course's form.

    ``pose`` is the z-down pose (``[x, y, theta]``) or the ``gtsam.Pose2`` it belongs
    to; returns ``P = B M Sigma M B^T`` with ``B = blockdiag(R(theta), 1)``, theta z-down.
    """
    if isinstance(pose, gtsam.Pose2):
        pose = pose_from_gtsam(pose)
    p = as_vector("pose", pose, 3)
    S = as_covariance("Sigma", Sigma, 3, semidefinite=True)
    B = _frame_jacobian(p[2])
    P = B @ _M @ S @ _M @ B.T
    return 0.5 * (P + P.T)


def point_to_gtsam(point) -> np.ndarray:
    """A z-down point ``[x, y]`` as GTSAM's ``Point2`` ``[x, -y]``."""
    p = as_vector("point", point, 2)
    return np.array([p[0], -p[1]])


#: The mirror is its own inverse.
point_from_gtsam = point_to_gtsam


def point_cov_to_gtsam(P) -> np.ndarray:
    """A point's covariance mirrored, ``S P S`` with ``S = diag(1, -1)`` (either way)."""
    return _S @ as_covariance("P", P, 2, semidefinite=True) @ _S


point_cov_from_gtsam = point_cov_to_gtsam


def reading_to_gtsam(z, R) -> tuple[gtsam.Rot2, float, np.ndarray]:
    """A z-down reading ``[rho, beta]`` with covariance R as GTSAM's (bearing, range, cov).

    GTSAM orders the error as ``[bearing, range]`` and its bearing is ``-beta``:
    the covariance becomes ``T R T^T`` with ``T = [[0, -1], [1, 0]]``.
    """
    z = as_vector("z", z, 2)
    R = as_covariance("R", R, 2)
    T = np.array([[0.0, -1.0], [1.0, 0.0]])
    return gtsam.Rot2(-z[1]), float(z[0]), T @ R @ T.T


# --------------------------------------------------------------------------- odometry
@dataclass(frozen=True)
class Odometry:
    """The encoders' motion between two graph poses, in the frame of the first (z-down).

    Attributes
    ----------
    delta : numpy.ndarray (3,)
        The relative pose ``[dx, dy, dtheta]`` (the second pose seen from the first).
    cov : numpy.ndarray (3, 3)
        Its covariance (additive, in the first pose's frame), propagated from Q.
    steps : int
        Encoder steps integrated.
    """

    delta: np.ndarray
    cov: np.ndarray
    steps: int


def integrate_odometry(u, dt, Q, wheel_base: float) -> Odometry:
    """Integrate wheel speeds from the origin and propagate their covariance (chapter 11).

    ``d_k = f(d_{k-1}, u_k)`` with :func:`slamlib.models.motion_model`, from ``d_0 = 0``,
    and ``Sigma_k = A_k Sigma_{k-1} A_k^T + W_k Q W_k^T`` with the Jacobians of
    :func:`slamlib.models.motion_jacobians` (the EKF's prediction of chapter 01,
    started from the first pose's own frame with no uncertainty).

    Parameters
    ----------
    u : array_like (k, 2)
        Wheel speeds ``[V_R, V_L]`` of each step (m/s).
    dt : array_like (k,)
        Step durations (s).
    Q : array_like (2, 2) or (k, 2, 2)
        Covariance of one step's ``u``: the same for every step, or one per step
        (a real log's noise density, ``Q_c / dt_k``, chapter 10).
    wheel_base : float
        b (m).
    """
    u = as_matrix("u", u, (None, 2))
    dt = as_vector("dt", dt, u.shape[0])
    if np.ndim(Q) == 3:
        if np.shape(Q)[0] != u.shape[0]:
            raise ValueError(f"Q: expected one 2x2 covariance per step ({u.shape[0]}), "
                             f"got {np.shape(Q)[0]}")
        Qs = [as_covariance("Q", q, 2, semidefinite=True) for q in Q]
    else:
        Qs = [as_covariance("Q", Q, 2, semidefinite=True)] * u.shape[0]
    d = np.zeros(3)
    S = np.zeros((3, 3))
    for k in range(u.shape[0]):
        A, W = motion_jacobians(d, u[k], dt[k], wheel_base)
        d = motion_model(d, u[k], dt[k], wheel_base)
        S = A @ S @ A.T + W @ Qs[k] @ W.T
    return Odometry(d, 0.5 * (S + S.T), int(u.shape[0]))


# --------------------------------------------------------------------------- the problem
@dataclass
class Problem:
    """What the graph of a run is made of (z-down, the course's units).

    Attributes
    ----------
    t : numpy.ndarray (N,)
        Time of each pose node: the run's start, each camera frame with
        readings after some motion, and the end of the encoder record.
    kind : numpy.ndarray of str (N,)
        ``"start"``, ``"update"`` (a camera frame) or ``"predict"`` (a node with
        no frame: the end, or ``max_steps`` encoder steps without one).
    x0, P0 : numpy.ndarray
        The prior on the first pose.
    odometry : list of Odometry (N - 1)
        Between node i and i + 1.
    readings : list of (ids (k,), z (k, 2), R (k, 2, 2)) (N)
        The readings attached to each node.
    wheel_base : float
    """

    t: np.ndarray
    kind: np.ndarray
    x0: np.ndarray
    P0: np.ndarray
    odometry: list
    readings: list
    wheel_base: float

    @property
    def n_poses(self) -> int:
        return int(self.t.shape[0])

    @property
    def landmark_ids(self) -> list[int]:
        """Ids in the order they were first read."""
        seen: dict[int, None] = {}
        for ids, _, _ in self.readings:
            for i in ids:
                seen.setdefault(int(i), None)
        return list(seen)

    def dead_reckoning(self) -> np.ndarray:
        """The poses chained from the prior through the odometry alone (N, 3)."""
        x = [self.x0.copy()]
        for od in self.odometry:
            x.append(compose_poses(x[-1], od.delta))
        return np.array(x)


def build_problem(run: Run, *, Q=None, R=None, P0=DEFAULT_P0, by: str = "capture",
                  use_sensor_R: bool = True, max_time: float | None = None,
                  max_steps: int | None = None, odometry_floor: float = 1e-10,
                  min_interval: float = 0.0) -> Problem:
    """The factor graph's contents for ``run``, from the same events the EKF sees.

    The run's events (:meth:`slamlib.runs.Run.events`) are read in the order
    :func:`slamlib.runner.run_filter` reads them: the encoder steps since the
    last node are integrated into one :class:`Odometry`; a camera frame with
    readings makes a new node (or joins the last one if the robot has not moved
    since). ``Q``, ``R``, ``P0``, ``by``, ``use_sensor_R`` mean what they mean for
    :func:`slamlib.runner.slam`. ``max_steps``: also make a node after this
    many encoder steps without a frame (long blind stretches, or a run without readings).

    ``odometry_floor`` (m^2 and rad^2) is added to each odometry covariance's
    diagonal: the Euler model gives a robot that stands still no sideways noise at
    all, and an interval spent (almost) standing has a (nearly) singular covariance;
    the default, 1e-10 (10 um, 10 urad), is below the runs' stored precision.

    ``min_interval`` (s): keyframes only; a camera frame less than this after the
    last pose node is left out, with its readings (0: every frame is used).
    """
    if not np.isfinite(odometry_floor) or odometry_floor < 0.0:
        raise ValueError(f"odometry_floor: expected a variance >= 0, got {odometry_floor}")
    # each step's Q: the run's own (a real log's density gives one per step) unless Q is given
    Q_steps = run.Q_steps(np.diff(run.enc_t)) if Q is None else None
    Q = run.Q() if Q is None else as_covariance("Q", Q, 2, semidefinite=True)
    P0 = as_covariance("P0", P0, 3)
    R_default = default_R(run) if R is None else as_covariance("R", R, 2)
    sensor = run.sensor() if (use_sensor_R and R is None) else None
    if max_steps is not None and int(max_steps) < 1:
        raise ValueError(f"max_steps: expected a positive integer or None, got {max_steps}")
    b = run.wheel_base

    t, kind = [float(run.enc_t[0])], ["start"]
    odometry: list[Odometry] = []
    readings: list[list] = [[]]
    us: list[np.ndarray] = []
    dts: list[float] = []
    qs: list[np.ndarray] = []
    t_last = float(run.enc_t[0])

    def close(t_node: float, k: str) -> None:
        od = integrate_odometry(np.array(us), np.array(dts), Q if Q_steps is None else
                                np.array(qs), b)
        odometry.append(Odometry(od.delta, od.cov + odometry_floor * np.eye(3), od.steps))
        us.clear()
        dts.clear()
        qs.clear()
        t.append(float(t_node))
        kind.append(k)
        readings.append([])

    for ev in run.events(by=by):
        if max_time is not None and ev.t > max_time:
            break
        if ev.kind == "predict":
            us.append(ev.u)
            dts.append(ev.dt)
            if Q_steps is not None:
                qs.append(Q_steps[ev.k - 1])
            t_last = ev.t
            if max_steps is not None and len(us) >= int(max_steps):
                close(ev.t, "predict")
            continue
        obs = ev.obs
        if len(obs) == 0:
            continue
        if len(t) > 1 and ev.t - t[-1] < min_interval:
            continue
        if us:
            close(ev.t, "update")
        elif kind[-1] == "predict":
            kind[-1] = "update"
        Rk = reading_covariances(sensor, obs.z)
        if Rk is None:
            Rk = np.broadcast_to(R_default, (len(obs), 2, 2)).copy()
        readings[-1].append((np.asarray(obs.ids, dtype=np.int64), np.asarray(obs.z, float), Rk))
    if us:
        close(t_last, "predict")

    def stack(parts):
        if not parts:
            return np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2, 2))
        return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                np.concatenate([p[2] for p in parts]))

    return Problem(t=np.array(t), kind=np.array(kind), x0=run.start_pose, P0=P0,
                   odometry=odometry, readings=[stack(r) for r in readings], wheel_base=b)


#: The robust kernels' default threshold on a reading's Mahalanobis distance
#: ``d = sqrt(e^T R^-1 e)`` (GTSAM's robust noise model weighs the whole 2-vector by its
#: whitened norm): ``sqrt(chi2_2^-1(0.95)) = sqrt(-2 ln 0.05) = 2.448``, so that a reading
#: that fits its R lies beyond it with probability 0.05. Huber's usual 1.345 is a constant
#: for a 1-D residual: for the norm of a 2-D one, ``P(d > 1.345) = exp(-1.345^2/2) = 0.40``.
ROBUST_K = float(np.sqrt(-2.0 * np.log(0.05)))


def _noise(cov: np.ndarray, robust: str | None = None, k: float = ROBUST_K):
    base = gtsam.noiseModel.Gaussian.Covariance(np.asarray(cov, dtype=float))
    if robust is None:
        return base
    if robust == "huber":
        m = gtsam.noiseModel.mEstimator.Huber.Create(k)
    elif robust == "cauchy":
        m = gtsam.noiseModel.mEstimator.Cauchy.Create(k)
    else:
        raise ValueError(f"robust: expected one of {ROBUST} or None, got {robust!r}")
    return gtsam.noiseModel.Robust.Create(m, base)


def _node_factors(problem: Problem, i: int, robust, robust_k) -> gtsam.NonlinearFactorGraph:
    """The factors that arrive with pose i: its prior or odometry, and its readings."""
    g = gtsam.NonlinearFactorGraph()
    if i == 0:
        g.add(gtsam.PriorFactorPose2(pose_key(0), pose_to_gtsam(problem.x0),
                                     _noise(pose_cov_to_gtsam(problem.x0, problem.P0))))
    else:
        od = problem.odometry[i - 1]
        g.add(gtsam.BetweenFactorPose2(pose_key(i - 1), pose_key(i), pose_to_gtsam(od.delta),
                                       _noise(pose_cov_to_gtsam(od.delta, od.cov))))
    ids, z, R = problem.readings[i]
    for j in range(ids.shape[0]):
        bearing, rng, cov = reading_to_gtsam(z[j], R[j])
        g.add(gtsam.BearingRangeFactor2D(pose_key(i), landmark_key(ids[j]), bearing, rng,
                                         _noise(cov, robust, robust_k)))
    return g


def factor_graph(problem: Problem, *, robust: str | None = None, robust_k: float = ROBUST_K
                 ) -> gtsam.NonlinearFactorGraph:
    """The whole graph of ``problem`` (GTSAM's z-up frame)."""
    g = gtsam.NonlinearFactorGraph()
    for i in range(problem.n_poses):
        g.push_back(_node_factors(problem, i, robust, robust_k))
    return g


def _new_landmarks(problem: Problem, i: int, pose: np.ndarray, known) -> dict[int, np.ndarray]:
    """First guesses (z-down) of the landmarks first read at node i, from ``pose``."""
    out: dict[int, np.ndarray] = {}
    ids, z, _ = problem.readings[i]
    for j in range(ids.shape[0]):
        m = int(ids[j])
        if m not in known and m not in out:
            out[m] = inverse_observe(pose, z[j])
    return out


def _initial_values(problem: Problem) -> gtsam.Values:
    """Dead-reckoned poses and each landmark from its first reading (batch start)."""
    v = gtsam.Values()
    X = problem.dead_reckoning()
    known: set[int] = set()
    for i in range(problem.n_poses):
        v.insert(pose_key(i), pose_to_gtsam(X[i]))
        for m, p in _new_landmarks(problem, i, X[i], known).items():
            v.insert(landmark_key(m), point_to_gtsam(p))
            known.add(m)
    return v


# --------------------------------------------------------------------------- the result
@dataclass
class GraphMap:
    """The smoother's map in the shape of ``EKFSLAM``'s (``landmarks``, ``landmark_cov``),
    so that what reads a filter's map (plots, :func:`slamlib.runner.map_error`) reads it.
    """

    landmark_ids: list
    x: np.ndarray
    P: np.ndarray

    @property
    def n_landmarks(self) -> int:
        return len(self.landmark_ids)

    @property
    def landmarks(self) -> dict[int, np.ndarray]:
        """Mapped landmarks, id -> position (z-down)."""
        return {int(i): self.x[k].copy() for k, i in enumerate(self.landmark_ids)}

    def landmark_cov(self, marker_id: int) -> np.ndarray:
        """Marginal covariance (2x2, z-down) of one landmark."""
        return self.P[self.landmark_ids.index(int(marker_id))].copy()


@dataclass
class GraphTrace(Trace):
    """A :class:`slamlib.runner.Trace` of the smoothed poses, with the map.

    ``x``, ``P`` are the final estimate of every pose node and its marginal
    covariance given ALL the readings (smoothed), z-down, next to the truth;
    ``filter`` is the map (:class:`GraphMap`).

    Extra attributes
    ----------------
    method : str
        ``"batch"`` or ``"isam2"``.
    landmark_ids : list of int
    landmark_x : numpy.ndarray (L, 2)
    landmark_P : numpy.ndarray (L, 2, 2)
        The map and its marginal covariances (z-down).
    online_x, online_P : numpy.ndarray (N, 3), (N, 3, 3) or None
        iSAM2 only: the estimate of each pose right after its own update, from
        the readings up to then (the filtered estimate, what an EKF gives).
    step_seconds : numpy.ndarray (N,) or None
        iSAM2 only: wall time of each update (s).
    step_reeliminated : numpy.ndarray (N,) or None
        iSAM2 only: variables re-eliminated by each update (its work, deterministic).
    problem : Problem
    graph : gtsam.NonlinearFactorGraph
    values : gtsam.Values
        The solution in GTSAM's frame.
    iterations : int
        Batch: Levenberg-Marquardt iterations.
    """

    method: str = "batch"
    landmark_ids: list = field(default_factory=list)
    landmark_x: np.ndarray | None = None
    landmark_P: np.ndarray | None = None
    online_x: np.ndarray | None = None
    online_P: np.ndarray | None = None
    step_seconds: np.ndarray | None = None
    step_reeliminated: np.ndarray | None = None
    problem: Problem | None = None
    graph: object = None
    values: object = None
    iterations: int = 0

    @property
    def landmarks(self) -> dict[int, np.ndarray]:
        """Mapped landmarks, id -> position (z-down), as ``EKFSLAM.landmarks``."""
        return self.filter.landmarks

    def landmark_cov(self, marker_id: int) -> np.ndarray:
        """Marginal covariance (2x2, z-down) of one landmark."""
        return self.filter.landmark_cov(marker_id)

    def metrics(self, world=None) -> dict[str, float]:
        """As :meth:`Trace.metrics` (on the smoothed poses), and the map's figures."""
        a = ate(self.x, self.truth)
        out = {"ate_xy": float(a.position), "ate_theta": float(a.heading),
               "mean_nees": float(np.mean(self.nees)),
               "final_xy_error": float(np.hypot(*self.error[-1, :2])),
               "landmarks": float(len(self.landmark_ids))}
        if world is not None:
            out["map_rmse"] = map_error(self.filter, world)[0]
        return out


def _collect(problem: Problem, values, marginal) -> tuple:
    X, P = [], []
    for i in range(problem.n_poses):
        p = values.atPose2(pose_key(i))
        X.append(pose_from_gtsam(p))
        P.append(pose_cov_from_gtsam(X[-1], marginal(pose_key(i))))
    ids = problem.landmark_ids
    L = [point_from_gtsam(values.atPoint2(landmark_key(m))) for m in ids]
    LP = [point_cov_from_gtsam(marginal(landmark_key(m))) for m in ids]
    return (np.array(X), np.array(P), ids, np.array(L).reshape(-1, 2),
            np.array(LP).reshape(-1, 2, 2))


def batch_marginals(graph: gtsam.NonlinearFactorGraph, values: gtsam.Values,
                    factorization: str = "auto"):
    """The marginal covariance of each variable of ``graph`` linearised at ``values``.

    Returns a function ``key -> covariance`` (GTSAM's frame). ``factorization``:
    ``"cholesky"``: :class:`gtsam.Marginals` (Cholesky of the information matrix);
    ``"qr"``: one iSAM2 elimination by QR of the whitened Jacobian at ``values``
    (nothing re-linearised or moved), which does not square the condition number;
    ``"auto"``: Cholesky, and QR if GTSAM finds the system indeterminate. A real
    log (chapter 11's MRCLAM robots) has camera frames milliseconds apart: their
    odometry factor is almost rigid (``odometry_floor`` sideways), and the
    information matrix is too badly conditioned for Cholesky.
    """
    if factorization not in ("auto", "cholesky", "qr"):
        raise ValueError(f"factorization: expected 'auto', 'cholesky' or 'qr', "
                         f"got {factorization!r}")
    if factorization != "qr":
        try:
            return gtsam.Marginals(graph, values).marginalCovariance
        except RuntimeError:
            if factorization == "cholesky":
                raise
    params = gtsam.ISAM2Params()
    params.setFactorization("QR")
    params.setRelinearizeThreshold(1e12)
    isam = gtsam.ISAM2(params)
    isam.update(graph, values)

    def marginal(key: int) -> np.ndarray:
        C = np.asarray(isam.marginalCovariance(key))
        if not (np.all(np.isfinite(C)) and np.all(np.diag(C) > 0.0)):
            name = gtsam.DefaultKeyFormatter(key)
            raise RuntimeError(f"batch_marginals: the QR marginal of {name} is not a "
                               "covariance (a factor with a singular covariance?)")
        return C

    return marginal


def smooth(run: Run, method: str = "batch", *, Q=None, R=None, P0=DEFAULT_P0,
           by: str = "capture", use_sensor_R: bool = True, max_time: float | None = None,
           max_steps: int | None = None, odometry_floor: float = 1e-10,
           min_interval: float = 0.0, robust: str | None = None, robust_k: float = ROBUST_K,
           relinearize_threshold: float = 0.01, final_iterations: int = 3) -> GraphTrace:
    """Smoothing and mapping of a run with GTSAM (chapter 11).

    Parameters
    ----------
    run : Run
        A recorded or simulated run.
    method : {"batch", "isam2"}
        ``"batch"``: the whole graph at once, Levenberg-Marquardt from the
        dead-reckoned poses. ``"isam2"``: one iSAM2 update per camera frame
        (each new pose starts at the current estimate of the previous one
        composed with the odometry, each new landmark from its first reading);
        after the last one, ``final_iterations`` more updates without new
        factors let the re-linearisation settle.
    Q, R, P0, by, use_sensor_R, max_time
        As for :func:`slamlib.runner.slam`.
    max_steps, odometry_floor, min_interval
        See :func:`build_problem`.
    robust : {"huber", "cauchy"}, optional
        A robust kernel on the readings, with the threshold ``robust_k`` on their
        Mahalanobis distance (default :data:`ROBUST_K`, 2.448).
    relinearize_threshold : float
        iSAM2: re-linearise a variable whose update exceeds this.

    Returns
    -------
    GraphTrace
        Smoothed poses with marginal covariances and the truth; the map; for
        iSAM2 also the online (filtered) estimates and each update's cost.
    """
    if method not in METHODS:
        raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
    if robust is not None and robust not in ROBUST:
        raise ValueError(f"robust: expected one of {ROBUST} or None, got {robust!r}")
    problem = build_problem(run, Q=Q, R=R, P0=P0, by=by, use_sensor_R=use_sensor_R,
                            max_time=max_time, max_steps=max_steps,
                            odometry_floor=odometry_floor, min_interval=min_interval)
    extra: dict = {}
    if method == "batch":
        graph = factor_graph(problem, robust=robust, robust_k=robust_k)
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(200)
        # far from the optimum (a drifted dead reckoning) LM may need a large damping
        # before a step lowers the error; GTSAM's default ceiling (1e5) stops it at once
        params.setlambdaUpperBound(1e12)
        params.setRelativeErrorTol(1e-10)
        params.setAbsoluteErrorTol(1e-12)
        params.setLinearSolverType("MULTIFRONTAL_QR")
        opt = gtsam.LevenbergMarquardtOptimizer(graph, _initial_values(problem), params)
        values = opt.optimize()
        X, P, ids, L, LP = _collect(problem, values, batch_marginals(graph, values))
        extra["iterations"] = int(opt.iterations())
    else:
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(relinearize_threshold)
        params.relinearizeSkip = 1
        params.setFactorization("QR")
        isam = gtsam.ISAM2(params)
        graph = gtsam.NonlinearFactorGraph()
        known: set[int] = set()
        on_x, on_P, secs, reel = [], [], [], []
        prev = problem.x0
        for i in range(problem.n_poses):
            g = _node_factors(problem, i, robust, robust_k)
            guess = problem.x0 if i == 0 else compose_poses(prev, problem.odometry[i - 1].delta)
            v = gtsam.Values()
            v.insert(pose_key(i), pose_to_gtsam(guess))
            for m, p in _new_landmarks(problem, i, guess, known).items():
                v.insert(landmark_key(m), point_to_gtsam(p))
                known.add(m)
            t0 = time.perf_counter()
            res = isam.update(g, v)
            prev = pose_from_gtsam(isam.calculateEstimatePose2(pose_key(i)))
            cov = isam.marginalCovariance(pose_key(i))
            secs.append(time.perf_counter() - t0)
            reel.append(int(res.getVariablesReeliminated()))
            on_x.append(prev)
            on_P.append(pose_cov_from_gtsam(prev, cov))
            graph.push_back(g)
        for _ in range(int(final_iterations)):
            isam.update()
        values = isam.calculateEstimate()
        X, P, ids, L, LP = _collect(problem, values, isam.marginalCovariance)
        extra.update(online_x=np.array(on_x), online_P=np.array(on_P),
                     step_seconds=np.array(secs), step_reeliminated=np.array(reel))
    return GraphTrace(t=problem.t.copy(), kind=problem.kind.copy(), x=X, P=P,
                      truth=run.truth_at(problem.t), method=method, landmark_ids=ids,
                      landmark_x=L, landmark_P=LP, filter=GraphMap(ids, L, LP), problem=problem,
                      graph=graph, values=values, **extra)


def information_matrix(trace: GraphTrace) -> tuple[np.ndarray, list[str]]:
    """The information matrix ``J^T Sigma^-1 J`` of the graph at its solution (chapter 11).

    Rows and columns: the poses in time order (3 each: x, y, theta), then the
    landmarks in the order first read (2 each), in GTSAM's frame (the mirror
    changes signs, never which entries are zero). Returns it with one label
    per block (``"x0"``..., ``"l21"``...).
    """
    n_poses = trace.problem.n_poses
    A, _ = trace.graph.linearize(trace.values).jacobian(variable_ordering(trace))
    labels = [f"x{i}" for i in range(n_poses)] + [f"l{m}" for m in trace.landmark_ids]
    return A.T @ A, labels


def variable_ordering(trace: GraphTrace) -> gtsam.Ordering:
    """The variables of ``trace``'s graph: the poses in time order, then the landmarks
    in the order first read (the columns of :func:`information_matrix`)."""
    return _ordering([pose_key(i) for i in range(trace.problem.n_poses)]
                     + [landmark_key(m) for m in trace.landmark_ids])


def _ordering(keys) -> gtsam.Ordering:
    """A gtsam.Ordering of ``keys``, in the order given."""
    ordering = gtsam.Ordering()
    for k in keys:
        ordering.push_back(k)
    return ordering


def unobservable_directions(factors, points, ordering, *, rtol: float = 1e-10,
                            n_smallest: int = 4) -> tuple[int, np.ndarray]:
    """How many directions a linearised factor graph holds no information about (chapter 11).

    Each factor is linearised, the whitened Jacobian ``A`` of all of them is stacked
    (one column per scalar of the variables in ``ordering``), and a direction ``v`` with
    ``A v = 0`` changes no residual to first order: the linearised problem cannot see
    it. Their number is the dimension of the null space of ``A``, counted from its
    singular values.

    Linearised at one point, a connected graph of odometry and range-bearing factors
    without a prior, in which every landmark is read from poses that fix it, has three (the
    whole estimate shifted in x and y, and turned). Linearised with
    a landmark's factors at different points, as EKF SLAM's moving estimates do, the
    turn is no longer in the null space: the linearised problem "sees" the heading.

    Parameters
    ----------
    factors : gtsam.NonlinearFactorGraph or iterable of gtsam.NonlinearFactor
        The factors (leave the prior out to count what the readings cannot see).
    points : gtsam.Values or callable
        Where to linearise: one ``Values`` for every factor, or a function
        ``factor -> Values`` called once per factor, in order (each factor at its own point).
    ordering : gtsam.Ordering or sequence of int
        The keys of the variables: exactly the keys the factors touch.
    rtol : float
        A singular value below ``rtol`` times the largest counts as zero.
    n_smallest : int
        How many of the smallest singular values to return.

    Returns
    -------
    count : int
        The number of unobservable directions (the nullity of ``A``).
    smallest : ndarray, shape (n_smallest,)
        The ``n_smallest`` smallest singular values of ``A`` over the largest, in
        decreasing order; when ``A`` has fewer rows than columns, the missing singular
        values are counted as 0.
    """
    if isinstance(factors, gtsam.NonlinearFactorGraph):
        factors = [factors.at(i) for i in range(factors.size())]
    factors = list(factors)
    if not factors:
        raise ValueError("factors: expected at least one factor, got none")
    if not (np.isfinite(rtol) and 0.0 < rtol < 1.0):
        raise ValueError(f"rtol: expected a number in (0, 1), got {rtol!r}")
    if isinstance(ordering, gtsam.Ordering):
        keys = [ordering.at(i) for i in range(ordering.size())]
    else:
        keys = [int(k) for k in ordering]
        ordering = _ordering(keys)
    touched = {k for fac in factors for k in fac.keys()}
    if len(set(keys)) != len(keys) or set(keys) != touched:
        raise ValueError("ordering: expected each key the factors touch exactly once; "
                         f"missing {sorted(touched - set(keys))}, not touched "
                         f"{sorted(set(keys) - touched)}, {len(keys) - len(set(keys))} repeated")
    at = points if callable(points) else (lambda fac: points)
    lin = gtsam.GaussianFactorGraph()
    for fac in factors:
        lin.push_back(fac.linearize(at(fac)))
    A = lin.jacobian(ordering)[0]
    n_smallest = int(n_smallest)
    if not 1 <= n_smallest <= A.shape[1]:
        raise ValueError(f"n_smallest: expected 1 to {A.shape[1]} (the columns), "
                         f"got {n_smallest}")
    sv = np.linalg.svd(A, compute_uv=False)
    sv = np.concatenate([sv, np.zeros(A.shape[1] - sv.size)])   # fewer rows than columns
    if sv[0] == 0.0:
        return A.shape[1], np.zeros(n_smallest)
    return int(np.sum(sv < rtol * sv[0])), sv[-n_smallest:] / sv[0]
