"""Write volumes and detected sources as VTKHDF files (``.vtkhdf``), which ParaView opens.

Volumes are temporal ``ImageData`` (VTKHDF 2.x, written with h5py)::

    /VTKHDF                 attrs Version (2, 2), Type "ImageData", WholeExtent
                            (0, nx-1, 0, ny-1, 0, nz-1), Origin, Spacing, Direction
    /VTKHDF/PointData/NAME  (T, nz, ny, nx) or (T, nz, ny, nx, 3) float64
    /VTKHDF/Steps           attr NSteps = T; Values (T,) the step times in s;
                            PointDataOffsets/NAME (T,) = 0 .. T-1

Sources are temporal ``PolyData`` (one vertex per source point and step,
written by VTK's own ``vtkHDFWriter``): point data ``kind`` (int8 codes),
``strength``, ``radius`` (m) and ``volume`` (ΔV, m³), and the legend of the
``kind`` codes as field data (``kind_code`` = 1, 2, 3 and ``kind_name`` =
monopole, dipole, quadrupole; :data:`KIND_LEGEND`).

Both are written to a hidden temporary file beside the target and renamed
over it only when complete.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from auralize.errors import DataError, MissingFileError
from auralize.io.files import fsync_path, temp_sibling
from auralize.volume import TimeVolume

#: the ``kind`` codes of source files and their names
KIND_LEGEND: dict[int, str] = {1: "monopole", 2: "dipole", 3: "quadrupole"}

#: VTKHDF version written (temporal data needs major version 2)
VERSION = (2, 2)


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

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> vol = TimeVolume.from_arrays({"p": np.zeros((2, 3, 4, 5))}, times=[0.0, 0.1])
    >>> write_volume_vtkhdf(vol, pathlib.Path(tempfile.mkdtemp()) / "p.vtkhdf")
    """
    import h5py

    p = _checked_target(path)
    for name in volume.field_names:
        if not name or "/" in name or name in (".", ".."):
            raise DataError(f"{p}: field name {name!r} cannot be a VTKHDF array name; use a "
                            "non-empty name without '/'")  # fmt: skip
    nx, ny, nz = (int(d) for d in volume.dims)
    n = int(volume.n_steps)
    tmp = temp_sibling(p)
    try:
        with h5py.File(tmp, "w-") as f:
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
            for name in volume.field_names:
                shape = tuple(volume.fields[name].frame_shape)
                ds = pdata.create_dataset(name, shape=(n, *shape), dtype=np.float64,
                                          chunks=(1, *shape))  # fmt: skip
                for step in range(n):
                    ds[step] = volume.frame(name, step)
                offsets.create_dataset(name, data=np.arange(n, dtype=np.int64))
        fsync_path(tmp)
        os.replace(tmp, p)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


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
    """
    import pyvista as pv

    f = series.frames[step]
    pts = series.positions(f.index) if f.index.size else np.zeros((0, 3))
    poly = pv.PolyData(np.asarray(pts, dtype=np.float64))
    if not poly.n_verts and poly.n_points:  # pyvista adds the vertices; keep them explicit
        poly.verts = np.column_stack([np.ones(poly.n_points, np.int64),
                                      np.arange(poly.n_points)]).ravel()  # fmt: skip
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

    Parameters
    ----------
    series : SourceSeries
        Detected sources; step n is written at time ``series.times[n]`` (s).
    path : path-like
        The ``.vtkhdf`` file; replaced if it exists.
    """
    from vtkmodules.util.vtkAlgorithm import VTKPythonAlgorithmBase
    from vtkmodules.vtkCommonDataModel import vtkPolyData
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as sddp
    from vtkmodules.vtkIOHDF import vtkHDFWriter

    p = _checked_target(path)
    times = [float(t) for t in series.times]
    polys = [sources_polydata(series, n) for n in range(len(times))]

    class _Steps(VTKPythonAlgorithmBase):
        """A source serving ``polys[n]`` at ``times[n]`` (the writer asks step by step)."""

        def __init__(self) -> None:
            super().__init__(nInputPorts=0, nOutputPorts=1, outputType="vtkPolyData")

        def RequestInformation(self, request: Any, in_info: Any, out_info: Any) -> int:
            info = out_info.GetInformationObject(0)
            info.Set(sddp.TIME_STEPS(), times, len(times))
            info.Set(sddp.TIME_RANGE(), [times[0], times[-1]], 2)
            return 1

        def RequestData(self, request: Any, in_info: Any, out_info: Any) -> int:
            info = out_info.GetInformationObject(0)
            t = info.Get(sddp.UPDATE_TIME_STEP()) if info.Has(sddp.UPDATE_TIME_STEP()) else times[0]
            step = int(np.argmin(np.abs(np.asarray(times) - t)))
            vtkPolyData.GetData(out_info, 0).ShallowCopy(polys[step])
            return 1

    tmp = temp_sibling(p, suffix=".vtkhdf")
    try:
        steps = _Steps()  # held: the pipeline calls back into this Python object
        writer = vtkHDFWriter()
        writer.SetInputConnection(steps.GetOutputPort())
        writer.SetFileName(str(tmp))
        writer.SetWriteAllTimeSteps(len(times) > 1)
        if not writer.Write() or not tmp.is_file():
            raise DataError(f"{p}: VTK could not write the sources as VTKHDF")
        if len(times) > 1:  # the writer stores the step times as float32: keep them exact
            import h5py

            with h5py.File(tmp, "r+") as f:
                steps_group = f["VTKHDF/Steps"]
                del steps_group["Values"]
                steps_group.create_dataset("Values", data=np.asarray(times, dtype=np.float64))
        fsync_path(tmp)
        os.replace(tmp, p)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
