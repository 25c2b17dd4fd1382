"""Arrivals and retarded time: when, from how far, and on which stretch of the
listener's path the sound emitted at a knot is heard.

The listener moves linearly between two captures of its path, so on one
capture interval the retarded-time equation c0 (a - t_n) = |L(a) - x| (paper
003 §3.2.4.2, Eqs. 15-17) is a quadratic in a - t_n with one positive root:
every arrival is solved in closed form, no iteration.  :func:`_arrival`
finds the interval and solves it for one emission (the scalar code);
:func:`_row_lines` lists, per knot row, the listener's two candidate lines
(:data:`_LINE` columns each) on which the SIMD loops solve all the knots of a
row at once (:func:`_line_arrival`, :func:`_knot_arrival`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from auralize.emitters._kernels.common import _NJIT, _NJIT_NORC, where


@numba.njit(inline="always", **_NJIT)
def _segment(listener_times, t, hint):
    """Index s of the capture interval [listener_times[s], listener_times[s+1]) holding t, or -1 / M-1 outside."""
    m = listener_times.size
    if t < listener_times[0]:
        return -1
    if t >= listener_times[m - 1]:
        return m - 1
    s = hint
    if s < 0:
        s = 0
    if s > m - 2:
        s = m - 2
    while s > 0 and t < listener_times[s]:
        s -= 1
    while s < m - 2 and t >= listener_times[s + 1]:
        s += 1
    return s


@numba.njit(inline="always", **_NJIT)
def _listener(listener_times, listener_pos, listener_vel, t, s):
    """Listener position and velocity at time t on segment s (held outside the path)."""
    m = listener_times.size
    if s < 0:
        return listener_pos[0, 0], listener_pos[0, 1], listener_pos[0, 2], 0.0, 0.0, 0.0
    if s >= m - 1:
        return listener_pos[m - 1, 0], listener_pos[m - 1, 1], listener_pos[m - 1, 2], 0.0, 0.0, 0.0
    dt = t - listener_times[s]
    return (
        listener_pos[s, 0] + listener_vel[s, 0] * dt,
        listener_pos[s, 1] + listener_vel[s, 1] * dt,
        listener_pos[s, 2] + listener_vel[s, 2] * dt,
        listener_vel[s, 0],
        listener_vel[s, 1],
        listener_vel[s, 2],
    )


@numba.njit(inline="always", **_NJIT)
def _heard_at(x, y, z, rmin, listener_times, listener_pos, c0, k):
    """Emission time of the sound from (x, y, z) that reaches capture k."""
    dx, dy, dz = listener_pos[k, 0] - x, listener_pos[k, 1] - y, listener_pos[k, 2] - z
    return listener_times[k] - max(math.sqrt(dx * dx + dy * dy + dz * dz), rmin) / c0


@numba.njit(inline="always", **_NJIT)
def _arrival(x, y, z, rmin, t_n, hint, listener_times, listener_pos, listener_vel, c0):
    """Reception time a of the emission at t_n from (x, y, z), with the distance
    D(a), dD/dt(a) and the capture interval s holding a.

    On a capture interval the listener moves linearly, L(t) = L_s + V (t - t_s),
    so c0 (a - t_n) = |L(a) - x| is a quadratic in u = a - t_n with one
    positive root: exact, no iteration.  ``hint`` is the interval of an
    earlier knot's arrival of the same source (arrivals increase with n), or
    of t_n, or -1.  The interval holding a is found first by a galloping
    search over the captures (O(log) of the captures passed, not one root
    per interval): the sound emitted at t_n reaches the listener after
    capture k iff the emission heard at k, τ_k = t_k - max(|L_k - x|, rmin)/c0,
    is not later than t_n (τ_k increases with k: the listener is slower than
    sound).
    """
    m = listener_times.size
    c2 = c0 * c0
    s = _segment(listener_times, t_n, hint if hint >= 0 else 0)
    if hint > s:
        s = hint
    if s < m - 1 and _heard_at(x, y, z, rmin, listener_times, listener_pos, c0, s + 1) <= t_n:
        # the arrival is past capture s + 1: gallop, then bisect, for the
        # last capture k with τ_k <= t_n (the arrival's interval is k)
        lo = s + 1
        step = 1
        hi = lo + step
        while hi <= m - 1 and _heard_at(x, y, z, rmin, listener_times, listener_pos, c0, hi) <= t_n:
            lo = hi
            step *= 2
            hi = lo + step
        if hi > m - 1:
            hi = m
            if _heard_at(x, y, z, rmin, listener_times, listener_pos, c0, m - 1) <= t_n:
                lo = m - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if _heard_at(x, y, z, rmin, listener_times, listener_pos, c0, mid) <= t_n:
                lo = mid
            else:
                hi = mid
        s = lo
    a = t_n
    d = 0.0
    dd = 0.0
    while True:
        if s < 0:
            lx, ly, lz = listener_pos[0, 0], listener_pos[0, 1], listener_pos[0, 2]
            vx = vy = vz = 0.0
            ts = t_n
        elif s >= m - 1:
            lx, ly, lz = listener_pos[m - 1, 0], listener_pos[m - 1, 1], listener_pos[m - 1, 2]
            vx = vy = vz = 0.0
            ts = t_n
        else:
            lx, ly, lz = listener_pos[s, 0], listener_pos[s, 1], listener_pos[s, 2]
            vx, vy, vz = listener_vel[s, 0], listener_vel[s, 1], listener_vel[s, 2]
            ts = listener_times[s]
        # P = L(t_n) - x on this interval's line
        px = lx + vx * (t_n - ts) - x
        py = ly + vy * (t_n - ts) - y
        pz = lz + vz * (t_n - ts) - z
        pv = px * vx + py * vy + pz * vz
        pp = px * px + py * py + pz * pz
        den = c2 - (vx * vx + vy * vy + vz * vz)
        u = (pv + math.sqrt(pv * pv + den * pp)) / den
        a = t_n + u
        # move to the next interval if the root lies beyond this one
        if s < m - 1 and a >= listener_times[s + 1]:
            s += 1
            continue
        dx, dy, dz = px + vx * u, py + vy * u, pz + vz * u
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if d <= rmin:
            d = rmin
            dd = 0.0
            a = t_n + rmin / c0
            s = _segment(listener_times, a, s)
        else:
            dd = (dx * vx + dy * vy + dz * vz) / d
        return a, d, dd, s


@numba.njit(inline="always", **_NJIT)
def _line_arrival(x, y, z, rm, line_pos, line_vel, t_n, inv_den, den, c0, inv_c0):
    """Arrival a, distance D (clamped to rm) and D·dD/dt of the emission at
    knot time t_n from (x, y, z), the listener on the line L + V (t - t_n)
    (``line_pos`` L and ``line_vel`` V, 3-tuples; see :func:`_arrival`;
    den = c0² - V²); branch-free, no division (the caller divides by D)."""
    lx, ly, lz = line_pos
    vx, vy, vz = line_vel
    qx = lx - x
    qy = ly - y
    qz = lz - z
    pv = qx * vx + qy * vy + qz * vz
    pp = qx * qx + qy * qy + qz * qz
    vv = vx * vx + vy * vy + vz * vz
    u = (pv + math.sqrt(pv * pv + den * pp)) * inv_den
    d = c0 * u
    clamp = d <= rm
    ddd = where(clamp, 0.0, pv + vv * u)
    d = where(clamp, rm, d)
    u = where(clamp, rm * inv_c0, u)
    return t_n + u, d, ddd


#: columns of one candidate line in a row of the line table (see _row_lines)
_LINE = 12


@numba.njit(**_NJIT_NORC)
def _row_lines(tn, listener_times, listener_pos, listener_vel, c0, d_max, n_lo, n_hi, row_lines):
    """Per knot row n, two candidate lines of the listener for the arrivals of
    the emissions at t_n: the capture interval s holding t_n and the next one.

    Per line (columns j·_LINE ...): the listener's position at t_n on the
    line, its velocity, t_n, the interval [t_lo, t_hi) where the line is the
    path, 1/(c0² - V²), c0² - V², and s (before the first capture and after
    the last the listener is held: V = 0).  An arrival solved on a line
    counts only if it falls in the line's interval.  Column 2·_LINE is 1 when
    an arrival can fall beyond the first line (t_n + D_max/c0 past its end),
    else 0 (the second line is then not solved).
    """
    m = listener_times.size
    s = 0
    for n in range(n_lo, n_hi + 1):
        t_n = tn[n]
        s = _segment(listener_times, t_n, max(s, 0))
        for j in range(2):
            sj = s + j
            o = j * _LINE
            if sj < 0:
                lx, ly, lz = listener_pos[0, 0], listener_pos[0, 1], listener_pos[0, 2]
                vx = vy = vz = 0.0
                t_lo, t_hi = -np.inf, listener_times[0]
            elif sj >= m - 1:
                lx, ly, lz = listener_pos[m - 1, 0], listener_pos[m - 1, 1], listener_pos[m - 1, 2]
                vx = vy = vz = 0.0
                t_lo, t_hi = listener_times[m - 1], np.inf
            else:
                dt = t_n - listener_times[sj]
                vx, vy, vz = listener_vel[sj, 0], listener_vel[sj, 1], listener_vel[sj, 2]
                lx, ly, lz = (
                    listener_pos[sj, 0] + vx * dt,
                    listener_pos[sj, 1] + vy * dt,
                    listener_pos[sj, 2] + vz * dt,
                )
                t_lo, t_hi = listener_times[sj], listener_times[sj + 1]
            if sj > m - 1:  # no such line
                t_lo = t_hi = np.inf
            den = c0 * c0 - (vx * vx + vy * vy + vz * vz)
            row_lines[n, o + 0] = lx
            row_lines[n, o + 1] = ly
            row_lines[n, o + 2] = lz
            row_lines[n, o + 3] = vx
            row_lines[n, o + 4] = vy
            row_lines[n, o + 5] = vz
            row_lines[n, o + 6] = t_n
            row_lines[n, o + 7] = t_lo
            row_lines[n, o + 8] = t_hi
            row_lines[n, o + 9] = 1.0 / den
            row_lines[n, o + 10] = den
            row_lines[n, o + 11] = sj
            if j == 0:
                row_lines[n, 2 * _LINE] = 1.0 if t_n + d_max / c0 >= t_hi else 0.0


@numba.njit(inline="always", **_NJIT)
def _line_tuple(R, o):
    return (
        R[o],
        R[o + 1],
        R[o + 2],
        R[o + 3],
        R[o + 4],
        R[o + 5],
        R[o + 6],
        R[o + 7],
        R[o + 8],
        R[o + 9],
        R[o + 10],
        R[o + 11],
    )


@numba.njit(inline="always", **_NJIT)
def _knot_arrival(x, y, z, rm, la, lb, c0, inv_c0, two):
    """Arrival, D, D·dD/dt and capture interval of one knot, solved on both
    candidate lines la, lb (tuples of a _row_lines row; lb only if ``two``)
    and taken from the one whose interval holds it; ``found`` False when
    neither does (branch-free)."""
    a1, d1, e1 = _line_arrival(
        x, y, z, rm, (la[0], la[1], la[2]), (la[3], la[4], la[5]), la[6], la[9], la[10], c0, inv_c0
    )
    ok1 = (a1 >= la[7]) & (a1 < la[8])
    if not two:
        return a1, d1, e1, la[11], ok1
    a2, d2, e2 = _line_arrival(
        x, y, z, rm, (lb[0], lb[1], lb[2]), (lb[3], lb[4], lb[5]), lb[6], lb[9], lb[10], c0, inv_c0
    )
    ok2 = (a2 >= lb[7]) & (a2 < lb[8])
    a = where(ok1, a1, a2)
    d = where(ok1, d1, d2)
    e = where(ok1, e1, e2)
    sg = where(ok1, la[11], lb[11])
    return a, d, e, sg, ok1 | ok2


@numba.njit(inline="always", **_NJIT)
def _listener_at(a, sg, la, lb):
    """Listener position at arrival a on the candidate line (la or lb) of
    capture interval sg (branch-free)."""
    sel = sg == la[11]
    x = where(sel, la[0] + la[3] * (a - la[6]), lb[0] + lb[3] * (a - lb[6]))
    y = where(sel, la[1] + la[4] * (a - la[6]), lb[1] + lb[4] * (a - lb[6]))
    z = where(sel, la[2] + la[5] * (a - la[6]), lb[2] + lb[5] * (a - lb[6]))
    return x, y, z


@numba.njit(inline="always", **_NJIT)
def _fval(qv, dq, d, dd, c0):
    """f = q(τ)/D and df/dt with τ = t - D/c0 (per data second)."""
    inv = 1.0 / d
    return qv * inv, (dq * (1.0 - dd / c0) - qv * dd * inv) * inv
