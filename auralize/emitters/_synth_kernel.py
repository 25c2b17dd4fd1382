"""Compiled core of the retarded-time synthesis (see :mod:`auralize.emitters.synthesis`).

Why numba: the work is a few hundred floating-point operations per (source,
step) piece with data-dependent control (pieces across listener captures or
accumulation blocks, panning pairs) that numpy cannot express without
materialising sources × samples arrays; numba compiles the loops to SIMD code.

The signal of one source between the arrivals of two consecutive knots
(data steps) is a smooth function f(t) = q(τ(t)) / D(t) with τ(t) = t - D(t)/c0
(paper 003 Eqs. 15-17).  It is represented on each piece by the cubic Hermite
interpolant of f and f' at the piece's ends, which is exact for a static
listener (q is a cubic in τ, τ is linear in t) and accurate to O(h⁴) otherwise.
The cubic is written in the binomial basis C(m - m0, i) at its first sample
m0; C(m - m0, i)·H(m - m0) is the (i+1)-fold cumulative sum of an impulse at
m0 + i, so a piece costs 4 impulses at its start and 4 (of the polynomial
continued, subtracted) at its end, whatever its length.  Four cumulative sums
per accumulation block then give the summed signal.  Cost:
O(sounding pieces + samples), not O(sources × samples).

Layout of the work:

* the sounding pieces are listed once per tracks (cached), sorted by data
  step, in chunks of :data:`_CHUNK` whose inputs (position, clamp radius, q
  and dq/dτ at both knots) are contiguous;
* per chunk, branch-free loops that LLVM vectorizes solve both knots'
  arrivals in closed form on the listener's candidate lines of that step
  (:func:`_row_lines`), the values and slopes of f, the Hermite cubic and its
  accumulator values at its start, end and (across an accumulation block)
  continuation; for ring layouts also the speaker-pair gains
  (:func:`_chunk_pair_gains`); all in one 1-D work array whose rows lie at
  constant distances, so the compiler needs no aliasing checks;
* a scalar loop adds the values to the accumulator; pieces across listener
  captures (the velocity, hence df/dt, jumps there) are split exactly
  (:func:`_piece_across`), arrivals beyond the candidate lines are solved in
  full (:func:`_piece_general`); the emissions at a capture of all the
  pieces split there fall on one sample with one offset, so they are summed
  in a small per-task table (a row per capture, in cache) and added to the
  accumulator once (:func:`_flush_captures`);
* a step whose arrivals may cross listener captures (a path recorded at
  10-20 Hz: most of them) is split there into parts, one per capture
  interval, each on the listener's line of its interval, and the parts are
  summed like pieces, in SIMD loops (:func:`_chunk_parts`); the scalar
  split above remains for steps that cross very many captures;
* the accumulator is skewed (level j of an impulse at m + j is stored in row
  m, so an emission touches one 32-byte row) with the channels of a sample
  side by side; threads take contiguous ranges of pieces and accumulate into
  their own stretch of the output only.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

from auralize.runtime.jit import configure as _configure_numba

_configure_numba()  # cache folder, OMP wait policy, compile notice

_NJIT = {"cache": True, "nogil": True, "error_model": "numpy"}
#: kernels that allocate nothing: compiled without reference counting (numba's
#: runtime increments and decrements an array's count, with atomic
#: instructions, wherever its code copies the array's handle: in every
#: iteration of the scatter loops, where the helpers taking arrays are
#: inlined); the arrays they get belong to their caller for the whole call
_NJIT_NORC = {**_NJIT, "_nrt": False}


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
def _qeval(t_a, h, q0, m0, q1, m1, tau, cubic):  # type: ignore[no-untyped-def]
    """Strength q and dq/dτ at time τ on a piece from knot time t_a to t_a + h
    with values q0, q1 and tangents m0, m1 (per second) at its knots."""
    s = (tau - t_a) / h
    if s < 0.0:
        s = 0.0
    if s > 1.0:
        s = 1.0
    if not cubic:
        return q0 + (q1 - q0) * s, (q1 - q0) / h
    m0 = m0 * h
    m1 = m1 * h
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
    """Panning gains (power-normalised) for direction a in the listener frame:
    pairwise 2-D VBAP, or 3-D VBAP when ``pinv`` is a triangle table (12
    columns, see :func:`_gains3`), or the AmbiX encoding gains when ``pinv``
    is a spherical-harmonic table (2 columns, see :func:`_gains_sh`).

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
    if pinv.shape[1] == 12:
        _gains3(xf, yl, ax * ux + ay * uy + az * uz, pinv, out)
        return
    if pinv.shape[1] == 2:
        _gains_sh(xf, yl, ax * ux + ay * uy + az * uz, pinv, out)
        return
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
def _gains3(x, y, z, tab, out):  # type: ignore[no-untyped-def]
    """3-D VBAP (the law of :func:`auralize.spatial.layouts.vbap3d_gains`) for direction
    (x, y, z) = (forward, left, up) in the listener frame; ``out`` zeroed.

    ``tab`` rows: a hull triangle — the inverse of the matrix of its speaker
    directions (9, row-major) and its three channels (-1: imaginary speaker);
    then one row per imaginary speaker: its direction (3), the bit mask of
    its real neighbours on the hull, and -2 in the channel columns.  The
    triangle whose gains have the largest minimum is used, negative gains
    clipped, imaginary speakers' gains dropped, Σ g² = 1; a direction exactly
    at an imaginary speaker is spread over its neighbours.
    """
    best = -1
    best_min = -np.inf
    for t in range(tab.shape[0]):
        if tab[t, 9] == -2.0:
            continue
        g0 = x * tab[t, 0] + y * tab[t, 3] + z * tab[t, 6]
        g1 = x * tab[t, 1] + y * tab[t, 4] + z * tab[t, 7]
        g2 = x * tab[t, 2] + y * tab[t, 5] + z * tab[t, 8]
        mn = min(g0, min(g1, g2))
        if mn > best_min:
            best_min = mn
            best = t
    power = 0.0
    if best >= 0:
        for v in range(3):
            ch = int(tab[best, 9 + v])
            g = x * tab[best, v] + y * tab[best, 3 + v] + z * tab[best, 6 + v]
            if ch >= 0 and g > 0.0:
                out[ch] += g
    for c in range(out.size):
        power += out[c] * out[c]
    if power < 1e-24:
        # at an imaginary speaker: its real neighbours share the sound
        bi = -1
        bd = -np.inf
        for t in range(tab.shape[0]):
            if tab[t, 9] == -2.0:
                dot = x * tab[t, 0] + y * tab[t, 1] + z * tab[t, 2]
                if dot > bd:
                    bd = dot
                    bi = t
        if bi >= 0:
            mask = int(tab[bi, 3])
            for c in range(out.size):
                if (mask >> c) & 1:
                    out[c] = 1.0
        power = 0.0
        for c in range(out.size):
            power += out[c] * out[c]
    if power > 0.0:
        inv = 1.0 / math.sqrt(power)
        for c in range(out.size):
            out[c] *= inv


@numba.njit(inline="always", **_NJIT)
def _gains_sh(x, y, z, tab, out):  # type: ignore[no-untyped-def]
    """AmbiX encoding gains (the law of :func:`auralize.spatial.ambisonics.sh_gains`:
    real SN3D spherical harmonics in ACN order, no Condon–Shortley phase) for
    direction (x, y, z) = (forward, left, up) in the listener frame, any
    length (normalised here; zero gives W = 1 and 0 elsewhere).

    ``tab ((N+1)², 2)``: per ACN channel its SN3D factor
    sqrt((2 − δ_m0)(n − |m|)!/(n + |m|)!), then the output channel that takes
    it (−1: not rendered; a layout may keep a subset of the harmonics, see
    :func:`auralize.spatial.ambix_layout`).  The order N follows from the rows.
    Cartesian form, no trigonometry: cos^m ϑ e^{imφ} = (x + iy)^m by complex
    multiplication, times P_n^m(z)/(1 − z²)^{m/2} by the associated Legendre
    recurrence in n from (2m − 1)!!.
    """
    for c in range(out.size):
        out[c] = 0.0
    r2 = x * x + y * y + z * z
    if r2 == 0.0:
        d = int(tab[0, 1])
        if d >= 0:
            out[d] = 1.0
        return
    inv = 1.0 / math.sqrt(r2)
    x *= inv
    y *= inv
    z *= inv
    order = int(math.sqrt(tab.shape[0]) + 0.5) - 1
    cm = 1.0  # Re (x + iy)^m
    sm = 0.0  # Im (x + iy)^m
    pmm = 1.0  # (2m - 1)!!
    for m in range(order + 1):
        if m > 0:
            cm, sm = cm * x - sm * y, sm * x + cm * y
            pmm *= 2 * m - 1
        q_prev = 0.0
        q = pmm
        for n in range(m, order + 1):
            if n == m + 1:
                q_prev, q = q, z * (2 * m + 1) * q
            elif n > m + 1:
                q_prev, q = q, ((2 * n - 1) * z * q - (n + m - 1) * q_prev) / (n - m)
            k = n * n + n + m
            d = int(tab[k, 1])
            if d >= 0:
                out[d] = tab[k, 0] * q * cm
            if m > 0:
                k = n * n + n - m
                d = int(tab[k, 1])
                if d >= 0:
                    out[d] = tab[k, 0] * q * sm


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


@numba.njit(**_NJIT_NORC)
def _pan_far(x, y, z, t, s, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, g, o):  # type: ignore[no-untyped-def]
    """:func:`_pan` compiled once and called, for the paths a render takes
    rarely (a piece over several accumulation blocks, the general fallback,
    the run kernel's panned pieces): inlining every copy of the listener,
    orientation and gain laws costs a minute of compile time.  The hot loops
    inline :func:`_pan` (a call, with its ten array arguments, made stereo
    along a 10 Hz recorded path 75 % slower)."""
    _pan(x, y, z, t, s, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, g, o)


@numba.njit(inline="always", **_NJIT)
def _emit1(acc, i, x, c0, c1, c2, c3, sign):  # type: ignore[no-untyped-def]
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
def _emit_piece(acc, base, blo, nb, ch, n_ch, shift, n_samples, u0, u1, p0, p1, p2, p3, ct, r0,
                r1):  # fmt: skip  # type: ignore[no-untyped-def]
    """Add the cubic P(u - u0) on samples ceil(u0) <= m < ceil(u1) (clipped to the
    output) into a task's accumulator window (blocks blo..blo+nb-1, channel ch,
    starting at ``base``).

    The running sums restart at every accumulation block (numerical safety), so
    a piece that crosses a block boundary is continued there: the same
    polynomial is emitted again at the block's first sample.  The signal thus
    does not depend on where the block boundaries fall.

    u0 (u1) at a listener capture whose row r0 (r1) of the capture table ``ct``
    is >= 0: the start (end) emission goes to that row instead (every
    source's emission at a capture falls on the same sample with the same
    offset, so they are summed there, in a table that stays in cache, and
    added to the accumulator once: :func:`_flush_captures`).

    Returns the number of emissions that fell outside the window (0 unless
    the caller's window is wrong).
    """
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
            _emit1(ct, (r0 * n_ch + ch) * 4, ms - u0, p0, p1, p2, p3, 1.0)
        else:
            _emit1(acc, row0 + (ms - b * block) * n_ch * 4, ms - u0, p0, p1, p2, p3, 1.0)
        if m_1 <= bend:
            if m_1 < n_samples and m_1 < bend:
                if r1 >= 0:
                    _emit1(ct, (r1 * n_ch + ch) * 4, m_1 - u0, p0, p1, p2, p3, -1.0)
                else:
                    _emit1(acc, row0 + (m_1 - b * block) * n_ch * 4, m_1 - u0, p0, p1, p2, p3,
                           -1.0)  # fmt: skip
            return 0
        b += 1
        ms = bend


@numba.njit(**_NJIT_NORC)
def _flush_captures(acc, ct, k_ct, tc, t_start, fs, n_samples, shift, blo, nb, base, n_ch,
                    m_first):  # fmt: skip  # type: ignore[no-untyped-def]
    """Add a task's capture table (see :func:`_emit_piece`: row r holds the
    summed emissions at capture k_ct + r, channels side by side) into its
    accumulator window; returns the number of non-zero rows outside it."""
    block = 1 << shift
    rs = n_ch * 4
    bad = 0
    for r in range(ct.size // rs):
        m = int(math.ceil((tc[k_ct + r] - t_start) * fs))
        j = (m >> shift) - blo if m >= 0 else -1
        ok = 0 <= m < n_samples and 0 <= j < nb and m >= m_first
        dst = base + (j * block + (m - (m >> shift) * block)) * rs
        for i in range(rs):
            v = ct[r * rs + i]
            if v != 0.0:
                if ok:
                    acc[dst + i] += v
                else:
                    bad += 1
    return bad


@numba.njit(inline="always", **_NJIT)
def _heard_at(x, y, z, rmin, tc, lc, c0, k):  # type: ignore[no-untyped-def]
    """Emission time of the sound from (x, y, z) that reaches capture k."""
    dx, dy, dz = lc[k, 0] - x, lc[k, 1] - y, lc[k, 2] - z
    return tc[k] - max(math.sqrt(dx * dx + dy * dy + dz * dz), rmin) / c0


@numba.njit(inline="always", **_NJIT)
def _arrival(x, y, z, rmin, t_n, hint, tc, lc, vc, c0):  # type: ignore[no-untyped-def]
    """Reception time a of the emission at t_n from (x, y, z), with the distance
    D(a), dD/dt(a) and the capture interval s holding a.

    On a capture interval the listener moves linearly, L(t) = L_s + V (t - t_s),
    so c0 (a - t_n) = |L(a) - x| is a quadratic in u = a - t_n with one
    positive root: exact, no iteration.  ``hint`` is the interval of an
    earlier knot's arrival of the same source (arrivals increase with n), or
    of t_n, or -1.  The interval holding a is found first by a galloping
    search over the captures (O(log) of the captures passed, not one root
    per interval): the sound emitted at t_n reaches the listener after
    capture k iff the emission heard at k, τ_k = t_k - max(|L_k - x|, rmin)/c0,
    is not later than t_n (τ_k increases with k: the listener is slower than
    sound).
    """
    m = tc.size
    c2 = c0 * c0
    s = _segment(tc, t_n, hint if hint >= 0 else 0)
    if hint > s:
        s = hint
    if s < m - 1 and _heard_at(x, y, z, rmin, tc, lc, c0, s + 1) <= t_n:
        # the arrival is past capture s + 1: gallop, then bisect, for the
        # last capture k with τ_k <= t_n (the arrival's interval is k)
        lo = s + 1
        step = 1
        hi = lo + step
        while hi <= m - 1 and _heard_at(x, y, z, rmin, tc, lc, c0, hi) <= t_n:
            lo = hi
            step *= 2
            hi = lo + step
        if hi > m - 1:
            hi = m
            if _heard_at(x, y, z, rmin, tc, lc, c0, m - 1) <= t_n:
                lo = m - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if _heard_at(x, y, z, rmin, tc, lc, c0, mid) <= t_n:
                lo = mid
            else:
                hi = mid
        s = lo
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
        if s < m - 1 and a >= tc[s + 1]:
            s += 1
            continue
        dx, dy, dz = px + vx * u, py + vy * u, pz + vz * u
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if d <= rmin:
            d = rmin
            dd = 0.0
            a = t_n + rmin / c0
            s = _segment(tc, a, s)
        else:
            dd = (dx * vx + dy * vy + dz * vz) / d
        return a, d, dd, s


@numba.njit(inline="always", **_NJIT)
def _emit_gained(acc, base, blo, nb, n_ch, shift, n_samples, u0, u1, va, wa, vb, wb, ga, gb,
                 fs, panned, ct, r0, r1):  # type: ignore[no-untyped-def]  # fmt: skip
    """Emit f·g on [u0, u1] for every channel: f Hermite from (va, wa), (vb, wb)
    (per data second), gains linear from ga to gb (mono: gain 1); r0, r1 the
    capture table rows of u0, u1 or -1 (see :func:`_emit_piece`)."""
    L = u1 - u0
    if L <= 0.0:
        return 0
    bad = 0
    inv_L = 1.0 / L
    inv_fs = 1.0 / fs
    if not panned:
        p0, p1, p2, p3 = _hermite_inv(inv_L, va, wa * inv_fs, vb, wb * inv_fs)
        return _emit_piece(acc, base, blo, nb, 0, 1, shift, n_samples, u0, u1, p0, p1, p2, p3, ct,
                           r0, r1)  # fmt: skip
    slope_t = fs * inv_L  # 1 / (t1 - t0)
    for c in range(n_ch):
        g0 = ga[c]
        g1 = gb[c]
        if g0 == 0.0 and g1 == 0.0:
            continue
        slope = (g1 - g0) * slope_t
        p0, p1, p2, p3 = _hermite_inv(inv_L, g0 * va, (g0 * wa + slope * va) * inv_fs, g1 * vb,
                                      (g1 * wb + slope * vb) * inv_fs)  # fmt: skip
        bad += _emit_piece(acc, base, blo, nb, c, n_ch, shift, n_samples, u0, u1, p0, p1, p2, p3, ct,
                           r0, r1)  # fmt: skip
    return bad


@numba.njit(inline="always", **_NJIT)
def _hermite_inv(inv, f0, d0, f1, d1):  # type: ignore[no-untyped-def]
    """Power-basis coefficients (in x = t - start, sample units) of the cubic
    Hermite with values f0, f1 and slopes d0, d1 over [0, L], given inv = 1/L."""
    dlt = (f1 - f0) * inv
    c2 = (3.0 * dlt - 2.0 * d0 - d1) * inv
    c3 = (d0 + d1 - 2.0 * dlt) * inv * inv
    return f0, d0, c2, c3


@numba.njit(inline="always", **_NJIT)
def _shifted(p0, p1, p2, p3, x):  # type: ignore[no-untyped-def]
    """The four accumulator values (see :func:`_emit1`) of P(m - m_start + x)."""
    b0 = p0 + x * (p1 + x * (p2 + x * p3))
    b1 = p1 + x * (2.0 * p2 + 3.0 * p3 * x)
    b2 = p2 + 3.0 * p3 * x
    s3 = 6.0 * p3
    return b0, b1 + b2 + p3, 2.0 * b2 + s3, s3


#: the chunk work array (one 1-D array, rows of _CHUNK: every access is at a
#: constant distance from every other, so the compiler vectorizes the loops
#: without aliasing checks): rows 0-7 the pieces' input (PD), 8-31 their
#: accumulator values, then kind, accumulator rows and arrivals
_CHUNK = 64
_W_VAL, _W_KIND, _W_SI, _W_EI, _W_CI, _W_A0, _W_A1, _W_S0, _W_S1 = 8, 32, 33, 34, 35, 36, 37, 38, 39
#: panning by speaker pairs: listener forward/up at both arrivals, the source's
#: direction in the listener's frame (forward, left) and pair index and gains
_W_O0, _W_O1, _W_XF0, _W_YL0, _W_XF1, _W_YL1 = 40, 46, 52, 53, 54, 55
_W_P0, _W_G00, _W_G01, _W_P1, _W_G10, _W_G11 = 56, 57, 58, 59, 60, 61
#: f and df/dt (per sample) at both arrivals
_W_F0, _W_WF0, _W_F1, _W_WF1 = 62, 63, 64, 65
_W_ROWS = 66


@numba.njit(inline="always", **_NJIT)
def _piece_values(W, r, i, L, inv_L, f0, w0, f1, w1, x0, x1, x2):  # type: ignore[no-untyped-def]
    """Rows r..r+11 of column i of W: the accumulator values of the cubic
    Hermite with values f0, f1 and slopes w0, w1 (per sample) over [0, L],
    added at its first sample (x0 = that sample - start), subtracted at its end
    (x1) and added again at the first sample of the next accumulation block
    (x2); inv_L = 1/L."""
    p0, p1, p2, p3 = _hermite_inv(inv_L, f0, w0, f1, w1)
    v0, v1, v2, v3 = _shifted(p0, p1, p2, p3, x0)
    W[r * _CHUNK + i] = v0
    W[(r + 1) * _CHUNK + i] = v1
    W[(r + 2) * _CHUNK + i] = v2
    W[(r + 3) * _CHUNK + i] = v3
    v0, v1, v2, v3 = _shifted(p0, p1, p2, p3, x1)
    W[(r + 4) * _CHUNK + i] = -v0
    W[(r + 5) * _CHUNK + i] = -v1
    W[(r + 6) * _CHUNK + i] = -v2
    W[(r + 7) * _CHUNK + i] = -v3
    v0, v1, v2, v3 = _shifted(p0, p1, p2, p3, x2)
    W[(r + 8) * _CHUNK + i] = v0
    W[(r + 9) * _CHUNK + i] = v1
    W[(r + 10) * _CHUNK + i] = v2
    W[(r + 11) * _CHUNK + i] = v3


@numba.njit(inline="always", **_NJIT)
def _line_arrival(x, y, z, rm, lx, ly, lz, vx, vy, vz, t_n, inv_den, den, c0, inv_c0):  # type: ignore[no-untyped-def]
    """Arrival a, distance D and D·dD/dt of the emission at knot time t_n from
    (x, y, z), the listener on the line L + V (t - t_n) (see :func:`_arrival`;
    den = c0² - V²); branch-free, no division (the caller divides by D)."""
    qx = lx - x
    qy = ly - y
    qz = lz - z
    pv = qx * vx + qy * vy + qz * vz
    pp = qx * qx + qy * qy + qz * qz
    vv = vx * vx + vy * vy + vz * vz
    u = (pv + math.sqrt(pv * pv + den * pp)) * inv_den
    d = c0 * u
    clamp = d <= rm
    ddd = 0.0 if clamp else pv + vv * u
    d = rm if clamp else d
    u = rm * inv_c0 if clamp else u
    return t_n + u, d, ddd


#: columns of one candidate line in a row of the line table (see _row_lines)
_LINE = 12


@numba.njit(**_NJIT_NORC)
def _row_lines(tn, tc, lc, vc, c0, d_max, n_lo, n_hi, RC):  # type: ignore[no-untyped-def]
    """Per knot row n, two candidate lines of the listener for the arrivals of
    the emissions at t_n: the capture interval s holding t_n and the next one.

    Per line (columns j·_LINE ...): the listener's position at t_n on the
    line, its velocity, t_n, the interval [t_lo, t_hi) where the line is the
    path, 1/(c0² - V²), c0² - V², and s (before the first capture and after
    the last the listener is held: V = 0).  An arrival solved on a line
    counts only if it falls in the line's interval.  Column 2·_LINE is 1 when
    an arrival can fall beyond the first line (t_n + D_max/c0 past its end),
    else 0 (the second line is then not solved).
    """
    m = tc.size
    s = 0
    for n in range(n_lo, n_hi + 1):
        t_n = tn[n]
        s = _segment(tc, t_n, max(s, 0))
        for j in range(2):
            sj = s + j
            o = j * _LINE
            if sj < 0:
                lx, ly, lz = lc[0, 0], lc[0, 1], lc[0, 2]
                vx = vy = vz = 0.0
                t_lo, t_hi = -np.inf, tc[0]
            elif sj >= m - 1:
                lx, ly, lz = lc[m - 1, 0], lc[m - 1, 1], lc[m - 1, 2]
                vx = vy = vz = 0.0
                t_lo, t_hi = tc[m - 1], np.inf
            else:
                dt = t_n - tc[sj]
                vx, vy, vz = vc[sj, 0], vc[sj, 1], vc[sj, 2]
                lx, ly, lz = lc[sj, 0] + vx * dt, lc[sj, 1] + vy * dt, lc[sj, 2] + vz * dt
                t_lo, t_hi = tc[sj], tc[sj + 1]
            if sj > m - 1:  # no such line
                t_lo = t_hi = np.inf
            den = c0 * c0 - (vx * vx + vy * vy + vz * vz)
            RC[n, o + 0] = lx
            RC[n, o + 1] = ly
            RC[n, o + 2] = lz
            RC[n, o + 3] = vx
            RC[n, o + 4] = vy
            RC[n, o + 5] = vz
            RC[n, o + 6] = t_n
            RC[n, o + 7] = t_lo
            RC[n, o + 8] = t_hi
            RC[n, o + 9] = 1.0 / den
            RC[n, o + 10] = den
            RC[n, o + 11] = sj
            if j == 0:
                RC[n, 2 * _LINE] = 1.0 if t_n + d_max / c0 >= t_hi else 0.0


@numba.njit(inline="always", **_NJIT)
def _knot_arrival(x, y, z, rm, la, lb, c0, inv_c0, two):  # type: ignore[no-untyped-def]
    """Arrival, D, D·dD/dt and capture interval of one knot, solved on both
    candidate lines la, lb (tuples of a _row_lines row; lb only if ``two``)
    and taken from the one whose interval holds it; ``found`` False when
    neither does (branch-free)."""
    a1, d1, e1 = _line_arrival(x, y, z, rm, la[0], la[1], la[2], la[3], la[4], la[5], la[6],
                               la[9], la[10], c0, inv_c0)  # fmt: skip
    ok1 = (a1 >= la[7]) & (a1 < la[8])
    if not two:
        return a1, d1, e1, la[11], ok1
    a2, d2, e2 = _line_arrival(x, y, z, rm, lb[0], lb[1], lb[2], lb[3], lb[4], lb[5], lb[6],
                               lb[9], lb[10], c0, inv_c0)  # fmt: skip
    ok2 = (a2 >= lb[7]) & (a2 < lb[8])
    a = a1 if ok1 else a2
    d = d1 if ok1 else d2
    e = e1 if ok1 else e2
    sg = la[11] if ok1 else lb[11]
    return a, d, e, sg, ok1 | ok2


@numba.njit(inline="always", **_NJIT)
def _cut_at_end(x, y, z, rm, q0, m0, q1, m1, sg0, ok0, la, lb, t_1, c0, inv_c0, t_start, fs, fn):  # type: ignore[no-untyped-def]
    """The end of a piece whose arrivals cross, after its start, a capture at
    or past the output's last sample: the piece is cut at that capture t_c
    (the listener's velocity changes there; nothing after it is heard in this
    output).  Returns ``cut`` and, at t_c: the arrival t_c, D, D·dD/dt on the
    start's line, and the strength q and dq/dτ at the emission time
    τ_c = t_c - D/c0 (cubic Hermite of the knots t_n = la[6], t_1; for linear
    pieces m0 = m1 = the slope, which the Hermite reproduces).  This is the
    first part of :func:`_piece_across`'s split, branch-free; sg0/ok0: the
    start's line and whether it holds the start's arrival."""
    sel = sg0 == la[11]
    lx = la[0] if sel else lb[0]
    ly = la[1] if sel else lb[1]
    lz = la[2] if sel else lb[2]
    vx = la[3] if sel else lb[3]
    vy = la[4] if sel else lb[4]
    vz = la[5] if sel else lb[5]
    th = la[8] if sel else lb[8]
    t_0 = la[6]
    fin = th < 1e300
    dt = th - t_0 if fin else 0.0
    px = lx + vx * dt - x
    py = ly + vy * dt - y
    pz = lz + vz * dt - z
    d = math.sqrt(px * px + py * py + pz * pz)
    clamp = d <= rm
    dd = 0.0 if clamp else px * vx + py * vy + pz * vz
    d = rm if clamp else d
    tau = th - d * inv_c0 if fin else t_0
    h = t_1 - t_0
    s = (tau - t_0) / h
    s = s if s > 0.0 else 0.0
    s = s if s < 1.0 else 1.0
    s2 = s * s
    s3 = s2 * s
    hm0 = m0 * h
    hm1 = m1 * h
    q = ((2.0 * s3 - 3.0 * s2 + 1.0) * q0 + (s3 - 2.0 * s2 + s) * hm0
         + (3.0 * s2 - 2.0 * s3) * q1 + (s3 - s2) * hm1)  # fmt: skip
    m = ((6.0 * s2 - 6.0 * s) * (q0 - q1) + (3.0 * s2 - 4.0 * s + 1.0) * hm0
         + (3.0 * s2 - 2.0 * s) * hm1) / h  # fmt: skip
    cut = ok0 & fin & ((th - t_start) * fs > fn - 1.0) & (tau < t_1)
    return cut, th, d, dd, q, m


@numba.njit(inline="always", **_NJIT)
def _take_cut(cut, ac, dc, ec, qc, mc, sgc, a, d, e, q, m, sg, ok):  # type: ignore[no-untyped-def]
    """The end of a piece: where :func:`_cut_at_end` cut it (``cut``), else its
    knot's arrival, D, D·dD/dt, q, dq/dτ, capture interval and found flag
    (branch-free)."""
    return (ac if cut else a, dc if cut else d, ec if cut else e, qc if cut else q,
            mc if cut else m, sgc if cut else sg, ok | cut)  # fmt: skip


@numba.njit(inline="always", **_NJIT)
def _piece_core(W, i, l0a, l0b, l1a, l1b, two, c0, inv_c0, t_start, fs, inv_fs, fn, fblock,
                inv_block, blo, nb, base, rs):  # fmt: skip  # type: ignore[no-untyped-def]
    """Arrivals, kind and accumulator rows of the piece in column i of W (see
    :func:`_chunk_pieces`; rs: accumulator values per sample row); returns the
    Hermite data (L, 1/L, f0, w0, f1, w1) and the offsets x0, x1, x2 of its
    emissions."""
    x = W[0 * _CHUNK + i]
    y = W[1 * _CHUNK + i]
    z = W[2 * _CHUNK + i]
    rm = W[3 * _CHUNK + i]
    q0 = W[4 * _CHUNK + i]
    m0 = W[5 * _CHUNK + i]
    q1 = W[6 * _CHUNK + i]
    m1 = W[7 * _CHUNK + i]
    a0, d0, dd0, sg0, ok0 = _knot_arrival(x, y, z, rm, l0a, l0b, c0, inv_c0, two)
    a1, d1, dd1, sg1, ok1 = _knot_arrival(x, y, z, rm, l1a, l1b, c0, inv_c0, two)
    if two:
        # a piece that crosses a capture at or past the output's end ends there
        cut, ac, dc, ddc, qc, mc = _cut_at_end(x, y, z, rm, q0, m0, q1, m1, sg0, ok0, l0a, l0b,
                                               l1a[6], c0, inv_c0, t_start, fs, fn)  # fmt: skip
        a1, d1, dd1, q1, m1, sg1, ok1 = _take_cut(cut, ac, dc, ddc, qc, mc, sg0, a1, d1, dd1, q1,
                                                  m1, sg1, ok1)  # fmt: skip
    return _piece_tail(W, i, a0, d0, dd0, q0, m0, sg0, ok0, a1, d1, dd1, q1, m1, sg1, ok1, c0,
                       inv_c0, t_start, fs, inv_fs, fn, fblock, inv_block, blo, nb, base, rs)  # fmt: skip


@numba.njit(inline="always", **_NJIT)
def _piece_tail(W, i, a0, d0, dd0, q0, m0, sg0, ok0, a1, d1, dd1, q1, m1, sg1, ok1, c0, inv_c0,
                t_start, fs, inv_fs, fn, fblock, inv_block, blo, nb, base, rs):  # fmt: skip  # type: ignore[no-untyped-def]
    """Kind, accumulator rows and Hermite data of the piece in column i of W
    from its ends: arrival a, distance D, D·dD/dt, q, dq/dτ, capture interval
    sg and whether the arrival was found (see :func:`_piece_core`)."""
    W[_W_A0 * _CHUNK + i] = a0
    W[_W_A1 * _CHUNK + i] = a1
    W[_W_S0 * _CHUNK + i] = sg0
    W[_W_S1 * _CHUNK + i] = sg1
    u0 = (a0 - t_start) * fs
    u1 = (a1 - t_start) * fs
    L = u1 - u0
    # one division for 1/D0, 1/D1 and 1/L
    L = L if L > 0.0 else 1.0
    inv0, inv1, inv_l = _inverses(d0, d1, L)
    dd0 = dd0 * inv0  # dD/dt
    dd1 = dd1 * inv1
    f0 = q0 * inv0
    f1 = q1 * inv1
    w0 = (m0 * (1.0 - dd0 * inv_c0) - f0 * dd0) * inv0 * inv_fs
    w1 = (m1 * (1.0 - dd1 * inv_c0) - f1 * dd1) * inv1 * inv_fs
    s0 = np.ceil(u0)
    s0 = s0 if s0 > 0.0 else 0.0
    s1 = np.ceil(u1)
    s1 = s1 if s1 < fn else fn
    valid = (s1 > s0) & (u1 > u0) & ok0 & ok1
    general = ~(ok0 & ok1)
    W[_W_F0 * _CHUNK + i] = f0
    W[_W_WF0 * _CHUNK + i] = w0
    W[_W_F1 * _CHUNK + i] = f1
    W[_W_WF1 * _CHUNK + i] = w1
    s0 = s0 if valid else 0.0
    s1 = s1 if valid else 1.0
    b0 = np.floor(s0 * inv_block)
    b1 = np.floor((s1 - 1.0) * inv_block)
    simple = (sg0 == sg1) & (b1 <= b0 + 1.0) & (b0 >= blo) & (b1 < blo + nb)
    W[_W_KIND * _CHUNK + i] = 2.0 if general else ((1.0 if simple else 3.0) if valid else 0.0)
    W[_W_SI * _CHUNK + i] = base + ((b0 - blo) * fblock + (s0 - b0 * fblock)) * rs
    end_inside = (s1 < fn) & (s1 < (b1 + 1.0) * fblock)
    W[_W_EI * _CHUNK + i] = (
        base + ((b1 - blo) * fblock + (s1 - b1 * fblock)) * rs if end_inside else -1.0
    )
    W[_W_CI * _CHUNK + i] = base + (b1 - blo) * fblock * rs if b1 > b0 else -1.0
    return L, inv_l, f0, w0, f1, w1, s0 - u0, s1 - u0, b1 * fblock - u0


@numba.njit(inline="always", **_NJIT)
def _inverses(a, b, c):  # type: ignore[no-untyped-def]
    """1/a, 1/b and 1/c with one division."""
    r = 1.0 / (a * b * c)
    return b * c * r, a * c * r, a * b * r


@numba.njit(inline="always", **_NJIT)
def _line_tuple(R, o):  # type: ignore[no-untyped-def]
    return (R[o], R[o + 1], R[o + 2], R[o + 3], R[o + 4], R[o + 5], R[o + 6], R[o + 7], R[o + 8],
            R[o + 9], R[o + 10], R[o + 11])  # fmt: skip


@numba.njit(**_NJIT_NORC)
def _chunk_pieces(PD, ck, cnt, RC0, RC1, c0, t_start, fs, n_samples, shift, blo, nb, base,
                  n_ch, panned, W):  # fmt: skip  # type: ignore[no-untyped-def]
    """The cnt pieces of chunk ck (PD[ck], of one row n: knots at t_n with the
    listener's candidate lines RC0, at t_{n+1} with RC1) into columns
    0..cnt-1 of the work array W (see _W_ROWS): arrivals (A0, A1) and their
    capture intervals (S0, S1), kind (0 silent or outside the output;
    1 simple: accumulator rows SI, EI, CI, -1 for none, and 12 values; 2
    general, see :func:`_piece_general`).  Panned layouts get two
    polynomials A (12 values) and B (the next 12) whose sum g0·A + g1·B is the
    piece on a channel whose gain goes linearly from g0 to g1.  SIMD loops: no
    branches in their bodies, integers carried as floats (exact).
    """
    inv_c0 = 1.0 / c0
    inv_fs = 1.0 / fs
    l0a = _line_tuple(RC0, 0)
    l0b = _line_tuple(RC0, _LINE)
    l1a = _line_tuple(RC1, 0)
    l1b = _line_tuple(RC1, _LINE)
    fn = float(n_samples)
    fblock = float(1 << shift)
    inv_block = 1.0 / fblock
    rs = 4.0 * n_ch
    # (unsigned indices: no wraparound checks, the copy vectorizes)
    uck = np.uint64(ck)
    for r in range(8):
        ur = np.uint64(r)
        for i in range(cnt):
            W[np.uint64(r * _CHUNK + i)] = PD[uck, ur, np.uint64(i)]
    # one candidate line per knot when no arrival can pass its end (most
    # steps): separate loops, so each stays branch-free
    two = RC0[2 * _LINE] != 0.0 or RC1[2 * _LINE] != 0.0
    if panned and two:
        for i in range(cnt):
            _one_piece(W, i, l0a, l0b, l1a, l1b, True, True, c0, inv_c0, t_start, fs, inv_fs, fn,
                       fblock, inv_block, blo, nb, base, rs)  # fmt: skip
    elif panned:
        for i in range(cnt):
            _one_piece(W, i, l0a, l0b, l1a, l1b, False, True, c0, inv_c0, t_start, fs, inv_fs, fn,
                       fblock, inv_block, blo, nb, base, rs)  # fmt: skip
    elif two:
        for i in range(cnt):
            _one_piece(W, i, l0a, l0b, l1a, l1b, True, False, c0, inv_c0, t_start, fs, inv_fs, fn,
                       fblock, inv_block, blo, nb, base, rs)  # fmt: skip
    else:
        for i in range(cnt):
            _one_piece(W, i, l0a, l0b, l1a, l1b, False, False, c0, inv_c0, t_start, fs, inv_fs,
                       fn, fblock, inv_block, blo, nb, base, rs)  # fmt: skip


@numba.njit(inline="always", **_NJIT)
def _one_piece(W, i, l0a, l0b, l1a, l1b, two, panned, c0, inv_c0, t_start, fs, inv_fs, fn, fblock,
               inv_block, blo, nb, base, rs):  # fmt: skip  # type: ignore[no-untyped-def]
    """One piece of :func:`_chunk_pieces`: its polynomial, or polynomials A and
    B when ``panned`` (a constant in each caller's loop, so the loop stays
    branch-free)."""
    L, inv, f0, w0, f1, w1, x0, x1, x2 = _piece_core(
        W, i, l0a, l0b, l1a, l1b, two, c0, inv_c0, t_start, fs, inv_fs, fn, fblock, inv_block,
        blo, nb, base, rs)  # fmt: skip
    if panned:
        _piece_values(W, _W_VAL, i, L, inv, f0, w0 - f0 * inv, 0.0, -f1 * inv, x0, x1, x2)
        _piece_values(W, _W_VAL + 12, i, L, inv, 0.0, f0 * inv, f1, w1 + f1 * inv, x0, x1, x2)
    else:
        _piece_values(W, _W_VAL, i, L, inv, f0, w0, f1, w1, x0, x1, x2)


@numba.njit(inline="always", **_NJIT)
def _listener_at(a, sg, la, lb):  # type: ignore[no-untyped-def]
    """Listener position at arrival a on the candidate line (la or lb) of
    capture interval sg (branch-free)."""
    sel = sg == la[11]
    x = la[0] + la[3] * (a - la[6]) if sel else lb[0] + lb[3] * (a - lb[6])
    y = la[1] + la[4] * (a - la[6]) if sel else lb[1] + lb[4] * (a - lb[6])
    z = la[2] + la[5] * (a - la[6]) if sel else lb[2] + lb[5] * (a - lb[6])
    return x, y, z


@numba.njit(inline="always", **_NJIT)
def _frame_coords(W, i, o, dx, dy, dz):  # type: ignore[no-untyped-def]
    """Direction (dx, dy, dz) in the listener's frame whose forward and up are
    rows o..o+5 of W: (forward, left) coordinates, left = up × forward."""
    fx, fy, fz = W[o * _CHUNK + i], W[(o + 1) * _CHUNK + i], W[(o + 2) * _CHUNK + i]
    ux, uy, uz = W[(o + 3) * _CHUNK + i], W[(o + 4) * _CHUNK + i], W[(o + 5) * _CHUNK + i]
    lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
    return dx * fx + dy * fy + dz * fz, dx * lx + dy * ly + dz * lz


@numba.njit(inline="always", **_NJIT)
def _orient_rows(W, i, o, qc, ot, t):  # type: ignore[no-untyped-def]
    """Rows o..o+5 of column i of W: the listener's forward and up at data time
    t from the orientation table (see :func:`_orient`)."""
    n = qc.shape[0]
    u = (t - ot[0]) * ot[1]
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
        W[(o + c) * _CHUNK + i] = qc[j, c] + w * (qc[j1, c] - qc[j, c])


@numba.njit(inline="always", **_NJIT)
def _pair_take(W, i, rp, rx, ry, a0, a1, a2, a3, fp):  # type: ignore[no-untyped-def]
    """Pair fp's gains from the direction (rows rx, ry) if both are >= 0 and no
    earlier pair was taken (row rp = pair index, then the two gains)."""
    xf = W[rx * _CHUNK + i]
    yl = W[ry * _CHUNK + i]
    g0 = a0 * xf + a1 * yl
    g1 = a2 * xf + a3 * yl
    k = rp * _CHUNK + i
    take = (g0 >= -1e-12) & (g1 >= -1e-12) & (W[k] < 0.0)
    W[k] = fp if take else W[k]
    W[k + _CHUNK] = g0 if take else W[k + _CHUNK]
    W[k + 2 * _CHUNK] = g1 if take else W[k + 2 * _CHUNK]


@numba.njit(inline="always", **_NJIT)
def _pair_normalise(W, i, rp):  # type: ignore[no-untyped-def]
    k = rp * _CHUNK + i
    g0 = max(W[k + _CHUNK], 0.0)
    g1 = max(W[k + 2 * _CHUNK], 0.0)
    norm = math.sqrt(g0 * g0 + g1 * g1)
    inv = 1.0 / (norm if norm > 0.0 else 1.0)
    W[k + _CHUNK] = g0 * inv
    W[k + 2 * _CHUNK] = g1 * inv
    return (norm > 0.0) & (W[k] >= 0.0)


@numba.njit(inline="always", **_NJIT)
def _orient_chunk(W, cnt, qc, ot, const_orient):  # type: ignore[no-untyped-def]
    """The listener's forward and up at both arrivals (rows A0, A1) of the
    chunk's pieces into rows O0, O1 of W (see :func:`_orient_rows`)."""
    if const_orient:
        for c in range(6):
            v = qc[0, c]
            for i in range(cnt):
                W[(_W_O0 + c) * _CHUNK + i] = v
                W[(_W_O1 + c) * _CHUNK + i] = v
    else:
        # (not constant: at least two rows) branch-free, unsigned indices: SIMD
        top = float(qc.shape[0] - 1)
        for i in range(cnt):
            _orient_lane(W, i, _W_O0, qc, ot[0], ot[1], top, W[_W_A0 * _CHUNK + i])
            _orient_lane(W, i, _W_O1, qc, ot[0], ot[1], top, W[_W_A1 * _CHUNK + i])


@numba.njit(inline="always", **_NJIT)
def _orient_lane(W, i, o, qc, t0, rate, top, t):  # type: ignore[no-untyped-def]
    """Rows o..o+5 of column i of W: the listener's forward and up at data time
    t from the orientation table qc (at least two rows, the last at ``top`` =
    rows - 1) sampled every 1/rate s from t0 (see :func:`_orient`); held
    outside the table.  Branch-free."""
    j, w = _orient_cell(t0, rate, top, t)
    for c in range(6):
        uc = np.uint64(c)
        a = qc[j, uc]
        W[(o + c) * _CHUNK + i] = a + w * (qc[j + np.uint64(1), uc] - a)


@numba.njit(inline="always", **_NJIT)
def _orient_cell(t0, rate, top, t):  # type: ignore[no-untyped-def]
    """Row j (unsigned) and weight w of the orientation table (at least two
    rows, the last at ``top``) at data time t: the value is row j + w·(row j+1
    - row j); held outside the table (see :func:`_orient_lane`)."""
    u = (t - t0) * rate
    u = u if u > 0.0 else 0.0
    u = u if u < top else top
    jf = np.floor(u)
    jf = jf if jf < top - 1.0 else top - 1.0
    return np.uint64(jf), u - jf


@numba.njit(inline="always", **_NJIT)
def _frame_at(qc, t0, rate, top, t, dx, dy, dz):  # type: ignore[no-untyped-def]
    """(forward, left) coordinates of direction (dx, dy, dz) in the listener's
    frame at data time t, forward and up from the orientation table qc (at
    least two rows; see :func:`_orient_lane`), left = up × forward."""
    j, w = _orient_cell(t0, rate, top, t)
    k = j + np.uint64(1)
    a = qc[j, np.uint64(0)]
    fx = a + w * (qc[k, np.uint64(0)] - a)
    a = qc[j, np.uint64(1)]
    fy = a + w * (qc[k, np.uint64(1)] - a)
    a = qc[j, np.uint64(2)]
    fz = a + w * (qc[k, np.uint64(2)] - a)
    a = qc[j, np.uint64(3)]
    ux = a + w * (qc[k, np.uint64(3)] - a)
    a = qc[j, np.uint64(4)]
    uy = a + w * (qc[k, np.uint64(4)] - a)
    a = qc[j, np.uint64(5)]
    uz = a + w * (qc[k, np.uint64(5)] - a)
    lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
    return dx * fx + dy * fy + dz * fz, dx * lx + dy * ly + dz * lz


@numba.njit(inline="always", **_NJIT)
def _pair_search(W, cnt, pinv):  # type: ignore[no-untyped-def]
    """Pair index and gains at both arrivals from the directions in rows
    XF0, YL0, XF1, YL1 (pair rows preset to -1); a direction with no pair
    (straight above or below) marks the piece general."""
    for p in range(pinv.shape[0]):
        a0, a1, a2, a3 = pinv[p, 0], pinv[p, 1], pinv[p, 2], pinv[p, 3]
        fp = float(p)
        for i in range(cnt):
            _pair_take(W, i, _W_P0, _W_XF0, _W_YL0, a0, a1, a2, a3, fp)
            _pair_take(W, i, _W_P1, _W_XF1, _W_YL1, a0, a1, a2, a3, fp)
    for i in range(cnt):
        ok = _pair_normalise(W, i, _W_P0) & _pair_normalise(W, i, _W_P1)
        kd = W[_W_KIND * _CHUNK + i]
        W[_W_KIND * _CHUNK + i] = 2.0 if (kd != 0.0) & ~ok else kd


@numba.njit(**_NJIT_NORC)
def _chunk_pair_gains(W, cnt, RC0, RC1, qc, ot, pinv, const_orient):  # type: ignore[no-untyped-def]
    """Pairwise 2-D VBAP gains at both arrivals of the chunk's pieces (the law
    of :func:`_gains`, fast path: the first speaker pair whose inverse base
    gives both gains >= 0, power-normalised): pair index and two gains per
    arrival into W.  The listener's orientation is read from its table in a
    scalar loop (unless it is constant), the rest in SIMD loops.  A direction
    straight above or below (no pair) marks the piece general."""
    _orient_chunk(W, cnt, qc, ot, const_orient)
    l0a = _line_tuple(RC0, 0)
    l0b = _line_tuple(RC0, _LINE)
    l1a = _line_tuple(RC1, 0)
    l1b = _line_tuple(RC1, _LINE)
    for i in range(cnt):
        x, y, z = W[0 * _CHUNK + i], W[1 * _CHUNK + i], W[2 * _CHUNK + i]
        px, py, pz = _listener_at(W[_W_A0 * _CHUNK + i], W[_W_S0 * _CHUNK + i], l0a, l0b)
        xf, yl = _frame_coords(W, i, _W_O0, x - px, y - py, z - pz)
        W[_W_XF0 * _CHUNK + i] = xf
        W[_W_YL0 * _CHUNK + i] = yl
        # (a piece cut at a capture, see _cut_at_end, ends on one of its start's lines)
        a1, s1 = W[_W_A1 * _CHUNK + i], W[_W_S1 * _CHUNK + i]
        px, py, pz = _listener_at(a1, s1, l1a, l1b)
        qx, qy, qz = _listener_at(a1, s1, l0a, l0b)
        on1 = (s1 == l1a[11]) | (s1 == l1b[11])
        px = px if on1 else qx
        py = py if on1 else qy
        pz = pz if on1 else qz
        xf, yl = _frame_coords(W, i, _W_O1, x - px, y - py, z - pz)
        W[_W_XF1 * _CHUNK + i] = xf
        W[_W_YL1 * _CHUNK + i] = yl
        W[_W_P0 * _CHUNK + i] = -1.0
        W[_W_P1 * _CHUNK + i] = -1.0
    _pair_search(W, cnt, pinv)


@numba.njit(inline="always", **_NJIT)
def _frame_coords3(W, i, o, dx, dy, dz):  # type: ignore[no-untyped-def]
    """As :func:`_frame_coords` with the third coordinate (up)."""
    fx, fy, fz = W[o * _CHUNK + i], W[(o + 1) * _CHUNK + i], W[(o + 2) * _CHUNK + i]
    ux, uy, uz = W[(o + 3) * _CHUNK + i], W[(o + 4) * _CHUNK + i], W[(o + 5) * _CHUNK + i]
    lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
    return dx * fx + dy * fy + dz * fz, dx * lx + dy * ly + dz * lz, dx * ux + dy * uy + dz * uz


@numba.njit(inline="always", **_NJIT)
def _sh_lanes(W, cnt, rx, ry, rz, tab, G, S):  # type: ignore[no-untyped-def]
    """AmbiX gains ``G ((N+1)², _CHUNK)`` of the directions in rows rx, ry, rz of
    W (the law of :func:`_gains_sh`, one SIMD loop per harmonic over the
    chunk's lanes; the rows are normalised in place; scratch ``S (5, _CHUNK)``;
    harmonic k goes to row ``tab[k, 1]`` of G, none when −1; the recurrence
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
        x, y, z = W[rx * _CHUNK + i], W[ry * _CHUNK + i], W[rz * _CHUNK + i]
        r2 = x * x + y * y + z * z
        nz = r2 > 0.0
        inv = 1.0 / math.sqrt(r2 if nz else 1.0)
        W[rx * _CHUNK + i] = x * inv
        W[ry * _CHUNK + i] = y * inv
        W[rz * _CHUNK + i] = z * inv
        S[4, i] = 1.0 if nz else 0.0  # no direction: W only
        S[0, i] = 1.0  # Re (x + iy)^m
        S[1, i] = 0.0  # Im (x + iy)^m
    pmm = 1.0
    for m in range(m_top + 1):
        if m > 0:
            pmm *= 2 * m - 1
            for i in range(cnt):
                x, y = W[rx * _CHUNK + i], W[ry * _CHUNK + i]
                c, s_ = S[0, i], S[1, i]
                S[0, i] = c * x - s_ * y
                S[1, i] = s_ * x + c * y
        for i in range(cnt):
            S[2, i] = pmm
            S[3, i] = 0.0
        for n in range(m, order + 1):
            if n == m + 1:
                a = 2.0 * m + 1.0
                for i in range(cnt):
                    q = S[2, i]
                    S[2, i] = a * W[rz * _CHUNK + i] * q
                    S[3, i] = q
            elif n > m + 1:
                a = (2.0 * n - 1.0) / (n - m)
                b = (n + m - 1.0) / (n - m)
                for i in range(cnt):
                    q = S[2, i]
                    S[2, i] = a * W[rz * _CHUNK + i] * q - b * S[3, i]
                    S[3, i] = q
            k = n * n + n + m
            f = tab[k, 0]
            d = int(tab[k, 1])
            if d >= 0:  # a harmonic the layout leaves out is skipped; the recurrence goes on
                if n == 0:
                    for i in range(cnt):
                        G[d, i] = f
                else:
                    for i in range(cnt):
                        G[d, i] = f * S[2, i] * S[0, i] * S[4, i]
            if m > 0:
                k = n * n + n - m
                f = tab[k, 0]
                d = int(tab[k, 1])
                if d >= 0:
                    for i in range(cnt):
                        G[d, i] = f * S[2, i] * S[1, i] * S[4, i]


@numba.njit(**_NJIT)
def _chunk_sh_gains(W, cnt, RC0, RC1, qc, ot, tab, const_orient, G0, G1, S):  # type: ignore[no-untyped-def]
    """AmbiX gains (:func:`_gains_sh`) at both arrivals of the chunk's pieces into
    ``G0``/``G1 ((N+1)², _CHUNK)``: listener-frame directions as in
    :func:`_chunk_pair_gains` (rows _W_XF*, _W_YL* and, unused by AmbiX,
    _W_P0/_W_P1 for up), harmonics by :func:`_sh_lanes`."""
    if const_orient:
        for c in range(6):
            v = qc[0, c]
            for i in range(cnt):
                W[(_W_O0 + c) * _CHUNK + i] = v
                W[(_W_O1 + c) * _CHUNK + i] = v
    else:
        for i in range(cnt):
            _orient_rows(W, i, _W_O0, qc, ot, W[_W_A0 * _CHUNK + i])
            _orient_rows(W, i, _W_O1, qc, ot, W[_W_A1 * _CHUNK + i])
    l0a = _line_tuple(RC0, 0)
    l0b = _line_tuple(RC0, _LINE)
    l1a = _line_tuple(RC1, 0)
    l1b = _line_tuple(RC1, _LINE)
    for i in range(cnt):
        x, y, z = W[0 * _CHUNK + i], W[1 * _CHUNK + i], W[2 * _CHUNK + i]
        px, py, pz = _listener_at(W[_W_A0 * _CHUNK + i], W[_W_S0 * _CHUNK + i], l0a, l0b)
        xf, yl, zu = _frame_coords3(W, i, _W_O0, x - px, y - py, z - pz)
        W[_W_XF0 * _CHUNK + i] = xf
        W[_W_YL0 * _CHUNK + i] = yl
        W[_W_P0 * _CHUNK + i] = zu
        # (a piece cut at a capture, see _cut_at_end, ends on one of its start's lines)
        a1, s1 = W[_W_A1 * _CHUNK + i], W[_W_S1 * _CHUNK + i]
        px, py, pz = _listener_at(a1, s1, l1a, l1b)
        qx, qy, qz = _listener_at(a1, s1, l0a, l0b)
        on1 = (s1 == l1a[11]) | (s1 == l1b[11])
        px = px if on1 else qx
        py = py if on1 else qy
        pz = pz if on1 else qz
        xf, yl, zu = _frame_coords3(W, i, _W_O1, x - px, y - py, z - pz)
        W[_W_XF1 * _CHUNK + i] = xf
        W[_W_YL1 * _CHUNK + i] = yl
        W[_W_P1 * _CHUNK + i] = zu
    _sh_lanes(W, cnt, _W_XF0, _W_YL0, _W_P0, tab, G0, S)
    _sh_lanes(W, cnt, _W_XF1, _W_YL1, _W_P1, tab, G1, S)


@numba.njit(inline="always", **_NJIT)
def _scatter_group(acc, W, i, si, ei, ci, off, g0, g1):  # type: ignore[no-untyped-def]
    """Add g0·A + g1·B of the piece in column i of W to one channel (offset off
    in an accumulator row) at its start, end and continuation rows (unsigned
    indices: no wraparound checks)."""
    _add_gained(acc, si + off, W, _W_VAL, i, g0, g1)
    if ei >= 0:
        _add_gained(acc, ei + off, W, _W_VAL + 4, i, g0, g1)
    if ci >= 0:
        _add_gained(acc, ci + off, W, _W_VAL + 8, i, g0, g1)


@numba.njit(inline="always", **_NJIT)
def _scatter_simple(acc, W, i, panned, pairs, spk_ch, nxt):  # type: ignore[no-untyped-def]
    """Add the simple piece or part (kind 1) in lane i of W to the accumulator
    when the layout is unpanned (its polynomial at its start, end and
    continuation rows SI, EI, CI) or panned by speaker pairs (g0·A + g1·B on
    the two channels of the pair at each end; nxt: the channel of the next
    speaker).  Returns whether it was added, and the rows SI, EI, CI (-1: none)
    for the caller to add it otherwise."""
    si = int(W[_W_SI * _CHUNK + i])
    ei = int(W[_W_EI * _CHUNK + i])
    ci = int(W[_W_CI * _CHUNK + i])
    if not panned:
        _add_plain(acc, si, W, _W_VAL, i)
        if ei >= 0:
            _add_plain(acc, ei, W, _W_VAL + 4, i)
        if ci >= 0:
            _add_plain(acc, ci, W, _W_VAL + 8, i)
        return True, si, ei, ci
    if not pairs:
        return False, si, ei, ci
    p0 = int(W[_W_P0 * _CHUNK + i])
    p1 = int(W[_W_P1 * _CHUNK + i])
    g00, g01 = W[_W_G00 * _CHUNK + i], W[_W_G01 * _CHUNK + i]
    g10, g11 = W[_W_G10 * _CHUNK + i], W[_W_G11 * _CHUNK + i]
    c00, c01 = spk_ch[p0], nxt[p0]
    if p0 == p1:
        _scatter_group(acc, W, i, si, ei, ci, c00 * 4, g00, g10)
        _scatter_group(acc, W, i, si, ei, ci, c01 * 4, g01, g11)
    else:
        c10, c11 = spk_ch[p1], nxt[p1]
        _scatter_group(acc, W, i, si, ei, ci, c00 * 4, g00, 0.0)
        _scatter_group(acc, W, i, si, ei, ci, c01 * 4, g01, 0.0)
        _scatter_group(acc, W, i, si, ei, ci, c10 * 4, 0.0, g10)
        _scatter_group(acc, W, i, si, ei, ci, c11 * 4, 0.0, g11)
    return True, si, ei, ci


@intrinsic
def _prefetch(typingctx, arr, idx):  # type: ignore[no-untyped-def]
    """Hint the cache to fetch ``arr[idx]`` for writing (``llvm.prefetch``; a
    hint only: no effect on the values, never faults, any index)."""

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
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
def _prefetch_lane(acc, W, i, cnt, pairs, spk_ch, nxt):  # type: ignore[no-untyped-def]
    """Prefetch the accumulator rows of lane i of W (if i < cnt and the lane is
    a simple piece or part, kind 1): its start and end rows at the channels of
    its first speaker pair (``pairs``) or at the row's start.  The scalar
    scatter loops call it a few lanes ahead: the rows of arrivals at knots lie
    anywhere in an accumulator of many megabytes (8 channels × 4 levels per
    sample), so most of them miss the cache."""
    if i >= cnt:
        return
    if W[_W_KIND * _CHUNK + i] != 1.0:
        return
    o0 = 0
    o1 = 0
    if pairs:
        p0 = int(W[_W_P0 * _CHUNK + i])
        o0 = spk_ch[p0] * 4
        o1 = nxt[p0] * 4
    si = int(W[_W_SI * _CHUNK + i])
    _prefetch(acc, si + o0)
    _prefetch(acc, si + o1)
    ei = int(W[_W_EI * _CHUNK + i])
    if ei >= 0:
        _prefetch(acc, ei + o0)
        _prefetch(acc, ei + o1)


@numba.njit(inline="always", **_NJIT)
def _add_dense(acc, row, W, r, i, G0, G1, n_ch):  # type: ignore[no-untyped-def]
    """acc[row + 4c : row + 4c + 4] += G0[c, i]·A + G1[c, i]·B for every channel
    c (A in rows r.., B in rows r + 12.. of lane i of W; row >= 0): the scatter
    of layouts whose gains are all non-zero (AmbiX), A and B read once."""
    a = np.uint64(row)
    w = np.uint64(r * _CHUNK + i)
    k = np.uint64(_CHUNK)
    a0, a1, a2, a3 = W[w], W[w + k], W[w + 2 * k], W[w + 3 * k]
    w = w + 12 * k
    b0, b1, b2, b3 = W[w], W[w + k], W[w + 2 * k], W[w + 3 * k]
    for c in range(n_ch):
        g0 = G0[c, i]
        g1 = G1[c, i]
        o = a + np.uint64(4 * c)
        acc[o] += g0 * a0 + g1 * b0
        acc[o + np.uint64(1)] += g0 * a1 + g1 * b1
        acc[o + np.uint64(2)] += g0 * a2 + g1 * b2
        acc[o + np.uint64(3)] += g0 * a3 + g1 * b3


@numba.njit(inline="always", **_NJIT)
def _add_plain(acc, row, W, r, i):  # type: ignore[no-untyped-def]
    """acc[row:row + 4] += rows r..r+3 of lane i of W (row >= 0: unsigned
    indices, no wraparound checks)."""
    a = np.uint64(row)
    w = np.uint64(r * _CHUNK + i)
    for v in range(4):
        acc[a + np.uint64(v)] += W[w + np.uint64(v * _CHUNK)]


@numba.njit(inline="always", **_NJIT)
def _add_gained(acc, row, W, r, i, g0, g1):  # type: ignore[no-untyped-def]
    """acc[row:row + 4] += g0·A + g1·B, A in rows r.. and B in rows r + 12.. of
    lane i of W (row >= 0)."""
    a = np.uint64(row)
    w = np.uint64(r * _CHUNK + i)
    for v in range(4):
        acc[a + np.uint64(v)] += (g0 * W[w + np.uint64(v * _CHUNK)]
                                  + g1 * W[w + np.uint64((v + 12) * _CHUNK)])  # fmt: skip


@numba.njit(**_NJIT_NORC)
def _piece_general(acc, base, blo, nb, n_ch, shift, n_samples, n, seg, x, y, z, rmin, tn, q0,
                   m0, q1, m1, cubic, tc, lc, vc, qc, ot, c0, t_start, fs, spk_az, spk_ch,
                   fold, pinv, panned, ga, gb, gx, gy, o, ct, k_ct):  # fmt: skip  # type: ignore[no-untyped-def]
    """Piece n (knots n, n + 1) of a source at (x, y, z) in full: arrivals
    solved across the listener's captures (:func:`_arrival`; seg: the capture
    interval holding t_n, where the search starts), gains, then
    :func:`_piece_across`."""
    a0, d0, dd0, s0 = _arrival(x, y, z, rmin, tn[n], seg, tc, lc, vc, c0)
    a1, d1, dd1, s1 = _arrival(x, y, z, rmin, tn[n + 1], s0, tc, lc, vc, c0)
    t_end = t_start + n_samples / fs
    if a1 <= t_start or a0 >= t_end or a1 <= a0:
        return 0
    va, wa = _fval(q0, m0, d0, dd0, c0)
    vb, wb = _fval(q1, m1, d1, dd1, c0)
    if panned:
        _pan_far(x, y, z, a0, s0, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, ga, o)
        _pan_far(x, y, z, a1, s1, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, gb, o)
    return _piece_across(acc, base, blo, nb, n_ch, shift, n_samples, n, x, y, z, rmin, tn, q0, m0,
                         q1, m1, cubic, tc, lc, vc, qc, ot, c0, t_start, fs, spk_az, spk_ch, fold,
                         pinv, panned, a0, a1, s0, s1, va, wa, vb, wb, ga, gb, gx, gy, o, ct,
                         k_ct)  # fmt: skip


@numba.njit(**_NJIT_NORC)
def _piece_across(acc, base, blo, nb, n_ch, shift, n_samples, n, x, y, z, rmin, tn, q0, m0, q1,
                  m1, cubic, tc, lc, vc, qc, ot, c0, t_start, fs, spk_az, spk_ch, fold, pinv,
                  panned, a0, a1, s0, s1, va, wa, vb, wb, ga, gb, gx, gy, o, ct, k_ct):  # fmt: skip  # type: ignore[no-untyped-def]
    """Piece n of a source at (x, y, z) from arrival a0 (capture interval s0,
    f = va, df/dt = wa per data second, gains ga) to a1 (s1, vb, wb, gb),
    split at the listener's captures inside it: the listener's velocity
    changes there, so does df/dt, and f, df/dt and the gains are evaluated on
    either side; continued across accumulation blocks.  The emissions at the
    captures go to the capture table ``ct`` (its row r: capture k_ct + r)
    where it has a row for them (:func:`_emit_piece`)."""
    bad = 0
    n_ct = ct.size // (4 * n_ch)
    r0 = -1
    u0 = (a0 - t_start) * fs
    for c in range(n_ch):
        gy[c] = ga[c] if panned else 1.0
    m = tc.size
    seg = s0
    while seg < s1:
        t1 = tc[seg + 1]
        # at the capture the listener is at lc[seg + 1] whichever line: D, the
        # emission time and q are the same on both sides, dD/dt is not
        px, py, pz = lc[seg + 1, 0] - x, lc[seg + 1, 1] - y, lc[seg + 1, 2] - z
        d = math.sqrt(px * px + py * py + pz * pz)
        inside = d <= rmin
        d = rmin if inside else d
        qv, dq = _qeval(tn[n], tn[n + 1] - tn[n], q0, m0, q1, m1, t1 - d / c0, cubic)
        # f and its derivative just before the capture ...
        ddl = 0.0
        if not inside and seg >= 0:
            ddl = (px * vc[seg, 0] + py * vc[seg, 1] + pz * vc[seg, 2]) / d
        v1, w1 = _fval(qv, dq, d, ddl, c0)
        if panned:
            _pan_far(x, y, z, t1, seg, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, gx, o)
        u1 = (t1 - t_start) * fs
        r1 = seg + 1 - k_ct
        if r1 < 0 or r1 >= n_ct:
            r1 = -1
        bad += _emit_gained(acc, base, blo, nb, n_ch, shift, n_samples, u0, u1, va, wa, v1, w1, gy,
                            gx, fs, panned, ct, r0, r1)  # fmt: skip
        seg += 1
        # ... and just after it, on the next line (held after the last capture)
        ddr = 0.0
        if not inside and seg < m - 1:
            ddr = (px * vc[seg, 0] + py * vc[seg, 1] + pz * vc[seg, 2]) / d
        va, wa = _fval(qv, dq, d, ddr, c0)
        if panned:
            for c in range(n_ch):
                gy[c] = gx[c]
        u0 = u1
        r0 = r1
    return bad + _emit_gained(acc, base, blo, nb, n_ch, shift, n_samples, u0, (a1 - t_start) * fs,
                              va, wa, vb, wb, gy, gb, fs, panned, ct, r0, -1)  # fmt: skip


#: parts (pieces split at the listener's captures, see :func:`_chunk_parts`):
#: further rows of their work array: the capture interval j, whether each end
#: is a knot (1) or a capture (0), the listener's position at both arrivals,
#: the listener's line on interval j (row j + 1 of the line table: 9 rows)
#: and captures j and j + 1 (position and time: 4 rows each)
_W_J, _W_K0, _W_K1, _W_L0, _W_L1, _W_LN, _W_C0, _W_C1 = 66, 67, 68, 69, 72, 75, 84, 88
_WP_ROWS = 92


@numba.njit(inline="always", **_NJIT)
def _hermite_at(t_0, h, q0, m0, q1, m1, tau):  # type: ignore[no-untyped-def]
    """Strength q and dq/dτ at τ of the cubic Hermite piece from knot t_0 to
    t_0 + h (values q0, q1, tangents m0, m1 per second; a linear piece has
    m0 = m1 = its slope, which the Hermite reproduces); branch-free."""
    s = (tau - t_0) / h
    s = s if s > 0.0 else 0.0
    s = s if s < 1.0 else 1.0
    s2 = s * s
    s3 = s2 * s
    hm0 = m0 * h
    hm1 = m1 * h
    q = ((2.0 * s3 - 3.0 * s2 + 1.0) * q0 + (s3 - 2.0 * s2 + s) * hm0
         + (3.0 * s2 - 2.0 * s3) * q1 + (s3 - s2) * hm1)  # fmt: skip
    m = ((6.0 * s2 - 6.0 * s) * (q0 - q1) + (3.0 * s2 - 4.0 * s + 1.0) * hm0
         + (3.0 * s2 - 2.0 * s) * hm1) / h  # fmt: skip
    return q, m


@numba.njit(inline="always", **_NJIT)
def _part_end(x, y, z, rm, at_knot, t_k, qk, mk, cx, cy, cz, ck, lx, ly, lz, vx, vy, vz, tr, den,
              inv_den, t_n, h, q0, m0, q1, m1, c0, inv_c0):  # fmt: skip  # type: ignore[no-untyped-def]
    """One end of a part on the listener's line L + V (t - tr): at a knot
    (``at_knot``: the emission at t_k, strength qk, dq/dτ mk, solved on the
    line as in :func:`_line_arrival`) or at a capture (arrival ck, the
    listener at (cx, cy, cz); the emission heard there and its q, dq/dτ from
    the piece's Hermite); returns arrival, D, D·dD/dt, q and dq/dτ
    (branch-free)."""
    dt = t_k - tr
    a1, d1, e1 = _line_arrival(x, y, z, rm, lx + vx * dt, ly + vy * dt, lz + vz * dt, vx, vy, vz,
                               t_k, inv_den, den, c0, inv_c0)  # fmt: skip
    px = cx - x
    py = cy - y
    pz = cz - z
    d = math.sqrt(px * px + py * py + pz * pz)
    clamp = d <= rm
    e2 = 0.0 if clamp else px * vx + py * vy + pz * vz
    d2 = rm if clamp else d
    a2 = ck
    q2, m2 = _hermite_at(t_n, h, q0, m0, q1, m1, a2 - d2 * inv_c0)
    return (a1 if at_knot else a2, d1 if at_knot else d2, e1 if at_knot else e2,
            qk if at_knot else q2, mk if at_knot else m2)  # fmt: skip


@numba.njit(inline="always", **_NJIT)
def _part_core(W, i, t_n, t_n1, c0, inv_c0, t_start, fs, inv_fs, fn, fblock, inv_block, blo, nb,
               base, rs):  # fmt: skip  # type: ignore[no-untyped-def]
    """Arrivals, kind and accumulator rows of the part in column i of W (see
    :func:`_chunk_parts`): the piece's emissions heard on the listener's
    line of capture interval j (rows LN), from its first knot or capture j
    (rows C0) to its last knot or capture j + 1 (rows C1); returns the
    Hermite data and emission offsets as :func:`_piece_core`.  Reads W only
    (no gathers: the loop vectorizes)."""
    x = W[0 * _CHUNK + i]
    y = W[1 * _CHUNK + i]
    z = W[2 * _CHUNK + i]
    rm = W[3 * _CHUNK + i]
    q0 = W[4 * _CHUNK + i]
    m0 = W[5 * _CHUNK + i]
    q1 = W[6 * _CHUNK + i]
    m1 = W[7 * _CHUNK + i]
    j = W[_W_J * _CHUNK + i]
    at0 = W[_W_K0 * _CHUNK + i] != 0.0
    at1 = W[_W_K1 * _CHUNK + i] != 0.0
    lx, ly, lz = W[_W_LN * _CHUNK + i], W[(_W_LN + 1) * _CHUNK + i], W[(_W_LN + 2) * _CHUNK + i]
    vx, vy, vz = (W[(_W_LN + 3) * _CHUNK + i], W[(_W_LN + 4) * _CHUNK + i],
                  W[(_W_LN + 5) * _CHUNK + i])  # fmt: skip
    tr, den, inv_den = (W[(_W_LN + 6) * _CHUNK + i], W[(_W_LN + 7) * _CHUNK + i],
                        W[(_W_LN + 8) * _CHUNK + i])  # fmt: skip
    h = t_n1 - t_n
    a0, d0, e0, qa, ma = _part_end(
        x, y, z, rm, at0, t_n, q0, m0, W[_W_C0 * _CHUNK + i], W[(_W_C0 + 1) * _CHUNK + i],
        W[(_W_C0 + 2) * _CHUNK + i], W[(_W_C0 + 3) * _CHUNK + i], lx, ly, lz, vx, vy, vz, tr, den,
        inv_den, t_n, h, q0, m0, q1, m1, c0, inv_c0)  # fmt: skip
    a1, d1, e1, qb, mb = _part_end(
        x, y, z, rm, at1, t_n1, q1, m1, W[_W_C1 * _CHUNK + i], W[(_W_C1 + 1) * _CHUNK + i],
        W[(_W_C1 + 2) * _CHUNK + i], W[(_W_C1 + 3) * _CHUNK + i], lx, ly, lz, vx, vy, vz, tr, den,
        inv_den, t_n, h, q0, m0, q1, m1, c0, inv_c0)  # fmt: skip
    W[_W_L0 * _CHUNK + i] = lx + vx * (a0 - tr)
    W[(_W_L0 + 1) * _CHUNK + i] = ly + vy * (a0 - tr)
    W[(_W_L0 + 2) * _CHUNK + i] = lz + vz * (a0 - tr)
    W[_W_L1 * _CHUNK + i] = lx + vx * (a1 - tr)
    W[(_W_L1 + 1) * _CHUNK + i] = ly + vy * (a1 - tr)
    W[(_W_L1 + 2) * _CHUNK + i] = lz + vz * (a1 - tr)
    return _piece_tail(W, i, a0, d0, e0, qa, ma, j, True, a1, d1, e1, qb, mb, j, True, c0, inv_c0,
                       t_start, fs, inv_fs, fn, fblock, inv_block, blo, nb, base, rs)  # fmt: skip


@numba.njit(**_NJIT_NORC)
def _part_pair_gains(W, cnt, qc, ot, pinv, const_orient):  # type: ignore[no-untyped-def]
    """Pairwise 2-D VBAP gains at both arrivals of a batch of parts (as
    :func:`_chunk_pair_gains`, the listener's positions from rows L0, L1)."""
    if const_orient:
        _orient_chunk(W, cnt, qc, ot, const_orient)
        for i in range(cnt):
            x, y, z = W[0 * _CHUNK + i], W[1 * _CHUNK + i], W[2 * _CHUNK + i]
            px, py, pz = (W[_W_L0 * _CHUNK + i], W[(_W_L0 + 1) * _CHUNK + i],
                          W[(_W_L0 + 2) * _CHUNK + i])  # fmt: skip
            xf, yl = _frame_coords(W, i, _W_O0, x - px, y - py, z - pz)
            W[_W_XF0 * _CHUNK + i] = xf
            W[_W_YL0 * _CHUNK + i] = yl
            px, py, pz = (W[_W_L1 * _CHUNK + i], W[(_W_L1 + 1) * _CHUNK + i],
                          W[(_W_L1 + 2) * _CHUNK + i])  # fmt: skip
            xf, yl = _frame_coords(W, i, _W_O1, x - px, y - py, z - pz)
            W[_W_XF1 * _CHUNK + i] = xf
            W[_W_YL1 * _CHUNK + i] = yl
    else:
        # the table's look-ups are gathers (a scalar loop): the frame is used
        # where it is read, not stored
        top = float(qc.shape[0] - 1)
        t0, rate = ot[0], ot[1]
        for i in range(cnt):
            x, y, z = W[0 * _CHUNK + i], W[1 * _CHUNK + i], W[2 * _CHUNK + i]
            px, py, pz = (W[_W_L0 * _CHUNK + i], W[(_W_L0 + 1) * _CHUNK + i],
                          W[(_W_L0 + 2) * _CHUNK + i])  # fmt: skip
            xf, yl = _frame_at(qc, t0, rate, top, W[_W_A0 * _CHUNK + i], x - px, y - py, z - pz)
            W[_W_XF0 * _CHUNK + i] = xf
            W[_W_YL0 * _CHUNK + i] = yl
            px, py, pz = (W[_W_L1 * _CHUNK + i], W[(_W_L1 + 1) * _CHUNK + i],
                          W[(_W_L1 + 2) * _CHUNK + i])  # fmt: skip
            xf, yl = _frame_at(qc, t0, rate, top, W[_W_A1 * _CHUNK + i], x - px, y - py, z - pz)
            W[_W_XF1 * _CHUNK + i] = xf
            W[_W_YL1 * _CHUNK + i] = yl
    for i in range(cnt):
        W[_W_P0 * _CHUNK + i] = -1.0
        W[_W_P1 * _CHUNK + i] = -1.0
    _pair_search(W, cnt, pinv)


@numba.njit(**_NJIT_NORC)
def _part_batch(W, cnt, LT, tc, lc, vc, qc, ot, t_n, t_n1, c0, t_start, fs, n_samples, shift, blo,
                nb, base, n_ch, panned, pairs, const_orient, spk_az, spk_ch, nxt, fold, pinv, acc,
                ga, gb, o, ct):  # fmt: skip  # type: ignore[no-untyped-def]
    """Sum the cnt parts in columns 0..cnt-1 of W (see :func:`_chunk_parts`):
    SIMD loops for their polynomials and speaker-pair gains, then a scalar
    loop that adds them to the accumulator (a part over more than two
    accumulation blocks, or with no speaker pair, through
    :func:`_emit_gained`).  Returns the number of emissions outside the window."""
    inv_c0 = 1.0 / c0
    inv_fs = 1.0 / fs
    fn = float(n_samples)
    fblock = float(1 << shift)
    inv_block = 1.0 / fblock
    rs = 4.0 * n_ch
    if panned:
        for i in range(cnt):
            L, inv, f0, w0, f1, w1, x0, x1, x2 = _part_core(
                W, i, t_n, t_n1, c0, inv_c0, t_start, fs, inv_fs, fn, fblock, inv_block, blo,
                nb, base, rs)  # fmt: skip
            _piece_values(W, _W_VAL, i, L, inv, f0, w0 - f0 * inv, 0.0, -f1 * inv, x0, x1, x2)
            _piece_values(W, _W_VAL + 12, i, L, inv, 0.0, f0 * inv, f1, w1 + f1 * inv, x0, x1, x2)
    else:
        for i in range(cnt):
            L, inv, f0, w0, f1, w1, x0, x1, x2 = _part_core(
                W, i, t_n, t_n1, c0, inv_c0, t_start, fs, inv_fs, fn, fblock, inv_block, blo,
                nb, base, rs)  # fmt: skip
            _piece_values(W, _W_VAL, i, L, inv, f0, w0, f1, w1, x0, x1, x2)
    if pairs:
        _part_pair_gains(W, cnt, qc, ot, pinv, const_orient)
    nbad = 0
    for i in range(_AHEAD):
        _prefetch_lane(acc, W, i, cnt, pairs, spk_ch, nxt)
    for i in range(cnt):
        _prefetch_lane(acc, W, i + _AHEAD, cnt, pairs, spk_ch, nxt)
        kd = W[_W_KIND * _CHUNK + i]
        if kd == 0.0:
            continue
        x, y, z = W[0 * _CHUNK + i], W[1 * _CHUNK + i], W[2 * _CHUNK + i]
        a0, a1 = W[_W_A0 * _CHUNK + i], W[_W_A1 * _CHUNK + i]
        sg = int(W[_W_J * _CHUNK + i])
        if kd == 1.0:
            done, si, ei, ci = _scatter_simple(acc, W, i, panned, pairs, spk_ch, nxt)
            if done:
                continue
            _pan(x, y, z, a0, sg, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, ga, o)
            _pan(x, y, z, a1, sg, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, gb, o)
            for c in range(n_ch):
                if ga[c] != 0.0 or gb[c] != 0.0:
                    _scatter_group(acc, W, i, si, ei, ci, c * 4, ga[c], gb[c])
            continue
        # over several accumulation blocks (kind 3), or no speaker pair (2)
        if pairs and kd == 3.0:
            for c in range(n_ch):
                ga[c] = 0.0
                gb[c] = 0.0
            p0 = int(W[_W_P0 * _CHUNK + i])
            p1 = int(W[_W_P1 * _CHUNK + i])
            ga[spk_ch[p0]] += W[_W_G00 * _CHUNK + i]
            ga[nxt[p0]] += W[_W_G01 * _CHUNK + i]
            gb[spk_ch[p1]] += W[_W_G10 * _CHUNK + i]
            gb[nxt[p1]] += W[_W_G11 * _CHUNK + i]
        elif panned:
            _pan(x, y, z, a0, sg, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, ga, o)
            _pan(x, y, z, a1, sg, tc, lc, vc, qc, ot, spk_az, spk_ch, fold, pinv, gb, o)
        nbad += _emit_gained(acc, base, blo, nb, n_ch, shift, n_samples, (a0 - t_start) * fs,
                             (a1 - t_start) * fs, W[_W_F0 * _CHUNK + i], W[_W_WF0 * _CHUNK + i] * fs,
                             W[_W_F1 * _CHUNK + i], W[_W_WF1 * _CHUNK + i] * fs, ga, gb, fs, panned,
                             ct, -1, -1)  # fmt: skip
    return nbad


@numba.njit(**_NJIT_NORC)
def _chunk_parts(PD, ck, cc, k_lo, k_hi, W, LT, tc, lc, vc, qc, ot, t_n, t_n1, c0, t_start, fs,
                 n_samples, shift, blo, nb, base, n_ch, panned, pairs, const_orient, spk_az, spk_ch,
                 nxt, fold, pinv, acc, ga, gb, o, ct, CN):  # fmt: skip  # type: ignore[no-untyped-def]
    """The cc pieces of chunk ck (row n: knots at t_n, t_n1) of a row whose
    arrivals may cross listener captures k_lo..k_hi-1, split there into parts.

    On capture interval j the listener moves on one line, so the emissions of
    a piece heard there (those between τ_j and τ_{j+1}, τ_k = t_k - D_k/c0
    the emission heard at capture k, increasing with k) form a part whose
    ends are a knot (arrival solved on the line) or a capture (arrival t_k,
    q from the piece's Hermite at τ_k): exactly the split of
    :func:`_piece_across`, in SIMD loops.  The interval of a knot's arrival
    is k_lo - 1 plus the number of captures k with τ_k <= its time (a
    count over the candidate captures, SIMD); the parts are then listed in
    batches of _CHUNK in W (rows 0-7 the piece's input, J, K0, K1, LN, C0, C1) and summed
    by :func:`_part_batch`; CN (2·_CHUNK) is work space for the counts.  Returns the number of emissions outside the window.
    """
    inv_c0 = 1.0 / c0
    uck = np.uint64(ck)
    for i in range(cc):
        CN[i] = 0.0
        CN[_CHUNK + i] = 0.0
    for k in range(k_lo, k_hi):
        lx, ly, lz, tk = lc[k, 0], lc[k, 1], lc[k, 2], tc[k]
        for i in range(cc):
            ui = np.uint64(i)
            dx = lx - PD[uck, np.uint64(0), ui]
            dy = ly - PD[uck, np.uint64(1), ui]
            dz = lz - PD[uck, np.uint64(2), ui]
            rm = PD[uck, np.uint64(3), ui]
            d = math.sqrt(dx * dx + dy * dy + dz * dz)
            d = d if d > rm else rm
            tau = tk - d * inv_c0
            CN[ui] += 1.0 if tau <= t_n else 0.0
            CN[np.uint64(_CHUNK) + ui] += 1.0 if tau <= t_n1 else 0.0
    nbad = 0
    p = np.int64(0)  # typed int64, not the literal 0 (see _constant_rows)
    last = tc.size - 1
    for i in range(cc):
        s0 = k_lo - 1 + int(CN[i])
        s1 = k_lo - 1 + int(CN[_CHUNK + i])
        ui = np.uint64(i)
        for j in range(s0, s1 + 1):
            # (unsigned indices, all >= 0: no wraparound checks in this scalar copy)
            for r in range(8):
                W[np.uint64(r * _CHUNK + p)] = PD[uck, np.uint64(r), ui]
            W[np.uint64(_W_J * _CHUNK + p)] = float(j)
            W[np.uint64(_W_K0 * _CHUNK + p)] = 1.0 if j == s0 else 0.0
            W[np.uint64(_W_K1 * _CHUNK + p)] = 1.0 if j == s1 else 0.0
            lt = np.uint64(j + 1)
            for r in range(9):
                W[np.uint64((_W_LN + r) * _CHUNK + p)] = LT[lt, np.uint64(r)]
            k0 = np.uint64(max(j, 0))
            k1 = np.uint64(min(j + 1, last))
            for r in range(3):
                W[np.uint64((_W_C0 + r) * _CHUNK + p)] = lc[k0, np.uint64(r)]
                W[np.uint64((_W_C1 + r) * _CHUNK + p)] = lc[k1, np.uint64(r)]
            W[np.uint64((_W_C0 + 3) * _CHUNK + p)] = tc[k0]
            W[np.uint64((_W_C1 + 3) * _CHUNK + p)] = tc[k1]
            p += 1
            if p == _CHUNK:
                nbad += _part_batch(W, p, LT, tc, lc, vc, qc, ot, t_n, t_n1, c0, t_start, fs,
                                    n_samples, shift, blo, nb, base, n_ch, panned, pairs,
                                    const_orient, spk_az, spk_ch, nxt, fold, pinv, acc, ga, gb,
                                    o, ct)  # fmt: skip
                p = np.int64(0)
    if p > 0:
        nbad += _part_batch(W, p, LT, tc, lc, vc, qc, ot, t_n, t_n1, c0, t_start, fs, n_samples,
                            shift, blo, nb, base, n_ch, panned, pairs, const_orient, spk_az,
                            spk_ch, nxt, fold, pinv, acc, ga, gb, o, ct)  # fmt: skip
    return nbad


@numba.njit(**_NJIT_NORC)
def _constant_rows(qc):  # type: ignore[no-untyped-def]
    """Whether every row of the orientation table qc equals its first.

    Typed ``bool``: a flag initialised from the literal ``True`` (or a
    counter from ``0``) and passed to a compiled, not inlined, kernel types
    first as ``Literal[bool](True)`` and then as ``bool``, and numba compiles
    that kernel, and everything it calls, once for each: minutes of compile
    time for nothing."""
    n_diff = 0
    for j in range(1, qc.shape[0]):
        for c in range(qc.shape[1]):
            n_diff += 1 if qc[j, c] != qc[0, c] else 0
    return n_diff == 0


@numba.njit(parallel=True, **_NJIT)
def render(cptr, ccnt, PD, tn, cubic, tc, lc, vc, qc, ot, c0, t_start, fs, n_samples, shift,
           spk_az, spk_ch, pinv, n_ch, fold, n_lo, n_hi, d_max, task_pieces, task_blk, RC, acc,
           out, ct, k_ct, KR, LT):  # fmt: skip  # type: ignore[no-untyped-def]
    """Sum every sounding piece into ``out (n_ch, n_samples)``; see module docstring.

    Parameters (all times in data seconds)
    ----------
    the sounding pieces in chunks of _CHUNK, sorted by knot row n (piece n runs
    from knot n to n + 1): row n's chunks are cptr[n]..cptr[n+1]-1, chunk c
    holds ccnt[c] pieces, PD (C, 8, _CHUNK) = x, y, z, clamp radius, q and
    dq/dτ at its first knot, q and dq/dτ at its last (strength·ΔV/(4π); for
    linear interpolation, ``cubic`` False, dq/dτ is the piece's slope),
    contiguous per chunk; tn (Tp,) knot times (padded with silent knots); tc (M,),
    lc (M,3), vc (M-1,3) listener captures; qc (N,6) forward/up table sampled
    from ot[0] at rate ot[1] (see :func:`_orient`); fs samples per data
    second; 2**shift samples per accumulation block; spk_az/spk_ch speaker
    azimuths (sorted) and channels; pinv (n_pairs, 4) inverse bases of
    adjacent speaker pairs (empty when an arc spans 180° or more, e.g. stereo),
    or for layouts with elevation the 3-D VBAP table of :func:`_gains3`.

    Work is split in tasks (one per thread): task j sums chunks
    task_pieces[j, 0]..task_pieces[j, 1]-1 of rows n_lo..n_hi-1 into its
    accumulator window: blocks task_blk[j, 0].. (task_blk[j, 1] of them) at
    offset task_blk[j, 2] of ``acc``; it emits nothing before sample
    task_blk[j, 3] (its first arrival: the rows before it are neither
    cleared nor read).  Pieces are sorted by row, so a task's
    arrivals, and its writes, stay within its own stretch of the output.
    RC (Tp, 2·_LINE + 1) is work space for the listener's lines per row;
    d_max bounds the source-listener distance.  ct (n_tasks, R·n_ch·4): each
    task's capture table for captures k_ct … k_ct + R - 1 (see
    :func:`_emit_piece`), cleared here.  Rows n with KR[n, 1] > KR[n, 0]
    (arrivals that may cross the listener's captures KR[n, 0]..KR[n, 1]-1)
    are split into parts at those captures (:func:`_chunk_parts`; LT (M+1, 9)
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
    const_orient = _constant_rows(qc)
    n_spk = spk_az.size
    nxt = np.empty(max(n_spk, 1), dtype=np.int64)  # channel of the next speaker
    for p in range(n_spk):
        nxt[p] = spk_ch[(p + 1) % n_spk]
    ng = n_ch if panned else 1
    _row_lines(tn, tc, lc, vc, c0, d_max, n_lo, n_hi, RC)
    bad = np.zeros(n_tasks, dtype=np.int64)
    for j in numba.prange(n_tasks):
        p_a, p_b = task_pieces[j, 0], task_pieces[j, 1]
        blo, nb, base = task_blk[j, 0], task_blk[j, 1], task_blk[j, 2]
        _clear_window(acc, task_blk[j], n_ch, block, n_samples)
        W = np.empty(_W_ROWS * _CHUNK)
        WP = np.empty(_WP_ROWS * _CHUNK)
        CN = np.empty(2 * _CHUNK)
        G0 = np.zeros((_CHUNK, ng))
        G1 = np.zeros((_CHUNK, ng))
        GT0 = np.zeros((ng if dense else 0, _CHUNK))  # AmbiX gains, channel-major
        GT1 = np.zeros((ng if dense else 0, _CHUNK))
        SH = np.empty((5, _CHUNK))
        ga = np.zeros(n_ch)
        gb = np.zeros(n_ch)
        gx = np.zeros(n_ch)
        gy = np.zeros(n_ch)
        o = np.zeros(6)
        ctj = ct[j]
        ctj[:] = 0.0
        nbad = _task_sum(
            PD, cptr, ccnt, tn, cubic, tc, lc, vc, qc, ot, c0, t_start, fs, n_samples, shift,
            spk_az, spk_ch, nxt, pinv, n_ch, fold, panned, pairs, dense, const_orient, n_lo, n_hi,
            p_a, p_b, blo, nb, base, RC, KR, LT, acc, ctj, k_ct, W, WP, CN, G0, G1, GT0, GT1, SH,
            ga, gb, gx, gy, o,
        )  # fmt: skip
        bad[j] = nbad + _flush_captures(acc, ctj, k_ct, tc, t_start, fs, n_samples, shift, blo, nb,
                                        base, n_ch, task_blk[j, 3])  # fmt: skip
    # integrate: per channel and block, the sum of the tasks' skewed levels,
    # then four running sums
    # (the sums restart at every accumulation block: blocks are independent)
    n_groups = min(n_tasks, n_ch)
    n_blocks = (n_samples + block - 1) // block
    for k in numba.prange(n_groups * n_blocks):
        g = k // n_blocks
        b = k - g * n_blocks
        _integrate(acc, task_blk, g * n_ch // n_groups, (g + 1) * n_ch // n_groups, b, n_ch,
                   block, n_samples, out)  # fmt: skip
    return int(bad.sum())


@numba.njit(**_NJIT_NORC)
def _task_sum(PD, cptr, ccnt, tn, cubic, tc, lc, vc, qc, ot, c0, t_start, fs, n_samples, shift,
              spk_az, spk_ch, nxt, pinv, n_ch, fold, panned, pairs, dense, const_orient, n_lo,
              n_hi, p_a, p_b, blo, nb, base, RC, KR, LT, acc, ctj, k_ct, W, WP, CN, G0, G1, GT0,
              GT1, SH, ga, gb, gx, gy, o):  # fmt: skip  # type: ignore[no-untyped-def]
    """One task of :func:`render`: its pieces (chunks p_a..p_b-1 of rows
    n_lo..n_hi-1) into its accumulator window (blocks blo..blo+nb-1 at offset
    ``base``) and capture table ``ctj``; W, WP, CN, G0, G1, GT0, GT1, SH, ga, gb,
    gx, gy and o are its work arrays.  Returns the number of emissions outside
    the window."""
    nbad = 0
    n = n_lo
    while n < n_hi and cptr[n + 1] <= p_a:
        n += 1
    while n < n_hi and cptr[n] < p_b:
        if KR[n, 1] > KR[n, 0]:
            for ck in range(max(cptr[n], p_a), min(cptr[n + 1], p_b)):
                nbad += _chunk_parts(
                    PD, ck, ccnt[ck], KR[n, 0], KR[n, 1], WP, LT, tc, lc, vc, qc, ot, tn[n],
                    tn[n + 1], c0, t_start, fs, n_samples, shift, blo, nb, base, n_ch, panned,
                    pairs, const_orient, spk_az, spk_ch, nxt, fold, pinv, acc, ga, gb, o, ctj,
                    CN,
                )  # fmt: skip
            n += 1
            continue
        for ck in range(max(cptr[n], p_a), min(cptr[n + 1], p_b)):
            cc = ccnt[ck]
            _chunk_pieces(PD, ck, cc, RC[n], RC[n + 1], c0, t_start, fs, n_samples, shift,
                          blo, nb, base, n_ch, panned, W)  # fmt: skip
            if pairs:
                _chunk_pair_gains(W, cc, RC[n], RC[n + 1], qc, ot, pinv, const_orient)
            elif dense:
                _chunk_sh_gains(W, cc, RC[n], RC[n + 1], qc, ot, pinv, const_orient, GT0,
                                GT1, SH)  # fmt: skip
            elif panned:
                for i in range(cc):
                    if W[_W_KIND * _CHUNK + i] != 1.0 and W[_W_KIND * _CHUNK + i] != 3.0:
                        continue
                    x, y, z = PD[ck, 0, i], PD[ck, 1, i], PD[ck, 2, i]
                    _pan(x, y, z, W[_W_A0 * _CHUNK + i], int(W[_W_S0 * _CHUNK + i]), tc, lc, vc, qc, ot, spk_az,
                         spk_ch, fold, pinv, ga, o)  # fmt: skip
                    _pan(x, y, z, W[_W_A1 * _CHUNK + i], int(W[_W_S1 * _CHUNK + i]), tc, lc, vc, qc, ot, spk_az,
                         spk_ch, fold, pinv, gb, o)  # fmt: skip
                    for c in range(n_ch):
                        G0[i, c] = ga[c]
                        G1[i, c] = gb[c]
            for i in range(_AHEAD):
                _prefetch_lane(acc, W, i, cc, pairs, spk_ch, nxt)
            for i in range(cc):
                _prefetch_lane(acc, W, i + _AHEAD, cc, pairs, spk_ch, nxt)
                kd = W[_W_KIND * _CHUNK + i]
                if kd == 0.0:
                    continue
                if kd == 1.0:
                    done, si, ei, ci = _scatter_simple(acc, W, i, panned, pairs, spk_ch, nxt)
                    if done:
                        continue
                    if dense:
                        _add_dense(acc, si, W, _W_VAL, i, GT0, GT1, n_ch)
                        if ei >= 0:
                            _add_dense(acc, ei, W, _W_VAL + 4, i, GT0, GT1, n_ch)
                        if ci >= 0:
                            _add_dense(acc, ci, W, _W_VAL + 8, i, GT0, GT1, n_ch)
                        continue
                    for c in range(n_ch):
                        g0 = G0[i, c]
                        g1 = G1[i, c]
                        if g0 != 0.0 or g1 != 0.0:
                            _scatter_group(acc, W, i, si, ei, ci, c * 4, g0, g1)
                    continue
                if kd == 3.0:
                    # across listener captures or several blocks: arrivals,
                    # values and gains from the SIMD loops
                    if pairs:
                        for c in range(n_ch):
                            ga[c] = 0.0
                            gb[c] = 0.0
                        p0 = int(W[_W_P0 * _CHUNK + i])
                        p1 = int(W[_W_P1 * _CHUNK + i])
                        ga[spk_ch[p0]] += W[_W_G00 * _CHUNK + i]
                        ga[nxt[p0]] += W[_W_G01 * _CHUNK + i]
                        gb[spk_ch[p1]] += W[_W_G10 * _CHUNK + i]
                        gb[nxt[p1]] += W[_W_G11 * _CHUNK + i]
                    elif dense:
                        for c in range(n_ch):
                            ga[c] = GT0[c, i]
                            gb[c] = GT1[c, i]
                    elif panned:
                        for c in range(n_ch):
                            ga[c] = G0[i, c]
                            gb[c] = G1[i, c]
                    nbad += _piece_across(
                        acc, base, blo, nb, n_ch, shift, n_samples, n, PD[ck, 0, i],
                        PD[ck, 1, i], PD[ck, 2, i], PD[ck, 3, i], tn, PD[ck, 4, i],
                        PD[ck, 5, i], PD[ck, 6, i], PD[ck, 7, i], cubic, tc, lc, vc, qc, ot, c0,
                        t_start, fs, spk_az, spk_ch, fold, pinv, panned, W[_W_A0 * _CHUNK + i],
                        W[_W_A1 * _CHUNK + i], int(W[_W_S0 * _CHUNK + i]),
                        int(W[_W_S1 * _CHUNK + i]), W[_W_F0 * _CHUNK + i],
                        W[_W_WF0 * _CHUNK + i] * fs, W[_W_F1 * _CHUNK + i],
                        W[_W_WF1 * _CHUNK + i] * fs, ga, gb, gx, gy, o, ctj, k_ct,
                    )  # fmt: skip
                    continue
                nbad += _piece_general(
                    acc, base, blo, nb, n_ch, shift, n_samples, n, int(RC[n, 11]), PD[ck, 0, i],
                    PD[ck, 1, i], PD[ck, 2, i], PD[ck, 3, i], tn, PD[ck, 4, i], PD[ck, 5, i],
                    PD[ck, 6, i], PD[ck, 7, i],
                    cubic, tc, lc, vc, qc, ot, c0, t_start, fs, spk_az, spk_ch, fold, pinv,
                    panned, ga, gb, gx, gy, o, ctj, k_ct,
                )  # fmt: skip
        n += 1
    return nbad


@numba.njit(inline="always", **_NJIT)
def _clear_window(acc, blk, n_ch, block, n_samples):  # type: ignore[no-untyped-def]
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
def _integrate(acc, task_blk, c_lo, c_hi, b, n_ch, block, n_samples, out):  # type: ignore[no-untyped-def]
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


@numba.njit(inline="always", **_NJIT)
def _knot_q(q, k, n, T, scale):  # type: ignore[no-untyped-def]
    """q/(4π) of source k at padded knot n (0 and T + 1 are the silent pads)."""
    if n < 1 or n > T:
        return 0.0
    return q[k, n - 1] * scale


@numba.njit(inline="always", **_NJIT)
def _knot_m(q, k, n, T, tn, scale):  # type: ignore[no-untyped-def]
    """Central-difference tangent dq/dτ at padded knot n (zero at the pads)."""
    if n < 1 or n > T:
        return 0.0
    return (_knot_q(q, k, n + 1, T, scale) - _knot_q(q, k, n - 1, T, scale)) / (
        tn[n + 1] - tn[n - 1]
    )


@numba.njit(**_NJIT)
def build_pieces(q, tn, pos, radius, cubic, counts_only, cptr, ccnt, PD):  # type: ignore[no-untyped-def]
    """The sounding pieces of tracks q (K, T) with padded knot times tn (T + 2),
    in chunks (see :func:`render`): piece n of source k (padded knots n, n + 1)
    sounds when q or (cubic) its tangent is non-zero at either knot.

    With ``counts_only`` returns the number of pieces per row (then the caller
    sizes cptr, ccnt, PD); else fills ccnt and PD.  Source-major, one pass
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
                    PD[ck, 0, ln] = pos[k, 0]
                    PD[ck, 1, ln] = pos[k, 1]
                    PD[ck, 2, ln] = pos[k, 2]
                    PD[ck, 3, ln] = max(radius[k], 1e-9)
                    PD[ck, 4, ln] = q_prev
                    PD[ck, 6, ln] = qn
                    if cubic:
                        PD[ck, 5, ln] = m_prev
                        PD[ck, 7, ln] = mn
                    else:
                        slope = (qn - q_prev) / (tn[n] - tn[r])
                        PD[ck, 5, ln] = slope
                        PD[ck, 7, ln] = slope
            q_prev = qn
            m_prev = mn
            nz_prev = nz
    if not counts_only:
        for r in range(Tp):
            for c in range(cptr[r], cptr[r + 1]):
                ccnt[c] = min(_CHUNK, cur[r] - (c - cptr[r]) * _CHUNK)
    return counts if counts_only else cur
