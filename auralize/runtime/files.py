"""Safe file output: atomic writes, paired files, ParaView collections, stale temporaries.

Rules every writer in auralize follows (see the README, "Output files"):

* Output folders are never created: a missing folder, a folder given as the
  output file, or a parent that is a file is refused up front with an
  :class:`~auralize.errors.OutputError` naming the path.
* A file is written to a hidden temporary beside the target, named
  ``.NAME.<pid>-<hex>...``, and renamed onto ``NAME`` when complete, so bad
  input or a crash never leaves a partial output file behind.  Temporaries
  left by a process that no longer runs (killed) are removed by the next
  write of the same target (:func:`clean_stale`).
* A file and its sidecar (``OUT.wav`` and ``OUT.wav.json``) are written as a
  pair (:func:`write_pair`): the sidecar records the file's SHA-256, and a
  pair interrupted between its two renames is completed by the next write.
* A ``.pvd`` collection's data folder is written under a fresh name, marked
  as auralize's own (:data:`DATA_MARKER`), and the ``.pvd`` is replaced
  atomically to point at it; only then is the old folder removed, and only if
  auralize wrote it (:func:`write_collection`).
* A write that fails stops there: the first failed write raises, the
  temporary is removed, and the error is an :class:`~auralize.errors.OutputError`
  naming the output (not the temporary) on one line, e.g. ``cannot write
  'out.h5': No space left on device (about 38 MiB needed, 12 KiB free)``
  (:func:`output_error`; the CLI prints the same line and exits 4).  HDF5
  files are written through :func:`atomic_hdf5`, which also leaves the HDF5
  library in a sound state after a full disk.
"""

from __future__ import annotations

import contextlib
import csv
import errno
import hashlib
import io
import json
import logging
import math
import os
import re
import shutil
import sys
import uuid
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import NDArray

from auralize.errors import OutputError, OutputExistsError

#: name of the file that marks a data folder as written by auralize
DATA_MARKER = ".auralize-data.json"


# ----------------------------------------------------------------- failed writes
#: errno values that say the output's disk (or quota) cannot take the file
DISK_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS)


def raised_in_hdf5(exc: BaseException) -> bool:
    """Whether ``exc`` was raised by h5py (its traceback passes through the package)."""
    tb = exc.__traceback__
    while tb is not None:
        if f"{os.sep}h5py{os.sep}" in tb.tb_frame.f_code.co_filename:
            return True
        tb = tb.tb_next
    return False


def write_errno(exc: BaseException) -> int | None:
    """The OS error number behind a failed write: ``exc.errno``, or the ``errno = N``
    that HDF5 puts in the messages of its failed writes."""
    number = getattr(exc, "errno", None)
    if isinstance(number, int) and number > 0:
        return number
    m = re.search(r"errno = (\d+)", str(exc))
    return int(m.group(1)) if m else None


def is_disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` says that a disk (or quota) is full or read-only (:data:`DISK_ERRNOS`)."""
    return write_errno(exc) in DISK_ERRNOS


def output_error(
    exc: BaseException, target: str | os.PathLike[str], *, nbytes: float | None = None
) -> OutputError:
    """The one-line :class:`~auralize.errors.OutputError` of a failed write of ``target``.

    Parameters
    ----------
    exc : the error raised by the write (an :class:`OSError`, or h5py's error).
    target : the output file (named in the message instead of its temporary).
    nbytes : about how many bytes the whole file needs, when known.

    Examples
    --------
    >>> import errno
    >>> str(output_error(OSError(errno.ENOSPC, "No space left on device"), "o.h5", nbytes=2**20))[:48]
    "cannot write 'o.h5': No space left on device (ab"
    """
    if isinstance(exc, OutputError):
        return exc
    number = write_errno(exc)
    if number is not None and number in errno.errorcode:
        why = os.strerror(number)
    elif isinstance(exc, OSError) and exc.strerror:
        why = str(exc.strerror)
    else:
        why = " ".join(str(exc).split("(", 1)[0].split()) or type(exc).__name__
    extra = []
    if number in (errno.ENOSPC, errno.EDQUOT):
        from auralize.runtime.resources import format_bytes

        if nbytes is not None and math.isfinite(nbytes):
            extra.append(f"about {format_bytes(nbytes)} needed")
        folder = Path(target).expanduser().parent
        with contextlib.suppress(OSError):
            extra.append(f"{format_bytes(shutil.disk_usage(str(folder) or '.').free)} free")
    tail = f" ({', '.join(extra)})" if extra else ""
    return OutputError(f"cannot write {str(target)!r}: {why}{tail}")


def _as_output_error(
    exc: BaseException, target: Path, tmp: Path | None, nbytes: float | None
) -> BaseException:
    """``exc`` as :func:`output_error` when it is a failure to write ``target`` (a full
    disk, or an OS error about the temporary ``tmp``), else ``exc`` itself."""
    if isinstance(exc, OutputError) or not isinstance(exc, OSError | RuntimeError):
        return exc
    if isinstance(exc, OSError) and (exc.filename or exc.filename2) and not is_disk_full(exc):
        named = {str(f) for f in (exc.filename, exc.filename2) if f}
        if not named & {str(target), str(tmp)}:
            return exc  # an input that cannot be read: not the output's fault
    elif not is_disk_full(exc) and (tmp is None or str(tmp) not in str(exc)):
        return exc
    return output_error(exc, target, nbytes=nbytes)


# ----------------------------------------------------------------- output paths
def check_output_path(path: str | Path, *, folder: bool = False) -> Path:
    """Check that ``path`` can be written as an output; return it as a :class:`Path`.

    Parameters
    ----------
    path : output file (or, with ``folder=True``, an output folder to create).
    folder : bool
        The output is a folder: it may exist already (as a folder).

    Raises
    ------
    OutputError
        The parent folder is missing or is a file, ``path`` is an existing
        folder (for a file output) or file (for a folder output), or the parent
        folder is not writable.
    """
    p = Path(path).expanduser()
    if not str(path).strip():
        raise OutputError("the output path is empty; give a file name")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.exists():
        raise OutputError(
            f"cannot write {str(p)!r}: the folder {str(parent)!r} does not exist "
            f"(auralize does not create folders for outputs; create it first)"
        )
    if not parent.is_dir():
        raise OutputError(f"cannot write {str(p)!r}: {str(parent)!r} is a file, not a folder")
    if folder:
        if p.exists() and not p.is_dir():
            raise OutputError(f"cannot use {str(p)!r} as the output folder: it is a file")
    elif p.is_dir():
        raise OutputError(f"cannot write {str(p)!r}: it is a folder; give a file name")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write {str(p)!r}: no permission to write in {str(parent)!r}")
    return p


# ----------------------------------------------------------------- temporaries
_TEMP_RE = r"\.(\d+)-[0-9a-f]{12}"


def temp_name(target: Path, *, suffix: str = ".part") -> Path:
    """A fresh hidden name beside ``target``: ``.NAME.<pid>-<hex><suffix>``.

    The process id in the name lets :func:`clean_stale` tell the temporaries of
    a process that was killed from those of one still writing.
    """
    return target.with_name(f".{target.name}.{os.getpid()}-{uuid.uuid4().hex[:12]}{suffix}")


def pid_alive(pid: int) -> bool:
    """Whether a process with id ``pid`` runs on this machine."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except (OverflowError, ValueError):
        return False
    return True


def _stale_temps(target: Path) -> Iterator[Path]:
    pattern = re.compile(re.escape(f".{target.name}") + _TEMP_RE + r"(\.[A-Za-z0-9.]*)?$")
    try:
        names = os.listdir(target.parent if str(target.parent) else ".")
    except OSError:
        return
    for name in names:
        m = pattern.match(name)
        if m and not pid_alive(int(m.group(1))):
            yield target.with_name(name)


def clean_stale(target: str | Path) -> list[Path]:
    """Remove temporaries of ``target`` left by processes that no longer run.

    Returns the paths removed.  Pending sidecars of a pair are left to
    :func:`recover_pair`, which completes or discards them.
    """
    t = Path(target)
    removed = []
    for p in _stale_temps(t):
        if p.name.endswith(".pending"):
            continue
        with contextlib.suppress(OSError):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()
            removed.append(p)
    return removed


def _finish_file(tmp: Path) -> None:
    """Give a finished temporary the usual permissions and flush it to disk."""
    os.chmod(tmp, 0o666 & ~_umask())
    fd = os.open(tmp, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(path: str | Path, *, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched.
    The target is checked first (:func:`check_output_path`): its folder must
    exist.  A failed write of the temporary raises
    :class:`~auralize.errors.OutputError` naming ``path`` (:func:`output_error`),
    also one that a library only reported without raising (h5py reports the
    writes that fail while it closes a file that way; write HDF5 files with
    :func:`atomic_hdf5`, which sees them in time).
    """
    target = check_output_path(path)
    clean_stale(target)
    tmp_path = temp_name(target, suffix=suffix if suffix is not None else target.suffix + ".part")
    try:
        tmp_path.touch(mode=0o600, exist_ok=False)
        with _unreported_failures(tmp_path) as failures:
            yield tmp_path
        if failures:  # a library reported a failed write of the temporary but did not raise
            raise failures[0]
        _finish_file(tmp_path)
        os.replace(tmp_path, target)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        err = _as_output_error(exc, target, tmp_path, None)
        if err is exc:
            raise
        raise err from exc


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


@contextlib.contextmanager
def _unreported_failures(tmp: Path) -> Iterator[list[BaseException]]:
    """Collect the errors about ``tmp`` that are reported without being raised (an
    object freed after a failed write: :data:`sys.unraisablehook`), instead of
    printing them; the list is filled when the block ends."""
    seen: list[BaseException] = []
    previous, previous_except = sys.unraisablehook, sys.excepthook

    def hook(unraisable: Any) -> None:
        exc = getattr(unraisable, "exc_value", None)
        if isinstance(exc, BaseException) and str(tmp) in str(exc):
            seen.append(exc)
        else:
            previous(unraisable)

    def excepthook(kind: Any, exc: Any, tb: Any) -> None:  # Cython prints them this way too
        if isinstance(exc, BaseException) and str(tmp) in str(exc):
            seen.append(exc)
        else:
            previous_except(kind, exc, tb)

    sys.unraisablehook, sys.excepthook = hook, excepthook
    try:
        yield seen
    finally:
        if sys.unraisablehook is hook:
            sys.unraisablehook = previous
        if sys.excepthook is excepthook:
            sys.excepthook = previous_except


class _Sink:
    """The file object HDF5 writes an output through (h5py's ``fileobj`` driver).

    A write the OS refuses (a full disk) is recorded, not passed on: HDF5 is told
    it succeeded and later writes are dropped, so the library never meets a
    failed write (after one it can crash the process when its objects are
    freed).  The writer asks :func:`stop_if_failed` after each step and
    :func:`atomic_hdf5` raises the recorded error as an
    :class:`~auralize.errors.OutputError`; the temporary is removed.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.raw = open(path, "x+b")  # closed by close()
        self.failed: OSError | None = None
        self.written = 0

    def _fail(self, exc: OSError) -> None:
        if self.failed is None:
            self.failed = exc

    def write(self, data: Any) -> int:
        view = memoryview(data).cast("B")
        if self.failed is None:
            try:
                done = 0
                while done < len(view):
                    done += self.raw.write(view[done:]) or 0
                self.written += done
            except OSError as exc:
                self._fail(exc)
        return len(view)

    def read(self, size: int = -1) -> bytes:
        data = self.raw.read(size)
        if self.failed is not None and size > 0 and len(data) < size:
            data += bytes(size - len(data))  # what a dropped write would have held
        return data

    def seek(self, offset: int, whence: int = 0) -> int:
        return self.raw.seek(offset, whence)

    def tell(self) -> int:
        return self.raw.tell()

    def truncate(self, size: int | None = None) -> int:
        if self.failed is None:
            try:
                return self.raw.truncate(size)
            except OSError as exc:
                self._fail(exc)
        return self.raw.tell() if size is None else size

    def flush(self) -> None:
        if self.failed is None:
            try:
                self.raw.flush()
            except OSError as exc:
                self._fail(exc)

    def close(self) -> None:
        if self.raw.closed:  # closed once already (an error after the close is handled)
            return
        try:
            self.flush()
        finally:
            with contextlib.suppress(OSError):
                self.raw.close()


def _sink_of(f: Any) -> _Sink | None:
    sink = getattr(f, "_auralize_sink", None)
    return sink if isinstance(sink, _Sink) else None


def stop_if_failed(f: Any) -> None:
    """Raise the error of the first failed write of an :func:`atomic_hdf5` file, if any.

    Writers call it after each step (each chunk written), so that a full disk
    ends them at once instead of at the end of the file; the error raised (an
    :class:`OSError` with the OS's error number) becomes the
    :class:`~auralize.errors.OutputError` of :func:`atomic_hdf5`.
    """
    sink = _sink_of(f)
    if sink is not None and sink.failed is not None:
        raise sink.failed


@contextlib.contextmanager
def atomic_hdf5(
    path: str | os.PathLike[str],
    *,
    suffix: str = ".part.h5",
    nbytes: float | None = None,
    what: str = "the file",
    **file_options: Any,
) -> Iterator[Any]:
    """Yield an :class:`h5py.File` open for writing on a temporary beside ``path``; rename
    it onto ``path`` when the block ends without error.

    Parameters
    ----------
    path : the output file; its folder must exist (:func:`check_output_path`).
    suffix : str
        Suffix of the temporary.
    nbytes : float, optional
        About how many bytes the file needs: refused up front (before HDF5 writes
        anything) if its disk has less free (:func:`~auralize.runtime.resources.require_disk`),
        and said in the error of a disk that fills up during the write.
    what : str
        What the file holds, for that refusal (e.g. ``"10 steps of 2 field(s)"``).
    **file_options
        Passed to :class:`h5py.File` (e.g. ``rdcc_nbytes=0``: no chunk cache, so
        that every chunk goes to disk when it is written).

    Raises
    ------
    OutputError
        The folder cannot be written, the disk has too little space, or a write
        failed (a full disk, a quota, an I/O error): one line naming ``path``.
        The temporary is removed; ``path`` is untouched.  Any other error raised
        inside the block (bad data) passes through unchanged, also after
        removing the temporary.

    Notes
    -----
    HDF5 writes through a file object that records a refused write instead of
    failing it (:class:`_Sink`): the library never sees a failed write, so a
    full disk cannot leave it in a state that crashes the process, and nothing
    of it reaches stderr.  Call :func:`stop_if_failed` after each step to end
    at the first failed write.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> with atomic_hdf5(pathlib.Path(tempfile.mkdtemp()) / "a.h5") as f:
    ...     f["x"] = np.arange(3)
    """
    import h5py

    target = check_output_path(path)
    if nbytes is not None:
        from auralize.runtime.resources import require_disk

        require_disk(target, nbytes, what)
    clean_stale(target)
    tmp = temp_name(target, suffix=suffix)
    sink: _Sink | None = None
    f = None
    try:
        sink = _Sink(tmp)
        f = h5py.File(sink, "w", **file_options)
        f._auralize_sink = sink
        yield f
        stop_if_failed(f)
        f.close()
        sink.close()
        if sink.failed is not None:
            raise sink.failed
        _finish_file(tmp)
        os.replace(tmp, target)
    except BaseException as exc:
        failed = sink.failed if sink is not None else None
        if f is not None:
            with contextlib.suppress(Exception):
                f.close()
        if sink is not None:
            sink.close()
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        if failed is not None and not isinstance(exc, OutputError):
            exc = failed  # the refused write, whatever HDF5 made of the data it did not get
        err = _as_output_error(exc, target, tmp, nbytes)
        if err is exc and exc is failed:
            err = output_error(exc, target, nbytes=nbytes)
        if err is exc:
            raise
        raise err from exc


def temp_sibling(path: Path, *, suffix: str = ".tmp") -> Path:
    """A fresh hidden name next to ``path`` for writing before an atomic rename.

    The name ``.NAME.<pid>-<hex><suffix>`` carries the writer's process id;
    temporaries of ``path`` left by processes that no longer run are removed
    first (:func:`clean_stale`).
    """
    clean_stale(path)
    return temp_name(path, suffix=suffix)


def fsync_path(path: Path) -> None:
    """Flush a written file (or directory entry) to disk; best effort."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):  # some filesystems cannot fsync a directory
            os.fsync(fd)
    finally:
        os.close(fd)


# ----------------------------------------------------------------- paired files
def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def recover_pair(main: str | Path, sidecar: str | Path) -> None:
    """Complete or discard a pair write that a killed process left half done.

    A pending sidecar (``.SIDECAR.<pid>-<hex>.pending``) of a process that no
    longer runs is renamed onto ``sidecar`` if ``main`` holds the bytes it
    describes (the process died between the two renames), else removed.
    """
    m, s = Path(main), Path(sidecar)
    clean_stale(m)
    for pending in _stale_temps(s):
        if not pending.name.endswith(".pending"):
            with contextlib.suppress(OSError):
                pending.unlink()
            continue
        try:
            digest = json.loads(pending.read_text()).get("sha256")
            done = m.is_file() and digest == file_sha256(m)
        except (OSError, ValueError, AttributeError):
            done = False
        with contextlib.suppress(OSError):
            if done:
                os.replace(pending, s)
            else:
                pending.unlink()


def write_pair(
    main: str | Path,
    write_main: Callable[[Path], None],
    sidecar: str | Path,
    sidecar_bytes: Callable[[str], bytes],
    *,
    suffix: str = ".part",
) -> None:
    """Write ``main`` and its ``sidecar`` so that both change or neither does.

    Parameters
    ----------
    main, sidecar : the two output paths (e.g. ``OUT.wav`` and ``OUT.wav.json``).
    write_main : callable
        Writes the main file's content to the temporary path it is given.
    sidecar_bytes : callable
        Given the main file's SHA-256 (hex), returns the sidecar's bytes; the
        sidecar should record it so that a reader can check the pair.
    suffix : str
        Suffix of the main file's temporary (writers that choose a format from
        the extension need it, e.g. ``".part.flac"``).

    Notes
    -----
    Both files are complete on disk before either is renamed into place; the
    main file is renamed first, then the sidecar.  A process killed between
    the two renames leaves a pending sidecar that :func:`recover_pair`
    (called by the next write of the same pair) renames into place.
    """
    m = check_output_path(main)
    s = check_output_path(sidecar)
    recover_pair(m, s)
    tmp_main = temp_name(m, suffix=suffix)
    tmp_side = temp_name(s, suffix=".pending")
    swapped = False
    try:
        tmp_main.touch(mode=0o600, exist_ok=False)
        write_main(tmp_main)
        _finish_file(tmp_main)
        tmp_side.write_bytes(sidecar_bytes(file_sha256(tmp_main)))
        _finish_file(tmp_side)
        os.replace(tmp_main, m)
        swapped = True
        os.replace(tmp_side, s)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp_main.unlink()
        if not swapped:  # after the first rename the pending sidecar completes the pair later
            with contextlib.suppress(FileNotFoundError):
                tmp_side.unlink()
        err = _as_output_error(exc, m, tmp_main, None)
        if err is exc:
            err = _as_output_error(exc, s, tmp_side, None)
        if err is exc:
            raise
        raise err from exc


# ----------------------------------------------------------------- ParaView collections
def collection_folders(pvd: Path) -> set[str]:
    """Names of the folders (beside ``pvd``) that an existing ``.pvd`` refers to."""
    try:
        root = ET.parse(pvd).getroot()
    except (OSError, ET.ParseError):
        return set()
    out = set()
    for entry in root.iter("DataSet"):
        parts = Path(entry.get("file") or "").parts
        if len(parts) > 1 and parts[0] not in (".", ".."):
            out.add(parts[0])
    return out


def _marker(folder: Path) -> dict[str, object] | None:
    try:
        data = json.loads((folder / DATA_MARKER).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("written_by") == "auralize" else None


def _marker_pid(mark: dict[str, object] | None) -> int:
    value = mark.get("pid") if mark is not None else None
    return value if isinstance(value, int) else 0


def _owned(folder: Path, pvd: Path, referenced: set[str]) -> bool:
    """Whether auralize wrote ``folder`` for ``pvd``: it carries the marker of this
    collection, or (folders written before the marker) it holds nothing but
    files the existing ``.pvd`` lists."""
    mark = _marker(folder)
    if mark is not None:
        return mark.get("collection") == pvd.name
    if folder.name not in referenced:
        return False
    try:
        root = ET.parse(pvd).getroot()
        listed = {Path(e.get("file") or "").name for e in root.iter("DataSet")}
        return all(p.is_file() and p.name in listed for p in folder.iterdir())
    except (OSError, ET.ParseError):
        return False


def write_collection(
    pvd: str | Path, data_name: str, write_steps: Callable[[Path], list[tuple[float, str]]]
) -> Path:
    """Write a ParaView ``.pvd`` collection and its data folder, atomically.

    Parameters
    ----------
    pvd : the ``.pvd`` file to write (replaced if it exists).
    data_name : str
        Base name of the data folder beside it, e.g. ``"run_data"``.
    write_steps : callable
        Given the (new, empty) data folder, writes one file per step into it and
        returns ``[(time in s, file name), ...]`` in step order.

    Returns
    -------
    Path
        The data folder the new ``.pvd`` refers to: ``data_name`` if it was
        free, else ``data_name.1``, ``data_name.2`` ... (the first free name).

    Raises
    ------
    OutputError
        ``data_name`` exists and auralize did not write it for this ``.pvd``
        (it is never replaced or deleted).

    Notes
    -----
    The new folder is marked (:data:`DATA_MARKER`) and filled, then a new
    ``.pvd`` pointing at it replaces the old one in one rename; the old folder
    is removed afterwards, and only if it is auralize's.  A kill at any point
    leaves the old or the new collection complete; folders of killed writers
    are removed by the next write of the same ``.pvd`` (folders the ``.pvd``
    does not list whose writer is this process or no longer runs).
    """
    path = check_output_path(pvd)
    clean_stale(path)
    clean_stale(path.with_name(data_name))
    referenced = collection_folders(path) if path.is_file() else set()
    base = path.with_name(data_name)
    if (base.exists() or base.is_symlink()) and (
        base.is_symlink() or not base.is_dir() or not _owned(base, path, referenced)
    ):
        what = (
            "is not a folder"
            if base.is_symlink() or not base.is_dir()
            else "was not written by auralize"
        )
        held = "" if what == "is not a folder" else _first_item(base)
        raise OutputExistsError(
            f"cannot write {str(path)!r}: {str(base)!r} exists and {what}{held}; auralize does not "
            f"replace it (move it away or choose another output name)"
        )
    siblings = [base] + sorted(path.parent.glob(f"{_glob_escape(data_name)}.[0-9]*"))
    for folder in siblings:  # folders of writers killed before or after the swap
        mark = _marker(folder) if folder.is_dir() and not folder.is_symlink() else None
        pid = _marker_pid(mark)
        if (
            mark is not None
            and mark.get("collection") == path.name
            and folder.name not in referenced
            and (pid == os.getpid() or not pid_alive(pid))
        ):
            _discard(folder, base)
    n = 0
    new = base
    while new.exists() or new.is_symlink():
        n += 1
        new = path.with_name(f"{data_name}.{n}")
    tmp_pvd = temp_name(path)
    tmp_dir = temp_name(base)
    try:
        # the folder appears under its name already marked, so a kill never leaves
        # an unmarked folder that would look like the user's
        os.mkdir(tmp_dir)  # the usual permissions (umask), not mkdtemp's 0700
        (tmp_dir / DATA_MARKER).write_text(
            json.dumps({"written_by": "auralize", "collection": path.name, "pid": os.getpid()})
        )
        os.rename(tmp_dir, new)
        with _vtk_quiet():
            entries = write_steps(new)
        lines = [
            '<?xml version="1.0"?>',
            '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
            "  <Collection>",
            *(
                f'    <DataSet timestep={quoteattr(repr(float(t)))} group="" part="0" '
                f"file={quoteattr(f'{new.name}/{name}')}/>"
                for t, name in entries
            ),
            "  </Collection>",
            "</VTKFile>",
            "",
        ]
        for f in new.iterdir():
            _finish_file(f)
        tmp_pvd.write_text("\n".join(lines), encoding="utf-8")
        _finish_file(tmp_pvd)
        os.replace(tmp_pvd, path)
    except BaseException as exc:
        if _marker_pid(_marker(new)) == os.getpid():
            _discard(new, base)
        shutil.rmtree(tmp_dir, ignore_errors=True)
        tmp_pvd.unlink(missing_ok=True)
        err = _as_output_error(exc, path, tmp_pvd, None)
        if err is exc:
            raise
        raise err from exc
    for name in referenced - {new.name}:
        old = path.with_name(name)
        if old.is_dir() and not old.is_symlink() and _owned(old, path, referenced):
            _discard(old, base)
    return new


class _DropVTK(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return "vtk" not in record.getMessage().lower()


@contextlib.contextmanager
def _vtk_quiet() -> Iterator[None]:
    """Keep VTK's own reports of a failed write (a full disk) off stderr: the error raised
    (an :class:`OSError` from the write) is what the user sees, on one line."""
    import pyvista as pv

    root = logging.getLogger()
    drop = _DropVTK()
    root.addFilter(drop)
    try:
        with pv.vtk_verbosity("off"):
            yield
    finally:
        root.removeFilter(drop)


def _discard(folder: Path, base: Path) -> None:
    """Remove a data folder: first renamed to a hidden temporary of ``base`` (one atomic
    step, so a kill never leaves a half-emptied folder under a visible name), then deleted."""
    gone = temp_name(base, suffix=".old")
    try:
        os.rename(folder, gone)
    except OSError:
        return
    shutil.rmtree(gone, ignore_errors=True)


def _first_item(folder: Path) -> str:
    try:
        items = sorted(p.name for p in folder.iterdir())
    except OSError:
        return ""
    return f" (it holds {items[0]!r})" if items else " (it is empty)"


def _glob_escape(name: str) -> str:
    import glob

    return glob.escape(name)


def read_timed_csv(
    path: str | Path, *, what: str, optional: list[str], rows_name: str = "captures"
) -> tuple[NDArray[np.float64], bool, str]:
    """Read a numeric CSV whose header starts ``t,x,y,z`` and may go on with ``optional``.

    Returns ``(rows as a flat table (n, 4 or 4 + len(optional)), has_optional,
    source name)``; malformed files raise :class:`~auralize.errors.FormatError`
    naming the file, line and what was expected.  Used for listener paths and
    object motions.
    """
    from auralize.errors import FormatError

    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise FormatError(f"{what} file {str(p)!r} does not exist") from None
    except UnicodeDecodeError:
        raise FormatError(f"{p}: not a text CSV file") from None
    except IsADirectoryError:
        raise FormatError(f"{what} file {str(p)!r} is a folder, not a CSV file") from None
    except OSError as exc:
        raise FormatError(f"{what} file {str(p)!r} cannot be read ({exc.strerror})") from None
    reader = csv.reader(io.StringIO(text))
    want = "t,x,y,z" + "".join("," + c for c in optional)
    try:
        header = [h.strip().lower() for h in next(reader)]
    except StopIteration:
        raise FormatError(f"{p}: empty file; expected a header '{want}'") from None
    if header[:4] != ["t", "x", "y", "z"]:
        raise FormatError(
            f"{p}: header must start with 't,x,y,z' (optional {','.join(optional)}); "
            f"got {','.join(header)!r}"
        )
    has_opt = bool(optional) and header[4 : 4 + len(optional)] == optional
    ncol = 4 + (len(optional) if has_opt else 0)
    rows = []
    for lineno, row in enumerate(reader, start=2):
        if not row or all(not c.strip() for c in row):
            continue
        try:
            vals = [float(c) for c in row[:ncol]]
        except ValueError:
            raise FormatError(f"{p}, line {lineno}: not a number in {row!r}") from None
        if len(vals) != ncol:
            raise FormatError(f"{p}, line {lineno}: expected {ncol} columns, got {len(row)}")
        bad = [c for c, v in zip(row, vals, strict=False) if not math.isfinite(v)]
        if bad:
            raise FormatError(f"{p}, line {lineno}: {bad[0].strip()!r} is not a finite number")
        rows.append(vals)
    if not rows:
        raise FormatError(f"{p}: no {rows_name} after the header")
    return np.asarray(rows, dtype=np.float64), has_opt, str(p)
