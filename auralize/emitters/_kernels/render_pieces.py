"""The piece-wise synthesis kernel (panned layouts, and recorded listener paths): one
task, :func:`render_task`.

Tasks take contiguous ranges of the pieces, which are sorted by knot row, so a
task's arrivals, and its writes, stay within its own stretch of the output; each
sums its chunks into its own accumulator window and capture table (threads run the
tasks side by side: :func:`auralize.emitters.synthesis.render_tracks`), then
:func:`~auralize.emitters._kernels.accumulate._integrate_tasks` integrates every
window into the output.
"""

from __future__ import annotations

import numba

from auralize.emitters._kernels.accumulate import (
    _AHEAD,
    _add_dense,
    _clear_window,
    _flush_captures,
    _prefetch_lane,
    _scatter_group,
    _scatter_simple,
)
from auralize.emitters._kernels.common import (
    _CHUNK,
    _NJIT_NORC,
    KIND_ACROSS,
    KIND_SILENT,
    KIND_SIMPLE,
    ROW,
    Window,
)
from auralize.emitters._kernels.gains import _pan
from auralize.emitters._kernels.lane_gains import _chunk_pair_gains, _chunk_sh_gains
from auralize.emitters._kernels.parts import _chunk_parts
from auralize.emitters._kernels.pieces import _chunk_pieces, _piece_across, _piece_general


@numba.njit(**_NJIT_NORC)
def render_task(task, pieces, rows, cubic, c0, lis, pan, out, scr, lanes):
    """Sum task ``task``'s sounding pieces into its accumulator window and capture
    table (see module docstring); returns the number of emissions outside the window
    (an internal error).

    Parameters (all times in data seconds)
    ----------
    task : int
        The task: chunks ``pieces.task_chunks[task, 0]`` .. ``[task, 1] - 1``, window
        ``out.task_blk[task]``, capture table ``out.capture_sums[task]``.
    pieces : PieceTable
        The sounding pieces (:class:`~auralize.emitters._kernels.common.PieceTable`):
        piece n of a source runs from knot n to n + 1, its ``piece_data`` lane holds
        x, y, z, clamp radius, q and dq/dτ at its first knot, q and dq/dτ at its
        last (strength·ΔV/(4π); for linear interpolation, ``cubic`` False, dq/dτ is
        the piece's slope).
    rows : KnotRows
        The knot rows (:class:`~auralize.emitters._kernels.common.KnotRows`): rows n
        with ``row_captures[n, 1] > row_captures[n, 0]`` (arrivals that may cross
        the listener's captures) are split there into parts
        (:func:`~auralize.emitters._kernels.parts._chunk_parts`); ``interval_lines``:
        the listener's position at time tr, velocity, tr, c0² - V², 1/(c0² - V²),
        held before the first and after the last capture.
    cubic : bool
        Cubic Hermite (else linear) interpolation of the strengths.
    c0 : float
        Speed of sound, m per data second.
    lis : Listener
        The listener's captures and orientation
        (:class:`~auralize.emitters._kernels.common.Listener`).
    pan : Panning
        The layout's panning: speaker azimuths and channels, and a table ``pinv``:
        inverse bases of adjacent speaker pairs ``(n_pairs, 4)`` (empty when an arc
        spans 180° or more; one row of 7 when an arc is wider than 180°, e.g.
        stereo: see :func:`~auralize.emitters._kernels.gains._gains`), or for layouts
        with elevation the 3-D VBAP table of
        :func:`~auralize.emitters._kernels.gains._gains3`, or the AmbiX table of
        :func:`~auralize.emitters._kernels.gains._gains_sh`.
    out : Accumulator
        The tasks' accumulator windows and capture tables
        (:class:`~auralize.emitters._kernels.common.Accumulator`).
    scr : Scratch
        The task's scratch (:class:`~auralize.emitters._kernels.common.Scratch`).
    lanes : Lanes
        The task's work arrays (:class:`~auralize.emitters._kernels.common.Lanes`).
    """
    blk = out.task_blk[task]
    acc, n_ch = out.acc, out.n_ch
    _clear_window(acc, blk, n_ch, 1 << out.shift, out.n_samples)
    task_captures = out.capture_sums[task]
    task_captures[:] = 0.0
    win = Window(
        acc,
        blk[2],
        blk[0],
        blk[1],
        n_ch,
        out.shift,
        out.n_samples,
        out.t_start,
        out.fs,
        task_captures,
        out.first_capture,
    )
    piece_data, chunk_start, chunk_count = pieces.piece_data, pieces.chunk_start, pieces.chunk_count
    p_a, p_b = pieces.task_chunks[task, 0], pieces.task_chunks[task, 1]
    tn, n_lo, n_hi = rows.knot_times, rows.n_lo, rows.n_hi
    row_captures, interval_lines = rows.row_captures, rows.interval_lines
    nbad = 0
    n = n_lo
    while n < n_hi and chunk_start[n + 1] <= p_a:
        n += 1
    while n < n_hi and chunk_start[n] < p_b:
        if row_captures[n, 1] > row_captures[n, 0]:
            captures = (row_captures[n, 0], row_captures[n, 1])
            for ck in range(max(chunk_start[n], p_a), min(chunk_start[n + 1], p_b)):
                nbad += _chunk_parts(
                    piece_data,
                    ck,
                    chunk_count[ck],
                    captures,
                    (tn[n], tn[n + 1]),
                    lanes.parts,
                    interval_lines,
                    c0,
                    lis,
                    pan,
                    win,
                    scr,
                )
            n += 1
            continue
        for ck in range(max(chunk_start[n], p_a), min(chunk_start[n + 1], p_b)):
            nbad += _sum_chunk(ck, n, pieces, rows, cubic, c0, lis, pan, win, scr, lanes)
        n += 1
    return nbad + _flush_captures(win, lis.times, blk[3])


@numba.njit(**_NJIT_NORC)
def _sum_chunk(ck, n, pieces, rows, cubic, c0, lis, pan, win, scr, lanes):
    """Chunk ck of the pieces of knot row n (see :func:`render_task`) into the task's
    window ``win``: the SIMD loops (arrivals, polynomials, speaker-pair or AmbiX
    gains), then a scalar loop that scatters each piece to the accumulator, or sums
    it in full (across captures or blocks, beyond the candidate lines).  Returns the
    number of emissions outside the window."""
    piece_data, chunk_count = pieces.piece_data, pieces.chunk_count
    tn, row_lines = rows.knot_times, rows.row_lines
    work, gains0, gains1 = lanes.pieces, lanes.gains0, lanes.gains1
    sh_gains0, sh_gains1, sh_scratch = lanes.sh_gains0, lanes.sh_gains1, lanes.sh_scratch
    acc, n_ch, fs = win.acc, win.n_ch, win.fs
    panned, pairs, dense, spk_ch, nxt = pan.panned, pan.pairs, pan.dense, pan.spk_ch, pan.nxt
    orient_table, orient_clock = lis.orient_table, lis.orient_clock
    ga, gb, frame = scr.ga, scr.gb, scr.frame
    k = _CHUNK
    nbad = 0
    cc = chunk_count[ck]
    _chunk_pieces(piece_data, ck, cc, row_lines[n], row_lines[n + 1], c0, win, panned, work)
    if pairs:
        _chunk_pair_gains(
            work,
            cc,
            row_lines[n],
            row_lines[n + 1],
            orient_table,
            orient_clock,
            pan.pinv,
            pan.fold,
            pan.const_orient,
        )
    elif dense:
        _chunk_sh_gains(
            work,
            cc,
            row_lines[n],
            row_lines[n + 1],
            orient_table,
            orient_clock,
            pan.pinv,
            pan.const_orient,
            sh_gains0,
            sh_gains1,
            sh_scratch,
        )
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
        piece = (
            piece_data[ck, 0, i],
            piece_data[ck, 1, i],
            piece_data[ck, 2, i],
            piece_data[ck, 3, i],
            piece_data[ck, 4, i],
            piece_data[ck, 5, i],
            piece_data[ck, 6, i],
            piece_data[ck, 7, i],
        )
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
            ends = (
                work[ROW.A0 * k + i],
                work[ROW.A1 * k + i],
                int(work[ROW.S0 * k + i]),
                int(work[ROW.S1 * k + i]),
                work[ROW.F0 * k + i],
                work[ROW.WF0 * k + i] * fs,
                work[ROW.F1 * k + i],
                work[ROW.WF1 * k + i] * fs,
            )
            nbad += _piece_across(win, lis, pan, scr, piece, tn, n, cubic, c0, ends)
            continue
        nbad += _piece_general(win, lis, pan, scr, piece, tn, n, int(row_lines[n, 11]), cubic, c0)
    return nbad
