"""Structured curvilinear grids: derivatives on the grid's own points (metric terms).

A structured curvilinear grid (PLOT3D, ``vtkStructuredGrid``, an ocean model's
or a lat/lon grid's coordinates) is logically a box of points indexed
``(i, j, k)`` — the index coordinates ξ = (ξ, η, ζ) — whose positions
``x(ξ)`` are given per point (``coords (nz, ny, nx, 3)``, x fastest as every
frame of :mod:`auralize.volume`).  Resampling it onto a uniform grid loses
what its fine cells resolve (an airfoil's boundary layer in an O-grid); here
it is differentiated where it is, by the chain rule:

* the metric ∂x_i/∂ξ_a is the index-space difference of the coordinates
  (:func:`index_derivative`: central inside, second-order one-sided at the
  faces, :func:`numpy.gradient` with ``edge_order=2``; an axis of 2 points
  its one difference, an axis of 1 point none);
* its inverse ∂ξ_a/∂x_i (3 × 3 per point) turns index derivatives into space
  derivatives: ∂f/∂x_i = Σ_a ∂ξ_a/∂x_i ∂f/∂ξ_a;
* the point's volume is ΔV = |det ∂x/∂ξ| times the trapezoid weights in index
  space (half at a face), which sum to the domain's volume to second order.

An axis of one point (a one-layer or 2-D grid) has no ∂x/∂ξ_a; it is taken
as the unit normal of the other two directions times a *thickness* (the
volume's nominal spacing along it), so the Jacobian stays invertible, the
derivative across the layer is 0 and ΔV is the area times the thickness,
as a uniform grid's one-point axis counts its whole spacing.

Since the index derivative is linear and applied alike to the coordinates
and to a field, the gradient of a field linear in x is exact (to round-off)
on any grid; a smooth field's converges at second order.  Second
derivatives (Lighthill's ∂²T_ij/∂x_i∂x_j) are two first derivatives
(∂_j (∂_i T_ij)), the divergence of the divergence.  The divergence, which
every strength and its error estimate are made of, is one compiled kernel
(numba, parallel over z-planes, compiled on first use: :func:`_kernel`); the
rest is numpy.  The kernel does the numpy reference's arithmetic in its order
(``CurvilinearMetric.divergence(..., compiled=False)``), so both agree to
round-off.  Uniform grids keep the stencil of :mod:`auralize.sources._kernels`,
bit for bit.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError

Array = NDArray[np.float64]

#: order of the stress components in the detection's arrays (xx, yy, zz, xy, xz, yz)
_STRESS_INDEX = ((0, 3, 4), (3, 1, 5), (4, 5, 2))
#: a cell whose |det ∂x/∂ξ| is below this fraction of the median is degenerate
DEGENERATE = 1e-10


def index_derivative(f: Array, axis: int, *, wide: bool = False) -> Array:
    """∂f/∂ξ along array ``axis`` in index units (unit spacing).

    Central differences inside, second-order one-sided at the faces
    (:func:`numpy.gradient`, ``edge_order=2``); an axis of 2 points its one
    difference, of 1 point 0.  ``wide``: the same over every second point
    (the 2h stencil, for Richardson error estimates; the h stencil where the
    axis has fewer than 6 points).

    Examples
    --------
    >>> index_derivative(np.array([0.0, 1.0, 4.0, 9.0]), 0).tolist()
    [0.0, 2.0, 4.0, 6.0]
    """
    n = f.shape[axis]
    if n == 1:
        return np.zeros_like(f)
    if n == 2:
        d = np.diff(f, axis=axis)
        return np.concatenate([d, d], axis=axis)
    if not wide or n < 6:
        return np.gradient(f, axis=axis, edge_order=2)
    out = np.empty_like(f)
    for o in (0, 1):
        sl: list[Any] = [slice(None)] * f.ndim
        sl[axis] = slice(o, None, 2)
        out[tuple(sl)] = np.gradient(f[tuple(sl)], axis=axis, edge_order=2) * 0.5
    return out


def _axis(a: int, ndim: int) -> int:
    """The array axis of index direction ``a`` (0 ξ/i/x-fastest, 1 η/j, 2 ζ/k) of a
    ``(nz, ny, nx, ...)`` array."""
    return 2 - a


def _unit(v: Array) -> Array:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


class CurvilinearMetric:
    """The metric terms of a structured curvilinear grid (see the module docstring).

    Parameters
    ----------
    coords : (nz, ny, nx, 3) array
        Point positions in metres.
    thickness : (3,) array
        Length given to an index direction of one point (x, y, z order of
        the index directions i, j, k).
    source : str
        For messages.

    Attributes
    ----------
    inv : (nz, ny, nx, 3, 3)
        ``inv[..., a, i]`` = ∂ξ_a/∂x_i.
    jac : (nz, ny, nx)
        |det ∂x/∂ξ| in m³ per index cell.

    Examples
    --------
    >>> xi, eta = np.meshgrid(np.arange(6.0), np.arange(5.0), indexing="xy")
    >>> coords = np.stack([xi + 0.3 * np.sin(eta), eta, np.zeros_like(xi)], -1)[None]
    >>> m = CurvilinearMetric(coords, thickness=np.ones(3))
    >>> g = m.gradient(2.0 * coords[..., 0] - coords[..., 1])
    >>> bool(np.allclose(g[..., 0], 2.0) and np.allclose(g[..., 1], -1.0))
    True
    """

    def __init__(self, coords: Array, *, thickness: Array, source: str = "<memory>") -> None:
        self.coords = np.ascontiguousarray(coords, dtype=np.float64)
        self.shape = self.coords.shape[:3]
        self.thickness = np.asarray(thickness, dtype=np.float64)
        self.source = source
        self.inv, det = self._metric(wide=False)
        self.jac = np.abs(det)
        self._wide: Array | None = None

    def _metric(self, *, wide: bool) -> tuple[Array, Array]:
        c = self.coords
        live = [c.shape[_axis(a, 4)] > 1 for a in range(3)]
        cols = [index_derivative(c, _axis(a, 4), wide=wide) for a in range(3)]
        flat = [a for a in range(3) if not live[a]]
        if len(flat) == 1:
            a = flat[0]
            b, d = (a + 1) % 3, (a + 2) % 3  # right-handed with the others
            cols[a] = _unit(np.cross(cols[b], cols[d])) * self.thickness[a]
        elif len(flat) == 2:
            (t,) = [cols[a] for a in range(3) if live[a]]
            tu = _unit(t)
            e = np.zeros_like(tu)
            e[..., np.argmin(np.abs(tu).reshape(-1, 3).mean(axis=0))] = 1.0
            n1 = _unit(np.cross(tu, e))
            n2 = _unit(np.cross(tu, n1))
            cols[flat[0]] = n1 * self.thickness[flat[0]]
            cols[flat[1]] = n2 * self.thickness[flat[1]]
        elif len(flat) == 3:
            for a in range(3):
                cols[a] = np.zeros_like(c)
                cols[a][..., a] = self.thickness[a]
        jm = np.stack(cols, axis=-1)  # (..., i, a) = ∂x_i/∂ξ_a
        det = np.linalg.det(jm)
        scale = float(np.median(np.abs(det))) if det.size else 0.0
        bad = ~(np.abs(det) > DEGENERATE * scale) if scale > 0 else np.ones(det.shape, bool)
        if bad.any():
            k, j, i = (int(v[0]) for v in np.nonzero(bad))
            raise DataError(
                f"{self.source}: the curvilinear grid has {int(bad.sum())} degenerate points "
                f"(cells of zero volume: coinciding or collapsed grid lines), e.g. point "
                f"(i, j, k) = ({i}, {j}, {k}) at {c[k, j, i].tolist()} m; read it resampled "
                f"onto a uniform grid (--resample, curvilinear='resample')"
            )
        return np.asarray(np.linalg.inv(jm), dtype=np.float64), np.asarray(det, dtype=np.float64)

    @property
    def inv_wide(self) -> Array:
        """∂ξ_a/∂x_i of the 2h stencil (:func:`index_derivative` ``wide``)."""
        if self._wide is None:
            self._wide = self._metric(wide=True)[0]
        return self._wide

    def _inv(self, wide: bool) -> Array:
        return self.inv_wide if wide else self.inv

    # ----------------------------------------------------------- derivatives
    def gradient(self, f: Array, *, wide: bool = False) -> Array:
        """∇f ``(nz, ny, nx, 3)`` (components x, y, z) of a scalar ``f (nz, ny, nx)``."""
        d = np.stack([index_derivative(f, _axis(a, 3), wide=wide) for a in range(3)], axis=-1)
        return np.einsum("...a,...ai->...i", d, self._inv(wide))

    def divergence(
        self,
        comps: tuple[Array, Array, Array] | Array,
        *,
        wide: bool = False,
        compiled: bool = True,
    ) -> Array:
        """∇·F ``(nz, ny, nx)`` of the components ``(F_x, F_y, F_z)`` (each ``(nz, ny, nx)``).

        ``compiled``: the numba kernel (:func:`_divergence_planes`); False: the
        numpy reference, whose numbers it gives to round-off.
        """
        inv = self._inv(wide)
        if compiled:
            from auralize.runtime.jit import kernel_args

            out = np.empty(self.shape)
            f = comps if isinstance(comps, np.ndarray) else np.stack(comps)
            _kernel()(*kernel_args(inv, f, int(wide), out))
            return out
        out = np.zeros(self.shape)
        for i in range(3):
            fi = comps[i]
            for a in range(3):
                if self.shape[_axis(a, 3)] > 1:
                    out += inv[..., a, i] * index_derivative(fi, _axis(a, 3), wide=wide)
        return out

    def quadrupole(self, tt: Array, *, wide: bool = False, compiled: bool = True) -> Array:
        """Σ_ij ∂²T_ij/∂x_i∂x_j ``(nz, ny, nx)`` of the symmetric stress ``tt (6, nz, ny, nx)``
        (order xx, yy, zz, xy, xz, yz): ∂_j (∂_i T_ij)."""
        w = np.stack(
            [
                self.divergence(tt[list(_STRESS_INDEX[j])], wide=wide, compiled=compiled)
                for j in range(3)
            ]
        )
        return self.divergence(w, wide=wide, compiled=compiled)

    # --------------------------------------------------------------- volumes
    def cell_volume(self) -> Array:
        """ΔV ``(nz, ny, nx)`` in m³: |det ∂x/∂ξ| times the trapezoid weights of the
        index directions (half at a face, 1 along an axis of one point)."""
        w = []
        for ax in range(3):  # z, y, x
            n = self.shape[ax]
            a = np.ones(n)
            if n > 1:
                a[0] = a[-1] = 0.5
            w.append(a)
        return self.jac * (w[0][:, None, None] * w[1][None, :, None] * w[2][None, None, :])

    # --------------------------------------------------------------- no-data
    def spread(self, bad: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """Points whose first derivative (any direction) reads a point of ``bad``."""
        out = bad.copy()
        for ax in range(3):
            n = bad.shape[ax]
            if n == 1:
                continue
            b = np.moveaxis(bad, ax, 0)
            o = np.moveaxis(out, ax, 0)
            o[1:] |= b[:-1]
            o[:-1] |= b[1:]
            if n >= 3:
                o[0] |= b[2]
                o[-1] |= b[-3]
        return out

    def mask_nodata(self, bad: NDArray[np.bool_], out: Array) -> None:
        """Zero the strengths ``out (3, nz, ny, nx)`` whose stencil reads a no-data point
        (monopole: the point; dipole: a first derivative's; quadrupole: two)."""
        once = self.spread(bad)
        out[0][bad] = 0.0
        out[1][once] = 0.0
        out[2][self.spread(once)] = 0.0


def _divergence_planes(inv, f, wide, out):
    """``out (nz, ny, nx)`` = Σ_i Σ_a ∂ξ_a/∂x_i ∂f_i/∂ξ_a of ``f (3, nz, ny, nx)`` with
    ``inv (nz, ny, nx, 3, 3)`` (:attr:`CurvilinearMetric.inv`), z-planes in parallel.

    The index derivative is :func:`index_derivative`'s as a 3-point stencil per
    point and axis (tabulated first): :func:`numpy.gradient`'s central
    ``(f[q+1] - f[q-1]) / 2``, ``-1.5 f0 + 2 f1 - 0.5 f2`` and ``0.5 f[-3] - 2 f[-2]
    + 1.5 f[-1]`` at the faces, one difference on 2 points; ``wide`` (1): the
    same over every second point, halved, on axes of 6 points or more.  Its
    weights are those of numpy's formulas (halving is exact), and the sum is
    taken in the numpy reference's order, so the two agree to round-off.
    Compiled by :func:`_kernel`.
    """
    nz, ny, nx = out.shape
    dims = (nx, ny, nz)
    big = max(nx, ny, nz)
    at = np.zeros((3, big, 3), dtype=np.int64)  # [axis, q, m]: the stencil's points
    wt = np.zeros((3, big, 3))  # and their weights
    for a in range(3):
        n = dims[a]
        s = 2 if wide == 1 and n >= 6 else 1
        h = 0.5 if s == 2 else 1.0
        for q in range(n):
            if n == 1:
                at[a, q, 0], at[a, q, 1], at[a, q, 2] = 0, 0, 0
            elif n == 2:
                at[a, q, 0], at[a, q, 1], at[a, q, 2] = 0, 1, 1
                wt[a, q, 0], wt[a, q, 1] = -1.0, 1.0
            elif q < s:  # the first point of its subsequence
                at[a, q, 0], at[a, q, 1], at[a, q, 2] = q, q + s, q + 2 * s
                wt[a, q, 0], wt[a, q, 1], wt[a, q, 2] = -1.5 * h, 2.0 * h, -0.5 * h
            elif q > n - 1 - s:  # the last
                at[a, q, 0], at[a, q, 1], at[a, q, 2] = q - 2 * s, q - s, q
                wt[a, q, 0], wt[a, q, 1], wt[a, q, 2] = 0.5 * h, -2.0 * h, 1.5 * h
            else:
                at[a, q, 0], at[a, q, 1], at[a, q, 2] = q - s, q, q + s
                wt[a, q, 0], wt[a, q, 2] = -0.5 * h, 0.5 * h
    for kp in prange(nz):
        k = np.int64(kp)  # prange's index may be unsigned: keep the index arithmetic signed
        k0, k1, k2 = at[2, k, 0], at[2, k, 1], at[2, k, 2]
        z0, z1, z2 = wt[2, k, 0], wt[2, k, 1], wt[2, k, 2]
        for j in range(ny):
            j0, j1, j2 = at[1, j, 0], at[1, j, 1], at[1, j, 2]
            y0, y1, y2 = wt[1, j, 0], wt[1, j, 1], wt[1, j, 2]
            for i in range(nx):
                i0, i1, i2 = at[0, i, 0], at[0, i, 1], at[0, i, 2]
                x0, x1, x2 = wt[0, i, 0], wt[0, i, 1], wt[0, i, 2]
                acc = 0.0
                for c in range(3):
                    if nx > 1:
                        d = x0 * f[c, k, j, i0] + x1 * f[c, k, j, i1] + x2 * f[c, k, j, i2]
                        acc += inv[k, j, i, 0, c] * d
                    if ny > 1:
                        d = y0 * f[c, k, j0, i] + y1 * f[c, k, j1, i] + y2 * f[c, k, j2, i]
                        acc += inv[k, j, i, 1, c] * d
                    if nz > 1:
                        d = z0 * f[c, k0, j, i] + z1 * f[c, k1, j, i] + z2 * f[c, k2, j, i]
                        acc += inv[k, j, i, 2, c] * d
                out[k, j, i] = acc


def prange(n: int) -> range:
    """``range``; :func:`_kernel` compiles :func:`_divergence_planes` with numba's
    ``prange`` in its place."""
    return range(n)


_COMPILED: list[Any] = []


def _kernel() -> Any:
    """:func:`_divergence_planes` compiled (once per process, from numba's cache when
    it holds it), one specialization: C-contiguous float64 arrays and an int.

    numba is imported here, not when the module is, so reading a curvilinear
    grid (``auralize info``) loads no compiler.
    """
    if not _COMPILED:
        import numba

        from auralize.runtime.jit import configure

        configure()  # cache folder, OMP wait policy, compile notice
        globals()["prange"] = numba.prange
        _COMPILED.append(
            numba.njit(
                "void(float64[:, :, :, :, ::1], float64[:, :, :, ::1], int64, float64[:, :, ::1])",
                parallel=True,
                cache=True,
                nogil=True,
                fastmath=False,
            )(_divergence_planes)
        )
    return _COMPILED[0]


def interp_coords(coords: Array, ijk: NDArray[np.floating]) -> Array:
    """Positions ``(N, 3)`` at fractional index positions ``ijk (N, 3)`` (columns i, j, k):
    multilinear interpolation of ``coords (nz, ny, nx, 3)`` (clipped to the grid)."""
    p = np.asarray(ijk, dtype=np.float64).reshape(-1, 3)
    nz, ny, nx = coords.shape[:3]
    out = np.zeros((p.shape[0], 3))
    lo, fr = [], []
    for a, n in enumerate((nx, ny, nz)):
        x = np.clip(p[:, a], 0.0, n - 1)
        i0 = np.minimum(np.floor(x).astype(np.intp), max(n - 2, 0))
        lo.append(i0)
        fr.append(x - i0 if n > 1 else np.zeros_like(x))
    for dk in (0, 1):
        for dj in (0, 1):
            for di in (0, 1):
                w = (
                    (fr[0] if di else 1 - fr[0])
                    * (fr[1] if dj else 1 - fr[1])
                    * (fr[2] if dk else 1 - fr[2])
                )
                i = np.minimum(lo[0] + di, nx - 1)
                j = np.minimum(lo[1] + dj, ny - 1)
                k = np.minimum(lo[2] + dk, nz - 1)
                out += w[:, None] * coords[k, j, i]
    return out


def nominal_spacing(coords: Array) -> Array:
    """Mean edge length along each index direction (x, y, z order of i, j, k) in metres;
    an axis of one point gets the smallest of the others (1 m if none)."""
    h = np.zeros(3)
    for a in range(3):
        ax = _axis(a, 4)
        if coords.shape[ax] > 1:
            h[a] = float(np.mean(np.linalg.norm(np.diff(coords, axis=ax), axis=-1)))
    live = h[h > 0]
    h[h <= 0] = float(live.min()) if live.size else 1.0
    return h


def max_edge(coords: Array, thickness: Array) -> Array:
    """Longest edge between neighbouring points along each index direction (x, y, z
    order of i, j, k) in metres; ``thickness`` along an axis of one point."""
    h = np.asarray(thickness, dtype=np.float64).copy()
    for a in range(3):
        ax = _axis(a, 4)
        if coords.shape[ax] > 1:
            h[a] = float(np.max(np.linalg.norm(np.diff(coords, axis=ax), axis=-1)))
    return h


def curvilinear_strengths(
    metric: CurvilinearMetric,
    rho_a: Array,
    rho_b: Array,
    dm: Array,
    tt: Array,
    *,
    inv_dt: float,
    out: Array,
) -> None:
    """Monopole, dipole and quadrupole strengths (paper 003 §3.2.3) on a curvilinear grid
    into ``out (3, nz, ny, nx)``: ∂ρ/∂t, ∇·(Δm)/Δt and ∂_j ∂_i T_ij, from the planar
    momentum change ``dm (3, ...)`` and stress ``tt (6, ...)`` (as
    :func:`auralize.sources._kernels.strengths`)."""
    np.multiply(rho_b - rho_a, inv_dt, out=out[0])
    np.multiply(metric.divergence(dm), inv_dt, out=out[1])
    out[2] = metric.quadrupole(tt)


def curvilinear_errors(
    metric: CurvilinearMetric,
    s: Array,
    *,
    rho_a2: Array,
    rho_b2: Array,
    dm: Array,
    dm2: Array,
    tt: Array,
    bad: NDArray[np.bool_],
    inv_dt: float,
    inv_dt2: float,
) -> Array:
    """Discretisation-error estimates ``(3, nz, ny, nx)`` of the strengths ``s``: the
    Richardson estimates of :func:`auralize.sources._kernels._error_point` (``|S_h −
    S_2h| / 3``, the 2h stencil of :func:`index_derivative` with its own metric;
    2Δt in time), 0 at no-data points."""
    err = np.zeros_like(s)
    if inv_dt2 > 0.0:
        err[0] = np.abs(s[0] - (rho_b2 - rho_a2) * inv_dt2) / 3.0
    d1 = metric.divergence(dm)
    d2 = metric.divergence(dm, wide=True)
    err[1] = np.abs(d1 - d2) * (inv_dt / 3.0)
    if inv_dt2 > 0.0:
        err[1] += np.abs(s[1] - metric.divergence(dm2) * inv_dt2) / 3.0
    err[2] = np.abs(metric.quadrupole(tt) - metric.quadrupole(tt, wide=True)) / 3.0
    err[:, bad] = 0.0
    return err


def curvilinear_residual(
    metric: CurvilinearMetric,
    rho_a: Array,
    rho_b: Array,
    rho_a2: Array,
    rho_b2: Array,
    *,
    m_c: Array,
    inv_dt: float,
    inv_dt2: float,
    bad: NDArray[np.bool_],
    out: Array,
    err: Array,
) -> None:
    """Continuity residual ∂ρ/∂t + ∇·m and its error estimate (as
    :func:`auralize.sources._kernels.residual`) on a curvilinear grid."""
    comps = (m_c[..., 0], m_c[..., 1], m_c[..., 2])
    dt1 = (rho_b - rho_a) * inv_dt
    d1 = metric.divergence(comps)
    out[...] = dt1 + d1
    e = np.abs(d1 - metric.divergence(comps, wide=True)) / 3.0
    if inv_dt2 > 0.0:
        e += np.abs(dt1 - (rho_b2 - rho_a2) * inv_dt2) / 3.0
    e[bad] = 0.0
    err[...] = e
