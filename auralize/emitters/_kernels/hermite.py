"""The cubic Hermite pieces: the strength q(τ) between two knots, and the
received signal f(t) = q(τ(t)) / D(t) on a piece written for the skewed
accumulator.

A piece of f is represented by the cubic Hermite interpolant of f and f' at
its ends (paper 003 §3.2.4.3 for the time interpolation of the strengths);
:func:`_hermite_inv` gives its power-basis coefficients, :func:`_shifted`
its four accumulator values at an emission (see
:mod:`auralize.emitters._kernels.accumulate`), :func:`_piece_values` those of
a piece's start, end and continuation into one lane of a work array.
:func:`_hermite_at` evaluates q and dq/dτ inside a piece (branch-free: the
SIMD loops); :func:`_qeval` is the scalar code's evaluation (linear or
cubic, with a branch).

The selects here are conditional expressions, not
:func:`~auralize.emitters._kernels.common.where`: :func:`_cut_at_end` and
:func:`_take_cut` are inlined into the runs kernel's steps, which are compiled with
FMA contraction (:func:`auralize.emitters._kernels.render_runs._chunk_step`), and
there the form of a select decides which multiply-adds LLVM fuses, hence the last
bit of the sum.
"""

from __future__ import annotations

import math

import numba

from auralize.emitters._kernels.common import _CHUNK, _NJIT


@numba.njit(inline="always", **_NJIT)
def _qeval(t_a, h, q0, m0, q1, m1, tau, cubic):
    """Strength q and dq/dτ at time τ on a piece from knot time t_a to t_a + h
    with values q0, q1 and tangents m0, m1 (per second) at its knots."""
    s = (tau - t_a) / h
    if s < 0.0:
        s = 0.0
    if s > 1.0:
        s = 1.0
    if not cubic:
        return q0 + (q1 - q0) * s, (q1 - q0) / h
    m0 = m0 * h
    m1 = m1 * h
    s2 = s * s
    s3 = s2 * s
    val = (
        (2 * s3 - 3 * s2 + 1) * q0
        + (s3 - 2 * s2 + s) * m0
        + (-2 * s3 + 3 * s2) * q1
        + (s3 - s2) * m1
    )
    der = (
        (6 * s2 - 6 * s) * q0
        + (3 * s2 - 4 * s + 1) * m0
        + (-6 * s2 + 6 * s) * q1
        + (3 * s2 - 2 * s) * m1
    ) / h
    return val, der


@numba.njit(inline="always", **_NJIT)
def _hermite_at(t_0, h, q0, m0, q1, m1, tau):
    """Strength q and dq/dτ at τ of the cubic Hermite piece from knot t_0 to
    t_0 + h (values q0, q1, tangents m0, m1 per second; a linear piece has
    m0 = m1 = its slope, which the Hermite reproduces); branch-free."""
    s = (tau - t_0) / h
    s = s if s > 0.0 else 0.0
    s = s if s < 1.0 else 1.0
    s2 = s * s
    s3 = s2 * s
    hm0 = m0 * h
    hm1 = m1 * h
    q = (
        (2.0 * s3 - 3.0 * s2 + 1.0) * q0
        + (s3 - 2.0 * s2 + s) * hm0
        + (3.0 * s2 - 2.0 * s3) * q1
        + (s3 - s2) * hm1
    )
    m = (
        (6.0 * s2 - 6.0 * s) * (q0 - q1)
        + (3.0 * s2 - 4.0 * s + 1.0) * hm0
        + (3.0 * s2 - 2.0 * s) * hm1
    ) / h
    return q, m


@numba.njit(inline="always", **_NJIT)
def _hermite_inv(inv, f0, d0, f1, d1):
    """Power-basis coefficients (in x = t - start, sample units) of the cubic
    Hermite with values f0, f1 and slopes d0, d1 over [0, L], given inv = 1/L."""
    dlt = (f1 - f0) * inv
    c2 = (3.0 * dlt - 2.0 * d0 - d1) * inv
    c3 = (d0 + d1 - 2.0 * dlt) * inv * inv
    return f0, d0, c2, c3


@numba.njit(inline="always", **_NJIT)
def _shifted(p0, p1, p2, p3, x):
    """The four accumulator values (see :func:`_emit1`) of P(m - m_start + x)."""
    b0 = p0 + x * (p1 + x * (p2 + x * p3))
    b1 = p1 + x * (2.0 * p2 + 3.0 * p3 * x)
    b2 = p2 + 3.0 * p3 * x
    s3 = 6.0 * p3
    return b0, b1 + b2 + p3, 2.0 * b2 + s3, s3


@numba.njit(inline="always", **_NJIT)
def _piece_values(work, r, i, L, inv_L, f0, w0, f1, w1, x0, x1, x2):
    """Rows r..r+11 of column i of work: the accumulator values of the cubic
    Hermite with values f0, f1 and slopes w0, w1 (per sample) over [0, L],
    added at its first sample (x0 = that sample - start), subtracted at its end
    (x1) and added again at the first sample of the next accumulation block
    (x2); inv_L = 1/L."""
    p0, p1, p2, p3 = _hermite_inv(inv_L, f0, w0, f1, w1)
    v0, v1, v2, v3 = _shifted(p0, p1, p2, p3, x0)
    work[r * _CHUNK + i] = v0
    work[(r + 1) * _CHUNK + i] = v1
    work[(r + 2) * _CHUNK + i] = v2
    work[(r + 3) * _CHUNK + i] = v3
    v0, v1, v2, v3 = _shifted(p0, p1, p2, p3, x1)
    work[(r + 4) * _CHUNK + i] = -v0
    work[(r + 5) * _CHUNK + i] = -v1
    work[(r + 6) * _CHUNK + i] = -v2
    work[(r + 7) * _CHUNK + i] = -v3
    v0, v1, v2, v3 = _shifted(p0, p1, p2, p3, x2)
    work[(r + 8) * _CHUNK + i] = v0
    work[(r + 9) * _CHUNK + i] = v1
    work[(r + 10) * _CHUNK + i] = v2
    work[(r + 11) * _CHUNK + i] = v3


@numba.njit(inline="always", **_NJIT)
def _cut_at_end(piece, sg0, ok0, la, lb, t_1, grid):
    """The end of a piece whose arrivals cross, after its start, a capture at
    or past the output's last sample: the piece is cut at that capture t_c
    (the listener's velocity changes there; nothing after it is heard in this
    output).  Returns ``cut`` and, at t_c: the arrival t_c, D, D·dD/dt on the
    start's line, and the strength q and dq/dτ at the emission time
    τ_c = t_c - D/c0 (cubic Hermite of the knots t_n = la[6], t_1; for linear
    pieces m0 = m1 = the slope, which the Hermite reproduces).  This is the
    first part of :func:`~auralize.emitters._kernels.pieces._piece_across`'s
    split, branch-free.  ``piece`` = (x, y, z, clamp radius, q0, dq/dτ0, q1,
    dq/dτ1), sg0/ok0: the start's line and whether it holds the start's
    arrival; ``grid`` a :class:`~auralize.emitters._kernels.common.LaneGrid`."""
    x, y, z, rm, q0, m0, q1, m1 = piece
    inv_c0, t_start, fs, fn = grid.inv_c0, grid.t_start, grid.fs, grid.fn
    sel = sg0 == la[11]
    lx = la[0] if sel else lb[0]
    ly = la[1] if sel else lb[1]
    lz = la[2] if sel else lb[2]
    vx = la[3] if sel else lb[3]
    vy = la[4] if sel else lb[4]
    vz = la[5] if sel else lb[5]
    th = la[8] if sel else lb[8]
    t_0 = la[6]
    fin = th < 1e300
    dt = th - t_0 if fin else 0.0
    px = lx + vx * dt - x
    py = ly + vy * dt - y
    pz = lz + vz * dt - z
    d = math.sqrt(px * px + py * py + pz * pz)
    clamp = d <= rm
    dd = 0.0 if clamp else px * vx + py * vy + pz * vz
    d = rm if clamp else d
    tau = th - d * inv_c0 if fin else t_0
    q, m = _hermite_at(t_0, t_1 - t_0, q0, m0, q1, m1, tau)
    cut = ok0 & fin & ((th - t_start) * fs > fn - 1.0) & (tau < t_1)
    return cut, th, d, dd, q, m


@numba.njit(inline="always", **_NJIT)
def _take_cut(cut, cut_end, knot_end):
    """The end of a piece: where :func:`_cut_at_end` cut it (``cut``; its
    arrival, D, D·dD/dt, q, dq/dτ and capture interval ``cut_end``), else its
    knot's (``knot_end``: the same and the found flag); branch-free."""
    ac, dc, ec, q_cut, m_cut, sgc = cut_end
    a, d, e, q, m, sg, ok = knot_end
    return (
        ac if cut else a,
        dc if cut else d,
        ec if cut else e,
        q_cut if cut else q,
        m_cut if cut else m,
        sgc if cut else sg,
        ok | cut,
    )
