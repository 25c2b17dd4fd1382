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

import numba
import numpy as np

from auralize.runtime.jit import configure as _configure_numba

_configure_numba()  # cache folder, OMP wait policy, compile notice

_NJIT = {"cache": True, "fastmath": False, "nogil": True}

NONE, MONOPOLE, DIPOLE, QUADRUPOLE = 0, 1, 2, 3
#: ΔV rules of :func:`classify_and_radius`
DV_CELL, DV_SPHERE = 0, 1


@numba.njit(inline="always", **_NJIT)
def _lohi(i: int, n: int) -> tuple[int, int]:
    lo = i - 1 if i > 0 else 0
    hi = i + 1 if i < n - 1 else n - 1
    return lo, hi


@numba.njit(inline="always", **_NJIT)
def _inner(i: int, n: int) -> int:
    """Centre of a 3-point stencil kept inside [0, n) (i itself if n < 3)."""
    if n < 3:
        return i
    if i < 1:
        return 1
    if i > n - 2:
        return n - 2
    return i


@numba.njit(parallel=True, **_NJIT)
def prepare_render(rho_a, rho_b, m_a, m_b, rho_c, v_c, dm, tt):  # type: ignore[no-untyped-def]
    """Planar momentum change dm (3, ...) and Lighthill stress tt (6, ...) = ρ v_i v_j.

    Order of tt: xx, yy, zz, xy, xz, yz (paper 003 Eq. 11).
    """
    nz, ny, nx = rho_c.shape
    for kp in numba.prange(nz):
        k = np.int64(kp)
        for j in range(ny):
            for i in range(nx):
                for c in range(3):
                    dm[c, k, j, i] = m_b[k, j, i, c] - m_a[k, j, i, c]
                r = rho_c[k, j, i]
                vx, vy, vz = v_c[k, j, i, 0], v_c[k, j, i, 1], v_c[k, j, i, 2]
                tt[0, k, j, i] = r * vx * vx
                tt[1, k, j, i] = r * vy * vy
                tt[2, k, j, i] = r * vz * vz
                tt[3, k, j, i] = r * vx * vy
                tt[4, k, j, i] = r * vx * vz
                tt[5, k, j, i] = r * vy * vz


def strengths(rho_a, rho_b, m_a, m_b, inv_dt, rho_c, v_c, h, out, work=None):  # type: ignore[no-untyped-def]
    """Monopole, dipole and quadrupole strengths at every vertex of one step.

    Paper 003 §3.2.3: ``S_m = ∂ρ/∂t``, ``S_d = ∂/∂x_i (∂(ρ v_i)/∂t)`` (Eq. 13),
    ``S_q = Σ_ij ∂²(ρ v_i v_j)/∂x_i ∂x_j`` (Eq. 14, all nine terms).

    Parameters
    ----------
    rho_a, rho_b : (nz, ny, nx) densities at the earlier and later step.
    m_a, m_b : (nz, ny, nx, 3) momenta ρv at the earlier and later step.
    inv_dt : 1 / (t_b - t_a).
    rho_c, v_c : density and velocity at the step itself (for S_q).
    h : (3,) spacing (x, y, z).
    out : (3, nz, ny, nx) result, written in place.
    work : optional (9, nz, ny, nx) scratch array, reused between calls.

    Returns the scratch array.
    """
    shape = rho_c.shape
    if work is None or work.shape != (9, *shape):
        work = np.empty((9, *shape))
    prepare_render(rho_a, rho_b, m_a, m_b, rho_c, v_c, work[:3], work[3:])
    _stencil(rho_a, rho_b, work[:3], work[3:], inv_dt, np.asarray(h, dtype=np.float64), out)
    return work


@numba.njit(parallel=True, **_NJIT)
def _stencil(rho_a, rho_b, dm, tt, inv_dt, h, out):  # type: ignore[no-untyped-def]
    """Finite-difference stencils on planar arrays (see :func:`strengths`)."""
    nz, ny, nx = rho_a.shape
    hx, hy, hz = h[0], h[1], h[2]
    gx = 1.0 / (hx * hx) if nx >= 3 else 0.0
    gy = 1.0 / (hy * hy) if ny >= 3 else 0.0
    gz = 1.0 / (hz * hz) if nz >= 3 else 0.0
    for kp in numba.prange(nz):
        k = np.int64(kp)
        k0, k1 = _lohi(k, nz)
        kc = _inner(k, nz)
        fz = 1.0 / ((k1 - k0) * hz) if k1 > k0 else 0.0
        for j in range(ny):
            j0, j1 = _lohi(j, ny)
            jc = _inner(j, ny)
            fy = 1.0 / ((j1 - j0) * hy) if j1 > j0 else 0.0
            for i in range(nx):
                i0, i1 = _lohi(i, nx)
                ic = _inner(i, nx)
                fx = 1.0 / ((i1 - i0) * hx) if i1 > i0 else 0.0
                out[0, k, j, i] = (rho_b[k, j, i] - rho_a[k, j, i]) * inv_dt
                div = (
                    (dm[0, k, j, i1] - dm[0, k, j, i0]) * fx
                    + (dm[1, k, j1, i] - dm[1, k, j0, i]) * fy
                    + (dm[2, k1, j, i] - dm[2, k0, j, i]) * fz
                )
                out[1, k, j, i] = div * inv_dt
                # diagonal terms: 3-point second differences (stencil kept inside)
                q = 0.0
                if nx >= 3:
                    q += (tt[0, k, j, ic + 1] - 2.0 * tt[0, k, j, ic] + tt[0, k, j, ic - 1]) * gx
                if ny >= 3:
                    q += (tt[1, k, jc + 1, i] - 2.0 * tt[1, k, jc, i] + tt[1, k, jc - 1, i]) * gy
                if nz >= 3:
                    q += (tt[2, kc + 1, j, i] - 2.0 * tt[2, kc, j, i] + tt[2, kc - 1, j, i]) * gz
                # off-diagonal terms, each twice (T_ij = T_ji); zero factors on flat axes
                q += (2.0 * fx * fy) * (
                    tt[3, k, j1, i1] - tt[3, k, j1, i0] - tt[3, k, j0, i1] + tt[3, k, j0, i0]
                )
                q += (2.0 * fx * fz) * (
                    tt[4, k1, j, i1] - tt[4, k1, j, i0] - tt[4, k0, j, i1] + tt[4, k0, j, i0]
                )
                q += (2.0 * fy * fz) * (
                    tt[5, k1, j1, i] - tt[5, k1, j0, i] - tt[5, k0, j1, i] + tt[5, k0, j0, i]
                )
                out[2, k, j, i] = q


@numba.njit(inline="always", **_NJIT)
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


@numba.njit(inline="always", **_NJIT)
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


@numba.njit(parallel=True, **_NJIT)
def _radii(s, kinds, thr, h, rule, radius_out):  # type: ignore[no-untyped-def]
    _, nz, ny, nx = s.shape
    hx, hy, hz = 0.5 * h[0], 0.5 * h[1], 0.5 * h[2]
    four_pi_3 = 4.0 * np.pi / 3.0
    for kp in numba.prange(nz):
        k = np.int64(kp)
        for j in range(ny):
            for i in range(nx):
                kind = kinds[k, j, i]
                if kind == NONE:
                    radius_out[k, j, i] = 0.0
                    continue
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
                    radius_out[k, j, i] = acc / n if n > 0 else (hx + hy + hz) / 3.0
                else:
                    # the vertex's share of the source region: a box reaching the cut
                    # on each side; no edge = grid border (half a cell), a single-point
                    # axis counts its whole spacing
                    ex = 2.0 * hx if nx == 1 else max(cxm, 0.0) + max(cxp, 0.0)
                    ey = 2.0 * hy if ny == 1 else max(cym, 0.0) + max(cyp, 0.0)
                    ez = 2.0 * hz if nz == 1 else max(czm, 0.0) + max(czp, 0.0)
                    radius_out[k, j, i] = (ex * ey * ez / four_pi_3) ** (1.0 / 3.0)


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


@numba.njit(inline="always", **_NJIT)
def _any_bad_cross(bad, k, j, i, k0, k1, j0, j1, i0, i1):  # type: ignore[no-untyped-def]
    return (bad[k, j, i0] or bad[k, j, i1] or bad[k, j0, i] or bad[k, j1, i]
            or bad[k0, j, i] or bad[k1, j, i])  # fmt: skip


@numba.njit(parallel=True, **_NJIT)
def mask_nodata(bad, out):  # type: ignore[no-untyped-def]
    """Zero the strengths ``out (3, nz, ny, nx)`` whose stencil reads a no-data point.

    ``bad (nz, ny, nx)`` is True at no-data points.  A no-data point has no
    strength of any type; the dipole strength of a point needs its six edge
    neighbours (one-sided at grid faces: itself), the quadrupole strength
    every point its second and mixed differences read (see :func:`_stencil`).
    """
    nz, ny, nx = bad.shape
    for kp in numba.prange(nz):
        k = np.int64(kp)
        k0, k1 = _lohi(k, nz)
        kc = _inner(k, nz)
        for j in range(ny):
            j0, j1 = _lohi(j, ny)
            jc = _inner(j, ny)
            for i in range(nx):
                i0, i1 = _lohi(i, nx)
                ic = _inner(i, nx)
                if bad[k, j, i]:
                    out[0, k, j, i] = 0.0
                    out[1, k, j, i] = 0.0
                    out[2, k, j, i] = 0.0
                    continue
                if _any_bad_cross(bad, k, j, i, k0, k1, j0, j1, i0, i1):
                    out[1, k, j, i] = 0.0
                    out[2, k, j, i] = 0.0
                    continue
                q_bad = False
                if nx >= 3:
                    q_bad = q_bad or bad[k, j, ic - 1] or bad[k, j, ic] or bad[k, j, ic + 1]
                if ny >= 3:
                    q_bad = q_bad or bad[k, jc - 1, i] or bad[k, jc, i] or bad[k, jc + 1, i]
                if nz >= 3:
                    q_bad = q_bad or bad[kc - 1, j, i] or bad[kc, j, i] or bad[kc + 1, j, i]
                q_bad = (q_bad or bad[k, j0, i0] or bad[k, j0, i1] or bad[k, j1, i0]
                         or bad[k, j1, i1] or bad[k0, j, i0] or bad[k0, j, i1]
                         or bad[k1, j, i0] or bad[k1, j, i1] or bad[k0, j0, i]
                         or bad[k0, j1, i] or bad[k1, j0, i] or bad[k1, j1, i])  # fmt: skip
                if q_bad:
                    out[2, k, j, i] = 0.0


def quadrupole_of_stress(tt, h):  # type: ignore[no-untyped-def]
    """Quadrupole strength ``(nz, ny, nx)`` of a given stress ``tt (6, nz, ny, nx)``.

    The same stencil as :func:`strengths` (so the same numbers give the
    same result bit for bit); used for the time-mean stress.
    """
    shape = tt.shape[1:]
    out = np.empty((3, *shape))
    zero = np.zeros(shape)
    _stencil(zero, zero, np.zeros((3, *shape)), np.ascontiguousarray(tt), 0.0,
             np.asarray(h, dtype=np.float64), out)  # fmt: skip
    return out[2].copy()


def empty_like_strengths(shape: tuple[int, int, int]) -> np.ndarray:
    return np.empty((3, *shape), dtype=np.float64)
