"""Panning laws for one direction (the scalar code, and :mod:`auralize.emitters._sampled`):
pairwise 2-D VBAP, 3-D VBAP and AmbiX encoding, in the listener's frame.

The laws are those of :mod:`auralize.spatial.layouts` and
:mod:`auralize.spatial.ambisonics` (:func:`_gains` dispatches on the table a
layout gives, see :func:`auralize.emitters.synthesis.pan_table`); the
listener's forward and up at a time come from its orientation table
(:func:`_orient`).  The SIMD versions over a chunk's lanes are in
:mod:`auralize.emitters._kernels.lane_gains`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from auralize.emitters._kernels.arrivals import _listener
from auralize.emitters._kernels.common import _NJIT, _NJIT_NORC


@numba.njit(inline="always", **_NJIT)
def _gains(direction, frame, spk_az, spk_ch, fold, pinv, out):
    """Panning gains ``out`` (power-normalised) for ``direction`` a = (ax, ay,
    az) in the listener's ``frame`` = (fx, fy, fz, ux, uy, uz), its forward f
    and up u: pairwise 2-D VBAP, or 3-D VBAP when ``pinv`` is a triangle
    table (12 columns, see :func:`_gains3`), or the AmbiX encoding gains when
    ``pinv`` is a spherical-harmonic table (2 columns, see :func:`_gains_sh`).

    left = u × f; azimuth counter-clockwise from forward.  ``fold`` mirrors
    rear directions to the front (2-speaker layouts).

    A horizontal layout with an arc of more than 180° (three front speakers;
    two speakers not both in front) gives ``pinv`` one row of 7 instead of
    pairs (:func:`auralize.emitters.synthesis.pan_table`): the index i of the
    arc's first speaker and the unit vectors (forward, left) of its two ends
    and of its middle.  A direction inside that arc goes whole to its nearer
    end: decided by the signs of cross products (when they are clear of
    round-off; else by the angles below), the gains are those of the angular
    law (exactly 1 and 0) without its atan2 and sines.  Two speakers both in
    front of a folding layout (stereo) give their pair alone, whose gains,
    the negative one clamped to 0, are the angular law's (to round-off) for
    every folded direction.
    """
    for c in range(out.size):
        out[c] = 0.0
    if spk_az.size == 0:
        out[0] = 1.0
        return
    xf, yl, zu = _direction_in_frame(direction, frame)
    if pinv.shape[1] == 12:
        _gains3(xf, yl, zu, pinv, out)
        return
    if pinv.shape[1] == 2:
        _gains_sh(xf, yl, zu, pinv, out)
        return
    _gains_plane(xf, yl, spk_az, spk_ch, fold, pinv, out)


@numba.njit(inline="always", **_NJIT)
def _direction_in_frame(direction, frame):
    """Coordinates (forward, left, up) of ``direction`` a = (ax, ay, az) in the
    listener's ``frame`` = (fx, fy, fz, ux, uy, uz), its forward f and up u;
    left = u × f."""
    ax, ay, az = direction
    fx, fy, fz, ux, uy, uz = frame
    lx, ly, lz = uy * fz - uz * fy, uz * fx - ux * fz, ux * fy - uy * fx
    return ax * fx + ay * fy + az * fz, ax * lx + ay * ly + az * lz, ax * ux + ay * uy + az * uz


@numba.njit(**_NJIT_NORC)
def _gains_called(direction, frame, spk_az, spk_ch, fold, pinv, out):
    """:func:`_gains` compiled once and called (see :func:`_pan_gains`)."""
    _gains(direction, frame, spk_az, spk_ch, fold, pinv, out)


@numba.njit(inline="always", **_NJIT)
def _pan_gains(direction, frame, spk_az, spk_ch, fold, pinv, out):
    """:func:`_gains` for the scalar code of the synthesis kernels: the laws of
    horizontal layouts inline, 3-D VBAP and AmbiX (the longer laws, a loop over the
    triangles or the harmonics per call) compiled once and called, so that the
    kernels that pan in several places do not compile them in every one."""
    if pinv.shape[1] == 12 or pinv.shape[1] == 2:
        _gains_called(direction, frame, spk_az, spk_ch, fold, pinv, out)
        return
    for c in range(out.size):
        out[c] = 0.0
    if spk_az.size == 0:
        out[0] = 1.0
        return
    xf, yl, _ = _direction_in_frame(direction, frame)
    _gains_plane(xf, yl, spk_az, spk_ch, fold, pinv, out)


@numba.njit(inline="always", **_NJIT)
def _gains_plane(xf, yl, spk_az, spk_ch, fold, pinv, out):
    """The gains of a horizontal layout (``out`` zeroed, at least one speaker) for the
    direction of forward and left coordinates (xf, yl) (see :func:`_gains`)."""
    n = spk_az.size
    if fold and xf < 0.0:
        xf = -xf
    if xf == 0.0 and yl == 0.0:
        # source straight above/below: spread evenly
        for i in range(n):
            out[spk_ch[i]] = 1.0 / math.sqrt(n)
        return
    if pinv.shape[1] == 7 and pinv.shape[0] == 1:
        near = _wide_end(xf, yl, pinv)
        if near >= 0:
            out[spk_ch[near % n]] = 1.0
            return
    # fast path (every arc < 180°): the pair whose inverse base gives both
    # gains >= 0 -- the same law as below without atan2 and sines.  Two
    # speakers in front of a folding layout give one pair, which takes every
    # direction: of its gains (never both negative in front) the negative one
    # is clamped to 0, and the nearer speaker takes all, as below
    npair = pinv.shape[0] if pinv.shape[1] == 4 else 0
    lo = -math.inf if fold and npair == 1 else -1e-12
    for i in range(npair):
        g0 = pinv[i, 0] * xf + pinv[i, 1] * yl
        g1 = pinv[i, 2] * xf + pinv[i, 3] * yl
        if g0 >= lo and g1 >= lo:
            g0 = max(g0, 0.0)
            g1 = max(g1, 0.0)
            norm = math.sqrt(g0 * g0 + g1 * g1)
            if norm > 0.0:  # (else the angular law: a direction too short to square)
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
    span = _python_mod(a1 - a0, two_pi)
    if span == 0.0:
        span = two_pi
    rel = _python_mod(phi - a0, two_pi)
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
def _python_mod(x, y):
    """``x % y`` for floats, as Python (and numba) define it: the remainder with the
    sign of y (of a zero remainder too), from ``np.fmod``.  numba compiles ``%`` as a
    call of its divmod helper, whose division and floor the caller throws away
    (inlined, LLVM removes them; called, they cost more than the remainder)."""
    mod = np.fmod(x, y)
    if mod != 0.0:
        if (y < 0.0) != (mod < 0.0):
            mod += y
    else:
        mod *= mod  # +0.0, as numba's divmod does it
        if y < 0.0:
            mod = -mod
    return mod


@numba.njit(inline="always", **_NJIT)
def _wide_end(xf, yl, tab):
    """The speaker index (i or i + 1) that takes the whole of direction (xf, yl)
    (forward, left) inside the arc of more than 180° from speaker i to i + 1,
    counter-clockwise, whose table row ``tab[0]`` = (i, its ends' unit
    vectors a and b, its middle m); -1 unless the direction is inside the
    arc and on one side of its middle by more than 1e-9 of its length (the
    caller then takes the angles).

    The rest of the circle, from b to a, spans less than 180°: a direction is
    inside the wide arc when it is clockwise of b or counter-clockwise of a,
    and nearer to a (its angle from a below half the arc) when it is
    clockwise of m."""
    ax, ay, bx, by, mx, my = tab[0, 1], tab[0, 2], tab[0, 3], tab[0, 4], tab[0, 5], tab[0, 6]
    eps = 1e-9 * (abs(xf) + abs(yl))
    inside = (bx * yl - by * xf < -eps) or (xf * ay - yl * ax < -eps)
    side = mx * yl - my * xf
    i = int(tab[0, 0])
    if not inside or abs(side) <= eps:
        return -1
    return i if side < 0.0 else i + 1


@numba.njit(inline="always", **_NJIT)
def _gains3(x, y, z, tab, out):
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
def _gains_sh(x, y, z, tab, out):
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
def _orient(orient_table, orient_clock, t, out):
    """Listener forward and up at data time t from the orientation table.

    ``orient_table (N, 6)`` holds forward and up sampled (by quaternion slerp between
    captures, see :mod:`auralize.listener`) every ``1/orient_clock[1]`` s from ``orient_clock[0]``;
    linear interpolation between ~1 ms samples is accurate to ~1e-7.
    """
    n = orient_table.shape[0]
    u = (t - orient_clock[0]) * orient_clock[1]
    if n == 1 or u <= 0.0:
        for c in range(6):
            out[c] = orient_table[0, c]
        return
    if u >= n - 1:
        for c in range(6):
            out[c] = orient_table[n - 1, c]
        return
    i = int(u)
    w = u - i
    for c in range(6):
        out[c] = orient_table[i, c] + w * (orient_table[i + 1, c] - orient_table[i, c])


@numba.njit(inline="always", **_NJIT)
def _pan(x, y, z, t, s, lis, pan, g, frame):
    """Panning gains ``g`` of a source at (x, y, z) heard at time t on capture
    interval s of the listener's path ``lis`` (a
    :class:`~auralize.emitters._kernels.common.Listener`), by the law of
    ``pan`` (a :class:`~auralize.emitters._kernels.common.Panning`);
    ``frame (6)`` scratch for the listener's forward and up."""
    lx, ly, lz, _, _, _ = _listener(lis.times, lis.pos, lis.vel, t, s)
    _orient(lis.orient_table, lis.orient_clock, t, frame)
    o = frame
    _pan_gains(
        (x - lx, y - ly, z - lz),
        (o[0], o[1], o[2], o[3], o[4], o[5]),
        pan.spk_az,
        pan.spk_ch,
        pan.fold,
        pan.pinv,
        g,
    )


@numba.njit(**_NJIT_NORC)
def _pan_far(x, y, z, t, s, lis, pan, g, frame):
    """:func:`_pan` compiled once and called, for the paths a render takes
    rarely (a piece over several accumulation blocks, the general fallback,
    the run kernel's panned pieces): inlining every copy of the listener,
    orientation and gain laws there would lengthen the cold compile.  The
    hot loops inline :func:`_pan` instead (a call there, with its arrays,
    is slower; ``auralize bench`` measures the renders)."""
    _pan(x, y, z, t, s, lis, pan, g, frame)


@numba.njit(**_NJIT_NORC)
def _constant_rows(orient_table):
    """Whether every row of the orientation table orient_table equals its first.

    Typed ``bool``: a flag initialised from the literal ``True`` (or a
    counter from ``0``) and passed to a compiled, not inlined, kernel types
    first as ``Literal[bool](True)`` and then as ``bool``, and numba compiles
    that kernel, and everything it calls, once for each: a second cold
    compile for nothing."""
    n_diff = 0
    for j in range(1, orient_table.shape[0]):
        for c in range(orient_table.shape[1]):
            n_diff += 1 if orient_table[j, c] != orient_table[0, c] else 0
    return n_diff == 0
