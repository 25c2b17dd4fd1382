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
from typing import Any

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
    return _mesh_series(path, loader, times, fields=fields, resolution=resolution,
                        name_map=name_map)  # fmt: skip


def _mesh_series(path: Path, loader: Any, times: list[float], *, fields: FieldsArg,
                 resolution: ResolutionArg, name_map: Mapping[str, str] | None) -> TimeVolume:  # fmt: skip
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

    return _child_series(path, ChildEnSightSteps(path), fields=fields, resolution=resolution,
                         name_map=name_map)  # fmt: skip


def _child_series(path: Path, loader: ChildEnSightSteps, *, fields: FieldsArg,
                  resolution: ResolutionArg, name_map: Mapping[str, str] | None) -> TimeVolume:  # fmt: skip
    """The lazy volume of the steps a child process reads (the child ends if opening fails)."""
    try:
        times = loader.times()
    except BaseException:
        loader.close()
        raise
    return _mesh_series(path, loader, times, fields=fields, resolution=resolution,
                        name_map=name_map)  # fmt: skip


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


def serve_child(kind: str, path: str) -> None:
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
_MESH_CLASSES = ("vtkUnstructuredGrid", "vtkPolyData", "vtkStructuredGrid",
                 "vtkRectilinearGrid", "vtkImageData")  # fmt: skip


def marshal_mesh(mesh: Any) -> bytes:
    """``mesh`` as bytes for another process: a JSON header line, then VTK's marshalled form.

    VTK's marshalling (its legacy binary format) keeps every array exactly but
    writes an image's origin, spacing and direction as text of 6 digits, so
    the header carries them in full.  No pickle crosses processes.
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
    """The mesh :func:`marshal_mesh` turned into ``data``."""
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
    """

    def __init__(self, path: Path, kind: str = "ensight") -> None:
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
        """End the child process (a later read starts a new one)."""
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
            raise FormatError(f"{self.path}: VTK's {CHILD_KINDS[self.kind]} reader failed "
                              f"({why}); {self._damaged}") from None  # fmt: skip
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
        """The case's time values in seconds (empty for a case without a TIME section)."""
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
    (``physical_times=False``).  The curvilinear grid is resampled onto a
    uniform grid; points outside it are no-data.
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
    """File endings ``pyvista.get_reader`` has a reader for."""
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
    """
    name = path.name
    if name.endswith(".hierarchy"):
        return path
    base = re.sub(r"\.cpu\d{4,}$", "", name)
    candidate = path.with_name(base + ".hierarchy")
    return candidate if candidate.is_file() else None


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
    return _child_series(path, ChildEnSightSteps(hierarchy, kind="enzo"), fields=fields,
                         resolution=resolution, name_map=name_map)  # fmt: skip
