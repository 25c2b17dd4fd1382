"""The piece and run tables the renders read, built from the tracks' strengths:
the sounding pieces in chunks (:func:`build_pieces`, for
:mod:`auralize.emitters._kernels.render_pieces`) and the runs of consecutive
sounding pieces with their knot data (:func:`find_runs`, :func:`fill_runs`,
for :mod:`auralize.emitters._kernels.render_runs`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from auralize.emitters._kernels.common import _CHUNK, _NJIT, KNOT_ROW


@numba.njit(inline="always", **_NJIT)
def _knot_q(q, k, n, T, scale):
    """q/(4π) of source k at padded knot n (0 and T + 1 are the silent pads)."""
    if n < 1 or n > T:
        return 0.0
    return q[k, n - 1] * scale


@numba.njit(inline="always", **_NJIT)
def _knot_m(q, k, n, T, tn, scale):
    """Central-difference tangent dq/dτ at padded knot n (zero at the pads)."""
    if n < 1 or n > T:
        return 0.0
    return (_knot_q(q, k, n + 1, T, scale) - _knot_q(q, k, n - 1, T, scale)) / (
        tn[n + 1] - tn[n - 1]
    )


@numba.njit(**_NJIT)
def build_pieces(q, tn, pos, radius, cubic, counts_only, cptr, ccnt, piece_data):
    """The sounding pieces of tracks q (K, T) with padded knot times tn (T + 2),
    in chunks (see :func:`render`): piece n of source k (padded knots n, n + 1)
    sounds when q or (cubic) its tangent is non-zero at either knot.

    With ``counts_only`` returns the number of pieces per row (then the caller
    sizes cptr, ccnt, piece_data); else fills ccnt and piece_data.  Source-major, one pass
    over q (contiguous), a write cursor per row.
    """
    K, T = q.shape
    Tp = T + 2
    scale = 1.0 / (4.0 * math.pi)
    counts = np.zeros(Tp, dtype=np.int64)
    cur = np.zeros(Tp, dtype=np.int64)
    for k in range(K):
        # knot values: nz at knot n needs q (and m for cubic) at n
        q_prev = 0.0
        m_prev = 0.0
        nz_prev = False
        for n in range(Tp):
            qn = _knot_q(q, k, n, T, scale)
            mn = _knot_m(q, k, n, T, tn, scale) if cubic else 0.0
            nz = qn != 0.0 or mn != 0.0
            if n > 0 and (nz or nz_prev):
                r = n - 1  # piece r from knot r to r + 1
                if counts_only:
                    counts[r] += 1
                else:
                    j = cur[r]
                    cur[r] = j + 1
                    ck = cptr[r] + j // _CHUNK
                    ln = j % _CHUNK
                    piece_data[ck, 0, ln] = pos[k, 0]
                    piece_data[ck, 1, ln] = pos[k, 1]
                    piece_data[ck, 2, ln] = pos[k, 2]
                    piece_data[ck, 3, ln] = max(radius[k], 1e-9)
                    piece_data[ck, 4, ln] = q_prev
                    piece_data[ck, 6, ln] = qn
                    if cubic:
                        piece_data[ck, 5, ln] = m_prev
                        piece_data[ck, 7, ln] = mn
                    else:
                        slope = (qn - q_prev) / (tn[n] - tn[r])
                        piece_data[ck, 5, ln] = slope
                        piece_data[ck, 7, ln] = slope
            q_prev = qn
            m_prev = mn
            nz_prev = nz
    if not counts_only:
        for r in range(Tp):
            for c in range(cptr[r], cptr[r + 1]):
                ccnt[c] = min(_CHUNK, cur[r] - (c - cptr[r]) * _CHUNK)
    return counts if counts_only else cur


@numba.njit(**_NJIT)
def find_runs(q, tn, cubic, counts_only, src, r0, length):
    """Runs of consecutive sounding pieces of tracks q (K, T) with padded knot
    times tn (T + 2): piece n (padded knots n, n + 1) sounds when q or (cubic)
    its tangent is non-zero at either knot (as in
    :func:`build_pieces`).  With ``counts_only``
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
def fill_runs(q, tn, pos, radius, cubic, src, r0, length, chunk, lane, goff, knot_data):
    """Knot data of every run (lane ``lane[i]`` of chunk ``chunk[i]``, see
    :func:`render`); knot_data must be zero-filled (knots past a run are silent)."""
    T = q.shape[1]
    scale = 1.0 / (4.0 * math.pi)
    for i in range(src.size):
        k = src[i]
        b = goff[chunk[i]] + lane[i]
        knot_data[b + KNOT_ROW.X * _CHUNK] = pos[k, 0]
        knot_data[b + KNOT_ROW.Y * _CHUNK] = pos[k, 1]
        knot_data[b + KNOT_ROW.Z * _CHUNK] = pos[k, 2]
        knot_data[b + KNOT_ROW.RM * _CHUNK] = max(radius[k], 1e-9)
        knot_data[b + KNOT_ROW.LEN * _CHUNK] = length[i]
        for jk in range(length[i] + 1):
            n = r0[i] + jk
            qn = _knot_q(q, k, n, T, scale)
            if cubic:
                mn = _knot_m(q, k, n, T, tn, scale)
            elif n + 1 < tn.size:
                mn = (_knot_q(q, k, n + 1, T, scale) - qn) / (tn[n + 1] - tn[n])
            else:
                mn = 0.0
            knot_data[b + (KNOT_ROW.KNOT + 2 * jk) * _CHUNK] = qn
            knot_data[b + (KNOT_ROW.KNOT + 2 * jk + 1) * _CHUNK] = mn
