"""Compiled core of the retarded-time synthesis (see :mod:`auralize.synthesis`).

Why numba: the algorithm walks, per source, its sequence of time steps, solves
for each step's arrival time at the moving listener (Newton), and emits a few
polynomial coefficients per piece.  The loop has data-dependent control flow
(splitting pieces at listener captures, skipping silent steps) that numpy
cannot express without materialising sources × samples arrays.

The signal of one source between two consecutive arrivals of its knots is a
smooth function f(t) = q(τ(t)) / D(t) with τ(t) = t - D(t)/c0 (Eqs. 15-17).
It is represented on each piece by the cubic Hermite interpolant of f and f'
at the piece's ends, which is exact for a static listener (q is a cubic in τ,
τ is linear in t) and accurate to O(h⁴) otherwise.  The cubic is written in the
binomial basis C(m - m0, i) at its first sample m0; the basis function
C(m - m0, i)·H(m - m0) is the (i+1)-fold cumulative sum of an impulse at
m0 + i, so a piece costs 4 impulses at its start and 4 (of the polynomial
continued, subtracted) at its end, whatever its length.  Four cumulative sums
per block then give the summed signal.  Cost: O(sources × steps + samples).
"""

from __future__ import annotations

import math

import numba
import numpy as np

_NJIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(inline="always", **_NJIT)
def _segment(tc, t, hint):  # type: ignore[no-untyped-def]
    """Index s of the capture interval [tc[s], tc[s+1]) holding t, or -1 / M-1 outside."""
    m = tc.size
    if t < tc[0]:
        return -1
    if t >= tc[m - 1]:
        return m - 1
    s = hint
    if s < 0:
        s = 0
    if s > m - 2:
        s = m - 2
    while s > 0 and t < tc[s]:
        s -= 1
    while s < m - 2 and t >= tc[s + 1]:
        s += 1
    return s


@numba.njit(inline="always", **_NJIT)
def _listener(tc, lc, vc, t, s):  # type: ignore[no-untyped-def]
    """Listener position and velocity at time t on segment s (held outside the path)."""
    m = tc.size
    if s < 0:
        return lc[0, 0], lc[0, 1], lc[0, 2], 0.0, 0.0, 0.0
    if s >= m - 1:
        return lc[m - 1, 0], lc[m - 1, 1], lc[m - 1, 2], 0.0, 0.0, 0.0
    dt = t - tc[s]
    return (
        lc[s, 0] + vc[s, 0] * dt,
        lc[s, 1] + vc[s, 1] * dt,
        lc[s, 2] + vc[s, 2] * dt,
        vc[s, 0],
        vc[s, 1],
        vc[s, 2],
    )


@numba.njit(inline="always", **_NJIT)
def _dist(x, y, z, lx, ly, lz, vx, vy, vz, rmin):  # type: ignore[no-untyped-def]
    """Distance D (clamped to rmin) and its time derivative."""
    dx, dy, dz = lx - x, ly - y, lz - z
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    if d <= rmin:
        return rmin, 0.0
    return d, (dx * vx + dy * vy + dz * vz) / d


@numba.njit(inline="always", **_NJIT)
def _qeval(tn, q, mt, k, n, tau, cubic):  # type: ignore[no-untyped-def]
    """Strength q and dq/dτ of source k on piece n (between knots n and n+1) at time τ."""
    h = tn[n + 1] - tn[n]
    s = (tau - tn[n]) / h
    if s < 0.0:
        s = 0.0
    if s > 1.0:
        s = 1.0
    q0, q1 = q[n, k], q[n + 1, k]
    if not cubic:
        return q0 + (q1 - q0) * s, (q1 - q0) / h
    m0, m1 = mt[n, k] * h, mt[n + 1, k] * h
    s2 = s * s
    s3 = s2 * s
    val = (
        (2 * s3 - 3 * s2 + 1) * q0
        + (s3 - 2 * s2 + s) * m0
        + (-2 * s3 + 3 * s2) * q1
        + (s3 - s2) * m1
    )
    der = ((6 * s2 - 6 * s) * q0 + (3 * s2 - 4 * s + 1) * m0 + (-6 * s2 + 6 * s) * q1
           + (3 * s2 - 2 * s) * m1) / h  # fmt: skip
    return val, der


@numba.njit(inline="always", **_NJIT)
def _gains(ax, ay, az, fx, fy, fz, ux, uy, uz, spk_az, spk_ch, fold, pinv, out):  # type: ignore[no-untyped-def]
    """Pairwise 2-D VBAP gains (power-normalised) for direction a in the listener frame.

    forward f, up u, left = u × f; azimuth counter-clockwise from forward.
    ``fold`` mirrors rear directions to the front (2-speaker layouts).
    """
    n = spk_az.size
    for c in range(out.size):
        out[c] = 0.0
    if n == 0:
        out[0] = 1.0
        return
    lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
    xf = ax * fx + ay * fy + az * fz
    yl = ax * lx + ay * ly + az * lz
    if fold and xf < 0.0:
        xf = -xf
    if xf == 0.0 and yl == 0.0:
        # source straight above/below: spread evenly
        for i in range(n):
            out[spk_ch[i]] = 1.0 / math.sqrt(n)
        return
    # fast path (every arc < 180°): the pair whose inverse base gives both
    # gains >= 0 -- the same law as below without atan2 and sines
    npair = pinv.shape[0]
    for i in range(npair):
        g0 = pinv[i, 0] * xf + pinv[i, 1] * yl
        g1 = pinv[i, 2] * xf + pinv[i, 3] * yl
        if g0 >= -1e-12 and g1 >= -1e-12:
            g0 = max(g0, 0.0)
            g1 = max(g1, 0.0)
            norm = math.sqrt(g0 * g0 + g1 * g1)
            out[spk_ch[i]] += g0 / norm
            out[spk_ch[(i + 1) % n]] += g1 / norm
            return
    phi = math.atan2(yl, xf)
    two_pi = 2.0 * math.pi
    # find arc [spk_az[i], spk_az[i+1]) (cyclic) containing phi
    i0 = n - 1
    for i in range(n):
        if spk_az[i] <= phi:
            i0 = i
    i1 = (i0 + 1) % n
    a0 = spk_az[i0]
    a1 = spk_az[i1]
    if n == 1:
        out[spk_ch[0]] = 1.0
        return
    # relative angles on the arc
    span = (a1 - a0) % two_pi
    if span == 0.0:
        span = two_pi
    rel = (phi - a0) % two_pi
    if span > math.pi:
        # an arc wider than 180° cannot be panned (negative gains): the source
        # goes to the nearer end speaker
        rel = 0.0 if rel < 0.5 * span else span
    if rel > span:
        rel = span
    # 2x2 VBAP: p = g0 l0 + g1 l1 with l at angles 0 and span
    s = math.sin(span)
    if abs(s) < 1e-12:
        g0 = math.cos(rel * math.pi / (2 * span))
        g1 = math.sin(rel * math.pi / (2 * span))
    else:
        g0 = math.sin(span - rel) / s
        g1 = math.sin(rel) / s
        if g0 < 0.0:
            g0 = 0.0
        if g1 < 0.0:
            g1 = 0.0
    norm = math.sqrt(g0 * g0 + g1 * g1)
    if norm > 0.0:
        out[spk_ch[i0]] += g0 / norm
        out[spk_ch[i1]] += g1 / norm


@numba.njit(inline="always", **_NJIT)
def _orient(otab, ot, t, out):  # type: ignore[no-untyped-def]
    """Listener forward and up at data time t from the orientation table.

    ``otab (N, 6)`` holds forward and up sampled (by quaternion slerp between
    captures, see :mod:`auralize.listener`) every ``1/ot[1]`` s from ``ot[0]``;
    linear interpolation between ~1 ms samples is accurate to ~1e-7.
    """
    n = otab.shape[0]
    u = (t - ot[0]) * ot[1]
    if n == 1 or u <= 0.0:
        for c in range(6):
            out[c] = otab[0, c]
        return
    if u >= n - 1:
        for c in range(6):
            out[c] = otab[n - 1, c]
        return
    i = int(u)
    w = u - i
    for c in range(6):
        out[c] = otab[i, c] + w * (otab[i + 1, c] - otab[i, c])


@numba.njit(inline="always", **_NJIT)
def _fval(qv, dq, d, dd, c0):  # type: ignore[no-untyped-def]
    """f = q(τ)/D and df/dt with τ = t - D/c0 (per data second)."""
    inv = 1.0 / d
    return qv * inv, (dq * (1.0 - dd / c0) - qv * dd * inv) * inv


@numba.njit(inline="always", **_NJIT)
def _pan(x, y, z, t, s, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, g, o):  # type: ignore[no-untyped-def]
    """Panning gains g of a source at (x, y, z) heard at time t (listener segment s)."""
    lx, ly, lz, _, _, _ = _listener(tc, lc, vc, t, s)
    _orient(qc, ot, t, o)
    _gains(x - lx, y - ly, z - lz, o[0], o[1], o[2], o[3], o[4], o[5], spk_az, spk_ch, fold,
           pinv, g)  # fmt: skip


@numba.njit(inline="always", **_NJIT)
def _hermite(L, f0, d0, f1, d1):  # type: ignore[no-untyped-def]
    """Power-basis coefficients (in x = t - start, sample units) of the cubic
    Hermite with values f0, f1 and slopes d0, d1 over [0, L]."""
    inv = 1.0 / L
    dlt = (f1 - f0) * inv
    c2 = (3.0 * dlt - 2.0 * d0 - d1) * inv
    c3 = (d0 + d1 - 2.0 * dlt) * inv * inv
    return f0, d0, c2, c3


@numba.njit(inline="always", **_NJIT)
def _emit(acc, th, ch, blk, B, m_start, x, c0, c1, c2, c3, sign):  # type: ignore[no-untyped-def]
    """Add sign × P(m - m_start + x) for m >= m_start, P = c0 + c1 x + c2 x² + c3 x³.

    The polynomial is Taylor-shifted to x and written in the binomial basis
    C(m - m_start, i), whose (i+1)-fold cumulative sum is an impulse at
    m_start + i: four impulses, into acc[blk, local index + level, level] (the
    four levels of one impulse share cache lines).  The accumulator is indexed
    in full (thread th, channel ch) rather than through views: a view made in
    the hot loop costs two atomic reference-count updates on memory shared by
    the threads.
    """
    b0 = c0 + x * (c1 + x * (c2 + x * c3))
    b1 = c1 + x * (2.0 * c2 + 3.0 * c3 * x)
    b2 = c2 + 3.0 * c3 * x
    loc = m_start - blk * B
    acc[th, ch, blk, loc, 0] += sign * b0
    acc[th, ch, blk, loc + 1, 1] += sign * (b1 + b2 + c3)
    acc[th, ch, blk, loc + 2, 2] += sign * (2.0 * b2 + 6.0 * c3)
    acc[th, ch, blk, loc + 3, 3] += sign * 6.0 * c3


@numba.njit(parallel=True, **_NJIT)
def _arrivals(pos, radius, tn, act, tc, lc, vc, c0, n_lo, n_hi, arr, darr, ddarr, n_chunks):  # type: ignore[no-untyped-def]
    """Reception time, distance and its rate at every knot n_lo..n_hi that bounds a
    sounding piece (NaN elsewhere).

    On a capture interval the listener moves linearly, L(t) = L_s + V (t - t_s),
    so c0 (a - t_n) = |L(a) - x| is a quadratic in u = a - t_n with one
    positive root: exact, no iteration.  The interval is found from the
    previous knot's (arrivals increase with n).
    """
    K = pos.shape[0]
    m = tc.size
    c2 = c0 * c0
    chunk = (K + n_chunks - 1) // n_chunks
    segs = np.full(K, -1, dtype=np.int64)
    # step-major inside each thread's block of sources: reads of the
    # (steps, sources) arrays stay contiguous
    for th in numba.prange(n_chunks):
        for n in range(n_lo, n_hi + 1):
            for k in range(th * chunk, min(K, (th + 1) * chunk)):
                # a knot is needed when a sounding piece starts or ends at it
                need = (n < n_hi and act[n, k] != 0) or (n > n_lo and act[n - 1, k] != 0)
                if not need:
                    arr[n, k] = np.nan
                    continue
                x, y, z, rmin = pos[k, 0], pos[k, 1], pos[k, 2], radius[k]
                seg = segs[k]
                t_n = tn[n]
                # the arrival is at or after t_n: start from the interval holding t_n
                s = _segment(tc, t_n, seg if seg >= 0 else 0)
                if seg > s:
                    s = seg
                a = t_n
                d = 0.0
                dd = 0.0
                while True:
                    if s < 0:
                        lx, ly, lz = lc[0, 0], lc[0, 1], lc[0, 2]
                        vx = vy = vz = 0.0
                        ts = t_n
                    elif s >= m - 1:
                        lx, ly, lz = lc[m - 1, 0], lc[m - 1, 1], lc[m - 1, 2]
                        vx = vy = vz = 0.0
                        ts = t_n
                    else:
                        lx, ly, lz = lc[s, 0], lc[s, 1], lc[s, 2]
                        vx, vy, vz = vc[s, 0], vc[s, 1], vc[s, 2]
                        ts = tc[s]
                    # P = L(t_n) - x on this interval's line
                    px = lx + vx * (t_n - ts) - x
                    py = ly + vy * (t_n - ts) - y
                    pz = lz + vz * (t_n - ts) - z
                    pv = px * vx + py * vy + pz * vz
                    pp = px * px + py * py + pz * pz
                    den = c2 - (vx * vx + vy * vy + vz * vz)
                    u = (pv + math.sqrt(pv * pv + den * pp)) / den
                    a = t_n + u
                    # move to the next interval if the root lies beyond this one
                    if s < m - 1 and s + 1 < m and a >= tc[s + 1] and s + 1 <= m - 1:
                        s += 1
                        continue
                    if s >= 0 and a < tc[s] and s > -1:
                        # cannot happen for a listener slower than sound; guard anyway
                        break
                    dx, dy, dz = px + vx * u, py + vy * u, pz + vz * u
                    d = math.sqrt(dx * dx + dy * dy + dz * dz)
                    if d <= rmin:
                        d = rmin
                        dd = 0.0
                        a = t_n + rmin / c0
                    else:
                        dd = (dx * vx + dy * vy + dz * vz) / d
                    break
                segs[k] = s
                arr[n, k] = a
                darr[n, k] = d
                ddarr[n, k] = dd


@numba.njit(parallel=True, **_NJIT)
def render(pos, radius, tn, q, mt, act, tc, lc, vc, qc, ot, c0, t_start, fs, n_samples, block,
           spk_az, spk_ch, pinv, n_ch, fold, n_threads, n_lo, n_hi, arr, darr, ddarr, accs):  # fmt: skip  # type: ignore[no-untyped-def]
    """Sum every source's pieces into ``(n_ch, n_samples)``; see module docstring.

    Parameters (all times in data seconds)
    ----------
    pos (K,3), radius (K,) clamp distances; tn (Tp,) knot times (padded with
    silent knots); q (Tp,K) strength·ΔV/(4π); mt (Tp,K) tangents dq/dτ
    (size-0 first axis for linear interpolation) — step-major, so that the
    step-major loops below read them contiguously; act (Tp,K) uint8, 1 where
    piece n of source k sounds (a compact mask: silent pieces cost one byte); tc (M,), lc (M,3), vc (M-1,3),
    listener captures; qc (N,6) forward/up table sampled from ot[0] at rate
    ot[1] (see :func:`_orient`); fs samples per data second; block samples per
    accumulation block; spk_az/spk_ch speaker azimuths (sorted) and channels;
    pinv (n_pairs, 4) inverse bases of adjacent speaker pairs (empty when an arc
    spans 180° or more, e.g. stereo);
    only pieces n_lo..n_hi-1 (those that can be heard in the output) are summed.
    arr, darr, ddarr (Tp, K) and accs (n_threads, n_ch, n_blocks, block + 4, 4)
    are work arrays supplied by the caller: fresh memory costs a page fault per
    4 KiB on first touch, which dominated short renders.

    Pieces are visited step-major (all sources' piece n, then n+1, ...) so the
    accumulator writes stay within the few thousand samples a step's arrivals
    span.  At a piece's ends (knot arrivals) τ is a knot time, so q, dq/dτ, D
    and dD/dt are known from the arrival solve: no further evaluation.
    """
    K = pos.shape[0]
    n_blocks = (n_samples + block - 1) // block
    cubic = mt.shape[0] > 0
    _arrivals(pos, radius, tn, act, tc, lc, vc, c0, n_lo, n_hi, arr, darr, ddarr, n_threads)
    accs[:] = 0.0
    t_end = t_start + n_samples / fs
    chunk = (K + n_threads - 1) // n_threads
    panned = spk_az.size > 0
    for th in numba.prange(n_threads):
        ga = np.zeros(n_ch)
        gb = np.zeros(n_ch)
        o = np.zeros(6)
        fa = np.zeros(n_ch)
        da = np.zeros(n_ch)
        fb = np.zeros(n_ch)
        db = np.zeros(n_ch)
        k_lo = th * chunk
        k_hi = min(K, (th + 1) * chunk)
        for n in range(n_lo, n_hi):
            h = tn[n + 1] - tn[n]
            for k in range(k_lo, k_hi):
                if act[n, k] == 0:
                    continue
                q0 = q[n, k]
                q1 = q[n + 1, k]
                if cubic:
                    m0 = mt[n, k]
                    m1 = mt[n + 1, k]
                else:
                    m0 = (q1 - q0) / h
                    m1 = m0
                if q0 == 0.0 and q1 == 0.0 and m0 == 0.0 and m1 == 0.0:
                    continue
                ta, tb = arr[n, k], arr[n + 1, k]
                if tb <= t_start or ta >= t_end or tb <= ta:
                    continue
                x, y, z, rmin = pos[k, 0], pos[k, 1], pos[k, 2], radius[k]
                # split [ta, tb] at listener captures and block boundaries
                t0 = ta
                seg = _segment(tc, t0, 0)
                # value at the piece start: the knot itself
                va, wa = _fval(q0, m0, darr[n, k], ddarr[n, k], c0)
                have_ga = False
                u0 = (t0 - t_start) * fs
                while t0 < tb:
                    t1 = tb
                    if seg + 1 < tc.size and tc[seg + 1] < t1 and tc[seg + 1] > t0:
                        t1 = tc[seg + 1]
                    bidx = int(math.floor(u0 / block)) if u0 >= 0 else 0
                    tbnd = t_start + (bidx + 1) * block / fs
                    at_block_end = tbnd < t1 and tbnd > t0
                    if at_block_end:
                        t1 = tbnd
                    segm = _segment(tc, 0.5 * (t0 + t1), seg)
                    if t1 == tb:
                        vb, wb = _fval(q1, m1, darr[n + 1, k], ddarr[n + 1, k], c0)
                    else:
                        lx, ly, lz, vx, vy, vz = _listener(tc, lc, vc, t1, segm)
                        d1, dd1 = _dist(x, y, z, lx, ly, lz, vx, vy, vz, rmin)
                        qv, dq = _qeval(tn, q, mt, k, n, t1 - d1 / c0, cubic)
                        vb, wb = _fval(qv, dq, d1, dd1, c0)
                    # a block boundary is exact in samples, so that the next
                    # sub-piece starts at the very sample this one stops before
                    u1 = (bidx + 1) * block if at_block_end else (t1 - t_start) * fs
                    m_0 = max(int(math.ceil(u0)), 0)
                    m_1 = min(int(math.ceil(u1)), n_samples)
                    if m_1 > m_0:
                        L = u1 - u0
                        blk = m_0 // block
                        end_inside = m_1 < n_samples and m_1 < (blk + 1) * block
                        if panned:
                            # gains vary slowly: linear between the sub-piece's ends
                            if not have_ga:
                                _pan(
                                    x,
                                    y,
                                    z,
                                    t0,
                                    segm,
                                    tc,
                                    lc,
                                    vc,
                                    qc,
                                    ot,
                                    spk_az,
                                    spk_ch,
                                    fold,
                                    pinv,
                                    ga,
                                    o,
                                )
                            _pan(
                                x,
                                y,
                                z,
                                t1,
                                segm,
                                tc,
                                lc,
                                vc,
                                qc,
                                ot,
                                spk_az,
                                spk_ch,
                                fold,
                                pinv,
                                gb,
                                o,
                            )
                            inv_dt = 1.0 / (t1 - t0)
                            for c in range(n_ch):
                                slope = (gb[c] - ga[c]) * inv_dt
                                fa[c] = ga[c] * va
                                da[c] = (ga[c] * wa + slope * va) / fs
                                fb[c] = gb[c] * vb
                                db[c] = (gb[c] * wb + slope * vb) / fs
                                ga[c] = gb[c]
                            have_ga = True
                        else:
                            fa[0] = va
                            da[0] = wa / fs
                            fb[0] = vb
                            db[0] = wb / fs
                        for c in range(n_ch):
                            if fa[c] == 0.0 and da[c] == 0.0 and fb[c] == 0.0 and db[c] == 0.0:
                                continue
                            p0, p1, p2, p3 = _hermite(L, fa[c], da[c], fb[c], db[c])
                            _emit(accs, th, c, blk, block, m_0, m_0 - u0, p0, p1, p2, p3, 1.0)
                            if end_inside:
                                _emit(accs, th, c, blk, block, m_1, m_1 - u0, p0, p1, p2, p3, -1.0)
                    else:
                        have_ga = False  # no sample here: gains at t1 were not computed
                    new_seg = _segment(tc, t1, seg)
                    if new_seg != segm and t1 < tb:
                        # split at a listener capture: the velocity changes, so the
                        # derivative on the right differs from the left one
                        lx, ly, lz, vx, vy, vz = _listener(tc, lc, vc, t1, new_seg)
                        d1, dd1 = _dist(x, y, z, lx, ly, lz, vx, vy, vz, rmin)
                        qv, dq = _qeval(tn, q, mt, k, n, t1 - d1 / c0, cubic)
                        vb, wb = _fval(qv, dq, d1, dd1, c0)
                    t0 = t1
                    u0 = u1
                    va, wa = vb, wb
                    seg = new_seg
    out = np.zeros((n_ch, n_blocks * block))
    for c in range(n_ch):
        for b in range(n_blocks):
            a3 = 0.0
            a2 = 0.0
            a1 = 0.0
            a0 = 0.0
            for i in range(block):
                s3 = 0.0
                s2 = 0.0
                s1 = 0.0
                s0 = 0.0
                for th in range(n_threads):
                    s3 += accs[th, c, b, i, 3]
                    s2 += accs[th, c, b, i, 2]
                    s1 += accs[th, c, b, i, 1]
                    s0 += accs[th, c, b, i, 0]
                a3 += s3
                a2 += s2 + a3
                a1 += s1 + a2
                a0 += s0 + a1
                out[c, b * block + i] = a0
    return out[:, :n_samples]
