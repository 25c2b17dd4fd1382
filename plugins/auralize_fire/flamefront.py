"""Flame-front reconstruction and the velocity-flux integral (paper 001 §3.1–§3.2).

The front S is the iso-surface of a smooth field B̃ built from the voxel field
B (burn rate, fuel, temperature or a level set) with the cubic B-spline basis
of Eqs. 7–8::

    B̃(x) = Σ_ijk φ((x - x_i)/h) φ((y - y_j)/h) φ((z - z_k)/h) B_ijk

B̃ is evaluated on a grid refined ``refine`` times, the surface is extracted
with VTK's flying-edges contouring, and normals come from the analytic
gradient of B̃ at each triangle's centroid.  The flux I = ∫_S u·n dS (Eq. 5)
uses one-point quadrature per triangle (§6) with u trilinearly sampled from
the voxel velocity field.

Boundary handling: the voxel field is padded by linear extrapolation
(B_-1 = 2 B_0 - B_1), so B̃ reproduces fields linear in x, y, z exactly up to
the grid's edges.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, ParameterError
from auralize_fire import _kernels

#: frames are padded with this many linearly extrapolated samples on each side
_PAD = 2


def bspline(t: NDArray[np.floating] | float) -> NDArray[np.float64]:
    """Cubic B-spline basis φ(t) of paper 001 Eq. 8 (support |t| < 2, unit sum over shifts).

    Parameters
    ----------
    t : array_like
        Offsets in grid units.

    Returns
    -------
    ndarray, same shape as ``t``.

    Examples
    --------
    >>> float(bspline(0.0)), float(bspline(1.0))
    (0.6666666666666666, 0.16666666666666666)
    """
    a = np.abs(np.asarray(t, dtype=np.float64))
    tau = 1.0 - a
    inner = (-3 * tau**3 + 3 * tau**2 + 3 * tau + 1) / 6.0
    outer = (1.0 + tau) ** 3 / 6.0
    return np.where(a <= 1, inner, np.where(a <= 2, outer, 0.0))


def bspline_deriv(t: NDArray[np.floating] | float) -> NDArray[np.float64]:
    """dφ/dt of :func:`bspline` (grid units)."""
    tt = np.asarray(t, dtype=np.float64)
    a = np.abs(tt)
    s = np.sign(tt)
    inner = (-12 * a + 9 * a**2) / 6.0  # d/da (4 - 6a² + 3a³)/6
    outer = -3 * (2 - a) ** 2 / 6.0  # d/da (2 - a)³/6
    return s * np.where(a <= 1, inner, np.where(a <= 2, outer, 0.0))


def _pad_linear(
    a: NDArray[np.float64], axes: tuple[int, ...], n: int = _PAD
) -> NDArray[np.float64]:
    """Pad ``a`` by ``n`` samples per side along ``axes`` with linear extrapolation."""
    out = a
    for ax in axes:
        m = out.shape[ax]
        if m < 2:
            raise DataError(f"need at least 2 samples along axis {ax} to extrapolate, got {m}")
        first = np.take(out, [0], axis=ax)
        d0 = first - np.take(out, [1], axis=ax)
        last = np.take(out, [m - 1], axis=ax)
        d1 = last - np.take(out, [m - 2], axis=ax)
        lo = [first + k * d0 for k in range(n, 0, -1)]
        hi = [last + k * d1 for k in range(1, n + 1)]
        out = np.concatenate([*lo, out, *hi], axis=ax)
    return out


def _refine_axis(a: NDArray[np.float64], axis: int, r: int) -> NDArray[np.float64]:
    """Evaluate the B-spline sum along one (padded) axis at ``r`` points per cell.

    ``a`` is padded by :data:`_PAD` along ``axis``; the result has
    ``(n - 1) r + 1`` samples there (n = unpadded length).
    """
    b = np.moveaxis(a, axis, 0)
    n = b.shape[0] - 2 * _PAD
    nf = (n - 1) * r + 1
    out = np.empty((nf, *b.shape[1:]), dtype=np.float64)
    for p in range(r):
        d = p / r
        cnt = n if p == 0 else n - 1  # fine points i*r + p with i + d <= n - 1
        acc = np.zeros((cnt, *b.shape[1:]))
        for k in (-1, 0, 1, 2):
            w = float(bspline(d - k))
            if w != 0.0:
                acc += w * b[_PAD + k : _PAD + k + cnt]
        out[p::r] = acc
    return np.moveaxis(out, 0, axis)


def refine_bspline(
    field: NDArray[np.floating], refine: int = 2, *, engine: str = "numba"
) -> NDArray[np.float64]:
    """Sample B̃ (Eq. 7) on a grid ``refine`` times finer than the voxel grid.

    Parameters
    ----------
    field : (nz, ny, nx) voxel values B_ijk.
    refine : int >= 1
        Fine points per voxel edge; the output keeps the original corners.
    engine : ``"numba"`` (fused loops) or ``"numpy"`` (reference; same result).

    Returns
    -------
    (((nz-1) r + 1), ((ny-1) r + 1), ((nx-1) r + 1)) array of B̃.
    """
    if int(refine) != refine or refine < 1:
        raise ParameterError(f"refine must be an integer >= 1, got {refine!r}")
    from auralize.runtime.resources import require_memory

    fine_points = float(np.prod([float(n) * refine for n in np.shape(field)[:3]]))
    # the refined grid in float64, its per-axis intermediates and the contour's working copies
    require_memory(
        fine_points * 8 * 4,
        f"B-spline refinement {refine} of a {'x'.join(str(n) for n in np.shape(field)[:3])} grid",
        hint="use a smaller --refine (2 is the paper's)",
    )
    if engine not in ("numba", "numpy"):
        raise ParameterError(f"engine must be 'numba' or 'numpy', got {engine!r}")
    a = _pad_linear(np.asarray(field, dtype=np.float64), (0, 1, 2))
    for ax in (2, 1, 0):  # each pass drops the padding of its own axis only
        if engine == "numba":
            a = _kernels.refine_axis(np.ascontiguousarray(a), ax, int(refine), _PAD)
        else:
            a = _refine_axis(a, ax, int(refine))
    return a


def _taps(u: NDArray[np.float64], n: int) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Tap indices (into a padded axis) and offsets for evaluation at index coordinates u."""
    i0 = np.clip(np.floor(u).astype(np.int64), 0, n - 2)
    frac = u - i0
    k = np.arange(-1, 3)
    return i0[:, None] + k + _PAD, frac[:, None] - k


def bspline_eval(
    field: NDArray[np.floating],
    ijk: NDArray[np.floating],
    *,
    gradient: bool = False,
    engine: str = "numba",
) -> NDArray[np.float64]:
    """Evaluate B̃ (Eq. 7) or its gradient at arbitrary index coordinates.

    Parameters
    ----------
    field : (nz, ny, nx) voxel values.
    ijk : (N, 3) points in index units (x, y, z order), inside the grid.
    gradient : return ∂B̃/∂(i, j, k) instead of B̃.
    engine : ``"numba"`` (fused loop) or ``"numpy"`` (reference; same result).

    Returns
    -------
    (N,) values or (N, 3) gradient per index unit (divide by the spacing for SI).
    """
    f = _pad_linear(np.asarray(field, dtype=np.float64), (0, 1, 2))
    nz, ny, nx = np.asarray(field).shape
    p = np.asarray(ijk, dtype=np.float64).reshape(-1, 3)
    if engine == "numba":
        out = _kernels.eval_points(f, p, np.array([nx, ny, nz]), _PAD, gradient)
        return out if gradient else out[:, 0]
    if engine != "numpy":
        raise ParameterError(f"engine must be 'numba' or 'numpy', got {engine!r}")
    ix, tx = _taps(p[:, 0], nx)
    iy, ty = _taps(p[:, 1], ny)
    iz, tz = _taps(p[:, 2], nz)
    vals = f[iz[:, :, None, None], iy[:, None, :, None], ix[:, None, None, :]]
    wx, wy, wz = bspline(tx), bspline(ty), bspline(tz)
    if not gradient:
        return np.einsum("nabc,na,nb,nc->n", vals, wz, wy, wx)
    dx, dy, dz = bspline_deriv(tx), bspline_deriv(ty), bspline_deriv(tz)
    return np.stack(
        [
            np.einsum("nabc,na,nb,nc->n", vals, wz, wy, dx),
            np.einsum("nabc,na,nb,nc->n", vals, wz, dy, wx),
            np.einsum("nabc,na,nb,nc->n", vals, dz, wy, wx),
        ],
        axis=1,
    )


def trilinear(field: NDArray[np.floating], ijk: NDArray[np.floating]) -> NDArray[np.float64]:
    """Trilinear interpolation of a (nz, ny, nx[, C]) field at (N, 3) index points (x, y, z).

    Points outside the grid are clamped to its faces.
    """
    a = np.asarray(field, dtype=np.float64)
    nz, ny, nx = a.shape[:3]
    p = np.asarray(ijk, dtype=np.float64).reshape(-1, 3)
    x = np.clip(p[:, 0], 0, nx - 1)
    y = np.clip(p[:, 1], 0, ny - 1)
    z = np.clip(p[:, 2], 0, nz - 1)
    i = np.minimum(x.astype(np.int64), max(nx - 2, 0))
    j = np.minimum(y.astype(np.int64), max(ny - 2, 0))
    k = np.minimum(z.astype(np.int64), max(nz - 2, 0))
    fx, fy, fz = x - i, y - j, z - k
    i1, j1, k1 = np.minimum(i + 1, nx - 1), np.minimum(j + 1, ny - 1), np.minimum(k + 1, nz - 1)
    extra = (slice(None),) * (a.ndim - 3)
    sh = (-1,) + (1,) * (a.ndim - 3)
    fx, fy, fz = fx.reshape(sh), fy.reshape(sh), fz.reshape(sh)
    c00 = a[(k, j, i, *extra)] * (1 - fx) + a[(k, j, i1, *extra)] * fx
    c01 = a[(k, j1, i, *extra)] * (1 - fx) + a[(k, j1, i1, *extra)] * fx
    c10 = a[(k1, j, i, *extra)] * (1 - fx) + a[(k1, j, i1, *extra)] * fx
    c11 = a[(k1, j1, i, *extra)] * (1 - fx) + a[(k1, j1, i1, *extra)] * fx
    return (c00 * (1 - fy) + c01 * fy) * (1 - fz) + (c10 * (1 - fy) + c11 * fy) * fz


@dataclass
class FlameFront:
    """A triangulated flame front at one time step.

    Attributes
    ----------
    points : (P, 3) vertex positions in metres.
    triangles : (T, 3) vertex indices.
    centroids : (T, 3) triangle centroids (quadrature points), metres.
    areas : (T,) triangle areas, m².
    normals : (T, 3) unit normals from the smooth field's gradient, pointing
        out of the burning region (towards lower B̃ for ``inside="high"``).
    """

    points: NDArray[np.float64]
    triangles: NDArray[np.int64]
    centroids: NDArray[np.float64]
    areas: NDArray[np.float64]
    normals: NDArray[np.float64]

    @property
    def area(self) -> float:
        """Total surface area (m²)."""
        return float(self.areas.sum())

    def flux(
        self,
        velocity: NDArray[np.floating],
        origin: NDArray[np.floating],
        spacing: NDArray[np.floating],
    ) -> float:
        """I = Σ_tri (u·n) A (paper 001 Eq. 5, one-point quadrature per triangle).

        Parameters
        ----------
        velocity : (nz, ny, nx, 3) m/s on the voxel grid.
        origin, spacing : (3,) grid geometry in metres.

        Returns
        -------
        float, m³/s.
        """
        return float(np.sum(self.u_dot_n(velocity, origin, spacing) * self.areas))

    def u_dot_n(
        self,
        velocity: NDArray[np.floating],
        origin: NDArray[np.floating],
        spacing: NDArray[np.floating],
    ) -> NDArray[np.float64]:
        """Normal velocity u·n at each triangle centroid (m/s), shape (T,)."""
        if len(self.areas) == 0:
            return np.zeros(0)
        ijk = (self.centroids - np.asarray(origin)) / np.asarray(spacing)
        u = trilinear(velocity, ijk)
        return np.einsum("ij,ij->i", u, self.normals)

    def to_pyvista(self) -> Any:
        """The front as a ``pyvista.PolyData`` (triangles; cell arrays ``area`` and ``normal``)."""
        import pyvista as pv

        faces = np.column_stack([np.full(len(self.triangles), 3), self.triangles]).ravel()
        mesh = pv.PolyData(self.points, faces=faces)
        mesh.cell_data["area"] = self.areas
        mesh.cell_data["normal"] = self.normals
        return mesh


def extract_front(
    field: NDArray[np.floating],
    iso: float,
    *,
    origin: NDArray[np.floating],
    spacing: NDArray[np.floating],
    refine: int = 2,
    inside: str = "high",
) -> FlameFront:
    """Flame front S = {B̃ = iso} (paper 001 §3.2, Eqs. 7–8).

    Parameters
    ----------
    field : (nz, ny, nx) voxel field B (e.g. burn rate, 1/s).
    iso : float
        Iso-value, in the field's units.
    origin, spacing : (3,) grid geometry in metres (x, y, z).
    refine : int
        B̃ is sampled ``refine`` times finer than the voxels before contouring.
    inside : ``"high"`` (burn, fuel, temperature: larger inside the flame) or
        ``"low"`` (level sets negative inside); sets the normal's orientation.

    Returns
    -------
    FlameFront (empty when the field does not cross ``iso``).

    Examples
    --------
    >>> x = np.linspace(-1, 1, 17)
    >>> z, y, xx = np.meshgrid(x, x, x, indexing="ij")
    >>> front = extract_front(0.5 - (xx**2 + y**2 + z**2), 0.0, origin=[-1, -1, -1],
    ...                       spacing=[0.125] * 3)
    >>> round(front.area / (4 * np.pi * 0.5), 2)  # B̃ of r² is r² + h²: radius² 0.5 - h²
    0.97
    """
    import pyvista as pv

    if inside not in ("high", "low"):
        raise ParameterError(f"inside must be 'high' or 'low', got {inside!r}")
    b = np.asarray(field, dtype=np.float64)
    if b.ndim != 3 or min(b.shape) < 2:
        raise DataError(
            f"flame-front field must be (nz, ny, nx) with >= 2 points per axis, got {b.shape}"
        )
    if not np.isfinite(iso):
        raise ParameterError(f"iso-value must be finite, got {iso!r}")
    org = np.asarray(origin, dtype=np.float64)
    sp = np.asarray(spacing, dtype=np.float64)
    fine = refine_bspline(b, refine)
    grid = pv.ImageData(dimensions=fine.shape[::-1], spacing=tuple(sp / refine), origin=tuple(org))
    grid.point_data["B"] = fine.ravel()
    surf = grid.contour(
        [float(iso)],
        scalars="B",
        method="flying_edges",
        compute_normals=False,
        compute_gradients=False,
        compute_scalars=False,
    )
    pts = np.asarray(surf.points, dtype=np.float64)
    if surf.n_cells == 0:
        e = np.zeros((0, 3))
        return FlameFront(pts.reshape(-1, 3), np.zeros((0, 3), np.int64), e, np.zeros(0), e)
    tris = np.asarray(surf.faces).reshape(-1, 4)[:, 1:].astype(np.int64)
    a, bb, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    cen = (a + bb + c) / 3.0
    areas = 0.5 * np.linalg.norm(np.cross(bb - a, c - a), axis=1)
    grad = bspline_eval(b, (cen - org) / sp, gradient=True) / sp
    gn = np.linalg.norm(grad, axis=1)
    ok = (gn > 0) & (areas > 0)
    n = np.zeros_like(grad)
    n[ok] = grad[ok] / gn[ok, None]
    if inside == "high":
        n = -n
    return FlameFront(pts, tris[ok], cen[ok], areas[ok], n[ok])
