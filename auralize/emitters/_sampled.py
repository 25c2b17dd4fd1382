"""Sampled backend of the emitters engine: audio-rate point emitters, compiled.

For every emitter the smooth quantities of the received sum (paper 003
§3.2.4.2 for the retarded time; far-field point-source law, paper 000 §6,
Eq. 5 and paper 004 §6, Eq. 4)

    p(t) = Σ_s  a_s(τ_s) · g(D_s),   t − τ_s = |L(t) − x_s(τ_s)| / c0

are evaluated at *control points* every ``K`` samples of the evaluation rate:
the retarded time τ (Newton's method for a moving emitter, from the delay of
the emitter's place at t) and its rate ``dτ/dt = (1 − n·v_L/c0) / (1 − n·v_s/c0)``, the clamped
distance law ``1/D^e`` (the delay uses the unclamped distance), a dipole's
projection on the unit vector n from the emitter to the listener, and the
layout's panning gains (the synthesis kernel's own law,
:func:`auralize.emitters._kernels.gains._gains`: pairwise 2-D VBAP, 3-D VBAP for
layouts with elevation, the AmbiX encoding for ``ambix1..3``; equal to
:func:`auralize.spatial.layouts.pan_gains`).  Inside
a block the emission index is the cubic Hermite interpolant of τ and dτ/dt,
the weights and gains are interpolated linearly; a block holding a listener
capture (where the listener's velocity jumps) is split there into two linear
pieces.  The emitted signal is read linearly at the emission index, weighted
and added to the channels with non-zero gains.  Table emitters
(:class:`auralize.emitters.TableEmitters`) are evaluated at the emission index
itself: inside each of their table blocks the table position is linear in the
index (exact) and the weights of the table components are taken linear
through their values at the block's ends and at the control points; the
index advances by forward differences of its cubic.  Against the per-sample numpy
reference (:mod:`auralize.emitters.reference`) this is within about 1e-4 of
the peak in mono and 1e-3 panned (the gains have kinks at speaker
directions) for a turning, moving listener and emitters at tens of m/s.

Control points lie on a grid fixed in playback time (multiples of ``K``
evaluation samples), so a render split into consecutive windows gives the
same samples as one render: live playback renders block by block.

Emitters sampled well below the output rate are first upsampled band-limited
(at most ``oversample`` ×) and, when the output rate is an integer multiple
of that, evaluated at the lower *internal rate* and resampled band-limited to
the output rate (the signal holds nothing above its own Nyquist frequency, so
the anti-imaging filter is short).  The output blocks are split between up to
two threads (the kernel releases the GIL) over disjoint ranges of samples.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from auralize.emitters._kernels.common import _NJIT_NORC
from auralize.emitters._kernels.gains import _gains
from auralize.emitters.parallel import N_THREADS, run_pieces
from auralize.runtime.jit import configure as _configure_numba
from auralize.runtime.jit import kernel_arg, kernel_args

_configure_numba()  # cache folder, OMP wait policy, compile notice

_NJIT = {"cache": True, "nogil": True, "error_model": "numpy"}

#: evaluation samples between control points
BLOCK = 32
#: blocks per chunk: a chunk's output stays in cache while every emitter adds to it
_CHUNK_BLOCKS = 64
#: evaluation samples below which one thread does all the work
_MIN_SPLIT = 16384
_N_THREADS = N_THREADS


@numba.njit(inline="always", **_NJIT)
def _position(pos, s, u):  # type: ignore[no-untyped-def]
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
def _velocity(pos, s, u, pos_rate):  # type: ignore[no-untyped-def]
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
def _newton(pos, s, pos_rate, t_pos, t, lx, ly, lz, tau, inv_c0):  # type: ignore[no-untyped-def]
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
def _retarded(pos, s, pos_rate, t_pos, t, lx, ly, lz, tau, inv_c0):  # type: ignore[no-untyped-def]
    """Retarded time of moving emitter s heard at (t, L): Newton's method from ``tau``
    (:func:`_newton` until converged)."""
    for _ in range(60):
        tau, done = _newton(pos, s, pos_rate, t_pos, t, lx, ly, lz, tau, inv_c0)
        if done:
            break
    return tau


@numba.njit(inline="always", **_NJIT)
def _rate(dx, dy, dz, inv_dt, vl, sx, sy, sz, inv_c0):  # type: ignore[no-untyped-def]
    """dτ/dt for emitter-minus-listener (dx, dy, dz) of inverse length ``inv_dt`` (0: the
    emitter at the listener), velocities vl, s."""
    if inv_dt == 0.0:
        return 1.0
    k = -inv_c0 * inv_dt  # n = -(dx, dy, dz) / dt
    num = 1.0 - k * (dx * vl[0] + dy * vl[1] + dz * vl[2])
    den = 1.0 - k * (dx * sx + dy * sy + dz * sz)
    return num / den


@numba.njit(inline="always", **_NJIT)
def _point(sig_c, pos, s, pos_rate, t_pos, radius, exponent, inv_c0, moving, solve, t, lx, ly, lz,
           fx, fy, fz, ux, uy, uz, tau, t_sig, fs, spk_az, spk_ch, fold, pinv, w, g, j):  # type: ignore[no-untyped-def]  # fmt: skip
    """Emitter s heard at time t by a listener at L with forward f, up u.

    Writes the amplitude weights ``w[j]`` (1/D^e, times the unit vector from
    the emitter to the listener for a dipole) and panning gains ``g[j]``;
    returns the emission index, the retarded time, the emitter-minus-listener
    vector and its inverse length (0 at the emitter), and the emitter's velocity.  ``tau``: for a moving
    emitter, a guess Newton's method starts from (``solve``), or the result of
    one Newton step (not ``solve``): the next step, taken from the quantities
    evaluated here anyway, converges it (as :func:`_newton`; the position moves
    along the trajectory's segment), else Newton's method continues.
    """
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
    inv_dt = 1.0 / dt if dt > 0.0 else 0.0
    if exponent == 1.0:
        amp = inv_dt if dt >= radius[s] else 1.0 / radius[s]
    else:
        amp = max(dt, radius[s]) ** (-exponent)
    if sig_c == 1:
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
        _gains((dx, dy, dz), (fx, fy, fz, ux, uy, uz), spk_az, spk_ch, fold, pinv, g[j])
    return (tau - t_sig) * fs, tau, dx, dy, dz, inv_dt, sx, sy, sz


@numba.njit(inline="always", **_NJIT)
def _scatter(out, vbuf, n0, i_lo, i_hi, p0, inv, g, ja, ka, gk, jb, kb):  # type: ignore[no-untyped-def]  # fmt: skip
    """Add ``vbuf[i]`` (``i_lo <= i < i_hi``) to the channels of ``out[:, n0 + i]`` with
    the panning gains linear from row ``ja`` of ``g`` (or of ``gk`` if ``ka``) at sample
    ``p0`` to row ``jb`` likewise at ``p0 + 1 / inv``."""
    for c in range(out.shape[0]):
        ga = gk[ja, c] if ka else g[ja, c]
        gb = gk[jb, c] if kb else g[jb, c]
        if ga == 0.0 and gb == 0.0:  # a silent channel only ever adds 0
            continue
        dg = (gb - ga) * inv
        for i in range(i_lo, i_hi):
            out[c, n0 + i] += (ga + dg * (i - p0)) * vbuf[i]


@numba.njit(inline="always", **_NJIT)
def _segment(sig, s, last, vbuf, out, n0, i_lo, i_hi, p0, p1, x0, h1, h2, h3, w, ja, jb, wk, ka,
             kb, g, gk):  # type: ignore[no-untyped-def]  # fmt: skip
    """Samples ``i_lo <= i < i_hi`` of a block between positions p0 and p1 (samples):
    emission index ``x0 + u (h1 + u (h2 + u h3))`` with u = (i − p0)/(p1 − p0), weights
    and gains linear from row ``ja`` of (w, g) or, if ``ka``, from row ``ja`` of
    (wk, gk); to row ``jb`` likewise with ``kb``.  Adds to ``out[:, n0 + i]``."""
    C = sig.shape[1]
    n_ch = out.shape[0]
    inv = 1.0 / (p1 - p0)
    wa0 = wk[ja, 0] if ka else w[ja, 0]
    dw0 = (wk[jb, 0] if kb else w[jb, 0]) - wa0
    wa1 = wa2 = dw1 = dw2 = 0.0
    if C == 3:
        wa1 = wk[ja, 1] if ka else w[ja, 1]
        wa2 = wk[ja, 2] if ka else w[ja, 2]
        dw1 = (wk[jb, 1] if kb else w[jb, 1]) - wa1
        dw2 = (wk[jb, 2] if kb else w[jb, 2]) - wa2
    # the emission index at both ends (the cubic is monotonic for subsonic motion)
    ua = (i_lo - p0) * inv
    ub = (i_hi - 1 - p0) * inv
    xa = x0 + ua * (h1 + ua * (h2 + ua * h3))
    xb = x0 + ub * (h1 + ub * (h2 + ub * h3))
    inside = min(xa, xb) >= 0.5 and max(xa, xb) <= last - 1.5
    sg0 = sig[s, 0]
    if inside and C == 1 and n_ch == 1:  # no bounds to check, straight to the output
        o = out[0]
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            i0 = int(xi)
            f = xi - i0
            a0 = sg0[i0]
            o[n0 + i] += (wa0 + u * dw0) * (a0 + f * (sg0[i0 + 1] - a0))
        return
    if inside and C == 1:  # no bounds to check
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            i0 = int(xi)
            f = xi - i0
            a0 = sg0[i0]
            vbuf[i] = (wa0 + u * dw0) * (a0 + f * (sg0[i0 + 1] - a0))
    elif inside and n_ch == 1:
        sg1 = sig[s, 1]
        sg2 = sig[s, 2]
        o = out[0]
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            i0 = int(xi)
            f = xi - i0
            a0 = sg0[i0]
            a1 = sg1[i0]
            a2 = sg2[i0]
            o[n0 + i] += (
                (wa0 + u * dw0) * (a0 + f * (sg0[i0 + 1] - a0))
                + (wa1 + u * dw1) * (a1 + f * (sg1[i0 + 1] - a1))
                + (wa2 + u * dw2) * (a2 + f * (sg2[i0 + 1] - a2))
            )
        return
    elif inside:
        sg1 = sig[s, 1]
        sg2 = sig[s, 2]
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            i0 = int(xi)
            f = xi - i0
            a0 = sg0[i0]
            a1 = sg1[i0]
            a2 = sg2[i0]
            vbuf[i] = (
                (wa0 + u * dw0) * (a0 + f * (sg0[i0 + 1] - a0))
                + (wa1 + u * dw1) * (a1 + f * (sg1[i0 + 1] - a1))
                + (wa2 + u * dw2) * (a2 + f * (sg2[i0 + 1] - a2))
            )
    else:  # near or beyond the signal's ends: zero outside [0, last]
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            v = 0.0
            if xi >= 0.0 and xi <= last:
                i0 = int(xi)
                f = xi - i0
                if i0 >= last:
                    i0 = last
                    f = 0.0
                i1 = min(i0 + 1, last)
                a0 = sig[s, 0, i0]
                v = (wa0 + u * dw0) * (a0 + f * (sig[s, 0, i1] - a0))
                if C == 3:
                    a1 = sig[s, 1, i0]
                    a2 = sig[s, 2, i0]
                    v += (wa1 + u * dw1) * (a1 + f * (sig[s, 1, i1] - a1))
                    v += (wa2 + u * dw2) * (a2 + f * (sig[s, 2, i1] - a2))
            vbuf[i] = v
    if n_ch == 1:
        for i in range(i_lo, i_hi):
            out[0, n0 + i] += vbuf[i]
        return
    _scatter(out, vbuf, n0, i_lo, i_hi, p0, inv, g, ja, ka, gk, jb, kb)


@numba.njit(inline="always", **_NJIT)
def _wrap(x, n):  # type: ignore[no-untyped-def]
    """x modulo n, in ``[0, n)`` (a table position on a looping row of n samples)."""
    y = x - math.floor(x / n) * n
    return y if 0.0 <= y < n else 0.0


@numba.njit(inline="always", **_NJIT)
def _row_pos(x, lf, r):  # type: ignore[no-untyped-def]
    """Table position x on row r (``lf`` as for :func:`_seg_table`), about in ``[0, length)``
    (the reads check)."""
    return x - math.floor(x * lf[r, 1]) * lf[r, 0]


@numba.njit(inline="always", **_NJIT)
def _cubic(x0, h1, h2, h3, u):  # type: ignore[no-untyped-def]
    """The emission index ``x0 + u (h1 + u (h2 + u h3))`` at fraction u of a piece."""
    return x0 + u * (h1 + u * (h2 + u * h3))


@numba.njit(inline="always", **_NJIT)
def _m_node(qa, qb, s, b, x, ginv, u, wa0, wa1, wa2, dw0, dw1, dw2, p):  # type: ignore[no-untyped-def]
    """Weight of table component p of table emitter s at emission index x, with the
    matrix of table block b (linear across it, extended past its ends) and the amplitude
    weights ``wa + u dw`` at fraction u of the output piece."""
    f = x * ginv - b
    q0 = qa[s, b, 0, p]
    m = (wa0 + u * dw0) * (q0 + f * (qb[s, b, 0, p] - q0))
    if qa.shape[2] == 3:
        q1 = qa[s, b, 1, p]
        q2 = qa[s, b, 2, p]
        m += (wa1 + u * dw1) * (q1 + f * (qb[s, b, 1, p] - q1))
        m += (wa2 + u * dw2) * (q2 + f * (qb[s, b, 2, p] - q2))
    return m


@numba.njit(inline="always", **_NJIT)
def _tab_weights(qa, qb, s, x, w, j, ginv):  # type: ignore[no-untyped-def]
    """Weights ``w[j, C + p]`` of the P table components of table emitter s at emission
    index x: its amplitude weights ``w[j, :C]`` applied to the matrix of the table block
    holding x (linear from ``qa`` to ``qb`` across the block; extended linearly past the
    emission's ends, where the signal is zero anyway)."""
    b = min(max(int(math.floor(x * ginv)), 0), qa.shape[1] - 1)
    f = x * ginv - b
    for p in range(qa.shape[3]):
        acc = 0.0
        for c in range(qa.shape[2]):
            q = qa[s, b, c, p]
            acc += w[j, c] * (q + f * (qb[s, b, c, p] - q))
        w[j, qa.shape[2] + p] = acc


@numba.njit(inline="always", **_NJIT)
def _node_line(qa, qb, s, b, gK, x0, X1, mA, mZ, iX, wa0, wa1, wa2, dw0, dw1, dw2, p):  # type: ignore[no-untyped-def]  # fmt: skip
    """The weight of table component p over the part of an output piece in table block b,
    linear in the emission index: ``(xl, ml, slope)`` through its values at the part's
    ends, the piece's ends (``mA`` at index ``x0``, ``mZ`` at ``X1``: the control points')
    where they lie in the block, else the block's ends (:func:`_m_node`)."""
    ginv = 1.0 / gK
    xbeg = b * gK
    xend = xbeg + gK
    if x0 <= X1:
        XL, XR, mL, mR = x0, X1, mA, mZ
    else:
        XL, XR, mL, mR = X1, x0, mZ, mA
    if XL >= xbeg:
        xl, ml = XL, mL
    else:
        xl = xbeg
        ml = _m_node(qa, qb, s, b, xl, ginv, (xl - x0) * iX, wa0, wa1, wa2, dw0, dw1, dw2, p)
    if XR < xend:
        xr, mr = XR, mR
    else:
        xr = xend
        mr = _m_node(qa, qb, s, b, xr, ginv, (xr - x0) * iX, wa0, wa1, wa2, dw0, dw1, dw2, p)
    return xl, ml, (mr - ml) / max(xr - xl, 1e-9)


@numba.njit(inline="always", **_NJIT)
def _read_row(tab, r, out, vbuf, n0, i0, i1, x, d, m0, s0, m1, s1, D1, D2, D3):  # type: ignore[no-untyped-def]  # fmt: skip
    """Samples ``i0 <= i < i1`` of a table emitter read from row r of ``tab`` without wrap:
    table position x and component weights m0, m1 advanced by ``d``, ``s0``, ``s1`` times
    the step ``D1`` of the emission index (forward differences ``D1, D2, D3`` of its
    cubic); added to ``out[0, n0 + i]`` (one channel) or written to ``vbuf[i]``."""
    if tab.shape[2] == 2 and out.shape[0] == 1:
        for i in range(i0, i1):
            k = int(x)
            fr = x - k
            a0 = tab[r, k, 0]
            a1 = tab[r, k, 1]
            out[0, n0 + i] += m0 * (a0 + fr * (tab[r, k + 1, 0] - a0)) + m1 * (
                a1 + fr * (tab[r, k + 1, 1] - a1))  # fmt: skip
            x += d * D1
            m0 += s0 * D1
            m1 += s1 * D1
            D1 += D2
            D2 += D3
        return
    for i in range(i0, i1):
        k = int(x)
        fr = x - k
        a0 = tab[r, k, 0]
        v = m0 * (a0 + fr * (tab[r, k + 1, 0] - a0))
        if tab.shape[2] == 2:
            a1 = tab[r, k, 1]
            v += m1 * (a1 + fr * (tab[r, k + 1, 1] - a1))
        if out.shape[0] == 1:
            out[0, n0 + i] += v
        else:
            vbuf[i] = v
        x += d * D1
        m0 += s0 * D1
        m1 += s1 * D1
        D1 += D2
        D2 += D3


@numba.njit(inline="always", **_NJIT)
def _row_at(tab, r, x, n):  # type: ignore[no-untyped-def]
    """Row r of ``tab`` (:func:`_seg_table`; ``n`` samples long) read linearly at table
    position x, wrapped: its components 0 and 1 (0.0 for a one-component table)."""
    if x >= n or x < 0.0:
        x = _wrap(x, n)
    k = int(x)
    fr = x - k
    a0 = tab[r, k, 0]
    g0 = a0 + fr * (tab[r, k + 1, 0] - a0)
    g1 = 0.0
    if tab.shape[2] == 2:
        a1 = tab[r, k, 1]
        g1 = a1 + fr * (tab[r, k + 1, 1] - a1)
    return g0, g1


@numba.njit(inline="always", **_NJIT)
def _seg_table(tab, lf, qa, qb, ph, r0, r1, wt, gK, s, vbuf, out, n0, i_lo, i_hi, p0, p1, x0,
               h1, h2, h3, w, ja, jb, wk, ka, kb, g, gk):  # type: ignore[no-untyped-def]  # fmt: skip
    """:func:`_segment` for table emitter s (:class:`auralize.emitters.TableEmitters`): its
    signal evaluated at the emission index itself, zero outside the emission, as stored
    samples.  Inside a table block the table position is linear in the emission index
    (exact) and so, taken, are the weights of the P table components (the amplitude
    weights, linear over the piece, times the block's matrix; exact at the piece's ends
    and at the table blocks' ends inside it; those at the control points follow the
    amplitude weights in the rows of ``w`` and ``wk``, :func:`_tab_weights`).  ``tab`` is
    padded
    (:attr:`auralize.emitters.TableEmitters.padded_table`: row r continues past its
    length with its own samples from 0); ``lf (R, 2)``: the rows' lengths and their
    inverses; ``ph (S, B + 1)``: the table positions at the blocks' ends.

    A piece inside the emission, on one row, across at most eight table blocks' ends and
    read inside the padding (the common case) runs without per-sample tests, block by
    block: the emission index by forward differences of its cubic, the table position and
    the weights advanced with it.  The choice is made on the whole piece, so that the samples do not
    depend on where a window cuts it.
    """
    P = tab.shape[2]
    n_ch = out.shape[0]
    nb = r0.shape[1]
    x_last = nb * gK - 1.0
    top = tab.shape[1] - 2.0  # a position below this reads inside the padding
    inv = 1.0 / (p1 - p0)
    ginv = 1.0 / gK
    wa0 = wk[ja, 0] if ka else w[ja, 0]
    dw0 = (wk[jb, 0] if kb else w[jb, 0]) - wa0
    wa1 = wa2 = dw1 = dw2 = 0.0
    if qa.shape[2] == 3:
        wa1 = wk[ja, 1] if ka else w[ja, 1]
        wa2 = wk[ja, 2] if ka else w[ja, 2]
        dw1 = (wk[jb, 1] if kb else w[jb, 1]) - wa1
        dw2 = (wk[jb, 2] if kb else w[jb, 2]) - wa2
    X1 = x0 + h1 + h2 + h3  # the emission index at the piece's end (u = 1)
    iX = 1.0 / (X1 - x0) if abs(X1 - x0) > 1e-12 else 0.0  # u of an index, linearly
    # the emission index at the piece's first and last samples, as if the piece were whole
    xa = _cubic(x0, h1, h2, h3, (math.ceil(p0) - p0) * inv)
    xb = _cubic(x0, h1, h2, h3, (math.ceil(p1) - 1 - p0) * inv)
    # the component weights at the piece's ends: the control points' (:func:`_tab_weights`)
    C = qa.shape[2]
    mA0 = wk[ja, C] if ka else w[ja, C]
    mZ0 = wk[jb, C] if kb else w[jb, C]
    mA1 = mZ1 = 0.0
    if P == 2:
        mA1 = wk[ja, C + 1] if ka else w[ja, C + 1]
        mZ1 = wk[jb, C + 1] if kb else w[jb, C + 1]
    fast = False
    ba = bz = ra = 0
    if 0.0 <= xa <= xb <= x_last:
        ba = int(xa * ginv)
        bz = min(int(xb * ginv), nb - 1)
        ra = r0[s, ba]
        fast = bz - ba <= 8
        for b in range(ba, bz + 1):
            if not fast:
                break
            # one row, read inside the padding over the piece's part in the block
            pr = _row_pos(ph[s, b], lf, ra)
            span = ph[s, b + 1] - ph[s, b]
            fast = (wt[s, b] == 0.0 and r0[s, b] == ra and pr + min(span, 0.0) >= 0.0
                    and pr + max(span, 0.0) < top)  # fmt: skip
    if fast:
        i0 = i_lo
        for b in range(ba, bz + 1):
            xbeg = b * gK
            xend = xbeg + gK
            # the samples up to the first at or past the block's end (from a linear guess)
            i1 = i_hi
            if b < bz:
                i1 = min(max(int(math.ceil(p0 + (xend - x0) * iX * (p1 - p0))), i0), i_hi)
                while i1 > i0 and _cubic(x0, h1, h2, h3, (i1 - 1 - p0) * inv) >= xend:
                    i1 -= 1
                while i1 < i_hi and _cubic(x0, h1, h2, h3, (i1 - p0) * inv) < xend:
                    i1 += 1
            if i1 <= i0:
                continue
            # weights linear in the index inside the block (:func:`_node_line`)
            xl, ml0, s0 = _node_line(qa, qb, s, b, gK, x0, X1, mA0, mZ0, iX, wa0, wa1, wa2, dw0,
                                     dw1, dw2, 0)  # fmt: skip
            ml1 = s1 = 0.0
            if P == 2:
                xl, ml1, s1 = _node_line(qa, qb, s, b, gK, x0, X1, mA1, mZ1, iX, wa0, wa1, wa2,
                                         dw0, dw1, dw2, 1)  # fmt: skip
            # the index at the first sample and its forward differences (exact for a cubic:
            # x(u + e) − x(u) and its differences, e the step in u of one sample); the
            # table position there, linear in the index inside the block
            u = (i0 - p0) * inv
            e = inv
            xi = _cubic(x0, h1, h2, h3, u)
            D1 = e * (h1 + h2 * (2.0 * u + e) + h3 * (3.0 * u * (u + e) + e * e))
            D2 = e * e * (2.0 * h2 + h3 * (6.0 * (u + e)))
            D3 = 6.0 * h3 * e * e * e
            d = (ph[s, b + 1] - ph[s, b]) * ginv
            ps = _row_pos(ph[s, b], lf, ra) + d * (xi - xbeg)
            _read_row(tab, ra, out, vbuf, n0, i0, i1, ps, d, ml0 + s0 * (xi - xl), s0,
                      ml1 + s1 * (xi - xl), s1, D1, D2, D3)  # fmt: skip
            i0 = i1
    else:
        xbeg = 1.0
        xend = 0.0  # no table block loaded yet
        ra = rb = 0
        Na = Nb = pa = pb = ds = wr = xl = 0.0
        ml0 = ml1 = sl0 = sl1 = 0.0
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = _cubic(x0, h1, h2, h3, u)
            if xi < 0.0 or xi > x_last:
                if n_ch > 1:
                    vbuf[i] = 0.0
                continue
            if xi < xbeg or xi >= xend:  # the table block holding this index
                b = min(int(xi * ginv), nb - 1)
                xbeg = float(b * gK)
                xend = xbeg + gK
                ra = r0[s, b]
                rb = r1[s, b]
                wr = wt[s, b]
                Na = lf[ra, 0]
                Nb = lf[rb, 0]
                ds = (ph[s, b + 1] - ph[s, b]) * ginv
                pa = _row_pos(ph[s, b], lf, ra) - ds * xbeg  # row ra's position: pa + ds x
                pb = _row_pos(ph[s, b], lf, rb) - ds * xbeg
                # weights linear in the index inside the block (:func:`_node_line`)
                xl, ml0, sl0 = _node_line(qa, qb, s, b, gK, x0, X1, mA0, mZ0, iX, wa0, wa1, wa2,
                                          dw0, dw1, dw2, 0)  # fmt: skip
                if P == 2:
                    xl, ml1, sl1 = _node_line(qa, qb, s, b, gK, x0, X1, mA1, mZ1, iX, wa0, wa1,
                                              wa2, dw0, dw1, dw2, 1)  # fmt: skip
            gx, gy = _row_at(tab, ra, pa + ds * xi, Na)
            if wr != 0.0:  # between two rows
                hx, hy = _row_at(tab, rb, pb + ds * xi, Nb)
                gx += wr * (hx - gx)
                gy += wr * (hy - gy)
            v = (ml0 + sl0 * (xi - xl)) * gx + (ml1 + sl1 * (xi - xl)) * gy
            if n_ch == 1:
                out[0, n0 + i] += v
            else:
                vbuf[i] = v
    if n_ch == 1:
        return
    _scatter(out, vbuf, n0, i_lo, i_hi, p0, inv, g, ja, ka, gk, jb, kb)


@numba.njit(**_NJIT)
def _table_samples(tab, lf, qa, qb, ph, r0, r1, wt, K, out, s0, s1):  # type: ignore[no-untyped-def]
    """Every emission sample of table emitters ``s0 <= s < s1`` into ``out (S, C, B K)``
    (the definition in :class:`auralize.emitters.TableEmitters`; ``tab`` and ``lf`` as
    for :func:`_seg_table`)."""
    B = qa.shape[1]
    C = qa.shape[2]
    P = qa.shape[3]
    inv = 1.0 / K
    tv = np.empty(P)
    for s in range(s0, s1):
        for b in range(B):
            ra = r0[s, b]
            rb = r1[s, b]
            wr = wt[s, b]
            Na = lf[ra, 0]
            Nb = lf[rb, 0]
            pa = _row_pos(ph[s, b], lf, ra)
            pb = _row_pos(ph[s, b], lf, rb)
            ds = (ph[s, b + 1] - ph[s, b]) * inv
            for j in range(K):
                x = pa + ds * j
                if x >= Na or x < 0.0:
                    x = _wrap(x, Na)
                k = int(x)
                fr = x - k
                y = pb + ds * j
                if y >= Nb or y < 0.0:
                    y = _wrap(y, Nb)
                kb = int(y)
                fb = y - kb
                for p in range(P):
                    a = tab[ra, k, p]
                    v = a + fr * (tab[ra, k + 1, p] - a)
                    if wr != 0.0:
                        a = tab[rb, kb, p]
                        v += wr * (a + fb * (tab[rb, kb + 1, p] - a) - v)
                    tv[p] = v
                for c in range(C):
                    acc = 0.0
                    for p in range(P):
                        q = qa[s, b, c, p]
                        acc += (q + (qb[s, b, c, p] - q) * (j * inv)) * tv[p]
                    out[s, c, b * K + j] = acc


@numba.njit(**_NJIT_NORC, fastmath={"contract"})
def _render(sig, fs, t_sig, pos, pos_rate, t_pos, radius, exponent, c0, tb, L, VR, VL, F, U,
            kf, tk, Lk, Fk, Uk, spk_az, spk_ch, fold, pinv, K, off, gen, tab, lf, qa, qb, ph, r0,
            r1, wt, gK, out, scratch, b0, b1):  # type: ignore[no-untyped-def]  # fmt: skip
    """Add the emitters heard in blocks ``b0 <= b < b1`` to ``out (n_ch, n)``.

    ``sig (S, C, n_e)`` emitted signals (C = 1 monopole, 3 dipole G) at rate
    ``fs`` from playback second ``t_sig``; ``pos (S, m, 3)`` positions at
    ``pos_rate`` from ``t_pos`` (m = 1: static); ``tb (B+1,)`` control-point
    times with listener position ``L``, velocity on the path segment after
    (``VR``) and before (``VL``), forward ``F`` and up ``U`` there; block b
    covers output samples ``b·K − off`` to ``(b+1)·K − off``.  The emission
    index is the cubic Hermite interpolant of the retarded time and its rate
    ``dτ/dt = (1 − n·v_L/c0) / (1 − n·v_s/c0)`` (n the unit vector from the
    emitter to the listener) at the block's ends; weights and gains are
    interpolated linearly.  ``kf (B,)``: the fractional sample in block b of
    a listener capture (a kink of the listener's path), -1 for none; such a
    block is split there into two linear pieces (listener ``Lk``, ``Fk``,
    ``Uk`` at time ``tk``).  Blocks of different ranges write disjoint
    samples (threads share ``out``); ``scratch`` is the call's own working
    memory (:func:`_scratch`), as the kernel allocates nothing.

    The retarded times of a chunk of control points are found together, each
    pass over the chunk independent point by point (the processor overlaps
    them): the emitter's place at t gives the first guess, one Newton step
    follows, and :func:`_point` checks convergence with the quantities it
    evaluates there; the few points not converged then (a step across a
    trajectory sample) continue alone.

    ``gen``: the emitters are table emitters (``tab``, ``lf`` and ``ph`` as for
    :func:`_seg_table`, ``qa, qb, r0, r1, wt`` and ``gK`` samples per
    table block, as :class:`auralize.emitters.TableEmitters`; ``sig`` is not
    read): each sample evaluates the signal at its emission index
    (:func:`_seg_table`).
    """
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
    CB = _CHUNK_BLOCKS
    # the scratch (:func:`_scratch`): chunk-long control-point arrays, their weights and
    # gains, then a piece's samples
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
                    tq[j] = t - math.sqrt((L[b, 0] - x) ** 2 + (L[b, 1] - y) ** 2
                                          + (L[b, 2] - z) ** 2) * inv_c0  # fmt: skip
                for j in range(nb):
                    b = cb0 + j
                    tq[j], _ = _newton(pos, s, pos_rate, t_pos, tb[b], L[b, 0], L[b, 1], L[b, 2],
                                       tq[j], inv_c0)  # fmt: skip
            for b in range(cb0, cb1 + 1):
                j = b - cb0
                t = tb[b]
                xe[j], tau, dx, dy, dz, idt, sx, sy, sz = _point(
                    C, pos, s, pos_rate, t_pos, radius, exponent, inv_c0, moving, False, t,
                    L[b, 0], L[b, 1], L[b, 2], F[b, 0], F[b, 1], F[b, 2], U[b, 0], U[b, 1], U[b, 2],
                    tq[j], t_sig, fs, spk_az, spk_ch, fold, pinv, w, g, j)  # fmt: skip
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
                    xk[j], _, _, _, _, _, _, _, _ = _point(
                        C, pos, s, pos_rate, t_pos, radius, exponent, inv_c0, moving, True, tk[b],
                        Lk[b, 0], Lk[b, 1], Lk[b, 2], Fk[b, 0], Fk[b, 1], Fk[b, 2], Uk[b, 0],
                        Uk[b, 1], Uk[b, 2], tau + (tk[b] - t), t_sig, fs, spk_az, spk_ch, fold,
                        pinv, wk, gk, j)  # fmt: skip
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
                    if gen:
                        _seg_table(tab, lf, qa, qb, ph, r0, r1, wt, gK, s, vbuf, out, n0, lo, hi,
                                   p0, p1, x0, h1, h2, h3, w, ja, jb, wk, ka, kb, g, gk)  # fmt: skip
                    else:
                        _segment(sig, s, last, vbuf, out, n0, lo, hi, p0, p1, x0, h1, h2, h3, w,
                                 ja, jb, wk, ka, kb, g, gk)  # fmt: skip


@numba.njit(**_NJIT)
def _box(a, b):  # type: ignore[no-untyped-def]
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


def _scratch(cw: int, n_ch: int, K: int) -> NDArray[np.float64]:
    """Scratch of one :func:`_render` call: ``cw`` weights per control point (signal
    components and table components), ``n_ch`` channels, ``K`` samples per block."""
    CB = _CHUNK_BLOCKS
    return np.empty(5 * CB + 4 + (2 * CB + 1) * (cw + n_ch) + K)


def table_signals(em: Any) -> NDArray[np.float64]:
    """The emission samples ``(S, C, n)`` of :class:`auralize.emitters.TableEmitters` ``em``."""
    S, B, C, _ = em.qa.shape
    out = np.empty((S, C, B * em.block))
    n_pieces = max(1, min(S, 4 * _N_THREADS)) if out.size >= _MIN_SPLIT else 1
    edges = [S * i // n_pieces for i in range(n_pieces + 1)]
    args = kernel_args(em.padded_table, _lengths(em), em.qa, em.qb, em.phase, em.r0, em.r1, em.w,
                       em.block, out)  # fmt: skip
    _run(lambda i: _table_samples(*args, edges[i], edges[i + 1]), n_pieces, _N_THREADS)
    return out


def _table_args(em: Any, gen: bool) -> tuple[Any, ...]:
    """The table-emitter arguments of :func:`_render` (placeholders for stored signals)."""
    if gen:
        return (True, em.padded_table, _lengths(em), em.qa, em.qb, em.phase, em.r0, em.r1, em.w,
                int(em.block))  # fmt: skip
    zi = np.zeros((1, 1), dtype=np.int64)
    return (False, np.zeros((1, 2, 1)), np.ones((1, 2)), np.zeros((1, 1, 1, 1)),
            np.zeros((1, 1, 1, 1)), np.zeros((1, 2)), zi, zi, np.zeros((1, 1)), 1)  # fmt: skip


def _lengths(em: Any) -> NDArray[np.float64]:
    """``(R, 2)``: the table rows' lengths and their inverses."""
    n = em.lengths.astype(np.float64)
    return np.ascontiguousarray(np.stack([n, 1.0 / n], axis=1))


def _run(fn: Callable[[int], None], n: int, nt: int) -> None:
    """``fn(i)`` for every i < n on up to ``nt`` threads (:func:`auralize.emitters.parallel.run_pieces`)."""
    run_pieces(fn, n, nt)


@dataclass
class Prepared:
    """Emitted signals ready for the kernel: ``sig (S, C, n)`` (C-contiguous, writable
    float64: :func:`auralize.runtime.jit.kernel_arg`) at rate ``fs`` from ``t0``
    (band-limited upsampled by ``up`` from the emitters' own rate)."""

    sig: NDArray[np.float64]
    fs: float
    t0: float
    up: int


def upsampling(rate_in: float, rate_out: int, oversample: int) -> int:
    """Integer band-limited upsampling factor of emitted signals (1: none).

    Emitters below half the output rate are upsampled to about ``oversample``
    × their rate (never above the output rate), so that the linear read at
    the retarded time has no audible images.
    """
    if oversample <= 1 or rate_in * 1.5 > rate_out:
        return 1
    return int(max(1, min(int(oversample), math.floor(rate_out / rate_in + 1e-9))))


def prepare(signals: NDArray[np.float64], rate: float, t0: float, up: int,
            i_lo: int = 0, i_hi: int | None = None) -> Prepared:  # fmt: skip
    """Samples ``i_lo:i_hi`` of ``signals (S, n)`` or ``(S, 3, n)``, upsampled ``up`` ×."""
    from scipy.signal import resample_poly

    sig = signals[:, None, :] if signals.ndim == 2 else signals
    n = sig.shape[2]
    i_hi = n if i_hi is None else i_hi
    if up == 1:  # read in place when contiguous float64 (float32 of a model: widened, exactly)
        return Prepared(kernel_arg(sig), float(rate), float(t0), 1)
    seg = sig[:, :, i_lo:i_hi]
    S, C, m = seg.shape
    flat = np.ascontiguousarray(seg, dtype=np.float64).reshape(S * C, m)
    # resample_poly's rows are padded apart: one contiguous copy, so that the kernel has
    # one signature (a strided 'A' array would be a second specialization to compile)
    y = kernel_arg(resample_poly(flat, up, 1, axis=1))
    return Prepared(y.reshape(S, C, m * up), float(rate) * up, float(t0) + i_lo / float(rate),
                    int(up))  # fmt: skip


#: half-length (input samples) of :func:`scipy.signal.resample_poly`'s default filter
_UP_HALF = 12


def _internal_factor(rate: int, fs: float) -> int:
    """Largest k with ``rate % k == 0`` and ``rate / k >= fs`` (1: evaluate at the output rate)."""
    k = int(math.floor(rate / fs + 1e-9))
    while k > 1 and rate % k:
        k -= 1
    return max(k, 1)


def _anti_image(k: int, rate: int, band: float) -> NDArray[np.float64]:
    """Kaiser FIR (80 dB) at ``rate`` passing ``band`` Hz and stopping from ``rate/k − band``."""
    from scipy.signal import firwin, kaiserord

    R = rate / k
    band = min(band, 0.45 * R)
    width = max(R - 2 * band, 0.05 * R)
    numtaps, beta = kaiserord(80.0, width / (0.5 * rate))
    numtaps += 1 - numtaps % 2
    return np.asarray(firwin(numtaps, band + 0.5 * width, fs=rate, window=("kaiser", beta)))


def _path_velocities(path: Any, t: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Listener velocity (m/s) at path times ``t`` on the segment after and before each."""
    T, P = path.times, path.positions
    n = T.size
    if n < 2:
        z = np.zeros((t.size, 3))
        return z, z.copy()
    dt = np.diff(T)
    v = np.diff(P, axis=0) / np.where(dt > 0, dt, 1.0)[:, None]
    v[dt <= 0] = 0.0
    v = np.vstack([np.zeros((1, 3)), v, np.zeros((1, 3))])  # held outside the path
    iR = np.searchsorted(T, t, side="right")
    iL = np.searchsorted(T, t, side="left")
    return np.ascontiguousarray(v[iR]), np.ascontiguousarray(v[iL])


def _orientations(path: Any, t: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Forward and up ``(len(t), 3)`` at path times t: :meth:`ListenerPath.orientation_at`,
    or its one orientation repeated when the path never turns."""
    f, u = path.forward, path.up
    if f is not None and u is not None and np.all(f == f[0]) and np.all(u == u[0]):
        F, U = path.orientation_at(t[:1])
        return np.repeat(F, t.size, axis=0), np.repeat(U, t.size, axis=0)
    return tuple(path.orientation_at(t))


def render_sampled(em: Any, path: Any, *, rate: int, layout: Any, n_out: int, start: float,
                   c0: float, block: int = BLOCK, oversample: int = 4,
                   internal: bool = True, prepared: Prepared | None = None,
                   threads: int | None = None) -> tuple[NDArray[np.float64], dict[str, Any]]:  # fmt: skip
    """Pressure ``(n_channels, n_out)`` of :class:`auralize.emitters.Emitters` ``em``.

    Output sample n is heard at playback second ``start + n / rate``.

    Parameters
    ----------
    block : int
        Evaluation samples between control points.
    oversample : int
        Emitters below the output rate are upsampled band-limited to at most
        this × their rate (1: read as given).
    internal : bool
        Evaluate at an integer fraction of the output rate when the
        (upsampled) signals allow it, then resample band-limited.
    prepared : Prepared, optional
        The whole signals already prepared (:func:`prepare`; block renderers
        reuse them).
    threads : int, optional
        Threads (default: up to 2 for long windows).

    Returns
    -------
    audio, meta (``internal_rate_hz``, ``signal_rate_hz``, ``block``, ``threads``)
    """
    from auralize.emitters import TableEmitters, law_exponent
    from auralize.emitters.synthesis import pan_table, panning_arrays
    from auralize.spatial.layouts import receiver_paths

    ears = receiver_paths(layout, path)
    if ears:  # several receivers (the ears): each along its own path, channels stacked
        outs = [render_sampled(em, p, rate=rate, layout=rl, n_out=n_out, start=start, c0=c0,
                               block=block, oversample=oversample, internal=internal,
                               prepared=prepared, threads=threads) for rl, p in ears]  # fmt: skip
        return np.concatenate([o[0] for o in outs]), outs[0][1]

    # table emitters are read from their tables, unless they need upsampling
    gen = isinstance(em, TableEmitters) and upsampling(em.rate, rate, oversample) == 1
    lay = layout
    n_ch = lay.n_channels
    e = law_exponent(em.law)
    K = int(block)
    if gen:
        up = 1
    else:
        up = prepared.up if prepared is not None else upsampling(em.rate, rate, oversample)
    fs = em.rate * up
    k = _internal_factor(int(rate), fs) if internal else 1
    m0f = start * rate
    m0 = int(round(m0f))
    aligned = abs(m0f - m0) < 1e-6
    if not aligned:
        k = 1
    R = rate / k
    h = _anti_image(k, int(rate), 0.5 * em.rate * 1.25) if k > 1 else np.zeros(0)
    P = (h.size // (2 * k) + 2) if k > 1 else 0
    # evaluation sample j is at playback second j / R (a grid fixed in time, so
    # windows join without seams) or, for a start off the output grid, start + j / R
    if aligned:
        j_lo = m0 // k - P
        n_int = -(-(m0 + n_out) // k) - j_lo + P + 1 if k > 1 else n_out
        t_base = 0.0
    else:
        j_lo, n_int = 0, n_out
        t_base = float(start)

    def t_of(j: Any) -> Any:
        return t_base + j / R

    K = max(4, int(round(K / k)))  # control points as often in time as at the output rate
    meta = {"internal_rate_hz": float(R), "signal_rate_hz": float(fs), "block": K}
    if n_out <= 0:
        return np.zeros((n_ch, max(n_out, 0))), {**meta, "threads": 0}
    t_lo, t_hi = t_of(j_lo), t_of(j_lo + n_int)
    tp0 = path.times[0]
    if gen:  # generated where they are read: no signal window
        prepared = Prepared(np.zeros((1, em.qa.shape[2], 1)), float(em.rate), float(em.t0), 1)
    elif prepared is None:
        # emission window: every retarded time of the window, bounded by distances
        lp = path.position_at(tp0 + np.linspace(t_lo, t_hi, 16))
        lo, hi = _box(*kernel_args(em.positions.reshape(-1, 3), lp))
        d_max = float(np.linalg.norm(hi - lo))
        tau_lo, tau_hi = t_lo - d_max / c0, t_hi
        i_lo = max(0, int(math.floor((tau_lo - em.t0) * em.rate)) - _UP_HALF)
        i_hi = min(em.n_samples, int(math.ceil((tau_hi - em.t0) * em.rate)) + _UP_HALF + 1)
        if i_hi <= i_lo:
            return np.zeros((n_ch, n_out)), {**meta, "threads": 0}
        prepared = prepare(em.signals, em.rate, em.t0, up, i_lo, i_hi)
    B = -(-(n_int + (j_lo % K)) // K)
    off = j_lo % K
    tb = t_of(j_lo - off + np.arange(B + 1, dtype=np.float64) * K)
    L = np.ascontiguousarray(path.position_at(tp0 + tb))
    VR, VL = _path_velocities(path, tp0 + tb)
    if n_ch > 1:
        F, U = _orientations(path, tp0 + tb)
        spk_az, spk_ch = panning_arrays(lay)
        pinv = pan_table(lay, spk_az)
    else:
        F = U = np.zeros((B + 1, 3))
        spk_az, spk_ch, pinv = np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, 4))
    F, U = np.ascontiguousarray(F), np.ascontiguousarray(U)
    # listener captures strictly inside a block: kinks of the listener's path
    kf = np.full(B, -1.0)
    tcap = path.times - tp0
    inside = (tcap > tb[0]) & (tcap < tb[-1])
    if np.any(inside):
        tc = tcap[inside]
        bi = np.clip(np.searchsorted(tb, tc, side="right") - 1, 0, B - 1)
        frac = (tc - tb[bi]) / (tb[bi + 1] - tb[bi]) * K
        keep = (frac > 1e-6) & (frac < K - 1e-6)
        bi, frac = bi[keep], frac[keep]
        if bi.size:
            first = np.r_[True, bi[1:] != bi[:-1]]  # one kink per block (the first)
            kf[bi[first]] = frac[first]
    tk = np.where(kf >= 0, tb[:-1] + np.maximum(kf, 0.0) / K * np.diff(tb), 0.0)
    if np.any(kf >= 0):
        Lk = np.ascontiguousarray(path.position_at(tp0 + tk))
    else:  # read only at kinks
        Lk = np.zeros((B, 3))
    if n_ch > 1 and np.any(kf >= 0):
        Fk, Uk = (np.ascontiguousarray(a) for a in path.orientation_at(tp0 + tk))
    else:
        Fk = Uk = np.zeros((B, 3))
    pos = em.positions if em.moving else em.positions[:, None, :]
    out = np.zeros((n_ch, n_int))
    nt = threads if threads is not None else (_N_THREADS if n_int >= _MIN_SPLIT else 1)
    nt = max(1, min(int(nt), _N_THREADS, B))
    n_pieces = min(B, 4 * nt) if nt > 1 else 1  # taken in turn by the threads
    edges = [B * i // n_pieces for i in range(n_pieces + 1)]
    tab_args = _table_args(em, gen)
    # one compiled signature whatever the arrays' dtype, layout and write flag (the
    # outputs are this function's own C-contiguous float64 arrays, passed as they are)
    args = kernel_args(
            prepared.sig, prepared.fs, prepared.t0, np.ascontiguousarray(pos), float(em.pos_rate),
            float(em.t0), em.radius, float(e), float(c0), tb, L, VR, VL, F, U, kf, tk, Lk, Fk, Uk,
            np.ascontiguousarray(spk_az, dtype=np.float64),
            np.ascontiguousarray(spk_ch, dtype=np.int64), bool(lay.fold_front),
            np.ascontiguousarray(pinv, dtype=np.float64), K, off,
            *tab_args, out)  # fmt: skip
    # weights per control point: the signal components, then the table components (one
    # placeholder for stored signals)
    cw = (em.qa.shape[2] if gen else prepared.sig.shape[1]) + tab_args[3].shape[3]
    _run(lambda i: _render(*args, _scratch(cw, n_ch, K), edges[i], edges[i + 1]), n_pieces, nt)
    if k > 1:
        from scipy.signal import resample_poly

        y = resample_poly(out, k, 1, axis=1, window=h)
        a = m0 - j_lo * k
        out = np.ascontiguousarray(y[:, a : a + n_out])
    return out, {**meta, "threads": nt}
