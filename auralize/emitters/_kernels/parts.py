"""Parts: the pieces of a knot row whose arrivals cross listener captures (a path
recorded at 10-20 Hz: most of them), split at those captures.

On capture interval j the listener moves on one line, so the emissions of a
piece heard there form a part whose ends are a knot (arrival solved on the
line) or a capture (arrival at the capture, q from the piece's Hermite):
exactly the split of :func:`auralize.emitters._kernels.pieces._piece_across`,
in SIMD loops over batches of parts (:func:`_chunk_parts`,
:func:`_part_batch`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from auralize.emitters._kernels.accumulate import (
    _AHEAD,
    NO_ROW,
    _emit_gained,
    _prefetch_lane,
    _scatter_group,
    _scatter_simple,
)
from auralize.emitters._kernels.arrivals import _line_arrival
from auralize.emitters._kernels.common import (
    _CHUNK,
    _NJIT,
    _NJIT_NORC,
    KIND_ACROSS,
    KIND_SILENT,
    KIND_SIMPLE,
    ROW,
    lane_grid,
    where,
)
from auralize.emitters._kernels.gains import _pan
from auralize.emitters._kernels.hermite import _hermite_at, _piece_values
from auralize.emitters._kernels.lane_gains import _part_pair_gains
from auralize.emitters._kernels.pieces import _piece_tail


@numba.njit(inline="always", **_NJIT)
def _part_end(piece, at_knot, t_k, qk, mk, capture, line, t_n, h, c0, inv_c0):
    """One end of a part of ``piece`` = (x, y, z, clamp radius, q0, dq/dτ0, q1,
    dq/dτ1; knots t_n, t_n + h) on the listener's ``line`` = (L, V, tr, den,
    1/den: position L at time tr, velocity V, den = c0² - V²): at a knot
    (``at_knot``: the emission at t_k, strength qk, dq/dτ mk, solved on the
    line as in :func:`~auralize.emitters._kernels.arrivals._line_arrival`) or
    at a capture (``capture`` = (position, time): the arrival is the
    capture's time; the emission heard there and its q, dq/dτ from the
    piece's Hermite); returns arrival, D, D·dD/dt, q and dq/dτ (branch-free)."""
    x, y, z, rm, q0, m0, q1, m1 = piece
    cx, cy, cz, ck = capture
    lx, ly, lz, vx, vy, vz, tr, den, inv_den = line
    dt = t_k - tr
    a1, d1, e1 = _line_arrival(
        x,
        y,
        z,
        rm,
        (lx + vx * dt, ly + vy * dt, lz + vz * dt),
        (vx, vy, vz),
        t_k,
        inv_den,
        den,
        c0,
        inv_c0,
    )
    px = cx - x
    py = cy - y
    pz = cz - z
    d = math.sqrt(px * px + py * py + pz * pz)
    clamp = d <= rm
    e2 = where(clamp, 0.0, px * vx + py * vy + pz * vz)
    d2 = where(clamp, rm, d)
    a2 = ck
    q2, m2 = _hermite_at(t_n, h, q0, m0, q1, m1, a2 - d2 * inv_c0)
    return (
        where(at_knot, a1, a2),
        where(at_knot, d1, d2),
        where(at_knot, e1, e2),
        where(at_knot, qk, q2),
        where(at_knot, mk, m2),
    )


@numba.njit(inline="always", **_NJIT)
def _part_core(work, i, t_n, t_n1, grid):
    """Arrivals, kind and accumulator rows of the part in lane i of ``work``
    (see :func:`_chunk_parts`): the piece's emissions heard on the listener's
    line of capture interval j (rows LN), from its first knot (t_n) or
    capture j (rows C0) to its last knot (t_n1) or capture j + 1 (rows C1);
    returns the Hermite data and emission offsets as
    :func:`~auralize.emitters._kernels.pieces._piece_core`.  Reads ``work``
    only (no gathers: the loop vectorizes)."""
    c0, inv_c0 = grid.c0, grid.inv_c0
    k = _CHUNK
    x = work[ROW.X * k + i]
    y = work[ROW.Y * k + i]
    z = work[ROW.Z * k + i]
    rm = work[ROW.RM * k + i]
    q0 = work[ROW.Q0 * k + i]
    m0 = work[ROW.M0 * k + i]
    q1 = work[ROW.Q1 * k + i]
    m1 = work[ROW.M1 * k + i]
    piece = (x, y, z, rm, q0, m0, q1, m1)
    j = work[ROW.J * k + i]
    at0 = work[ROW.K0 * k + i] != 0.0
    at1 = work[ROW.K1 * k + i] != 0.0
    lx, ly, lz = work[ROW.LN * k + i], work[(ROW.LN + 1) * k + i], work[(ROW.LN + 2) * k + i]
    vx, vy, vz = work[(ROW.LN + 3) * k + i], work[(ROW.LN + 4) * k + i], work[(ROW.LN + 5) * k + i]
    tr, den = work[(ROW.LN + 6) * k + i], work[(ROW.LN + 7) * k + i]
    inv_den = work[(ROW.LN + 8) * k + i]
    line = (lx, ly, lz, vx, vy, vz, tr, den, inv_den)
    cap0 = (
        work[ROW.C0 * k + i],
        work[(ROW.C0 + 1) * k + i],
        work[(ROW.C0 + 2) * k + i],
        work[(ROW.C0 + 3) * k + i],
    )
    cap1 = (
        work[ROW.C1 * k + i],
        work[(ROW.C1 + 1) * k + i],
        work[(ROW.C1 + 2) * k + i],
        work[(ROW.C1 + 3) * k + i],
    )
    h = t_n1 - t_n
    a0, d0, e0, qa, ma = _part_end(piece, at0, t_n, q0, m0, cap0, line, t_n, h, c0, inv_c0)
    a1, d1, e1, qb, mb = _part_end(piece, at1, t_n1, q1, m1, cap1, line, t_n, h, c0, inv_c0)
    work[ROW.L0 * k + i] = lx + vx * (a0 - tr)
    work[(ROW.L0 + 1) * k + i] = ly + vy * (a0 - tr)
    work[(ROW.L0 + 2) * k + i] = lz + vz * (a0 - tr)
    work[ROW.L1 * k + i] = lx + vx * (a1 - tr)
    work[(ROW.L1 + 1) * k + i] = ly + vy * (a1 - tr)
    work[(ROW.L1 + 2) * k + i] = lz + vz * (a1 - tr)
    return _piece_tail(work, i, (a0, d0, e0, qa, ma, j, True), (a1, d1, e1, qb, mb, j, True), grid)


@numba.njit(**_NJIT_NORC)
def _part_lanes(work, cnt, knots, grid, panned):
    """The arrivals, kind, accumulator rows and polynomial values of the cnt parts in
    lanes 0..cnt-1 of ``work`` (:func:`_part_core`; ``knots`` = (t_n, t_n1) their
    piece's knot times, ``grid`` a
    :class:`~auralize.emitters._kernels.common.LaneGrid`): SIMD loops, polynomials A
    and B when ``panned`` (see
    :func:`~auralize.emitters._kernels.pieces._chunk_pieces`)."""
    t_n, t_n1 = knots
    if panned:
        for i in range(cnt):
            L, inv, f0, w0, f1, w1, x0, x1, x2 = _part_core(work, i, t_n, t_n1, grid)
            _piece_values(work, ROW.VAL_A, i, L, inv, f0, w0 - f0 * inv, 0.0, -f1 * inv, x0, x1, x2)
            _piece_values(work, ROW.VAL_B, i, L, inv, 0.0, f0 * inv, f1, w1 + f1 * inv, x0, x1, x2)
    else:
        for i in range(cnt):
            L, inv, f0, w0, f1, w1, x0, x1, x2 = _part_core(work, i, t_n, t_n1, grid)
            _piece_values(work, ROW.VAL_A, i, L, inv, f0, w0, f1, w1, x0, x1, x2)


@numba.njit(**_NJIT_NORC)
def _part_batch(work, cnt, knots, c0, lis, pan, win, scr):
    """Sum the cnt parts in lanes 0..cnt-1 of ``work`` (see :func:`_chunk_parts`;
    ``knots`` = (t_n, t_n1) their piece's knot times): SIMD loops for their
    polynomials (:func:`_part_lanes`) and speaker-pair gains, then a scalar loop
    that adds them to the accumulator window ``win`` (a part over more than two
    accumulation blocks, or with no speaker pair, through
    :func:`~auralize.emitters._kernels.accumulate._emit_gained`).  Returns the
    number of emissions outside the window."""
    acc, t_start, fs, n_ch = win.acc, win.t_start, win.fs, win.n_ch
    panned, pairs, spk_ch, nxt = pan.panned, pan.pairs, pan.spk_ch, pan.nxt
    ga, gb, frame = scr.ga, scr.gb, scr.frame
    _part_lanes(work, cnt, knots, lane_grid(c0, win), panned)
    if pairs:
        _part_pair_gains(
            work, cnt, lis.orient_table, lis.orient_clock, pan.pinv, pan.fold, pan.const_orient
        )
    nbad = 0
    for i in range(_AHEAD):
        _prefetch_lane(acc, work, i, cnt, pairs, spk_ch, nxt)
    for i in range(cnt):
        _prefetch_lane(acc, work, i + _AHEAD, cnt, pairs, spk_ch, nxt)
        kd = work[ROW.KIND * _CHUNK + i]
        if kd == KIND_SILENT:
            continue
        x, y, z = work[ROW.X * _CHUNK + i], work[ROW.Y * _CHUNK + i], work[ROW.Z * _CHUNK + i]
        a0, a1 = work[ROW.A0 * _CHUNK + i], work[ROW.A1 * _CHUNK + i]
        sg = int(work[ROW.J * _CHUNK + i])
        si = ei = ci = -1
        if kd == KIND_SIMPLE:
            done, si, ei, ci = _scatter_simple(acc, work, i, panned, pairs, spk_ch, nxt)
            if done:
                continue
        # a simple part of a layout panned otherwise than by pairs; over several
        # accumulation blocks (KIND_ACROSS), or no speaker pair (KIND_GENERAL)
        if pairs and kd == KIND_ACROSS:
            for c in range(n_ch):
                ga[c] = 0.0
                gb[c] = 0.0
            p0 = int(work[ROW.P0 * _CHUNK + i])
            p1 = int(work[ROW.P1 * _CHUNK + i])
            ga[spk_ch[p0]] += work[ROW.G00 * _CHUNK + i]
            ga[nxt[p0]] += work[ROW.G01 * _CHUNK + i]
            gb[spk_ch[p1]] += work[ROW.G10 * _CHUNK + i]
            gb[nxt[p1]] += work[ROW.G11 * _CHUNK + i]
        elif panned:
            _pan(x, y, z, a0, sg, lis, pan, ga, frame)
            _pan(x, y, z, a1, sg, lis, pan, gb, frame)
        if kd == KIND_SIMPLE:
            for c in range(n_ch):
                if ga[c] != 0.0 or gb[c] != 0.0:
                    _scatter_group(acc, work, i, si, ei, ci, c * 4, ga[c], gb[c])
            continue
        fw = (
            work[ROW.F0 * _CHUNK + i],
            work[ROW.WF0 * _CHUNK + i] * fs,
            work[ROW.F1 * _CHUNK + i],
            work[ROW.WF1 * _CHUNK + i] * fs,
        )
        nbad += _emit_gained(
            win, (a0 - t_start) * fs, (a1 - t_start) * fs, fw, ga, gb, panned, NO_ROW, NO_ROW
        )
    return nbad


@numba.njit(**_NJIT_NORC)
def _chunk_parts(piece_data, ck, cc, captures, knots, work, interval_lines, c0, lis, pan, win, scr):
    """The cc pieces of chunk ck (knot row n: ``knots`` = (t_n, t_n1)) of a row
    whose arrivals may cross the listener's captures ``captures`` = (k_lo,
    k_hi): k_lo..k_hi-1, split there into parts.

    On capture interval j the listener moves on one line, so the emissions of
    a piece heard there (those between τ_j and τ_{j+1}, τ_k = t_k - D_k/c0
    the emission heard at capture k, increasing with k) form a part whose
    ends are a knot (arrival solved on the line) or a capture (arrival t_k,
    q from the piece's Hermite at τ_k): exactly the split of
    :func:`~auralize.emitters._kernels.pieces._piece_across`, in SIMD loops.
    The interval of a knot's arrival is k_lo - 1 plus the number of captures
    k with τ_k <= its time (a count over the candidate captures, SIMD, into
    ``scr.counts``); the parts are then listed in batches of _CHUNK in
    ``work`` (rows X..M1, J, K0, K1, LN, C0, C1; ``interval_lines`` (M+1, 9)
    the listener's line on capture interval j at row j + 1) and summed by
    :func:`_part_batch`.  Returns the number of emissions outside the window.
    """
    k_lo, k_hi = captures
    t_n, t_n1 = knots
    listener_times, listener_pos = lis.times, lis.pos
    counts = scr.counts
    inv_c0 = 1.0 / c0
    uck = np.uint64(ck)
    for i in range(cc):
        counts[i] = 0.0
        counts[_CHUNK + i] = 0.0
    for k in range(k_lo, k_hi):
        lx, ly, lz = listener_pos[k, 0], listener_pos[k, 1], listener_pos[k, 2]
        tk = listener_times[k]
        for i in range(cc):
            ui = np.uint64(i)
            dx = lx - piece_data[uck, np.uint64(0), ui]
            dy = ly - piece_data[uck, np.uint64(1), ui]
            dz = lz - piece_data[uck, np.uint64(2), ui]
            rm = piece_data[uck, np.uint64(3), ui]
            d = math.sqrt(dx * dx + dy * dy + dz * dz)
            d = where(d > rm, d, rm)
            tau = tk - d * inv_c0
            counts[ui] += where(tau <= t_n, 1.0, 0.0)
            counts[np.uint64(_CHUNK) + ui] += where(tau <= t_n1, 1.0, 0.0)
    nbad = 0
    p = np.int64(0)  # typed int64, not the literal 0 (see _constant_rows)
    last = listener_times.size - 1
    for i in range(cc):
        s0 = k_lo - 1 + int(counts[i])
        s1 = k_lo - 1 + int(counts[_CHUNK + i])
        ui = np.uint64(i)
        for j in range(s0, s1 + 1):
            # (unsigned indices, all >= 0: no wraparound checks in this scalar copy)
            for r in range(ROW.INPUT_END):
                work[np.uint64(r * _CHUNK + p)] = piece_data[uck, np.uint64(r), ui]
            work[np.uint64(ROW.J * _CHUNK + p)] = float(j)
            work[np.uint64(ROW.K0 * _CHUNK + p)] = 1.0 if j == s0 else 0.0
            work[np.uint64(ROW.K1 * _CHUNK + p)] = 1.0 if j == s1 else 0.0
            lt = np.uint64(j + 1)
            for r in range(9):
                work[np.uint64((ROW.LN + r) * _CHUNK + p)] = interval_lines[lt, np.uint64(r)]
            k0 = np.uint64(max(j, 0))
            k1 = np.uint64(min(j + 1, last))
            for r in range(3):
                work[np.uint64((ROW.C0 + r) * _CHUNK + p)] = listener_pos[k0, np.uint64(r)]
                work[np.uint64((ROW.C1 + r) * _CHUNK + p)] = listener_pos[k1, np.uint64(r)]
            work[np.uint64((ROW.C0 + 3) * _CHUNK + p)] = listener_times[k0]
            work[np.uint64((ROW.C1 + 3) * _CHUNK + p)] = listener_times[k1]
            p += 1
            if p == _CHUNK:
                nbad += _part_batch(work, p, knots, c0, lis, pan, win, scr)
                p = np.int64(0)
    if p > 0:
        nbad += _part_batch(work, p, knots, c0, lis, pan, win, scr)
    return nbad
