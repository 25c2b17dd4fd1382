"""Compiled inner loops (numba) for source detection.

numba is used here because each kernel is a fused stencil over every voxel:
written in numpy, the quadrupole term alone needs ~20 full-size temporaries
and the whole detection ~15 ms per 64³ step; fused, it reads each input once.
Everything else in the package stays numpy.  Kernels are pure functions on
arrays in the ``(nz, ny, nx)`` layout of :mod:`auralize.volume`.

Finite differences (second order, on the uniform grid of spacing ``h``):

* first derivative: central ``(f[i+1] - f[i-1]) / 2h``, one-sided at the borders;
* second derivative: ``(f[i+1] - 2 f[i] + f[i-1]) / h²``, the stencil shifted
  inwards at the borders (zero on axes with fewer than 3 points);
* mixed derivative: the tensor product of two first derivatives.

No-data points (outside the input mesh, NaN in a frame) are handled by
:func:`mask_nodata` after the stencils: a strength whose stencil reads a
no-data point is itself no-data (zero), rather than a one-sided difference,
so no value is ever extrapolated from the points that remain.
"""

from __future__ import annotations

import itertools
import threading
from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np

from auralize.runtime.jit import configure as _configure_numba

_configure_numba()  # cache folder, OMP wait policy, compile notice

_NJIT = {"cache": True, "fastmath": False, "nogil": True}
#: functions only compiled code calls: no wrappers for calls from Python
_INNER = {**_NJIT, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}

NONE, MONOPOLE, DIPOLE, QUADRUPOLE = 0, 1, 2, 3
#: ΔV rules of :func:`classify_and_radius`
DV_CELL, DV_SPHERE = 0, 1


@numba.njit(inline="always", **_INNER)
def _lohi(i: int, n: int) -> tuple[int, int]:
    lo = i - 1 if i > 0 else 0
    hi = i + 1 if i < n - 1 else n - 1
    return lo, hi


@numba.njit(inline="always", **_INNER)
def _inner(i: int, n: int) -> int:
    """Centre of a 3-point stencil kept inside [0, n) (i itself if n < 3)."""
    if n < 3:
        return i
    if i < 1:
        return 1
    if i > n - 2:
        return n - 2
    return i


#: the bits of a float64 but its sign, and those of +inf: the bit patterns of values >= 0
#: order as int64 as the values do, every NaN's above +inf's
_ABS_BITS = np.int64(0x7FFFFFFFFFFFFFFF)
_INF_BITS = np.int64(0x7FF0000000000000)
#: points of the buffers of the compiled maxima (a few kB: in the first-level cache)
CHUNK = 512


@numba.njit(**_INNER)
def _top_bits(x, nan_ignored):  # type: ignore[no-untyped-def]
    """The largest |value| of the contiguous float64 run ``x`` as its bit pattern (0 at
    least): a NaN's when one is there, or (``nan_ignored``) NaN counted as 0.

    An integer maximum over the bit patterns is the float one and vectorizes (a
    float maximum, for its NaN rule, does not); ``.view(np.float64)`` turns the
    patterns back into values.
    """
    b = x.view(np.int64)
    top = np.int64(0)
    for p in range(b.size):
        v = b[p] & _ABS_BITS
        if nan_ignored:
            v = v if v <= _INF_BITS else 0
        top = v if v > top else top
    return top


@numba.njit(**_INNER)
def _momentum_plane(rho_a, v_a, rho_b, v_b, dm, o):  # type: ignore[no-untyped-def]
    """``dm[:, o]`` = ``ρ_b v_b − ρ_a v_a`` of one plane's densities ``(ny, nx)`` and
    velocities ``(ny, nx, 3)``."""
    m = rho_a.size
    ra, rb = rho_a.reshape(m), rho_b.reshape(m)
    fa, fb = v_a.reshape(3 * m), v_b.reshape(3 * m)
    dx, dy, dz = dm[0, o].reshape(m), dm[1, o].reshape(m), dm[2, o].reshape(m)
    for p in range(m):
        dx[p] = rb[p] * fb[3 * p] - ra[p] * fa[3 * p]
        dy[p] = rb[p] * fb[3 * p + 1] - ra[p] * fa[3 * p + 1]
        dz[p] = rb[p] * fb[3 * p + 2] - ra[p] * fa[3 * p + 2]


@numba.njit(parallel=True, **_NJIT)
def momentum_change(rho_a, v_a, rho_b, v_b, dm):  # type: ignore[no-untyped-def]
    """Planar momentum change ``dm (3, nz, ny, nx)`` = ``ρ_b v_b − ρ_a v_a`` of densities
    ``(nz, ny, nx)`` and velocities ``(nz, ny, nx, 3)`` (the time difference of the mass
    flux in the dipole strength, paper 003 Eq. 13), the momenta not made: the same
    numbers as ``m_b - m_a`` of ``m = rho[..., None] * v``."""
    for kp in numba.prange(dm.shape[1]):
        k = np.int64(kp)
        _momentum_plane(rho_a[k], v_a[k], rho_b[k], v_b[k], dm, k)


@numba.njit(**_INNER)
def _stress_plane(rho, v, tt, o):  # type: ignore[no-untyped-def]
    """``tt[:, o]`` = ρ v_i v_j (xx, yy, zz, xy, xz, yz) of one plane ``(ny, nx)``."""
    m = rho.size
    r, f = rho.reshape(m), v.reshape(3 * m)
    txx, tyy, tzz = tt[0, o].reshape(m), tt[1, o].reshape(m), tt[2, o].reshape(m)
    txy, txz, tyz = tt[3, o].reshape(m), tt[4, o].reshape(m), tt[5, o].reshape(m)
    for p in range(m):
        rr = r[p]
        vx, vy, vz = f[3 * p], f[3 * p + 1], f[3 * p + 2]
        txx[p] = rr * vx * vx
        tyy[p] = rr * vy * vy
        tzz[p] = rr * vz * vz
        txy[p] = rr * vx * vy
        txz[p] = rr * vx * vz
        tyz[p] = rr * vy * vz


@numba.njit(parallel=True, **_NJIT)
def stress(rho, v, tt):  # type: ignore[no-untyped-def]
    """Lighthill stress ``tt (6, nz, ny, nx)`` = ρ v_i v_j (order xx, yy, zz, xy, xz, yz;
    paper 003 Eq. 11) of ``rho (nz, ny, nx)`` and ``v (nz, ny, nx, 3)``."""
    for kp in numba.prange(tt.shape[1]):
        k = np.int64(kp)
        _stress_plane(rho[k], v[k], tt, k)


@numba.njit(**_INNER)
def _input_maxima_plane(r, f, out):  # type: ignore[no-untyped-def]
    """``out (3,)`` int64 = the bit patterns (:func:`_top_bits`) of ``(max|ρ|, max|ρv|,
    max|ρv ∘ v|)`` over a plane's flat ``r (m,)`` and ``f (3 m,)`` (velocities): each at
    least 0, NaN if any value is.  The products go through small buffers a chunk at
    a time."""
    m = r.size
    bm, bt = np.empty(3 * CHUNK), np.empty(3 * CHUNK)
    out[0] = _top_bits(r, False)
    out[1] = 0
    out[2] = 0
    for p0 in range(0, m, CHUNK):
        n = min(CHUNK, m - p0)
        for p in range(n):
            rr = r[p0 + p]
            for q in range(3):
                mq = rr * f[3 * (p0 + p) + q]
                bm[3 * p + q] = mq
                bt[3 * p + q] = mq * f[3 * (p0 + p) + q]
        out[1] = max(out[1], _top_bits(bm[: 3 * n], False))
        out[2] = max(out[2], _top_bits(bt[: 3 * n], False))


@numba.njit(**_INNER)
def _strength_point(rho_a, rho_b, dm, tt, inv_dt, h, k, j, i, out, o):  # type: ignore[no-untyped-def]
    """The strengths of point ``(k, j, i)`` into ``out[:, o, j, i]`` (see :func:`strengths`;
    planes as :func:`_strength_plane`)."""
    nz, ny, nx = rho_a.shape
    R = dm.shape[1]
    hx, hy, hz = h[0], h[1], h[2]
    gx = 1.0 / (hx * hx) if nx >= 3 else 0.0
    gy = 1.0 / (hy * hy) if ny >= 3 else 0.0
    gz = 1.0 / (hz * hz) if nz >= 3 else 0.0
    k0, k1 = _lohi(k, nz)
    kc = _inner(k, nz)
    fz = 1.0 / ((k1 - k0) * hz) if k1 > k0 else 0.0
    q, q0, q1 = k % R, k0 % R, k1 % R
    qm, qc, qp = (kc - 1) % R, kc % R, (kc + 1) % R
    j0, j1 = _lohi(j, ny)
    jc = _inner(j, ny)
    fy = 1.0 / ((j1 - j0) * hy) if j1 > j0 else 0.0
    i0, i1 = _lohi(i, nx)
    ic = _inner(i, nx)
    fx = 1.0 / ((i1 - i0) * hx) if i1 > i0 else 0.0
    out[0, o, j, i] = (rho_b[k, j, i] - rho_a[k, j, i]) * inv_dt
    div = (
        (dm[0, q, j, i1] - dm[0, q, j, i0]) * fx
        + (dm[1, q, j1, i] - dm[1, q, j0, i]) * fy
        + (dm[2, q1, j, i] - dm[2, q0, j, i]) * fz
    )
    out[1, o, j, i] = div * inv_dt
    # diagonal terms: 3-point second differences (stencil kept inside)
    s = 0.0
    if nx >= 3:
        s += (tt[0, q, j, ic + 1] - 2.0 * tt[0, q, j, ic] + tt[0, q, j, ic - 1]) * gx
    if ny >= 3:
        s += (tt[1, q, jc + 1, i] - 2.0 * tt[1, q, jc, i] + tt[1, q, jc - 1, i]) * gy
    if nz >= 3:
        s += (tt[2, qp, j, i] - 2.0 * tt[2, qc, j, i] + tt[2, qm, j, i]) * gz
    # off-diagonal terms, each twice (T_ij = T_ji); zero factors on flat axes
    s += (2.0 * fx * fy) * (
        tt[3, q, j1, i1] - tt[3, q, j1, i0] - tt[3, q, j0, i1] + tt[3, q, j0, i0]
    )
    s += (2.0 * fx * fz) * (
        tt[4, q1, j, i1] - tt[4, q1, j, i0] - tt[4, q0, j, i1] + tt[4, q0, j, i0]
    )
    s += (2.0 * fy * fz) * (
        tt[5, q1, j1, i] - tt[5, q1, j0, i] - tt[5, q0, j1, i] + tt[5, q0, j0, i]
    )
    out[2, o, j, i] = s


@numba.njit(**_INNER)
def _run(a, start, n, c, kk, d):  # type: ignore[no-untyped-def]
    """The ``n`` points from ``start + d`` of plane ``kk`` (at slot ``kk % R``, R the planes
    of ``a``) of component ``c`` of the flat stacks ``a (C, R, ny nx)``."""
    return a[c, kk % a.shape[1], start + d : start + d + n]


#: how a run loop (:func:`_diff_over` and the like) stores its term t: ``out = t``,
#: ``out = 0.0 + t`` (the first term of a sum started at 0) or ``out = out + t``
SET, FIRST, ADD = 0, 1, 2


@numba.njit(**_INNER)
def _diff_over(out, a, b, d, mode):  # type: ignore[no-untyped-def]
    """Along a run: t = (a - b) / d, stored by ``mode``.

    The run loops are small functions, one operation each, that the stencils
    call on one-dimensional runs of the planes (:func:`_error_rows`,
    :func:`_strength_rows`): each compiles once, reads a few runs, and the
    compiler turns it into vector instructions.
    """
    for i in range(out.size):
        t = (a[i] - b[i]) / d
        out[i] = t if mode == SET else (0.0 + t if mode == FIRST else out[i] + t)


@numba.njit(**_INNER)
def _diff_times(out, a, b, f, mode):  # type: ignore[no-untyped-def]
    """Along a run: t = (a - b) * f, stored by ``mode``."""
    for i in range(out.size):
        t = (a[i] - b[i]) * f
        out[i] = t if mode == SET else (0.0 + t if mode == FIRST else out[i] + t)


@numba.njit(**_INNER)
def _second_times(out, p, c, m, g, mode):  # type: ignore[no-untyped-def]
    """Along a run: t = (p - 2 c + m) g (a second difference), stored by ``mode``."""
    for i in range(out.size):
        t = (p[i] - 2.0 * c[i] + m[i]) * g
        out[i] = t if mode == SET else (0.0 + t if mode == FIRST else out[i] + t)


@numba.njit(**_INNER)
def _second_over(out, p, c, m, p2, m2, d, mode):  # type: ignore[no-untyped-def]
    """Along a run: t = ((p - 2 c + m) - (p2 - 2 c + m2) / 4) / d, the second difference
    over h less the one over 2h (:func:`_error_point`), stored by ``mode``."""
    for i in range(out.size):
        a = p[i] - 2.0 * c[i] + m[i]
        b = 0.25 * (p2[i] - 2.0 * c[i] + m2[i])
        t = (a - b) / d
        out[i] = t if mode == SET else (0.0 + t if mode == FIRST else out[i] + t)


@numba.njit(**_INNER)
def _pair_over(oa, a1, a2, da, ob, b1, b2, db):  # type: ignore[no-untyped-def]
    """Along a run: oa = 0.0 + (a1 - a2) / da and ob = 0.0 + (b1 - b2) / db (two first terms
    of sums, :data:`FIRST`, in one loop)."""
    for i in range(oa.size):
        oa[i] = 0.0 + (a1[i] - a2[i]) / da
        ob[i] = 0.0 + (b1[i] - b2[i]) / db


@numba.njit(**_INNER)
def _gap_of_divergences(ed, eq, em, q1, q2, dq1, q3, q4, dq2, m1, m2, dm1, m3, m4, dm2, f):  # type: ignore[no-untyped-def]
    """Along a run: the y and z terms ``(q1 - q2) / dq1``, ``(q3 - q4) / dq2`` added to the 2h
    divergence ``eq``, ``(m1 - m2) / dm1``, ``(m3 - m4) / dm2`` to the h one ``em`` (each sum
    in its order), and ed = |em - eq| f / 3 (a Richardson estimate, :func:`_error_point`)."""
    for i in range(ed.size):
        q = eq[i] + (q1[i] - q2[i]) / dq1
        q = q + (q3[i] - q4[i]) / dq2
        e = em[i] + (m1[i] - m2[i]) / dm1
        e = e + (m3[i] - m4[i]) / dm2
        ed[i] = abs(e - q) * f / 3.0


@numba.njit(**_INNER)
def _rest_of_divergence(ed, em, s, y1, y2, dy, z1, z2, dz, f):  # type: ignore[no-untyped-def]
    """Along a run: the y and z terms ``(y1 - y2) / dy``, ``(z1 - z2) / dz`` added to the
    divergence ``em``, and ed = ed + |s - em f| / 3 (a strength less its 2Δt stencil)."""
    for i in range(ed.size):
        e = em[i] + (y1[i] - y2[i]) / dy
        e = e + (z1[i] - z2[i]) / dz
        ed[i] = ed[i] + abs(s[i] - e * f) / 3.0


@numba.njit(**_INNER)
def _second_pair_over(out, yp, yc, ym, yp2, ym2, dy, zp, zc, zm, zp2, zm2, dz):  # type: ignore[no-untyped-def]
    """Along a run: two terms of :func:`_second_over` (over ``dy``, then ``dz``) added to
    ``out``, in that order."""
    for i in range(out.size):
        a = yp[i] - 2.0 * yc[i] + ym[i]
        b = 0.25 * (yp2[i] - 2.0 * yc[i] + ym2[i])
        q = out[i] + (a - b) / dy
        a = zp[i] - 2.0 * zc[i] + zm[i]
        b = 0.25 * (zp2[i] - 2.0 * zc[i] + zm2[i])
        out[i] = q + (a - b) / dz


#: :func:`_mixed_pair` stores ``|out + t| / 3``: the last term of a sum, and its estimate
LAST = 3


@numba.njit(**_INNER)
def _mixed_pair(out, pp, pm, mp, mm, pp2, pm2, mp2, mm2, d, mode):  # type: ignore[no-untyped-def]
    """Along a run: t = 2 (w - w2) / d, ``w = (pp - pm - mp + mm) / 4`` and ``w2 = (pp2 - pm2 -
    mp2 + mm2) / 16``, the mixed differences over h and 2h (each term twice), stored by
    ``mode`` (:data:`SET`, :data:`ADD` or :data:`LAST`)."""
    for i in range(out.size):
        w = (pp[i] - pm[i] - mp[i] + mm[i]) / 4.0
        w2 = (pp2[i] - pm2[i] - mp2[i] + mm2[i]) / 16.0
        t = 2.0 * (w - w2) / d
        if mode == SET:
            out[i] = t
        elif mode == ADD:
            out[i] = out[i] + t
        else:
            out[i] = abs(out[i] + t) / 3.0


@numba.njit(**_INNER)
def _third_of_change(out, s, b, a, f):  # type: ignore[no-untyped-def]
    """Along a run: out = |s - ((b - a) 1) f| / 3 (a strength less its 2Δt time stencil)."""
    for i in range(out.size):
        out[i] = abs(s[i] - ((b[i] - a[i]) * 1.0) * f) / 3.0


@numba.njit(**_INNER)
def _cross_times(out, pp, pm, mp, mm, f, mode):  # type: ignore[no-untyped-def]
    """Along a run: t = f (pp - pm - mp + mm), stored by ``mode``."""
    for i in range(out.size):
        t = f * (pp[i] - pm[i] - mp[i] + mm[i])
        out[i] = t if mode == SET else (0.0 + t if mode == FIRST else out[i] + t)


@numba.njit(**_INNER)
def _diff_pair_times(out, y1, y2, fy, z1, z2, fz, g):  # type: ignore[no-untyped-def]
    """Along a run: out = ((out + (y1 - y2) fy) + (z1 - z2) fz) g (two terms of
    :func:`_diff_times` added, then the sum scaled, in one loop)."""
    for i in range(out.size):
        t = out[i] + (y1[i] - y2[i]) * fy
        out[i] = (t + (z1[i] - z2[i]) * fz) * g


@numba.njit(**_INNER)
def _second_pair_times(out, yp, yc, ym, gy, zp, zc, zm, gz):  # type: ignore[no-untyped-def]
    """Along a run: two terms of :func:`_second_times` (times ``gy``, then ``gz``) added to
    ``out``, in that order."""
    for i in range(out.size):
        t = out[i] + (yp[i] - 2.0 * yc[i] + ym[i]) * gy
        out[i] = t + (zp[i] - 2.0 * zc[i] + zm[i]) * gz


@numba.njit(**_INNER)
def _add_cross(out, a, pp, pm, mp, mm, f):  # type: ignore[no-untyped-def]
    """Along a run: out = (out + a) + f (pp - pm - mp + mm) (:func:`_add_run`, then a term of
    :func:`_cross_times`, in one loop)."""
    for i in range(out.size):
        t = out[i] + a[i]
        out[i] = t + f * (pp[i] - pm[i] - mp[i] + mm[i])


@numba.njit(**_INNER)
def _add_run(out, a):  # type: ignore[no-untyped-def]
    """Along a run: out = out + a."""
    for i in range(out.size):
        out[i] = out[i] + a[i]


@numba.njit(**_INNER)
def _strength_rows(rho_a, rho_b, dm, tt, inv_dt, h, k, j, r, out, o):  # type: ignore[no-untyped-def]
    """:func:`_strength_point` at every point of the ``r`` rows from ``j`` on of plane ``k``
    (``nx`` >= 3; ``r`` is 1 or the rows are all inner, 1 .. ny-2).

    The same operations in the same order, point by point, grouped as in
    :func:`_error_rows`: run loops along the rows as one flat run.  A term
    with an x difference is taken along the run at x = 1 .. nx-2 (wrong at
    each end of a row, which reads the next row), then at x = 0 and nx-1:
    copied from the next point in for the second difference (its stencil is
    kept inside, :func:`_inner`), one-sided for the first differences.  The
    monopole strength's run holds the mixed x terms until it is written last.
    """
    nz, ny, nx = rho_a.shape
    R = dm.shape[1]
    hx, hy, hz = h[0], h[1], h[2]
    gx = 1.0 / (hx * hx)
    gy = 1.0 / (hy * hy) if ny >= 3 else 0.0
    gz = 1.0 / (hz * hz) if nz >= 3 else 0.0
    k0, k1 = _lohi(k, nz)
    kc = _inner(k, nz)
    fz = 1.0 / ((k1 - k0) * hz) if k1 > k0 else 0.0
    j0, j1 = _lohi(j, ny)
    jc = _inner(j, ny)
    fy = 1.0 / ((j1 - j0) * hy) if j1 > j0 else 0.0
    fx, fx1 = 1.0 / (2 * hx), 1.0 / (1 * hx)  # inside, at the faces
    m = ny * nx
    p0, n = j * nx, r * nx  # the run: its first point (flat) and length
    dm_, tt_ = dm.reshape(3, R, m), tt.reshape(6, R, m)
    ra, rb = rho_a.reshape(nz, m)[k, p0 : p0 + n], rho_b.reshape(nz, m)[k, p0 : p0 + n]
    flat = out.reshape(3, out.shape[1], m)
    sm, sd, sq = flat[0, o, p0 : p0 + n], flat[1, o, p0 : p0 + n], flat[2, o, p0 : p0 + n]
    ym, yp, yc = (j0 - j) * nx, (j1 - j) * nx, (jc - j) * nx  # row offsets

    # dipole: x first (in sd), one-sided at the faces
    _diff_times(
        sd[1 : n - 1],
        _run(dm_, p0 + 1, n - 2, 0, k, 1),
        _run(dm_, p0 + 1, n - 2, 0, k, -1),
        fx,
        SET,
    )
    xd = _run(dm_, p0, n, 0, k, 0)
    for q in range(r):
        e, g = q * nx, q * nx + nx - 1
        sd[e] = (xd[e + 1] - xd[e]) * fx1
        sd[g] = (xd[g] - xd[g - 1]) * fx1
    _diff_pair_times(
        sd,
        _run(dm_, p0, n, 1, k, yp),
        _run(dm_, p0, n, 1, k, ym),
        fy,
        _run(dm_, p0, n, 2, k1, 0),
        _run(dm_, p0, n, 2, k0, 0),
        fz,
        inv_dt,
    )
    # quadrupole: second differences, x first (kept inside: the face copies the next in)
    _second_times(
        sq[1 : n - 1],
        _run(tt_, p0 + 1, n - 2, 0, k, 1),
        _run(tt_, p0 + 1, n - 2, 0, k, 0),
        _run(tt_, p0 + 1, n - 2, 0, k, -1),
        gx,
        FIRST,
    )
    for q in range(r):
        e, g = q * nx, q * nx + nx - 1
        sq[e] = sq[e + 1]
        sq[g] = sq[g - 1]
    if ny >= 3 and nz >= 3:
        _second_pair_times(
            sq,
            _run(tt_, p0, n, 1, k, yc + nx),
            _run(tt_, p0, n, 1, k, yc),
            _run(tt_, p0, n, 1, k, yc - nx),
            gy,
            _run(tt_, p0, n, 2, kc + 1, 0),
            _run(tt_, p0, n, 2, kc, 0),
            _run(tt_, p0, n, 2, kc - 1, 0),
            gz,
        )
    elif ny >= 3:
        _second_times(
            sq,
            _run(tt_, p0, n, 1, k, yc + nx),
            _run(tt_, p0, n, 1, k, yc),
            _run(tt_, p0, n, 1, k, yc - nx),
            gy,
            ADD,
        )
    elif nz >= 3:
        _second_times(
            sq,
            _run(tt_, p0, n, 2, kc + 1, 0),
            _run(tt_, p0, n, 2, kc, 0),
            _run(tt_, p0, n, 2, kc - 1, 0),
            gz,
            ADD,
        )
    # mixed xy and xz (each in sm first, one-sided at the faces) added, and yz with xz
    for c in range(2):
        if c == 0:
            cc, kp, km, dp, dn, f2 = 3, k, k, yp, ym, fy
        else:
            cc, kp, km, dp, dn, f2 = 4, k1, k0, 0, 0, fz
        _cross_times(
            sm[1 : n - 1],
            _run(tt_, p0 + 1, n - 2, cc, kp, dp + 1),
            _run(tt_, p0 + 1, n - 2, cc, kp, dp - 1),
            _run(tt_, p0 + 1, n - 2, cc, km, dn + 1),
            _run(tt_, p0 + 1, n - 2, cc, km, dn - 1),
            2.0 * fx * f2,
            SET,
        )
        xp, xm = _run(tt_, p0, n, cc, kp, dp), _run(tt_, p0, n, cc, km, dn)
        for q in range(r):
            e, g = q * nx, q * nx + nx - 1
            sm[e] = (2.0 * fx1 * f2) * (xp[e + 1] - xp[e] - xm[e + 1] + xm[e])
            sm[g] = (2.0 * fx1 * f2) * (xp[g] - xp[g - 1] - xm[g] + xm[g - 1])
        if c == 0:
            _add_run(sq, sm)
    _add_cross(
        sq,
        sm,
        _run(tt_, p0, n, 5, k1, yp),
        _run(tt_, p0, n, 5, k1, ym),
        _run(tt_, p0, n, 5, k0, yp),
        _run(tt_, p0, n, 5, k0, ym),
        2.0 * fy * fz,
    )
    # monopole
    _diff_times(sm, rb, ra, inv_dt, SET)


@numba.njit(**_INNER)
def _strength_plane(rho_a, rho_b, dm, tt, inv_dt, h, k, out, o):  # type: ignore[no-untyped-def]
    """The strengths of plane ``k`` into ``out[:, o]`` (see :func:`strengths`):
    :func:`_strength_rows` (its inner rows at once), or :func:`_strength_point` at each
    point of a grid of fewer than 3 points along x.

    ``rho_a, rho_b (nz, ny, nx)``; ``dm (3, R, ny, nx)`` and ``tt (6, R, ny, nx)`` hold
    planes at slots ``plane % R``: every plane (R = nz) or the last R of a sweep.
    """
    ny, nx = rho_a.shape[1], rho_a.shape[2]
    if nx < 3:
        for j in range(ny):
            for i in range(nx):
                _strength_point(rho_a, rho_b, dm, tt, inv_dt, h, k, j, i, out, o)
        return
    j = 0
    while j < ny:  # the first row, the inner ones at once, the last
        r = ny - 2 if j == 1 and ny > 2 else 1
        _strength_rows(rho_a, rho_b, dm, tt, inv_dt, h, k, j, r, out, o)
        j += r


def strengths(rho_a, rho_b, dm, tt, inv_dt, h, out):  # type: ignore[no-untyped-def]
    """Monopole, dipole and quadrupole strengths at every vertex of one step.

    Paper 003 §3.2.3: ``S_m = ∂ρ/∂t``, ``S_d = ∂/∂x_i (∂(ρ v_i)/∂t)`` (Eq. 13),
    ``S_q = Σ_ij ∂²(ρ v_i v_j)/∂x_i ∂x_j`` (Eq. 14, all nine terms).

    Parameters
    ----------
    rho_a, rho_b : (nz, ny, nx) densities at the earlier and later step.
    dm : (3, nz, ny, nx) their momentum change (:func:`momentum_change`).
    tt : (6, nz, ny, nx) the stress at the step itself (:func:`stress`).
    inv_dt : 1 / (t_b - t_a).
    h : (3,) spacing (x, y, z).
    out : (3, nz, ny, nx) result, written in place.
    """
    h = np.asarray(h, dtype=np.float64)
    over_planes(
        lambda lo, hi: _strength_planes(rho_a, rho_b, dm, tt, float(inv_dt), h, out, lo, hi),
        rho_a.shape,
    )


@numba.njit(inline="always", **_INNER)
def _classify(sm: float, sd: float, sq: float, thr, zero) -> int:  # type: ignore[no-untyped-def]
    """Exclusive classification of paper 003 §3.2.3 (thresholds on magnitudes)."""
    am, ad, aq = abs(sm), abs(sd), abs(sq)
    if am > thr[0]:
        return MONOPOLE
    if ad > thr[1] and am <= zero[0]:
        return DIPOLE
    if aq > thr[2] and am <= zero[0] and ad <= zero[1]:
        return QUADRUPOLE
    return NONE


@numba.njit(inline="always", **_INNER)
def _cut(s, kinds, kind, thr, own, k, j, i, half):  # type: ignore[no-untyped-def]
    """Cut distance from a source point towards neighbour (k, j, i) (§3.2.4.1).

    Half the edge when the neighbour is a source of the same type (or the
    strength does not fall below the threshold along the edge), otherwise the
    linearly interpolated crossing of |S| with the threshold.
    """
    if kinds[k, j, i] == kind:
        return half
    other = abs(s[kind - 1, k, j, i])
    t = thr[kind - 1]
    if other >= t:
        return half
    return 2.0 * half * (own - t) / (own - other)


@numba.njit(parallel=True, **_NJIT)
def _classify_all(s, thr, zero, kind_out):  # type: ignore[no-untyped-def]
    _, nz, ny, nx = s.shape
    for kp in numba.prange(nz):
        k = np.int64(kp)
        for j in range(ny):
            for i in range(nx):
                kind_out[k, j, i] = _classify(
                    s[0, k, j, i], s[1, k, j, i], s[2, k, j, i], thr, zero
                )


@numba.njit(inline="always", **_INNER)
def _radius_at(s, kinds, thr, h, rule, k, j, i):  # type: ignore[no-untyped-def]
    """The ΔV radius of the source point ``(k, j, i)`` (see :func:`classify_and_radius`)."""
    _, nz, ny, nx = s.shape
    hx, hy, hz = 0.5 * h[0], 0.5 * h[1], 0.5 * h[2]
    kind = kinds[k, j, i]
    own = abs(s[kind - 1, k, j, i])
    # cut distances along -x, +x, -y, +y, -z, +z (-1: no edge)
    cxm = _cut(s, kinds, kind, thr, own, k, j, i - 1, hx) if i > 0 else -1.0
    cxp = _cut(s, kinds, kind, thr, own, k, j, i + 1, hx) if i < nx - 1 else -1.0
    cym = _cut(s, kinds, kind, thr, own, k, j - 1, i, hy) if j > 0 else -1.0
    cyp = _cut(s, kinds, kind, thr, own, k, j + 1, i, hy) if j < ny - 1 else -1.0
    czm = _cut(s, kinds, kind, thr, own, k - 1, j, i, hz) if k > 0 else -1.0
    czp = _cut(s, kinds, kind, thr, own, k + 1, j, i, hz) if k < nz - 1 else -1.0
    if rule == DV_SPHERE:
        acc = 0.0
        n = 0
        for c in (cxm, cxp, cym, cyp, czm, czp):
            if c >= 0.0:
                acc += c
                n += 1
        return acc / n if n > 0 else (hx + hy + hz) / 3.0
    # the vertex's share of the source region: a box reaching the cut on each side;
    # no edge = grid border (half a cell), a single-point axis counts its whole spacing
    ex = 2.0 * hx if nx == 1 else max(cxm, 0.0) + max(cxp, 0.0)
    ey = 2.0 * hy if ny == 1 else max(cym, 0.0) + max(cyp, 0.0)
    ez = 2.0 * hz if nz == 1 else max(czm, 0.0) + max(czp, 0.0)
    return (ex * ey * ez / (4.0 * np.pi / 3.0)) ** (1.0 / 3.0)


@numba.njit(parallel=True, **_NJIT)
def _radii(s, kinds, thr, h, rule, radius_out):  # type: ignore[no-untyped-def]
    _, nz, ny, nx = s.shape
    for kp in numba.prange(nz):
        k = np.int64(kp)
        for j in range(ny):
            for i in range(nx):
                if kinds[k, j, i] == NONE:
                    radius_out[k, j, i] = 0.0
                else:
                    radius_out[k, j, i] = _radius_at(s, kinds, thr, h, rule, k, j, i)


@numba.njit(**_INNER)
def _classify_run(kinds, sm, sd, sq, thr, zero):  # type: ignore[no-untyped-def]
    """:func:`_classify` along a run (the same classes, as selects, which vectorize), and
    the number of sources in it."""
    t0, t1, t2, z0, z1 = thr[0], thr[1], thr[2], zero[0], zero[1]
    c = 0
    for i in range(kinds.size):
        am, ad, aq = abs(sm[i]), abs(sd[i]), abs(sq[i])
        kind = QUADRUPOLE if aq > t2 and am <= z0 and ad <= z1 else NONE
        kind = DIPOLE if ad > t1 and am <= z0 else kind
        kind = MONOPOLE if am > t0 else kind
        kinds[i] = kind
        c += kind != NONE
    return c


@numba.njit(**_NJIT)
def _classify_planes(s, thr, zero, kinds, count, lo, hi):  # type: ignore[no-untyped-def]
    """Classes of the points of planes ``[lo, hi)`` into ``kinds``, their sources counted
    per plane into ``count``."""
    _, nz, ny, nx = s.shape
    m = ny * nx
    flat, kf = s.reshape(3, nz, m), kinds.reshape(nz, m)
    for k in range(lo, hi):
        count[k] = _classify_run(kf[k], flat[0, k], flat[1, k], flat[2, k], thr, zero)


@numba.njit(**_NJIT)
def _gather_planes(s, thr, h, rule, kinds, start, index, kind_of, strength, radius, lo, hi):  # type: ignore[no-untyped-def]
    """The source points of planes ``[lo, hi)``, from ``start[k]`` on for plane ``k``."""
    _, _, ny, nx = s.shape
    for k in range(lo, hi):
        p = start[k]
        for j in range(ny):
            for i in range(nx):
                kind = kinds[k, j, i]
                if kind == NONE:
                    continue
                index[p] = (k * ny + j) * nx + i
                kind_of[p] = kind
                strength[p] = s[kind - 1, k, j, i]
                radius[p] = _radius_at(s, kinds, thr, h, rule, k, j, i)
                p += 1


def sources(s, thr, zero, h, rule=DV_CELL, kinds=None):  # type: ignore[no-untyped-def]
    """The source points of strengths ``s (3, nz, ny, nx)``: their flat C-order indices,
    classes (int8), signed strengths and ΔV radii, in index order.

    :func:`classify_and_radius` then the points gathered, in two passes over the planes
    (the classes, then the radii of the source points alone; a radius reads the
    classes of the neighbours); ``kinds``: optional int8 scratch ``(nz, ny, nx)``.
    """
    if kinds is None or kinds.shape != s.shape[1:]:
        kinds = np.empty(s.shape[1:], dtype=np.int8)
    nz = s.shape[1]
    count = np.zeros(nz, dtype=np.int64)
    over_planes(lambda lo, hi: _classify_planes(s, thr, zero, kinds, count, lo, hi), kinds.shape)
    start = np.concatenate([[0], np.cumsum(count)])
    n = int(start[-1])
    out = (np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int8), np.empty(n), np.empty(n))
    over_planes(
        lambda lo, hi: _gather_planes(s, thr, h, rule, kinds, start, *out, lo, hi), kinds.shape
    )
    return out


def classify_and_radius(s, thr, zero, h, kind_out, radius_out, rule=DV_CELL):  # type: ignore[no-untyped-def]
    """Classify every vertex and compute its ΔV-sphere radius (0 where no source).

    ``rule`` :data:`DV_CELL` (default): ΔV is the vertex's share of the source
    region, a box that reaches on each side of the vertex to the cut distance
    along that grid edge (half the edge inside a source block, the
    threshold crossing at the region's border, nothing beyond a grid face);
    the radius is that of the sphere of the same volume.  Inside a source
    block ΔV = h_x h_y h_z, so Σ S ΔV is the midpoint/trapezoid rule for
    ∫ S dV over the source region and converges as the grid is refined.

    ``rule`` :data:`DV_SPHERE`: paper 003 §3.2.4.1, Fig. 3 literally: the
    radius is the mean of the cut distances along the (up to six) edges
    leaving the vertex (an interior vertex of a block gets r = h/2, so
    ΔV = π h³/6, about half its cell).
    """
    _classify_all(s, thr, zero, kind_out)
    _radii(s, kind_out, thr, h, rule, radius_out)


@numba.njit(inline="always", **_INNER)
def _any_bad_cross(bad, k, j, i, k0, k1, j0, j1, i0, i1):  # type: ignore[no-untyped-def]
    return (
        bad[k, j, i0]
        or bad[k, j, i1]
        or bad[k, j0, i]
        or bad[k, j1, i]
        or bad[k0, j, i]
        or bad[k1, j, i]
    )


@numba.njit(**_INNER)
def _mask_plane(bad, k, out, o):  # type: ignore[no-untyped-def]
    """:func:`mask_nodata` of plane ``k``, whose strengths are ``out[:, o]``."""
    nz, ny, nx = bad.shape
    k0, k1 = _lohi(k, nz)
    kc = _inner(k, nz)
    for j in range(ny):
        j0, j1 = _lohi(j, ny)
        jc = _inner(j, ny)
        for i in range(nx):
            i0, i1 = _lohi(i, nx)
            ic = _inner(i, nx)
            if bad[k, j, i]:
                out[0, o, j, i] = 0.0
                out[1, o, j, i] = 0.0
                out[2, o, j, i] = 0.0
                continue
            if _any_bad_cross(bad, k, j, i, k0, k1, j0, j1, i0, i1):
                out[1, o, j, i] = 0.0
                out[2, o, j, i] = 0.0
                continue
            q_bad = False
            if nx >= 3:
                q_bad = q_bad or bad[k, j, ic - 1] or bad[k, j, ic] or bad[k, j, ic + 1]
            if ny >= 3:
                q_bad = q_bad or bad[k, jc - 1, i] or bad[k, jc, i] or bad[k, jc + 1, i]
            if nz >= 3:
                q_bad = q_bad or bad[kc - 1, j, i] or bad[kc, j, i] or bad[kc + 1, j, i]
            q_bad = (
                q_bad
                or bad[k, j0, i0]
                or bad[k, j0, i1]
                or bad[k, j1, i0]
                or bad[k, j1, i1]
                or bad[k0, j, i0]
                or bad[k0, j, i1]
                or bad[k1, j, i0]
                or bad[k1, j, i1]
                or bad[k0, j0, i]
                or bad[k0, j1, i]
                or bad[k1, j0, i]
                or bad[k1, j1, i]
            )
            if q_bad:
                out[2, o, j, i] = 0.0


@numba.njit(parallel=True, **_NJIT)
def mask_nodata(bad, out):  # type: ignore[no-untyped-def]
    """Zero the strengths ``out (3, nz, ny, nx)`` whose stencil reads a no-data point.

    ``bad (nz, ny, nx)`` is True at no-data points.  A no-data point has no
    strength of any type; the dipole strength of a point needs its six edge
    neighbours (one-sided at grid faces: itself), the quadrupole strength
    every point its second and mixed differences read (see :func:`strengths`).
    """
    for kp in numba.prange(bad.shape[0]):
        k = np.int64(kp)
        _mask_plane(bad, k, out, k)


def quadrupole_of_stress(tt, h):  # type: ignore[no-untyped-def]
    """Quadrupole strength ``(nz, ny, nx)`` of a given stress ``tt (6, nz, ny, nx)``.

    The same stencil as :func:`strengths` (so the same numbers give the
    same result bit for bit); used for the time-mean stress.
    """
    shape = tt.shape[1:]
    out = np.empty((3, *shape))
    zero = np.zeros(shape)
    strengths(zero, zero, np.zeros((3, *shape)), np.ascontiguousarray(tt), 0.0, h, out)
    return out[2].copy()


@numba.njit(**_NJIT)
def _strength_planes(rho_a, rho_b, dm, tt, inv_dt, h, out, lo, hi):  # type: ignore[no-untyped-def]
    """:func:`strengths` of planes ``[lo, hi)``."""
    for k in range(lo, hi):
        _strength_plane(rho_a, rho_b, dm, tt, inv_dt, h, k, out, k)


def empty_like_strengths(shape: tuple[int, int, int]) -> np.ndarray:
    return np.empty((3, *shape), dtype=np.float64)


@numba.njit(inline="always", **_INNER)
def _inner2(i: int, n: int) -> int:
    """Centre of a 5-point (2h) stencil kept inside [0, n) (-1 if n < 5: no 2h stencil)."""
    if n < 5:
        return -1
    if i < 2:
        return 2
    if i > n - 3:
        return n - 3
    return i


@numba.njit(**_INNER)
def _error_point(rho_a2, rho_b2, dm, dm2, tt, s, bad, inv_dt, inv_dt2, h, k, j, i, err):  # type: ignore[no-untyped-def]
    """Discretisation-error estimates ``err[:, j, i]`` of the strengths ``s[:, k, j, i]``.

    Each strength is a second-order finite difference (paper 003 §3.2.3:
    ``S_m = ∂ρ/∂t``, ``S_d`` of Eq. 13, ``S_q`` of Eq. 14); the same difference
    over twice the step (2h in space, 2Δt in time) differs from it by about
    three times its truncation error (Richardson), so ``|S_h − S_2h| / 3``
    estimates the error of S_h: the monopole's from the time stencil, the
    dipole's from its divergence (space) and its time difference, the
    quadrupole's from its second and mixed differences.  Where a wider
    stencil does not fit (an axis of fewer than 5 points, a series of
    fewer than 4 steps) or would read a no-data point (``bad``), that part
    of the estimate is 0.

    ``rho_a2, rho_b2`` densities at steps n-2 and n+2 (clipped); ``dm``,
    ``dm2`` the momentum changes ``(3, nz, ny, nx)`` over the Δt and 2Δt
    stencils; ``tt (6, nz, ny, nx)`` the stress the quadrupole strength was
    taken of (steady state removed); ``inv_dt``, ``inv_dt2`` the inverse
    time spans (``inv_dt2`` 0: no 2Δt stencil); ``h (3,)`` the spacing.  ``dm``,
    ``dm2``, ``tt`` and ``s`` hold planes at slots ``plane % R`` (R their second
    axis: every plane, or the last R of a sweep); ``rho_a2``, ``rho_b2`` and
    ``bad (nz, ny, nx)`` every plane.
    """
    nz, ny, nx = bad.shape
    R = dm.shape[1]
    hx, hy, hz = h[0], h[1], h[2]
    wide_t = inv_dt2 > 0.0
    k2, j2, i2 = _inner2(k, nz), _inner2(j, ny), _inner2(i, nx)
    if bad[k, j, i]:
        err[0, j, i] = 0.0
        err[1, j, i] = 0.0
        err[2, j, i] = 0.0
        return
    q = k % R  # slots of the planes read
    qm2, qm1, qc = (k2 - 2) % R, (k2 - 1) % R, k2 % R
    qp1, qp2 = (k2 + 1) % R, (k2 + 2) % R
    # monopole: time stencil over 2Δt
    em = 0.0
    if wide_t:
        em = abs(s[0, q, j, i] - (rho_b2[k, j, i] - rho_a2[k, j, i]) * inv_dt2) / 3.0
    # dipole: divergence over 2h (space), and over 2Δt (time)
    ed = 0.0
    ok_x = i2 >= 0 and not (bad[k, j, i2 - 2] or bad[k, j, i2 + 2])
    ok_y = j2 >= 0 and not (bad[k, j2 - 2, i] or bad[k, j2 + 2, i])
    ok_z = k2 >= 0 and not (bad[k2 - 2, j, i] or bad[k2 + 2, j, i])
    div2 = 0.0
    div1 = 0.0
    if ok_x:
        div2 += (dm[0, q, j, i2 + 2] - dm[0, q, j, i2 - 2]) / (4.0 * hx)
        div1 += (dm[0, q, j, i2 + 1] - dm[0, q, j, i2 - 1]) / (2.0 * hx)
    if ok_y:
        div2 += (dm[1, q, j2 + 2, i] - dm[1, q, j2 - 2, i]) / (4.0 * hy)
        div1 += (dm[1, q, j2 + 1, i] - dm[1, q, j2 - 1, i]) / (2.0 * hy)
    if ok_z:
        div2 += (dm[2, qp2, j, i] - dm[2, qm2, j, i]) / (4.0 * hz)
        div1 += (dm[2, qp1, j, i] - dm[2, qm1, j, i]) / (2.0 * hz)
    ed = abs(div1 - div2) * inv_dt / 3.0
    if wide_t:
        d2 = 0.0
        i0, i1 = _lohi(i, nx)
        j0, j1 = _lohi(j, ny)
        k0, k1 = _lohi(k, nz)
        if i1 > i0:
            d2 += (dm2[0, q, j, i1] - dm2[0, q, j, i0]) / ((i1 - i0) * hx)
        if j1 > j0:
            d2 += (dm2[1, q, j1, i] - dm2[1, q, j0, i]) / ((j1 - j0) * hy)
        if k1 > k0:
            d2 += (dm2[2, k1 % R, j, i] - dm2[2, k0 % R, j, i]) / ((k1 - k0) * hz)
        ed += abs(s[1, q, j, i] - d2 * inv_dt2) / 3.0
    # quadrupole: second differences over 2h, mixed ones as products of 2h differences
    eq = 0.0
    if ok_x:
        a = tt[0, q, j, i2 + 1] - 2.0 * tt[0, q, j, i2] + tt[0, q, j, i2 - 1]
        b = 0.25 * (tt[0, q, j, i2 + 2] - 2.0 * tt[0, q, j, i2] + tt[0, q, j, i2 - 2])
        eq += (a - b) / (hx * hx)
    if ok_y:
        a = tt[1, q, j2 + 1, i] - 2.0 * tt[1, q, j2, i] + tt[1, q, j2 - 1, i]
        b = 0.25 * (tt[1, q, j2 + 2, i] - 2.0 * tt[1, q, j2, i] + tt[1, q, j2 - 2, i])
        eq += (a - b) / (hy * hy)
    if ok_z:
        a = tt[2, qp1, j, i] - 2.0 * tt[2, qc, j, i] + tt[2, qm1, j, i]
        b = 0.25 * (tt[2, qp2, j, i] - 2.0 * tt[2, qc, j, i] + tt[2, qm2, j, i])
        eq += (a - b) / (hz * hz)
    if ok_x and ok_y:
        a = (
            tt[3, q, j2 + 1, i2 + 1]
            - tt[3, q, j2 + 1, i2 - 1]
            - tt[3, q, j2 - 1, i2 + 1]
            + tt[3, q, j2 - 1, i2 - 1]
        ) / 4.0
        b = (
            tt[3, q, j2 + 2, i2 + 2]
            - tt[3, q, j2 + 2, i2 - 2]
            - tt[3, q, j2 - 2, i2 + 2]
            + tt[3, q, j2 - 2, i2 - 2]
        ) / 16.0
        eq += 2.0 * (a - b) / (hx * hy)
    if ok_x and ok_z:
        a = (
            tt[4, qp1, j, i2 + 1]
            - tt[4, qp1, j, i2 - 1]
            - tt[4, qm1, j, i2 + 1]
            + tt[4, qm1, j, i2 - 1]
        ) / 4.0
        b = (
            tt[4, qp2, j, i2 + 2]
            - tt[4, qp2, j, i2 - 2]
            - tt[4, qm2, j, i2 + 2]
            + tt[4, qm2, j, i2 - 2]
        ) / 16.0
        eq += 2.0 * (a - b) / (hx * hz)
    if ok_y and ok_z:
        a = (
            tt[5, qp1, j2 + 1, i]
            - tt[5, qp1, j2 - 1, i]
            - tt[5, qm1, j2 + 1, i]
            + tt[5, qm1, j2 - 1, i]
        ) / 4.0
        b = (
            tt[5, qp2, j2 + 2, i]
            - tt[5, qp2, j2 - 2, i]
            - tt[5, qm2, j2 + 2, i]
            + tt[5, qm2, j2 - 2, i]
        ) / 16.0
        eq += 2.0 * (a - b) / (hy * hz)
    err[0, j, i] = em
    err[1, j, i] = ed
    err[2, j, i] = abs(eq) / 3.0


@numba.njit(**_INNER)
def _ends_from_inner(row, r, nx):  # type: ignore[no-untyped-def]
    """In each of the ``r`` rows of ``nx`` points of the flat ``row``, set the first two
    points to the third and the last two to the third last (an x stencil centred
    at :func:`_inner2`)."""
    for q in range(r):
        o = q * nx
        row[o] = row[o + 1] = row[o + 2]
        row[o + nx - 1] = row[o + nx - 2] = row[o + nx - 3]


@numba.njit(**_INNER)
def _error_rows(rho_a2, rho_b2, dm, dm2, tt, s, inv_dt, inv_dt2, h, k, j, r, err, work):  # type: ignore[no-untyped-def]
    """:func:`_error_point` at every point of the ``r`` rows from ``j`` on of plane ``k``,
    where every 2h stencil fits (no axis of fewer than 5 points) and reads no
    no-data point; ``r`` is 1 or the rows are all inner (2 .. ny-3).

    The same operations in the same order, point by point, as
    :func:`_error_point`, grouped differently: run loops (:func:`_diff_over`,
    :func:`_gap_of_divergences` and the like) over the rows as one flat run,
    each adding a term or two (in their order) to the run of ``err (3, ny, nx)``
    it writes, or finishing its estimate (``work``: scratch like it).  A term
    with an x difference is taken along the run at x = 2 .. nx-3 (wrong at
    the two points at each end of a row, which read the next row), then
    copied to those points from the third (third last), where the stencil is
    centred (:func:`_inner2`); the one-sided x difference of the 2Δt dipole
    is taken at x = 0 and nx-1 apart.  The y and z stencils are those of row
    ``j`` (centred at :func:`_inner2`), the same along the rows.  Planes as
    :func:`_error_point`.
    """
    nz, ny, nx = rho_a2.shape
    R = dm.shape[1]
    hx, hy, hz = h[0], h[1], h[2]
    k2, j2 = _inner2(k, nz), _inner2(j, ny)
    k0, k1 = _lohi(k, nz)
    j0, j1 = _lohi(j, ny)
    m = ny * nx
    p0, n = j * nx, r * nx  # the run: its first point (flat) and length
    dy = (j2 - j) * nx  # offset of the y stencil's centre row
    dm_, dm2_ = dm.reshape(3, R, m), dm2.reshape(3, R, m)
    tt_, s_ = tt.reshape(6, R, m), s.reshape(3, R, m)
    e_, w_ = err.reshape(3, m), work.reshape(3, m)
    em, ed, eq = e_[0, p0 : p0 + n], e_[1, p0 : p0 + n], e_[2, p0 : p0 + n]
    w0 = w_[0, p0 : p0 + n]

    # dipole: divergence over 2h (in eq) and over h (in em), x first, then y and z
    # added and the estimate taken (in ed)
    _pair_over(
        eq[2 : n - 2],
        _run(dm_, p0 + 2, n - 4, 0, k, 2),
        _run(dm_, p0 + 2, n - 4, 0, k, -2),
        4.0 * hx,
        em[2 : n - 2],
        _run(dm_, p0 + 2, n - 4, 0, k, 1),
        _run(dm_, p0 + 2, n - 4, 0, k, -1),
        2.0 * hx,
    )
    _ends_from_inner(eq, r, nx)
    _ends_from_inner(em, r, nx)
    _gap_of_divergences(
        ed,
        eq,
        em,
        _run(dm_, p0, n, 1, k, dy + 2 * nx),
        _run(dm_, p0, n, 1, k, dy - 2 * nx),
        4.0 * hy,
        _run(dm_, p0, n, 2, k2 + 2, 0),
        _run(dm_, p0, n, 2, k2 - 2, 0),
        4.0 * hz,
        _run(dm_, p0, n, 1, k, dy + nx),
        _run(dm_, p0, n, 1, k, dy - nx),
        2.0 * hy,
        _run(dm_, p0, n, 2, k2 + 1, 0),
        _run(dm_, p0, n, 2, k2 - 1, 0),
        2.0 * hz,
        inv_dt,
    )
    # dipole: time stencil over 2Δt (its divergence in em), x first
    if inv_dt2 > 0.0:
        _diff_over(
            em[2 : n - 2],
            _run(dm2_, p0 + 2, n - 4, 0, k, 1),
            _run(dm2_, p0 + 2, n - 4, 0, k, -1),
            2 * hx,
            FIRST,
        )
        xd = _run(dm2_, p0, n, 0, k, 0)
        for q in range(r):  # central at x = 1 and nx-2, one-sided at the faces
            e = q * nx
            em[e] = 0.0 + (xd[e + 1] - xd[e]) / (1 * hx)
            em[e + 1] = 0.0 + (xd[e + 2] - xd[e]) / (2 * hx)
            em[e + nx - 2] = 0.0 + (xd[e + nx - 1] - xd[e + nx - 3]) / (2 * hx)
            em[e + nx - 1] = 0.0 + (xd[e + nx - 1] - xd[e + nx - 2]) / (1 * hx)
        _rest_of_divergence(
            ed,
            em,
            _run(s_, p0, n, 1, k, 0),
            _run(dm2_, p0, n, 1, k, (j1 - j) * nx),
            _run(dm2_, p0, n, 1, k, (j0 - j) * nx),
            (j1 - j0) * hy,
            _run(dm2_, p0, n, 2, k1, 0),
            _run(dm2_, p0, n, 2, k0, 0),
            (k1 - k0) * hz,
            inv_dt2,
        )
    # quadrupole: second differences along x, then y and z (in eq)
    _second_over(
        eq[2 : n - 2],
        _run(tt_, p0 + 2, n - 4, 0, k, 1),
        _run(tt_, p0 + 2, n - 4, 0, k, 0),
        _run(tt_, p0 + 2, n - 4, 0, k, -1),
        _run(tt_, p0 + 2, n - 4, 0, k, 2),
        _run(tt_, p0 + 2, n - 4, 0, k, -2),
        hx * hx,
        FIRST,
    )
    _ends_from_inner(eq, r, nx)
    _second_pair_over(
        eq,
        _run(tt_, p0, n, 1, k, dy + nx),
        _run(tt_, p0, n, 1, k, dy),
        _run(tt_, p0, n, 1, k, dy - nx),
        _run(tt_, p0, n, 1, k, dy + 2 * nx),
        _run(tt_, p0, n, 1, k, dy - 2 * nx),
        hy * hy,
        _run(tt_, p0, n, 2, k2 + 1, 0),
        _run(tt_, p0, n, 2, k2, 0),
        _run(tt_, p0, n, 2, k2 - 1, 0),
        _run(tt_, p0, n, 2, k2 + 2, 0),
        _run(tt_, p0, n, 2, k2 - 2, 0),
        hz * hz,
    )
    # mixed xy, then xz: their term (the h and 2h differences, in w0), added
    for c in range(2):
        if c == 0:
            cc, kp, km, kp2, km2, f = 3, k, k, k, k, hx * hy
            dp, dn, dp2, dn2 = dy + nx, dy - nx, dy + 2 * nx, dy - 2 * nx
        else:
            cc, kp, km, kp2, km2, f = 4, k2 + 1, k2 - 1, k2 + 2, k2 - 2, hx * hz
            dp, dn, dp2, dn2 = 0, 0, 0, 0
        _mixed_pair(
            w0[2 : n - 2],
            _run(tt_, p0 + 2, n - 4, cc, kp, dp + 1),
            _run(tt_, p0 + 2, n - 4, cc, kp, dp - 1),
            _run(tt_, p0 + 2, n - 4, cc, km, dn + 1),
            _run(tt_, p0 + 2, n - 4, cc, km, dn - 1),
            _run(tt_, p0 + 2, n - 4, cc, kp2, dp2 + 2),
            _run(tt_, p0 + 2, n - 4, cc, kp2, dp2 - 2),
            _run(tt_, p0 + 2, n - 4, cc, km2, dn2 + 2),
            _run(tt_, p0 + 2, n - 4, cc, km2, dn2 - 2),
            f,
            SET,
        )
        _ends_from_inner(w0, r, nx)
        _add_run(eq, w0)
    # mixed yz, and the estimate
    _mixed_pair(
        eq,
        _run(tt_, p0, n, 5, k2 + 1, dy + nx),
        _run(tt_, p0, n, 5, k2 + 1, dy - nx),
        _run(tt_, p0, n, 5, k2 - 1, dy + nx),
        _run(tt_, p0, n, 5, k2 - 1, dy - nx),
        _run(tt_, p0, n, 5, k2 + 2, dy + 2 * nx),
        _run(tt_, p0, n, 5, k2 + 2, dy - 2 * nx),
        _run(tt_, p0, n, 5, k2 - 2, dy + 2 * nx),
        _run(tt_, p0, n, 5, k2 - 2, dy - 2 * nx),
        hy * hz,
        LAST,
    )
    # monopole: time stencil over 2Δt
    if inv_dt2 > 0.0:
        rb, ra = rho_b2.reshape(nz, m)[k, p0 : p0 + n], rho_a2.reshape(nz, m)[k, p0 : p0 + n]
        _third_of_change(em, _run(s_, p0, n, 0, k, 0), rb, ra, inv_dt2)
    else:
        em[:] = 0.0


@numba.njit(**_INNER)
def _error_plane(rho_a2, rho_b2, dm, dm2, tt, s, bad, rowbad, inv_dt, inv_dt2, h, k, err, work):  # type: ignore[no-untyped-def]
    """Discretisation-error estimates ``err (3, ny, nx)`` of the strengths ``s`` in plane ``k``:
    :func:`_error_rows` over the rows whose stencils all fit and read no no-data point
    (``rowbad (nz, ny)`` tells the rows with one; the inner rows at once when they all
    do), :func:`_error_point` at the points of the other rows.  Only ``s[:, k]`` of the
    strengths is read (planes as :func:`_error_point`)."""
    nz, ny, nx = bad.shape
    rows = nx >= 5 and ny >= 5 and nz >= 5
    k2 = _inner2(k, nz)
    block = rows and not (rowbad[k].any() or rowbad[k2 - 2].any() or rowbad[k2 + 2].any())
    j = 0
    while j < ny:
        j2 = _inner2(j, ny)
        r = ny - 4 if block and j == 2 else 1  # rows done at once
        if r > 1 or (
            rows
            and not (
                rowbad[k, j]
                or rowbad[k, j2 - 2]
                or rowbad[k, j2 + 2]
                or rowbad[k2 - 2, j]
                or rowbad[k2 + 2, j]
            )
        ):
            _error_rows(rho_a2, rho_b2, dm, dm2, tt, s, inv_dt, inv_dt2, h, k, j, r, err, work)
        else:
            for i in range(nx):
                _error_point(rho_a2, rho_b2, dm, dm2, tt, s, bad, inv_dt, inv_dt2, h, k, j, i, err)
        j += r


@numba.njit(**_NJIT)
def _rows_with_nodata(bad):  # type: ignore[no-untyped-def]
    """``(nz, ny)``: whether row ``bad[k, j]`` holds a no-data point."""
    nz, ny, nx = bad.shape
    out = np.zeros((nz, ny), dtype=np.bool_)
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                if bad[k, j, i]:
                    out[k, j] = True
                    break
    return out


@numba.njit(parallel=True, **_NJIT)
def _error_stencil(rho_a2, rho_b2, dm, dm2, tt, inv_dt, inv_dt2, h, s, bad, err):  # type: ignore[no-untyped-def]
    """Discretisation-error estimates ``err (3, nz, ny, nx)`` of the strengths ``s``,
    plane by plane (see :func:`_error_plane`); :func:`detect_step` takes the same
    planes as it sweeps, without this array."""
    rowbad = _rows_with_nodata(bad)
    for kp in numba.prange(s.shape[1]):
        k = np.int64(kp)
        plane = np.empty(err.shape[:1] + err.shape[2:])
        work = np.empty_like(plane)
        _error_plane(
            rho_a2, rho_b2, dm, dm2, tt, s, bad, rowbad, inv_dt, inv_dt2, h, k, plane, work
        )
        err[:, k] = plane


@numba.njit(parallel=True, **_NJIT)
def _max_along_x(err, out):  # type: ignore[no-untyped-def]
    """``out[c, k, j, i]`` = the largest of ``err[c, k, j, i-1..i+1]`` (clipped at the faces),
    0 at least (NaN ignored, as ``max(e, x)`` from 0)."""
    nc, nz, ny, nx = err.shape
    for kp in numba.prange(nz):
        k = np.int64(kp)
        for c in range(nc):
            for j in range(ny):
                for i in range(nx):
                    i0, i1 = _lohi(i, nx)
                    e = 0.0
                    for ii in range(i0, i1 + 1):
                        x = err[c, k, j, ii]
                        if x > e:
                            e = x
                    out[c, k, j, i] = e


@numba.njit(parallel=True, **_NJIT)
def _floor_with(s, mx, factor, roundoff):  # type: ignore[no-untyped-def]
    """:func:`apply_floor` given the error estimates already maximised along x (``mx``)."""
    nz, ny, nx = s.shape[1], s.shape[2], s.shape[3]
    for kp in numba.prange(nz):
        k = np.int64(kp)
        k0, k1 = _lohi(k, nz)
        for c in range(3):
            lim = roundoff[c]
            for j in range(ny):
                j0, j1 = _lohi(j, ny)
                for i in range(nx):
                    a = abs(s[c, k, j, i])
                    if a == 0.0:
                        continue
                    if a <= lim:
                        s[c, k, j, i] = 0.0
                        continue
                    e = 0.0
                    for kk in range(k0, k1 + 1):
                        for jj in range(j0, j1 + 1):
                            x = mx[c, kk, jj, i]
                            if x > e:
                                e = x
                    if a <= factor * e:
                        s[c, k, j, i] = 0.0


@numba.njit(**_NJIT)
def _step_change_planes(r0, v0, r1, v1, out, lo, hi):  # type: ignore[no-untyped-def]
    nz = r0.shape[0]
    m = r0.size // max(nz, 1)
    for k in range(lo, hi):
        a, b = r0[k].reshape(m), r1[k].reshape(m)
        fa, fb = v0[k].reshape(3 * m), v1[k].reshape(3 * m)
        d, md = np.empty(CHUNK), np.empty(3 * CHUNK)
        top = out[k]
        top[0] = 0
        top[1] = 0
        for p0 in range(0, m, CHUNK):
            n = min(CHUNK, m - p0)
            for p in range(n):
                d[p] = b[p0 + p] - a[p0 + p]
                for c in range(3):
                    x = a[p0 + p] * fa[3 * (p0 + p) + c]
                    md[3 * p + c] = b[p0 + p] * fb[3 * (p0 + p) + c] - x
            top[0] = max(top[0], _top_bits(d[:n], True))
            top[1] = max(top[1], _top_bits(md[: 3 * n], True))
        _input_maxima_plane(b, fb, top[2:])


def step_change(r0, v0, r1, v1):  # type: ignore[no-untyped-def]
    """How much a step changed from the one before: ``(max|ρ1 − ρ0|, max|m1 − m0|)`` of their
    densities ``(nz, ny, nx)`` and velocities ``(nz, ny, nx, 3)``, ``m = ρ v`` (NaN ignored,
    at least 0), and the second step's :func:`input_maxima_planes` ``(nz, 3)``, in one pass."""
    bits = np.zeros((r0.shape[0], 5), dtype=np.int64)
    if r0.size:
        over_planes(lambda lo, hi: _step_change_planes(r0, v0, r1, v1, bits, lo, hi), r0.shape)
    values = bits.view(np.float64)
    top = values[:, :2].max(axis=0, initial=0.0)
    return float(top[0]), float(top[1]), np.ascontiguousarray(values[:, 2:])


def apply_floor(s, err, factor, roundoff, work=None):  # type: ignore[no-untyped-def]
    """Zero each strength of ``s (3, ...)`` not above ``factor`` times its error
    estimate or above ``roundoff (3,)`` (in place).

    The estimate of a point is the largest of ``err`` over the point and its
    26 neighbours: a truncation error varies smoothly in space, and the
    Richardson estimate of one point can vanish where the leading error term
    changes sign while the strength, made of the same error, does not.  The
    27-point maximum is taken as a maximum along x (into ``work``, a scratch
    array like ``err``, allocated when not given) and then over the 3 × 3
    neighbours in y and z: the same number, in 12 reads instead of 27.
    Returns the scratch array.
    """
    if work is None or work.shape != err.shape:
        work = np.empty_like(err)
    _max_along_x(err, work)
    _floor_with(s, work, factor, roundoff)
    return work


@numba.njit(inline="always", **_INNER)
def _up(e: float, x: float) -> float:
    """``x`` if it is larger than ``e``, else ``e`` (a NaN ``x`` never is)."""
    return x if x > e else e


@numba.njit(**_INNER)
def _max_x(plane, out):  # type: ignore[no-untyped-def]
    """``out[c, j, i]`` = the largest of ``plane[c, j, i-1..i+1]`` (clipped at the faces), 0 at
    least (NaN ignored, as ``max(e, x)`` from 0).  The inner points in one loop along a
    row (vector instructions), the two end points apart."""
    nc, ny, nx = plane.shape
    for c in range(nc):
        for j in range(ny):
            row, o = plane[c, j], out[c, j, 1:]
            for i in range(nx - 2):
                o[i] = _up(_up(_up(0.0, row[i]), row[i + 1]), row[i + 2])
            for i in (0, nx - 1):
                i0, i1 = _lohi(i, nx)
                out[c, j, i] = _up(_up(0.0, row[i0]), row[i1])


@numba.njit(**_INNER)
def _max_y(plane, out):  # type: ignore[no-untyped-def]
    """As :func:`_max_x`, along y (the middle axis), a row at a time."""
    nc, ny, nx = plane.shape
    for c in range(nc):
        for j in range(ny):
            j0, j1 = _lohi(j, ny)
            ra, rb, rc, o = plane[c, j0], plane[c, j], plane[c, j1], out[c, j]
            for i in range(nx):
                o[i] = _up(_up(_up(0.0, ra[i]), rb[i]), rc[i])


@numba.njit(**_INNER)
def _floor_plane(s, o, near, k, nz, factor, roundoff, out):  # type: ignore[no-untyped-def]
    """The strengths ``s[:, o]`` of plane ``k`` (of ``nz``) into ``out[:, k]``, those not above
    ``roundoff (3,)`` or ``factor`` times the largest error estimate around them zeroed;
    ``near (3, 3, ny, nx)`` holds the estimates of planes k-1, k, k+1 (slot ``plane %
    3``), each already the largest over the 3 × 3 points around in x and y (see
    :func:`apply_floor`).  A row at a time; a strength that stays is written as it was."""
    ny = s.shape[2]
    k0, k1 = _lohi(k, nz)
    for c in range(3):
        lim = roundoff[c]
        for j in range(ny):
            row, dst = s[c, o, j], out[c, k, j]
            ea, eb, ec = near[k0 % 3, c, j], near[k % 3, c, j], near[k1 % 3, c, j]
            for i in range(row.size):
                x = row[i]
                a = abs(x)
                e = _up(_up(_up(0.0, ea[i]), eb[i]), ec[i])
                dst[i] = 0.0 if a != 0.0 and (a <= lim or a <= factor * e) else x


_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def in_threads(fn, n, threads=None):  # type: ignore[no-untyped-def]
    """Call ``fn(i)`` for ``0 <= i < n``, this thread and a small pool of others (up to
    numba's thread count, or ``threads``) taking the next ``i`` in turn; ``fn`` runs a
    ``nogil`` kernel.  A sweep is plain compiled code run by threads of its own, not a
    ``parallel=True`` kernel, whose compilation takes several times as long."""
    global _POOL
    nt = max(1, min(n, numba.get_num_threads() if threads is None else threads))
    if nt > 1 and _POOL is None:
        with _POOL_LOCK:
            if _POOL is None:
                _POOL = ThreadPoolExecutor(
                    max_workers=max(1, numba.config.NUMBA_NUM_THREADS - 1),
                    thread_name_prefix="auralize-sweep",
                )
    pieces = itertools.count()  # next() is atomic under the GIL

    def work() -> None:
        for i in pieces:
            if i >= n:
                return
            fn(i)

    futures = [_POOL.submit(work) for _ in range(nt - 1)] if nt > 1 and _POOL is not None else []
    work()
    for fu in futures:
        fu.result()


#: a pass over fewer points than this runs on the calling thread alone: on a small grid,
#: handing pieces of it to other threads costs more than they take off
THREAD_POINTS = 1 << 15


def thread_count(points=None) -> int:  # type: ignore[no-untyped-def]
    """The threads the detection's kernels run on: numba's thread count, or 1 for a pass
    over fewer than :data:`THREAD_POINTS` ``points``."""
    if points is not None and points < THREAD_POINTS:
        return 1
    return int(numba.get_num_threads())


def split(n, pieces):  # type: ignore[no-untyped-def]
    """The edges ``(pieces + 1,)`` of ``pieces`` nearly equal ranges of ``[0, n)`` (ints)."""
    return [n * b // pieces for b in range(pieces + 1)]


def over_planes(fn, shape):  # type: ignore[no-untyped-def]
    """Call ``fn(lo, hi)`` over the planes ``[0, nz)`` of a grid of ``shape (nz, ny, nx)`` in
    a few ranges of planes, on the threads of :func:`in_threads` (one on a small grid,
    :func:`thread_count`)."""
    nz = shape[0]
    threads = thread_count(int(np.prod(shape)))
    pieces = max(1, min(nz, 4 * threads))
    edges = split(nz, pieces)
    in_threads(lambda b: fn(edges[b], edges[b + 1]), pieces, threads)


#: steady-state modes of :func:`detect_step`: none, interpolated between two anchors,
#: an anchor (no fluctuation), a given quadrupole strength subtracted
STEADY_NONE, STEADY_BETWEEN, STEADY_ANCHOR, STEADY_GIVEN = 0, 1, 2, 3
#: planes of its inputs and strengths each sweep of :func:`detect_step` keeps (the
#: widest stencil, the 2h one of the floor's error estimate, spans five)
SWEEP_PLANES = 5


def detect_step(  # type: ignore[no-untyped-def]
    frames,
    steady,
    nodata,
    bad,
    inv_dt,
    inv_dt2,
    h,
    factor,
    roundoff,
    out,
    blocks=None,
    rowbad=None,
):
    """The strengths of one step on a uniform grid, each plane's once its inputs are in,
    steady state removed, no-data masked and floored: ``out (3, nz, ny, nx)``.

    The same numbers as the passes one after the other over whole arrays
    (:func:`momentum_change`, :func:`stress`, :func:`strengths`, the steady
    state subtracted as :func:`subtract_steady`, :func:`mask_nodata`, and
    :func:`_error_stencil` then :func:`apply_floor`), in one sweep along z:
    the planes are split into one block per thread, and a block keeps the
    last :data:`SWEEP_PLANES` planes of the momentum changes (Δt and 2Δt), the
    stress (and the stress less its steady state) and the strengths, and the
    error estimates of three planes (maximised over x and y).  For each new
    plane it takes the strengths of the planes whose stencils are in, their
    error estimates (paper 003 §3.2.3, the Richardson estimate of
    :func:`_error_point`), and floors a plane once the estimates of the
    planes on both sides are known.  A block also takes the planes just
    outside it that its own need (their strengths unfloored): no block waits
    for another, and the arrays of a step are never made.

    Parameters
    ----------
    frames : tuple
        ``(rho_a, v_a, rho_b, v_b, rho_c, v_c, rho_a2, v_a2, rho_b2, v_b2)``:
        densities ``(nz, ny, nx)`` and velocities ``(nz, ny, nx, 3)`` at steps
        n-1, n+1, n, n-2 and n+2 (clipped at the ends of the series).
    steady : tuple
        ``(mode, f, sa, sb, rho_a, v_a, rho_b, v_b)``: :data:`STEADY_BETWEEN`
        subtracts ``(1 - f) sa + f sb`` from the quadrupole strength and, when
        flooring, ``(1 - f) ta + f tb`` from the stress the estimates read, ``ta``
        and ``tb`` the stresses of the anchor frames (``rho_a, v_a``, ``rho_b, v_b``;
        :func:`_steady_stress_plane`);
        :data:`STEADY_ANCHOR` sets the quadrupole strength to 0;
        :data:`STEADY_GIVEN` subtracts ``sa``; :data:`STEADY_NONE` nothing.
    nodata, bad : (nz, ny, nx) bool
        No-data points of the strengths (:func:`mask_nodata`) and of the error
        estimates (those and the points without data at n-2 or n+2).
    inv_dt, inv_dt2 : float
        Inverse time spans of the Δt and 2Δt stencils (``inv_dt2`` 0: none).
    h : (3,) spacing; ``factor`` of the floor (0: no floor); ``roundoff (3,)``.
    blocks : int, optional
        Blocks of planes (default: one per thread); the result does not depend on it.
    rowbad : (nz, ny) bool, optional
        :func:`_rows_with_nodata` of ``bad``, when the caller has it.
    """
    nz = out.shape[1]
    threads = thread_count(out[0].size)
    n_blocks = max(1, min(nz, threads if blocks is None else int(blocks)))
    edges = split(nz, n_blocks)
    mode, f, sa, sb, ra, va, rb, vb = steady
    if rowbad is None:
        rowbad = _rows_with_nodata(bad)
    args = (
        *frames,
        (int(mode), float(f), sa, sb, ra, va, rb, vb),
        nodata,
        bad,
        rowbad,
        bool(nodata.any()),
        float(inv_dt),
        float(inv_dt2),
        np.asarray(h, dtype=np.float64),
        (float(factor), np.asarray(roundoff, dtype=np.float64)),
    )
    in_threads(lambda b: _sweep(*args, edges[b], edges[b + 1], out), n_blocks, threads)


@numba.njit(**_INNER)
def _planes_read(k, nz, error):  # type: ignore[no-untyped-def]
    """The first and the last plane the strengths (``error``: the error estimates) of
    plane ``k`` of ``nz`` read."""
    k0, k1 = _lohi(k, nz)
    if error:
        if nz < 5:
            return k0, k1
        k2 = _inner2(k, nz)
        return min(k0, k2 - 2), max(k1, k2 + 2)
    if nz < 3:
        return k0, k1
    kc = _inner(k, nz)
    return min(k0, kc - 1), max(k1, kc + 1)


@numba.njit(**_NJIT)
def _sweep(  # type: ignore[no-untyped-def]
    rho_a,
    v_a,
    rho_b,
    v_b,
    rho_c,
    v_c,
    rho_a2,
    v_a2,
    rho_b2,
    v_b2,
    steady,
    nodata,
    bad,
    rowbad,
    masked,
    inv_dt,
    inv_dt2,
    h,
    floor,
    lo,
    hi,
    out,
):
    """:func:`detect_step` for the planes ``[lo, hi)`` (one block)."""
    mode, f, sa, sb, ra, va, rb, vb = steady
    factor, roundoff = floor
    nz, ny, nx = rho_c.shape
    R = SWEEP_PLANES
    flooring = factor > 0.0
    # the estimates read the stress less its steady state
    remove = mode == STEADY_BETWEEN and flooring
    w = 1.0 - f
    dm = np.empty((3, R, ny, nx))
    dm2 = np.empty((3, R, ny, nx))
    raw = np.empty((6, R, ny, nx))
    tt = np.empty((6, R, ny, nx)) if remove else raw
    s = np.empty((3, R, ny, nx))
    anchor = np.empty((6, 2, ny, nx))  # the anchors' stress of a plane
    near = np.empty((3, 3, ny, nx))  # error estimates of planes k-1, k, k+1
    work = np.empty((3, ny, nx))
    # the strengths of planes [ks, last] and (flooring) their estimates are needed
    ks = max(lo - 1, 0) if flooring else lo
    last = min(hi, nz - 1) if flooring else hi - 1
    first_plane = _planes_read(ks, nz, flooring)[0]
    last_plane = _planes_read(last, nz, flooring)[1]
    ke = ks  # the next estimates
    kf = lo  # the next plane to floor
    for e in range(first_plane, last_plane + 1):
        # the new plane's inputs
        o = e % R
        _momentum_plane(rho_a[e], v_a[e], rho_b[e], v_b[e], dm, o)
        _stress_plane(rho_c[e], v_c[e], raw, o)
        if flooring:
            _momentum_plane(rho_a2[e], v_a2[e], rho_b2[e], v_b2[e], dm2, o)
        if remove:
            _steady_stress_plane(raw, ra[e], va[e], rb[e], vb[e], w, f, tt, o, anchor)
        # then whatever they let be done
        progress = True
        while progress:
            progress = False
            if ks <= last and ks < kf + R and _planes_read(ks, nz, False)[1] <= e:
                o = ks % R
                _strength_plane(rho_a, rho_b, dm, raw, inv_dt, h, ks, s, o)
                if mode == STEADY_BETWEEN:
                    _subtract_plane(s[2, o], sa[ks], sb[ks], w, f, s[2, o])
                elif mode == STEADY_ANCHOR:
                    s[2, o] = 0.0
                elif mode == STEADY_GIVEN:
                    _less_plane(s[2, o], sa[ks])
                if masked:
                    _mask_plane(nodata, ks, s, o)
                ks += 1
                progress = True
            if flooring and ke < ks and ke <= kf + 1 and _planes_read(ke, nz, True)[1] <= e:
                # its estimates, each the largest over the 3 × 3 points around in x and y
                est = near[ke % 3]
                _error_plane(
                    rho_a2, rho_b2, dm, dm2, tt, s, bad, rowbad, inv_dt, inv_dt2, h, ke, est, work
                )
                _max_x(est, work)
                _max_y(work, est)
                ke += 1
                progress = True
            if kf < hi and (ke > min(kf + 1, nz - 1) if flooring else kf < ks):
                if flooring:
                    _floor_plane(s, kf % R, near, kf, nz, factor, roundoff, out)
                else:
                    _copy_planes(s, kf % R, out, kf)
                kf += 1
                progress = True


@numba.njit(**_NJIT)
def _input_maxima_planes(rho, v, out, lo, hi):  # type: ignore[no-untyped-def]
    m = rho.shape[1] * rho.shape[2]
    for k in range(lo, hi):
        _input_maxima_plane(rho[k].reshape(m), v[k].reshape(3 * m), out[k])


def input_maxima_planes(rho, v):  # type: ignore[no-untyped-def]
    """Per plane ``(nz, 3)``: :func:`input_maxima` of each plane."""
    rho = np.ascontiguousarray(rho, dtype=np.float64)
    v = np.ascontiguousarray(v, dtype=np.float64)
    bits = np.zeros((rho.shape[0], 3), dtype=np.int64)
    if rho.size:
        over_planes(lambda lo, hi: _input_maxima_planes(rho, v, bits, lo, hi), rho.shape)
    return bits.view(np.float64)


def input_maxima(rho, v):  # type: ignore[no-untyped-def]
    """``(max|ρ|, max|ρv|, max|ρv ∘ v|)`` over ``rho (nz, ny, nx)`` and ``v (nz, ny, nx, 3)``,
    each at least 0 and NaN if any value is (as ``np.max(np.abs(x), initial=0.0)`` of
    ``x = rho``, ``m = rho[..., None] * v`` and ``m * v``), without temporaries."""
    top = np.max(input_maxima_planes(rho, v), axis=0, initial=0.0)
    return float(top[0]), float(top[1]), float(top[2])


@numba.njit(**_INNER)
def _subtract_plane(x, a, b, w, f, out):  # type: ignore[no-untyped-def]
    """``out = x - (w a + f b)`` over one plane ``(ny, nx)`` (``out`` may be ``x``)."""
    m = x.size
    xf, af, bf, of = x.reshape(m), a.reshape(m), b.reshape(m), out.reshape(m)
    for p in range(m):
        of[p] = xf[p] - (w * af[p] + f * bf[p])


@numba.njit(**_INNER)
def _steady_stress_plane(raw, ra, va, rb, vb, w, f, out, o, work):  # type: ignore[no-untyped-def]
    """``out[:, o]`` = ``raw[:, o] - (w ta + f tb)`` over one plane, ``ta`` and ``tb`` the
    stresses (:func:`_stress_plane`) of the densities ``ra, rb (ny, nx)`` and the
    velocities ``va, vb (ny, nx, 3)`` (``work (6, 2, ny, nx)``: scratch)."""
    _stress_plane(ra, va, work, 0)
    _stress_plane(rb, vb, work, 1)
    for c in range(6):
        _subtract_plane(raw[c, o], work[c, 0], work[c, 1], w, f, out[c, o])


@numba.njit(**_INNER)
def _less_plane(x, a):  # type: ignore[no-untyped-def]
    """``x = x - a`` over one plane ``(ny, nx)``."""
    xf, af = x.reshape(x.size), a.reshape(a.size)
    for p in range(xf.size):
        xf[p] = xf[p] - af[p]


@numba.njit(**_INNER)
def _copy_planes(src, a, dst, b):  # type: ignore[no-untyped-def]
    """``dst[c, b] = src[c, a]`` for each component ``c`` (planes ``(ny, nx)``; a loop: a
    slice assignment would compile numpy's shape-mismatch error with it)."""
    for c in range(src.shape[0]):
        sf, df = src[c, a].reshape(src[c, a].size), dst[c, b].reshape(dst[c, b].size)
        for p in range(sf.size):
            df[p] = sf[p]


@numba.njit(parallel=True, **_NJIT)
def subtract_steady(sq, sa, sb, tt, ta, tb, f, with_stress):  # type: ignore[no-untyped-def]
    """Subtract the steady state interpolated between two anchors, in place:
    ``sq -= (1 - f) sa + f sb`` and, when ``with_stress``, ``tt -= (1 - f) ta + f tb``
    (the same operations, in the same order, as the numpy expressions)."""
    w = 1.0 - f
    for kp in numba.prange(sq.shape[0]):
        k = np.int64(kp)
        _subtract_plane(sq[k], sa[k], sb[k], w, f, sq[k])
        if with_stress:
            for c in range(6):
                _subtract_plane(tt[c, k], ta[c, k], tb[c, k], w, f, tt[c, k])


@numba.njit(**_INNER)
def _gradient_plane(f, h, scale, k, out):  # type: ignore[no-untyped-def]
    """``out[k] (ny, nx, 3)`` = ∇f · ``scale`` of plane ``k`` (see :func:`gradient`): the
    same operations, x along the flat plane (central, each row's ends redone one-sided),
    y a row at a time, z along the plane."""
    nz, ny, nx = f.shape
    hx, hy, hz = h[0], h[1], h[2]
    m = ny * nx
    c, o = f[k].reshape(m), out[k].reshape(3 * m)
    for p in range(m - 2):
        o[3 * p + 3] = (c[p + 2] - c[p]) / (2.0 * hx) * scale
    for j in range(ny):
        p, e = j * nx, j * nx + nx - 1
        if nx < 2:
            o[3 * p] = 0.0
        else:
            o[3 * p] = (c[p + 1] - c[p]) / hx * scale
            o[3 * e] = (c[e] - c[e - 1]) / hx * scale
    for j in range(ny):
        j0, j1 = _lohi(j, ny)
        ty = 2.0 * hy if j1 - j0 == 2 else hy
        p, a, b = j * nx, j0 * nx, j1 * nx
        for i in range(nx):
            o[3 * (p + i) + 1] = 0.0 if ny < 2 else (c[b + i] - c[a + i]) / ty * scale
    k0, k1 = _lohi(k, nz)
    za, zb = f[k0].reshape(m), f[k1].reshape(m)
    tz = 2.0 * hz if k1 - k0 == 2 else hz
    for p in range(m):
        o[3 * p + 2] = 0.0 if nz < 2 else (zb[p] - za[p]) / tz * scale


@numba.njit(**_NJIT)
def _gradient_planes(f, h, scale, out, top, lo, hi):  # type: ignore[no-untyped-def]
    """:func:`gradient` of planes ``[lo, hi)``; with ``top`` (nz,) the bit patterns of each
    plane's largest |component| (:func:`_top_bits`, NaN ignored), else ``top`` empty."""
    for k in range(lo, hi):
        _gradient_plane(f, h, scale, k, out)
        if top.size:
            top[k] = _top_bits(out[k].reshape(out[k].size), True)


def gradient(f, h, scale, out):  # type: ignore[no-untyped-def]
    """``out (nz, ny, nx, 3)`` = ∇f · ``scale`` (components x, y, z) of ``f (nz, ny, nx)``.

    :func:`numpy.gradient` with ``edge_order=1`` exactly (central differences
    ``(f[i+1] - f[i-1]) / 2h`` inside, one-sided ``(f[1] - f[0]) / h`` at the
    faces, the same operations), then times ``scale``; a component along an
    axis of fewer than 2 points is 0.
    """
    f = np.ascontiguousarray(f, dtype=np.float64)
    h = np.asarray(h, dtype=np.float64)
    none = np.zeros(0, dtype=np.int64)
    over_planes(lambda lo, hi: _gradient_planes(f, h, float(scale), out, none, lo, hi), f.shape)


def gradient_max(f, h, out):  # type: ignore[no-untyped-def]
    """:func:`gradient` (scale 1) into ``out (nz, ny, nx, 3)``, and its largest |component|,
    NaN ignored, at least 0 (as ``np.nanmax(np.abs(out), initial=0.0)``)."""
    f = np.ascontiguousarray(f, dtype=np.float64)
    h = np.asarray(h, dtype=np.float64)
    top = np.zeros(f.shape[0], dtype=np.int64)
    over_planes(lambda lo, hi: _gradient_planes(f, h, 1.0, out, top, lo, hi), f.shape)
    return float(top.max(initial=0).view(np.float64))


def gradient_absmax(f, h):  # type: ignore[no-untyped-def]
    """The largest |component| of :func:`gradient` (scale 1), NaN ignored, at least 0 (as
    ``np.nanmax(np.abs(g), initial=0.0)``)."""
    return gradient_max(f, h, np.empty((*np.shape(f), 3)))


@numba.njit(parallel=True, **_NJIT)
def residual(rho_a, rho_b, rho_a2, rho_b2, m_c, inv_dt, inv_dt2, h, bad, out, err):  # type: ignore[no-untyped-def]
    """Continuity residual ``Q = ∂ρ/∂t + ∇·m`` (``out (nz, ny, nx)``) and its
    discretisation-error estimate ``err`` (as :func:`_error_stencil`: the
    difference of the Δt and 2Δt time stencils and of the h and 2h
    divergences, over 3).

    ``m_c (nz, ny, nx, 3)`` is the mass flux at the step itself; ``inv_dt2``
    0 means no 2Δt stencil.  The divergence uses the detection's first
    differences (central inside, one-sided at grid faces).
    """
    nz, ny, nx = rho_a.shape
    hx, hy, hz = h[0], h[1], h[2]
    for kp in numba.prange(nz):
        k = np.int64(kp)
        k0, k1 = _lohi(k, nz)
        k2 = _inner2(k, nz)
        fz = 1.0 / ((k1 - k0) * hz) if k1 > k0 else 0.0
        for j in range(ny):
            j0, j1 = _lohi(j, ny)
            j2 = _inner2(j, ny)
            fy = 1.0 / ((j1 - j0) * hy) if j1 > j0 else 0.0
            for i in range(nx):
                i0, i1 = _lohi(i, nx)
                i2 = _inner2(i, nx)
                fx = 1.0 / ((i1 - i0) * hx) if i1 > i0 else 0.0
                dt1 = (rho_b[k, j, i] - rho_a[k, j, i]) * inv_dt
                div = (
                    (m_c[k, j, i1, 0] - m_c[k, j, i0, 0]) * fx
                    + (m_c[k, j1, i, 1] - m_c[k, j0, i, 1]) * fy
                    + (m_c[k1, j, i, 2] - m_c[k0, j, i, 2]) * fz
                )
                out[k, j, i] = dt1 + div
                if bad[k, j, i]:
                    err[k, j, i] = 0.0
                    continue
                e = 0.0
                if inv_dt2 > 0.0:
                    e += abs(dt1 - (rho_b2[k, j, i] - rho_a2[k, j, i]) * inv_dt2) / 3.0
                d1 = 0.0
                d2 = 0.0
                if i2 >= 0 and not (bad[k, j, i2 - 2] or bad[k, j, i2 + 2]):
                    d1 += (m_c[k, j, i2 + 1, 0] - m_c[k, j, i2 - 1, 0]) / (2.0 * hx)
                    d2 += (m_c[k, j, i2 + 2, 0] - m_c[k, j, i2 - 2, 0]) / (4.0 * hx)
                if j2 >= 0 and not (bad[k, j2 - 2, i] or bad[k, j2 + 2, i]):
                    d1 += (m_c[k, j2 + 1, i, 1] - m_c[k, j2 - 1, i, 1]) / (2.0 * hy)
                    d2 += (m_c[k, j2 + 2, i, 1] - m_c[k, j2 - 2, i, 1]) / (4.0 * hy)
                if k2 >= 0 and not (bad[k2 - 2, j, i] or bad[k2 + 2, j, i]):
                    d1 += (m_c[k2 + 1, j, i, 2] - m_c[k2 - 1, j, i, 2]) / (2.0 * hz)
                    d2 += (m_c[k2 + 2, j, i, 2] - m_c[k2 - 2, j, i, 2]) / (4.0 * hz)
                err[k, j, i] = e + abs(d1 - d2) / 3.0
