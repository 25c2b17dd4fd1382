"""Compiled unpanned synthesis by runs of pieces: one emission per knot.

Same sum as :func:`auralize.emitters._synth_kernel.render` (see its module docstring
for the pieces, the Hermite cubic of f = q(τ)/D on each piece and the
skewed accumulator), organised so that consecutive pieces of a source share
their common knot:

* a **run** is a maximal stretch of consecutive sounding pieces of one
  source; runs with the same first row, sorted by length, fill chunks of
  :data:`_CHUNK` lanes whose knot data (q and dq/dτ per knot) are
  contiguous;
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

AmbiX layouts (the spherical harmonics of :func:`_synth_kernel._gains_sh`,
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

import math

import numba
import numpy as np

from auralize.emitters._synth_kernel import (
    _CHUNK,
    _LINE,
    _NJIT,
    _add_plain,
    _clear_window,
    _constant_rows,
    _cut_at_end,
    _emit1,
    _flush_captures,
    _integrate,
    _inverses,
    _knot_arrival,
    _knot_m,
    _knot_q,
    _line_tuple,
    _listener_at,
    _orient_rows,
    _pan_far,
    _piece_across,
    _piece_general,
    _prefetch,
    _row_lines,
    _sh_lanes,
    _shifted,
    _take_cut,
)
from auralize.runtime.jit import configure as _configure_numba

_configure_numba()  # cache folder, OMP wait policy, compile notice

#: rows of a chunk in the knot data (each _CHUNK lanes): position, clamp
#: radius, run length (pieces), then per knot j: q at _K_KNOT + 2j, dq/dτ at
#: _K_KNOT + 2j + 1 (linear interpolation: the slope of the piece from knot j)
_K_X, _K_Y, _K_Z, _K_RM, _K_LEN, _K_KNOT = 0, 1, 2, 3, 4, 5

#: rows of the work array (one 1-D array of rows of _CHUNK: constant distances,
#: no aliasing checks): inputs of a step ...
_R_X, _R_Y, _R_Z, _R_RM, _R_LEN, _R_Q, _R_M, _R_QP, _R_MP = 0, 1, 2, 3, 4, 5, 6, 7, 8
#: ... its outputs: the emission at the previous knot (row, 4 values), the
#: restart of the piece that ends at this knot (sample; the cubic's c2, c3),
#: the piece's kind and what the scalar code needs of it ...
_R_EROW, _R_E, _R_RROW, _R_C2, _R_KIND = 9, 10, 14, 15, 19
_R_A0, _R_A1, _R_S0, _R_S1, _R_F0, _R_WF0, _R_F1, _R_WF1 = 20, 21, 22, 23, 24, 25, 26, 27
#: ... and the state carried from knot to knot: arrival in samples, its
#: sample, f, df/dt (per sample, of the piece that starts there), arrival,
#: capture interval, found, and the pending end of the piece that ends there
#: (4 Taylor coefficients around the arrival; flag)
_R_U, _R_SM, _R_F, _R_W, _R_A, _R_SG, _R_OK, _R_P, _R_PF = 28, 29, 30, 31, 32, 33, 34, 35, 39
_R_ROWS = 40
#: AmbiX runs only: the emission at the previous knot split by gain (X, Y, Z:
#: 4 rows each, see the module docstring), the A part of this piece's c2, c3
#: and f/L at its start (B's slope there), the A part of the pending end (its
#: slope, c2, c3: its value is 0), the listener's forward and up at the
#: knot's arrival and the knot's direction in the listener's frame
_R_GX, _R_GY, _R_GZ, _R_CA, _R_PA, _R_OR, _R_DIR = 40, 44, 48, 52, 55, 58, 64
_RG_ROWS = 67
#: lanes ahead whose emission rows the AmbiX scatter prefetches
_AHEAD_G = 8


@numba.njit(inline="always", **_NJIT)
def _run_step(W, i, j, la_p, lb_p, la, lb, t_n, two, cubic, first, c0, inv_c0, t_start, fs,
              inv_fs, fn, fblock, inv_block, blo, nb, base, rs, gained):  # fmt: skip  # type: ignore[no-untyped-def]
    """Knot j (time t_n, candidate lines la, lb) of the run in lane i, and the
    piece from knot j - 1 (lines la_p, lb_p) to it; branch-free.

    Writes the emission at knot j - 1 (start of this piece minus the pending
    end of the previous one, Taylor-shifted to the knot's sample), this
    piece's restart (at sample 0 when it starts before the output, or at
    the first sample of the next accumulation block it runs into), its kind
    (0 silent or outside, 1 in the shared emissions, 2 general, 3 across
    captures: both summed by the scalar code), and carries knot j's state.
    ``gained`` (AmbiX runs): also the emission split by gain (rows GX, GY,
    GZ) and the A parts (rows CA, PA); a piece cut at a capture is left to
    the scalar code (its end's gains are not the knot's).
    """
    o = _CHUNK
    x = W[_R_X * o + i]
    y = W[_R_Y * o + i]
    z = W[_R_Z * o + i]
    rm = W[_R_RM * o + i]
    q = W[_R_Q * o + i]
    mr = W[_R_M * o + i]
    qp = W[_R_QP * o + i]
    mp = W[_R_MP * o + i]
    m1 = mr if cubic else mp  # dq/dτ at the piece's end (linear: its slope)
    a, d, e, sg, ok = _knot_arrival(x, y, z, rm, la, lb, c0, inv_c0, two)
    up = W[_R_U * o + i]
    sp = W[_R_SM * o + i]
    fp = W[_R_F * o + i]
    wp = W[_R_W * o + i]
    ap = W[_R_A * o + i]
    sgp = W[_R_SG * o + i]
    okp = W[_R_OK * o + i] != 0.0
    # the piece's end: the knot, or where it is cut (a capture at or past the
    # output's end that its arrivals cross)
    a1, d1, e1, q1, me, sg1, ok1 = a, d, e, q, m1, sg, ok
    cut = False
    if two:
        cut, ac, dc, ec, qc, mc = _cut_at_end(x, y, z, rm, qp, mp, q, m1, sgp, okp, la_p, lb_p,
                                              t_n, c0, inv_c0, t_start, fs, fn)  # fmt: skip
        cut = cut & ~first
        a1, d1, e1, q1, me, sg1, ok1 = _take_cut(cut, ac, dc, ec, qc, mc, sgp, a, d, e, q, m1, sg,
                                                 ok)  # fmt: skip
    u = (a - t_start) * fs
    u1 = (a1 - t_start) * fs
    L = u1 - up
    L = L if L > 0.0 else 1.0
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
    s0c = sp if sp > 0.0 else 0.0
    s1c = s1 if s1 < fn else fn
    live = ~first & (j - 1.0 < W[_R_LEN * o + i])
    found = okp & ok1
    valid = live & found & (s1c > s0c) & (u1 > up)
    b0 = np.floor(s0c * inv_block)
    b1 = np.floor((s1c - 1.0) * inv_block)
    clip0 = sp < 0.0
    simple = (valid & (sgp == sg1) & (b1 <= b0 + 1.0) & ~(clip0 & (b1 > b0)) & (b0 >= blo)
              & (b1 < blo + nb))  # fmt: skip
    if gained:
        simple = simple & ~cut
    W[_R_KIND * o + i] = (
        ((1.0 if simple else 3.0) if valid else 0.0) if found else (2.0 if live else 0.0)
    )
    dlt = (f1 - fp) * inv_l
    c2 = (3.0 * dlt - 2.0 * wp - w1) * inv_l
    c3 = (wp + w1 - 2.0 * dlt) * inv_l * inv_l
    # the emission at knot j - 1: this piece's start minus the previous one's end
    pf = W[_R_PF * o + i] != 0.0
    e0 = (fp if simple else 0.0) - W[_R_P * o + i]
    e1_ = (wp if simple else 0.0) - W[(_R_P + 1) * o + i]
    e2 = (c2 if simple else 0.0) - W[(_R_P + 2) * o + i]
    e3 = (c3 if simple else 0.0) - W[(_R_P + 3) * o + i]
    v0, v1, v2, v3 = _shifted(e0, e1_, e2, e3, sp - up)
    use = pf | (simple & ~clip0)
    W[_R_EROW * o + i] = base + (sp - blo * fblock) * rs if use else -1.0
    W[_R_E * o + i] = v0
    W[(_R_E + 1) * o + i] = v1
    W[(_R_E + 2) * o + i] = v2
    W[(_R_E + 3) * o + i] = v3
    if gained:
        # A: the part of the piece that the gain at its start multiplies (the
        # gain linear along the piece, as the piece-wise kernel's g0·A + g1·B):
        # the Hermite cubic of value fp, slope wp - fp/L at the start, value
        # 0, slope -f1/L at the end; B = the piece - A
        fl = fp * inv_l
        c2a = (f1 * inv_l - fl - 2.0 * wp) * inv_l
        c3a = (wp + fl - f1 * inv_l) * inv_l * inv_l
        pa1 = W[_R_PA * o + i]
        pa2 = W[(_R_PA + 1) * o + i]
        pa3 = W[(_R_PA + 2) * o + i]
        x0, x1, x2, x3 = _shifted(0.0, -pa1, -pa2, -pa3, sp - up)
        y0, y1, y2, y3 = _shifted(
            (fp if simple else 0.0) - W[_R_P * o + i],
            ((wp - fl) if simple else 0.0) - (W[(_R_P + 1) * o + i] - pa1),
            (c2a if simple else 0.0) - (W[(_R_P + 2) * o + i] - pa2),
            (c3a if simple else 0.0) - (W[(_R_P + 3) * o + i] - pa3), sp - up)  # fmt: skip
        z0, z1, z2, z3 = _shifted(0.0, fl if simple else 0.0, (c2 - c2a) if simple else 0.0,
                                  (c3 - c3a) if simple else 0.0, sp - up)  # fmt: skip
        W[_R_GX * o + i] = x0
        W[(_R_GX + 1) * o + i] = x1
        W[(_R_GX + 2) * o + i] = x2
        W[(_R_GX + 3) * o + i] = x3
        W[_R_GY * o + i] = y0
        W[(_R_GY + 1) * o + i] = y1
        W[(_R_GY + 2) * o + i] = y2
        W[(_R_GY + 3) * o + i] = y3
        W[_R_GZ * o + i] = z0
        W[(_R_GZ + 1) * o + i] = z1
        W[(_R_GZ + 2) * o + i] = z2
        W[(_R_GZ + 3) * o + i] = z3
        W[_R_CA * o + i] = c2a
        W[(_R_CA + 1) * o + i] = c3a
        W[(_R_CA + 2) * o + i] = fl
    # restart (rare: emitted by the scalar code from the cubic's c2, c3): at
    # the output's first sample, or at the next accumulation block's
    mr0 = 0.0 if clip0 else b1 * fblock
    W[_R_RROW * o + i] = mr0 if simple & (clip0 | (b1 > b0)) else -1.0
    W[_R_C2 * o + i] = c2
    W[(_R_C2 + 1) * o + i] = c3
    # for the scalar code
    W[_R_A0 * o + i] = ap
    W[_R_A1 * o + i] = a1
    W[_R_S0 * o + i] = sgp
    W[_R_S1 * o + i] = sg1
    W[_R_F0 * o + i] = fp
    W[_R_WF0 * o + i] = wp
    W[_R_F1 * o + i] = f1
    W[_R_WF1 * o + i] = w1
    # the end of this piece, pending at knot j: its Taylor coefficients around
    # the arrival (not when the end falls on a new accumulation block: the
    # piece was not continued there)
    end = simple & ~cut & (s1 < fn) & (s1 < (b1 + 1.0) * fblock)
    W[_R_P * o + i] = f1 if end else 0.0
    W[(_R_P + 1) * o + i] = w1 if end else 0.0
    W[(_R_P + 2) * o + i] = c2 + 3.0 * c3 * L if end else 0.0
    W[(_R_P + 3) * o + i] = c3 if end else 0.0
    W[_R_PF * o + i] = 1.0 if end else 0.0
    if gained:
        W[_R_PA * o + i] = -f1 * inv_l if end else 0.0
        W[(_R_PA + 1) * o + i] = c2a + 3.0 * c3a * L if end else 0.0
        W[(_R_PA + 2) * o + i] = c3a if end else 0.0
    W[_R_U * o + i] = u
    W[_R_SM * o + i] = s
    W[_R_F * o + i] = f
    W[_R_W * o + i] = wr
    W[_R_A * o + i] = a
    W[_R_SG * o + i] = sg
    W[_R_OK * o + i] = 1.0 if ok else 0.0


@numba.njit(inline="always", **_NJIT)
def _run_first(W, i, la, lb, two, c0, inv_c0, t_start, fs, inv_fs, gained):  # type: ignore[no-untyped-def]
    """The state of the first knot of the run in lane i that a task sweeps
    (see :func:`_run_step`; no piece ends there)."""
    o = _CHUNK
    a, d, e, sg, ok = _knot_arrival(W[_R_X * o + i], W[_R_Y * o + i], W[_R_Z * o + i],
                                    W[_R_RM * o + i], la, lb, c0, inv_c0, two)  # fmt: skip
    inv_d = 1.0 / d
    dd = e * inv_d
    f = W[_R_Q * o + i] * inv_d
    u = (a - t_start) * fs
    W[_R_U * o + i] = u
    W[_R_SM * o + i] = np.ceil(u)
    W[_R_F * o + i] = f
    W[_R_W * o + i] = (W[_R_M * o + i] * (1.0 - dd * inv_c0) - f * dd) * inv_d * inv_fs
    W[_R_A * o + i] = a
    W[_R_SG * o + i] = sg
    W[_R_OK * o + i] = 1.0 if ok else 0.0
    for r in range(_R_P, _R_PF + 1):
        W[r * o + i] = 0.0
    if gained:
        for r in range(_R_PA, _R_PA + 3):
            W[r * o + i] = 0.0


@numba.njit(fastmath={"contract"}, **_NJIT)
def _chunk_step(W, cnt, j, RCp, RC, two, cubic, first, c0, t_start, fs, fn, fblock, blo, nb,
                base, rs, gained):  # fmt: skip  # type: ignore[no-untyped-def]
    """:func:`_run_step` over the cnt lanes of a chunk (separate loops for one
    and two candidate lines, with and without gains, so that each stays
    branch-free)."""
    inv_c0 = 1.0 / c0
    inv_fs = 1.0 / fs
    inv_block = 1.0 / fblock
    la = _line_tuple(RC, 0)
    lb = _line_tuple(RC, _LINE)
    la_p = _line_tuple(RCp, 0)
    lb_p = _line_tuple(RCp, _LINE)
    fj = float(j)
    if first:  # the knot only: no piece ends here
        if gained:
            for i in range(cnt):
                _run_first(W, i, la, lb, two, c0, inv_c0, t_start, fs, inv_fs, True)
        else:
            for i in range(cnt):
                _run_first(W, i, la, lb, two, c0, inv_c0, t_start, fs, inv_fs, False)
    elif gained:
        if two:
            for i in range(cnt):
                _run_step(W, i, fj, la_p, lb_p, la, lb, la[6], True, cubic, first, c0, inv_c0,
                          t_start, fs, inv_fs, fn, fblock, inv_block, blo, nb, base, rs, True)  # fmt: skip
        else:
            for i in range(cnt):
                _run_step(W, i, fj, la_p, lb_p, la, lb, la[6], False, cubic, first, c0, inv_c0,
                          t_start, fs, inv_fs, fn, fblock, inv_block, blo, nb, base, rs, True)  # fmt: skip
    elif two:
        for i in range(cnt):
            _run_step(W, i, fj, la_p, lb_p, la, lb, la[6], True, cubic, first, c0, inv_c0,
                      t_start, fs, inv_fs, fn, fblock, inv_block, blo, nb, base, rs, False)  # fmt: skip
    else:
        for i in range(cnt):
            _run_step(W, i, fj, la_p, lb_p, la, lb, la[6], False, cubic, first, c0, inv_c0,
                      t_start, fs, inv_fs, fn, fblock, inv_block, blo, nb, base, rs, False)  # fmt: skip


@numba.njit(**_NJIT)
def _knot_gains(W, cnt, RC, qc, ot, tab, const_orient, G, S):  # type: ignore[no-untyped-def]
    """AmbiX gains ``G (n_ch, _CHUNK)`` of the knot just solved in each lane
    (arrival and capture interval in rows A, SG; the listener on the
    candidate lines of RC): the direction in the listener's frame at the
    arrival, harmonics by :func:`_sh_lanes` (as the piece-wise kernel's
    :func:`_synth_kernel._chunk_sh_gains` at a piece's ends).  A knot heard
    on neither line (left to the scalar code) gets some finite gains."""
    o = _CHUNK
    la = _line_tuple(RC, 0)
    lb = _line_tuple(RC, _LINE)
    if not const_orient:
        for i in range(cnt):
            _orient_rows(W, i, _R_OR, qc, ot, W[_R_A * o + i])
    # (branch-free: the loop vectorizes)
    for i in range(cnt):
        a = W[_R_A * o + i]
        px, py, pz = _listener_at(a, W[_R_SG * o + i], la, lb)
        dx = W[_R_X * o + i] - px
        dy = W[_R_Y * o + i] - py
        dz = W[_R_Z * o + i] - pz
        fx, fy, fz = W[_R_OR * o + i], W[(_R_OR + 1) * o + i], W[(_R_OR + 2) * o + i]
        ux, uy, uz = W[(_R_OR + 3) * o + i], W[(_R_OR + 4) * o + i], W[(_R_OR + 5) * o + i]
        lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
        ok = W[_R_OK * o + i] != 0.0
        W[_R_DIR * o + i] = (dx * fx + dy * fy + dz * fz) if ok else 1.0
        W[(_R_DIR + 1) * o + i] = (dx * lx + dy * ly + dz * lz) if ok else 0.0
        W[(_R_DIR + 2) * o + i] = (dx * ux + dy * uy + dz * uz) if ok else 0.0
    _sh_lanes(W, cnt, _R_DIR, _R_DIR + 1, _R_DIR + 2, tab, G, S)


@numba.njit(inline="always", **_NJIT)
def _add_split(acc, row, W, i, g2, g1, g0, n_ch):  # type: ignore[no-untyped-def]
    """acc[row + 4c : row + 4c + 4] += g2[c, i]·X + g1[c, i]·Y + g0[c, i]·Z for
    every channel c (X, Y, Z in rows GX, GY, GZ of lane i; row >= 0)."""
    a = np.uint64(row)
    o = _CHUNK
    x0, x1 = W[_R_GX * o + i], W[(_R_GX + 1) * o + i]
    x2, x3 = W[(_R_GX + 2) * o + i], W[(_R_GX + 3) * o + i]
    y0, y1 = W[_R_GY * o + i], W[(_R_GY + 1) * o + i]
    y2, y3 = W[(_R_GY + 2) * o + i], W[(_R_GY + 3) * o + i]
    z0, z1 = W[_R_GZ * o + i], W[(_R_GZ + 1) * o + i]
    z2, z3 = W[(_R_GZ + 2) * o + i], W[(_R_GZ + 3) * o + i]
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
def _copy_rows(W, r, KD, off, n_rows, cnt):  # type: ignore[no-untyped-def]
    """Rows r.. of W (n_rows of them, cnt lanes) from KD[off:]: unsigned
    indices (no wraparound checks), so that the copy vectorizes."""
    for k in range(n_rows):
        dst = np.uint64((r + k) * _CHUNK)
        src = np.uint64(off + k * _CHUNK)
        for i in range(cnt):
            W[dst + np.uint64(i)] = KD[src + np.uint64(i)]


@numba.njit(parallel=True, **_NJIT)
def render(gr0, glen, gcnt, goff, KD, tn, cubic, tc, lc, vc, qc, ot, c0, t_start, fs, n_samples,
           shift, n_ch, tab, n_lo, n_hi, d_max, task_rows, task_blk, RC, acc, out, ct, k_ct):  # fmt: skip  # type: ignore[no-untyped-def]
    """Sum every run of sounding pieces into ``out (n_ch, n_samples)``.

    Chunk g holds gcnt[g] runs whose first piece is in row gr0[g], the
    longest glen[g] pieces, at offset goff[g] of the knot data KD (rows of
    _CHUNK, see _K_*), sorted by gr0.  Task j sums the pieces of rows
    task_rows[j, 0]..task_rows[j, 1]-1 (the runs cut at its first and last
    knot rows) into its accumulator window (task_blk[j] = first block,
    number of blocks, offset in ``acc``, first sample, as in
    :func:`auralize.emitters._synth_kernel.render`): tasks split time, so their
    windows barely overlap.  ``tab`` is the spherical-harmonic table of an
    AmbiX layout of n_ch channels (:func:`_synth_kernel._gains_sh`; with qc,
    ot the listener's orientation) or has no rows (unpanned, n_ch = 1).  The
    other arguments are those of that function.  Returns the number of
    emissions outside the windows (an internal error).
    """
    n_tasks = task_rows.shape[0]
    block = 1 << shift
    fblock = float(block)
    fn = float(n_samples)
    gained = tab.shape[0] > 0
    rs = 4.0 * n_ch
    const_orient = _constant_rows(qc)
    _row_lines(tn, tc, lc, vc, c0, d_max, n_lo, n_hi, RC)
    bad = np.zeros(n_tasks, dtype=np.int64)
    for jt in numba.prange(n_tasks):
        blo, nb, base = task_blk[jt, 0], task_blk[jt, 1], task_blk[jt, 2]
        _clear_window(acc, task_blk[jt], n_ch, block, n_samples)
        n_rows = _RG_ROWS if gained else _R_ROWS
        W = np.zeros(n_rows * _CHUNK)
        # the scalar code's panning: AmbiX gains from the table (placeholder
        # speakers), none when unpanned
        spk_az = np.zeros(n_ch if gained else 0)
        spk_ch = np.arange(n_ch)
        pinv = tab if gained else np.zeros((0, 4))
        ga = np.ones(n_ch)
        gb = np.ones(n_ch)
        gx = np.ones(n_ch)
        gy = np.ones(n_ch)
        o6 = np.zeros(6)
        # gains of the last three knots (slot k % 3 for knot k), scratch
        G = np.zeros((3, n_ch if gained else 0, _CHUNK))
        S = np.empty((5, _CHUNK))
        ctj = ct[jt]
        ctj[:] = 0.0
        nbad = 0
        ra = max(task_rows[jt, 0], n_lo)
        rb = min(task_rows[jt, 1], n_hi)
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
            _copy_rows(W, 0, KD, off, 5, cnt)
            for r in range(_R_U, n_rows):
                for i in range(cnt):
                    W[r * _CHUNK + i] = 0.0
            if gained:
                G[:] = 0.0
                if const_orient:
                    for c in range(6):
                        for i in range(cnt):
                            W[(_R_OR + c) * _CHUNK + i] = qc[0, c]
            for n in range(ka, kb + 1):
                jk = n - r0
                kq = off + (_K_KNOT + 2 * jk) * _CHUNK
                _copy_rows(W, _R_Q, KD, kq, 2, cnt)
                if jk >= 1:
                    _copy_rows(W, _R_QP, KD, kq - 2 * _CHUNK, 2, cnt)
                first = n == ka
                two = RC[n, 2 * _LINE] != 0.0 or (not first and RC[n - 1, 2 * _LINE] != 0.0)
                rp = n if first else n - 1
                _chunk_step(W, cnt, jk, RC[rp], RC[n], two, cubic, first, c0, t_start, fs, fn,
                            fblock, blo, nb, base, rs, gained)  # fmt: skip
                g0 = G[jk % 3]  # knot n
                g1 = G[(jk + 2) % 3]  # knot n - 1
                g2 = G[(jk + 1) % 3]  # knot n - 2
                if gained:
                    _knot_gains(W, cnt, RC[n], qc, ot, tab, const_orient, g0, S)
                if first:
                    continue
                for i in range(cnt):
                    if gained and i + _AHEAD_G < cnt:
                        # the emission rows of AmbiX layouts span several cache
                        # lines: fetched a few lanes ahead
                        ea = W[_R_EROW * _CHUNK + i + _AHEAD_G]
                        if ea >= 0.0:
                            for k in range(0, 4 * n_ch, 8):
                                _prefetch(acc, np.uint64(ea) + np.uint64(k))
                    er = W[_R_EROW * _CHUNK + i]
                    if er >= 0.0:
                        if gained:
                            _add_split(acc, er, W, i, g2, g1, g0, n_ch)
                        else:
                            _add_plain(acc, er, W, _R_E, i)
                    mr0 = W[_R_RROW * _CHUNK + i]
                    if mr0 >= 0.0:
                        row = int(base + (mr0 - blo * fblock) * rs)
                        x = mr0 - (W[_R_A0 * _CHUNK + i] - t_start) * fs
                        f0, w0 = W[_R_F0 * _CHUNK + i], W[_R_WF0 * _CHUNK + i]
                        c2, c3 = W[_R_C2 * _CHUNK + i], W[(_R_C2 + 1) * _CHUNK + i]
                        if gained:
                            c2a, c3a = W[_R_CA * _CHUNK + i], W[(_R_CA + 1) * _CHUNK + i]
                            fl = W[(_R_CA + 2) * _CHUNK + i]
                            for c in range(n_ch):
                                ha = g1[c, i]
                                hb = g0[c, i]
                                _emit1(acc, row + 4 * c, x, ha * f0, ha * (w0 - fl) + hb * fl,
                                       ha * c2a + hb * (c2 - c2a), ha * c3a + hb * (c3 - c3a), 1.0)  # fmt: skip
                        else:
                            _emit1(acc, row, x, f0, w0, c2, c3, 1.0)
                    kd = W[_R_KIND * _CHUNK + i]
                    if kd < 2.0:
                        continue
                    x, y, z, rm = W[i], W[_CHUNK + i], W[2 * _CHUNK + i], W[3 * _CHUNK + i]
                    q0, m0 = W[_R_QP * _CHUNK + i], W[_R_MP * _CHUNK + i]
                    q1 = W[_R_Q * _CHUNK + i]
                    m1 = W[_R_M * _CHUNK + i] if cubic else m0
                    if kd == 3.0:
                        a0, a1 = W[_R_A0 * _CHUNK + i], W[_R_A1 * _CHUNK + i]
                        s0, s1 = int(W[_R_S0 * _CHUNK + i]), int(W[_R_S1 * _CHUNK + i])
                        if gained:
                            _pan_far(x, y, z, a0, s0, tc, lc, vc, qc, ot, spk_az, spk_ch, False, pinv,
                                 ga, o6)  # fmt: skip
                            _pan_far(x, y, z, a1, s1, tc, lc, vc, qc, ot, spk_az, spk_ch, False, pinv,
                                 gb, o6)  # fmt: skip
                        nbad += _piece_across(
                            acc, base, blo, nb, n_ch, shift, n_samples, n - 1, x, y, z, rm, tn, q0,
                            m0, q1, m1, cubic, tc, lc, vc, qc, ot, c0, t_start, fs, spk_az, spk_ch,
                            False, pinv, gained, a0, a1, s0, s1, W[_R_F0 * _CHUNK + i],
                            W[_R_WF0 * _CHUNK + i] * fs, W[_R_F1 * _CHUNK + i],
                            W[_R_WF1 * _CHUNK + i] * fs, ga, gb, gx, gy, o6, ctj, k_ct,
                        )  # fmt: skip
                    else:
                        nbad += _piece_general(
                            acc, base, blo, nb, n_ch, shift, n_samples, n - 1, int(RC[n - 1, 11]),
                            x, y, z, rm, tn, q0, m0, q1, m1, cubic, tc, lc, vc, qc, ot, c0,
                            t_start, fs, spk_az, spk_ch, False, pinv, gained, ga, gb, gx, gy, o6,
                            ctj, k_ct,
                        )  # fmt: skip
            # the end of the last piece (its knot has no piece after it here):
            # slots as after the last knot, kb
            g0 = G[(kb - r0) % 3]
            g1 = G[(kb - r0 + 2) % 3]
            for i in range(cnt):
                if W[_R_PF * _CHUNK + i] != 0.0:
                    sm = W[_R_SM * _CHUNK + i]
                    row = int(base + (sm - blo * fblock) * rs)
                    x = sm - W[_R_U * _CHUNK + i]
                    p0, p1 = W[_R_P * _CHUNK + i], W[(_R_P + 1) * _CHUNK + i]
                    p2, p3 = W[(_R_P + 2) * _CHUNK + i], W[(_R_P + 3) * _CHUNK + i]
                    if gained:
                        pa1, pa2 = W[_R_PA * _CHUNK + i], W[(_R_PA + 1) * _CHUNK + i]
                        pa3 = W[(_R_PA + 2) * _CHUNK + i]
                        for c in range(n_ch):
                            ha = g1[c, i]
                            hb = g0[c, i]
                            _emit1(acc, row + 4 * c, x, hb * p0, ha * pa1 + hb * (p1 - pa1),
                                   ha * pa2 + hb * (p2 - pa2), ha * pa3 + hb * (p3 - pa3), -1.0)  # fmt: skip
                    else:
                        _emit1(acc, row, x, p0, p1, p2, p3, -1.0)
        bad[jt] = nbad + _flush_captures(acc, ctj, k_ct, tc, t_start, fs, n_samples, shift, blo, nb,
                                         base, n_ch, task_blk[jt, 3])  # fmt: skip
    # integrate: per channel group and block (as the piece-wise kernel)
    n_groups = min(n_tasks, n_ch)
    n_blocks = (n_samples + block - 1) // block
    for k in numba.prange(n_groups * n_blocks):
        gi = k // n_blocks
        b = k - gi * n_blocks
        _integrate(acc, task_blk, gi * n_ch // n_groups, (gi + 1) * n_ch // n_groups, b, n_ch,
                   block, n_samples, out)  # fmt: skip
    return int(bad.sum())


@numba.njit(**_NJIT)
def find_runs(q, tn, cubic, counts_only, src, r0, length):  # type: ignore[no-untyped-def]
    """Runs of consecutive sounding pieces of tracks q (K, T) with padded knot
    times tn (T + 2): piece n (padded knots n, n + 1) sounds when q or (cubic)
    its tangent is non-zero at either knot (as in
    :func:`auralize.emitters._synth_kernel.build_pieces`).  With ``counts_only``
    returns the number of runs; else fills each run's source, first piece
    and number of pieces."""
    K, T = q.shape
    Tp = T + 2
    scale = 1.0 / (4.0 * math.pi)
    nr = 0
    for k in range(K):
        nz_prev = False
        start = -1
        for n in range(Tp):
            nz = _knot_q(q, k, n, T, scale) != 0.0 or (
                cubic and _knot_m(q, k, n, T, tn, scale) != 0.0
            )
            sounds = n > 0 and (nz or nz_prev)  # piece n - 1
            if sounds and start < 0:
                start = n - 1
            if not sounds and start >= 0:
                if not counts_only:
                    src[nr] = k
                    r0[nr] = start
                    length[nr] = n - 1 - start
                nr += 1
                start = -1
            nz_prev = nz
        if start >= 0:
            if not counts_only:
                src[nr] = k
                r0[nr] = start
                length[nr] = Tp - 1 - start
            nr += 1
    return nr


@numba.njit(**_NJIT)
def fill_runs(q, tn, pos, radius, cubic, src, r0, length, chunk, lane, goff, KD):  # type: ignore[no-untyped-def]
    """Knot data of every run (lane ``lane[i]`` of chunk ``chunk[i]``, see
    :func:`render`); KD must be zero-filled (knots past a run are silent)."""
    T = q.shape[1]
    scale = 1.0 / (4.0 * math.pi)
    for i in range(src.size):
        k = src[i]
        b = goff[chunk[i]] + lane[i]
        KD[b + _K_X * _CHUNK] = pos[k, 0]
        KD[b + _K_Y * _CHUNK] = pos[k, 1]
        KD[b + _K_Z * _CHUNK] = pos[k, 2]
        KD[b + _K_RM * _CHUNK] = max(radius[k], 1e-9)
        KD[b + _K_LEN * _CHUNK] = length[i]
        for jk in range(length[i] + 1):
            n = r0[i] + jk
            qn = _knot_q(q, k, n, T, scale)
            if cubic:
                mn = _knot_m(q, k, n, T, tn, scale)
            elif n + 1 < tn.size:
                mn = (_knot_q(q, k, n + 1, T, scale) - qn) / (tn[n + 1] - tn[n])
            else:
                mn = 0.0
            KD[b + (_K_KNOT + 2 * jk) * _CHUNK] = qn
            KD[b + (_K_KNOT + 2 * jk + 1) * _CHUNK] = mn
