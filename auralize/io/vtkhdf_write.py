"""Write volumes and detected sources as VTKHDF files (``.vtkhdf``), which ParaView opens.

Volumes are temporal ``ImageData`` (VTKHDF 2.x, written with h5py)::

    /VTKHDF                 attrs Version (2, 2), Type "ImageData", WholeExtent
                            (0, nx-1, 0, ny-1, 0, nz-1), Origin, Spacing, Direction
    /VTKHDF/PointData/NAME  (T, nz, ny, nx) or (T, nz, ny, nx, 3) float64
    /VTKHDF/Steps           attr NSteps = T; Values (T,) the step times in s;
                            PointDataOffsets/NAME (T,) = 0 .. T-1

Sources are temporal ``PolyData`` (one vertex per source point and step, in
the layout VTK's own ``vtkHDFWriter`` writes): point data ``kind`` (int8 codes),
``strength``, ``radius`` (m) and ``volume`` (ΔV, m³), and the legend of the
``kind`` codes as field data (``kind_code`` = 1, 2, 3 and ``kind_name`` =
monopole, dipole, quadrupole; :data:`KIND_LEGEND`).

Both are written with h5py to a hidden temporary file beside the target and
renamed over it only when complete (:func:`~auralize.runtime.files.atomic_hdf5`):
a disk with too little free space is refused before the first byte, and a
write that fails anyway (the disk filled meanwhile) ends the writer at once
with one :class:`~auralize.errors.OutputError`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, MissingFileError
from auralize.runtime.files import atomic_hdf5, stop_if_failed
from auralize.volume import TimeVolume

#: the ``kind`` codes of source files and their names
KIND_LEGEND: dict[int, str] = {1: "monopole", 2: "dipole", 3: "quadrupole"}

#: VTKHDF version written (temporal data needs major version 2)
VERSION = (2, 2)

#: bytes of an HDF5 file beyond its arrays (superblock, groups, attributes), for disk checks
_OVERHEAD = 65536.0


def _ascii_attr(group: Any, name: str, value: str) -> None:
    """A fixed-length ASCII string attribute (what vtkHDFReader expects for ``Type``)."""
    group.attrs.create(name, np.bytes_(value.encode("ascii")))


def _checked_target(path: str | os.PathLike[str]) -> Path:
    p = Path(path).expanduser()
    if not p.parent.is_dir():
        raise MissingFileError(f"{str(p)!r}: the folder {str(p.parent)!r} does not exist")
    return p


def write_volume_vtkhdf(volume: TimeVolume, path: str | os.PathLike[str]) -> None:
    """Write ``volume`` as a temporal VTKHDF ``ImageData`` file, atomically.

    Parameters
    ----------
    volume : TimeVolume
        The volume; frames are read one step at a time and must be finite.
        Scalar fields become 1-component, vector fields 3-component point data.
    path : path-like
        The ``.vtkhdf`` file; replaced if it exists.

    Raises
    ------
    MissingFileError
        The folder of ``path`` does not exist.
    DataError
        A field name cannot name a VTKHDF array (empty, ``/``), or a frame
        holds NaN/Inf at a valid point of a volume that checks
        (``check_finite``); nothing is left behind.
    OutputError
        The disk has less free space than the file needs (refused before
        writing), or a write failed: the first failed write ends it, and
        nothing is left behind (:func:`~auralize.runtime.files.atomic_hdf5`).

    Examples
    --------
    >>> import h5py, numpy as np, tempfile, pathlib
    >>> vol = TimeVolume.from_arrays({"p": np.zeros((2, 3, 4, 5))}, times=[0.0, 0.1])
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "p.vtkhdf"
    >>> write_volume_vtkhdf(vol, f)
    >>> with h5py.File(f, "r") as h:
    ...     h["VTKHDF/PointData/p"].shape, h["VTKHDF/Steps/Values"][()].tolist()
    ((2, 3, 4, 5), [0.0, 0.1])
    """
    p = _checked_target(path)
    for name in volume.field_names:
        if not name or "/" in name or name in (".", ".."):
            raise DataError(
                f"{p}: field name {name!r} cannot be a VTKHDF array name; use a "
                "non-empty name without '/'"
            )
    nx, ny, nz = (int(d) for d in volume.dims)
    n = int(volume.n_steps)
    shapes = {name: tuple(volume.fields[name].frame_shape) for name in volume.field_names}
    nbytes = n * sum(8.0 * float(np.prod(s)) for s in shapes.values()) + 16.0 * n + _OVERHEAD
    what = f"{n} steps of {len(shapes)} field(s)"
    # no chunk cache: each step goes to disk when written, so a full disk stops at that step
    with atomic_hdf5(p, suffix=".vtkhdf.part", nbytes=nbytes, what=what, rdcc_nbytes=0) as f:
        root = f.create_group("VTKHDF")
        root.attrs["Version"] = np.asarray(VERSION, dtype=np.int64)
        _ascii_attr(root, "Type", "ImageData")
        root.attrs["WholeExtent"] = np.asarray([0, nx - 1, 0, ny - 1, 0, nz - 1], np.int64)
        root.attrs["Origin"] = np.asarray(volume.origin, dtype=np.float64)
        root.attrs["Spacing"] = np.asarray(volume.spacing, dtype=np.float64)
        root.attrs["Direction"] = np.eye(3).ravel()
        pdata = root.create_group("PointData", track_order=True)
        steps = root.create_group("Steps")
        steps.attrs["NSteps"] = np.int64(n)
        steps.create_dataset("Values", data=np.asarray(volume.times, dtype=np.float64))
        offsets = steps.create_group("PointDataOffsets")
        for name, shape in shapes.items():
            ds = pdata.create_dataset(name, shape=(n, *shape), dtype=np.float64, chunks=(1, *shape))
            for step in range(n):
                ds[step] = volume.frame(name, step)
                stop_if_failed(f)  # a full disk ends the writer here, not after every step
            offsets.create_dataset(name, data=np.arange(n, dtype=np.int64))


def _legend_arrays() -> tuple[Any, Any]:
    from vtkmodules.vtkCommonCore import vtkIntArray, vtkStringArray

    codes, names = vtkIntArray(), vtkStringArray()
    codes.SetName("kind_code")
    names.SetName("kind_name")
    for code, name in KIND_LEGEND.items():
        codes.InsertNextValue(code)
        names.InsertNextValue(name)
    return codes, names


def sources_polydata(series: Any, step: int) -> Any:
    """The sources of ``step`` as pyvista ``PolyData`` (one vertex cell per source point).

    Point data ``kind``, ``strength``, ``radius`` (m), ``volume`` (m³); field
    data ``kind_code`` / ``kind_name``, the legend of the ``kind`` codes.

    Parameters
    ----------
    series : SourceSeries
        Detected sources (:class:`~auralize.sources.detection.SourceSeries`).
    step : int
        Time step, 0 to ``series.n_steps - 1``.

    Returns
    -------
    pyvista.PolyData
        Points at the sources' grid positions (m).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.sources import SourceFrame, SourceSeries
    >>> frames = [SourceFrame(index=np.array([0, 5]), kind=np.array([1, 2], np.int8),
    ...                       strength=np.array([0.5, -1.0]), radius=np.array([0.1, 0.2]))]
    >>> series = SourceSeries(frames=frames, times=np.array([0.0]), origin=np.zeros(3),
    ...                       spacing=np.full(3, 0.5), dims=(4, 3, 2),
    ...                       thresholds=np.ones(3))
    >>> poly = sources_polydata(series, 0)
    >>> poly.points.tolist(), poly.point_data["kind"].tolist()
    ([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0]], [1, 2])
    """
    import pyvista as pv

    f = series.frames[step]
    pts = series.positions(f.index) if f.index.size else np.zeros((0, 3))
    poly = pv.PolyData(np.asarray(pts, dtype=np.float64))
    if not poly.n_verts and poly.n_points:  # pyvista adds the vertices; keep them explicit
        poly.verts = np.column_stack(
            [np.ones(poly.n_points, np.int64), np.arange(poly.n_points)]
        ).ravel()
    poly.point_data["kind"] = f.kind.astype(np.int8)
    poly.point_data["strength"] = np.asarray(f.strength, dtype=np.float64)
    poly.point_data["radius"] = np.asarray(f.radius, dtype=np.float64)
    poly.point_data["volume"] = np.asarray(f.volume, dtype=np.float64)
    codes, names = _legend_arrays()
    poly.GetFieldData().AddArray(codes)
    poly.GetFieldData().AddArray(names)
    return poly


def write_sources_vtkhdf(series: Any, path: str | os.PathLike[str]) -> None:
    """Write a :class:`~auralize.sources.detection.SourceSeries` as temporal VTKHDF ``PolyData``, atomically.

    One vertex cell per source point and step; point data ``kind`` (int8 codes),
    ``strength``, ``radius`` (m) and ``volume`` (m³); field data ``kind_code`` /
    ``kind_name`` (:data:`KIND_LEGEND`) in every step.  The layout is the one
    VTK's own ``vtkHDFWriter`` writes, so ParaView and ``vtkHDFReader`` open it.

    Parameters
    ----------
    series : SourceSeries
        Detected sources; step n is written at time ``series.times[n]`` (s, float64).
    path : path-like
        The ``.vtkhdf`` file; replaced if it exists.

    Raises
    ------
    MissingFileError
        The folder of ``path`` does not exist.
    OutputError
        The disk has less free space than the file needs (refused before
        writing), or a write failed: the first failed write ends it, and
        nothing is left behind (:func:`~auralize.runtime.files.atomic_hdf5`).

    Examples
    --------
    >>> import h5py, tempfile, pathlib
    >>> import numpy as np
    >>> from auralize.sources import SourceFrame, SourceSeries
    >>> frames = [SourceFrame(index=np.array([0, 5]), kind=np.array([1, 2], np.int8),
    ...                       strength=np.array([0.5, -1.0]), radius=np.array([0.1, 0.2]))]
    >>> series = SourceSeries(frames=frames, times=np.array([0.0]), origin=np.zeros(3),
    ...                       spacing=np.full(3, 0.5), dims=(4, 3, 2),
    ...                       thresholds=np.ones(3))
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "sources.vtkhdf"
    >>> write_sources_vtkhdf(series, f)
    >>> with h5py.File(f, "r") as h:
    ...     h["VTKHDF/NumberOfPoints"][()].tolist(), h["VTKHDF/PointData/strength"][()].tolist()
    ([2], [0.5, -1.0])
    """
    p = _checked_target(path)
    frames = list(series.frames)
    n = len(frames)
    times = np.asarray([float(t) for t in series.times], dtype=np.float64)
    counts = np.asarray([f.index.size for f in frames], dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64) if n else counts
    total = int(counts.sum())

    def cat(name: str, dtype: Any) -> NDArray[Any]:
        parts = [np.asarray(getattr(f, name), dtype=dtype) for f in frames]
        return np.concatenate(parts) if parts else np.zeros(0, dtype)

    index = cat("index", np.int64)
    points = np.asarray(series.positions(index), np.float64) if total else np.zeros((0, 3))
    point_data = {
        "kind": cat("kind", np.int8),
        "strength": cat("strength", np.float64),
        "radius": cat("radius", np.float64),
        "volume": cat("volume", np.float64),
    }
    codes = np.asarray(list(KIND_LEGEND), dtype=np.int32)
    names = [name.encode("ascii") for name in KIND_LEGEND.values()]
    nbytes = 73.0 * total + 400.0 * n + _OVERHEAD  # points, data, connectivity; per step
    what = f"{total} source points over {n} steps"
    with atomic_hdf5(p, suffix=".vtkhdf.part", nbytes=nbytes, what=what) as f:
        root = f.create_group("VTKHDF")
        root.attrs["Version"] = np.asarray(VERSION, dtype=np.int64)
        _ascii_attr(root, "Type", "PolyData")
        root.create_dataset("NumberOfPoints", data=counts)
        root.create_dataset("Points", data=points.reshape(-1, 3))
        local = [np.arange(c, dtype=np.int64) for c in counts]
        for topo in ("Vertices", "Lines", "Polygons", "Strips"):
            g = root.create_group(topo)
            cells = counts if topo == "Vertices" else np.zeros(n, np.int64)
            g.create_dataset("NumberOfCells", data=cells)
            g.create_dataset("NumberOfConnectivityIds", data=cells)
            if topo == "Vertices" and n:
                g.create_dataset("Offsets", data=np.concatenate([np.arange(c + 1) for c in counts]))
                g.create_dataset("Connectivity", data=np.concatenate(local))
            else:
                g.create_dataset("Offsets", data=np.zeros(n, np.int64))
                g.create_dataset("Connectivity", data=np.zeros(0, np.int64))
        pdata = root.create_group("PointData", track_order=True)
        for name, values in point_data.items():
            ds = pdata.create_dataset(name, data=values)
            if name == "kind":
                _ascii_attr(ds, "Attribute", "Scalars")
        root.create_group("CellData")
        fdata = root.create_group("FieldData", track_order=True)
        fdata.create_dataset("kind_code", data=np.tile(codes, n))
        fdata.create_dataset("kind_name", data=names * n, dtype=h5py_string())
        steps = root.create_group("Steps")
        steps.attrs["NSteps"] = np.int64(n)
        steps.create_dataset("Values", data=times)
        steps.create_dataset("PartOffsets", data=np.arange(n, dtype=np.int64))
        steps.create_dataset("NumberOfParts", data=np.ones(n, np.int64))
        steps.create_dataset("PointOffsets", data=starts)
        topo_offsets = np.zeros((n, 4), np.int64)
        topo_offsets[:, 0] = starts
        steps.create_dataset("CellOffsets", data=topo_offsets)
        steps.create_dataset("ConnectivityIdOffsets", data=topo_offsets)
        pdo = steps.create_group("PointDataOffsets")
        for name in point_data:
            pdo.create_dataset(name, data=starts)
        steps.create_group("CellDataOffsets")
        fdo, fds = steps.create_group("FieldDataOffsets"), steps.create_group("FieldDataSizes")
        for name in ("kind_code", "kind_name"):
            fdo.create_dataset(name, data=np.arange(n, dtype=np.int64) * len(KIND_LEGEND))
            fds.create_dataset(name, data=np.tile([1, len(KIND_LEGEND)], (n, 1)).astype(np.int64))


def h5py_string() -> Any:
    """The HDF5 type of VTKHDF string arrays: variable-length ASCII.

    Returns
    -------
    numpy.dtype
        ``h5py.string_dtype("ascii")``.

    Examples
    --------
    >>> import h5py
    >>> h5py.check_string_dtype(h5py_string()).encoding
    'ascii'
    """
    import h5py

    return h5py.string_dtype("ascii")
