"""Files VTK's own readers open: XDMF, EnSight Gold, PLOT3D, AMR, multiblock and the rest.

Each reader here hands :func:`auralize.io._mesh.open_mesh_series` a loader
that reads one time step per call with a VTK reader (through pyvista), so
volumes stay lazy: one step in memory at a time, and opening reads the time
values plus the first step (to learn the grid and the arrays).  VTK's XDMF
and EnSight readers end the process on some damaged files: XDMF files and
their heavy data are checked first (:mod:`auralize.io.xdmf_check`), EnSight
cases are read in a child process (:class:`ChildEnSightSteps`).

=====================================  ==============================================
input                                  reader
=====================================  ==============================================
``.xdmf``, ``.xmf`` (XDMF 2/3, e.g.    :func:`read_xdmf` (VTK's ``vtkXdmfReader``)
dolfinx/FEniCS, meshio series)
``.case`` (EnSight Gold, transient     :func:`read_ensight` (``vtkEnSightGoldReader``)
or single step)
PLOT3D grid (``.xyz``, ``.x``,        :func:`read_plot3d` (``vtkMultiBlockPLOT3DReader``)
``.grd``, ``*xyz*.bin``) + ``.q``      or numpy for single-grid binary solutions
series, or a ``.q`` next to its grid
``.vthb``/``.vth`` (AMR)               :func:`read_amr` (merged leaf blocks, resampled)
anything else ``pyvista.get_reader``   :func:`read_with_pyvista`
opens
=====================================  ==============================================
"""

from __future__ import annotations

import os
import re
import sys
import threading
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np

from auralize.errors import AuralizeError, DataError, FormatError
from auralize.io._common import FieldsArg, require_exists
from auralize.io._mesh import as_dataset, import_pyvista, open_mesh_series
from auralize.io.resample import ResolutionArg
from auralize.io.xdmf_check import check_xdmf
from auralize.runtime.vtkcompat import amr_block, amr_block_count, c_locale_kept
from auralize.runtime.vtklog import c_stderr_logged, error_mark, first_error, one_line
from auralize.volume import TimeVolume

#: Grid-file endings of PLOT3D (solutions are ``.q``).
PLOT3D_GRID_SUFFIXES = (".xyz", ".x", ".grd")
#: AMR file endings (VTK XML hierarchical box data).
AMR_SUFFIXES = (".vthb", ".vth")
XDMF_SUFFIXES = (".xdmf", ".xmf", ".xdmf3", ".xdmf2")


class _TimeReaderSteps:
    """Loader over the time values of one pyvista reader (kept open, one step per read)."""

    def __init__(
        self,
        make: Callable[[], Any],
        label: str,
        before_read: Callable[[float | None], None] | None = None,
    ) -> None:
        self._make = make
        self._reader: Any = None
        self._lock = threading.Lock()
        self.label = label
        self._before_read = before_read

    def _get(self) -> Any:
        if self._reader is None:
            self.error_mark = error_mark()  # a failed read reports the reader's first error
            self._reader = self._make()
        return self._reader

    def _values(self) -> list[float]:
        try:
            values = getattr(self._get(), "time_values", None)
        except TypeError:  # pyvista fails on readers that report no time steps
            return []
        return [float(t) for t in values] if values else []

    def times(self) -> list[float]:
        with self._lock, c_stderr_logged():
            return self._values()

    def __call__(self, step: int) -> Any:
        with self._lock, c_stderr_logged():
            reader = self._get()
            values = self._values()
            if self._before_read is not None:
                self._before_read(values[step] if values else None)
            if values:
                reader.set_active_time_value(values[step])
            return reader.read()


def _open_reader_series(
    path: Path,
    make: Callable[[], Any],
    *,
    kind: str,
    fields: FieldsArg,
    resolution: ResolutionArg,
    name_map: Mapping[str, str] | None,
    before_read: Callable[[float | None], None] | None = None,
) -> TimeVolume:
    loader = _TimeReaderSteps(make, str(path), before_read)
    mark = error_mark()
    try:
        times = loader.times()
    except AuralizeError:
        raise
    except Exception as exc:  # VTK raises many kinds; name the file, the kind and VTK's reason
        why = first_error(mark) or f"{type(exc).__name__}: {one_line(str(exc))}"
        raise FormatError(f"{path}: cannot read as {kind} ({why})") from exc
    return _mesh_series(
        path, loader, times, fields=fields, resolution=resolution, name_map=name_map
    )


def _mesh_series(
    path: Path,
    loader: Any,
    times: list[float],
    *,
    fields: FieldsArg,
    resolution: ResolutionArg,
    name_map: Mapping[str, str] | None,
) -> TimeVolume:
    """The lazy volume of a reader's steps; no times means one step at frame 0."""
    physical = len(times) > 0
    times = times or [0.0]
    return open_mesh_series(
        source=str(path),
        loader=loader,
        labels=[f"{path} t={t:g}" for t in times] if physical else [str(path)],
        times=times,
        physical_times=physical,
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )


# --------------------------------------------------------------------------- XDMF
def read_xdmf(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open an XDMF (``.xdmf``/``.xmf``) time series as a lazy volume.

    Read with VTK's XDMF reader: a temporal grid collection gives one step per
    ``<Time Value=...>`` (seconds); heavy data stay in their HDF5 files until a
    step is read.  A mesh grid listed beside the temporal collection (as
    meshio writes it) is the same mesh and is not counted twice.

    VTK's reader ends the process on damaged heavy data and reads files from
    anywhere, so the XML and every file it names are checked first
    (:mod:`auralize.io.xdmf_check`): heavy data outside the XDMF's folder and
    XIncludes of other files are refused unless
    :func:`~auralize.io.hdf5.allow_external_data` allows them, and damaged
    HDF5 data raise :class:`FormatError` instead of crashing.

    Parameters
    ----------
    path : path-like
        The ``.xdmf``/``.xmf`` file.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step per time of the temporal collection (s); a file without
        times is one step at 0 (``physical_times=False``).

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not XDMF, XML entities, heavy data outside the folder or
        XIncludes of other files (unless allowed), damaged or missing heavy
        data, a file VTK cannot read.
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
    The meshio time series shipped with auralize (a 2 x 2 square, five steps):

    >>> from pathlib import Path
    >>> import auralize
    >>> data = Path(auralize.__file__).parent / "data"
    >>> vol = read_xdmf(data / "xdmf-timeseries/meshio/out.xdmf")
    >>> vol.times.tolist(), vol.dims, vol.field_names
    ([0.0, 0.25, 0.5, 0.75, 1.0], (2, 2, 1), ['phi', 'u', 'a'])
    """
    path = Path(path).expanduser()
    require_exists(path)
    checked = check_xdmf(path)

    def make() -> Any:
        pv = import_pyvista()
        try:
            return pv.XdmfReader(str(path))
        except TypeError:  # pyvista's XdmfReader needs time steps; a static file has none
            from vtkmodules.vtkIOXdmf2 import vtkXdmfReader

            return _StaticReader(vtkXdmfReader, str(path))

    return _open_reader_series(
        path,
        make,
        kind="XDMF",
        fields=fields,
        resolution=resolution,
        name_map=name_map,
        before_read=checked.check_step,
    )


class _StaticReader:
    """A VTK reader of a file without time steps, read whole (``time_values`` empty)."""

    time_values: tuple[float, ...] = ()

    def __init__(self, cls: Any, path: str) -> None:
        self.cls, self.path = cls, path

    def read(self) -> Any:
        pv = import_pyvista()
        reader = self.cls()
        reader.SetFileName(self.path)
        reader.Update()
        return pv.wrap(reader.GetOutputDataObject(0))


# --------------------------------------------------------------------------- EnSight
def read_ensight(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open an EnSight Gold ``.case`` file (transient or single step) as a lazy volume.

    A transient case gives one step per time value of its ``TIME`` section;
    a case without one is a single step at time 0 (``physical_times=False``).
    Boundary parts (lower-dimensional cells) are dropped; the volume parts
    are merged.  VTK reads each step in a child process
    (:class:`ChildEnSightSteps`) and the merged mesh is checked
    (:func:`~auralize.io._mesh.check_mesh`), so a damaged geometry or
    variable file raises :class:`FormatError` or :class:`DataError` naming the
    case instead of ending the process.

    Parameters
    ----------
    path : path-like
        The ``.case`` file; the files it names lie beside it.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step per time value (s), or one step at 0 without a ``TIME``
        section.

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not an EnSight case, a geometry or variable file VTK cannot
        read or that is damaged (the reading process failed or crashed).
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
    The cylinder wake shipped with auralize (one step, a flat mesh):

    >>> from pathlib import Path
    >>> import auralize
    >>> data = Path(auralize.__file__).parent / "data"
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")  # a ResampledWarning: the mesh is unstructured
    ...     vol = read_ensight(data / "ensight-cylinder/cylinder_Re35.case", resolution=40)
    >>> vol.field_names, vol.n_steps, vol.physical_times, vol.dims[2]
    (['pressure', 'vorticity_mag', 'velocity'], 1, False, 1)
    """
    path = Path(path).expanduser()
    require_exists(path)
    try:
        head = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise FormatError(f"{path}: cannot read ({exc})") from exc
    if "FORMAT" not in head.upper() or "GEOMETRY" not in head.upper():
        raise FormatError(
            f"{path}: not an EnSight case file (no FORMAT and GEOMETRY sections); the file "
            f"may be truncated"
        )

    return _child_series(
        path, ChildEnSightSteps(path), fields=fields, resolution=resolution, name_map=name_map
    )


def _child_series(
    path: Path,
    loader: ChildEnSightSteps,
    *,
    fields: FieldsArg,
    resolution: ResolutionArg,
    name_map: Mapping[str, str] | None,
) -> TimeVolume:
    """The lazy volume of the steps a child process reads (the child ends if opening fails)."""
    try:
        times = loader.times()
    except BaseException:
        loader.close()
        raise
    return _mesh_series(
        path, loader, times, fields=fields, resolution=resolution, name_map=name_map
    )


#: The child process of :class:`ChildEnSightSteps`: ``<program> KIND PATH``.
_CHILD_PROGRAM = (
    "import sys; from auralize.io.vtk_readers import serve_child; "
    "serve_child(sys.argv[1], sys.argv[2])"
)
#: What a child process reads: kind -> the name of VTK's reader in messages.
CHILD_KINDS = {"ensight": "EnSight", "enzo": "Enzo"}
#: Seconds one request to the child may take before it is given up.
CHILD_TIMEOUT_S = 600.0


class _EnzoAMR:
    """One Enzo output through VTK's ``vtkAMREnzoReader``: its grids as a MultiBlock.

    ``path`` is the output's ``.hierarchy`` file (VTK finds the parameter file
    and the HDF5 grid files beside it); every level and every cell array is read.
    """

    time_values: tuple[float, ...] = ()

    def __init__(self, path: str) -> None:
        self.path = str(Path(path).resolve())  # VTK resolves grid files against its folder

    def read(self) -> Any:
        from vtkmodules.vtkIOAMR import vtkAMREnzoReader

        reader = vtkAMREnzoReader()
        reader.SetFileName(self.path)
        reader.SetMaxLevel(64)
        reader.UpdateInformation()
        for i in range(reader.GetNumberOfCellArrays()):
            reader.SetCellArrayStatus(reader.GetCellArrayName(i), 1)
        reader.Update()
        return amr_leaves(reader.GetOutputDataObject(0), label=self.path)


def serve_child(kind: Literal["ensight", "enzo"], path: str) -> None:
    """Child side of :class:`ChildEnSightSteps`: read steps of ``path`` on request.

    ``kind`` is a key of :data:`CHILD_KINDS`: ``ensight`` (an EnSight case) or
    ``enzo`` (one Enzo output's ``.hierarchy``).
    Requests arrive on stdin, one a line: ``times`` or ``read <time>`` (``read -``
    for a case without times).  Each answer on stdout is a status byte (``+``
    done, ``!`` refused), an 8-byte big-endian length and the payload: the
    times as JSON, the step's mesh (merged, checked by
    :func:`~auralize.io._mesh.as_dataset`) as :func:`marshal_mesh` gives it, or
    ``<error class>\\n<message>``.  VTK's error messages are collected, not
    printed: a read that logs one is refused with it.

    Parameters
    ----------
    kind : {"ensight", "enzo"}
        What ``path`` is.
    path : str
        The EnSight ``.case`` file or the Enzo ``.hierarchy`` file.

    Examples
    --------
    A child process asked for the times of the cylinder case (which has none):

    >>> import json, subprocess, sys
    >>> from pathlib import Path
    >>> import auralize
    >>> case = Path(auralize.__file__).parent / "data/ensight-cylinder/cylinder_Re35.case"
    >>> child = ("import sys; from auralize.io.vtk_readers import serve_child; "
    ...          "serve_child('ensight', sys.argv[1])")
    >>> out = subprocess.run([sys.executable, "-c", child, str(case)], input=b"times\\n",
    ...                      capture_output=True, check=True).stdout
    >>> out[:1], int.from_bytes(out[1:9], "big"), json.loads(out[9:])
    (b'+', 2, [])
    """
    import json
    import struct

    from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

    proto = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # stray prints of C code must not reach the answers
    pv = import_pyvista()
    window = vtkStringOutputWindow()
    vtkOutputWindow.SetInstance(window)
    reader: Any = None

    def answer(ok: bool, payload: bytes) -> None:
        proto.write((b"+" if ok else b"!") + struct.pack(">Q", len(payload)) + payload)
        proto.flush()

    for line in sys.stdin.buffer:
        command, _, arg = line.decode().strip().partition(" ")
        seen = len(window.GetOutput())
        try:
            if reader is None:
                reader = pv.EnSightReader(path) if kind == "ensight" else _EnzoAMR(path)
            if command == "times":
                values = getattr(reader, "time_values", None) or []
                answer(True, json.dumps([float(t) for t in values]).encode())
                continue
            if arg != "-":
                reader.set_active_time_value(float(arg))
            out = reader.read()
            logged = window.GetOutput()[seen:].split("ERROR: In ")[1:]
            if logged:  # "ERROR: In <source>, line <n>" then the message
                lines = [ln for ln in logged[0].splitlines() if ln.strip()]
                raise FormatError(" ".join(lines[min(1, len(lines) - 1)].split()))
            mesh = as_dataset(out, label=path)
            if mesh.n_points == 0:
                raise FormatError(f"the {CHILD_KINDS[kind]} data hold no points")
            answer(True, marshal_mesh(mesh))
        except AuralizeError as exc:
            answer(False, f"{type(exc).__name__}\n{exc}".encode())
        except Exception as exc:  # VTK and pyvista raise many kinds
            answer(False, f"FormatError\n{type(exc).__name__}: {exc}".encode())


#: The data set classes a child process may send back.
_MESH_CLASSES = (
    "vtkUnstructuredGrid",
    "vtkPolyData",
    "vtkStructuredGrid",
    "vtkRectilinearGrid",
    "vtkImageData",
)


def marshal_mesh(mesh: Any) -> bytes:
    """``mesh`` as bytes for another process: a JSON header line, then VTK's marshalled form.

    VTK's marshalling (its legacy binary format) keeps every array exactly but
    writes an image's origin, spacing and direction as text of 6 digits, so
    the header carries them in full.  No pickle crosses processes.

    Parameters
    ----------
    mesh : pyvista.DataSet
        An unstructured grid, poly data, structured, rectilinear or image data.

    Returns
    -------
    bytes
        What :func:`unmarshal_mesh` turns back into the mesh.

    Raises
    ------
    FormatError
        Another kind of data object, or one VTK cannot marshal.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> img = pv.ImageData(dimensions=(3, 2, 2), spacing=(0.1, 0.2, 0.3))
    >>> img.point_data["rho"] = np.arange(12.0)
    >>> data = marshal_mesh(img)
    >>> data.split(b"\\n", 1)[0][:40]
    b'{"class": "vtkImageData", "point": ["rho'
    """
    import json

    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkCharArray
    from vtkmodules.vtkParallelCore import vtkCommunicator

    name = mesh.GetClassName()
    if name not in _MESH_CLASSES:
        raise FormatError(f"the reader returned a {name}, not a mesh with point or cell data")
    head: dict[str, object] = {"class": name}
    for key, data in (("point", mesh.GetPointData()), ("cell", mesh.GetCellData())):
        head[key] = [data.GetArrayName(i) for i in range(data.GetNumberOfArrays())]
    if name == "vtkImageData":
        head["origin"] = list(mesh.GetOrigin())
        head["spacing"] = list(mesh.GetSpacing())
        matrix = mesh.GetDirectionMatrix()
        head["direction"] = [matrix.GetElement(i, j) for i in range(3) for j in range(3)]
    buffer = vtkCharArray()
    with c_locale_kept():
        marshalled = vtkCommunicator.MarshalDataObject(mesh, buffer)
    if not marshalled:
        raise FormatError(f"VTK cannot marshal the {name} the reader returned")
    return json.dumps(head).encode() + b"\n" + vtk_to_numpy(buffer).tobytes()


def unmarshal_mesh(data: bytes) -> Any:
    """The mesh :func:`marshal_mesh` turned into ``data``.

    Parameters
    ----------
    data : bytes
        :func:`marshal_mesh`'s output (from another process).

    Returns
    -------
    pyvista.DataSet
        The mesh, its arrays in their original order; an image keeps its
        origin, spacing and direction exactly.

    Raises
    ------
    FormatError
        ``data`` does not hold a mesh of a known class, or VTK cannot read it.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> img = pv.ImageData(dimensions=(3, 2, 2), spacing=(0.1, 0.2, 1 / 3))
    >>> img.point_data["rho"] = np.arange(12.0)
    >>> back = unmarshal_mesh(marshal_mesh(img))
    >>> back.spacing == img.spacing, back.point_data["rho"].tolist() == list(range(12))
    (True, True)
    """
    import json

    from vtkmodules import vtkCommonDataModel
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkCharArray
    from vtkmodules.vtkParallelCore import vtkCommunicator

    pv = import_pyvista()
    line, _, body = data.partition(b"\n")
    head = json.loads(line)
    name = head.get("class")
    if name not in _MESH_CLASSES:
        raise FormatError(f"the reading process sent a {name!r}, not a mesh")
    buffer = vtkCharArray()
    buffer.SetNumberOfTuples(len(body))
    view = vtk_to_numpy(buffer)
    view[:] = np.frombuffer(body, dtype=view.dtype)
    mesh = getattr(vtkCommonDataModel, name)()
    with c_locale_kept():
        unmarshalled = vtkCommunicator.UnMarshalDataObject(buffer, mesh)
    if not unmarshalled:
        raise FormatError(f"the {name} the reading process sent cannot be read back")
    for key, data in (("point", mesh.GetPointData()), ("cell", mesh.GetCellData())):
        _restore_order(data, head[key])
    if name == "vtkImageData":
        mesh.SetOrigin(*head["origin"])
        mesh.SetSpacing(*head["spacing"])
        mesh.SetDirectionMatrix(*head["direction"])
    return pv.wrap(mesh)


def _restore_order(data: Any, names: list[str]) -> None:
    """Put the arrays of ``data`` (point or cell data) in the order ``names`` (the file's).

    VTK's marshalled form lists the active scalars and vectors first; the
    order of arrays is the order of a volume's fields, so it is restored.
    """
    have = [data.GetArrayName(i) for i in range(data.GetNumberOfArrays())]
    if have == names:
        return
    if sorted(have) != sorted(names):
        raise FormatError(f"the reading process sent arrays {have}, expected {names}")
    scalars, vectors = data.GetScalars(), data.GetVectors()
    arrays = [data.GetAbstractArray(n) for n in names]
    for n in names:
        data.RemoveArray(n)
    for array in arrays:
        data.AddArray(array)
    if scalars is not None:
        data.SetActiveScalars(scalars.GetName())
    if vectors is not None:
        data.SetActiveVectors(vectors.GetName())


class ChildEnSightSteps:
    """Loader of an EnSight case whose steps VTK reads in a child process.

    VTK's EnSight readers end the process (segmentation fault) on some
    damaged geometry files, and return meshes with garbage connectivity on
    others.  Here one child process (started on first use, kept for the
    volume's life, ended when the loader is garbage-collected or the program
    exits) reads each step with VTK, merges its parts and checks the result
    (:func:`~auralize.io._mesh.check_mesh`); the mesh comes back in VTK's
    marshalled form (:func:`marshal_mesh`).
    A child that crashes, hangs for :data:`CHILD_TIMEOUT_S` or reports a VTK
    error becomes a :class:`FormatError` naming the case, and the next read
    starts a new child.  Opening a valid case costs one process start, about
    what the import of VTK costs.

    ``loader(step)`` returns the merged mesh of time step ``step`` (a
    pyvista data set), raising :class:`FormatError` or :class:`DataError`
    naming the case when it cannot be read.

    Parameters
    ----------
    path : Path
        The EnSight ``.case`` file, or an Enzo output's ``.hierarchy``.
    kind : {"ensight", "enzo"}
        What ``path`` is (:data:`CHILD_KINDS`).

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> case = Path(auralize.__file__).parent / "data/ensight-cylinder/cylinder_Re35.case"
    >>> loader = ChildEnSightSteps(case)
    >>> mesh = loader(0)  # the case has no TIME section: one step
    >>> type(mesh).__name__, sorted(mesh.point_data)
    ('UnstructuredGrid', ['pressure', 'velocity', 'vorticity_mag'])
    >>> loader.close()
    """

    def __init__(self, path: Path, kind: Literal["ensight", "enzo"] = "ensight") -> None:
        self.path = path
        self.kind = kind
        self.label = str(path)
        self._lock = threading.Lock()
        self._proc: Any = None
        self._times: list[float] | None = None
        self._finalizer: Any = None

    def _start(self) -> Any:
        import subprocess
        import weakref

        if self._proc is None or self._proc.poll() is not None:
            try:
                self._proc = subprocess.Popen(
                    [sys.executable, "-c", _CHILD_PROGRAM, self.kind, str(self.path)],
                    stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.DEVNULL,
                )
            except OSError as exc:
                raise FormatError(
                    f"{self.path}: cannot start a process to read it ({exc})"
                ) from exc
            if self._finalizer is not None:
                self._finalizer.detach()
            self._finalizer = weakref.finalize(self, _stop_child, self._proc)
        return self._proc

    def close(self) -> None:
        """End the child process (a later read starts a new one).

        Examples
        --------
        >>> from pathlib import Path
        >>> import auralize
        >>> case = Path(auralize.__file__).parent / "data/ensight-cylinder/cylinder_Re35.case"
        >>> loader = ChildEnSightSteps(case)
        >>> loader.close()  # no child started yet: nothing to end
        """
        with self._lock:
            if self._finalizer is not None:
                self._finalizer()
            self._proc = None

    def _ask(self, request: str) -> bytes:
        import struct

        proc = self._start()
        try:
            proc.stdin.write(request.encode() + b"\n")
            proc.stdin.flush()
            head = _read_exact(proc.stdout, 9, self.path)
            body = _read_exact(proc.stdout, struct.unpack(">Q", head[1:])[0], self.path)
        except (OSError, FormatError, struct.error) as exc:
            _stop_child(proc)
            status = proc.poll()
            why = f"exit status {status}" if status else f"{type(exc).__name__}: {exc}"
            if status is not None and status < 0:
                why = f"the reading process crashed with signal {-status}"
            raise FormatError(
                f"{self.path}: VTK's {CHILD_KINDS[self.kind]} reader failed "
                f"({why}); {self._damaged}"
            ) from None
        if head[:1] == b"+":
            return body
        kind, _, message = body.decode("utf-8", "replace").partition("\n")
        if kind == "DataError":
            raise DataError(f"{self.path}: {message.removeprefix(str(self.path) + ': ')}")
        raise FormatError(
            f"{self.path}: VTK's {CHILD_KINDS[self.kind]} reader failed ({message}); "
            f"{self._damaged}"
        )

    @property
    def _damaged(self) -> str:
        if self.kind == "enzo":
            return "the hierarchy, parameter or grid files of the output are truncated or corrupt"
        return "a geometry or variable file of the case is truncated or corrupt"

    def times(self) -> list[float]:
        """The case's time values in seconds (empty for a case without a TIME section).

        Asked of the child process once, then remembered.

        Returns
        -------
        list of float

        Raises
        ------
        FormatError
            The child process cannot read the case (or crashed reading it).

        Examples
        --------
        >>> from pathlib import Path
        >>> import auralize
        >>> case = Path(auralize.__file__).parent / "data/ensight-cylinder/cylinder_Re35.case"
        >>> loader = ChildEnSightSteps(case)
        >>> loader.times()
        []
        >>> loader.close()
        """
        import json

        with self._lock:
            if self._times is None:
                self._times = [float(t) for t in json.loads(self._ask("times"))]
            return list(self._times)

    def __call__(self, step: int) -> Any:
        times = self.times()
        with self._lock:
            request = f"read {times[step]!r}" if times else "read -"
            data = self._ask(request)
        return unmarshal_mesh(data)


def _stop_child(proc: Any) -> None:
    import subprocess

    if proc.poll() is None:
        proc.kill()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:  # pragma: no cover - a kill is not refused
        pass
    for stream in (proc.stdin, proc.stdout):
        try:
            stream.close()
        except OSError:
            pass


def _read_exact(stream: Any, n: int, path: Path) -> bytes:
    """``n`` bytes from the child's stdout, or :class:`FormatError` at EOF or timeout."""
    import select
    import time

    out = bytearray()
    deadline = time.monotonic() + CHILD_TIMEOUT_S
    fd = stream.fileno()
    while len(out) < n:
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            raise FormatError(f"no answer within {CHILD_TIMEOUT_S:g} s")
        chunk = os.read(fd, min(n - len(out), 1 << 20))
        if not chunk:
            raise FormatError("the reading process ended")
        out += chunk
    return bytes(out)


# --------------------------------------------------------------------------- PLOT3D
def _natural_key(p: Path) -> list[object]:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]


def plot3d_files(path: Path) -> tuple[Path, list[Path]]:
    """The grid file and the solution (``.q``) files a PLOT3D path names.

    A grid file (``.xyz``, ``.x``, ``.grd`` or a ``.bin`` whose name
    holds ``xyz``) takes the ``.q`` files beside it that share its name's
    stem (``flow.xyz`` -> ``flow*.q``; ``combxyz.bin`` -> ``combq.bin``), in
    natural order; a ``.q`` file takes the grid beside it.

    Parameters
    ----------
    path : Path
        A grid file or a solution file.

    Returns
    -------
    grid : Path
    solutions : list of Path
        ``[path]`` when ``path`` is a solution.

    Raises
    ------
    FormatError
        A solution without its grid beside it, or a grid without solutions.

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> data = Path(auralize.__file__).parent / "data"
    >>> grid, solutions = plot3d_files(data / "plot3d-combustor/combq.bin")
    >>> grid.name, [q.name for q in solutions]
    ('combxyz.bin', ['combq.bin'])
    """
    folder = path.parent
    suffix = path.suffix.lower()
    name = path.name
    if suffix == ".q" or (suffix == ".bin" and "q" in path.stem.lower() and "xyz" not in name):
        candidates = [folder / (path.stem + s) for s in PLOT3D_GRID_SUFFIXES] + [
            folder / re.sub("q", "xyz", name, count=1, flags=re.I)
        ]
        stem = re.sub(r"[_.-]?\d+$", "", path.stem)
        candidates += [folder / (stem + s) for s in PLOT3D_GRID_SUFFIXES]
        grids = [c for c in candidates if c.is_file() and c != path]
        if not grids:
            raise FormatError(
                f"{path}: a PLOT3D solution file needs its grid file beside it (looked for "
                f"{', '.join(sorted({c.name for c in candidates}))}); open the grid file instead"
            )
        return grids[0], [path]
    if suffix == ".bin":
        q = folder / re.sub("xyz", "q", name, count=1, flags=re.I)
        solutions = [q] if q.is_file() else []
    else:
        solutions = sorted(
            (p for p in folder.glob(f"{path.stem}*") if p.suffix.lower() == ".q"), key=_natural_key
        )
    if not solutions:
        raise FormatError(
            f"{path}: a PLOT3D grid file, but no solution (.q) file was found beside it (looked "
            f"for {path.stem}*.q); PLOT3D needs a grid and at least one .q file"
        )
    return path, solutions


def q_layout(q: Path, dims: tuple[int, int, int]) -> tuple[int, np.dtype[Any]] | None:
    """Where a single-grid PLOT3D solution's data start, and their dtype.

    Tries the common binary layouts — little or big endian, single or double
    precision, with or without Fortran record markers — and accepts the one
    whose size and header dimensions match the grid's.  ``None`` when none
    does (multi-grid, 2-D or otherwise unusual files are left to VTK).

    Parameters
    ----------
    q : Path
        The solution file.
    dims : (int, int, int)
        The grid's points along its i, j, k index directions.

    Returns
    -------
    (offset, dtype) or None
        Byte offset of the first value (density at the first point) and the
        values' dtype; the file holds 5 values per point after it (density,
        3 momentum components, stagnation energy), one variable after another.

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> data = Path(auralize.__file__).parent / "data"
    >>> q = data / "plot3d-combustor/combq.bin"
    >>> q_layout(q, (57, 33, 25))
    (28, dtype('>f4'))
    >>> q_layout(q, (57, 33, 24)) is None
    True
    """
    size = q.stat().st_size
    n = int(np.prod(dims))
    with q.open("rb") as fh:
        head = fh.read(16)
    for endian in "<>":
        for prec in (4, 8):
            for markers in (False, True):
                if markers:
                    offset = (4 + 12 + 4) + (4 + 4 * prec + 4) + 4
                    total = offset + 5 * n * prec + 4
                    first = 4
                else:
                    offset = 12 + 4 * prec
                    total = offset + 5 * n * prec
                    first = 0
                if total != size or len(head) < first + 12:
                    continue
                got = np.frombuffer(head[first : first + 12], dtype=f"{endian}i4")
                if tuple(int(d) for d in got) == tuple(dims):
                    return offset, np.dtype(f"{endian}f{prec}")
    return None


class _Plot3DSteps:
    """Loader over ``.q`` files.

    The grid is read once with VTK; a single-grid solution in a common binary
    layout (:func:`q_layout`) is then read directly (one ``numpy`` read per
    step); any other is read with a fresh VTK reader per step.
    """

    def __init__(self, grid: Path, solutions: list[Path]) -> None:
        self.grid, self.solutions = grid, solutions
        self._mesh: Any = None

    def _vtk(self, q: Path) -> Any:
        pv = import_pyvista()
        reader = pv.MultiBlockPlot3DReader(str(self.grid))
        reader.auto_detect_format = True
        reader.add_q_files([str(q)])
        out = reader.read()
        n_points = sum(b.n_points for b in out if b is not None)
        if n_points == 0:
            raise FormatError(
                f"{q}: VTK's PLOT3D reader returned no data for {self.grid.name} + {q.name}; "
                f"the q file is truncated, corrupt or belongs to another grid"
            )
        # VTK does not check the solution's size: a q file holds 5 variables per point
        # (density, 3 momentum components, energy), 4 or 8 bytes each, plus headers.
        need = 5 * 4 * n_points
        have = q.stat().st_size
        if have < need:
            raise FormatError(
                f"{q}: {have} bytes, but a PLOT3D solution for the grid's {n_points} points "
                f"needs at least {need} (5 variables of 4 bytes); the file is truncated or "
                f"belongs to another grid"
            )
        return out

    def _grid_mesh(self) -> Any:
        if self._mesh is None:
            pv = import_pyvista()
            reader = pv.MultiBlockPlot3DReader(str(self.grid))
            reader.auto_detect_format = True
            blocks = [b for b in reader.read() if b is not None and b.n_points > 0]
            self._mesh = blocks[0] if len(blocks) == 1 else False
        return self._mesh

    def __call__(self, step: int) -> Any:
        q = self.solutions[step]
        mesh = self._grid_mesh()
        layout = None if mesh is False else q_layout(q, tuple(mesh.dimensions))
        if layout is None:
            return self._vtk(q)
        offset, dtype = layout
        n = mesh.n_points
        data = np.fromfile(q, dtype=dtype, offset=offset, count=5 * n)
        if data.size != 5 * n:
            raise FormatError(f"{q}: truncated PLOT3D solution ({data.size} of {5 * n} values)")
        data = data.reshape(5, n).astype(np.float64)
        out = mesh.copy(deep=False)
        out.clear_data()
        out.point_data["Density"] = data[0]
        out.point_data["Momentum"] = np.ascontiguousarray(data[1:4].T)
        out.point_data["StagnationEnergy"] = data[4]
        return out


def read_plot3d(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open a PLOT3D grid plus its ``.q`` solution series as a lazy volume.

    The q file's fields are named as VTK names them: ``Density``,
    ``Momentum`` (vector), ``StagnationEnergy``.  PLOT3D holds no physical
    times: steps are the ``.q`` files in natural order at 30 Hz
    (``physical_times=False``).  A single curvilinear grid keeps its points
    (``TimeVolume.coords``) unless ``curvilinear="resample"`` (or a
    ``resolution``) asks for a uniform grid (:func:`auralize.io.open_volume`);
    other grids are resampled, points outside them no-data.

    Parameters
    ----------
    path : path-like
        A grid file or a ``.q`` solution beside its grid (:func:`plot3d_files`).
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step per ``.q`` file.

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        A solution without its grid, a grid without solutions, a
        truncated or corrupt grid or solution, a solution of another grid.
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
    The combustor shipped with auralize (one solution on a curvilinear grid):

    >>> from pathlib import Path
    >>> import auralize
    >>> data = Path(auralize.__file__).parent / "data"
    >>> vol = read_plot3d(data / "plot3d-combustor/combxyz.bin")
    >>> vol.field_names, vol.dims, vol.curvilinear
    (['Density', 'Momentum', 'StagnationEnergy'], (57, 33, 25), True)
    """
    path = Path(path).expanduser()
    require_exists(path)
    grid, solutions = plot3d_files(path)
    loader = _Plot3DSteps(grid, solutions)
    from auralize.volume import DEFAULT_FRAME_RATE_HZ

    return open_mesh_series(
        source=str(path),
        loader=loader,
        labels=[f"{grid} + {q.name}" for q in solutions],
        times=[n / DEFAULT_FRAME_RATE_HZ for n in range(len(solutions))],
        physical_times=False,
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )


# --------------------------------------------------------------------------- AMR, generic
def read_amr(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open a VTK AMR file (``.vthb``/``.vth``): its boxes are merged and resampled.

    Every level's boxes are read; coarse cells covered by finer boxes are
    blanked by VTK, so the merged mesh samples the finest data available.

    Parameters
    ----------
    path : path-like
        The AMR file (VTK XML ``vtkOverlappingAMR`` or
        ``vtkHierarchicalBoxDataSet``), its blocks beside it.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step at time 0 (``physical_times=False``); cell data are
        interpolated to points (``attrs["centring"]``).

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        A file VTK cannot read, one that holds no boxes.
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
    >>> import tempfile, pathlib, warnings
    >>> from vtkmodules.vtkFiltersAMR import vtkAMRGaussianPulseSource
    >>> from vtkmodules.vtkIOXML import vtkXMLUniformGridAMRWriter
    >>> pulse = vtkAMRGaussianPulseSource()
    >>> pulse.SetDimension(3)
    >>> pulse.SetRootSpacing(0.5)
    >>> _ = pulse.Update()
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "pulse.vthb"
    >>> writer = vtkXMLUniformGridAMRWriter()
    >>> writer.SetFileName(str(f))
    >>> writer.SetInputData(pulse.GetOutput())
    >>> writer.Write()
    1
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")  # a ResampledWarning: the boxes are merged
    ...     vol = read_amr(f)
    >>> vol.field_names, vol.attrs["centring"]["Gaussian-Pulse"]
    (['Centroid', 'Gaussian-Pulse'], 'cell')
    """
    path = Path(path).expanduser()
    require_exists(path)

    def make() -> Any:
        from vtkmodules.vtkIOXML import vtkXMLUniformGridAMRReader

        import_pyvista()

        class _AMR:
            time_values: tuple[float, ...] = ()

            def read(self) -> Any:
                reader = vtkXMLUniformGridAMRReader()
                reader.SetFileName(str(path))
                reader.SetMaximumLevelsToReadByDefault(0)
                reader.Update()
                return amr_leaves(reader.GetOutputDataObject(0), label=str(path))

        return _AMR()

    return _open_reader_series(
        path, make, kind="VTK AMR", fields=fields, resolution=resolution, name_map=name_map
    )


def amr_leaves(amr: Any, *, label: str) -> Any:
    """An AMR data set as a pyvista MultiBlock of its boxes, hidden (refined) cells removed.

    Cells a finer level covers carry the ``HIDDENCELL`` bit in
    ``vtkGhostType``; dropping them leaves every region once, at its finest level.

    Parameters
    ----------
    amr : vtkOverlappingAMR or vtkNonOverlappingAMR
        What VTK's AMR readers return.
    label : str
        The file, for messages.

    Returns
    -------
    pyvista.MultiBlock
        One block per box with cells left: the box itself, or an unstructured
        grid of its visible cells.

    Raises
    ------
    FormatError
        ``amr`` is not an AMR data set, or holds no boxes.

    Examples
    --------
    >>> from vtkmodules.vtkFiltersAMR import vtkAMRGaussianPulseSource
    >>> pulse = vtkAMRGaussianPulseSource()
    >>> pulse.SetDimension(3)
    >>> pulse.SetRootSpacing(0.5)
    >>> _ = pulse.Update()
    >>> amr = pulse.GetOutput()
    >>> amr.GetNumberOfLevels(), amr_leaves(amr, label="pulse").n_blocks
    (2, 3)
    """
    pv = import_pyvista()
    if amr is None or not hasattr(amr, "GetNumberOfLevels"):
        raise FormatError(f"{label}: not an AMR data set")
    hidden = 8  # vtkDataSetAttributes::HIDDENCELL
    blocks = pv.MultiBlock()
    for level in range(amr.GetNumberOfLevels()):
        for index in range(amr_block_count(amr, level)):
            box = amr_block(amr, level, index)
            if box is None:
                continue
            image = pv.ImageData()
            image.ShallowCopy(box)
            ghost = image.cell_data.get("vtkGhostType")
            if ghost is not None:
                keep = (np.asarray(ghost) & hidden) == 0
                if not keep.any():
                    continue
                image.cell_data.remove("vtkGhostType")
                blocks.append(image.extract_cells(np.flatnonzero(keep)))
            else:
                blocks.append(image)
    if len(blocks) == 0:
        raise FormatError(f"{label}: the AMR file holds no boxes")
    return blocks


def read_with_pyvista(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open any file ``pyvista.get_reader`` knows (Exodus, CGNS, FLUENT, Nek5000 ...).

    Time values come from the reader when it has them; meshes are merged and
    resampled like every other mesh.

    Parameters
    ----------
    path : path-like
        A file with one of :func:`pyvista_suffixes`.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step per time value of the reader (s), or one step at 0
        (``physical_times=False``).

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        No reader for the ending, a file the reader cannot read.
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
    >>> img.point_data["density"] = np.arange(24.0)
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "scan.nii"
    >>> from vtkmodules.vtkIOImage import vtkNIFTIImageWriter  # a NIfTI file, as scanners write
    >>> w = vtkNIFTIImageWriter()
    >>> w.SetFileName(str(f)); w.SetInputData(img); w.Write()
    >>> vol = read_with_pyvista(f)
    >>> vol.dims, vol.n_steps, float(np.nanmax(vol.frame(vol.field_names[0], 0)))
    ((4, 3, 2), 1, 23.0)
    """
    path = Path(path).expanduser()
    require_exists(path)

    def make() -> Any:
        pv = import_pyvista()
        return pv.get_reader(str(path))

    return _open_reader_series(
        path,
        make,
        kind=f"a {path.suffix} file",
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )


def pyvista_suffixes() -> tuple[str, ...]:
    """File endings ``pyvista.get_reader`` has a reader for.

    Returns
    -------
    tuple of str
        Lower-case endings with their dot, sorted; empty with a pyvista that
        does not list its readers.

    Examples
    --------
    >>> ".cgns" in pyvista_suffixes(), ".vtu" in pyvista_suffixes()
    (True, True)
    """
    try:
        from pyvista.core.utilities.reader import CLASS_READERS
    except ImportError:  # pragma: no cover - layout of older pyvista
        return ()
    return tuple(sorted(CLASS_READERS))


# --------------------------------------------------------------------------- Enzo
def enzo_hierarchy(path: Path) -> Path | None:
    """The ``.hierarchy`` file of the Enzo output ``path`` belongs to, or ``None``.

    ``path`` may be the hierarchy itself, the output's parameter file
    (``data0010`` beside ``data0010.hierarchy``) or one of its HDF5 grid files
    (``data0010.cpu0000``).

    Parameters
    ----------
    path : Path
        Any path; only names are looked at (and whether the hierarchy exists).

    Returns
    -------
    Path or None
        ``path`` itself when it ends in ``.hierarchy``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (out / "data0010.hierarchy").write_text("Grid = 1")
    >>> enzo_hierarchy(out / "data0010.cpu0003").name, enzo_hierarchy(out / "data0011")
    ('data0010.hierarchy', None)
    """
    name = path.name
    if name.endswith(".hierarchy"):
        return path
    base = re.sub(r"\.cpu\d{4,}$", "", name)
    candidate = path.with_name(base + ".hierarchy")
    return candidate if candidate.is_file() else None


#: keys VTK's Enzo reader looks for in each grid's entry of a hierarchy, in this order:
#: it scans forward for each one in turn, and one missing (or out of order) makes it
#: scan past the end of the file without stopping
ENZO_GRID_KEYS = (
    "GridStartIndex",
    "GridEndIndex",
    "GridLeftEdge",
    "GridRightEdge",
    "BaryonFileName",
    "NumberOfParticles",
)


def _check_enzo_grid_keys(hierarchy: Path, text: str) -> None:
    """Raise :class:`FormatError` unless every grid entry of the hierarchy ``text`` holds
    :data:`ENZO_GRID_KEYS` in order (VTK's reader would never return on it)."""
    starts = [m.start() for m in re.finditer(r"^\s*Grid\s*=\s*\d+", text, flags=re.M)]
    for a, b in zip(starts, [*starts[1:], len(text)], strict=True):
        entry = text[a:b]
        grid = entry.split("=", 1)[1].split()[0]
        at = 0
        for key in ENZO_GRID_KEYS:
            m = re.compile(rf"^\s*{key}\s*=", flags=re.M).search(entry, at)
            if m is None:
                where = (
                    "missing"
                    if re.search(rf"^\s*{key}\s*=", entry, re.M) is None
                    else ("out of order")
                )
                raise FormatError(
                    f"{hierarchy}: grid {grid}'s entry has {key} {where} (an Enzo hierarchy "
                    f"gives each grid {', '.join(ENZO_GRID_KEYS)} in this order); the file is "
                    f"damaged or not written by Enzo"
                )
            at = m.end()


def read_enzo(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open one Enzo AMR output with VTK's Enzo reader: one step, grids merged and resampled.

    ``path`` is the output's ``.hierarchy``, its parameter file or one of its
    ``.cpuNNNN`` grid files.  The grid files the hierarchy names must lie in
    its folder (nothing outside it is read) and be HDF5 files.  VTK reads in a
    child process (:class:`ChildEnSightSteps`), since its Enzo reader ends the
    process on some malformed hierarchies.

    Parameters
    ----------
    path : path-like
        The output's ``.hierarchy``, parameter file or a grid file.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`.

    Returns
    -------
    TimeVolume
        One step at time 0 (``physical_times=False``); cell data are
        interpolated to points.

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        No hierarchy beside ``path``, a hierarchy without ``Grid = 1``
        and a ``BaryonFileName``, a missing parameter file, grid files that are
        missing, not HDF5 or outside the folder, a reader that fails or crashes.
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
    An output of one 8³ grid on the unit cube:

    >>> import tempfile, pathlib, h5py, numpy as np
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> with h5py.File(out / "data0001.cpu0000", "w") as f:
    ...     f["Grid00000001/Density"] = np.arange(512.0, dtype=np.float32).reshape(8, 8, 8)
    >>> _ = (out / "data0001").write_text(
    ...     "InitialTime = 0.5\\nTopGridRank = 3\\nTopGridDimensions = 8 8 8\\n"
    ...     "DomainLeftEdge = 0 0 0\\nDomainRightEdge = 1 1 1\\nDataLabel[0] = Density\\n")
    >>> _ = (out / "data0001.hierarchy").write_text(
    ...     "\\nGrid = 1\\nTask = 0\\nGridRank = 3\\nGridDimension = 8 8 8\\n"
    ...     "GridStartIndex = 0 0 0\\nGridEndIndex = 7 7 7\\nGridLeftEdge = 0 0 0\\n"
    ...     "GridRightEdge = 1 1 1\\nTime = 0.5\\nSubgridsAreStatic = 0\\n"
    ...     "NumberOfBaryonFields = 1\\nFieldType = 0\\nBaryonFileName = data0001.cpu0000\\n"
    ...     "CourantSafetyNumber = 0.3\\nPPMFlatteningParameter = 0\\nPPMDiffusionParameter = 0\\n"
    ...     "PPMSteepeningParameter = 0\\nNumberOfParticles = 0\\nGravityBoundaryType = 0\\n"
    ...     "Pointer: Grid[1]->NextGridThisLevel = 0\\nPointer: Grid[1]->NextGridNextLevel = 0\\n")
    >>> vol = read_enzo(out / "data0001.hierarchy")
    >>> vol.field_names, vol.n_steps, float(np.nanmax(vol.frame("Density", 0)))
    (['Density'], 1, 511.0)
    """
    import h5py

    path = Path(path).expanduser()
    require_exists(path)
    hierarchy = enzo_hierarchy(path)
    if hierarchy is None:
        raise FormatError(
            f"{path}: an Enzo output needs its .hierarchy file beside it "
            f"({path.with_name(re.sub(r'[.]cpu[0-9]+$', '', path.name) + '.hierarchy').name})"
        )
    try:
        text = hierarchy.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise FormatError(f"{hierarchy}: cannot read ({exc})") from exc
    grids = re.findall(r"^\s*BaryonFileName\s*=\s*(\S+)", text, flags=re.M)
    if not re.search(r"^\s*Grid\s*=\s*1\b", text, flags=re.M) or not grids:
        raise FormatError(
            f"{hierarchy}: not an Enzo hierarchy (no 'Grid = 1' with a BaryonFileName)"
        )
    _check_enzo_grid_keys(hierarchy, text)
    parameters = hierarchy.with_name(hierarchy.name.removesuffix(".hierarchy"))
    if not parameters.is_file():
        raise FormatError(f"{hierarchy}: the Enzo parameter file {parameters.name} is missing")
    folder = hierarchy.parent.resolve()
    for name in sorted(set(grids)):
        grid = folder / Path(name).name  # VTK reads grid files from the hierarchy's folder
        if not grid.is_file() or not h5py.is_hdf5(str(grid)):
            raise FormatError(
                f"{hierarchy}: the grid file {grid.name} it names is missing or not HDF5"
            )
    return _child_series(
        path,
        ChildEnSightSteps(hierarchy, kind="enzo"),
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )
