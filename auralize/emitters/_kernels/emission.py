"""Reading the emitted signals along an output piece, for the sampled backend's kernel
(:mod:`auralize.emitters._kernels.sampled`): between two control points the emission
index is a cubic of the output sample, the amplitude weights and panning gains are
linear.  Stored signals are read linearly at the emission index (:func:`_segment`);
table emitters (:class:`auralize.emitters.TableEmitters`) are evaluated at the index
itself (:func:`_seg_table`; every emission sample: :func:`table_samples`).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba
import numpy as np

from auralize.emitters._kernels.common import _NJIT, where

#: Table emitters (:class:`auralize.emitters.TableEmitters`; ``gen`` False: stored
#: signals, the rest placeholders): the padded table (row r continues past its
#: length with its own samples from 0), the rows' lengths and their inverses ``(R, 2)``,
#: the component matrices at the blocks' starts and ends ``qa``, ``qb``, the table
#: positions at the blocks' ends ``phase (S, B + 1)``, the rows ``r0``, ``r1`` and weight
#: ``w`` each block reads, and the samples per table block.
Tables = namedtuple(
    "Tables", ["gen", "table", "lengths", "qa", "qb", "phase", "r0", "r1", "w", "block"]
)
#: The weights and gains of a chunk's control points (``w``, ``g``) and of the
#: listener captures inside its blocks (``wk``, ``gk``).
PointRows = namedtuple("PointRows", ["w", "wk", "g", "gk"])


@numba.njit(inline="always", **_NJIT)
def _scatter(out, vbuf, part, inv, ends, rows):
    """Add ``vbuf[i]`` (``i_lo <= i < i_hi``, ``part`` = (n0, i_lo, i_hi, p0, p1)) to the
    channels of ``out[:, n0 + i]`` with the panning gains linear from row ``ja`` of
    ``rows.g`` (or of ``rows.gk`` if ``ka``) at sample ``p0`` to row ``jb`` likewise at
    ``p0 + 1 / inv`` (``ends`` = (ja, jb, ka, kb))."""
    n0, i_lo, i_hi, p0, _ = part
    ja, jb, ka, kb = ends
    g, gk = rows.g, rows.gk
    for c in range(out.shape[0]):
        ga = gk[ja, c] if ka else g[ja, c]
        gb = gk[jb, c] if kb else g[jb, c]
        if ga == 0.0 and gb == 0.0:  # a silent channel only ever adds 0
            continue
        dg = (gb - ga) * inv
        for i in range(i_lo, i_hi):
            out[c, n0 + i] += (ga + dg * (i - p0)) * vbuf[i]


@numba.njit(inline="always", **_NJIT)
def _weights_along(rows, ends, n_comp):
    """The amplitude weights at a piece's start and their change to its end,
    ``(wa0, wa1, wa2, dw0, dw1, dw2)`` (components 1 and 2 for a dipole, ``n_comp``
    3; else 0): row ``ja`` of ``rows.w`` (of ``rows.wk`` if ``ka``) to row ``jb`` likewise
    with ``kb``, ``ends`` = (ja, jb, ka, kb)."""
    w, wk = rows.w, rows.wk
    ja, jb, ka, kb = ends
    wa0 = wk[ja, 0] if ka else w[ja, 0]
    dw0 = (wk[jb, 0] if kb else w[jb, 0]) - wa0
    wa1 = wa2 = dw1 = dw2 = 0.0
    if n_comp == 3:
        wa1 = wk[ja, 1] if ka else w[ja, 1]
        wa2 = wk[ja, 2] if ka else w[ja, 2]
        dw1 = (wk[jb, 1] if kb else w[jb, 1]) - wa1
        dw2 = (wk[jb, 2] if kb else w[jb, 2]) - wa2
    return wa0, wa1, wa2, dw0, dw1, dw2


@numba.njit(inline="always", **_NJIT)
def _segment(sig, s, last, vbuf, out, part, index, ends, rows):
    """Samples ``i_lo <= i < i_hi`` of a block between positions p0 and p1 (samples;
    ``part`` = (n0, i_lo, i_hi, p0, p1)): emission index ``x0 + u (h1 + u (h2 + u h3))``
    (``index`` = (x0, h1, h2, h3)) with u = (i − p0)/(p1 − p0), weights and gains linear
    from row ``ja`` of (w, g) or, if ``ka``, from row ``ja`` of (wk, gk); to row ``jb``
    likewise with ``kb`` (``ends`` = (ja, jb, ka, kb), ``rows`` a :class:`PointRows`).
    Adds to ``out[:, n0 + i]``."""
    n0, i_lo, i_hi, p0, p1 = part
    x0, h1, h2, h3 = index
    C = sig.shape[1]
    n_ch = out.shape[0]
    inv = 1.0 / (p1 - p0)
    wa0, wa1, wa2, dw0, dw1, dw2 = _weights_along(rows, ends, C)
    # the emission index at both ends (the cubic is monotonic for subsonic motion)
    ua = (i_lo - p0) * inv
    ub = (i_hi - 1 - p0) * inv
    xa = x0 + ua * (h1 + ua * (h2 + ua * h3))
    xb = x0 + ub * (h1 + ub * (h2 + ub * h3))
    inside = min(xa, xb) >= 0.5 and max(xa, xb) <= last - 1.5
    sg0 = sig[s, 0]
    if inside and C == 1 and n_ch == 1:  # no bounds to check, straight to the output
        o = out[0]
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            i0 = int(xi)
            f = xi - i0
            a0 = sg0[i0]
            o[n0 + i] += (wa0 + u * dw0) * (a0 + f * (sg0[i0 + 1] - a0))
        return
    if inside and C == 1:  # no bounds to check
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            i0 = int(xi)
            f = xi - i0
            a0 = sg0[i0]
            vbuf[i] = (wa0 + u * dw0) * (a0 + f * (sg0[i0 + 1] - a0))
    elif inside and n_ch == 1:
        sg1 = sig[s, 1]
        sg2 = sig[s, 2]
        o = out[0]
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            i0 = int(xi)
            f = xi - i0
            a0 = sg0[i0]
            a1 = sg1[i0]
            a2 = sg2[i0]
            o[n0 + i] += (
                (wa0 + u * dw0) * (a0 + f * (sg0[i0 + 1] - a0))
                + (wa1 + u * dw1) * (a1 + f * (sg1[i0 + 1] - a1))
                + (wa2 + u * dw2) * (a2 + f * (sg2[i0 + 1] - a2))
            )
        return
    elif inside:
        sg1 = sig[s, 1]
        sg2 = sig[s, 2]
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            i0 = int(xi)
            f = xi - i0
            a0 = sg0[i0]
            a1 = sg1[i0]
            a2 = sg2[i0]
            vbuf[i] = (
                (wa0 + u * dw0) * (a0 + f * (sg0[i0 + 1] - a0))
                + (wa1 + u * dw1) * (a1 + f * (sg1[i0 + 1] - a1))
                + (wa2 + u * dw2) * (a2 + f * (sg2[i0 + 1] - a2))
            )
    else:  # near or beyond the signal's ends: zero outside [0, last]
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = x0 + u * (h1 + u * (h2 + u * h3))
            v = 0.0
            if xi >= 0.0 and xi <= last:
                i0 = int(xi)
                f = xi - i0
                if i0 >= last:
                    i0 = last
                    f = 0.0
                i1 = min(i0 + 1, last)
                a0 = sig[s, 0, i0]
                v = (wa0 + u * dw0) * (a0 + f * (sig[s, 0, i1] - a0))
                if C == 3:
                    a1 = sig[s, 1, i0]
                    a2 = sig[s, 2, i0]
                    v += (wa1 + u * dw1) * (a1 + f * (sig[s, 1, i1] - a1))
                    v += (wa2 + u * dw2) * (a2 + f * (sig[s, 2, i1] - a2))
            vbuf[i] = v
    if n_ch == 1:
        for i in range(i_lo, i_hi):
            out[0, n0 + i] += vbuf[i]
        return
    _scatter(out, vbuf, part, inv, ends, rows)


@numba.njit(inline="always", **_NJIT)
def _wrap(x, n):
    """x modulo n, in ``[0, n)`` (a table position on a looping row of n samples)."""
    y = x - math.floor(x / n) * n
    return where((0.0 <= y) & (y < n), y, 0.0)


@numba.njit(inline="always", **_NJIT)
def _row_pos(x, lf, r):
    """Table position x on row r (``lf`` as for :func:`_seg_table`), about in ``[0, length)``
    (the reads check)."""
    return x - math.floor(x * lf[r, 1]) * lf[r, 0]


@numba.njit(inline="always", **_NJIT)
def _cubic(x0, h1, h2, h3, u):
    """The emission index ``x0 + u (h1 + u (h2 + u h3))`` at fraction u of a piece."""
    return x0 + u * (h1 + u * (h2 + u * h3))


@numba.njit(inline="always", **_NJIT)
def _m_node(qa, qb, s, b, x, ginv, u, amp, p):
    """Weight of table component p of table emitter s at emission index x, with the
    matrix of table block b (linear across it, extended past its ends) and the amplitude
    weights ``wa + u dw`` at fraction u of the output piece (``amp`` = (wa0, wa1, wa2,
    dw0, dw1, dw2), :func:`_weights_along`)."""
    wa0, wa1, wa2, dw0, dw1, dw2 = amp
    f = x * ginv - b
    q0 = qa[s, b, 0, p]
    m = (wa0 + u * dw0) * (q0 + f * (qb[s, b, 0, p] - q0))
    if qa.shape[2] == 3:
        q1 = qa[s, b, 1, p]
        q2 = qa[s, b, 2, p]
        m += (wa1 + u * dw1) * (q1 + f * (qb[s, b, 1, p] - q1))
        m += (wa2 + u * dw2) * (q2 + f * (qb[s, b, 2, p] - q2))
    return m


@numba.njit(inline="always", **_NJIT)
def _tab_weights(qa, qb, s, x, w, j, ginv):
    """Weights ``w[j, C + p]`` of the P table components of table emitter s at emission
    index x: its amplitude weights ``w[j, :C]`` applied to the matrix of the table block
    holding x (linear from ``qa`` to ``qb`` across the block; extended linearly past the
    emission's ends, where the signal is zero anyway)."""
    b = min(max(int(math.floor(x * ginv)), 0), qa.shape[1] - 1)
    f = x * ginv - b
    for p in range(qa.shape[3]):
        acc = 0.0
        for c in range(qa.shape[2]):
            q = qa[s, b, c, p]
            acc += w[j, c] * (q + f * (qb[s, b, c, p] - q))
        w[j, qa.shape[2] + p] = acc


@numba.njit(inline="always", **_NJIT)
def _node_line(qa, qb, s, b, gK, piece, m_ends, amp, p):
    """The weight of table component p over the part of an output piece in table block b,
    linear in the emission index: ``(xl, ml, slope)`` through its values at the part's
    ends, the piece's ends (``m_ends`` = (mA at index x0, mZ at X1): the control points';
    ``piece`` = (x0, X1, 1/(X1 − x0))) where they lie in the block, else the block's ends
    (:func:`_m_node`; ``amp`` the amplitude weights, :func:`_weights_along`)."""
    x0, X1, iX = piece
    mA, mZ = m_ends
    ginv = 1.0 / gK
    xbeg = b * gK
    xend = xbeg + gK
    if x0 <= X1:
        XL, XR, mL, mR = x0, X1, mA, mZ
    else:
        XL, XR, mL, mR = X1, x0, mZ, mA
    if XL >= xbeg:
        xl, ml = XL, mL
    else:
        xl = xbeg
        ml = _m_node(qa, qb, s, b, xl, ginv, (xl - x0) * iX, amp, p)
    if XR < xend:
        xr, mr = XR, mR
    else:
        xr = xend
        mr = _m_node(qa, qb, s, b, xr, ginv, (xr - x0) * iX, amp, p)
    return xl, ml, (mr - ml) / max(xr - xl, 1e-9)


@numba.njit(inline="always", **_NJIT)
def _read_row(tab, r, out, vbuf, span, start, weights, steps):
    """Samples ``i0 <= i < i1`` (``span`` = (n0, i0, i1)) of a table emitter read from row
    r of ``tab`` without wrap: table position x and component weights m0, m1
    (``start`` = (x, d), ``weights`` = (m0, s0, m1, s1)) advanced by ``d``, ``s0``, ``s1``
    times the step ``D1`` of the emission index (forward differences ``steps`` = (D1,
    D2, D3) of its cubic); added to ``out[0, n0 + i]`` (one channel) or written to
    ``vbuf[i]``."""
    n0, i0, i1 = span
    x, d = start
    m0, s0, m1, s1 = weights
    D1, D2, D3 = steps
    if tab.shape[2] == 2 and out.shape[0] == 1:
        for i in range(i0, i1):
            k = int(x)
            fr = x - k
            a0 = tab[r, k, 0]
            a1 = tab[r, k, 1]
            out[0, n0 + i] += m0 * (a0 + fr * (tab[r, k + 1, 0] - a0)) + m1 * (
                a1 + fr * (tab[r, k + 1, 1] - a1)
            )
            x += d * D1
            m0 += s0 * D1
            m1 += s1 * D1
            D1 += D2
            D2 += D3
        return
    for i in range(i0, i1):
        k = int(x)
        fr = x - k
        a0 = tab[r, k, 0]
        v = m0 * (a0 + fr * (tab[r, k + 1, 0] - a0))
        if tab.shape[2] == 2:
            a1 = tab[r, k, 1]
            v += m1 * (a1 + fr * (tab[r, k + 1, 1] - a1))
        if out.shape[0] == 1:
            out[0, n0 + i] += v
        else:
            vbuf[i] = v
        x += d * D1
        m0 += s0 * D1
        m1 += s1 * D1
        D1 += D2
        D2 += D3


@numba.njit(inline="always", **_NJIT)
def _row_at(tab, r, x, n):
    """Row r of ``tab`` (:func:`_seg_table`; ``n`` samples long) read linearly at table
    position x, wrapped: its components 0 and 1 (0.0 for a one-component table)."""
    if x >= n or x < 0.0:
        x = _wrap(x, n)
    k = int(x)
    fr = x - k
    a0 = tab[r, k, 0]
    g0 = a0 + fr * (tab[r, k + 1, 0] - a0)
    g1 = 0.0
    if tab.shape[2] == 2:
        a1 = tab[r, k, 1]
        g1 = a1 + fr * (tab[r, k + 1, 1] - a1)
    return g0, g1


@numba.njit(inline="always", **_NJIT)
def _seg_table(tables, s, vbuf, out, part, index, ends, rows):
    """:func:`_segment` for table emitter s (:class:`auralize.emitters.TableEmitters`): its
    signal evaluated at the emission index itself, zero outside the emission, as stored
    samples.  Inside a table block the table position is linear in the emission index
    (exact) and so, taken, are the weights of the P table components (the amplitude
    weights, linear over the piece, times the block's matrix; exact at the piece's ends
    and at the table blocks' ends inside it; those at the control points follow the
    amplitude weights in the rows of ``w`` and ``wk``, :func:`_tab_weights`).  ``tables``:
    the :class:`Tables`; ``part``, ``index``, ``ends``, ``rows`` as for :func:`_segment`.

    A piece inside the emission, on one row, across at most eight table blocks' ends and
    read inside the padding (the common case) runs without per-sample tests, block by
    block: the emission index by forward differences of its cubic, the table position and
    the weights advanced with it.  The choice is made on the whole piece, so that the samples do not
    depend on where a window cuts it.
    """
    tab, lf, qa, qb, ph = tables.table, tables.lengths, tables.qa, tables.qb, tables.phase
    r0, r1, wt, gK = tables.r0, tables.r1, tables.w, tables.block
    n0, i_lo, i_hi, p0, p1 = part
    x0, h1, h2, h3 = index
    ja, jb, ka, kb = ends
    w, wk = rows.w, rows.wk
    P = tab.shape[2]
    n_ch = out.shape[0]
    nb = r0.shape[1]
    x_last = nb * gK - 1.0
    top = tab.shape[1] - 2.0  # a position below this reads inside the padding
    inv = 1.0 / (p1 - p0)
    ginv = 1.0 / gK
    amp = _weights_along(rows, ends, qa.shape[2])
    X1 = x0 + h1 + h2 + h3  # the emission index at the piece's end (u = 1)
    iX = where(abs(X1 - x0) > 1e-12, 1.0 / (X1 - x0), 0.0)  # u of an index, linearly
    piece = (x0, X1, iX)
    # the emission index at the piece's first and last samples, as if the piece were whole
    xa = _cubic(x0, h1, h2, h3, (math.ceil(p0) - p0) * inv)
    xb = _cubic(x0, h1, h2, h3, (math.ceil(p1) - 1 - p0) * inv)
    # the component weights at the piece's ends: the control points' (:func:`_tab_weights`)
    C = qa.shape[2]
    mA0 = wk[ja, C] if ka else w[ja, C]
    mZ0 = wk[jb, C] if kb else w[jb, C]
    mA1 = mZ1 = 0.0
    if P == 2:
        mA1 = wk[ja, C + 1] if ka else w[ja, C + 1]
        mZ1 = wk[jb, C + 1] if kb else w[jb, C + 1]
    fast = False
    ba = bz = ra = 0
    if 0.0 <= xa <= xb <= x_last:
        ba = int(xa * ginv)
        bz = min(int(xb * ginv), nb - 1)
        ra = r0[s, ba]
        fast = bz - ba <= 8
        for b in range(ba, bz + 1):
            if not fast:
                break
            # one row, read inside the padding over the piece's part in the block
            pr = _row_pos(ph[s, b], lf, ra)
            span = ph[s, b + 1] - ph[s, b]
            fast = (
                wt[s, b] == 0.0
                and r0[s, b] == ra
                and pr + min(span, 0.0) >= 0.0
                and pr + max(span, 0.0) < top
            )
    if fast:
        i0 = i_lo
        for b in range(ba, bz + 1):
            xbeg = b * gK
            xend = xbeg + gK
            # the samples up to the first at or past the block's end (from a linear guess)
            i1 = i_hi
            if b < bz:
                i1 = min(max(int(math.ceil(p0 + (xend - x0) * iX * (p1 - p0))), i0), i_hi)
                while i1 > i0 and _cubic(x0, h1, h2, h3, (i1 - 1 - p0) * inv) >= xend:
                    i1 -= 1
                while i1 < i_hi and _cubic(x0, h1, h2, h3, (i1 - p0) * inv) < xend:
                    i1 += 1
            if i1 <= i0:
                continue
            # weights linear in the index inside the block (:func:`_node_line`)
            xl, ml0, s0 = _node_line(qa, qb, s, b, gK, piece, (mA0, mZ0), amp, 0)
            ml1 = s1 = 0.0
            if P == 2:
                xl, ml1, s1 = _node_line(qa, qb, s, b, gK, piece, (mA1, mZ1), amp, 1)
            # the index at the first sample and its forward differences (exact for a cubic:
            # x(u + e) − x(u) and its differences, e the step in u of one sample); the
            # table position there, linear in the index inside the block
            u = (i0 - p0) * inv
            e = inv
            xi = _cubic(x0, h1, h2, h3, u)
            D1 = e * (h1 + h2 * (2.0 * u + e) + h3 * (3.0 * u * (u + e) + e * e))
            D2 = e * e * (2.0 * h2 + h3 * (6.0 * (u + e)))
            D3 = 6.0 * h3 * e * e * e
            d = (ph[s, b + 1] - ph[s, b]) * ginv
            ps = _row_pos(ph[s, b], lf, ra) + d * (xi - xbeg)
            _read_row(
                tab,
                ra,
                out,
                vbuf,
                (n0, i0, i1),
                (ps, d),
                (ml0 + s0 * (xi - xl), s0, ml1 + s1 * (xi - xl), s1),
                (D1, D2, D3),
            )
            i0 = i1
    else:
        xbeg = 1.0
        xend = 0.0  # no table block loaded yet
        ra = rb = 0
        Na = Nb = pa = pb = ds = wr = xl = 0.0
        ml0 = ml1 = sl0 = sl1 = 0.0
        for i in range(i_lo, i_hi):
            u = (i - p0) * inv
            xi = _cubic(x0, h1, h2, h3, u)
            if xi < 0.0 or xi > x_last:
                if n_ch > 1:
                    vbuf[i] = 0.0
                continue
            if xi < xbeg or xi >= xend:  # the table block holding this index
                b = min(int(xi * ginv), nb - 1)
                xbeg = float(b * gK)
                xend = xbeg + gK
                ra = r0[s, b]
                rb = r1[s, b]
                wr = wt[s, b]
                Na = lf[ra, 0]
                Nb = lf[rb, 0]
                ds = (ph[s, b + 1] - ph[s, b]) * ginv
                pa = _row_pos(ph[s, b], lf, ra) - ds * xbeg  # row ra's position: pa + ds x
                pb = _row_pos(ph[s, b], lf, rb) - ds * xbeg
                # weights linear in the index inside the block (:func:`_node_line`)
                xl, ml0, sl0 = _node_line(qa, qb, s, b, gK, piece, (mA0, mZ0), amp, 0)
                if P == 2:
                    xl, ml1, sl1 = _node_line(qa, qb, s, b, gK, piece, (mA1, mZ1), amp, 1)
            gx, gy = _row_at(tab, ra, pa + ds * xi, Na)
            if wr != 0.0:  # between two rows
                hx, hy = _row_at(tab, rb, pb + ds * xi, Nb)
                gx += wr * (hx - gx)
                gy += wr * (hy - gy)
            v = (ml0 + sl0 * (xi - xl)) * gx + (ml1 + sl1 * (xi - xl)) * gy
            if n_ch == 1:
                out[0, n0 + i] += v
            else:
                vbuf[i] = v
    if n_ch == 1:
        return
    _scatter(out, vbuf, part, inv, ends, rows)


@numba.njit(**_NJIT)
def table_samples(tables, out, s0, s1):
    """Every emission sample of table emitters ``s0 <= s < s1`` into ``out (S, C, B K)``
    (the definition in :class:`auralize.emitters.TableEmitters`; ``tables`` a
    :class:`Tables`)."""
    tab, lf, qa, qb, ph = tables.table, tables.lengths, tables.qa, tables.qb, tables.phase
    r0, r1, wt, K = tables.r0, tables.r1, tables.w, tables.block
    B = qa.shape[1]
    C = qa.shape[2]
    P = qa.shape[3]
    inv = 1.0 / K
    tv = np.empty(P)
    for s in range(s0, s1):
        for b in range(B):
            ra = r0[s, b]
            rb = r1[s, b]
            wr = wt[s, b]
            Na = lf[ra, 0]
            Nb = lf[rb, 0]
            pa = _row_pos(ph[s, b], lf, ra)
            pb = _row_pos(ph[s, b], lf, rb)
            ds = (ph[s, b + 1] - ph[s, b]) * inv
            for j in range(K):
                x = pa + ds * j
                if x >= Na or x < 0.0:
                    x = _wrap(x, Na)
                k = int(x)
                fr = x - k
                y = pb + ds * j
                if y >= Nb or y < 0.0:
                    y = _wrap(y, Nb)
                kb = int(y)
                fb = y - kb
                for p in range(P):
                    a = tab[ra, k, p]
                    v = a + fr * (tab[ra, k + 1, p] - a)
                    if wr != 0.0:
                        a = tab[rb, kb, p]
                        v += wr * (a + fb * (tab[rb, kb + 1, p] - a) - v)
                    tv[p] = v
                for c in range(C):
                    acc = 0.0
                    for p in range(P):
                        q = qa[s, b, c, p]
                        acc += (q + (qb[s, b, c, p] - q) * (j * inv)) * tv[p]
                    out[s, c, b * K + j] = acc
