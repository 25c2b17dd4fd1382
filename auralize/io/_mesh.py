"""Turning pyvista meshes, one time step at a time, into uniform-grid frames.

Every pyvista-based reader (``.pvd``, ``.series``, single VTK files, VTKHDF,
OpenFOAM) supplies a *loader* ``loader(step) -> mesh`` and the step times;
:func:`open_mesh_series` reads step 0 to learn the grid and the arrays, and
returns a :class:`~auralize.volume.TimeVolume` whose fields call the loader
again, one step per read.  Uniform grids (``ImageData``, evenly spaced
``RectilinearGrid``) keep their points; anything else is sampled onto a
uniform grid covering its bounds with VTK's ``vtkResampleWithDataSet``
(pyvista's :meth:`~pyvista.DataSetFilters.sample`).
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
    return pyvista


def as_dataset(obj: object, *, label: str) -> pyvista.DataSet:
    """One pyvista DataSet from a reader's output (composites are merged)."""
    pv = import_pyvista()
    if obj is None:
        raise FormatError(f"{label}: the reader returned no data")
    if not isinstance(obj, pv.DataObject):
        obj = pv.wrap(obj)
    if isinstance(obj, pv.DataSet):
        return obj
    if isinstance(obj, pv.MultiBlock) and "internalMesh" in obj.keys():
        return as_dataset(obj["internalMesh"], label=label)
    try:
        blocks = [b for b in obj if b is not None]  # type: ignore[attr-defined]
    except TypeError:
        raise FormatError(
            f"{label}: holds a {type(obj).__name__}, not a mesh with point or cell data"
        ) from None
    blocks = [as_dataset(b, label=label) for b in blocks]
    blocks = [b for b in blocks if b.n_points > 0]
    if not blocks:
        raise FormatError(f"{label}: the file holds no points")
    if len(blocks) == 1:
        return blocks[0]
    return pv.MultiBlock(blocks).combine()


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
    return None


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


class _Sampler:
    """Sample any mesh onto a fixed uniform grid (linear interpolation in each cell).

    Grid points outside the mesh take the value of the nearest point inside
    (found by a Euclidean distance transform; cached while the mesh is static).
    """

    def __init__(self, grid: Grid) -> None:
        self.origin, self.spacing, self.dims = grid
        self._target: Any = None
        self._mask: NDArray[np.bool_] | None = None
        self._fill: NDArray[np.intp] | None = None
        self.outside = 0

    def _fill_index(self, inside: NDArray[np.bool_], *, label: str) -> NDArray[np.intp] | None:
        if inside.all():
            return None
        if not inside.any():
            raise DataError(
                f"{label}: no point of the uniform grid "
                f"{describe_grid(self.origin, self.spacing, self.dims)} lies inside the mesh; "
                f"the mesh may have no volume cells"
            )
        if self._mask is None or not np.array_equal(self._mask, inside):
            from scipy.ndimage import distance_transform_edt

            indices = distance_transform_edt(
                ~inside, sampling=self.spacing[::-1], return_distances=False, return_indices=True
            )
            self._fill = np.ravel_multi_index(tuple(indices), inside.shape).ravel()
            self._mask = inside
        return self._fill

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
        inside = np.asarray(out.point_data["vtkValidPointMask"]).astype(bool).reshape(nz, ny, nx)
        self.outside = int(np.count_nonzero(~inside))
        fill = self._fill_index(inside, label=label)
        result = {}
        for name in names:
            a = np.array(out.point_data[name], dtype=np.float64)
            if fill is not None:
                a = a[fill]
            result[name] = _frame(a, (nz, ny, nx), name=name, label=label)
        return result


def _load(loader: Loader, step: int, label: str) -> pyvista.DataSet:
    try:
        obj = loader(step)
    except AuralizeError:
        raise
    except Exception as exc:  # VTK and pyvista raise many kinds; name the file
        raise FormatError(f"{label}: cannot read ({type(exc).__name__}: {exc})") from exc
    return as_dataset(obj, label=label)


@dataclass
class MeshSteps:
    """Loads and converts one time step at a time; keeps the last step's arrays.

    Shared by all fields of a volume, so reading every field of one step loads
    the step's file(s) once.  Thread-safe; ``n_loads`` counts loads.
    """

    loader: Loader
    labels: Sequence[str]
    converter: _SameGrid | _Sampler
    names: Sequence[str]
    n_loads: int = 0
    _step: int | None = None
    _arrays: dict[str, NDArray] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def seed(self, step: int, arrays: dict[str, NDArray]) -> None:
        with self._lock:
            self._step, self._arrays = step, arrays

    def arrays(self, step: int) -> dict[str, NDArray]:
        with self._lock:
            if self._step != step:
                label = self.labels[step]
                mesh = _load(self.loader, step, label)
                self._arrays = self.converter.convert(mesh, self.names, label=label)
                self._step = step
                self.n_loads += 1
            return self._arrays


@dataclass
class MeshFrames:
    """One field of a mesh time series; :meth:`read` loads (at most) one step."""

    steps: MeshSteps
    array_name: str
    n_steps: int
    frame_shape: tuple[int, ...]

    def read(self, step: int) -> NDArray[np.float64]:
        return self.steps.arrays(step)[self.array_name].copy()


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
    mesh0 = _load(loader, 0, labels[0])
    if mesh0.n_points == 0:
        raise FormatError(f"{labels[0]}: the mesh has no points")
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
    converter: _SameGrid | _Sampler
    if geom is not None:
        origin, spacing, dims = geom
        converter = _SameGrid(geom)
        steps = MeshSteps(loader=loader, labels=labels, converter=converter, names=names)
    else:
        origin, spacing, dims = grid_for_bounds(
            mesh0.bounds, n_points=mesh0.n_points, resolution=resolution, source=source
        )
        converter = _Sampler((origin, spacing, dims))
        steps = MeshSteps(loader=loader, labels=labels, converter=converter, names=names)
        steps.seed(0, converter.convert(mesh0, names, label=labels[0]))
        how = "automatic" if resolution is None else f"resolution={resolution!r}"
        outside = (
            f"; {converter.outside} of {int(np.prod(dims))} grid points lie outside the mesh "
            f"and take the value of the nearest point inside"
            if converter.outside
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
    )
    if geom is not None:
        volume = resample_uniform(volume, resolution)
    return volume
