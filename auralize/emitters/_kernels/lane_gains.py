"""Panning gains over the lanes of a chunk (SIMD loops): the listener's frame at each
piece's two arrivals, the direction of the source in it, and the gains of
speaker pairs (2-D VBAP, :func:`_chunk_pair_gains`, :func:`_part_pair_gains`)
or of the AmbiX harmonics (:func:`_chunk_sh_gains`, :func:`_sh_lanes`).

The same laws as :mod:`auralize.emitters._kernels.gains`, branch-free, one
lane per piece, reading and writing rows of the work array
(:data:`auralize.emitters._kernels.common.ROW`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from auralize.emitters._kernels.arrivals import _LINE, _line_tuple, _listener_at
from auralize.emitters._kernels.common import (
    _CHUNK,
    _NJIT,
    _NJIT_NORC,
    KIND_GENERAL,
    KIND_SILENT,
    ROW,
    where,
)


@numba.njit(inline="always", **_NJIT)
def _frame_coords(work, i, o, dx, dy, dz):
    """Direction (dx, dy, dz) in the listener's frame whose forward and up are
    rows o..o+5 of work: (forward, left) coordinates, left = up × forward."""
    fx, fy, fz = work[o * _CHUNK + i], work[(o + 1) * _CHUNK + i], work[(o + 2) * _CHUNK + i]
    ux, uy, uz = work[(o + 3) * _CHUNK + i], work[(o + 4) * _CHUNK + i], work[(o + 5) * _CHUNK + i]
    lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
    return dx * fx + dy * fy + dz * fz, dx * lx + dy * ly + dz * lz


@numba.njit(inline="always", **_NJIT)
def _frame_coords3(work, i, o, dx, dy, dz):
    """As :func:`_frame_coords` with the third coordinate (up)."""
    fx, fy, fz = work[o * _CHUNK + i], work[(o + 1) * _CHUNK + i], work[(o + 2) * _CHUNK + i]
    ux, uy, uz = work[(o + 3) * _CHUNK + i], work[(o + 4) * _CHUNK + i], work[(o + 5) * _CHUNK + i]
    lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
    return dx * fx + dy * fy + dz * fz, dx * lx + dy * ly + dz * lz, dx * ux + dy * uy + dz * uz


@numba.njit(inline="always", **_NJIT)
def _orient_rows(work, i, o, orient_table, orient_clock, t):
    """Rows o..o+5 of column i of work: the listener's forward and up at data time
    t from the orientation table (see :func:`_orient`)."""
    n = orient_table.shape[0]
    u = (t - orient_clock[0]) * orient_clock[1]
    j = 0
    w = 0.0
    if n > 1 and u > 0.0:
        if u >= n - 1:
            j = n - 1
        else:
            j = int(u)
            w = u - j
    j1 = min(j + 1, n - 1)
    for c in range(6):
        work[(o + c) * _CHUNK + i] = orient_table[j, c] + w * (
            orient_table[j1, c] - orient_table[j, c]
        )


@numba.njit(inline="always", **_NJIT)
def _orient_cell(t0, rate, top, t):
    """Row j (unsigned) and weight w of the orientation table (at least two
    rows, the last at ``top``) at data time t: the value is row j + w·(row j+1
    - row j); held outside the table (see :func:`_orient_lane`)."""
    u = (t - t0) * rate
    u = where(u > 0.0, u, 0.0)
    u = where(u < top, u, top)
    jf = np.floor(u)
    jf = where(jf < top - 1.0, jf, top - 1.0)
    return np.uint64(jf), u - jf


@numba.njit(inline="always", **_NJIT)
def _orient_lane(work, i, o, orient_table, t0, rate, top, t):
    """Rows o..o+5 of column i of work: the listener's forward and up at data time
    t from the orientation table orient_table (at least two rows, the last at ``top`` =
    rows - 1) sampled every 1/rate s from t0 (see :func:`_orient`); held
    outside the table.  Branch-free."""
    j, w = _orient_cell(t0, rate, top, t)
    for c in range(6):
        uc = np.uint64(c)
        a = orient_table[j, uc]
        work[(o + c) * _CHUNK + i] = a + w * (orient_table[j + np.uint64(1), uc] - a)


@numba.njit(inline="always", **_NJIT)
def _orient_chunk(work, cnt, orient_table, orient_clock, const_orient):
    """The listener's forward and up at both arrivals (rows A0, A1) of the
    chunk's pieces into rows O0, O1 of work (see :func:`_orient_rows`)."""
    if const_orient:
        for c in range(6):
            v = orient_table[0, c]
            for i in range(cnt):
                work[(ROW.O0 + c) * _CHUNK + i] = v
                work[(ROW.O1 + c) * _CHUNK + i] = v
    else:
        # (not constant: at least two rows) branch-free, unsigned indices: SIMD
        top = float(orient_table.shape[0] - 1)
        for i in range(cnt):
            _orient_lane(
                work,
                i,
                ROW.O0,
                orient_table,
                orient_clock[0],
                orient_clock[1],
                top,
                work[ROW.A0 * _CHUNK + i],
            )
            _orient_lane(
                work,
                i,
                ROW.O1,
                orient_table,
                orient_clock[0],
                orient_clock[1],
                top,
                work[ROW.A1 * _CHUNK + i],
            )


@numba.njit(inline="always", **_NJIT)
def _frame_at(orient_table, t0, rate, top, t, dx, dy, dz):
    """(forward, left) coordinates of direction (dx, dy, dz) in the listener's
    frame at data time t, forward and up from the orientation table orient_table (at
    least two rows; see :func:`_orient_lane`), left = up × forward."""
    j, w = _orient_cell(t0, rate, top, t)
    k = j + np.uint64(1)
    a = orient_table[j, np.uint64(0)]
    fx = a + w * (orient_table[k, np.uint64(0)] - a)
    a = orient_table[j, np.uint64(1)]
    fy = a + w * (orient_table[k, np.uint64(1)] - a)
    a = orient_table[j, np.uint64(2)]
    fz = a + w * (orient_table[k, np.uint64(2)] - a)
    a = orient_table[j, np.uint64(3)]
    ux = a + w * (orient_table[k, np.uint64(3)] - a)
    a = orient_table[j, np.uint64(4)]
    uy = a + w * (orient_table[k, np.uint64(4)] - a)
    a = orient_table[j, np.uint64(5)]
    uz = a + w * (orient_table[k, np.uint64(5)] - a)
    lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
    return dx * fx + dy * fy + dz * fz, dx * lx + dy * ly + dz * lz


@numba.njit(inline="always", **_NJIT)
def _pair_take(work, i, rp, rx, ry, a0, a1, a2, a3, fp, lo):
    """Pair fp's gains from the direction (rows rx, ry) if both are >= lo and no
    earlier pair was taken (row rp = pair index, then the two gains)."""
    xf = work[rx * _CHUNK + i]
    yl = work[ry * _CHUNK + i]
    g0 = a0 * xf + a1 * yl
    g1 = a2 * xf + a3 * yl
    k = rp * _CHUNK + i
    take = (g0 >= lo) & (g1 >= lo) & (work[k] < 0.0)
    work[k] = where(take, fp, work[k])
    work[k + _CHUNK] = where(take, g0, work[k + _CHUNK])
    work[k + 2 * _CHUNK] = where(take, g1, work[k + 2 * _CHUNK])


@numba.njit(inline="always", **_NJIT)
def _pair_normalise(work, i, rp):
    k = rp * _CHUNK + i
    g0 = max(work[k + _CHUNK], 0.0)
    g1 = max(work[k + 2 * _CHUNK], 0.0)
    norm = math.sqrt(g0 * g0 + g1 * g1)
    inv = 1.0 / where(norm > 0.0, norm, 1.0)
    work[k + _CHUNK] = g0 * inv
    work[k + 2 * _CHUNK] = g1 * inv
    return (norm > 0.0) & (work[k] >= 0.0)


@numba.njit(inline="always", **_NJIT)
def _pair_search(work, cnt, pinv, fold):
    """Pair index and gains at both arrivals from the directions in rows
    XF0, YL0, XF1, YL1 (pair rows preset to -1); a direction with no pair
    (straight above or below) marks the piece general.  ``fold`` mirrors
    rear directions to the front; a folding layout's single pair (two
    speakers in front, see :func:`auralize.emitters._kernels.gains._gains_plane`)
    takes every direction, its negative gain clamped to 0."""
    if fold:
        for i in range(cnt):
            work[ROW.XF0 * _CHUNK + i] = abs(work[ROW.XF0 * _CHUNK + i])
            work[ROW.XF1 * _CHUNK + i] = abs(work[ROW.XF1 * _CHUNK + i])
    lo = -math.inf if fold and pinv.shape[0] == 1 else -1e-12
    for p in range(pinv.shape[0]):
        a0, a1, a2, a3 = pinv[p, 0], pinv[p, 1], pinv[p, 2], pinv[p, 3]
        fp = float(p)
        for i in range(cnt):
            _pair_take(work, i, ROW.P0, ROW.XF0, ROW.YL0, a0, a1, a2, a3, fp, lo)
            _pair_take(work, i, ROW.P1, ROW.XF1, ROW.YL1, a0, a1, a2, a3, fp, lo)
    for i in range(cnt):
        ok = _pair_normalise(work, i, ROW.P0) & _pair_normalise(work, i, ROW.P1)
        kd = work[ROW.KIND * _CHUNK + i]
        work[ROW.KIND * _CHUNK + i] = where((kd != KIND_SILENT) & ~ok, KIND_GENERAL, kd)


@numba.njit(**_NJIT_NORC)
def _chunk_pair_gains(
    work, cnt, lines0, lines1, orient_table, orient_clock, pinv, fold, const_orient
):
    """Pairwise 2-D VBAP gains at both arrivals of the chunk's pieces (the law
    of :func:`_gains`, fast path: the first speaker pair whose inverse base
    gives both gains >= 0, or a folding layout's single pair, see
    :func:`_pair_search`, power-normalised): pair index and two gains per
    arrival into work.  The listener's orientation is read from its table in a
    scalar loop (unless it is constant), the rest in SIMD loops.  A direction
    straight above or below (no pair) marks the piece general."""
    _orient_chunk(work, cnt, orient_table, orient_clock, const_orient)
    l0a = _line_tuple(lines0, 0)
    l0b = _line_tuple(lines0, _LINE)
    l1a = _line_tuple(lines1, 0)
    l1b = _line_tuple(lines1, _LINE)
    for i in range(cnt):
        x, y, z = work[ROW.X * _CHUNK + i], work[ROW.Y * _CHUNK + i], work[ROW.Z * _CHUNK + i]
        px, py, pz = _listener_at(work[ROW.A0 * _CHUNK + i], work[ROW.S0 * _CHUNK + i], l0a, l0b)
        xf, yl = _frame_coords(work, i, ROW.O0, x - px, y - py, z - pz)
        work[ROW.XF0 * _CHUNK + i] = xf
        work[ROW.YL0 * _CHUNK + i] = yl
        # (a piece cut at a capture, see _cut_at_end, ends on one of its start's lines)
        a1, s1 = work[ROW.A1 * _CHUNK + i], work[ROW.S1 * _CHUNK + i]
        px, py, pz = _listener_at(a1, s1, l1a, l1b)
        qx, qy, qz = _listener_at(a1, s1, l0a, l0b)
        on1 = (s1 == l1a[11]) | (s1 == l1b[11])
        px = where(on1, px, qx)
        py = where(on1, py, qy)
        pz = where(on1, pz, qz)
        xf, yl = _frame_coords(work, i, ROW.O1, x - px, y - py, z - pz)
        work[ROW.XF1 * _CHUNK + i] = xf
        work[ROW.YL1 * _CHUNK + i] = yl
        work[ROW.P0 * _CHUNK + i] = -1.0
        work[ROW.P1 * _CHUNK + i] = -1.0
    _pair_search(work, cnt, pinv, fold)


@numba.njit(**_NJIT_NORC)
def _part_pair_gains(work, cnt, orient_table, orient_clock, pinv, fold, const_orient):
    """Pairwise 2-D VBAP gains at both arrivals of a batch of parts (as
    :func:`_chunk_pair_gains`, the listener's positions from rows L0, L1)."""
    if const_orient:
        _orient_chunk(work, cnt, orient_table, orient_clock, const_orient)
        for i in range(cnt):
            x, y, z = work[ROW.X * _CHUNK + i], work[ROW.Y * _CHUNK + i], work[ROW.Z * _CHUNK + i]
            px, py, pz = (
                work[ROW.L0 * _CHUNK + i],
                work[(ROW.L0 + 1) * _CHUNK + i],
                work[(ROW.L0 + 2) * _CHUNK + i],
            )
            xf, yl = _frame_coords(work, i, ROW.O0, x - px, y - py, z - pz)
            work[ROW.XF0 * _CHUNK + i] = xf
            work[ROW.YL0 * _CHUNK + i] = yl
            px, py, pz = (
                work[ROW.L1 * _CHUNK + i],
                work[(ROW.L1 + 1) * _CHUNK + i],
                work[(ROW.L1 + 2) * _CHUNK + i],
            )
            xf, yl = _frame_coords(work, i, ROW.O1, x - px, y - py, z - pz)
            work[ROW.XF1 * _CHUNK + i] = xf
            work[ROW.YL1 * _CHUNK + i] = yl
    else:
        # the table's look-ups are gathers (a scalar loop): the frame is used
        # where it is read, not stored
        top = float(orient_table.shape[0] - 1)
        t0, rate = orient_clock[0], orient_clock[1]
        for i in range(cnt):
            x, y, z = work[ROW.X * _CHUNK + i], work[ROW.Y * _CHUNK + i], work[ROW.Z * _CHUNK + i]
            px, py, pz = (
                work[ROW.L0 * _CHUNK + i],
                work[(ROW.L0 + 1) * _CHUNK + i],
                work[(ROW.L0 + 2) * _CHUNK + i],
            )
            xf, yl = _frame_at(
                orient_table, t0, rate, top, work[ROW.A0 * _CHUNK + i], x - px, y - py, z - pz
            )
            work[ROW.XF0 * _CHUNK + i] = xf
            work[ROW.YL0 * _CHUNK + i] = yl
            px, py, pz = (
                work[ROW.L1 * _CHUNK + i],
                work[(ROW.L1 + 1) * _CHUNK + i],
                work[(ROW.L1 + 2) * _CHUNK + i],
            )
            xf, yl = _frame_at(
                orient_table, t0, rate, top, work[ROW.A1 * _CHUNK + i], x - px, y - py, z - pz
            )
            work[ROW.XF1 * _CHUNK + i] = xf
            work[ROW.YL1 * _CHUNK + i] = yl
    for i in range(cnt):
        work[ROW.P0 * _CHUNK + i] = -1.0
        work[ROW.P1 * _CHUNK + i] = -1.0
    _pair_search(work, cnt, pinv, fold)


@numba.njit(inline="always", **_NJIT)
def _sh_lanes(work, cnt, rx, ry, rz, tab, gains, scratch):
    """AmbiX gains ``gains ((N+1)², _CHUNK)`` of the directions in rows rx, ry, rz of
    work (the law of :func:`_gains_sh`, one SIMD loop per harmonic over the
    chunk's lanes; the rows are normalised in place; scratch ``scratch (5, _CHUNK)``;
    harmonic k goes to row ``tab[k, 1]`` of gains, none when −1; the recurrence
    stops at the highest degree and the highest |m| the layout keeps, e.g.
    m = 0 for the zonal harmonics of the ear receivers)."""
    order = 0
    m_top = 0
    for k in range(tab.shape[0]):
        if tab[k, 1] >= 0.0:
            n_k = int(math.sqrt(k) + 1e-9)
            m_k = abs(k - n_k * n_k - n_k)
            order = max(order, n_k)
            m_top = max(m_top, m_k)
    for i in range(cnt):
        x, y, z = work[rx * _CHUNK + i], work[ry * _CHUNK + i], work[rz * _CHUNK + i]
        r2 = x * x + y * y + z * z
        nz = r2 > 0.0
        inv = 1.0 / math.sqrt(where(nz, r2, 1.0))
        work[rx * _CHUNK + i] = x * inv
        work[ry * _CHUNK + i] = y * inv
        work[rz * _CHUNK + i] = z * inv
        scratch[4, i] = where(nz, 1.0, 0.0)  # no direction: the omnidirectional channel (W) only
        scratch[0, i] = 1.0  # Re (x + iy)^m
        scratch[1, i] = 0.0  # Im (x + iy)^m
    pmm = 1.0
    for m in range(m_top + 1):
        if m > 0:
            pmm *= 2 * m - 1
            for i in range(cnt):
                x, y = work[rx * _CHUNK + i], work[ry * _CHUNK + i]
                c, s_ = scratch[0, i], scratch[1, i]
                scratch[0, i] = c * x - s_ * y
                scratch[1, i] = s_ * x + c * y
        for i in range(cnt):
            scratch[2, i] = pmm
            scratch[3, i] = 0.0
        for n in range(m, order + 1):
            if n == m + 1:
                a = 2.0 * m + 1.0
                for i in range(cnt):
                    q = scratch[2, i]
                    scratch[2, i] = a * work[rz * _CHUNK + i] * q
                    scratch[3, i] = q
            elif n > m + 1:
                a = (2.0 * n - 1.0) / (n - m)
                b = (n + m - 1.0) / (n - m)
                for i in range(cnt):
                    q = scratch[2, i]
                    scratch[2, i] = a * work[rz * _CHUNK + i] * q - b * scratch[3, i]
                    scratch[3, i] = q
            k = n * n + n + m
            f = tab[k, 0]
            d = int(tab[k, 1])
            if d >= 0:  # a harmonic the layout leaves out is skipped; the recurrence goes on
                if n == 0:
                    for i in range(cnt):
                        gains[d, i] = f
                else:
                    for i in range(cnt):
                        gains[d, i] = f * scratch[2, i] * scratch[0, i] * scratch[4, i]
            if m > 0:
                k = n * n + n - m
                f = tab[k, 0]
                d = int(tab[k, 1])
                if d >= 0:
                    for i in range(cnt):
                        gains[d, i] = f * scratch[2, i] * scratch[1, i] * scratch[4, i]


@numba.njit(**_NJIT)
def _chunk_sh_gains(
    work,
    cnt,
    lines0,
    lines1,
    orient_table,
    orient_clock,
    tab,
    const_orient,
    gains0,
    gains1,
    scratch,
):
    """AmbiX gains (:func:`_gains_sh`) at both arrivals of the chunk's pieces into
    ``gains0``/``gains1 ((N+1)², _CHUNK)``: listener-frame directions as in
    :func:`_chunk_pair_gains` (rows ROW.XF*, ROW.YL* and, unused by AmbiX,
    ROW.P0/ROW.P1 for up), harmonics by :func:`_sh_lanes`."""
    if const_orient:
        for c in range(6):
            v = orient_table[0, c]
            for i in range(cnt):
                work[(ROW.O0 + c) * _CHUNK + i] = v
                work[(ROW.O1 + c) * _CHUNK + i] = v
    else:
        for i in range(cnt):
            _orient_rows(work, i, ROW.O0, orient_table, orient_clock, work[ROW.A0 * _CHUNK + i])
            _orient_rows(work, i, ROW.O1, orient_table, orient_clock, work[ROW.A1 * _CHUNK + i])
    l0a = _line_tuple(lines0, 0)
    l0b = _line_tuple(lines0, _LINE)
    l1a = _line_tuple(lines1, 0)
    l1b = _line_tuple(lines1, _LINE)
    for i in range(cnt):
        x, y, z = work[ROW.X * _CHUNK + i], work[ROW.Y * _CHUNK + i], work[ROW.Z * _CHUNK + i]
        px, py, pz = _listener_at(work[ROW.A0 * _CHUNK + i], work[ROW.S0 * _CHUNK + i], l0a, l0b)
        xf, yl, zu = _frame_coords3(work, i, ROW.O0, x - px, y - py, z - pz)
        work[ROW.XF0 * _CHUNK + i] = xf
        work[ROW.YL0 * _CHUNK + i] = yl
        work[ROW.P0 * _CHUNK + i] = zu
        # (a piece cut at a capture, see _cut_at_end, ends on one of its start's lines)
        a1, s1 = work[ROW.A1 * _CHUNK + i], work[ROW.S1 * _CHUNK + i]
        px, py, pz = _listener_at(a1, s1, l1a, l1b)
        qx, qy, qz = _listener_at(a1, s1, l0a, l0b)
        on1 = (s1 == l1a[11]) | (s1 == l1b[11])
        px = where(on1, px, qx)
        py = where(on1, py, qy)
        pz = where(on1, pz, qz)
        xf, yl, zu = _frame_coords3(work, i, ROW.O1, x - px, y - py, z - pz)
        work[ROW.XF1 * _CHUNK + i] = xf
        work[ROW.YL1 * _CHUNK + i] = yl
        work[ROW.P1 * _CHUNK + i] = zu
    _sh_lanes(work, cnt, ROW.XF0, ROW.YL0, ROW.P0, tab, gains0, scratch)
    _sh_lanes(work, cnt, ROW.XF1, ROW.YL1, ROW.P1, tab, gains1, scratch)
