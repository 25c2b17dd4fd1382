"""The compiled kernels of the emitters engine's sampled backend
(:mod:`auralize.emitters._sampled`, where the method is described): audio-rate point
emitters heard along the listener's path.

:func:`render` evaluates, per emitter, the retarded time, distance law, dipole
projection and panning gains at control points every ``K`` samples
(:func:`_point`), and reads the emitted signal at the emission index, the cubic
Hermite interpolant of the retarded time between them (:func:`_segment`; table
emitters: :func:`_seg_table`).  Its arguments come in named bundles:
:class:`Sources`, :class:`ControlPoints`, :class:`Speakers`, :class:`Tables`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba
import numpy as np

from auralize.emitters._kernels.common import _NJIT, _NJIT_NORC, where
from auralize.emitters._kernels.emission import PointRows, _seg_table, _segment, _tab_weights
from auralize.emitters._kernels.gains import _gains

#: blocks per chunk: a chunk's output stays in cache while every emitter adds to it
CHUNK_BLOCKS = 64

#: The emitters: signals ``sig (S, C, n_e)`` at ``fs`` samples per second from playback
#: second ``t_sig``, positions ``pos (S, m, 3)`` at ``pos_rate`` from ``t_pos`` (m = 1:
#: static), clamp radii ``(S,)`` and the distance law's exponent.
Sources = namedtuple(
    "Sources", ["sig", "fs", "t_sig", "pos", "pos_rate", "t_pos", "radius", "exponent"]
)
#: The listener at the control points ``times (B+1,)``: position, velocity on the path
#: segment after and before, forward and up there; per block, the fractional sample of
#: a listener capture inside it (``kink``, -1 for none) and the listener at that
#: capture (time, position, forward, up).
ControlPoints = namedtuple(
    "ControlPoints",
    [
        "times",
        "pos",
        "vel_after",
        "vel_before",
        "forward",
        "up",
        "kink",
        "kink_time",
        "kink_pos",
        "kink_forward",
        "kink_up",
    ],
)
#: The layout's panning: speaker azimuths (sorted) and channels, whether rear
#: directions fold to the front, and the pair, triangle or harmonic table (see
#: :func:`auralize.emitters._kernels.gains._gains`); no speakers: unpanned.
Speakers = namedtuple("Speakers", ["az", "ch", "fold", "table"])


@numba.njit(inline="always", **_NJIT)
def _position(pos, s, u):
    """Trajectory of emitter s at fractional sample u (linear, held at the ends)."""
    m = pos.shape[1]
    if m == 1 or u <= 0.0:
        return pos[s, 0, 0], pos[s, 0, 1], pos[s, 0, 2]
    if u >= m - 1:
        return pos[s, m - 1, 0], pos[s, m - 1, 1], pos[s, m - 1, 2]
    i = int(u)
    w = u - i
    return (
        pos[s, i, 0] + w * (pos[s, i + 1, 0] - pos[s, i, 0]),
        pos[s, i, 1] + w * (pos[s, i + 1, 1] - pos[s, i, 1]),
        pos[s, i, 2] + w * (pos[s, i + 1, 2] - pos[s, i, 2]),
    )


@numba.njit(inline="always", **_NJIT)
def _velocity(pos, s, u, pos_rate):
    """Velocity (m/s) of emitter s's trajectory at fractional sample u (0 where held)."""
    m = pos.shape[1]
    if m == 1 or u < 0.0 or u >= m - 1:
        return 0.0, 0.0, 0.0
    i = int(u)
    return (
        (pos[s, i + 1, 0] - pos[s, i, 0]) * pos_rate,
        (pos[s, i + 1, 1] - pos[s, i, 1]) * pos_rate,
        (pos[s, i + 1, 2] - pos[s, i, 2]) * pos_rate,
    )


@numba.njit(inline="always", **_NJIT)
def _newton(pos, s, pos_rate, t_pos, t, lx, ly, lz, tau, inv_c0):
    """One Newton step for the retarded time of moving emitter s heard at (t, L) from ``tau``.

    f(τ) = τ − t + D(τ)/c0 has f' = 1 + n_d·v/c0 >= 1 − Mach > 0 (n_d the unit
    vector from the listener to the emitter).  Returns the new τ and whether
    it is converged: a step under 1e-7 s that stays on the trajectory segment
    where f' was taken (f'' is at most v²/(D c0) there, so the error left is
    under about 1e-12 s for emitters slower than 100 m/s at 5 cm).
    """
    u = (tau - t_pos) * pos_rate
    x, y, z = _position(pos, s, u)
    vx, vy, vz = _velocity(pos, s, u, pos_rate)
    dx, dy, dz = x - lx, y - ly, z - lz
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    f = tau - t + d * inv_c0
    step = f  # f' = 1 at the listener
    if d > 0.0:  # f / f' = f d / (d + n_d·v d / c0)
        step = f * d / (d + (dx * vx + dy * vy + dz * vz) * inv_c0)
    tau -= step
    return tau, abs(step) < 1e-7 and int((tau - t_pos) * pos_rate) == int(u)


@numba.njit(inline="always", **_NJIT)
def _retarded(pos, s, pos_rate, t_pos, t, lx, ly, lz, tau, inv_c0):
    """Retarded time of moving emitter s heard at (t, L): Newton's method from ``tau``
    (:func:`_newton` until converged)."""
    for _ in range(60):
        tau, done = _newton(pos, s, pos_rate, t_pos, t, lx, ly, lz, tau, inv_c0)
        if done:
            break
    return tau


@numba.njit(inline="always", **_NJIT)
def _rate(dx, dy, dz, inv_dt, vl, sx, sy, sz, inv_c0):
    """dτ/dt for emitter-minus-listener (dx, dy, dz) of inverse length ``inv_dt`` (0: the
    emitter at the listener), velocities vl, s."""
    if inv_dt == 0.0:
        return 1.0
    k = -inv_c0 * inv_dt  # n = -(dx, dy, dz) / dt
    num = 1.0 - k * (dx * vl[0] + dy * vl[1] + dz * vl[2])
    den = 1.0 - k * (dx * sx + dy * sy + dz * sz)
    return num / den


@numba.njit(inline="always", **_NJIT)
def _point(n_comp, src, s, inv_c0, moving, solve, at, tau, spk, w, g, j):
    """Emitter s of ``src`` (:class:`Sources`; ``n_comp`` signal components) heard at
    time t by a listener at L with forward f, up u: ``at`` = (t, L, f, u), 10 values.

    Writes the amplitude weights ``w[j]`` (1/D^e, times the unit vector from
    the emitter to the listener for a dipole) and panning gains ``g[j]``;
    returns the emission index, the retarded time, the emitter-minus-listener
    vector and its inverse length (0 at the emitter), and the emitter's velocity.  ``tau``: for a moving
    emitter, a guess Newton's method starts from (``solve``), or the result of
    one Newton step (not ``solve``): the next step, taken from the quantities
    evaluated here anyway, converges it (as :func:`_newton`; the position moves
    along the trajectory's segment), else Newton's method continues.  ``spk``: the
    layout's :class:`Speakers`.
    """
    t, lx, ly, lz, fx, fy, fz, ux, uy, uz = at
    pos, pos_rate, t_pos = src.pos, src.pos_rate, src.t_pos
    radius, exponent = src.radius, src.exponent
    if moving:
        if solve:
            tau = _retarded(pos, s, pos_rate, t_pos, t, lx, ly, lz, tau, inv_c0)
        for _ in range(2):
            u = (tau - t_pos) * pos_rate
            x, y, z = _position(pos, s, u)
            sx, sy, sz = _velocity(pos, s, u, pos_rate)
            dx, dy, dz = x - lx, y - ly, z - lz
            dt = math.sqrt(dx * dx + dy * dy + dz * dz)
            if solve:
                break
            step = tau - t + dt * inv_c0
            if dt > 0.0:
                step = step * dt / (dt + (dx * sx + dy * sy + dz * sz) * inv_c0)
            if abs(step) < 1e-7 and int((tau - step - t_pos) * pos_rate) == int(u):
                # the step taken: the trajectory is linear on the segment
                tau -= step
                x, y, z = x - sx * step, y - sy * step, z - sz * step
                dx, dy, dz = x - lx, y - ly, z - lz
                dt = math.sqrt(dx * dx + dy * dy + dz * dz)
                break
            tau = _retarded(pos, s, pos_rate, t_pos, t, lx, ly, lz, tau - step, inv_c0)
            solve = True
    else:
        x, y, z = pos[s, 0, 0], pos[s, 0, 1], pos[s, 0, 2]
        sx, sy, sz = 0.0, 0.0, 0.0
        dx, dy, dz = x - lx, y - ly, z - lz
        dt = math.sqrt(dx * dx + dy * dy + dz * dz)
    tau = t - dt * inv_c0
    inv_dt = where(dt > 0.0, 1.0 / dt, 0.0)
    if exponent == 1.0:
        amp = where(dt >= radius[s], inv_dt, 1.0 / radius[s])
    else:
        amp = max(dt, radius[s]) ** (-exponent)
    if n_comp == 1:
        w[j, 0] = amp
    elif dt > 0.0:
        a = amp * inv_dt
        w[j, 0] = -dx * a
        w[j, 1] = -dy * a
        w[j, 2] = -dz * a
    else:
        w[j, 0] = 0.0
        w[j, 1] = 0.0
        w[j, 2] = 0.0
    if g.shape[1] > 1:
        _gains((dx, dy, dz), (fx, fy, fz, ux, uy, uz), spk.az, spk.ch, spk.fold, spk.table, g[j])
    return (tau - src.t_sig) * src.fs, tau, dx, dy, dz, inv_dt, sx, sy, sz


@numba.njit(**_NJIT_NORC, fastmath={"contract"})
def render(src, lis, spk, tables, c0, K, off, out, scratch, b0, b1):
    """Add the emitters heard in blocks ``b0 <= b < b1`` to ``out (n_ch, n)``.

    ``src``: the emitters (:class:`Sources`: signals ``(S, C, n_e)``, C = 1 monopole,
    3 dipole G); ``lis``: the listener at the control points (:class:`ControlPoints`);
    ``spk``: the layout (:class:`Speakers`); ``tables``: table emitters
    (:class:`Tables`); block b covers output samples ``b·K − off`` to
    ``(b+1)·K − off``.  The emission
    index is the cubic Hermite interpolant of the retarded time and its rate
    ``dτ/dt = (1 − n·v_L/c0) / (1 − n·v_s/c0)`` (n the unit vector from the
    emitter to the listener) at the block's ends; weights and gains are
    interpolated linearly.  A block holding a listener capture (a kink of the
    listener's path, ``lis.kink``) is split there into two linear pieces.  Blocks of different ranges write disjoint
    samples (threads share ``out``); ``scratch`` is the call's own working
    memory (:func:`auralize.emitters._sampled.scratch`), as the kernel allocates nothing.

    The retarded times of a chunk of control points are found together, each
    pass over the chunk independent point by point (the processor overlaps
    them): the emitter's place at t gives the first guess, one Newton step
    follows, and :func:`_point` checks convergence with the quantities it
    evaluates there; the few points not converged then (a step across a
    trajectory sample) continue alone.

    ``tables.gen``: the emitters are table emitters (``src.sig`` is not read): each
    sample evaluates the signal at its emission index (:func:`_seg_table`).
    """
    sig, fs, pos, pos_rate, t_pos = src.sig, src.fs, src.pos, src.pos_rate, src.t_pos
    tb, L, VR, VL, F, U = lis.times, lis.pos, lis.vel_after, lis.vel_before, lis.forward, lis.up
    kf, tk, Lk, Fk, Uk = lis.kink, lis.kink_time, lis.kink_pos, lis.kink_forward, lis.kink_up
    gen, qa, qb, r0, gK = tables.gen, tables.qa, tables.qb, tables.r0, tables.block
    if gen:
        S = qa.shape[0]
        C = qa.shape[2]
        n_e = r0.shape[1] * gK
    else:
        S, C, n_e = sig.shape
    n_ch, n = out.shape
    moving = pos.shape[1] > 1
    ginv = 1.0 / gK
    inv_c0 = 1.0 / c0
    CB = CHUNK_BLOCKS
    # the scratch (:func:`auralize.emitters._sampled.scratch`): chunk-long control-point
    # arrays, their weights and gains, then a piece's samples
    CW = C + qa.shape[3]
    o = 0
    xe, o = scratch[o : o + CB + 1], o + CB + 1
    ma, o = scratch[o : o + CB + 1], o + CB + 1
    mb, o = scratch[o : o + CB + 1], o + CB + 1
    tq, o = scratch[o : o + CB + 1], o + CB + 1
    xk, o = scratch[o : o + CB], o + CB
    w, o = scratch[o : o + (CB + 1) * CW].reshape((CB + 1, CW)), o + (CB + 1) * CW
    g, o = scratch[o : o + (CB + 1) * n_ch].reshape((CB + 1, n_ch)), o + (CB + 1) * n_ch
    wk, o = scratch[o : o + CB * CW].reshape((CB, CW)), o + CB * CW
    gk, o = scratch[o : o + CB * n_ch].reshape((CB, n_ch)), o + CB * n_ch
    g[:, :] = 0.0
    gk[:, :] = 0.0
    vbuf = scratch[o : o + K]
    rows = PointRows(w, wk, g, gk)
    last = n_e - 1
    for cb0 in range(b0, b1, CB):
        cb1 = min(cb0 + CB, b1)
        nb = cb1 - cb0 + 1
        for s in range(S):
            if moving:  # retarded times of the chunk's control points
                for j in range(nb):
                    b = cb0 + j
                    t = tb[b]
                    x, y, z = _position(pos, s, (t - t_pos) * pos_rate)
                    tq[j] = (
                        t
                        - math.sqrt((L[b, 0] - x) ** 2 + (L[b, 1] - y) ** 2 + (L[b, 2] - z) ** 2)
                        * inv_c0
                    )
                for j in range(nb):
                    b = cb0 + j
                    tq[j], _ = _newton(
                        pos, s, pos_rate, t_pos, tb[b], L[b, 0], L[b, 1], L[b, 2], tq[j], inv_c0
                    )
            for b in range(cb0, cb1 + 1):
                j = b - cb0
                t = tb[b]
                at = (
                    t,
                    L[b, 0],
                    L[b, 1],
                    L[b, 2],
                    F[b, 0],
                    F[b, 1],
                    F[b, 2],
                    U[b, 0],
                    U[b, 1],
                    U[b, 2],
                )
                xe[j], tau, dx, dy, dz, idt, sx, sy, sz = _point(
                    C, src, s, inv_c0, moving, False, at, tq[j], spk, w, g, j
                )
                if gen:
                    _tab_weights(qa, qb, s, xe[j], w, j, ginv)
                # dτ/dt on both sides (the listener's velocity may jump at a
                # capture), in signal samples per block
                r = _rate(dx, dy, dz, idt, VR[b], sx, sy, sz, inv_c0)
                if b < cb1:
                    ma[j] = (tb[b + 1] - t) * fs * r
                if b > cb0:
                    if VL[b, 0] != VR[b, 0] or VL[b, 1] != VR[b, 1] or VL[b, 2] != VR[b, 2]:
                        r = _rate(dx, dy, dz, idt, VL[b], sx, sy, sz, inv_c0)
                    mb[j] = (t - tb[b - 1]) * fs * r
                if b < cb1 and kf[b] >= 0.0:  # a capture inside the block
                    at = (
                        tk[b],
                        Lk[b, 0],
                        Lk[b, 1],
                        Lk[b, 2],
                        Fk[b, 0],
                        Fk[b, 1],
                        Fk[b, 2],
                        Uk[b, 0],
                        Uk[b, 1],
                        Uk[b, 2],
                    )
                    xk[j], _, _, _, _, _, _, _, _ = _point(
                        C, src, s, inv_c0, moving, True, at, tau + (tk[b] - t), spk, wk, gk, j
                    )
                    if gen:
                        _tab_weights(qa, qb, s, xk[j], wk, j, ginv)
            for b in range(cb0, cb1):
                j = b - cb0
                xa = xe[j]
                xb = xe[j + 1]
                if (xa < -1.0 and xb < -1.0) or (xa > last + 1.0 and xb > last + 1.0):
                    continue  # silent block
                n0 = b * K - off
                i_lo = max(0, -n0)
                i_hi = min(K, n - n0)
                if i_lo >= i_hi:
                    continue
                kj = kf[b]
                ik = min(max(int(math.ceil(kj)), i_lo), i_hi)
                # one piece (cubic Hermite emission index), or two linear pieces on both
                # sides of a capture; one call site each keeps the kernel small
                for q in range(1 if kj < 0.0 else 2):
                    if kj < 0.0:
                        lo, hi, p0, p1, x0, h1 = i_lo, i_hi, 0.0, float(K), xa, ma[j]
                        h2 = 3.0 * (xb - xa) - 2.0 * ma[j] - mb[j + 1]
                        h3 = 2.0 * (xa - xb) + ma[j] + mb[j + 1]
                        ja, jb, ka, kb = j, j + 1, False, False
                    elif q == 0:
                        lo, hi, p0, p1, x0, h1, h2, h3 = i_lo, ik, 0.0, kj, xa, xk[j] - xa, 0.0, 0.0
                        ja, jb, ka, kb = j, j, False, True
                    else:
                        lo, hi, p0, p1, x0, h1 = ik, i_hi, kj, float(K), xk[j], xb - xk[j]
                        h2 = h3 = 0.0
                        ja, jb, ka, kb = j, j + 1, True, False
                    if hi <= lo:
                        continue
                    part, index, ends = (n0, lo, hi, p0, p1), (x0, h1, h2, h3), (ja, jb, ka, kb)
                    if gen:
                        _seg_table(tables, s, vbuf, out, part, index, ends, rows)
                    else:
                        _segment(sig, s, last, vbuf, out, part, index, ends, rows)


@numba.njit(**_NJIT)
def bounding_box(a, b):
    """Lower and upper corners ``(3,)`` of the points ``a (N, 3)`` and ``b (M, 3)``."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for p in (a, b):
        for i in range(p.shape[0]):
            for k in range(3):
                v = p[i, k]
                lo[k] = min(lo[k], v)
                hi[k] = max(hi[k], v)
    return lo, hi
