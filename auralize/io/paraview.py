"""ParaView time series via pyvista: ``.pvd``, ``.series``, VTKHDF, single VTK files.

Readers return a lazy :class:`~auralize.volume.TimeVolume`: step 0 is read to
learn the grid and arrays, every later frame read loads its step's file with
:func:`pyvista.read` (see :mod:`auralize.io._mesh`).  Only VTK's own file
kinds are read (:data:`MESH_SUFFIXES`); nothing is unpickled.

The writer :func:`write_pvd` stores one ``.vti`` per time step in a sibling
folder ``<stem>_data/`` and a ``.pvd`` collection pointing at them, so a
volume opens in ParaView with its time steps.
"""

from __future__ import annotations

import errno
import json
import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np

from auralize.errors import DataError, FormatError, ParameterError
from auralize.io._common import FieldsArg, require_exists
from auralize.io._mesh import import_pyvista, open_mesh_series
from auralize.io.resample import ResolutionArg
from auralize.volume import DEFAULT_FRAME_RATE_HZ, TimeVolume

#: VTK file kinds a ``.pvd``/``.series`` step (or a single opened file) may be.
MESH_SUFFIXES = (
    ".vti",
    ".vts",
    ".vtr",
    ".vtu",
    ".vtp",
    ".vtk",
    ".vtm",
    ".pvti",
    ".pvts",
    ".pvtr",
    ".pvtu",
)


def _step_file(base: Path, name: str, *, collection: Path, what: str) -> Path:
    file = (base / name).expanduser()
    if file.suffix.lower() not in MESH_SUFFIXES:
        raise FormatError(
            f"{collection}: {what} {name!r} is not a VTK data file; supported kinds are "
            f"{', '.join(MESH_SUFFIXES)}"
        )
    if not file.is_file():
        raise FormatError(f"{collection}: {what} {name!r} does not exist (looked for {file})")
    return file


def _read_parts(parts: list[Path]) -> Any:
    pv = import_pyvista()
    meshes = [pv.read(str(p)) for p in parts]
    return meshes[0] if len(meshes) == 1 else pv.MultiBlock(meshes)


class _FileSteps:
    """Loader over step files: ``self(step)`` reads step ``step`` with pyvista."""

    def __init__(self, steps: list[list[Path]]) -> None:
        self.steps = steps

    def __call__(self, step: int) -> Any:
        return _read_parts(self.steps[step])


def _sorted_steps(entries: list[tuple[float, Path]]) -> tuple[list[float], list[list[Path]]]:
    """Group ``(time, file)`` entries by time, in increasing time order."""
    by_time: dict[float, list[Path]] = {}
    for t, file in entries:
        by_time.setdefault(t, []).append(file)
    times = sorted(by_time)
    return times, [by_time[t] for t in times]


# --------------------------------------------------------------------------- .pvd
def read_pvd(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open a ParaView ``.pvd`` collection as a lazy volume.

    Parameters
    ----------
    path : path-like
        The ``.pvd`` file: ``<VTKFile type="Collection">`` with
        ``<DataSet timestep=... file=.../>`` entries, files relative to it.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step per timestep of the collection; step 0 has been read to
        learn the grid.

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not a ``<VTKFile type="Collection">`` with ``DataSet`` entries,
        entries without a file or with a timestep that is no number, step
        files that do not exist or are not VTK data files, a damaged step file.
    FieldError
        A requested field is not in the file.
    DataError
        Timesteps that are not finite or occur twice (same part); steps whose
        grids or arrays disagree, a damaged mesh, a ``box`` that holds none of
        the mesh.
    ParameterError
        Bad ``fields=``, ``resolution=`` or ``name_map=``.
    ResourceError
        The uniform grid a mesh is resampled onto does not fit in memory.

    Warns
    -----
    ResampledWarning
        The mesh is put on a uniform grid (unless its points form one).

    Notes
    -----
    Entries are taken in increasing ``timestep`` order (as ParaView does).
    Entries sharing a timestep with different ``part`` numbers are pieces of
    one step and are merged; the same timestep and part twice is an error.
    Without any ``timestep`` attribute, entries are frames at 30 Hz in file
    order (``physical_times=False``).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.ones((2, 2, 3, 4))}, times=[0.0, 0.5])
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "run.pvd"
    >>> write_pvd(vol, out)
    >>> read_pvd(out).times.tolist()
    [0.0, 0.5]
    """
    path = Path(path).expanduser()
    require_exists(path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise FormatError(f"{path}: not a valid .pvd (XML) file: {exc}") from exc
    except OSError as exc:
        raise FormatError(f"{path}: cannot read ({exc})") from exc
    if root.tag != "VTKFile" or root.get("type") != "Collection":
        raise FormatError(
            f"{path}: root element is <{root.tag} type={root.get('type')!r}>; a .pvd file "
            f'needs <VTKFile type="Collection">'
        )
    coll = root.find("Collection")
    entries = [] if coll is None else coll.findall("DataSet")
    if not entries:
        raise FormatError(f"{path}: the collection has no <DataSet timestep=... file=...> entries")
    stamps = [e.get("timestep") for e in entries]
    physical = any(s is not None for s in stamps)
    if physical and any(s is None for s in stamps):
        raise FormatError(
            f"{path}: {sum(s is None for s in stamps)} of {len(stamps)} DataSet entries lack "
            f"timestep=; give every entry a time or none"
        )
    seen: dict[tuple[float, str], str] = {}
    parsed: list[tuple[float, Path]] = []
    for n, entry in enumerate(entries):
        name = entry.get("file")
        if not name:
            raise FormatError(f"{path}: DataSet entry {n} has no file= attribute")
        if physical:
            try:
                t = float(entry.get("timestep", ""))
            except ValueError:
                raise FormatError(
                    f"{path}: DataSet {name!r} has timestep={entry.get('timestep')!r}; "
                    f"it must be a number (seconds)"
                ) from None
            if not math.isfinite(t):
                raise DataError(
                    f"{path}: DataSet {name!r} has timestep={t!r}; times must be finite"
                )
        else:
            t = n / DEFAULT_FRAME_RATE_HZ
        key = (t, entry.get("part", "0"))
        if key in seen:
            raise DataError(
                f"{path}: DataSets {seen[key]!r} and {name!r} have the same timestep={t!r} "
                f"(and part); times must be strictly increasing"
            )
        seen[key] = name
        parsed.append((t, _step_file(path.parent, name, collection=path, what="DataSet file")))
    times, steps = _sorted_steps(parsed)
    return open_mesh_series(
        source=str(path),
        loader=_FileSteps(steps),
        labels=[f"{path} step {n} ({', '.join(str(p) for p in s)})" for n, s in enumerate(steps)],
        times=times,
        physical_times=physical,
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )


# --------------------------------------------------------------------------- .series
def read_series(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open a ParaView ``.series`` file (JSON) as a lazy volume.

    Parameters
    ----------
    path : path-like
        ``{"file-series-version": "1.0", "files": [{"name": "a_0.vti", "time": 0.0}, ...]}``,
        names relative to the ``.series`` file (``.vti``, ``.vts``, ``.vtu`` ...).
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step per file, at its ``time`` (s).

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not valid JSON, no ``files`` list, an unknown
        ``file-series-version``, an entry without a name or a numeric time,
        step files that do not exist or are not VTK data files.
    FieldError
        A requested field is not in the file.
    DataError
        Times that are not finite or occur twice; steps whose grids or arrays
        disagree, a damaged mesh, a ``box`` that holds none of the mesh.
    ParameterError
        Bad ``fields=``, ``resolution=`` or ``name_map=``.
    ResourceError
        The uniform grid a mesh is resampled onto does not fit in memory.

    Warns
    -----
    ResampledWarning
        The mesh is put on a uniform grid (unless its points form one).

    Notes
    -----
    Files are taken in increasing time order; two files at one time are an error.

    Examples
    --------
    >>> import json, tempfile, pathlib, numpy as np, pyvista as pv
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> for n in range(2):
    ...     img = pv.ImageData(dimensions=(4, 3, 2))
    ...     img.point_data["rho"] = np.full(24, float(n))
    ...     img.save(folder / f"a_{n}.vti")
    >>> files = [{"name": "a_0.vti", "time": 0.0}, {"name": "a_1.vti", "time": 0.25}]
    >>> _ = (folder / "a.series").write_text(
    ...     json.dumps({"file-series-version": "1.0", "files": files}))
    >>> vol = read_series(folder / "a.series")
    >>> vol.times.tolist(), vol.dims, float(vol.frame("rho", 1).max())
    ([0.0, 0.25], (4, 3, 2), 1.0)
    """
    path = Path(path).expanduser()
    require_exists(path)
    expected = '{"file-series-version": "1.0", "files": [{"name": ..., "time": ...}]}'
    try:
        content = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise FormatError(f"{path}: not a valid .series (JSON) file: {exc}") from exc
    files = content.get("files") if isinstance(content, dict) else None
    if not isinstance(files, list) or not files:
        raise FormatError(f"{path}: a .series file needs a non-empty 'files' list: {expected}")
    version = content.get("file-series-version")
    if version is not None and not str(version).startswith("1."):
        raise FormatError(
            f"{path}: file-series-version={version!r} is not supported; this reader knows 1.0"
        )
    parsed: list[tuple[float, Path]] = []
    seen: dict[float, str] = {}
    for n, entry in enumerate(files):
        name = entry.get("name") if isinstance(entry, dict) else None
        t = entry.get("time") if isinstance(entry, dict) else None
        if not isinstance(name, str) or not name:
            raise FormatError(f"{path}: files[{n}] has no 'name'; expected {expected}")
        if isinstance(t, bool) or not isinstance(t, int | float):
            raise FormatError(
                f"{path}: files[{n}] ({name!r}) has time={t!r}; it must be a number (seconds)"
            )
        t = float(t)
        if not math.isfinite(t):
            raise DataError(f"{path}: files[{n}] ({name!r}) has time={t!r}; times must be finite")
        if t in seen:
            raise DataError(
                f"{path}: {seen[t]!r} and {name!r} have the same time={t!r}; times must be "
                f"strictly increasing"
            )
        seen[t] = name
        parsed.append((t, _step_file(path.parent, name, collection=path, what="file")))
    times, steps = _sorted_steps(parsed)
    return open_mesh_series(
        source=str(path),
        loader=_FileSteps(steps),
        labels=[str(s[0]) for s in steps],
        times=times,
        physical_times=True,
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )


# --------------------------------------------------------------------------- single files
#: VTK XML data set types read as AMR: VTK 5 wrote hierarchical box data sets as ``.vtm``.
AMR_TYPES = ("vtkOverlappingAMR", "vtkNonOverlappingAMR", "vtkHierarchicalBoxDataSet")


def xml_root_type(path: Path) -> str | None:
    """The ``type`` of a VTK XML file's ``<VTKFile>`` element (``None`` if it has none).

    Reads the first 4 KiB only: the element opens every VTK XML file.

    Parameters
    ----------
    path : Path
        Any path; an unreadable one has no type.

    Returns
    -------
    str or None
        E.g. ``"ImageData"``, ``"Collection"``, ``"vtkOverlappingAMR"``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "old.vtm"
    >>> _ = f.write_text('<?xml version="1.0"?><VTKFile type="vtkHierarchicalBoxDataSet">')
    >>> xml_root_type(f), xml_root_type(f.parent / "missing.vtm")
    ('vtkHierarchicalBoxDataSet', None)
    """
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        return None
    m = re.search(rb"<VTKFile\b[^>]*?\btype\s*=\s*[\"']([A-Za-z0-9_]+)[\"']", head)
    return m.group(1).decode() if m else None


def read_mesh_file(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open one VTK data file (``.vti``, ``.vts``, ``.vtu`` ...) as a one-step volume.

    The single time is 0 with ``physical_times=False``.  An AMR file by another
    name (VTK 5 wrote hierarchical box data sets as ``.vtm``) is read by
    :func:`auralize.io.vtk_readers.read_amr`.

    Parameters
    ----------
    path : path-like
        A file of one of :data:`MESH_SUFFIXES`; a ``.vtm``'s blocks are merged.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step; its frame has been read to learn the grid.

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not a VTK data file, a damaged file, a file that holds no points.
    FieldError
        A requested field is not in the file.
    DataError
        Steps whose grids or arrays disagree, a damaged mesh, a ``box``
        that holds none of the mesh.
    ParameterError
        Bad ``fields=``, ``resolution=`` or ``name_map=``.
    ResourceError
        The uniform grid a mesh is resampled onto does not fit in memory.

    Warns
    -----
    ResampledWarning
        The mesh is put on a uniform grid (unless its points form one).

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np, pyvista as pv
    >>> img = pv.ImageData(dimensions=(4, 3, 2), spacing=(0.5, 0.5, 0.5))
    >>> img.point_data["rho"] = np.arange(24.0)
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "rho.vti"
    >>> img.save(f)
    >>> vol = read_mesh_file(f)
    >>> vol.dims, vol.spacing.tolist(), vol.n_steps, vol.physical_times
    ((4, 3, 2), [0.5, 0.5, 0.5], 1, False)
    """
    path = Path(path).expanduser()
    require_exists(path)
    if xml_root_type(path) in AMR_TYPES:  # an AMR file by another name (VTK 5's .vtm)
        from auralize.io.vtk_readers import read_amr

        return read_amr(path, fields=fields, resolution=resolution, name_map=name_map)
    file = _step_file(path.parent, path.name, collection=path, what="file")
    return open_mesh_series(
        source=str(path),
        loader=_FileSteps([[file]]),
        labels=[str(path)],
        times=[0.0],
        physical_times=False,
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )


# --------------------------------------------------------------------------- VTKHDF
class _VTKHDFSteps:
    """Loader over the time steps of a VTKHDF file.

    Each step is read with a fresh ``vtkHDFReader``: in VTK 9.7 a reused
    reader returns stale data when asked for step 0 again after another step.
    """

    def __init__(self, path: Path) -> None:
        self.path = str(path)

    def _reader(self) -> Any:
        import_pyvista()
        from vtkmodules.vtkIOHDF import vtkHDFReader

        reader = vtkHDFReader()
        reader.SetFileName(self.path)
        reader.UpdateInformation()
        return reader

    def times(self) -> list[float] | None:
        """The file's time values (``/VTKHDF/Steps/Values``), or None if not temporal."""
        from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as sddp

        info = self._reader().GetOutputInformation(0)
        if not info.Has(sddp.TIME_STEPS()):
            return None
        return [float(t) for t in info.Get(sddp.TIME_STEPS())]

    def __call__(self, step: int) -> Any:
        pv = import_pyvista()
        reader = self._reader()
        if reader.GetNumberOfSteps() > 0:
            reader.SetStep(step)
        reader.Update()
        out = reader.GetOutputDataObject(0)
        return None if out is None else pv.wrap(out)


def _check_vtkhdf_self_contained(path: Path) -> None:
    """Refuse a VTKHDF file that reads other files (VTK's HDF5 would follow its links)."""
    import h5py

    from auralize.io.hdf5 import check_self_contained

    try:
        with h5py.File(path, "r") as f:
            check_self_contained(f, path)
    except FormatError:
        raise
    except (OSError, RuntimeError, KeyError, ValueError) as exc:
        raise FormatError(f"{path}: cannot read as VTKHDF ({exc})") from exc


def read_vtkhdf(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open a VTKHDF file (``/VTKHDF`` group) as a lazy volume.

    Temporal files (a ``/VTKHDF/Steps`` group) give one time step per step,
    read with VTK's ``vtkHDFReader.SetStep``; others give one step at time 0
    with ``physical_times=False``.

    Parameters
    ----------
    path : path-like
        The ``.vtkhdf`` (or other HDF5) file.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        Times from ``/VTKHDF/Steps/Values`` (s).

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not readable as VTKHDF, data in other files (external
        links or datasets, unless allowed:
        :func:`auralize.io.hdf5.allow_external_data`).
    FieldError
        A requested field is not in the file.
    DataError
        Steps whose grids or arrays disagree, a damaged mesh, a ``box``
        that holds none of the mesh.
    ParameterError
        Bad ``fields=``, ``resolution=`` or ``name_map=``.
    ResourceError
        The uniform grid a mesh is resampled onto does not fit in memory.

    Warns
    -----
    ResampledWarning
        The mesh is put on a uniform grid (unless its points form one).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from auralize.io.vtkhdf_write import write_volume_vtkhdf
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.zeros((3, 2, 3, 4))}, times=[0.0, 0.1, 0.2])
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "p.vtkhdf"
    >>> write_volume_vtkhdf(vol, f)
    >>> again = read_vtkhdf(f)
    >>> again.times.tolist(), again.dims
    ([0.0, 0.1, 0.2], (4, 3, 2))
    """
    path = Path(path).expanduser()
    require_exists(path)
    _check_vtkhdf_self_contained(path)
    loader = _VTKHDFSteps(path)
    try:
        times = loader.times()
    except Exception as exc:  # VTK reader failures; name the file
        raise FormatError(f"{path}: cannot read as VTKHDF ({exc})") from exc
    physical = times is not None and len(times) > 0
    if not physical:
        times = [0.0]
    return open_mesh_series(
        source=str(path),
        loader=loader,
        labels=[f"{path} step {n}" for n in range(len(times))],  # type: ignore[arg-type]
        times=times,  # type: ignore[arg-type]
        physical_times=physical,
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )


# --------------------------------------------------------------------------- writer
def write_pvd(
    volume: TimeVolume,
    path: str | os.PathLike[str],
    *,
    compression: Literal["gzip"] | None = None,
) -> None:
    """Write ``volume`` as ``<stem>.pvd`` plus ``<stem>_data/<stem>_NNNN.vti``, atomically.

    The ``.vti`` files go into a new data folder (``<stem>_data``, or
    ``<stem>_data.1`` ... when that name holds the previous version), then a
    new ``.pvd`` pointing at it replaces the old one in one rename, then the
    old folder is removed (:func:`auralize.runtime.files.write_collection`).  A crash
    or a kill at any point leaves the old or the new collection complete.

    Parameters
    ----------
    volume : TimeVolume
        The volume; every frame must be finite.
    path : path-like
        The ``.pvd`` file; it and its data folder are replaced if they exist.
        Its folder must exist.  An existing ``<stem>_data/`` that auralize did
        not write for this ``.pvd`` is never replaced
        (:class:`~auralize.errors.OutputExistsError`, a :class:`FileExistsError`).
    compression : {None, "gzip"}
        Compress the ``.vti`` arrays with zlib (gzip's deflate).

    Raises
    ------
    ParameterError
        ``compression`` is neither None nor ``"gzip"``.
    DataError
        A frame holds NaN/Inf at a valid point of a volume that checks
        (``check_finite``); the old collection is kept.
    OutputError
        The folder cannot be written or the disk has too little free space
        (uncompressed: refused before writing);
        :class:`~auralize.errors.OutputExistsError` when ``<stem>_data/``
        exists and auralize did not write it.

    Notes
    -----
    ``physical_times`` is not stored: the times are written as they are.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.ones((2, 2, 3, 4))}, times=[0.0, 0.5])
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "run.pvd"
    >>> write_pvd(vol, out)
    >>> sorted(p.name for p in (out.parent / "run_data").glob("*.vti"))
    ['run_0000.vti', 'run_0001.vti']
    """
    from auralize.runtime.files import write_collection

    path = Path(path).expanduser()
    if compression not in (None, "gzip"):
        raise ParameterError(f"{path}: compression={compression!r}; valid are None and 'gzip'")
    pv = import_pyvista()
    from vtkmodules.vtkCommonMisc import vtkErrorCode
    from vtkmodules.vtkIOXML import vtkXMLImageDataWriter

    stem = path.stem
    width = max(4, len(str(volume.n_steps - 1)))
    names = [f"{stem}_{n:0{width}d}.vti" for n in range(volume.n_steps)]

    def write_steps(folder: Path) -> list[tuple[float, str]]:
        nx, ny, nz = volume.dims
        for step, name in enumerate(names):
            image = pv.ImageData(
                dimensions=volume.dims,
                spacing=tuple(float(s) for s in volume.spacing),
                origin=tuple(float(o) for o in volume.origin),
            )
            for field_name in volume.field_names:
                frame = volume.frame(field_name, step)
                flat = frame.reshape(nx * ny * nz, 3) if frame.ndim == 4 else frame.reshape(-1)
                image.point_data[field_name] = np.ascontiguousarray(flat)
            # VTK's writer, set as pyvista's ``save`` sets it (whose ``compression`` is recent)
            writer = vtkXMLImageDataWriter()
            writer.SetFileName(str(folder / name))
            writer.SetInputData(image)
            writer.SetDataModeToBinary()
            if compression == "gzip":
                writer.SetCompressorTypeToZLib()
            else:
                writer.SetCompressorTypeToNone()
            if not writer.Write():
                full = writer.GetErrorCode() == vtkErrorCode.OutOfDiskSpaceError
                code = errno.ENOSPC if full else errno.EIO
                raise OSError(code, os.strerror(code), str(folder / name))
        return [(float(t), name) for t, name in zip(volume.times, names, strict=True)]

    if compression is None:
        from auralize.runtime.resources import require_disk

        comps = sum(3 if volume.is_vector(n) else 1 for n in volume.field_names)
        require_disk(
            path,
            volume.n_steps * float(volume.n_points) * comps * 8 + 65536,
            f"{volume.n_steps} steps of {len(volume.field_names)} field(s)",
        )
    write_collection(path, f"{stem}_data", write_steps)
