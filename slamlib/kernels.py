"""The filters' inner loops, compiled with numba: one implementation of each, written out.

:mod:`slamlib.ekf` keeps the filters' logic (association, gate decisions,
reports, hooks) in Python and calls these kernels for the arithmetic of one
step, where numpy's cost per call, not the arithmetic, was the price: a
course-sized state (n = 23) spent about 110 us in some 25 numpy calls per
update, and a Monte-Carlo of 100 runs makes 54,000 updates.

Each kernel is the algebra its docstring gives, on checked float64 arrays
(the callers check), in loops a student can read against the chapter:

- :func:`motion_terms`, :func:`shear_cov`, :func:`predict_pose` and
  :func:`predict_poses`: the prediction of chapter 01 (scalars);
- :func:`observe_into`: ``h``, ``H_pose``, ``H_landmark`` of chapter 03;
- :func:`innovation_covs` and :func:`innovation_distances`: ``S_i = H_i P H_i^T + R_i``,
  ``y_i`` and ``d2_i`` (the gate);
- :func:`fuse`: the joint update of chapter 05 through the Cholesky factor of S, and
  :func:`solve_lower`, its forward substitution (JCBB's too, chapter 09);

No fast-math: LLVM does not reassociate or fuse these operations, so a
kernel's scalar arithmetic is IEEE arithmetic in the order written, and
the results do not depend on the machine's vector width or on how many
processes share the work. ``cache=True`` keeps the compiled code beside
this file (``__pycache__``), so only the first process compiles.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_PI = math.pi
_TWO_PI = 2.0 * math.pi


@njit(cache=True)
def wrap(a: float) -> float:
    """``a`` wrapped to [-pi, pi): ``(a + pi) mod 2 pi - pi`` (a finite float).

    The same operations as :func:`slamlib.models.wrap_angle` (Python's and
    numba's float ``%`` take the sign of the divisor, as ``np.mod``).
    """
    w = (a + _PI) % _TWO_PI - _PI
    return w - _TWO_PI if w >= _PI else w


@njit(cache=True)
def motion_terms(theta: float, V_R: float, V_L: float, dt: float, b: float):
    """The scalars of the motion model and its Jacobians (chapter 01), computed once.

    With ``V = (V_R + V_L)/2``, ``w = (V_L - V_R)/b`` (z-down) and the heading
    ``theta`` at the start of the step, returns ``(dx, dy, dtheta, hc, hs, g)``:

    - the step ``dx = V cos(theta) dt``, ``dy = V sin(theta) dt``, ``dtheta = w dt``
      (so ``f(x) = x + [dx, dy, dtheta]``, heading wrapped);
    - ``A = [[1, 0, -dy], [0, 1, dx], [0, 0, 1]]``;
    - ``W = [[hc, hc], [hs, hs], [-g, g]]`` with ``hc = cos(theta) dt/2``,
      ``hs = sin(theta) dt/2``, ``g = dt/b``.

    The one place of these formulas: :func:`slamlib.models.motion_model`,
    :func:`slamlib.models.motion_jacobians` and the filters' prediction all
    take them from here (``slamlib.models.motion_terms`` is this function).
    """
    v, w = 0.5 * (V_R + V_L), (V_L - V_R) / b
    c, s = math.cos(theta), math.sin(theta)
    return v * c * dt, v * s * dt, w * dt, 0.5 * c * dt, 0.5 * s * dt, dt / b


@njit(cache=True)
def shear_cov(P, Q, a: float, b: float, w00: float, w01: float, w10: float, w11: float,
              w20: float, w21: float) -> None:
    """``P_rr <- A P_rr A^T + W Q W^T`` for the shear ``A = I + c e_3^T``, ``c = [a, b, 0]``.

    Element by element, exactly symmetric (``P`` the filter's storage, ``W`` the
    3x2 noise Jacobian row by row, chapter 01)::

        (A P A^T)_ij = P_ij + c_i P_3j + P_i3 c_j + c_i c_j P_33
    """
    p00, p01, p02 = P[0, 0], P[0, 1], P[0, 2]
    p11, p12, p22 = P[1, 1], P[1, 2], P[2, 2]
    q00, q01, q11 = Q[0, 0], Q[0, 1], Q[1, 1]
    # rows of W Q
    r00, r01 = w00 * q00 + w01 * q01, w00 * q01 + w01 * q11
    r10, r11 = w10 * q00 + w11 * q01, w10 * q01 + w11 * q11
    r20, r21 = w20 * q00 + w21 * q01, w20 * q01 + w21 * q11
    n00 = p00 + 2.0 * a * p02 + a * a * p22 + (r00 * w00 + r01 * w01)
    n01 = p01 + a * p12 + b * p02 + a * b * p22 + (r00 * w10 + r01 * w11)
    n11 = p11 + 2.0 * b * p12 + b * b * p22 + (r10 * w10 + r11 * w11)
    n02 = p02 + a * p22 + (r00 * w20 + r01 * w21)
    n12 = p12 + b * p22 + (r10 * w20 + r11 * w21)
    n22 = p22 + (r20 * w20 + r21 * w21)
    P[0, 0], P[0, 1], P[0, 2] = n00, n01, n02
    P[1, 0], P[1, 1], P[1, 2] = n01, n11, n12
    P[2, 0], P[2, 1], P[2, 2] = n02, n12, n22


@njit(cache=True)
def predict_pose(x, P, Q, V_R: float, V_L: float, dt: float, b: float):
    """One prediction of the pose and of ``P_rr`` (chapter 01); returns its shear ``(a, b)``.

    ``x[:3] <- f(x[:3], u)`` with :func:`motion_terms`, and ``P_rr`` by
    :func:`shear_cov` with ``A = I + c e_3^T``, ``c = [-dy, dx, 0]``.
    ``P_rm <- A P_rm`` is left to the caller, who composes the shears of
    several predictions by adding their ``c`` (see ``slamlib.ekf``).
    """
    th = x[2]
    dx, dy, dth, hc, hs, g = motion_terms(th, V_R, V_L, dt, b)
    x[0] = x[0] + dx
    x[1] = x[1] + dy
    x[2] = wrap(th + dth)
    shear_cov(P, Q, -dy, dx, hc, hc, hs, hs, -g, g)
    return -dy, dx


@njit(cache=True)
def apply_shear(P, n: int, a: float, b: float) -> None:
    """``P_rm <- (I + c e_3^T) P_rm`` for ``c = [a, b, 0]``, and ``P_mr = P_rm^T`` (O(n)):
    rows 0 and 1 of ``P_rm`` gain ``a`` and ``b`` times row 2."""
    for j in range(3, n):
        P[0, j] += a * P[2, j]
        P[1, j] += b * P[2, j]
        P[j, 0], P[j, 1] = P[0, j], P[1, j]


@njit(cache=True)
def predict_poses(x, P, Q, u, dt, b: float, has_shear: bool, sa: float, sb: float,
                  poses, covs):
    """:func:`predict_pose` for each row of ``u`` (k, 2), ``dt`` (k,) and ``Q`` (k, 2, 2), in order.

    ``Q[k]`` is step k's covariance of ``u`` (the same matrix for every step
    when the filter has one ``Q``: a broadcast view; one per step when the
    noise is a density, ``Q_k = Q_c / dt_k``, chapter 10).

    Writes the pose and ``P_rr`` after each step into ``poses`` (k, 3) and
    ``covs`` (k, 3, 3) (what a trace records), and returns the pending shear
    ``(has, a, b)``: the given one ``(has_shear, sa, sb)`` plus each step's, added
    in the order the steps are made (as one prediction at a time would).
    """
    for k in range(dt.shape[0]):
        a, bb = predict_pose(x, P, Q[k], u[k, 0], u[k, 1], dt[k], b)
        if has_shear:
            sa, sb = sa + a, sb + bb
        else:
            sa, sb, has_shear = a, bb, True
        for i in range(3):
            poses[k, i] = x[i]
            for j in range(3):
                covs[k, i, j] = P[i, j]
    return has_shear, sa, sb


@njit(cache=True)
def observe_into(pose, L, h, Hp, Hl) -> None:
    """The direct observation of k landmarks ``L`` (k, 2) and its Jacobians (chapter 03).

    Per landmark, with ``dx = x_F - x_B``, ``dy = y_F - y_B``, ``q = dx^2 + dy^2``
    and ``r = sqrt(q)`` (``hypot``)::

        h          = [r, atan2(dy, dx) - theta]          (bearing wrapped)
        H_pose     = [[-dx/r, -dy/r,  0],   H_landmark = [[ dx/r, dy/r],
                      [ dy/q, -dx/q, -1]]                 [-dy/q, dx/q]]

    into ``h`` (k, 2), ``Hp`` (k, 2, 3), ``Hl`` (k, 2, 2). A landmark on the
    robot (``q = 0``) has no bearing: its rows of ``h``, ``Hl`` and the first
    two columns of ``Hp`` are NaN.
    """
    for i in range(L.shape[0]):
        dx = L[i, 0] - pose[0]
        dy = L[i, 1] - pose[1]
        q = dx * dx + dy * dy
        r = math.hypot(dx, dy)
        if q > 0.0:
            h[i, 0] = r
            h[i, 1] = wrap(math.atan2(dy, dx) - pose[2])
            a, bb, c, d = dx / r, dy / r, -dy / q, dx / q
        else:
            h[i, 0] = h[i, 1] = a = bb = c = d = np.nan
        Hl[i, 0, 0], Hl[i, 0, 1], Hl[i, 1, 0], Hl[i, 1, 1] = a, bb, c, d
        Hp[i, 0, 0], Hp[i, 0, 1], Hp[i, 0, 2] = -a, -bb, 0.0
        Hp[i, 1, 0], Hp[i, 1, 1], Hp[i, 1, 2] = -c, -d, -1.0


@njit(cache=True)
def innovation_covs(P, slots, Hp, Hl, R, S) -> None:
    """``S_i = H_i P H_i^T + R_i`` of each reading into ``S`` (k, 2, 2), exactly symmetric.

    From the blocks of P the reading touches: the pose, and its landmark at
    ``slots[i]`` when ``slots[i] >= 0`` (a known map has none), with
    ``H_i = [H_pose_i, H_landmark_i]`` over those columns.
    """
    for i in range(slots.shape[0]):
        s = slots[i]
        c = 5 if s >= 0 else 3
        # Hb: the reading's 2 x c Jacobian over [pose, landmark]; idx: those columns of P
        Hb = np.empty((2, c))
        idx = np.empty(c, dtype=np.int64)
        for j in range(3):
            idx[j] = j
            Hb[0, j], Hb[1, j] = Hp[i, 0, j], Hp[i, 1, j]
        if s >= 0:
            idx[3], idx[4] = s, s + 1
            for j in range(2):
                Hb[0, 3 + j], Hb[1, 3 + j] = Hl[i, 0, j], Hl[i, 1, j]
        # HPb = Hb P[idx, idx] (2 x c), then S = HPb Hb^T + R
        HPb = np.zeros((2, c))
        for r in range(2):
            for j in range(c):
                acc = 0.0
                for q in range(c):
                    acc += Hb[r, q] * P[idx[q], idx[j]]
                HPb[r, j] = acc
        for r in range(2):
            for j in range(2):
                acc = 0.0
                for q in range(c):
                    acc += HPb[r, q] * Hb[j, q]
                S[i, r, j] = acc + R[i, r, j]
        S[i, 0, 1] = S[i, 1, 0] = 0.5 * (S[i, 0, 1] + S[i, 1, 0])


@njit(cache=True)
def innovation_distances(z, h, S, y, d2) -> None:
    """``y_i = z_i - h_i`` (bearing wrapped) and ``d2_i = y_i^T S_i^-1 y_i`` (the gate).

    The 2x2 inverse written out: ``S^-1 = [[s11, -s01], [-s01, s00]] / (s00 s11 - s01^2)``.
    """
    for i in range(h.shape[0]):
        y0 = z[i, 0] - h[i, 0]
        y1 = wrap(z[i, 1] - h[i, 1])
        y[i, 0], y[i, 1] = y0, y1
        s00, s01, s11 = S[i, 0, 0], S[i, 0, 1], S[i, 1, 1]
        d2[i] = (s11 * y0 * y0 - 2.0 * s01 * y0 * y1 + s00 * y1 * y1) / (s00 * s11 - s01 * s01)


@njit(cache=True)
def solve_lower(L, B) -> None:
    """``B <- L^-1 B`` in place for a lower-triangular ``L`` (m x m) and ``B`` (m x k), by
    forward substitution, O(m^2 k): row r is ``(B_r - sum_{j<r} L_rj B_j) / L_rr``."""
    for r in range(L.shape[0]):
        for c in range(B.shape[1]):
            a = B[r, c]
            for j in range(r):
                a -= L[r, j] * B[j, c]
            B[r, c] = a / L[r, r]


@njit(cache=True)
def fuse(x, P, n: int, slots, Hp, Hl, y, R, subtract: bool):
    """One joint update with m readings (chapter 05); returns ``(ok, NIS, W)``.

    H (2m x n) has non-zero columns only at the pose and the landmarks read;
    with ``c`` those columns and ``Hc`` H restricted to them::

        HP = Hc P[c, :]   (= H P, 2m x n)       S = HP[:, c] Hc^T + R = L L^T
        W  = L^-1 HP      (the whitened gain)    v = L^-1 y
        x <- x + W^T v,   P <- P - W^T W,        NIS = v^T v

    (``K = W^T L^-1``, so ``W^T v = K y`` and ``W^T W = K S K^T``.) ``P -= W^T W``
    is done here, entry ``(i, j)`` and ``(j, i)`` by the same sum, when
    ``subtract``; otherwise the caller does it with W (BLAS, large n). If S
    is not positive definite nothing changes and ``ok`` is False.
    """
    m = slots.shape[0]
    # the observed landmarks, once each, in the order first read
    lm = np.empty(m, dtype=np.int64)
    nl = 0
    for j in range(m):
        s = slots[j]
        if s >= 0:
            seen = False
            for q in range(nl):
                if lm[q] == s:
                    seen = True
            if not seen:
                lm[nl] = s
                nl += 1
    nc = 3 + 2 * nl
    cols = np.empty(nc, dtype=np.int64)
    cols[0], cols[1], cols[2] = 0, 1, 2
    for q in range(nl):
        cols[3 + 2 * q], cols[4 + 2 * q] = lm[q], lm[q] + 1
    Hc = np.zeros((2 * m, nc))
    for j in range(m):
        for r in range(2):
            for c in range(3):
                Hc[2 * j + r, c] = Hp[j, r, c]
        s = slots[j]
        if s >= 0:
            q = 0
            while lm[q] != s:
                q += 1
            for r in range(2):
                Hc[2 * j + r, 3 + 2 * q] = Hl[j, r, 0]
                Hc[2 * j + r, 4 + 2 * q] = Hl[j, r, 1]
    mm = 2 * m
    HP = np.zeros((mm, n))
    for r in range(mm):
        for c in range(nc):
            hv = Hc[r, c]
            if hv != 0.0:
                row = cols[c]
                for k in range(n):
                    HP[r, k] += hv * P[row, k]
    S = np.zeros((mm, mm))
    for r in range(mm):
        for q in range(mm):
            acc = 0.0
            for c in range(nc):
                acc += HP[r, cols[c]] * Hc[q, c]
            S[r, q] = acc
    for j in range(m):
        for r in range(2):
            for q in range(2):
                S[2 * j + r, 2 * j + q] += R[j, r, q]
    # Cholesky of the symmetric part, S = L L^T
    L = np.zeros((mm, mm))
    for r in range(mm):
        for q in range(r + 1):
            acc = 0.5 * (S[r, q] + S[q, r])
            for k in range(q):
                acc -= L[r, k] * L[q, k]
            if r == q:
                if not acc > 0.0:
                    return False, np.nan, HP
                L[r, r] = math.sqrt(acc)
            else:
                L[r, q] = acc / L[q, q]
    # W = L^-1 HP and v = L^-1 y, by forward substitution
    W = HP
    v = np.empty((mm, 1))
    for r in range(mm):
        v[r, 0] = y[r // 2, r % 2]
    solve_lower(L, W)
    solve_lower(L, v)
    v = v[:, 0]
    nis = 0.0
    for r in range(mm):
        nis += v[r] * v[r]
    for c in range(n):
        acc = 0.0
        for r in range(mm):
            acc += W[r, c] * v[r]
        x[c] += acc
    if subtract:
        for i in range(n):
            for j in range(i, n):
                acc = 0.0
                for r in range(mm):
                    acc += W[r, i] * W[r, j]
                P[i, j] -= acc
                if j != i:
                    P[j, i] -= acc
    return True, nis, W


# --------------------------------------------------------------------------- the simulator
# slamlib.sim's loop, one encoder period at a time (chapter 01): the controller, the slip, the
# camera's capture instants, the exact arc and the encoders. Python's min and max are written out
# (``min(a, b)`` is ``b`` only if ``b < a``) so that ties give the same float as in Python.
@njit(cache=True)
def _py_min(a: float, b: float) -> float:
    return b if b < a else a


@njit(cache=True)
def _py_max(a: float, b: float) -> float:
    return b if b > a else a


@njit(cache=True)
def arc(x: float, y: float, th: float, v: float, w: float, dt: float):
    """Exact motion at constant ``v`` and ``w`` for ``dt`` (``slamlib.sim.integrate_arc``).

    An arc of radius ``v/w`` or, when ``|w dt| < 1e-9``, its second-order
    expansion (a segment at the mid heading); heading wrapped.
    """
    dth = w * dt
    if abs(dth) < 1e-9:
        c, s = math.cos(th + 0.5 * dth), math.sin(th + 0.5 * dth)
        return x + v * dt * c, y + v * dt * s, wrap(th + dth)
    r = v / w
    th1 = th + dth
    return x + r * (math.sin(th1) - math.sin(th)), y - r * (math.cos(th1) - math.cos(th)), wrap(th1)


@njit(cache=True)
def encoder_count(rim_angle: float, ticks_per_rev: float, offset: int, bits: int) -> int:
    """The counter after the wheel turned ``rim_angle`` (``slamlib.sim.encoder_counter``):
    whole ticks (floor) plus ``offset``, modulo ``2**bits``."""
    ticks = int(math.floor(rim_angle * ticks_per_rev / (2.0 * math.pi)))
    return (ticks + offset) % (1 << bits)


@njit(cache=True)
def waypoint_command(wp, index: int, v: float, w: float, px: float, py: float, th: float,
                     dt: float, b: float, v_max: float, w_max: float, k_heading: float,
                     accel: float, alpha: float, tolerance: float, turn_in_place: float):
    """One call of ``WaypointController.command``: returns ``(index, v, w, V_R, V_L)``.

    Skip the waypoints within ``tolerance``; aim at the next one (``w = k e``
    clipped to ``w_max``, ``v = v_max cos e``, zero beyond ``turn_in_place``,
    braking on the final approach); both speeds rate-limited; wheel speeds
    ``v -/+ w b/2``.
    """
    n = wp.shape[0]
    while index < n:
        if math.hypot(wp[index, 0] - px, wp[index, 1] - py) > tolerance:
            break
        index += 1
    if index < n:
        dx, dy = wp[index, 0] - px, wp[index, 1] - py
        dist = math.hypot(dx, dy)
        e = wrap(math.atan2(dy, dx) - th)
        w_des = _py_max(-w_max, _py_min(w_max, k_heading * e))
        v_des = 0.0 if abs(e) > turn_in_place else v_max * math.cos(e)
        if index == n - 1:                 # final approach: brake in time
            v_des = _py_min(v_des, math.sqrt(2.0 * accel * _py_max(dist - 0.5 * tolerance,
                                                                    0.0)))
    else:
        v_des = w_des = 0.0
    dv, dw = accel * dt, alpha * dt
    v += _py_max(-dv, _py_min(dv, v_des - v))
    w += _py_max(-dw, _py_min(dw, w_des - w))
    half = 0.5 * w * b
    return index, v, w, v - half, v + half


@njit(cache=True)
def sim_period(pose, VR: float, VL: float, eR: float, eL: float, k: int, next_frame: int,
               b: float, dt: float, sigma_wheel: float, encoder_rate: float,
               camera_rate: float, cap_j, cap_pose):
    """One encoder period of ``KobukiSim.step``: returns ``(next_frame, n_captured)``.

    The ground speeds are the rim speeds plus the slip ``sigma_wheel * [eR, eL]``;
    the camera frames ``j`` whose instant ``j / camera_rate`` falls in this
    period (none without a camera, ``camera_rate = 0``) are captured at the
    pose on the arc then (into ``cap_j``, ``cap_pose``); ``pose`` moves along
    the arc of the period.
    """
    gR, gL = VR + sigma_wheel * eR, VL + sigma_wheel * eL
    v, w = 0.5 * (gR + gL), (gL - gR) / b
    x0, y0, th0 = pose[0], pose[1], pose[2]
    n = 0
    while camera_rate > 0.0:
        x = next_frame * encoder_rate / camera_rate     # capture time in periods
        kk = int(math.floor(x + 1e-9))
        if kk > k:
            break
        frac = _py_max(x - k, 0.0) if kk == k else 0.0
        if frac < 1e-9:
            px, py, pth = x0, y0, th0
        else:
            px, py, pth = arc(x0, y0, th0, v, w, frac * dt)
        cap_j[n] = next_frame
        cap_pose[n, 0], cap_pose[n, 1], cap_pose[n, 2] = px, py, pth
        n += 1
        next_frame += 1
    pose[0], pose[1], pose[2] = arc(x0, y0, th0, v, w, dt)
    return next_frame, n


@njit(cache=True)
def drive_waypoints(wp, control, pose, state, angles, slip, n_max: int, b: float, r: float,
                    dt: float, sigma_wheel: float, encoder_rate: float, camera_rate: float,
                    ticks_per_rev: float, bits: int, off_R: int, off_L: int,
                    times, poses, ticks, cap_j, cap_pose):
    """``simulate``'s loop (command, then one period) while ``state[0] < n_max``, the path is
    not finished and slip rows remain; returns ``(periods done, frames captured)``.

    ``control = [index, v, w, v_max, w_max, k_heading, accel, alpha, tolerance,
    turn_in_place]`` (the first three updated), ``state = [k, next_frame]``,
    ``angles`` the rim angles; each period's time, pose and counters go to
    ``times``, ``poses``, ``ticks``, its frames to ``cap_j``, ``cap_pose``.
    """
    index, v, w = int(control[0]), control[1], control[2]
    k, next_frame = state[0], state[1]
    n_wp = wp.shape[0]
    done = 0
    ncap = 0
    while k < n_max and done < slip.shape[0]:
        if index >= n_wp and v == 0.0 and w == 0.0:
            break
        index, v, w, VR, VL = waypoint_command(
            wp, index, v, w, pose[0], pose[1], pose[2], dt, b, control[3], control[4],
            control[5], control[6], control[7], control[8], control[9])
        next_frame, n = sim_period(pose, VR, VL, slip[done, 0], slip[done, 1], k, next_frame,
                                   b, dt, sigma_wheel, encoder_rate, camera_rate,
                                   cap_j[ncap:], cap_pose[ncap:])
        ncap += n
        angles[0] += VR * dt / r
        angles[1] += VL * dt / r
        k += 1
        times[done] = k / encoder_rate
        poses[done, 0], poses[done, 1], poses[done, 2] = pose[0], pose[1], pose[2]
        ticks[done, 0] = encoder_count(angles[0], ticks_per_rev, off_R, bits)
        ticks[done, 1] = encoder_count(angles[1], ticks_per_rev, off_L, bits)
        done += 1
    control[0], control[1], control[2] = index, v, w
    state[0], state[1] = k, next_frame
    return done, ncap
