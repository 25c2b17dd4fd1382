"""The skewed accumulator: emissions of polynomials, their scatter from the work
array, the capture table, and the integration into the output.

The cubic of a piece is written in the binomial basis C(m - m0, i) at its
first sample m0; C(m - m0, i)·H(m - m0) is the (i+1)-fold cumulative sum of an
impulse at m0 + i, so a piece costs 4 impulses at its start and 4 (of the
polynomial continued, subtracted) at its end, whatever its length
(:func:`_emit1`).  Level j of an impulse at m + j is stored in row m, so an
emission touches one 32-byte row, with the channels of a sample side by
side.  Four cumulative sums per accumulation block give the signal
(:func:`_integrate`, :func:`_integrate_tasks`); the sums restart at every
block (numerical safety), so a piece that crosses one is continued there.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

from auralize.emitters._kernels.common import _CHUNK, _NJIT, _NJIT_NORC, KIND_SIMPLE, ROW
from auralize.emitters._kernels.hermite import _hermite_inv


@numba.njit(inline="always", **_NJIT)
def _emit1(acc, i, x, c0, c1, c2, c3, sign):
    """Add sign × P(m - m_start + x) for m >= m_start to the row ``i`` of a
    skewed accumulator, P = c0 + c1 x + c2 x² + c3 x³.

    The polynomial is Taylor-shifted to x and written in the binomial basis
    C(m - m_start, j), whose (j+1)-fold cumulative sum is an impulse at
    m_start + j.  Level j's impulse at m_start + j is stored in row m_start
    (the integration reads level j of sample m from row m - j), so the four
    values of one emission share a 32-byte row: one cache line.
    """
    b0 = c0 + x * (c1 + x * (c2 + x * c3))
    b1 = c1 + x * (2.0 * c2 + 3.0 * c3 * x)
    b2 = c2 + 3.0 * c3 * x
    acc[i] += sign * b0
    acc[i + 1] += sign * (b1 + b2 + c3)
    acc[i + 2] += sign * (2.0 * b2 + 6.0 * c3)
    acc[i + 3] += sign * 6.0 * c3


@numba.njit(inline="always", **_NJIT)
def _emit_piece(win, ch, n_ch, u0, u1, poly, r0, r1):
    """Add the cubic P(u - u0) (coefficients ``poly`` in the power basis, sample
    units) on samples ceil(u0) <= m < ceil(u1) (clipped to the output) into
    channel ch (of n_ch) of a task's accumulator window ``win`` (a
    :class:`~auralize.emitters._kernels.common.Window`).

    The running sums restart at every accumulation block (numerical safety), so
    a piece that crosses a block boundary is continued there: the same
    polynomial is emitted again at the block's first sample.  The signal thus
    does not depend on where the block boundaries fall.

    u0 (u1) at a listener capture whose row r0 (r1) of the window's capture
    table is >= 0: the start (end) emission goes to that row instead (every
    source's emission at a capture falls on the same sample with the same
    offset, so they are summed there, in a table that stays in cache, and
    added to the accumulator once: :func:`_flush_captures`).

    Returns the number of emissions that fell outside the window (0 unless
    the caller's window is wrong).
    """
    acc, sums, base, blo, nb = win.acc, win.capture_sums, win.base, win.blo, win.nb
    n_samples, shift = win.n_samples, win.shift
    p0, p1, p2, p3 = poly
    m_0 = max(int(math.ceil(u0)), 0)
    m_1 = min(int(math.ceil(u1)), n_samples)
    if m_1 <= m_0:
        return 0
    block = 1 << shift
    b = m_0 >> shift
    ms = m_0
    while True:
        bend = (b + 1) * block
        j = b - blo
        if j < 0 or j >= nb:
            return 1
        row0 = base + (j * block * n_ch + ch) * 4
        if ms == m_0 and r0 >= 0 and u0 > -1.0:
            _emit1(sums, (r0 * n_ch + ch) * 4, ms - u0, p0, p1, p2, p3, 1.0)
        else:
            _emit1(acc, row0 + (ms - b * block) * n_ch * 4, ms - u0, p0, p1, p2, p3, 1.0)
        if m_1 <= bend:
            if m_1 < n_samples and m_1 < bend:
                if r1 >= 0:
                    _emit1(sums, (r1 * n_ch + ch) * 4, m_1 - u0, p0, p1, p2, p3, -1.0)
                else:
                    _emit1(acc, row0 + (m_1 - b * block) * n_ch * 4, m_1 - u0, p0, p1, p2, p3, -1.0)
            return 0
        b += 1
        ms = bend


#: no row of the capture table (an emission that goes to the accumulator): typed
#: int64, as the rows the callers compute (a literal -1 would type as a constant and
#: compile :func:`_emit_gained` once more for it)
NO_ROW = np.int64(-1)


@numba.njit(**_NJIT_NORC)
def _emit_gained(win, u0, u1, fw, ga, gb, panned, r0, r1):
    """Emit f·g on [u0, u1] (samples) into every channel of window ``win``: f
    the Hermite cubic from value and slope ``fw = (va, wa, vb, wb)`` (slopes
    per data second) at its ends, gains linear from ``ga`` to ``gb`` (unpanned:
    gain 1); r0, r1 the capture table rows of u0, u1 or -1 (see
    :func:`_emit_piece`).  The scalar code's emission (pieces and parts the SIMD
    loops leave to it), compiled once and called."""
    va, wa, vb, wb = fw
    fs = win.fs
    L = u1 - u0
    if L <= 0.0:
        return 0
    bad = 0
    inv_L = 1.0 / L
    inv_fs = 1.0 / fs
    if not panned:
        poly = _hermite_inv(inv_L, va, wa * inv_fs, vb, wb * inv_fs)
        return _emit_piece(win, 0, 1, u0, u1, poly, r0, r1)
    slope_t = fs * inv_L  # 1 / (t1 - t0)
    for c in range(win.n_ch):
        g0 = ga[c]
        g1 = gb[c]
        if g0 == 0.0 and g1 == 0.0:
            continue
        slope = (g1 - g0) * slope_t
        poly = _hermite_inv(
            inv_L,
            g0 * va,
            (g0 * wa + slope * va) * inv_fs,
            g1 * vb,
            (g1 * wb + slope * vb) * inv_fs,
        )
        bad += _emit_piece(win, c, win.n_ch, u0, u1, poly, r0, r1)
    return bad


@numba.njit(**_NJIT_NORC)
def _flush_captures(win, listener_times, m_first):
    """Add a task's capture table (see :func:`_emit_piece`: row r holds the
    summed emissions at capture ``win.first_capture + r``, channels side by
    side) into its accumulator window ``win``, from sample m_first on;
    returns the number of non-zero rows outside it."""
    acc, capture_sums, first_capture = win.acc, win.capture_sums, win.first_capture
    t_start, fs, n_samples, shift = win.t_start, win.fs, win.n_samples, win.shift
    blo, nb, base, n_ch = win.blo, win.nb, win.base, win.n_ch
    block = 1 << shift
    rs = n_ch * 4
    bad = 0
    for r in range(capture_sums.size // rs):
        m = int(math.ceil((listener_times[first_capture + r] - t_start) * fs))
        j = (m >> shift) - blo if m >= 0 else -1
        ok = 0 <= m < n_samples and 0 <= j < nb and m >= m_first
        dst = base + (j * block + (m - (m >> shift) * block)) * rs
        for i in range(rs):
            v = capture_sums[r * rs + i]
            if v != 0.0:
                if ok:
                    acc[dst + i] += v
                else:
                    bad += 1
    return bad


@numba.njit(inline="always", **_NJIT)
def _add_plain(acc, row, work, r, i):
    """acc[row:row + 4] += rows r..r+3 of lane i of work (row >= 0: unsigned
    indices, no wraparound checks)."""
    a = np.uint64(row)
    w = np.uint64(r * _CHUNK + i)
    for v in range(4):
        acc[a + np.uint64(v)] += work[w + np.uint64(v * _CHUNK)]


@numba.njit(inline="always", **_NJIT)
def _add_gained(acc, row, work, r, i, g0, g1):
    """acc[row:row + 4] += g0·A + g1·B, A in rows r.. and B in rows r + 12.. of
    lane i of work (row >= 0)."""
    a = np.uint64(row)
    w = np.uint64(r * _CHUNK + i)
    for v in range(4):
        acc[a + np.uint64(v)] += (
            g0 * work[w + np.uint64(v * _CHUNK)] + g1 * work[w + np.uint64((v + 12) * _CHUNK)]
        )


@numba.njit(inline="always", **_NJIT)
def _add_dense(acc, row, work, r, i, gains0, gains1, n_ch):
    """acc[row + 4c : row + 4c + 4] += gains0[c, i]·A + gains1[c, i]·B for every channel
    c (A in rows r.., B in rows r + 12.. of lane i of work; row >= 0): the scatter
    of layouts whose gains are all non-zero (AmbiX), A and B read once."""
    a = np.uint64(row)
    w = np.uint64(r * _CHUNK + i)
    k = np.uint64(_CHUNK)
    a0, a1, a2, a3 = work[w], work[w + k], work[w + 2 * k], work[w + 3 * k]
    w = w + 12 * k
    b0, b1, b2, b3 = work[w], work[w + k], work[w + 2 * k], work[w + 3 * k]
    for c in range(n_ch):
        g0 = gains0[c, i]
        g1 = gains1[c, i]
        o = a + np.uint64(4 * c)
        acc[o] += g0 * a0 + g1 * b0
        acc[o + np.uint64(1)] += g0 * a1 + g1 * b1
        acc[o + np.uint64(2)] += g0 * a2 + g1 * b2
        acc[o + np.uint64(3)] += g0 * a3 + g1 * b3


@numba.njit(inline="always", **_NJIT)
def _scatter_group(acc, work, i, si, ei, ci, off, g0, g1):
    """Add g0·A + g1·B of the piece in column i of work to one channel (offset off
    in an accumulator row) at its start, end and continuation rows (unsigned
    indices: no wraparound checks)."""
    _add_gained(acc, si + off, work, ROW.VAL_A, i, g0, g1)
    if ei >= 0:
        _add_gained(acc, ei + off, work, ROW.VAL_A + 4, i, g0, g1)
    if ci >= 0:
        _add_gained(acc, ci + off, work, ROW.VAL_A + 8, i, g0, g1)


@numba.njit(inline="always", **_NJIT)
def _scatter_simple(acc, work, i, panned, pairs, spk_ch, nxt):
    """Add the simple piece or part (kind 1) in lane i of work to the accumulator
    when the layout is unpanned (its polynomial at its start, end and
    continuation rows SI, EI, CI) or panned by speaker pairs (g0·A + g1·B on
    the two channels of the pair at each end; nxt: the channel of the next
    speaker).  Returns whether it was added, and the rows SI, EI, CI (-1: none)
    for the caller to add it otherwise."""
    si = int(work[ROW.SI * _CHUNK + i])
    ei = int(work[ROW.EI * _CHUNK + i])
    ci = int(work[ROW.CI * _CHUNK + i])
    if not panned:
        _add_plain(acc, si, work, ROW.VAL_A, i)
        if ei >= 0:
            _add_plain(acc, ei, work, ROW.VAL_A + 4, i)
        if ci >= 0:
            _add_plain(acc, ci, work, ROW.VAL_A + 8, i)
        return True, si, ei, ci
    if not pairs:
        return False, si, ei, ci
    p0 = int(work[ROW.P0 * _CHUNK + i])
    p1 = int(work[ROW.P1 * _CHUNK + i])
    g00, g01 = work[ROW.G00 * _CHUNK + i], work[ROW.G01 * _CHUNK + i]
    g10, g11 = work[ROW.G10 * _CHUNK + i], work[ROW.G11 * _CHUNK + i]
    c00, c01 = spk_ch[p0], nxt[p0]
    if p0 == p1:
        _scatter_group(acc, work, i, si, ei, ci, c00 * 4, g00, g10)
        _scatter_group(acc, work, i, si, ei, ci, c01 * 4, g01, g11)
    else:
        c10, c11 = spk_ch[p1], nxt[p1]
        _scatter_group(acc, work, i, si, ei, ci, c00 * 4, g00, 0.0)
        _scatter_group(acc, work, i, si, ei, ci, c01 * 4, g01, 0.0)
        _scatter_group(acc, work, i, si, ei, ci, c10 * 4, 0.0, g10)
        _scatter_group(acc, work, i, si, ei, ci, c11 * 4, 0.0, g11)
    return True, si, ei, ci


@intrinsic
def _prefetch(typingctx, arr, idx):
    """Hint the cache to fetch ``arr[idx]`` for writing (``llvm.prefetch``; a
    hint only: no effect on the values, never faults, any index)."""

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1]], wraparound=False)
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch")
        builder.call(fn, [builder.bitcast(ptr, i8p), i32(1), i32(3), i32(1)])
        return context.get_dummy_value()

    return types.void(arr, idx), codegen


#: lanes ahead that the scatter loops ask the cache for (see :func:`_prefetch_lane`)
_AHEAD = 12


@numba.njit(inline="always", **_NJIT)
def _prefetch_lane(acc, work, i, cnt, pairs, spk_ch, nxt):
    """Prefetch the accumulator rows of lane i of work (if i < cnt and the lane is
    a simple piece or part, kind 1): its start and end rows at the channels of
    its first speaker pair (``pairs``) or at the row's start.  The scalar
    scatter loops call it a few lanes ahead: the rows of arrivals at knots lie
    anywhere in an accumulator of many megabytes (8 channels × 4 levels per
    sample), so most of them miss the cache."""
    if i >= cnt:
        return
    if work[ROW.KIND * _CHUNK + i] != KIND_SIMPLE:
        return
    o0 = 0
    o1 = 0
    if pairs:
        p0 = int(work[ROW.P0 * _CHUNK + i])
        o0 = spk_ch[p0] * 4
        o1 = nxt[p0] * 4
    si = int(work[ROW.SI * _CHUNK + i])
    _prefetch(acc, si + o0)
    _prefetch(acc, si + o1)
    ei = int(work[ROW.EI * _CHUNK + i])
    if ei >= 0:
        _prefetch(acc, ei + o0)
        _prefetch(acc, ei + o1)


@numba.njit(inline="always", **_NJIT)
def _clear_window(acc, blk, n_ch, block, n_samples):
    """Zero a task's accumulator window blk = (first block, blocks, offset,
    first sample) from three rows before its first sample (the integration
    reads levels 1-3 from the rows before a sample) to the last sample."""
    w0 = blk[0] * block
    first = max(blk[3] - 3 - w0, 0)
    # (unsigned indices, all >= 0: contiguous stores, not a scatter)
    for i in range(
        blk[2] + n_ch * first * 4, blk[2] + n_ch * min(blk[1] * block, n_samples - w0) * 4
    ):
        acc[np.uint64(i)] = 0.0


@numba.njit(**_NJIT)
def _integrate(acc, task_blk, c_lo, c_hi, b, n_ch, block, n_samples, out):
    """out[c_lo:c_hi] in accumulation block b from the tasks' skewed
    accumulators (channels interleaved per sample row, so one pass reads each
    row once; a task counts from its first sample on): level j of sample m
    is row m - j; the four levels are summed 4, 3, 2 and 1 times."""
    n_tasks = task_blk.shape[0]
    rs = 4 * n_ch
    nc = c_hi - c_lo
    run = np.zeros((nc, 4))
    lim = min(block, n_samples - b * block)
    # the tasks whose window holds block b: the offset of their row of sample
    # 0 at channel c_lo and the first sample they count from
    row0 = np.zeros(n_tasks, dtype=np.int64)
    i0 = np.full(n_tasks, lim, dtype=np.int64)
    for j in range(n_tasks):
        jb = b - task_blk[j, 0]
        if 0 <= jb < task_blk[j, 1]:
            row0[j] = task_blk[j, 2] + (jb * block * n_ch + c_lo) * 4
            i0[j] = max(task_blk[j, 3] - b * block, 0)
    for i in range(lim):
        for c in range(nc):
            v3 = 0.0
            v2 = 0.0
            v1 = 0.0
            v0 = 0.0
            for j in range(n_tasks):
                if i < i0[j]:
                    continue
                # (unsigned: the rows read are >= 0)
                r = np.uint64(row0[j] + (i * n_ch + c) * 4)
                v0 += acc[r]
                if i >= 1:
                    v1 += acc[r - np.uint64(rs - 1)]
                if i >= 2:
                    v2 += acc[r - np.uint64(2 * rs - 2)]
                if i >= 3:
                    v3 += acc[r - np.uint64(3 * rs - 3)]
            r3 = run[c, 3] + v3
            r2 = run[c, 2] + v2 + r3
            r1 = run[c, 1] + v1 + r2
            r0 = run[c, 0] + v0 + r1
            run[c, 3] = r3
            run[c, 2] = r2
            run[c, 1] = r1
            run[c, 0] = r0
            out[c_lo + c, b * block + i] = r0


@numba.njit(parallel=True, **_NJIT)
def _integrate_tasks(acc, task_blk, n_tasks, n_ch, block, n_samples, out):
    """``out (n_ch, n_samples)`` from the skewed accumulators of the first
    n_tasks tasks (see :func:`_integrate`), in parallel over groups of
    channels and accumulation blocks (the running sums restart at every
    block, so blocks are independent): the last stage of both renders."""
    n_groups = min(n_tasks, n_ch)
    n_blocks = (n_samples + block - 1) // block
    for k in numba.prange(n_groups * n_blocks):
        g = k // n_blocks
        b = k - g * n_blocks
        _integrate(
            acc,
            task_blk,
            g * n_ch // n_groups,
            (g + 1) * n_ch // n_groups,
            b,
            n_ch,
            block,
            n_samples,
            out,
        )
