"""The piece-wise kernel's pieces: one source between two consecutive knots (data
steps), heard between the arrivals of their emissions.

Per chunk of :data:`~auralize.emitters._kernels.common._CHUNK` pieces of one
knot row, branch-free loops solve both knots' arrivals on the listener's
candidate lines, the values and slopes of f = q/D at them, the Hermite
cubic and its accumulator values, and the piece's kind
(:data:`~auralize.emitters._kernels.common.KIND_SIMPLE` ...) into the work
array (:func:`_chunk_pieces`).  The scalar code sums the pieces the SIMD
loops cannot: across listener captures (:func:`_piece_across`, where the
listener's velocity, hence df/dt, jumps) and beyond the candidate lines
(:func:`_piece_general`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from auralize.emitters._kernels.accumulate import NO_ROW, _emit_gained
from auralize.emitters._kernels.arrivals import _LINE, _arrival, _fval, _knot_arrival, _line_tuple
from auralize.emitters._kernels.common import (
    _CHUNK,
    _NJIT,
    _NJIT_NORC,
    KIND_ACROSS,
    KIND_GENERAL,
    KIND_SILENT,
    KIND_SIMPLE,
    ROW,
    _inverses,
    lane_grid,
    where,
)
from auralize.emitters._kernels.gains import _pan_far
from auralize.emitters._kernels.hermite import _cut_at_end, _piece_values, _qeval, _take_cut


@numba.njit(inline="always", **_NJIT)
def _piece_core(work, i, l0a, l0b, l1a, l1b, two, grid):
    """Arrivals, kind and accumulator rows of the piece in lane i of ``work``
    (see :func:`_chunk_pieces`; its knots heard on the candidate lines l0a,
    l0b and l1a, l1b, the second of each only if ``two``; ``grid`` a
    :class:`~auralize.emitters._kernels.common.LaneGrid`); returns the Hermite
    data (L, 1/L, f0, w0, f1, w1) and the offsets x0, x1, x2 of its emissions."""
    c0, inv_c0 = grid.c0, grid.inv_c0
    x = work[ROW.X * _CHUNK + i]
    y = work[ROW.Y * _CHUNK + i]
    z = work[ROW.Z * _CHUNK + i]
    rm = work[ROW.RM * _CHUNK + i]
    q0 = work[ROW.Q0 * _CHUNK + i]
    m0 = work[ROW.M0 * _CHUNK + i]
    q1 = work[ROW.Q1 * _CHUNK + i]
    m1 = work[ROW.M1 * _CHUNK + i]
    a0, d0, dd0, sg0, ok0 = _knot_arrival(x, y, z, rm, l0a, l0b, c0, inv_c0, two)
    a1, d1, dd1, sg1, ok1 = _knot_arrival(x, y, z, rm, l1a, l1b, c0, inv_c0, two)
    if two:
        # a piece that crosses a capture at or past the output's end ends there
        cut, ac, dc, ddc, q_cut, m_cut = _cut_at_end(
            (x, y, z, rm, q0, m0, q1, m1), sg0, ok0, l0a, l0b, l1a[6], grid
        )
        a1, d1, dd1, q1, m1, sg1, ok1 = _take_cut(
            cut, (ac, dc, ddc, q_cut, m_cut, sg0), (a1, d1, dd1, q1, m1, sg1, ok1)
        )
    return _piece_tail(
        work, i, (a0, d0, dd0, q0, m0, sg0, ok0), (a1, d1, dd1, q1, m1, sg1, ok1), grid
    )


@numba.njit(inline="always", **_NJIT)
def _piece_tail(work, i, end0, end1, grid):
    """Kind, accumulator rows and Hermite data of the piece in lane i of
    ``work`` from its ends ``end0``, ``end1``: arrival a, distance D,
    D·dD/dt, q, dq/dτ, capture interval sg and whether the arrival was found
    (see :func:`_piece_core`)."""
    a0, d0, dd0, q0, m0, sg0, ok0 = end0
    a1, d1, dd1, q1, m1, sg1, ok1 = end1
    inv_c0, t_start, fs, inv_fs, fn = grid.inv_c0, grid.t_start, grid.fs, grid.inv_fs, grid.fn
    fblock, inv_block, blo, nb = grid.fblock, grid.inv_block, grid.blo, grid.nb
    base, rs = grid.base, grid.rs
    work[ROW.A0 * _CHUNK + i] = a0
    work[ROW.A1 * _CHUNK + i] = a1
    work[ROW.S0 * _CHUNK + i] = sg0
    work[ROW.S1 * _CHUNK + i] = sg1
    u0 = (a0 - t_start) * fs
    u1 = (a1 - t_start) * fs
    L = u1 - u0
    # one division for 1/D0, 1/D1 and 1/L
    L = where(L > 0.0, L, 1.0)
    inv0, inv1, inv_l = _inverses(d0, d1, L)
    dd0 = dd0 * inv0  # dD/dt
    dd1 = dd1 * inv1
    f0 = q0 * inv0
    f1 = q1 * inv1
    w0 = (m0 * (1.0 - dd0 * inv_c0) - f0 * dd0) * inv0 * inv_fs
    w1 = (m1 * (1.0 - dd1 * inv_c0) - f1 * dd1) * inv1 * inv_fs
    s0 = np.ceil(u0)
    s0 = where(s0 > 0.0, s0, 0.0)
    s1 = np.ceil(u1)
    s1 = where(s1 < fn, s1, fn)
    valid = (s1 > s0) & (u1 > u0) & ok0 & ok1
    general = ~(ok0 & ok1)
    work[ROW.F0 * _CHUNK + i] = f0
    work[ROW.WF0 * _CHUNK + i] = w0
    work[ROW.F1 * _CHUNK + i] = f1
    work[ROW.WF1 * _CHUNK + i] = w1
    s0 = where(valid, s0, 0.0)
    s1 = where(valid, s1, 1.0)
    b0 = np.floor(s0 * inv_block)
    b1 = np.floor((s1 - 1.0) * inv_block)
    simple = (sg0 == sg1) & (b1 <= b0 + 1.0) & (b0 >= blo) & (b1 < blo + nb)
    work[ROW.KIND * _CHUNK + i] = where(
        general, KIND_GENERAL, where(valid, where(simple, KIND_SIMPLE, KIND_ACROSS), KIND_SILENT)
    )
    work[ROW.SI * _CHUNK + i] = base + ((b0 - blo) * fblock + (s0 - b0 * fblock)) * rs
    end_inside = (s1 < fn) & (s1 < (b1 + 1.0) * fblock)
    work[ROW.EI * _CHUNK + i] = where(
        end_inside, base + ((b1 - blo) * fblock + (s1 - b1 * fblock)) * rs, -1.0
    )
    work[ROW.CI * _CHUNK + i] = where(b1 > b0, base + (b1 - blo) * fblock * rs, -1.0)
    return L, inv_l, f0, w0, f1, w1, s0 - u0, s1 - u0, b1 * fblock - u0


@numba.njit(inline="always", **_NJIT)
def _one_piece(work, i, l0a, l0b, l1a, l1b, two, panned, grid):
    """One piece of :func:`_chunk_pieces`: its polynomial, or polynomials A and
    B when ``panned`` (a constant in each caller's loop, so the loop stays
    branch-free)."""
    L, inv, f0, w0, f1, w1, x0, x1, x2 = _piece_core(work, i, l0a, l0b, l1a, l1b, two, grid)
    if panned:
        _piece_values(work, ROW.VAL_A, i, L, inv, f0, w0 - f0 * inv, 0.0, -f1 * inv, x0, x1, x2)
        _piece_values(work, ROW.VAL_B, i, L, inv, 0.0, f0 * inv, f1, w1 + f1 * inv, x0, x1, x2)
    else:
        _piece_values(work, ROW.VAL_A, i, L, inv, f0, w0, f1, w1, x0, x1, x2)


@numba.njit(**_NJIT_NORC)
def _chunk_pieces(piece_data, ck, cnt, lines0, lines1, c0, win, panned, work):
    """The cnt pieces of chunk ck (``piece_data[ck]``, of one knot row n: knots
    at t_n with the listener's candidate lines ``lines0``, at t_{n+1} with
    ``lines1``, rows of :func:`~auralize.emitters._kernels.arrivals._row_lines`)
    into lanes 0..cnt-1 of the work array (rows
    :data:`~auralize.emitters._kernels.common.ROW` up to PIECE_END), for the
    accumulator window ``win``: arrivals (A0, A1) and their capture
    intervals (S0, S1), kind (KIND_SILENT, or outside the output;
    KIND_SIMPLE: accumulator rows SI, EI, CI, -1 for none, and 12 values;
    KIND_GENERAL, see :func:`_piece_general`; KIND_ACROSS, see
    :func:`_piece_across`).  Panned layouts get two polynomials A (12 values)
    and B (the next 12) whose sum g0·A + g1·B is the piece on a channel whose
    gain goes linearly from g0 to g1.  SIMD loops: no branches in their
    bodies, integers carried as floats (exact).
    """
    grid = lane_grid(c0, win)
    l0a = _line_tuple(lines0, 0)
    l0b = _line_tuple(lines0, _LINE)
    l1a = _line_tuple(lines1, 0)
    l1b = _line_tuple(lines1, _LINE)
    # (unsigned indices: no wraparound checks, the copy vectorizes)
    uck = np.uint64(ck)
    for r in range(ROW.INPUT_END):
        ur = np.uint64(r)
        for i in range(cnt):
            work[np.uint64(r * _CHUNK + i)] = piece_data[uck, ur, np.uint64(i)]
    # one candidate line per knot when no arrival can pass its end (most
    # steps): separate loops, so each stays branch-free
    two = lines0[2 * _LINE] != 0.0 or lines1[2 * _LINE] != 0.0
    if panned and two:
        for i in range(cnt):
            _one_piece(work, i, l0a, l0b, l1a, l1b, True, True, grid)
    elif panned:
        for i in range(cnt):
            _one_piece(work, i, l0a, l0b, l1a, l1b, False, True, grid)
    elif two:
        for i in range(cnt):
            _one_piece(work, i, l0a, l0b, l1a, l1b, True, False, grid)
    else:
        for i in range(cnt):
            _one_piece(work, i, l0a, l0b, l1a, l1b, False, False, grid)


@numba.njit(**_NJIT_NORC)
def _piece_general(win, lis, pan, scr, piece, tn, n, seg, cubic, c0):
    """Piece n (knots n, n + 1) of a source ``piece`` = (x, y, z, clamp
    radius, q0, dq/dτ0, q1, dq/dτ1) in full: arrivals solved across the
    listener's captures (:func:`_arrival`; seg: the capture interval holding
    t_n, where the search starts), gains (into ``scr.ga``, ``scr.gb``), then
    :func:`_piece_across`.  ``win``, ``lis``, ``pan``, ``scr``: the
    :class:`~auralize.emitters._kernels.common.Window`, ``Listener``,
    ``Panning`` and ``Scratch`` of the task."""
    x, y, z, rmin, q0, m0, q1, m1 = piece
    t_start, fs, n_samples = win.t_start, win.fs, win.n_samples
    a0, d0, dd0, s0 = _arrival(x, y, z, rmin, tn[n], seg, lis.times, lis.pos, lis.vel, c0)
    a1, d1, dd1, s1 = _arrival(x, y, z, rmin, tn[n + 1], s0, lis.times, lis.pos, lis.vel, c0)
    t_end = t_start + n_samples / fs
    if a1 <= t_start or a0 >= t_end or a1 <= a0:
        return 0
    va, wa = _fval(q0, m0, d0, dd0, c0)
    vb, wb = _fval(q1, m1, d1, dd1, c0)
    if pan.panned:
        _pan_far(x, y, z, a0, s0, lis, pan, scr.ga, scr.frame)
        _pan_far(x, y, z, a1, s1, lis, pan, scr.gb, scr.frame)
    return _piece_across(
        win, lis, pan, scr, piece, tn, n, cubic, c0, (a0, a1, s0, s1, va, wa, vb, wb)
    )


@numba.njit(**_NJIT_NORC)
def _piece_across(win, lis, pan, scr, piece, tn, n, cubic, c0, ends):
    """Piece n of a source ``piece`` (as :func:`_piece_general`) from
    ``ends`` = (a0, a1, s0, s1, va, wa, vb, wb): arrival a0 (capture interval
    s0, f = va, df/dt = wa per data second, gains ``scr.ga``) to a1 (s1, vb,
    wb, ``scr.gb``), split at the listener's captures inside it: the
    listener's velocity changes there, so does df/dt, and f, df/dt and the
    gains are evaluated on either side; continued across accumulation
    blocks.  The emissions at the captures go to the window's capture table
    (its row r: capture ``win.first_capture + r``) where it has a row for
    them (:func:`~auralize.emitters._kernels.accumulate._emit_piece`)."""
    x, y, z, rmin, q0, m0, q1, m1 = piece
    a0, a1, s0, s1, va, wa, vb, wb = ends
    t_start, fs, n_ch, first_capture = win.t_start, win.fs, win.n_ch, win.first_capture
    listener_times, listener_pos, listener_vel = lis.times, lis.pos, lis.vel
    ga, gb, gx, gy = scr.ga, scr.gb, scr.gx, scr.gy
    panned = pan.panned
    bad = 0
    n_ct = win.capture_sums.size // (4 * n_ch)
    r0 = NO_ROW
    u0 = (a0 - t_start) * fs
    for c in range(n_ch):
        gy[c] = ga[c] if panned else 1.0
    m = listener_times.size
    seg = s0
    while seg < s1:
        t1 = listener_times[seg + 1]
        # at the capture the listener is at listener_pos[seg + 1] whichever
        # line: D, the emission time and q are the same on both sides, dD/dt
        # is not
        px = listener_pos[seg + 1, 0] - x
        py = listener_pos[seg + 1, 1] - y
        pz = listener_pos[seg + 1, 2] - z
        d = math.sqrt(px * px + py * py + pz * pz)
        inside = d <= rmin
        d = rmin if inside else d
        qv, dq = _qeval(tn[n], tn[n + 1] - tn[n], q0, m0, q1, m1, t1 - d / c0, cubic)
        # f and its derivative just before the capture ...
        ddl = 0.0
        if not inside and seg >= 0:
            vx, vy, vz = listener_vel[seg, 0], listener_vel[seg, 1], listener_vel[seg, 2]
            ddl = (px * vx + py * vy + pz * vz) / d
        v1, w1 = _fval(qv, dq, d, ddl, c0)
        if panned:
            _pan_far(x, y, z, t1, seg, lis, pan, gx, scr.frame)
        u1 = (t1 - t_start) * fs
        r1 = seg + 1 - first_capture
        if r1 < 0 or r1 >= n_ct:
            r1 = NO_ROW
        bad += _emit_gained(win, u0, u1, (va, wa, v1, w1), gy, gx, panned, r0, r1)
        seg += 1
        # ... and just after it, on the next line (held after the last capture)
        ddr = 0.0
        if not inside and seg < m - 1:
            vx, vy, vz = listener_vel[seg, 0], listener_vel[seg, 1], listener_vel[seg, 2]
            ddr = (px * vx + py * vy + pz * vz) / d
        va, wa = _fval(qv, dq, d, ddr, c0)
        if panned:
            for c in range(n_ch):
                gy[c] = gx[c]
        u0 = u1
        r0 = r1
    return bad + _emit_gained(
        win, u0, (a1 - t_start) * fs, (va, wa, vb, wb), gy, gb, panned, r0, NO_ROW
    )
