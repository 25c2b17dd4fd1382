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
(∂_j (∂_i T_ij)), the divergence of the divergence.  Everything here is
numpy: the curvilinear path is slower than the compiled uniform stencil of
:mod:`auralize.sources._kernels`, which uniform grids keep, bit for bit.
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

    def divergence(self, comps: tuple[Array, Array, Array] | Array, *,
                   wide: bool = False) -> Array:  # fmt: skip
        """∇·F ``(nz, ny, nx)`` of the components ``(F_x, F_y, F_z)`` (each ``(nz, ny, nx)``)."""
        inv = self._inv(wide)
        out = np.zeros(self.shape)
        for i in range(3):
            fi = comps[i]
            for a in range(3):
                if self.shape[_axis(a, 3)] > 1:
                    out += inv[..., a, i] * index_derivative(fi, _axis(a, 3), wide=wide)
        return out

    def quadrupole(self, tt: Array, *, wide: bool = False) -> Array:
        """Σ_ij ∂²T_ij/∂x_i∂x_j ``(nz, ny, nx)`` of the symmetric stress ``tt (6, nz, ny, nx)``
        (order xx, yy, zz, xy, xz, yz): ∂_j (∂_i T_ij)."""
        w = [self.divergence(tt[list(_STRESS_INDEX[j])], wide=wide) for j in range(3)]
        return self.divergence((w[0], w[1], w[2]), wide=wide)

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
                w = ((fr[0] if di else 1 - fr[0]) * (fr[1] if dj else 1 - fr[1])
                     * (fr[2] if dk else 1 - fr[2]))  # fmt: skip
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


def curvilinear_strengths(metric: CurvilinearMetric, rho_a: Array, rho_b: Array, dm: Array,
                          tt: Array, inv_dt: float, out: Array) -> None:  # fmt: skip
    """Monopole, dipole and quadrupole strengths (paper 003 §3.2.3) on a curvilinear grid
    into ``out (3, nz, ny, nx)``: ∂ρ/∂t, ∇·(Δm)/Δt and ∂_j ∂_i T_ij, from the planar
    momentum change ``dm (3, ...)`` and stress ``tt (6, ...)`` (as
    :func:`auralize.sources._kernels.strengths`)."""
    np.multiply(rho_b - rho_a, inv_dt, out=out[0])
    np.multiply(metric.divergence((dm[0], dm[1], dm[2])), inv_dt, out=out[1])
    out[2] = metric.quadrupole(tt)


def curvilinear_errors(metric: CurvilinearMetric, s: Array, rho_a2: Array, rho_b2: Array,
                       dm: Array, dm2: Array, tt: Array, bad: NDArray[np.bool_],
                       inv_dt: float, inv_dt2: float) -> Array:  # fmt: skip
    """Discretisation-error estimates ``(3, nz, ny, nx)`` of the strengths ``s``: the
    Richardson estimates of :func:`auralize.sources._kernels._error_plane` (``|S_h −
    S_2h| / 3``, the 2h stencil of :func:`index_derivative` with its own metric;
    2Δt in time), 0 at no-data points."""
    err = np.zeros_like(s)
    if inv_dt2 > 0.0:
        err[0] = np.abs(s[0] - (rho_b2 - rho_a2) * inv_dt2) / 3.0
    d1 = metric.divergence((dm[0], dm[1], dm[2]))
    d2 = metric.divergence((dm[0], dm[1], dm[2]), wide=True)
    err[1] = np.abs(d1 - d2) * (inv_dt / 3.0)
    if inv_dt2 > 0.0:
        err[1] += np.abs(s[1] - metric.divergence((dm2[0], dm2[1], dm2[2])) * inv_dt2) / 3.0
    err[2] = np.abs(metric.quadrupole(tt) - metric.quadrupole(tt, wide=True)) / 3.0
    err[:, bad] = 0.0
    return err


def curvilinear_residual(metric: CurvilinearMetric, rho_a: Array, rho_b: Array,
                         rho_a2: Array, rho_b2: Array, m_c: Array, inv_dt: float,
                         inv_dt2: float, bad: NDArray[np.bool_], out: Array,
                         err: Array) -> None:  # fmt: skip
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
