"""Compiled unpanned (and AmbiX) synthesis by runs of pieces: one emission per knot.

Same sum as :func:`auralize.emitters._kernels.render_pieces.render_task` (see
:mod:`auralize.emitters._kernels` for the pieces, the Hermite cubic of
f = q(τ)/D on each piece and the skewed accumulator), organised so that
consecutive pieces of a source share their common knot:

* a **run** is a maximal stretch of consecutive sounding pieces of one
  source; runs with the same first row, sorted by length, fill chunks of
  :data:`_CHUNK` lanes whose knot data (q and dq/dτ per knot, rows
  :data:`~auralize.emitters._kernels.common.KNOT_ROW`) are contiguous;
* a chunk is swept knot by knot.  Each knot's arrival, D and f, df/dt are
  solved once (the piece-wise kernel solves them for both pieces that share
  the knot), and the piece that ends there gets its Hermite cubic;
* the end of one piece and the start of the next meet at the same sample
  (the knot's arrival), so their two emissions are one: expanded around the
  arrival the two cubics share value and slope (the Hermite is C¹), and the
  emission holds the difference of their quadratic and cubic terms.  An
  unpanned signal thus costs four accumulator adds per knot instead of
  eight per piece.

Pieces whose arrivals straddle a listener capture, whose knot is heard
beyond the listener's candidate lines, or that need more than one restart
of an accumulation block leave the shared emissions and are summed in full
by the scalar code of the piece-wise kernel.

AmbiX layouts (the spherical harmonics of :func:`~auralize.emitters._kernels.gains._gains_sh`,
every channel gained; the binaural ear receivers are such layouts) are
summed by runs too: the piece-wise kernel gives a piece the gains G(a) of
its two arrivals, g₀·A + g₁·B (the Hermite cubic of g·f for g linear along
the piece).  At a knot the gain is shared, so a channel's cubics meet with
equal value (their slopes differ), and the emission at knot j − 1 of
channel c is G_{j−2,c}·X + G_{j−1,c}·Y + G_{j,c}·Z: X the
previous piece's A end (subtracted), Y this piece's A start minus the
previous piece's B end, Z this piece's B start.  Three 4-vectors per knot,
the gains per knot (not per piece end): one arrival and one set of
harmonics per knot instead of two.  Other panned layouts (speaker pairs
switch between knots) use the piece-wise kernel.
"""

from __future__ import annotations

import numba
import numpy as np

from auralize.emitters._kernels.accumulate import (
    _add_plain,
    _clear_window,
    _emit1,
    _flush_captures,
    _prefetch,
)
from auralize.emitters._kernels.arrivals import (
    _LINE,
    _knot_arrival,
    _line_tuple,
    _listener_at,
)
from auralize.emitters._kernels.common import (
    _CHUNK,
    _NJIT,
    _NJIT_NORC,
    KIND_ACROSS,
    KIND_GENERAL,
    KIND_SILENT,
    KIND_SIMPLE,
    KNOT_ROW,
    RUN_ROW,
    Window,
    _inverses,
    lane_grid,
    where,
)
from auralize.emitters._kernels.gains import _pan_far
from auralize.emitters._kernels.hermite import _cut_at_end, _shifted, _take_cut
from auralize.emitters._kernels.lane_gains import _orient_rows, _sh_lanes
from auralize.emitters._kernels.pieces import _piece_across, _piece_general

#: lanes ahead whose emission rows the AmbiX scatter prefetches
_AHEAD_G = 8


@numba.njit(inline="always", **_NJIT)
def _run_step(work, i, j, lines_prev, lines, t_n, two, cubic, first, grid, gained):
    """Knot j (time t_n, candidate lines ``lines`` = (la, lb)) of the run in lane
    i, and the piece from knot j - 1 (lines ``lines_prev``) to it;
    branch-free (``grid``: a :class:`~auralize.emitters._kernels.common.LaneGrid`).

    Writes the emission at knot j - 1 (start of this piece minus the pending
    end of the previous one, Taylor-shifted to the knot's sample), this
    piece's restart (at sample 0 when it starts before the output, or at
    the first sample of the next accumulation block it runs into), its kind
    (KIND_SILENT, or outside; KIND_SIMPLE, in the shared emissions;
    KIND_GENERAL and KIND_ACROSS, summed by the scalar code), and carries
    knot j's state.
    ``gained`` (AmbiX runs): also the emission split by gain (rows GX, GY,
    GZ) and the A parts (rows CA, PA); a piece cut at a capture is left to
    the scalar code (its end's gains are not the knot's).
    """
    la_p, lb_p = lines_prev
    la, lb = lines
    c0, inv_c0, t_start, fs, inv_fs, fn = (
        grid.c0,
        grid.inv_c0,
        grid.t_start,
        grid.fs,
        grid.inv_fs,
        grid.fn,
    )
    fblock, inv_block, blo, nb, base, rs = (
        grid.fblock,
        grid.inv_block,
        grid.blo,
        grid.nb,
        grid.base,
        grid.rs,
    )
    o = _CHUNK
    x = work[RUN_ROW.X * o + i]
    y = work[RUN_ROW.Y * o + i]
    z = work[RUN_ROW.Z * o + i]
    rm = work[RUN_ROW.RM * o + i]
    q = work[RUN_ROW.Q * o + i]
    mr = work[RUN_ROW.M * o + i]
    qp = work[RUN_ROW.QP * o + i]
    mp = work[RUN_ROW.MP * o + i]
    m1 = where(cubic, mr, mp)  # dq/dτ at the piece's end (linear: its slope)
    a, d, e, sg, ok = _knot_arrival(x, y, z, rm, la, lb, c0, inv_c0, two)
    up = work[RUN_ROW.U * o + i]
    sp = work[RUN_ROW.SM * o + i]
    fp = work[RUN_ROW.F * o + i]
    wp = work[RUN_ROW.W * o + i]
    ap = work[RUN_ROW.A * o + i]
    sgp = work[RUN_ROW.SG * o + i]
    okp = work[RUN_ROW.OK * o + i] != 0.0
    # the piece's end: the knot, or where it is cut (a capture at or past the
    # output's end that its arrivals cross)
    a1, d1, e1, q1, me, sg1, ok1 = a, d, e, q, m1, sg, ok
    cut = False
    if two:
        cut, ac, dc, ec, q_cut, m_cut = _cut_at_end(
            (x, y, z, rm, qp, mp, q, m1), sgp, okp, la_p, lb_p, t_n, grid
        )
        cut = cut & ~first
        a1, d1, e1, q1, me, sg1, ok1 = _take_cut(
            cut, (ac, dc, ec, q_cut, m_cut, sgp), (a, d, e, q, m1, sg, ok)
        )
    u = (a - t_start) * fs
    u1 = (a1 - t_start) * fs
    L = u1 - up
    L = where(L > 0.0, L, 1.0)
    # one division for 1/D (knot), 1/D1 (the piece's end) and 1/L
    inv_d, inv_d1, inv_l = _inverses(d, d1, L)
    dd = e * inv_d
    f = q * inv_d
    wr = (mr * (1.0 - dd * inv_c0) - f * dd) * inv_d * inv_fs
    dd1 = e1 * inv_d1
    f1 = q1 * inv_d1
    w1 = (me * (1.0 - dd1 * inv_c0) - f1 * dd1) * inv_d1 * inv_fs
    s = np.ceil(u)
    # the piece from knot j - 1: samples ceil(up) .. ceil(u1) - 1 of the output
    s1 = np.ceil(u1)
    s0c = where(sp > 0.0, sp, 0.0)
    s1c = where(s1 < fn, s1, fn)
    live = ~first & (j - 1.0 < work[RUN_ROW.LEN * o + i])
    found = okp & ok1
    valid = live & found & (s1c > s0c) & (u1 > up)
    b0 = np.floor(s0c * inv_block)
    b1 = np.floor((s1c - 1.0) * inv_block)
    clip0 = sp < 0.0
    simple = (
        valid
        & (sgp == sg1)
        & (b1 <= b0 + 1.0)
        & ~(clip0 & (b1 > b0))
        & (b0 >= blo)
        & (b1 < blo + nb)
    )
    if gained:
        simple = simple & ~cut
    work[RUN_ROW.KIND * o + i] = where(
        found,
        where(valid, where(simple, KIND_SIMPLE, KIND_ACROSS), KIND_SILENT),
        where(live, KIND_GENERAL, KIND_SILENT),
    )
    dlt = (f1 - fp) * inv_l
    c2 = (3.0 * dlt - 2.0 * wp - w1) * inv_l
    c3 = (wp + w1 - 2.0 * dlt) * inv_l * inv_l
    # the emission at knot j - 1: this piece's start minus the previous one's end
    pf = work[RUN_ROW.PF * o + i] != 0.0
    e0 = where(simple, fp, 0.0) - work[RUN_ROW.P * o + i]
    e1_ = where(simple, wp, 0.0) - work[(RUN_ROW.P + 1) * o + i]
    e2 = where(simple, c2, 0.0) - work[(RUN_ROW.P + 2) * o + i]
    e3 = where(simple, c3, 0.0) - work[(RUN_ROW.P + 3) * o + i]
    v0, v1, v2, v3 = _shifted(e0, e1_, e2, e3, sp - up)
    use = pf | (simple & ~clip0)
    work[RUN_ROW.EROW * o + i] = where(use, base + (sp - blo * fblock) * rs, -1.0)
    work[RUN_ROW.E * o + i] = v0
    work[(RUN_ROW.E + 1) * o + i] = v1
    work[(RUN_ROW.E + 2) * o + i] = v2
    work[(RUN_ROW.E + 3) * o + i] = v3
    if gained:
        # A: the part of the piece that the gain at its start multiplies (the
        # gain linear along the piece, as the piece-wise kernel's g0·A + g1·B):
        # the Hermite cubic of value fp, slope wp - fp/L at the start, value
        # 0, slope -f1/L at the end; B = the piece - A
        fl = fp * inv_l
        c2a = (f1 * inv_l - fl - 2.0 * wp) * inv_l
        c3a = (wp + fl - f1 * inv_l) * inv_l * inv_l
        pa1 = work[RUN_ROW.PA * o + i]
        pa2 = work[(RUN_ROW.PA + 1) * o + i]
        pa3 = work[(RUN_ROW.PA + 2) * o + i]
        x0, x1, x2, x3 = _shifted(0.0, -pa1, -pa2, -pa3, sp - up)
        y0, y1, y2, y3 = _shifted(
            where(simple, fp, 0.0) - work[RUN_ROW.P * o + i],
            where(simple, wp - fl, 0.0) - (work[(RUN_ROW.P + 1) * o + i] - pa1),
            where(simple, c2a, 0.0) - (work[(RUN_ROW.P + 2) * o + i] - pa2),
            where(simple, c3a, 0.0) - (work[(RUN_ROW.P + 3) * o + i] - pa3),
            sp - up,
        )
        z0, z1, z2, z3 = _shifted(
            0.0,
            where(simple, fl, 0.0),
            where(simple, c2 - c2a, 0.0),
            where(simple, c3 - c3a, 0.0),
            sp - up,
        )
        work[RUN_ROW.GX * o + i] = x0
        work[(RUN_ROW.GX + 1) * o + i] = x1
        work[(RUN_ROW.GX + 2) * o + i] = x2
        work[(RUN_ROW.GX + 3) * o + i] = x3
        work[RUN_ROW.GY * o + i] = y0
        work[(RUN_ROW.GY + 1) * o + i] = y1
        work[(RUN_ROW.GY + 2) * o + i] = y2
        work[(RUN_ROW.GY + 3) * o + i] = y3
        work[RUN_ROW.GZ * o + i] = z0
        work[(RUN_ROW.GZ + 1) * o + i] = z1
        work[(RUN_ROW.GZ + 2) * o + i] = z2
        work[(RUN_ROW.GZ + 3) * o + i] = z3
        work[RUN_ROW.CA * o + i] = c2a
        work[(RUN_ROW.CA + 1) * o + i] = c3a
        work[(RUN_ROW.CA + 2) * o + i] = fl
    # restart (rare: emitted by the scalar code from the cubic's c2, c3): at
    # the output's first sample, or at the next accumulation block's
    mr0 = where(clip0, 0.0, b1 * fblock)
    work[RUN_ROW.RROW * o + i] = where(simple & (clip0 | (b1 > b0)), mr0, -1.0)
    work[RUN_ROW.C2 * o + i] = c2
    work[(RUN_ROW.C2 + 1) * o + i] = c3
    # for the scalar code
    work[RUN_ROW.A0 * o + i] = ap
    work[RUN_ROW.A1 * o + i] = a1
    work[RUN_ROW.S0 * o + i] = sgp
    work[RUN_ROW.S1 * o + i] = sg1
    work[RUN_ROW.F0 * o + i] = fp
    work[RUN_ROW.WF0 * o + i] = wp
    work[RUN_ROW.F1 * o + i] = f1
    work[RUN_ROW.WF1 * o + i] = w1
    # the end of this piece, pending at knot j: its Taylor coefficients around
    # the arrival (not when the end falls on a new accumulation block: the
    # piece was not continued there)
    end = simple & ~cut & (s1 < fn) & (s1 < (b1 + 1.0) * fblock)
    work[RUN_ROW.P * o + i] = where(end, f1, 0.0)
    work[(RUN_ROW.P + 1) * o + i] = where(end, w1, 0.0)
    work[(RUN_ROW.P + 2) * o + i] = where(end, c2 + 3.0 * c3 * L, 0.0)
    work[(RUN_ROW.P + 3) * o + i] = where(end, c3, 0.0)
    work[RUN_ROW.PF * o + i] = where(end, 1.0, 0.0)
    if gained:
        work[RUN_ROW.PA * o + i] = where(end, -f1 * inv_l, 0.0)
        work[(RUN_ROW.PA + 1) * o + i] = where(end, c2a + 3.0 * c3a * L, 0.0)
        work[(RUN_ROW.PA + 2) * o + i] = where(end, c3a, 0.0)
    work[RUN_ROW.U * o + i] = u
    work[RUN_ROW.SM * o + i] = s
    work[RUN_ROW.F * o + i] = f
    work[RUN_ROW.W * o + i] = wr
    work[RUN_ROW.A * o + i] = a
    work[RUN_ROW.SG * o + i] = sg
    work[RUN_ROW.OK * o + i] = where(ok, 1.0, 0.0)


@numba.njit(inline="always", **_NJIT)
def _run_first(work, i, la, lb, two, grid, gained):
    """The state of the first knot of the run in lane i that a task sweeps
    (see :func:`_run_step`; no piece ends there)."""
    c0, inv_c0, t_start, fs, inv_fs = grid.c0, grid.inv_c0, grid.t_start, grid.fs, grid.inv_fs
    o = _CHUNK
    a, d, e, sg, ok = _knot_arrival(
        work[RUN_ROW.X * o + i],
        work[RUN_ROW.Y * o + i],
        work[RUN_ROW.Z * o + i],
        work[RUN_ROW.RM * o + i],
        la,
        lb,
        c0,
        inv_c0,
        two,
    )
    inv_d = 1.0 / d
    dd = e * inv_d
    f = work[RUN_ROW.Q * o + i] * inv_d
    u = (a - t_start) * fs
    work[RUN_ROW.U * o + i] = u
    work[RUN_ROW.SM * o + i] = np.ceil(u)
    work[RUN_ROW.F * o + i] = f
    work[RUN_ROW.W * o + i] = (
        (work[RUN_ROW.M * o + i] * (1.0 - dd * inv_c0) - f * dd) * inv_d * inv_fs
    )
    work[RUN_ROW.A * o + i] = a
    work[RUN_ROW.SG * o + i] = sg
    work[RUN_ROW.OK * o + i] = where(ok, 1.0, 0.0)
    for r in range(RUN_ROW.P, RUN_ROW.PF + 1):
        work[r * o + i] = 0.0
    if gained:
        for r in range(RUN_ROW.PA, RUN_ROW.PA + 3):
            work[r * o + i] = 0.0


@numba.njit(fastmath={"contract"}, **_NJIT)
def _chunk_step(work, cnt, j, lines_prev, row_lines, two, cubic, first, grid, gained):
    """:func:`_run_step` over the cnt lanes of a chunk (knot j of its runs,
    candidate lines of its row ``row_lines`` and of the previous row
    ``lines_prev``; separate loops for one and two candidate lines, with and
    without gains, so that each stays branch-free)."""
    la = _line_tuple(row_lines, 0)
    lb = _line_tuple(row_lines, _LINE)
    lines = (la, lb)
    lines_p = (_line_tuple(lines_prev, 0), _line_tuple(lines_prev, _LINE))
    t_n = la[6]
    fj = float(j)
    if first:  # the knot only: no piece ends here
        if gained:
            for i in range(cnt):
                _run_first(work, i, la, lb, two, grid, True)
        else:
            for i in range(cnt):
                _run_first(work, i, la, lb, two, grid, False)
    elif gained:
        if two:
            for i in range(cnt):
                _run_step(work, i, fj, lines_p, lines, t_n, True, cubic, first, grid, True)
        else:
            for i in range(cnt):
                _run_step(work, i, fj, lines_p, lines, t_n, False, cubic, first, grid, True)
    elif two:
        for i in range(cnt):
            _run_step(work, i, fj, lines_p, lines, t_n, True, cubic, first, grid, False)
    else:
        for i in range(cnt):
            _run_step(work, i, fj, lines_p, lines, t_n, False, cubic, first, grid, False)


@numba.njit(**_NJIT)
def _knot_gains(
    work, cnt, row_lines, orient_table, orient_clock, tab, const_orient, gains, scratch
):
    """AmbiX gains ``gains (n_ch, _CHUNK)`` of the knot just solved in each lane
    (arrival and capture interval in rows A, SG; the listener on the
    candidate lines of row_lines): the direction in the listener's frame at the
    arrival, harmonics by :func:`_sh_lanes` (as the piece-wise kernel's
    :func:`~auralize.emitters._kernels.lane_gains._chunk_sh_gains` at a piece's ends).  A knot heard
    on neither line (left to the scalar code) gets some finite gains."""
    o = _CHUNK
    la = _line_tuple(row_lines, 0)
    lb = _line_tuple(row_lines, _LINE)
    if not const_orient:
        for i in range(cnt):
            _orient_rows(work, i, RUN_ROW.OR, orient_table, orient_clock, work[RUN_ROW.A * o + i])
    # (branch-free: the loop vectorizes)
    for i in range(cnt):
        a = work[RUN_ROW.A * o + i]
        px, py, pz = _listener_at(a, work[RUN_ROW.SG * o + i], la, lb)
        dx = work[RUN_ROW.X * o + i] - px
        dy = work[RUN_ROW.Y * o + i] - py
        dz = work[RUN_ROW.Z * o + i] - pz
        fx, fy, fz = (
            work[RUN_ROW.OR * o + i],
            work[(RUN_ROW.OR + 1) * o + i],
            work[(RUN_ROW.OR + 2) * o + i],
        )
        ux, uy, uz = (
            work[(RUN_ROW.OR + 3) * o + i],
            work[(RUN_ROW.OR + 4) * o + i],
            work[(RUN_ROW.OR + 5) * o + i],
        )
        lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
        ok = work[RUN_ROW.OK * o + i] != 0.0
        work[RUN_ROW.DIR * o + i] = where(ok, dx * fx + dy * fy + dz * fz, 1.0)
        work[(RUN_ROW.DIR + 1) * o + i] = where(ok, dx * lx + dy * ly + dz * lz, 0.0)
        work[(RUN_ROW.DIR + 2) * o + i] = where(ok, dx * ux + dy * uy + dz * uz, 0.0)
    _sh_lanes(work, cnt, RUN_ROW.DIR, RUN_ROW.DIR + 1, RUN_ROW.DIR + 2, tab, gains, scratch)


@numba.njit(inline="always", **_NJIT)
def _add_split(acc, row, work, i, g2, g1, g0, n_ch):
    """acc[row + 4c : row + 4c + 4] += g2[c, i]·X + g1[c, i]·Y + g0[c, i]·Z for
    every channel c (X, Y, Z in rows GX, GY, GZ of lane i; row >= 0)."""
    a = np.uint64(row)
    o = _CHUNK
    x0, x1 = work[RUN_ROW.GX * o + i], work[(RUN_ROW.GX + 1) * o + i]
    x2, x3 = work[(RUN_ROW.GX + 2) * o + i], work[(RUN_ROW.GX + 3) * o + i]
    y0, y1 = work[RUN_ROW.GY * o + i], work[(RUN_ROW.GY + 1) * o + i]
    y2, y3 = work[(RUN_ROW.GY + 2) * o + i], work[(RUN_ROW.GY + 3) * o + i]
    z0, z1 = work[RUN_ROW.GZ * o + i], work[(RUN_ROW.GZ + 1) * o + i]
    z2, z3 = work[(RUN_ROW.GZ + 2) * o + i], work[(RUN_ROW.GZ + 3) * o + i]
    for c in range(n_ch):
        a2 = g2[c, i]
        a1 = g1[c, i]
        a0 = g0[c, i]
        r = a + np.uint64(4 * c)
        acc[r] += a2 * x0 + a1 * y0 + a0 * z0
        acc[r + np.uint64(1)] += a2 * x1 + a1 * y1 + a0 * z1
        acc[r + np.uint64(2)] += a2 * x2 + a1 * y2 + a0 * z2
        acc[r + np.uint64(3)] += a2 * x3 + a1 * y3 + a0 * z3


@numba.njit(inline="always", **_NJIT)
def _copy_rows(work, r, knot_data, off, n_rows, cnt):
    """Rows r.. of work (n_rows of them, cnt lanes) from knot_data[off:]: unsigned
    indices (no wraparound checks), so that the copy vectorizes."""
    for k in range(n_rows):
        dst = np.uint64((r + k) * _CHUNK)
        src = np.uint64(off + k * _CHUNK)
        for i in range(cnt):
            work[dst + np.uint64(i)] = knot_data[src + np.uint64(i)]


@numba.njit(**_NJIT_NORC)
def render_task(task, runs, rows, cubic, c0, lis, pan, out, scr, work, gains, sh_scratch):
    """Sum the runs of task ``task`` into its accumulator window and capture table;
    returns the number of emissions outside the window (an internal error).

    Task j sums the pieces of knot rows ``runs.task_rows[j, 0]`` ..
    ``runs.task_rows[j, 1] - 1`` (the runs cut at its first and last knot rows;
    tasks split time, so their windows barely overlap) into its window
    ``out.task_blk[j]`` (:class:`~auralize.emitters._kernels.common.Accumulator`).
    ``runs``: the runs in chunks (:class:`~auralize.emitters._kernels.common.RunTable`);
    ``rows``, ``cubic``, ``c0``, ``lis`` as for
    :func:`auralize.emitters._kernels.render_pieces.render_task`.  ``pan``: unpanned
    (one channel), or an AmbiX layout of ``out.n_ch`` channels whose spherical-harmonic
    table (:func:`~auralize.emitters._kernels.gains._gains_sh`) is ``pan.pinv``, with
    ``pan.dense`` set (placeholder speakers for the scalar code's
    :func:`~auralize.emitters._kernels.gains._pan_far`).  The task's work arrays:
    ``scr`` (:class:`~auralize.emitters._kernels.common.Scratch`), ``work`` (rows
    :data:`~auralize.emitters._kernels.common.RUN_ROW`, up to ``PLAIN_END`` when
    unpanned), ``gains (3, n_ch, _CHUNK)`` (the gains of the last three knots, slot
    k % 3 for knot k; no channels when unpanned) and ``sh_scratch (5, _CHUNK)``.
    """
    gr0, glen, gcnt, goff, knot_data = (
        runs.first_row,
        runs.length,
        runs.count,
        runs.offset,
        runs.knot_data,
    )
    tn, n_lo, n_hi, row_lines = rows.knot_times, rows.n_lo, rows.n_hi, rows.row_lines
    orient_table, orient_clock = lis.orient_table, lis.orient_clock
    acc, n_ch, shift, t_start, fs = out.acc, out.n_ch, out.shift, out.t_start, out.fs
    tab, gained, const_orient = pan.pinv, pan.dense, pan.const_orient
    ga, gb, o6 = scr.ga, scr.gb, scr.frame
    block = 1 << shift
    fblock = float(block)
    rs = 4.0 * n_ch
    n_rows = RUN_ROW.END if gained else RUN_ROW.PLAIN_END
    blk = out.task_blk[task]
    blo, nb, base = blk[0], blk[1], blk[2]
    _clear_window(acc, blk, n_ch, block, out.n_samples)
    task_captures = out.capture_sums[task]
    task_captures[:] = 0.0
    win = Window(
        acc,
        base,
        blo,
        nb,
        n_ch,
        shift,
        out.n_samples,
        t_start,
        fs,
        task_captures,
        out.first_capture,
    )
    grid = lane_grid(c0, win)
    scratch = sh_scratch
    nbad = 0
    ra = max(runs.task_rows[task, 0], n_lo)
    rb = min(runs.task_rows[task, 1], n_hi)
    for g in range(gr0.size):
        r0 = gr0[g]
        if r0 >= rb:
            break
        cnt = gcnt[g]
        off = goff[g]
        ka = max(r0, ra)
        kb = min(r0 + glen[g], rb)
        if kb <= ka:
            continue
        _copy_rows(work, 0, knot_data, off, 5, cnt)
        for r in range(RUN_ROW.U, n_rows):
            for i in range(cnt):
                work[r * _CHUNK + i] = 0.0
        if gained:
            gains[:] = 0.0
            if const_orient:
                for c in range(6):
                    for i in range(cnt):
                        work[(RUN_ROW.OR + c) * _CHUNK + i] = orient_table[0, c]
        for n in range(ka, kb + 1):
            jk = n - r0
            kq = off + (KNOT_ROW.KNOT + 2 * jk) * _CHUNK
            _copy_rows(work, RUN_ROW.Q, knot_data, kq, 2, cnt)
            if jk >= 1:
                _copy_rows(work, RUN_ROW.QP, knot_data, kq - 2 * _CHUNK, 2, cnt)
            first = n == ka
            two = row_lines[n, 2 * _LINE] != 0.0 or (
                not first and row_lines[n - 1, 2 * _LINE] != 0.0
            )
            rp = n if first else n - 1
            _chunk_step(work, cnt, jk, row_lines[rp], row_lines[n], two, cubic, first, grid, gained)
            g0 = gains[jk % 3]  # knot n
            g1 = gains[(jk + 2) % 3]  # knot n - 1
            g2 = gains[(jk + 1) % 3]  # knot n - 2
            if gained:
                _knot_gains(
                    work,
                    cnt,
                    row_lines[n],
                    orient_table,
                    orient_clock,
                    tab,
                    const_orient,
                    g0,
                    scratch,
                )
            if first:
                continue
            for i in range(cnt):
                if gained and i + _AHEAD_G < cnt:
                    # the emission rows of AmbiX layouts span several cache
                    # lines: fetched a few lanes ahead
                    ea = work[RUN_ROW.EROW * _CHUNK + i + _AHEAD_G]
                    if ea >= 0.0:
                        for k in range(0, 4 * n_ch, 8):
                            _prefetch(acc, np.uint64(ea) + np.uint64(k))
                er = work[RUN_ROW.EROW * _CHUNK + i]
                if er >= 0.0:
                    if gained:
                        _add_split(acc, er, work, i, g2, g1, g0, n_ch)
                    else:
                        _add_plain(acc, er, work, RUN_ROW.E, i)
                mr0 = work[RUN_ROW.RROW * _CHUNK + i]
                if mr0 >= 0.0:
                    row = int(base + (mr0 - blo * fblock) * rs)
                    x = mr0 - (work[RUN_ROW.A0 * _CHUNK + i] - t_start) * fs
                    f0, w0 = work[RUN_ROW.F0 * _CHUNK + i], work[RUN_ROW.WF0 * _CHUNK + i]
                    c2, c3 = work[RUN_ROW.C2 * _CHUNK + i], work[(RUN_ROW.C2 + 1) * _CHUNK + i]
                    if gained:
                        c2a, c3a = (
                            work[RUN_ROW.CA * _CHUNK + i],
                            work[(RUN_ROW.CA + 1) * _CHUNK + i],
                        )
                        fl = work[(RUN_ROW.CA + 2) * _CHUNK + i]
                        for c in range(n_ch):
                            ha = g1[c, i]
                            hb = g0[c, i]
                            _emit1(
                                acc,
                                row + 4 * c,
                                x,
                                ha * f0,
                                ha * (w0 - fl) + hb * fl,
                                ha * c2a + hb * (c2 - c2a),
                                ha * c3a + hb * (c3 - c3a),
                                1.0,
                            )
                    else:
                        _emit1(acc, row, x, f0, w0, c2, c3, 1.0)
                kd = work[RUN_ROW.KIND * _CHUNK + i]
                if kd < KIND_GENERAL:
                    continue
                x, y, z = (
                    work[RUN_ROW.X * _CHUNK + i],
                    work[RUN_ROW.Y * _CHUNK + i],
                    work[RUN_ROW.Z * _CHUNK + i],
                )
                rm = work[RUN_ROW.RM * _CHUNK + i]
                q0, m0 = work[RUN_ROW.QP * _CHUNK + i], work[RUN_ROW.MP * _CHUNK + i]
                q1 = work[RUN_ROW.Q * _CHUNK + i]
                m1 = work[RUN_ROW.M * _CHUNK + i] if cubic else m0
                piece = (x, y, z, rm, q0, m0, q1, m1)
                if kd == KIND_ACROSS:
                    a0, a1 = work[RUN_ROW.A0 * _CHUNK + i], work[RUN_ROW.A1 * _CHUNK + i]
                    s0 = int(work[RUN_ROW.S0 * _CHUNK + i])
                    s1 = int(work[RUN_ROW.S1 * _CHUNK + i])
                    if gained:
                        _pan_far(x, y, z, a0, s0, lis, pan, ga, o6)
                        _pan_far(x, y, z, a1, s1, lis, pan, gb, o6)
                    ends = (
                        a0,
                        a1,
                        s0,
                        s1,
                        work[RUN_ROW.F0 * _CHUNK + i],
                        work[RUN_ROW.WF0 * _CHUNK + i] * fs,
                        work[RUN_ROW.F1 * _CHUNK + i],
                        work[RUN_ROW.WF1 * _CHUNK + i] * fs,
                    )
                    nbad += _piece_across(win, lis, pan, scr, piece, tn, n - 1, cubic, c0, ends)
                else:
                    nbad += _piece_general(
                        win, lis, pan, scr, piece, tn, n - 1, int(row_lines[n - 1, 11]), cubic, c0
                    )
        # the end of the last piece (its knot has no piece after it here):
        # slots as after the last knot, kb
        g0 = gains[(kb - r0) % 3]
        g1 = gains[(kb - r0 + 2) % 3]
        for i in range(cnt):
            if work[RUN_ROW.PF * _CHUNK + i] != 0.0:
                sm = work[RUN_ROW.SM * _CHUNK + i]
                row = int(base + (sm - blo * fblock) * rs)
                x = sm - work[RUN_ROW.U * _CHUNK + i]
                p0, p1 = work[RUN_ROW.P * _CHUNK + i], work[(RUN_ROW.P + 1) * _CHUNK + i]
                p2, p3 = work[(RUN_ROW.P + 2) * _CHUNK + i], work[(RUN_ROW.P + 3) * _CHUNK + i]
                if gained:
                    pa1, pa2 = (work[RUN_ROW.PA * _CHUNK + i], work[(RUN_ROW.PA + 1) * _CHUNK + i])
                    pa3 = work[(RUN_ROW.PA + 2) * _CHUNK + i]
                    for c in range(n_ch):
                        ha = g1[c, i]
                        hb = g0[c, i]
                        _emit1(
                            acc,
                            row + 4 * c,
                            x,
                            hb * p0,
                            ha * pa1 + hb * (p1 - pa1),
                            ha * pa2 + hb * (p2 - pa2),
                            ha * pa3 + hb * (p3 - pa3),
                            -1.0,
                        )
                else:
                    _emit1(acc, row, x, p0, p1, p2, p3, -1.0)
    return nbad + _flush_captures(win, lis.times, blk[3])
