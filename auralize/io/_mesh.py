"""Turning pyvista meshes, one time step at a time, into uniform-grid frames.

Every pyvista-based reader (``.pvd``, ``.series``, single VTK files, VTKHDF,
OpenFOAM) supplies a *loader* ``loader(step) -> mesh`` and the step times;
:func:`open_mesh_series` reads step 0 to learn the grid and the arrays, and
returns a :class:`~auralize.volume.TimeVolume` whose fields call the loader
again, one step per read.  Uniform grids (``ImageData``, evenly spaced
``RectilinearGrid``) keep their points; anything else is sampled onto a
uniform grid covering its bounds (or the region of interest, ``box=``) with
VTK's ``vtkResampleWithDataSet`` (pyvista's
:meth:`~pyvista.DataSetFilters.sample`), at a voxel chosen from the mesh's
own cell sizes in that region (:func:`cell_sizes`,
:func:`auralize.io.resample.grid_for_cells`).  Meshes whose points are an
evenly spaced lattice keep their points too, and so does a surface (2-D
cells) whose points project onto such a lattice, e.g. a height field
``z(x, y)``: it is read on the lattice in its plane (dims 1 across it),
with its own point values (:func:`surface_lattice`).  Any other curved
surface (a shell) is read as the grid points it passes through, with the
surface's values interpolated there (:func:`shell_voxels`).  A structured
curvilinear grid (``vtkStructuredGrid``: ``.vts``, PLOT3D) keeps its own
points (``TimeVolume.coords``; derivatives by its metric terms,
:mod:`auralize.curvilinear`) unless the reader options ask for resampling
(``curvilinear="resample"`` or a ``resolution``; a ``box`` crops it in index
space to the block whose cells cover it, :func:`auralize.io.options.index_block`);
:func:`resample_curvilinear` puts one on a uniform grid for what needs it.  The
reader option ``axis_scale=`` scales every step's mesh as it is loaded, before
any of this.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import AuralizeError, DataError, FormatError, MissingDependencyError
from auralize.io._common import FieldsArg, select_fields, warn_resampled
from auralize.io.resample import (
    AUTO_MAX_GRID_POINTS_2D,
    AUTO_MAX_GRID_POINTS_3D,
    GridChoice,
    ResolutionArg,
    check_resolution,
    describe_grid,
    grid_for_cells,
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
        if any(
            o.n_points == b.n_points and np.array_equal(np.asarray(o.points), pts) for o in blocks
        ):
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
        from auralize.runtime.vtkcompat import cell_type_utilities

        cell_types = cell_type_utilities()
        _check_cell_array(mesh.GetCells(), n, label=label, what="cell")
        types = np.asarray(mesh.celltypes, dtype=np.int64)
        if types.size != mesh.n_cells:
            raise DataError(
                f"{label}: the mesh is corrupt: {types.size} cell types for {mesh.n_cells} cells"
            )
        for t in np.unique(types).tolist():
            if not 0 <= t < 256 or cell_types.GetClassNameFromTypeId(t) == "UnknownClass":
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
        for cells, what in (
            (mesh.GetVerts(), "vertex"),
            (mesh.GetLines(), "line"),
            (mesh.GetPolys(), "polygon"),
            (mesh.GetStrips(), "strip"),
        ):
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
    from auralize.runtime.vtkcompat import cell_type_utilities, distinct_cell_types

    if mesh.n_cells == 0:
        return 0
    types = distinct_cell_types(mesh)
    return max(int(cell_type_utilities().GetDimension(t)) for t in types)


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
    grid_z, grid_y, grid_x = (
        origin[a] + spacing[a] * np.arange(d) for a, d in ((2, nk), (1, nj), (0, ni))
    )
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


def curvilinear_points(mesh: Any) -> NDArray[np.float64] | None:
    """The points ``(nz, ny, nx, 3)`` of a structured curvilinear grid (a
    ``vtkStructuredGrid``: PLOT3D, ``.vts``; or a ``vtkRectilinearGrid``, ``.vtr``),
    in VTK's point order (i fastest); None for any other mesh."""
    pv = import_pyvista()
    if isinstance(mesh, pv.RectilinearGrid):
        axes = [np.asarray(c, dtype=np.float64) for c in (mesh.x, mesh.y, mesh.z)]
        if any(c.size > 1 and np.any(np.diff(c) <= 0) for c in axes):
            return None
        zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
        return np.stack([xx, yy, zz], axis=-1)
    if not isinstance(mesh, pv.StructuredGrid):
        return None
    ni, nj, nk = (int(d) for d in mesh.dimensions)
    pts = np.asarray(mesh.points, dtype=np.float64)
    if pts.shape != (ni * nj * nk, 3) or ni * nj * nk < 2:
        return None
    return pts.reshape(nk, nj, ni, 3).copy()


class _Structured:
    """Steps that are the same structured curvilinear grid as step 0: its own points,
    no interpolation (``TimeVolume.coords``)."""

    def __init__(self, coords: NDArray[np.float64]) -> None:
        self.coords = coords
        ext = coords.reshape(-1, 3).max(axis=0) - coords.reshape(-1, 3).min(axis=0)
        self.tol = 1e-6 * float(np.max(ext))

    def convert(self, mesh: Any, names: Sequence[str], *, label: str) -> dict[str, NDArray]:
        pts = curvilinear_points(mesh)
        if pts is None or pts.shape != self.coords.shape:
            nz, ny, nx = self.coords.shape[:3]
            got = (
                f"a {type(mesh).__name__}"
                if pts is None
                else f"a structured grid of {pts.shape[2]}x{pts.shape[1]}x{pts.shape[0]} points"
            )
            raise DataError(
                f"{label}: has {got}, but the first time step has a curvilinear grid of "
                f"{nx}x{ny}x{nz} points; every step of a series must share one grid"
            )
        if not np.allclose(pts, self.coords, rtol=0.0, atol=self.tol):
            raise DataError(
                f"{label}: the curvilinear grid's points moved (by up to "
                f"{float(np.abs(pts - self.coords).max()):.3g} m) from the first time step's; "
                f"a moving grid is read resampled (--resample, curvilinear='resample')"
            )
        shape = self.coords.shape[:3]
        arrays = point_arrays(mesh, names, label=label)
        return {n: _frame(a, shape, name=n, label=label) for n, a in arrays.items()}


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
    return SurfaceLattice(
        grid=grid,
        order=order,
        axis=axis,
        level=level,
        deviation=float(np.max(np.abs(pts[:, axis] - level))),
    )


class _Lattice:
    """Steps whose points are an evenly spaced lattice: reorder point data, no interpolation.

    With ``axis`` given (a surface, :func:`surface_lattice`), every step's
    points are first projected along ``axis`` onto the plane at ``level``,
    so a surface moving along that axis stays on the same lattice.
    """

    def __init__(
        self,
        grid: Grid,
        order: NDArray[np.intp],
        points: NDArray[np.floating],
        axis: int | None = None,
        level: float = 0.0,
    ) -> None:
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


def scale_mesh(mesh: Any, scale: NDArray[np.float64] | None) -> Any:
    """``mesh`` with its coordinates multiplied by ``scale`` (x, y, z), as a shallow copy.

    Uniform and rectilinear grids keep their kind (origin and spacing, or the
    axis coordinates, are scaled); any other mesh gets a scaled copy of its
    points.  The loaded mesh itself is not changed (a reader may cache it).
    """
    if scale is None:
        return mesh
    pv = import_pyvista()
    s = np.asarray(scale, dtype=np.float64)
    if isinstance(mesh, pv.ImageData):
        direction = np.asarray(getattr(mesh, "direction_matrix", np.eye(3)))
        if np.allclose(direction, np.eye(3)):
            out = mesh.copy(deep=False)
            out.origin = tuple(np.asarray(mesh.origin, dtype=np.float64) * s)
            out.spacing = tuple(np.asarray(mesh.spacing, dtype=np.float64) * s)
            return out
        mesh = mesh.cast_to_structured_grid()  # a rotated image: scale its points
    if isinstance(mesh, pv.RectilinearGrid):
        out = mesh.copy(deep=False)
        out.x, out.y, out.z = (
            np.asarray(c, dtype=np.float64) * s[a] for a, c in enumerate((mesh.x, mesh.y, mesh.z))
        )
        return out
    out = mesh.copy(deep=False)
    out.points = np.asarray(mesh.points, dtype=np.float64) * s
    return out


#: Cells of a VTK type per mesh point in a regular mesh of that type, by type id: a cube
#: is 6 tetrahedra, 3 pyramids or 2 wedges, a square 2 triangles, so
#: ``(cells_per_point * volume) ** (1/3)`` is the edge of the cube each point stands for.
_CELLS_PER_POINT = np.ones(256)
_CELLS_PER_POINT[[5, 22]] = 2.0  # triangles (linear, quadratic)
_CELLS_PER_POINT[[10, 24]] = 6.0  # tetrahedra
_CELLS_PER_POINT[[13, 26, 32]] = 2.0  # wedges
_CELLS_PER_POINT[[14, 27]] = 3.0  # pyramids

_MEASURE = {1: "Length", 2: "Area", 3: "Volume"}


@dataclass
class CellSizes:
    """Sizes of a mesh's cells of its highest dimension.

    ``size`` holds each cell's equivalent edge in metres (the edge of the
    cube, square or segment that one mesh point stands for in a regular mesh
    of such cells: ``(cells_per_point * measure) ** (1 / dim)``), ``inside``
    whether the cell's centre lies in the region of interest; cells of zero
    size (degenerate, or of a lower dimension) are left out.
    """

    size: NDArray[np.float64]
    inside: NDArray[np.bool_]
    dim: int


def cell_sizes(mesh: Any, box: Sequence[float] | None = None) -> CellSizes:
    """The equivalent edges of ``mesh``'s cells, and which lie in ``box`` (vectorised)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    pv = import_pyvista()
    dim = cell_dimension(mesh)
    if dim == 0:
        return CellSizes(np.zeros(0), np.zeros(0, dtype=bool), 0)
    sized = mesh.compute_cell_sizes(
        length=dim == 1, area=dim == 2, volume=dim == 3, vertex_count=False
    )
    measure = np.abs(np.asarray(sized.cell_data[_MEASURE[dim]], dtype=np.float64))
    if isinstance(mesh, pv.UnstructuredGrid):
        per_point = _CELLS_PER_POINT[np.asarray(mesh.celltypes, dtype=np.intp)]
    elif isinstance(mesh, pv.PolyData) and dim == 2:
        # cells run vertices, lines, polygons, strips; a polygon of 3 points is a triangle
        per_point = np.ones(mesh.n_cells)
        n_before = mesh.GetVerts().GetNumberOfCells() + mesh.GetLines().GetNumberOfCells()
        off = vtk_to_numpy(mesh.GetPolys().GetOffsetsArray())
        counts = np.diff(off) if off.size else np.zeros(0, dtype=np.int64)
        per_point[n_before : n_before + counts.size] = np.where(counts == 3, 2.0, 1.0)
        off = vtk_to_numpy(mesh.GetStrips().GetOffsetsArray())
        if off.size > 1:  # a strip of k points is k - 2 triangles
            k = np.diff(off).astype(np.float64)
            per_point[n_before + counts.size :] = 2.0 / np.maximum(k - 2.0, 1.0)
    else:  # structured grids: hexahedra, quadrilaterals, lines
        per_point = np.ones(mesh.n_cells)
    keep = measure > 0
    size = (per_point[keep] * measure[keep]) ** (1.0 / dim)
    if box is None:
        inside = np.ones(size.size, dtype=bool)
    else:
        centres = np.asarray(mesh.cell_centers().points, dtype=np.float64)[keep]
        inside = in_box(centres, box, mesh.bounds)
    return CellSizes(size, inside, dim)


def in_box(
    points: NDArray[np.floating], box: Sequence[float], bounds: Sequence[float]
) -> NDArray[np.bool_]:
    """Which ``points`` lie in ``box`` along the axes on which the mesh (``bounds``) is not flat."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
    ext = b[:, 1] - b[:, 0]
    inside = np.ones(pts.shape[0], dtype=bool)
    for a in range(3):
        if ext[a] > 1e-9 * float(ext.max()):
            tol = 1e-9 * float(ext.max())
            inside &= (pts[:, a] >= box[2 * a] - tol) & (pts[:, a] <= box[2 * a + 1] + tol)
    return inside


def region_bounds(
    bounds: Sequence[float], box: Sequence[float] | None, *, source: str
) -> tuple[float, ...]:
    """The mesh ``bounds`` cut to ``box`` (along the axes on which the mesh is not flat)."""
    b = [float(v) for v in bounds]
    if box is None:
        return tuple(b)
    ext = [b[2 * a + 1] - b[2 * a] for a in range(3)]
    out = list(b)
    for a in range(3):
        if ext[a] > 1e-9 * max(ext):
            out[2 * a] = max(b[2 * a], float(box[2 * a]))
            out[2 * a + 1] = min(b[2 * a + 1], float(box[2 * a + 1]))
            if out[2 * a] > out[2 * a + 1]:
                raise DataError(
                    f"{source}: the box {', '.join(f'{v:g}' for v in box)} m holds none of the "
                    f"mesh: along {'xyz'[a]} the mesh spans {b[2 * a]:g} .. {b[2 * a + 1]:g} m"
                )
    return tuple(out)


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


def surface_triangles(mesh: Any) -> NDArray[np.intp]:
    """``(T, 3)`` point ids of the triangles that cover ``mesh``'s 2-D cells.

    Quadrilaterals, polygons and strips are split by VTK (``vtkGeometryFilter``
    then ``vtkTriangleFilter``); the ids index ``mesh.points``.
    """
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkFiltersCore import vtkTriangleFilter
    from vtkmodules.vtkFiltersGeometry import vtkGeometryFilter

    src = mesh.copy(deep=False)
    src.clear_data()
    src.point_data["auralize_point_id"] = np.arange(mesh.n_points, dtype=np.int64)
    geometry = vtkGeometryFilter()
    geometry.SetInputData(src)
    triangles = vtkTriangleFilter()
    triangles.SetInputConnection(geometry.GetOutputPort())
    triangles.PassVertsOff()
    triangles.PassLinesOff()
    triangles.Update()
    out = triangles.GetOutput()
    conn = vtk_to_numpy(out.GetPolys().GetConnectivityArray()).astype(np.intp).reshape(-1, 3)
    ids = vtk_to_numpy(out.GetPointData().GetArray("auralize_point_id")).astype(np.intp)
    return ids[conn]


#: Most surface samples :func:`shell_voxels` holds at once (its memory stays ~100 MB).
_SHELL_CHUNK = 1 << 20


def shell_voxels(
    points: NDArray[np.floating], triangles: NDArray[np.intp], grid: Grid
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """The grid points a triangulated surface passes through, and how to interpolate there.

    Every triangle is sampled on a barycentric lattice no coarser than half
    the grid's spacing (one pass per subdivision level, in chunks; a triangle
    smaller than that by its own corners, shared with its neighbours); each
    sample is rounded to its nearest grid point, and each grid point hit
    keeps the sample nearest to it.

    Returns
    -------
    voxels : ndarray of int, shape (K,)
        C-order indices ``(z, y, x)`` of the grid points hit, ascending.
    ids, weights : ndarray, shape (K, 3)
        The point ids of the triangle of each voxel's sample and the sample's
        barycentric weights: a point field ``f`` at the voxel is
        ``(weights * f[ids]).sum(axis=1)``.
    """
    origin, spacing, dims = grid
    o, h = np.asarray(origin, dtype=np.float64), np.asarray(spacing, dtype=np.float64)
    n = np.asarray(dims, dtype=np.int64)
    step = 0.5 * float(np.min([h[a] for a in range(3) if n[a] > 1] or [h.min()]))
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    tri = np.asarray(triangles, dtype=np.intp).reshape(-1, 3)
    corner = pts[tri]  # (T, 3 corners, 3)
    longest = np.max(np.linalg.norm(corner - np.roll(corner, 1, axis=1), axis=2), axis=1)
    levels = np.maximum(np.ceil(longest / step), 1).astype(np.int64)
    d2_max = 0.25 * float(np.sum(h**2))  # a sample is at most half a diagonal from its voxel
    found: list[tuple[NDArray, ...]] = []

    def nearest(vox: NDArray, d2: NDArray, ids: NDArray, w: NDArray) -> tuple[NDArray, ...]:
        """Per voxel, the sample nearest it: one sort on (voxel, quantized distance)."""
        q = np.clip(d2 / d2_max, 0.0, 1.0) * float(2**30)
        order = np.argsort((vox << np.int64(31)) + q.astype(np.int64))
        v = vox[order]
        first = np.concatenate([[True], v[1:] != v[:-1]])
        pick = order[first]
        return vox[pick], d2[pick], ids[pick], w[pick]

    def add(x: NDArray, ids: NDArray, w: NDArray) -> None:
        idx = np.rint((x - o) / h).astype(np.int64)
        inside = np.all((idx >= 0) & (idx < n), axis=1)
        idx, x = idx[inside], x[inside]
        vox = (idx[:, 2] * n[1] + idx[:, 1]) * n[0] + idx[:, 0]
        d2 = np.sum((x - (o + idx * h)) ** 2, axis=1)
        found.append(nearest(vox, d2, ids[inside], w[inside]))

    corners_only = np.unique(tri[levels == 1])  # small triangles: their corners suffice
    for start in range(0, corners_only.size, _SHELL_CHUNK):
        v = corners_only[start : start + _SHELL_CHUNK]
        w = np.zeros((v.size, 3))
        w[:, 0] = 1.0
        add(pts[v], np.repeat(v[:, None], 3, axis=1), w)
    for m in np.unique(levels[levels > 1]).tolist():  # one pass per level, not per cell
        i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1), indexing="ij")
        ok = i + j <= m
        w = np.stack([i[ok], j[ok], m - i[ok] - j[ok]], axis=1).astype(np.float64) / m  # (S, 3)
        cells = np.flatnonzero(levels == m)
        per_chunk = max(1, _SHELL_CHUNK // w.shape[0])
        for start in range(0, cells.size, per_chunk):
            sel = cells[start : start + per_chunk]
            x = np.einsum("sk,tkd->tsd", w, corner[sel]).reshape(-1, 3)
            add(x, np.repeat(tri[sel], w.shape[0], axis=0), np.tile(w, (sel.size, 1)))
    if not found:
        return np.zeros(0, dtype=np.intp), np.zeros((0, 3), dtype=np.intp), np.zeros((0, 3))
    vox, _, ids, w = nearest(*(np.concatenate(parts) for parts in zip(*found, strict=True)))
    return vox.astype(np.intp), ids, w


class _Shell:
    """A curved surface read as the grid points it passes through (a one-voxel shell).

    :attr:`valid` marks the grid points the first step's surface passes
    through (:func:`shell_voxels`); each holds the surface's point values
    interpolated linearly in a triangle at the surface point nearest it.  A
    step whose points or cells differ from the last one's is voxelized anew,
    and the first step's shell voxels it misses are NaN.
    """

    def __init__(self, grid: Grid, mesh: Any) -> None:
        self.origin, self.spacing, self.dims = grid
        self._points = np.array(mesh.points, dtype=np.float64)
        self._n_cells = int(mesh.n_cells)
        self.voxels, self.ids, self.weights = shell_voxels(
            self._points, surface_triangles(mesh), grid
        )
        nx, ny, nz = self.dims
        valid = np.zeros(nx * ny * nz, dtype=bool)
        valid[self.voxels] = True
        self.valid = valid.reshape(nz, ny, nx)

    def convert(self, mesh: Any, names: Sequence[str], *, label: str) -> dict[str, NDArray]:
        pts = np.asarray(mesh.points, dtype=np.float64)
        if (
            pts.shape != self._points.shape
            or int(mesh.n_cells) != self._n_cells
            or not np.array_equal(pts, self._points)
        ):
            grid = (self.origin, self.spacing, self.dims)
            vox, ids, w = shell_voxels(pts, surface_triangles(mesh), grid)
            keep = self.valid.reshape(-1)[vox]
            self.voxels, self.ids, self.weights = vox[keep], ids[keep], w[keep]
            self._points, self._n_cells = pts.copy(), int(mesh.n_cells)
        nx, ny, nz = self.dims
        out = {}
        for name, arr in point_arrays(mesh, names, label=label).items():
            a = np.asarray(arr, dtype=np.float64)
            if a.ndim == 2 and a.shape[1] == 1:
                a = a[:, 0]
            if a.shape not in ((pts.shape[0],), (pts.shape[0], 3)):
                raise DataError(
                    f"{label}: array {name!r} has shape {a.shape}; expected ({pts.shape[0]},) "
                    f"or ({pts.shape[0]}, 3) on a surface of {pts.shape[0]} points"
                )
            vals = np.einsum("kc,kc...->k...", self.weights, a[self.ids])
            frame = np.full((nx * ny * nz, *a.shape[1:]), np.nan)
            frame[self.voxels] = vals
            out[name] = frame.reshape((nz, ny, nx, *a.shape[1:]))
        return out


def _load(
    loader: Loader, step: int, label: str, scale: NDArray[np.float64] | None = None
) -> pyvista.DataSet:
    """Step ``step`` as one checked DataSet, its coordinates times ``scale`` (axis_scale)."""
    return scale_mesh(_load_raw(loader, step, label), scale)


def _load_raw(loader: Loader, step: int, label: str) -> pyvista.DataSet:
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
    converter: _SameGrid | _Lattice | _Sampler | _Shell | _Structured
    names: Sequence[str]
    scale: NDArray[np.float64] | None = None
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
                self._mesh = _load(self.loader, step, label, self.scale)
                self._arrays = {}
                self._step = step
                self.n_loads += 1
            whole = isinstance(self.converter, _Sampler | _Shell)
            wanted = self.names if name is None or whole else [name]
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
    apply_axis_scale: bool = True,
) -> TimeVolume:
    """Build a lazy :class:`TimeVolume` over the meshes ``loader`` returns.

    The reader options (:func:`auralize.io.options.current`) apply first:
    ``axis_scale`` multiplies every step's coordinates as it is loaded (so the
    grid is chosen in metres; ``attrs["axis_scale_applied"]`` says so), and
    ``box`` is the region whose cells set an automatic resolution and that
    a resampled grid covers.

    A mesh that is neither a uniform grid, a lattice nor a surface over a
    lattice is put on a uniform grid: a curved surface (2-D cells, not
    planar) as the shell of grid points it passes through (:class:`_Shell`),
    anything else by linear interpolation in its cells (:class:`_Sampler`).
    The automatic grid's voxel is a low percentile of the cells' sizes in the
    region (:func:`auralize.io.resample.grid_for_cells`), within a point
    budget that the memory available may lower; a grid (automatic or from
    ``resolution=``) that cannot fit in memory is refused before it is
    allocated (:class:`~auralize.errors.ResourceError`).  The one
    :class:`~auralize.io.ResampledWarning` says what was lost: the share of
    cells smaller than a voxel and of points outside the grid, also in
    ``attrs["resampling"]``.

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
    apply_axis_scale : bool
        False for a reader that scales its coordinates itself.
    """
    from auralize.io.options import current

    resolution = check_resolution(resolution, source=source)
    if len(labels) != len(times):
        raise FormatError(f"{source}: {len(labels)} step files for {len(times)} times")
    from auralize.runtime.vtklog import error_mark, first_error

    options = current()
    scale = (
        np.asarray(options.axis_scale, dtype=np.float64)
        if apply_axis_scale and options.axis_scale is not None
        else None
    )
    mark = error_mark()
    mesh0 = _load(loader, 0, labels[0], scale)
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
    native = (
        geom is None
        and lattice is None
        and surface is None
        and options.curvilinear == "native"
        and resolution is None
        and curvilinear_points(mesh0) is not None
    )
    converter: _SameGrid | _Lattice | _Sampler | _Shell | _Structured
    coords = None
    valid = None
    resampling: dict[str, Any] | None = None

    def new_steps() -> MeshSteps:
        return MeshSteps(
            loader=loader, labels=labels, converter=converter, names=names, scale=scale
        )

    if geom is not None:
        origin, spacing, dims = geom
        converter = _SameGrid(geom)
        steps = new_steps()
    elif native:
        from auralize.curvilinear import nominal_spacing

        coords = curvilinear_points(mesh0)
        assert coords is not None
        dims = (int(coords.shape[2]), int(coords.shape[1]), int(coords.shape[0]))
        origin = coords.reshape(-1, 3).min(axis=0)
        spacing = nominal_spacing(coords)
        converter = _Structured(coords)
        steps = new_steps()
    elif lattice is not None:
        (origin, spacing, dims), order = lattice
        converter = _Lattice((origin, spacing, dims), order, mesh0.points)
        steps = new_steps()
        steps.seed(0, converter.convert(mesh0, names, label=labels[0]))
    elif surface is not None:
        origin, spacing, dims = surface.grid
        converter = _Lattice(surface.grid, surface.order, mesh0.points, surface.axis, surface.level)
        steps = new_steps()
        steps.seed(0, converter.convert(mesh0, names, label=labels[0]))
        warn_resampled(
            f"{source}: a surface ({type(mesh0).__name__} with {mesh0.n_points} points, 2-D "
            f"cells) read on its own points, no interpolation: the lattice "
            f"{describe_grid(origin, spacing, dims)} in the plane {'xyz'[surface.axis]} = "
            f"{surface.level:.6g} m; the points lie up to ±{surface.deviation:.3g} m off it "
            f"(at the first step), and source positions are projected onto it"
        )
    else:
        shell = cell_dimension(mesh0) == 2 and not _is_flat(mesh0.bounds)
        n_comps = sum(comps[n] for n in names)
        choice, sizes, points_out = _choose_grid(
            mesh0,
            box=options.box,
            resolution=resolution,
            components=n_comps,
            n_steps=len(times),
            source=source,
        )
        origin, spacing, dims = choice.origin, choice.spacing, choice.dims
        converter = (
            _Shell((origin, spacing, dims), mesh0) if shell else _Sampler((origin, spacing, dims))
        )
        steps = new_steps()
        steps.seed(0, converter.convert(mesh0, names, label=labels[0]))
        valid = converter.valid
        assert valid is not None
        below = float(np.mean(sizes < choice.voxel)) if sizes.size else 0.0
        resampling = {
            "cells_below_voxel": below,
            "points_outside": points_out,
            "voxel": choice.voxel,
            "why": choice.why,
        }
        in_box = " in the box" if options.box is not None else ""
        lost = (
            f"; lost: {100.0 * below:.1f} % of the mesh's cells{in_box} are smaller than a "
            f"voxel ({choice.voxel:.3g} m), {100.0 * points_out:.1f} % of its points lie "
            f"outside the grid"
        )
        if choice.capped:
            lost += (
                f"; the finest cells are not resolved (the grid would need a "
                f"{choice.cell:.3g} m voxel): pass --box (box=) for a region, or --resolution "
                f"for a finer grid"
            )
        n_valid = int(np.count_nonzero(valid))
        if shell:
            if n_valid == 0:
                raise DataError(
                    f"{labels[0]}: the surface passes through no point of the grid "
                    f"{describe_grid(origin, spacing, dims)}; pass a finer resolution="
                )
            warn_resampled(
                f"{source}: a surface ({type(mesh0).__name__} with {mesh0.n_points} points, "
                f"2-D cells, not planar) read as a shell of {n_valid} voxels "
                f"({100.0 * n_valid / valid.size:.2f} % of the grid "
                f"{describe_grid(origin, spacing, dims)}; {choice.why}): each holds the "
                f"surface's values interpolated at the surface point nearest it, the rest is "
                f"no-data (NaN, valid=False){lost}"
            )
        else:
            n_out = valid.size - n_valid
            outside = (
                f"; {n_out} of {valid.size} grid points ({100.0 * n_out / valid.size:.1f} %) "
                f"lie outside the mesh and are no-data (NaN, valid=False)"
                if n_out
                else ""
            )
            warn_resampled(
                f"{source}: {type(mesh0).__name__} with {mesh0.n_points} points resampled by "
                f"linear interpolation onto a uniform grid of "
                f"{describe_grid(origin, spacing, dims)} ({choice.why}){outside}{lost}"
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
        coords=coords,
    )
    volume.attrs["centring"] = {
        vol_name: ("point" if file_name in mesh0.point_data.keys() else "cell")
        for vol_name, file_name in chosen.items()
    }
    volume.attrs["mesh"] = f"{type(mesh0).__name__} with {mesh0.n_points} points"
    if resampling is not None:
        volume.attrs["resampling"] = resampling
    if scale is not None:
        volume.attrs["axis_scale_applied"] = scale.tolist()
    if geom is not None or lattice is not None or surface is not None:
        volume = resample_uniform(volume, resolution)
    return volume


def resample_curvilinear(volume: TimeVolume, *, resolution: ResolutionArg = None) -> TimeVolume:
    """A curvilinear volume (``volume.coords``) put on a uniform grid, lazily; any other
    volume as it is.

    For what needs a uniform grid (the uniform file formats of
    :func:`auralize.io.save_volume`, the viewer's volume rendering): each step
    is made a ``vtkStructuredGrid`` of the volume's points and frames and
    sampled as :func:`open_mesh_series` samples a mesh (the voxel from its
    cells, a :class:`~auralize.io.ResampledWarning` saying what is lost).  A
    volume cut to a box (``attrs["box"]``: its index block, whose cells cover
    the box) is sampled over that box, as reading the file resampled with the
    box would.  Detection and rendering keep the native grid.
    """
    if volume.coords is None:
        return volume
    from auralize.io.options import ReadOptions, check_box, reading

    pv = import_pyvista()
    nz, ny, nx = volume.shape
    base = pv.StructuredGrid()
    base.points = volume.coords.reshape(-1, 3)
    base.dimensions = (nx, ny, nz)
    names = [n for n in volume.field_names if not n.startswith("(")]  # not assembled ones

    def loader(step: int) -> Any:
        g = base.copy(deep=False)
        for n in names:
            a = volume.frame(n, step)
            g.point_data[n] = a.reshape(-1, 3) if a.ndim == 4 else a.reshape(-1)
        return g

    region = check_box(volume.attrs.get("box"), source=volume.source)
    with reading(ReadOptions(curvilinear="resample", box=region)):
        out = open_mesh_series(
            source=volume.source,
            loader=loader,
            labels=[f"{volume.source} step {n}" for n in range(volume.n_steps)],
            times=volume.times,
            physical_times=volume.physical_times,
            fields=None,
            resolution=resolution,
            name_map=None,
            apply_axis_scale=False,
        )
    out.attrs = {**volume.attrs, **out.attrs}
    out.check_finite = volume.check_finite
    return out


def _is_flat(bounds: Sequence[float]) -> bool:
    """Whether a mesh of these bounds has zero extent along some axis (a 2-D mesh)."""
    ext = np.asarray(bounds, dtype=np.float64).reshape(3, 2) @ np.array([-1.0, 1.0])
    return bool(np.any(ext <= 1e-9 * float(ext.max())))


def _choose_grid(
    mesh: Any,
    *,
    box: Sequence[float] | None,
    resolution: ResolutionArg,
    components: int,
    n_steps: int,
    source: str,
) -> tuple[GridChoice, NDArray[np.float64], float]:
    """The grid a mesh is resampled onto, its cell sizes in the box, and the share of its
    points outside the box; refuses a grid that cannot fit in memory."""
    from auralize.runtime.resources import (
        FRAME_WORK_ARRAYS,
        available_bytes,
        format_bytes,
        require_volume,
    )

    region = region_bounds(mesh.bounds, box, source=source)
    cells = cell_sizes(mesh, box)
    sizes = cells.size[cells.inside]
    if box is None:
        n_in, points_out = int(mesh.n_points), 0.0
    else:
        n_in = int(np.count_nonzero(in_box(mesh.points, box, mesh.bounds)))
        points_out = 1.0 - n_in / max(int(mesh.n_points), 1)
    budget = AUTO_MAX_GRID_POINTS_2D if _is_flat(region) else AUTO_MAX_GRID_POINTS_3D
    # the automatic grid also leaves half the memory available free
    per_point = 8.0 * max(int(components), FRAME_WORK_ARRAYS)
    fits = int(0.5 * available_bytes() / per_point)
    memory_bound = fits < budget
    budget = max(min(budget, fits), 8)
    choice = grid_for_cells(
        region, sizes, n_points=max(n_in, 8), resolution=resolution, budget=budget, source=source
    )
    if choice.capped and memory_bound:
        choice = replace(
            choice,
            why=f"{choice.why} (half the {format_bytes(2 * fits * per_point)} of memory available)",
        )
    require_volume(
        choice.dims,
        n_steps,
        components,
        f"{source}: resampled onto a uniform grid",
        hint="pass a coarser --resolution (resolution=) or a smaller --box (box=)",
        data=False,
    )
    return choice, sizes, points_out
