"""The piece-wise synthesis kernel (panned layouts, and recorded listener paths):
task driver and entry point :func:`render`.

Threads take contiguous ranges of the pieces, which are sorted by knot row,
so a task's arrivals, and its writes, stay within its own stretch of the
output; each sums its chunks (:func:`_task_sum`) into its own accumulator
window and capture table, then :func:`~auralize.emitters._kernels.accumulate._integrate_tasks`
integrates every window into the output.
"""

from __future__ import annotations

import numba
import numpy as np

from auralize.emitters._kernels.accumulate import (
    _AHEAD,
    _add_dense,
    _clear_window,
    _flush_captures,
    _integrate_tasks,
    _prefetch_lane,
    _scatter_group,
    _scatter_simple,
)
from auralize.emitters._kernels.arrivals import _row_lines
from auralize.emitters._kernels.common import (
    _CHUNK,
    _NJIT,
    _NJIT_NORC,
    KIND_ACROSS,
    KIND_SILENT,
    KIND_SIMPLE,
    ROW,
    Listener,
    Panning,
    Scratch,
    Window,
)
from auralize.emitters._kernels.gains import _constant_rows, _pan
from auralize.emitters._kernels.lane_gains import _chunk_pair_gains, _chunk_sh_gains
from auralize.emitters._kernels.parts import _chunk_parts
from auralize.emitters._kernels.pieces import _chunk_pieces, _piece_across, _piece_general


@numba.njit(parallel=True, **_NJIT)
def render(cptr, ccnt, piece_data, tn, cubic, listener_times, listener_pos, listener_vel,
           orient_table, orient_clock, c0, t_start, fs, n_samples, shift, spk_az, spk_ch, pinv,
           n_ch, fold, n_lo, n_hi, d_max, task_pieces, task_blk, row_lines, acc, out,
           capture_sums, first_capture, row_captures, interval_lines):  # fmt: skip
    """Sum every sounding piece into ``out (n_ch, n_samples)``; see module docstring.

    Parameters (all times in data seconds)
    ----------
    the sounding pieces in chunks of _CHUNK, sorted by knot row n (piece n runs
    from knot n to n + 1): row n's chunks are cptr[n]..cptr[n+1]-1, chunk c
    holds ccnt[c] pieces, piece_data (C, 8, _CHUNK) = x, y, z, clamp radius, q and
    dq/dτ at its first knot, q and dq/dτ at its last (strength·ΔV/(4π); for
    linear interpolation, ``cubic`` False, dq/dτ is the piece's slope),
    contiguous per chunk; tn (Tp,) knot times (padded with silent knots); listener_times (M,),
    listener_pos (M,3), listener_vel (M-1,3) listener captures; orient_table (N,6) forward/up table sampled
    from orient_clock[0] at rate orient_clock[1] (see :func:`~auralize.emitters._kernels.gains._orient`); fs samples per data
    second; 2**shift samples per accumulation block; spk_az/spk_ch speaker
    azimuths (sorted) and channels; pinv (n_pairs, 4) inverse bases of
    adjacent speaker pairs (empty when an arc spans 180° or more; one row
    of 7 when an arc is wider than 180°, e.g. stereo: see
    :func:`~auralize.emitters._kernels.gains._gains`),
    or for layouts with elevation the 3-D VBAP table of
    :func:`~auralize.emitters._kernels.gains._gains3`, or the AmbiX table of
    :func:`~auralize.emitters._kernels.gains._gains_sh`.

    Work is split in tasks (one per thread): task j sums chunks
    task_pieces[j, 0]..task_pieces[j, 1]-1 of rows n_lo..n_hi-1 into its
    accumulator window: blocks task_blk[j, 0].. (task_blk[j, 1] of them) at
    offset task_blk[j, 2] of ``acc``; it emits nothing before sample
    task_blk[j, 3] (its first arrival: the rows before it are neither
    cleared nor read).  Pieces are sorted by row, so a task's
    arrivals, and its writes, stay within its own stretch of the output.
    row_lines (Tp, 2·_LINE + 1) is work space for the listener's lines per row;
    d_max bounds the source-listener distance.  capture_sums (n_tasks, R·n_ch·4): each
    task's capture table for captures first_capture … first_capture + R - 1 (see
    :func:`~auralize.emitters._kernels.accumulate._emit_piece`), cleared here.  Rows n with row_captures[n, 1] > row_captures[n, 0]
    (arrivals that may cross the listener's captures row_captures[n, 0]..row_captures[n, 1]-1)
    are split into parts at those captures (:func:`~auralize.emitters._kernels.parts._chunk_parts`; interval_lines (M+1, 9)
    the listener's line on each capture interval j at row j + 1: position at
    time tr, velocity, tr, c0² - V², 1/(c0² - V²), held before the first and
    after the last capture).

    Returns the number of emissions outside the windows (an internal error).
    """
    n_tasks = task_pieces.shape[0]
    block = 1 << shift
    panned = spk_az.size > 0
    # speaker pairs (every arc < 180°): gains in SIMD loops
    pairs = panned and pinv.shape[0] > 0 and pinv.shape[1] == 4 and not fold
    # AmbiX: every channel has a gain (spherical harmonics)
    dense = panned and pinv.shape[1] == 2
    const_orient = _constant_rows(orient_table)
    n_spk = spk_az.size
    nxt = np.empty(max(n_spk, 1), dtype=np.int64)  # channel of the next speaker
    for p in range(n_spk):
        nxt[p] = spk_ch[(p + 1) % n_spk]
    ng = n_ch if panned else 1
    _row_lines(tn, listener_times, listener_pos, listener_vel, c0, d_max, n_lo, n_hi, row_lines)
    bad = np.zeros(n_tasks, dtype=np.int64)
    for j in numba.prange(n_tasks):
        blo, nb, base = task_blk[j, 0], task_blk[j, 1], task_blk[j, 2]
        _clear_window(acc, task_blk[j], n_ch, block, n_samples)
        lanes = (
            np.empty(ROW.PIECE_END * _CHUNK),  # pieces
            np.empty(ROW.END * _CHUNK),  # parts
            np.zeros((_CHUNK, ng)),  # gains at the pieces' starts and ends (any other layout)
            np.zeros((_CHUNK, ng)),
            np.zeros((ng if dense else 0, _CHUNK)),  # AmbiX gains, channel-major
            np.zeros((ng if dense else 0, _CHUNK)),
            np.empty((5, _CHUNK)),  # scratch of the harmonics
        )
        scr = Scratch(np.zeros(n_ch), np.zeros(n_ch), np.zeros(n_ch), np.zeros(n_ch), np.zeros(6),
                      np.empty(2 * _CHUNK))  # fmt: skip
        task_captures = capture_sums[j]
        task_captures[:] = 0.0
        lis = Listener(listener_times, listener_pos, listener_vel, orient_table, orient_clock)
        pan = Panning(spk_az, spk_ch, nxt, pinv, fold, panned, pairs, dense, const_orient)
        win = Window(acc, base, blo, nb, n_ch, shift, n_samples, t_start, fs, task_captures,
                     first_capture)  # fmt: skip
        rows = (tn, n_lo, n_hi, row_lines, row_captures, interval_lines)
        nbad = _task_sum((piece_data, cptr, ccnt), rows, task_pieces[j, 0], task_pieces[j, 1],
                         cubic, c0, lis, pan, win, scr, lanes)  # fmt: skip
        bad[j] = nbad + _flush_captures(win, listener_times, task_blk[j, 3])
    _integrate_tasks(acc, task_blk, n_tasks, n_ch, block, n_samples, out)
    return int(bad.sum())


@numba.njit(**_NJIT_NORC)
def _task_sum(pieces, rows, p_a, p_b, cubic, c0, lis, pan, win, scr, lanes):
    """One task of :func:`render`: its pieces (chunks p_a..p_b-1 of ``pieces`` =
    (piece_data, cptr, ccnt), of knot rows n_lo..n_hi-1, ``rows`` = (tn, n_lo,
    n_hi, row_lines, row_captures, interval_lines)) into its accumulator
    window and capture table ``win``; ``scr`` and ``lanes`` (work arrays of
    pieces and parts, per-lane gains at both ends, per-lane AmbiX gains,
    scratch of the harmonics) are its work arrays.  Returns the number of
    emissions outside the window."""
    piece_data, cptr, ccnt = pieces
    tn, n_lo, n_hi, row_lines, row_captures, interval_lines = rows
    work, part_work, gains0, gains1, sh_gains0, sh_gains1, sh_scratch = lanes
    acc, n_ch, fs = win.acc, win.n_ch, win.fs
    panned, pairs, dense, spk_ch, nxt = pan.panned, pan.pairs, pan.dense, pan.spk_ch, pan.nxt
    orient_table, orient_clock = lis.orient_table, lis.orient_clock
    ga, gb, frame = scr.ga, scr.gb, scr.frame
    k = _CHUNK
    nbad = 0
    n = n_lo
    while n < n_hi and cptr[n + 1] <= p_a:
        n += 1
    while n < n_hi and cptr[n] < p_b:
        if row_captures[n, 1] > row_captures[n, 0]:
            captures = (row_captures[n, 0], row_captures[n, 1])
            for ck in range(max(cptr[n], p_a), min(cptr[n + 1], p_b)):
                nbad += _chunk_parts(piece_data, ck, ccnt[ck], captures, (tn[n], tn[n + 1]),
                                     part_work, interval_lines, c0, lis, pan, win, scr)  # fmt: skip
            n += 1
            continue
        for ck in range(max(cptr[n], p_a), min(cptr[n + 1], p_b)):
            cc = ccnt[ck]
            _chunk_pieces(piece_data, ck, cc, row_lines[n], row_lines[n + 1], c0, win, panned, work)
            if pairs:
                _chunk_pair_gains(work, cc, row_lines[n], row_lines[n + 1], orient_table,
                                  orient_clock, pan.pinv, pan.const_orient)  # fmt: skip
            elif dense:
                _chunk_sh_gains(work, cc, row_lines[n], row_lines[n + 1], orient_table,
                                orient_clock, pan.pinv, pan.const_orient, sh_gains0, sh_gains1,
                                sh_scratch)  # fmt: skip
            elif panned:
                for i in range(cc):
                    kd = work[ROW.KIND * k + i]
                    if kd != KIND_SIMPLE and kd != KIND_ACROSS:
                        continue
                    x, y, z = piece_data[ck, 0, i], piece_data[ck, 1, i], piece_data[ck, 2, i]
                    a0, s0 = work[ROW.A0 * k + i], int(work[ROW.S0 * k + i])
                    a1, s1 = work[ROW.A1 * k + i], int(work[ROW.S1 * k + i])
                    _pan(x, y, z, a0, s0, lis, pan, ga, frame)
                    _pan(x, y, z, a1, s1, lis, pan, gb, frame)
                    for c in range(n_ch):
                        gains0[i, c] = ga[c]
                        gains1[i, c] = gb[c]
            for i in range(_AHEAD):
                _prefetch_lane(acc, work, i, cc, pairs, spk_ch, nxt)
            for i in range(cc):
                _prefetch_lane(acc, work, i + _AHEAD, cc, pairs, spk_ch, nxt)
                kd = work[ROW.KIND * k + i]
                if kd == KIND_SILENT:
                    continue
                if kd == KIND_SIMPLE:
                    done, si, ei, ci = _scatter_simple(acc, work, i, panned, pairs, spk_ch, nxt)
                    if done:
                        continue
                    if dense:
                        _add_dense(acc, si, work, ROW.VAL_A, i, sh_gains0, sh_gains1, n_ch)
                        if ei >= 0:
                            _add_dense(acc, ei, work, ROW.VAL_A + 4, i, sh_gains0, sh_gains1, n_ch)
                        if ci >= 0:
                            _add_dense(acc, ci, work, ROW.VAL_A + 8, i, sh_gains0, sh_gains1, n_ch)
                        continue
                    for c in range(n_ch):
                        g0 = gains0[i, c]
                        g1 = gains1[i, c]
                        if g0 != 0.0 or g1 != 0.0:
                            _scatter_group(acc, work, i, si, ei, ci, c * 4, g0, g1)
                    continue
                piece = (piece_data[ck, 0, i], piece_data[ck, 1, i], piece_data[ck, 2, i],
                         piece_data[ck, 3, i], piece_data[ck, 4, i], piece_data[ck, 5, i],
                         piece_data[ck, 6, i], piece_data[ck, 7, i])  # fmt: skip
                if kd == KIND_ACROSS:
                    # across listener captures or several blocks: arrivals,
                    # values and gains from the SIMD loops
                    if pairs:
                        for c in range(n_ch):
                            ga[c] = 0.0
                            gb[c] = 0.0
                        p0 = int(work[ROW.P0 * k + i])
                        p1 = int(work[ROW.P1 * k + i])
                        ga[spk_ch[p0]] += work[ROW.G00 * k + i]
                        ga[nxt[p0]] += work[ROW.G01 * k + i]
                        gb[spk_ch[p1]] += work[ROW.G10 * k + i]
                        gb[nxt[p1]] += work[ROW.G11 * k + i]
                    elif dense:
                        for c in range(n_ch):
                            ga[c] = sh_gains0[c, i]
                            gb[c] = sh_gains1[c, i]
                    elif panned:
                        for c in range(n_ch):
                            ga[c] = gains0[i, c]
                            gb[c] = gains1[i, c]
                    ends = (work[ROW.A0 * k + i], work[ROW.A1 * k + i], int(work[ROW.S0 * k + i]),
                            int(work[ROW.S1 * k + i]), work[ROW.F0 * k + i],
                            work[ROW.WF0 * k + i] * fs, work[ROW.F1 * k + i],
                            work[ROW.WF1 * k + i] * fs)  # fmt: skip
                    nbad += _piece_across(win, lis, pan, scr, piece, tn, n, cubic, c0, ends)
                    continue
                nbad += _piece_general(win, lis, pan, scr, piece, tn, n, int(row_lines[n, 11]),
                                       cubic, c0)  # fmt: skip
        n += 1
    return nbad
