"""Turning pyvista meshes, one time step at a time, into uniform-grid frames.

Every pyvista-based reader (``.pvd``, ``.series``, single VTK files, VTKHDF,
OpenFOAM) supplies a *loader* ``loader(step) -> mesh`` and the step times;
:func:`open_mesh_series` reads step 0 to learn the grid and the arrays, and
returns a :class:`~auralize.volume.TimeVolume` whose fields call the loader
again, one step per read.  Uniform grids (``ImageData``, evenly spaced
``RectilinearGrid``) keep their points; anything else is sampled onto a
uniform grid covering its bounds with VTK's ``vtkResampleWithDataSet``
(pyvista's :meth:`~pyvista.DataSetFilters.sample`).  Meshes whose points
are an evenly spaced lattice keep their points too, and so does a surface
(2-D cells) whose points project onto such a lattice, e.g. a height field
``z(x, y)``: it is read on the lattice in its plane (dims 1 across it),
with its own point values (:func:`surface_lattice`).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import AuralizeError, DataError, FormatError, MissingDependencyError
from auralize.io._common import FieldsArg, select_fields, warn_resampled
from auralize.io.resample import (
    ResolutionArg,
    check_resolution,
    describe_grid,
    grid_for_bounds,
    resample_uniform,
)
from auralize.volume import FrameSource, TimeVolume

if TYPE_CHECKING:
    import pyvista

#: ``loader(step)`` returns the mesh of one time step (any pyvista/VTK data object).
Loader = Callable[[int], Any]

Grid = tuple[NDArray[np.float64], NDArray[np.float64], tuple[int, int, int]]


def import_pyvista() -> Any:
    """Import pyvista, or say how to install it."""
    try:
        import pyvista
    except ImportError as exc:  # pragma: no cover - pyvista is a core dependency
        raise MissingDependencyError(
            "reading and writing VTK, ParaView and OpenFOAM files needs pyvista and vtk: "
            "pip install pyvista vtk"
        ) from exc
    from auralize.runtime.vtklog import route_if_enabled

    route_if_enabled()  # on the command line VTK's messages go to auralize's log
    return pyvista


def as_dataset(obj: object, *, label: str) -> pyvista.DataSet:
    """One pyvista DataSet from a reader's output (composites are merged)."""
    pv = import_pyvista()
    if obj is None:
        raise FormatError(f"{label}: the reader returned no data")
    if not isinstance(obj, pv.DataObject):
        obj = pv.wrap(obj)
    if isinstance(obj, pv.DataSet):
        check_mesh(obj, label=label)
        return obj
    if isinstance(obj, pv.MultiBlock) and "internalMesh" in obj.keys():
        return as_dataset(obj["internalMesh"], label=label)
    leaves = [b for b in _leaves(obj, label=label) if b.n_points > 0]
    for b in leaves:
        check_mesh(b, label=label)  # before VTK's merge filter follows the cells
    if not leaves:
        raise FormatError(f"{label}: the file holds no points")
    # Boundary parts (EnSight parts, OpenFOAM patches, XDMF surfaces) have cells of a
    # lower dimension than the volume they bound: keep the highest-dimension blocks.
    top = max(cell_dimension(b) for b in leaves)
    blocks: list[Any] = []
    for b in leaves:
        if cell_dimension(b) != top:
            continue
        pts = np.asarray(b.points)
        if any(o.n_points == b.n_points and np.array_equal(np.asarray(o.points), pts)
               for o in blocks):  # fmt: skip
            continue  # the same mesh listed twice (meshio's XDMF series, for one)
        blocks.append(b)
    if len(blocks) == 1:
        return blocks[0]
    return pv.MultiBlock(blocks).combine(merge_points=True)


#: Points per cell of VTK's fixed-size cell types, by type id (-1: any number).
_CELL_POINTS = np.full(256, -1, dtype=np.int64)
_CELL_POINTS[[1, 3, 5, 8, 9, 10, 11, 12, 13, 14, 15, 16]] = [1, 2, 3, 4, 4, 4, 8, 8, 6, 5, 10, 12]
_CELL_POINTS[[21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34]] = [
    3,
    6,
    8,
    10,
    20,
    15,
    13,
    9,
    27,
    18,
    7,
    12,
    15,
    6,
]


def _vtk_array(arr: Any) -> NDArray[Any]:
    from vtkmodules.util.numpy_support import vtk_to_numpy

    return np.empty(0, dtype=np.int64) if arr is None else vtk_to_numpy(arr)


def _check_cell_array(cells: Any, n_points: int, *, label: str, what: str) -> None:
    """Offsets rising from 0 to the connectivity's length; every point id in range."""
    if cells is None:
        return
    conn = _vtk_array(cells.GetConnectivityArray())
    off = _vtk_array(cells.GetOffsetsArray())
    if off.size and (off[0] != 0 or off[-1] != conn.size or np.any(np.diff(off) < 0)):
        raise DataError(
            f"{label}: the mesh is corrupt: the {what} offsets do not run from 0 to the "
            f"{conn.size} point ids of its connectivity"
        )
    if conn.size and (int(conn.min()) < 0 or int(conn.max()) >= n_points):
        bad = int(conn.min()) if int(conn.min()) < 0 else int(conn.max())
        raise DataError(
            f"{label}: the mesh is corrupt: a {what} refers to point {bad}, but the mesh has "
            f"{n_points} points (valid ids 0 to {n_points - 1}); the file is damaged"
        )


def check_mesh(mesh: Any, *, label: str) -> None:
    """Raise :class:`DataError` unless ``mesh`` is structurally sound.

    VTK's filters (merging, probing, cell-to-point conversion) trust a mesh's
    cells: a point id past the end of the points, offsets that run backwards
    or a cell type VTK does not know make them read outside their arrays and
    end the process.  A damaged file can make a reader return exactly such a
    mesh (a flipped bit in a connectivity block), so every mesh is checked
    here, in a few vectorized passes, before any filter sees it: point
    coordinates are finite, cell offsets rise from 0 to the connectivity's
    length, every point id (of cells and polyhedron faces) lies in
    ``[0, n_points)``, every cell type is one VTK knows and fixed-size cells
    (triangles, tetrahedra, hexahedra ...) have their number of points.
    """
    pv = import_pyvista()
    if isinstance(mesh, pv.ImageData):
        geometry = np.concatenate([np.asarray(mesh.origin), np.asarray(mesh.spacing)])
    elif isinstance(mesh, pv.RectilinearGrid):
        geometry = np.concatenate([np.asarray(c) for c in (mesh.x, mesh.y, mesh.z)])
    else:
        geometry = np.asarray(mesh.points) if mesh.n_points else np.zeros(0)
    if not np.all(np.isfinite(geometry)):
        raise DataError(
            f"{label}: the mesh is corrupt: its point coordinates include NaN or infinite "
            f"values; the file is damaged"
        )
    n = int(mesh.n_points)
    if isinstance(mesh, pv.UnstructuredGrid):
        from vtkmodules.vtkCommonDataModel import vtkCellTypeUtilities

        _check_cell_array(mesh.GetCells(), n, label=label, what="cell")
        types = np.asarray(mesh.celltypes, dtype=np.int64)
        if types.size != mesh.n_cells:
            raise DataError(
                f"{label}: the mesh is corrupt: {types.size} cell types for {mesh.n_cells} cells"
            )
        for t in np.unique(types).tolist():
            if not 0 <= t < 256 or vtkCellTypeUtilities.GetClassNameFromTypeId(t) == "UnknownClass":
                raise DataError(
                    f"{label}: the mesh is corrupt: cell type {t} is not a VTK cell type; "
                    f"the file is damaged"
                )
        if types.size:
            counts = np.diff(_vtk_array(mesh.GetCells().GetOffsetsArray()))
            expected = _CELL_POINTS[types]
            wrong = np.flatnonzero((expected >= 0) & (counts != expected))
            if wrong.size:
                k = int(wrong[0])
                raise DataError(
                    f"{label}: the mesh is corrupt: cell {k} (type {int(types[k])}) has "
                    f"{int(counts[k])} points, but that cell type has {int(expected[k])}"
                )
        if 42 in types and hasattr(mesh, "GetPolyhedronFaces"):
            _check_cell_array(mesh.GetPolyhedronFaces(), n, label=label, what="polyhedron face")
    elif isinstance(mesh, pv.PolyData):
        for cells, what in ((mesh.GetVerts(), "vertex"), (mesh.GetLines(), "line"),
                            (mesh.GetPolys(), "polygon"), (mesh.GetStrips(), "strip")):  # fmt: skip
            _check_cell_array(cells, n, label=label, what=what)


def _leaves(obj: Any, *, label: str) -> list[Any]:
    pv = import_pyvista()
    if obj is None:
        return []
    if not isinstance(obj, pv.DataObject):
        obj = pv.wrap(obj)
    if isinstance(obj, pv.DataSet):
        return [obj]
    try:
        children = list(obj)
    except TypeError:
        raise FormatError(
            f"{label}: holds a {type(obj).__name__}, not a mesh with point or cell data"
        ) from None
    return [leaf for child in children for leaf in _leaves(child, label=label)]


def cell_dimension(mesh: Any) -> int:
    """Largest topological dimension of ``mesh``'s cells (0 points ... 3 volumes)."""
    from vtkmodules.vtkCommonDataModel import vtkCellTypeUtilities

    if mesh.n_cells == 0:
        return 0
    types = {int(t) for t in mesh.distinct_cell_types}
    return max(int(vtkCellTypeUtilities.GetDimension(int(t))) for t in types)


def array_components(mesh: pyvista.DataSet) -> dict[str, int]:
    """``{name: components}`` of numeric point arrays, then cell-only arrays.

    Arrays whose names start with ``vtk`` (masks, ghost levels, ids) are skipped.
    """
    out: dict[str, int] = {}
    for data in (mesh.point_data, mesh.cell_data):
        for name in data.keys():
            if name.startswith("vtk") or name in out:
                continue
            arr = np.asarray(data[name])
            if arr.dtype.kind not in "fiub":
                continue
            out[name] = 1 if arr.ndim == 1 else int(np.prod(arr.shape[1:]))
    return out


def uniform_geometry(mesh: pyvista.DataSet) -> Grid | None:
    """``(origin, spacing, dims)`` if ``mesh`` is an axis-aligned uniform grid, else None."""
    pv = import_pyvista()
    if isinstance(mesh, pv.ImageData):
        direction = np.asarray(getattr(mesh, "direction_matrix", np.eye(3)))
        if not np.allclose(direction, np.eye(3)):
            return None
        dims = tuple(int(d) for d in mesh.dimensions)
        spacing = np.asarray(mesh.spacing, dtype=np.float64).copy()
        if any(s <= 0 for s, d in zip(spacing, dims, strict=True) if d > 1):
            return None
        spacing[spacing <= 0] = 1.0
        origin = np.asarray(mesh.bounds, dtype=np.float64)[::2].copy()
        return origin, spacing, dims  # type: ignore[return-value]
    if isinstance(mesh, pv.RectilinearGrid):
        coords = [np.asarray(c, dtype=np.float64) for c in (mesh.x, mesh.y, mesh.z)]
        spacing = np.ones(3)
        for a, c in enumerate(coords):
            if c.size > 1:
                d = np.diff(c)
                if d[0] <= 0 or not np.allclose(d, d[0], rtol=1e-6, atol=0.0):
                    return None
                spacing[a] = (c[-1] - c[0]) / (c.size - 1)
        origin = np.array([c[0] for c in coords])
        return origin, spacing, (coords[0].size, coords[1].size, coords[2].size)
    if isinstance(mesh, pv.StructuredGrid):
        return _structured_uniform(mesh)
    return None


def _structured_uniform(mesh: Any) -> Grid | None:
    """A structured grid whose i, j, k run evenly along x, y, z is a uniform grid.

    Checked in one pass over the points (PLOT3D and ``.vts`` files of
    Cartesian grids), with the relative tolerance of :func:`lattice_order`.
    """
    ni, nj, nk = (int(d) for d in mesh.dimensions)
    pts = np.asarray(mesh.points, dtype=np.float64).reshape(nk, nj, ni, 3)
    lines = (pts[0, 0, :, :], pts[0, :, 0, :], pts[:, 0, 0, :])
    origin = pts[0, 0, 0].copy()
    ext = pts.reshape(-1, 3).max(axis=0) - pts.reshape(-1, 3).min(axis=0)
    scale = float(ext.max())
    if not np.isfinite(scale) or scale <= 0:
        return None
    tol = 1e-5 * scale
    spacing = np.ones(3)
    for axis, line in enumerate(lines):
        if line.shape[0] > 1:
            step = np.diff(line, axis=0)
            off_axis = np.delete(step, axis, axis=1)
            if np.any(np.abs(off_axis) > tol) or step[0, axis] <= tol:
                return None
            if np.any(np.abs(step[:, axis] - step[0, axis]) > tol):
                return None
            spacing[axis] = (line[-1, axis] - line[0, axis]) / (line.shape[0] - 1)
    dims = (ni, nj, nk)
    active = [spacing[a] for a in range(3) if dims[a] > 1]
    for a in range(3):
        if dims[a] == 1:
            spacing[a] = min(active) if active else 1.0
    grid_z, grid_y, grid_x = (origin[a] + spacing[a] * np.arange(d) for a, d in
                              ((2, nk), (1, nj), (0, ni)))  # fmt: skip
    if (
        np.abs(pts[..., 0] - grid_x[None, None, :]).max() > tol
        or np.abs(pts[..., 1] - grid_y[None, :, None]).max() > tol
        or np.abs(pts[..., 2] - grid_z[:, None, None]).max() > tol
    ):
        return None
    return origin, spacing, dims


def point_arrays(
    mesh: pyvista.DataSet, names: Sequence[str], *, label: str
) -> dict[str, NDArray[Any]]:
    """Point arrays ``names`` of ``mesh``; cell-only arrays converted to points."""
    out: dict[str, NDArray[Any]] = {}
    cell_names: list[str] = []
    for name in names:
        if name in mesh.point_data.keys():
            out[name] = np.asarray(mesh.point_data[name])
        elif name in mesh.cell_data.keys():
            cell_names.append(name)
        else:
            have = sorted(set(mesh.point_data.keys()) | set(mesh.cell_data.keys()))
            raise DataError(
                f"{label}: no array {name!r} (the first time step has it; this one has "
                f"{', '.join(repr(h) for h in have) or 'none'}); every step needs the same arrays"
            )
    if cell_names:
        tmp = mesh.copy(deep=False)
        tmp.clear_point_data()
        for name in list(tmp.cell_data.keys()):
            if name not in cell_names:
                del tmp.cell_data[name]
        converted = tmp.cell_data_to_point_data()
        for name in cell_names:
            out[name] = np.asarray(converted.point_data[name])
    return out


def _frame(arr: NDArray[Any], shape: tuple[int, int, int], *, name: str, label: str) -> NDArray:
    a = np.array(arr, dtype=np.float64)  # always a copy the reader cannot overwrite
    n = int(np.prod(shape))
    if a.shape not in ((n,), (n, 1), (n, 3)):
        raise DataError(
            f"{label}: array {name!r} has shape {a.shape}; expected ({n},) or ({n}, 3) "
            f"on a grid of {shape[2]}x{shape[1]}x{shape[0]} points"
        )
    if a.ndim == 2 and a.shape[-1] == 3:
        return a.reshape((*shape, 3))
    return a.reshape(shape)


def _same_grid(a: Grid, b: Grid) -> bool:
    """Whether two grids have the same dims and (to round-off) origin and spacing."""
    scale = float(np.max(np.abs(b[1]) * np.maximum(np.asarray(b[2]) - 1, 1)))
    return (
        tuple(a[2]) == tuple(b[2])
        and np.allclose(a[0], b[0], rtol=0.0, atol=1e-5 * scale)
        and np.allclose(a[1], b[1], rtol=1e-5, atol=0.0)
    )


class _SameGrid:
    """Steps that are uniform grids identical to step 0: reshape, no interpolation."""

    def __init__(self, grid: Grid) -> None:
        self.origin, self.spacing, self.dims = grid

    def convert(self, mesh: Any, names: Sequence[str], *, label: str) -> dict[str, NDArray]:
        geom = uniform_geometry(mesh)
        if (
            geom is None
            or tuple(geom[2]) != tuple(self.dims)
            or not np.allclose(geom[0], self.origin, rtol=1e-9, atol=1e-12)
            or not np.allclose(geom[1], self.spacing, rtol=1e-9, atol=1e-12)
        ):
            got = "a non-uniform mesh" if geom is None else describe_grid(*geom)
            raise DataError(
                f"{label}: has {got}, but the first time step has "
                f"{describe_grid(self.origin, self.spacing, self.dims)}; every step of a "
                f"series must share one grid"
            )
        nx, ny, nz = self.dims
        arrays = point_arrays(mesh, names, label=label)
        return {n: _frame(a, (nz, ny, nx), name=n, label=label) for n, a in arrays.items()}


def lattice_order(points: NDArray[np.floating]) -> tuple[Grid, NDArray[np.intp]] | None:
    """Whether mesh points form a full, evenly spaced axis-aligned lattice.

    OpenFOAM ``blockMesh`` boxes, unstructured exports of uniform grids and
    axis-aligned structured grids are such lattices: their point data are
    exact values at uniform grid points, with no interpolation needed.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Mesh point coordinates in metres.

    Returns
    -------
    ((origin, spacing, dims), order) or None
        ``order`` (N,) holds, for each C-order grid point ``(z, y, x)``, the
        index of the mesh point there.  ``None`` when the points are not one
        point per node of an evenly spaced lattice (relative tolerance 1e-5
        of the mesh extent, which float32 coordinates meet).
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = pts.shape[0]
    if n < 2:
        return None
    ext = pts.max(axis=0) - pts.min(axis=0)
    scale = float(ext.max())
    if not np.isfinite(scale) or scale <= 0:
        return None
    tol = 1e-5 * scale
    index = np.empty((n, 3), dtype=np.intp)
    origin, spacing, dims = np.zeros(3), np.ones(3), [1, 1, 1]
    for a in range(3):
        c = pts[:, a]
        order = np.argsort(c, kind="stable")
        sc = c[order]
        new = np.concatenate([[True], np.diff(sc) > tol])
        levels = sc[new]
        if levels.size > 1:
            step = np.diff(levels)
            h = (levels[-1] - levels[0]) / (levels.size - 1)
            if np.any(np.abs(step - h) > tol):
                return None
            spacing[a] = h
        dims[a] = int(levels.size)
        origin[a] = levels[0]
        index[order, a] = np.cumsum(new) - 1
        if dims[0] * dims[1] * dims[2] > n:
            return None
    if dims[0] * dims[1] * dims[2] != n:
        return None
    active = [spacing[a] for a in range(3) if dims[a] > 1]
    for a in range(3):
        if dims[a] == 1:
            spacing[a] = min(active) if active else 1.0
    flat = (index[:, 2] * dims[1] + index[:, 1]) * dims[0] + index[:, 0]
    order = np.full(n, -1, dtype=np.intp)
    order[flat] = np.arange(n)
    if np.any(order < 0):  # two points on one node
        return None
    return (origin, spacing, (dims[0], dims[1], dims[2])), order


@dataclass
class SurfaceLattice:
    """A 2-D surface whose points project onto an evenly spaced lattice.

    ``grid`` is the lattice (dims 1 along ``axis``, at coordinate ``level``),
    ``order`` as in :func:`lattice_order`, ``deviation`` the largest distance
    in metres of a point from the plane.
    """

    grid: Grid
    order: NDArray[np.intp]
    axis: int
    level: float
    deviation: float


def project(points: NDArray[np.floating], axis: int, level: float) -> NDArray[np.float64]:
    """``points (N, 3)`` with coordinate ``axis`` set to ``level`` (metres)."""
    pts = np.array(points, dtype=np.float64).reshape(-1, 3)
    pts[:, axis] = level
    return pts


def surface_lattice(mesh: Any) -> SurfaceLattice | None:
    """Whether ``mesh`` is a surface lying over an evenly spaced lattice (a height field).

    A mesh whose cells are 2-D (:func:`cell_dimension`) and whose points,
    projected along the axis of their smallest extent onto the plane at
    their mean coordinate, form a full evenly spaced lattice
    (:func:`lattice_order`): its point values are read on that lattice as
    they are, with no interpolation and no data off the surface.  None for
    anything else (a volume, or a curved surface that folds over or is not
    evenly spaced in projection).
    """
    if cell_dimension(mesh) != 2:
        return None
    pts = np.asarray(mesh.points, dtype=np.float64).reshape(-1, 3)
    if pts.shape[0] < 4 or not np.all(np.isfinite(pts)):
        return None
    ext = pts.max(axis=0) - pts.min(axis=0)
    axis = int(np.argmin(ext))
    level = float(pts[:, axis].mean())
    found = lattice_order(project(pts, axis, level))
    if found is None:
        return None
    grid, order = found
    if sum(d > 1 for d in grid[2]) != 2:
        return None
    return SurfaceLattice(grid=grid, order=order, axis=axis, level=level,
                          deviation=float(np.max(np.abs(pts[:, axis] - level))))  # fmt: skip


class _Lattice:
    """Steps whose points are an evenly spaced lattice: reorder point data, no interpolation.

    With ``axis`` given (a surface, :func:`surface_lattice`), every step's
    points are first projected along ``axis`` onto the plane at ``level``,
    so a surface moving along that axis stays on the same lattice.
    """

    def __init__(self, grid: Grid, order: NDArray[np.intp], points: NDArray[np.floating],
                 axis: int | None = None, level: float = 0.0) -> None:  # fmt: skip
        self.origin, self.spacing, self.dims = grid
        self.order = order
        self.axis, self.level = axis, level
        self._points = self._project(points)

    def _project(self, points: Any) -> NDArray[np.float64]:
        if self.axis is None:
            return np.array(points, dtype=np.float64)
        return project(points, self.axis, self.level)

    def convert(self, mesh: Any, names: Sequence[str], *, label: str) -> dict[str, NDArray]:
        pts = self._project(mesh.points)
        if pts.shape != self._points.shape or not np.array_equal(pts, self._points):
            found = lattice_order(pts)
            if found is None or not _same_grid(found[0], (self.origin, self.spacing, self.dims)):
                raise DataError(
                    f"{label}: the mesh points moved off the first time step's lattice of "
                    f"{describe_grid(self.origin, self.spacing, self.dims)}; every step of a "
                    f"series must share one grid"
                )
            self.order, self._points = found[1], pts
        nx, ny, nz = self.dims
        arrays = point_arrays(mesh, names, label=label)
        return {
            n: _frame(np.asarray(a)[self.order], (nz, ny, nx), name=n, label=label)
            for n, a in arrays.items()
        }


class _Sampler:
    """Sample any mesh onto a fixed uniform grid (linear interpolation in each cell).

    Grid points outside the mesh get NaN: nothing is extrapolated.  VTK's
    probe (``vtkResampleWithDataSet``) marks which points it found a cell for
    (``vtkValidPointMask``); :attr:`valid` is that mask at the first step.
    """

    def __init__(self, grid: Grid) -> None:
        self.origin, self.spacing, self.dims = grid
        self._target: Any = None
        self.valid: NDArray[np.bool_] | None = None

    def convert(self, mesh: Any, names: Sequence[str], *, label: str) -> dict[str, NDArray]:
        pv = import_pyvista()
        nx, ny, nz = self.dims
        if self._target is None:
            self._target = pv.ImageData(
                dimensions=self.dims, spacing=tuple(self.spacing), origin=tuple(self.origin)
            )
        arrays = point_arrays(mesh, names, label=label)
        src = mesh.copy(deep=False)
        src.clear_data()
        for name, arr in arrays.items():
            src.point_data[name] = arr
        out = self._target.sample(src)
        inside = np.asarray(out.point_data["vtkValidPointMask"]).astype(bool)
        if self.valid is None:
            self.valid = inside.reshape(nz, ny, nx)
            if not inside.any():
                raise DataError(
                    f"{label}: no point of the uniform grid "
                    f"{describe_grid(self.origin, self.spacing, self.dims)} lies inside the "
                    f"mesh; the mesh may have no volume cells (pass a finer resolution=)"
                )
        result = {}
        for name in names:
            a = np.array(out.point_data[name], dtype=np.float64)
            a[~inside] = np.nan
            result[name] = _frame(a, (nz, ny, nx), name=name, label=label)
        return result


def _load(loader: Loader, step: int, label: str) -> pyvista.DataSet:
    from auralize.runtime.vtklog import error_mark, first_error, one_line

    mark = getattr(loader, "error_mark", None)
    mark = error_mark() if mark is None else mark
    try:
        obj = loader(step)
    except AuralizeError:
        raise
    except Exception as exc:  # VTK and pyvista raise many kinds; name the file and VTK's reason
        why = first_error(mark) or f"{type(exc).__name__}: {one_line(str(exc))}"
        raise FormatError(f"{label}: cannot read ({why})") from exc
    try:
        return as_dataset(obj, label=label)
    except FormatError as exc:
        reason = first_error(mark)  # the reader said why it returned nothing usable
        if reason is None or reason in str(exc):
            raise
        raise FormatError(f"{exc} (VTK: {reason})") from exc


@dataclass
class MeshSteps:
    """Loads and converts one time step at a time; keeps the last step's arrays.

    Shared by all fields of a volume, so reading every field of one step loads
    the step's file(s) once.  Thread-safe; ``n_loads`` counts loads.
    """

    loader: Loader
    labels: Sequence[str]
    converter: _SameGrid | _Lattice | _Sampler
    names: Sequence[str]
    n_loads: int = 0
    _step: int | None = None
    _mesh: Any = None
    _arrays: dict[str, NDArray] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def seed(self, step: int, arrays: dict[str, NDArray]) -> None:
        with self._lock:
            self._step, self._arrays, self._mesh = step, arrays, None

    def arrays(self, step: int, name: str | None = None) -> dict[str, NDArray]:
        """The converted arrays of ``step``: ``name`` at least (all when None).

        A uniform or lattice step converts only the arrays asked for (the
        others stay in the loaded mesh until asked for); a sampled step is
        probed once for all arrays.
        """
        with self._lock:
            label = self.labels[step]
            if self._step != step:
                self._mesh = _load(self.loader, step, label)
                self._arrays = {}
                self._step = step
                self.n_loads += 1
            wanted = self.names if name is None or isinstance(self.converter, _Sampler) else [name]
            missing = [n for n in wanted if n not in self._arrays]
            if missing:
                self._arrays.update(self.converter.convert(self._mesh, missing, label=label))
            return self._arrays


@dataclass
class MeshFrames:
    """One field of a mesh time series; :meth:`read` loads (at most) one step."""

    steps: MeshSteps
    array_name: str
    n_steps: int
    frame_shape: tuple[int, ...]

    def read(self, step: int) -> NDArray[np.float64]:
        return self.steps.arrays(step, self.array_name)[self.array_name].copy()


def open_mesh_series(
    *,
    source: str,
    loader: Loader,
    labels: Sequence[str],
    times: Sequence[float] | NDArray[np.floating],
    physical_times: bool,
    fields: FieldsArg,
    resolution: ResolutionArg,
    name_map: Mapping[str, str] | None,
) -> TimeVolume:
    """Build a lazy :class:`TimeVolume` over the meshes ``loader`` returns.

    Parameters
    ----------
    source : str
        The file the user opened (for messages and ``TimeVolume.source``).
    loader : callable
        ``loader(step)`` returns the mesh of time step ``step``.
    labels : sequence of str
        Per-step description for messages (usually the step's file).
    times : array_like, shape (T,)
        Step times in seconds.
    physical_times : bool
        False when ``times`` are frame indices at 30 Hz.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.
    """
    resolution = check_resolution(resolution, source=source)
    if len(labels) != len(times):
        raise FormatError(f"{source}: {len(labels)} step files for {len(times)} times")
    from auralize.runtime.vtklog import error_mark, first_error

    mark = error_mark()
    mesh0 = _load(loader, 0, labels[0])
    if mesh0.n_points == 0:
        vtk_why = first_error(getattr(loader, "error_mark", mark))
        why = (
            f"VTK: {vtk_why}"
            if vtk_why
            else "a data file it refers to may be missing, truncated or corrupt"
        )
        raise FormatError(f"{labels[0]}: the mesh has no points ({why})")
    comps = array_components(mesh0)
    requested: list[str] = []
    if isinstance(fields, str):
        requested = [fields]
    elif isinstance(fields, Mapping):
        requested = [v for v in fields.values() if isinstance(v, str)]
    elif isinstance(fields, Sequence):
        requested = [f for f in fields if isinstance(f, str)]
    for name in requested:
        if comps.get(name, 1) not in (1, 3):
            raise DataError(
                f"{labels[0]}: array {name!r} has {comps[name]} components; a field is a "
                f"scalar (1 component) or a vector (3 components)"
            )
    usable = [n for n, c in comps.items() if c in (1, 3)]
    chosen = select_fields(usable, fields, name_map, source=source)
    names = list(dict.fromkeys(chosen.values()))
    geom = uniform_geometry(mesh0)
    lattice = None if geom is not None else lattice_order(mesh0.points)
    surface = None if geom is not None or lattice is not None else surface_lattice(mesh0)
    converter: _SameGrid | _Lattice | _Sampler
    valid = None
    if geom is not None:
        origin, spacing, dims = geom
        converter = _SameGrid(geom)
        steps = MeshSteps(loader=loader, labels=labels, converter=converter, names=names)
    elif lattice is not None:
        (origin, spacing, dims), order = lattice
        converter = _Lattice((origin, spacing, dims), order, mesh0.points)
        steps = MeshSteps(loader=loader, labels=labels, converter=converter, names=names)
        steps.seed(0, converter.convert(mesh0, names, label=labels[0]))
    elif surface is not None:
        origin, spacing, dims = surface.grid
        converter = _Lattice(surface.grid, surface.order, mesh0.points, surface.axis,
                             surface.level)  # fmt: skip
        steps = MeshSteps(loader=loader, labels=labels, converter=converter, names=names)
        steps.seed(0, converter.convert(mesh0, names, label=labels[0]))
        warn_resampled(
            f"{source}: a surface ({type(mesh0).__name__} with {mesh0.n_points} points, 2-D "
            f"cells) read on its own points, no interpolation: the lattice "
            f"{describe_grid(origin, spacing, dims)} in the plane {'xyz'[surface.axis]} = "
            f"{surface.level:.6g} m; the points lie up to ±{surface.deviation:.3g} m off it "
            f"(at the first step), and source positions are projected onto it"
        )
    else:
        origin, spacing, dims = grid_for_bounds(
            mesh0.bounds, n_points=mesh0.n_points, resolution=resolution, source=source
        )
        sampler = _Sampler((origin, spacing, dims))
        converter = sampler
        steps = MeshSteps(loader=loader, labels=labels, converter=converter, names=names)
        steps.seed(0, converter.convert(mesh0, names, label=labels[0]))
        valid = sampler.valid
        assert valid is not None
        n_out = int(np.count_nonzero(~valid))
        how = "automatic" if resolution is None else f"resolution={resolution!r}"
        outside = (
            f"; {n_out} of {valid.size} grid points ({100.0 * n_out / valid.size:.1f} %) lie "
            f"outside the mesh and are no-data (NaN, valid=False)"
            if n_out
            else ""
        )
        warn_resampled(
            f"{source}: {type(mesh0).__name__} with {mesh0.n_points} points resampled by "
            f"linear interpolation onto a uniform grid of {describe_grid(origin, spacing, dims)} "
            f"({how}){outside}"
        )
    nx, ny, nz = dims
    frames: dict[str, FrameSource] = {
        vol_name: MeshFrames(
            steps=steps,
            array_name=file_name,
            n_steps=len(times),
            frame_shape=(nz, ny, nx) if comps[file_name] == 1 else (nz, ny, nx, 3),
        )
        for vol_name, file_name in chosen.items()
    }
    volume = TimeVolume(
        origin=origin,
        spacing=spacing,
        dims=dims,
        times=np.asarray(times, dtype=np.float64),
        fields=frames,
        physical_times=physical_times,
        source=source,
        valid=valid,
    )
    volume.attrs["centring"] = {
        vol_name: ("point" if file_name in mesh0.point_data.keys() else "cell")
        for vol_name, file_name in chosen.items()
    }
    volume.attrs["mesh"] = f"{type(mesh0).__name__} with {mesh0.n_points} points"
    if geom is not None or lattice is not None or surface is not None:
        volume = resample_uniform(volume, resolution)
    return volume
