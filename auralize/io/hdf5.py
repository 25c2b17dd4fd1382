"""HDF5 volume files: the auralize format v1 and arbitrary HDF5 datasets.

Format v1 (see docs/design.md): root attributes ``auralize_format="volume"`` and
``version=1``; ``/time`` float64 ``(T,)`` strictly increasing seconds; group
``/grid`` with attributes ``origin`` and ``spacing`` ``(3,)`` in metres;
``/fields/<name>`` of shape ``(T, nz, ny, nx)`` or ``(T, nz, ny, nx, 3)``.  A
dataset attribute ``axes="txyz"`` means ``(T, nx, ny, nz[, 3])``; frames of
such datasets are transposed on read.  The writer also stores the optional
root attribute ``physical_times`` (bool) and ``/grid`` attribute ``dims``
``(nx, ny, nz)``; readers do not require them.  Optional: ``/valid`` bool
``(nz, ny, nx)``, True where the grid point lies inside the input mesh
(:attr:`TimeVolume.valid <auralize.volume.TimeVolume.valid>`; absent: all
valid), and a ``units`` attribute on a field dataset.  NaN in a field is
no-data.

Frames are read lazily: :class:`HDF5Frames` holds only the file name and the
dataset path and opens the file for each :meth:`~HDF5Frames.read`, so a volume
stays usable after the reader returns and is cheap to pickle.  Nothing here
unpickles data; object and string datasets are refused.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import KW_ONLY, dataclass
from pathlib import Path
from typing import Any, Literal, cast

import h5py
import numpy as np
from numpy.typing import NDArray

from auralize.errors import (
    AuralizeError,
    DataError,
    FieldError,
    FormatError,
    ParameterError,
)
from auralize.io._common import FieldsArg, require_exists, select_fields
from auralize.runtime.files import atomic_hdf5, stop_if_failed
from auralize.runtime.hdf5safe import allow_external_data as allow_external_data
from auralize.runtime.hdf5safe import check_self_contained as check_self_contained
from auralize.runtime.hdf5safe import external_data_allowed as external_data_allowed
from auralize.runtime.hdf5safe import refused_external as refused_external
from auralize.runtime.resources import require_memory
from auralize.volume import DEFAULT_FRAME_RATE_HZ, FrameSource, TimeVolume

#: Value of the root attribute ``auralize_format`` of a volume file.
FORMAT_NAME = "volume"
#: The format version this module reads and writes.
FORMAT_VERSION = 1
#: Keys of a generic ``fields=`` mapping that name grid and time data, not fields.
GENERIC_META_KEYS = ("time", "origin", "spacing")

_AXES_ORDERS = ("tzyx", "txyz")

HDF5Kind = Literal["auralize", "vtkhdf", "netcdf4", "generic"]
#: Storage order of a field dataset (attribute ``axes``).
AxesOrder = Literal["tzyx", "txyz"]


def _h5_error(path: Path, exc: BaseException) -> FormatError:
    text = " ".join(str(exc).split())
    return FormatError(
        f"{path}: cannot read as HDF5 ({type(exc).__name__}: {text}); the file may be corrupt, "
        f"truncated, or hold broken or looping links"
    )


@dataclass
class HDF5Frames:
    """One field of an HDF5 file, read one time step per :meth:`read`.

    Parameters
    ----------
    filename : str
        The HDF5 file; opened read-only for every read.
    dataset : str
        Absolute path of the dataset in the file.
    n_steps : int
        Number of time steps (the dataset's first dimension).
    frame_shape : tuple of int
        ``(nz, ny, nx)`` or ``(nz, ny, nx, 3)``, the shape :meth:`read` returns.
    axes : {"tzyx", "txyz"}
        Storage order: ``"txyz"`` datasets are transposed on read.

    Examples
    --------
    >>> import h5py, numpy as np, tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "p.h5"
    >>> with h5py.File(f, "w") as h:
    ...     h["run/p"] = np.zeros((3, 4, 5, 6))  # (T, nz, ny, nx)
    >>> frames = HDF5Frames(str(f), "/run/p", n_steps=3, frame_shape=(4, 5, 6))
    >>> frames.read(2).shape
    (4, 5, 6)
    """

    filename: str
    dataset: str
    _: KW_ONLY
    n_steps: int
    frame_shape: tuple[int, ...]
    axes: AxesOrder = "tzyx"

    def read(self, step: int) -> NDArray[np.float64]:
        """Read time step ``step`` as a new float64 array of shape ``frame_shape``.

        The file is opened for this read only.

        Parameters
        ----------
        step : int
            Time step, 0 to ``n_steps - 1``.

        Returns
        -------
        ndarray, shape frame_shape
            ``(nz, ny, nx)`` or ``(nz, ny, nx, 3)`` float64, whatever the
            dataset's storage order and type.

        Raises
        ------
        FormatError
            The dataset reads other files (external or virtual data, unless
            allowed: :func:`allow_external_data`), the file cannot be read, or
            the step's shape changed since the file was opened.

        Examples
        --------
        >>> import h5py, numpy as np, tempfile, pathlib
        >>> f = pathlib.Path(tempfile.mkdtemp()) / "p.h5"
        >>> raw = np.arange(2 * 4 * 3 * 2.0).reshape(2, 4, 3, 2)  # (T, nx, ny, nz)
        >>> with h5py.File(f, "w") as h:
        ...     h["p"] = raw
        >>> frames = HDF5Frames(str(f), "/p", n_steps=2, frame_shape=(2, 3, 4), axes="txyz")
        >>> frame = frames.read(1)  # (nz, ny, nx)
        >>> frame.shape, bool(frame[1, 2, 3] == raw[1, 3, 2, 1])
        ((2, 3, 4), True)
        """
        try:
            with h5py.File(self.filename, "r") as f:
                ds = f[self.dataset]
                if not external_data_allowed() and (ds.external or ds.is_virtual):
                    raise FormatError(
                        f"{self.filename}: dataset {self.dataset!r} reads data from other files; "
                        f"refused (give --allow-external if you trust the file)"
                    )
                raw = ds[step]
        except FormatError:
            raise
        except (OSError, KeyError, ValueError, RuntimeError, TypeError) as exc:
            raise FormatError(
                f"{self.filename}: cannot read step {step} of dataset {self.dataset!r} "
                f"({exc}); the file may be truncated, corrupt or changed since it was opened"
            ) from exc
        arr = np.asarray(raw, dtype=np.float64)
        if self.axes == "txyz":
            arr = np.ascontiguousarray(arr.transpose(2, 1, 0, *range(3, arr.ndim)))
        if arr.shape != self.frame_shape:
            raise FormatError(
                f"{self.filename}: step {step} of {self.dataset!r} has shape {arr.shape}, "
                f"expected {self.frame_shape}; the file changed since it was opened"
            )
        return arr


# --------------------------------------------------------------------------- sniffing
def sniff(path: Path) -> HDF5Kind:
    """Tell an auralize volume file from a VTKHDF file and other HDF5 files.

    Parameters
    ----------
    path : Path
        An HDF5 file.

    Returns
    -------
    {"auralize", "vtkhdf", "netcdf4", "generic"}
        ``"vtkhdf"`` with a ``/VTKHDF`` group, ``"auralize"`` with the root
        attribute ``auralize_format``, ``"netcdf4"`` with ``_NCProperties`` or
        dimension scales at the root, else ``"generic"``.

    Raises
    ------
    FormatError
        If ``path`` is not a readable HDF5 file (corrupt, truncated, other kind).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from auralize.volume import TimeVolume
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "v.h5"
    >>> write_hdf5(TimeVolume.from_arrays({"p": np.zeros((1, 2, 2, 2))}, times=[0.0]), f)
    >>> sniff(f)
    'auralize'
    """
    try:
        is_hdf5 = h5py.is_hdf5(str(path))
    except OSError as exc:
        raise FormatError(f"{path}: cannot read the file ({exc})") from exc
    if not is_hdf5:
        raise FormatError(
            f"{path}: not an HDF5 file (no HDF5 signature); the file is corrupt, truncated "
            f"or of another kind"
        )
    try:
        with h5py.File(path, "r") as f:
            if "VTKHDF" in f:
                return "vtkhdf"
            if "auralize_format" in f.attrs:
                return "auralize"
            if "_NCProperties" in f.attrs or any(
                isinstance(obj, h5py.Dataset) and "DIMENSION_LIST" in obj.attrs
                for obj in f.values()
            ):
                return "netcdf4"
            return "generic"
    except (KeyError, ValueError, RuntimeError, TypeError) as exc:
        raise _h5_error(path, exc) from exc
    except OSError as exc:
        raise FormatError(
            f"{path}: cannot open as HDF5 ({exc}); the file may be corrupt or truncated"
        ) from exc


def wants_generic(kind: HDF5Kind, fields: FieldsArg) -> bool:
    """Whether ``fields=`` asks for datasets by path rather than v1 field names.

    Parameters
    ----------
    kind : {"auralize", "vtkhdf", "netcdf4", "generic"}
        What :func:`sniff` says of the file.
    fields : None, str, sequence of str or mapping
        The ``fields=`` of :func:`auralize.io.open_volume`.

    Returns
    -------
    bool
        True for a mapping, unless the file is an auralize volume file and the
        mapping names no dataset path (``"/..."``) and none of the keys
        ``"time"``, ``"origin"``, ``"spacing"``.

    Examples
    --------
    >>> wants_generic("auralize", {"density": "rho"}), wants_generic("auralize", {"rho": "/f/rho"})
    (False, True)
    >>> wants_generic("generic", ["rho"])
    False
    """
    if not isinstance(fields, Mapping):
        return False
    if kind != "auralize":
        return True
    return any(k in GENERIC_META_KEYS for k in fields) or any(
        isinstance(v, str) and v.startswith("/") for v in fields.values()
    )


# --------------------------------------------------------------------------- attributes
def _attr_str(value: object) -> str:
    if isinstance(value, np.ndarray) and value.size == 1:
        value = value.reshape(()).item()
    if isinstance(value, bytes | np.bytes_):
        return bytes(value).decode("utf-8", "replace")
    return str(value)


def _attr_vec3(value: object, *, path: Path, what: str) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.size == 1:
        arr = np.repeat(arr, 3)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise FormatError(f"{path}: {what} must be 3 finite numbers (x, y, z); got {value!r}")
    return arr


def _field_frames(path: Path, ds: object, label: str, *, n_times: int | None) -> HDF5Frames:
    if not isinstance(ds, h5py.Dataset):
        raise FormatError(f"{path}: {label} is a group, not a dataset")
    if ds.dtype.kind not in "fiu":
        raise DataError(
            f"{path}: {label} ({ds.name}) has dtype {ds.dtype}; a field needs integer or "
            f"floating-point numbers"
        )
    axes = _attr_str(ds.attrs.get("axes", "tzyx")).lower()
    if axes not in _AXES_ORDERS:
        raise FormatError(
            f"{path}: {label} ({ds.name}) has axes={axes!r}; valid values are 'tzyx' "
            f"(the default, shape (T, nz, ny, nx[, 3])) and 'txyz' (shape (T, nx, ny, nz[, 3]))"
        )
    shape = tuple(int(s) for s in ds.shape)
    order = "(T, nz, ny, nx)" if axes == "tzyx" else "(T, nx, ny, nz)"
    if len(shape) not in (4, 5) or (len(shape) == 5 and shape[-1] != 3) or min(shape) < 1:
        raise DataError(
            f"{path}: {label} ({ds.name}) has shape {shape}; a field needs {order} (scalar) "
            f"or {order[:-1]}, 3) (vector) with axes={axes!r}"
        )
    if n_times is not None and shape[0] != n_times:
        raise DataError(
            f"{path}: {label} ({ds.name}) has {shape[0]} time steps but /time has {n_times}"
        )
    frame_shape = shape[1:] if axes == "tzyx" else (shape[3], shape[2], shape[1], *shape[4:])
    return HDF5Frames(
        filename=str(path),
        dataset=str(ds.name),
        n_steps=shape[0],
        frame_shape=frame_shape,
        axes=cast(AxesOrder, axes),
    )


# --------------------------------------------------------------------------- v1 reader
def read_hdf5(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open an auralize HDF5 volume file (format v1) lazily.

    Parameters
    ----------
    path : path-like
        The ``.h5`` file.
    fields : None, str, sequence of str or mapping, optional
        Fields to open (default all); a mapping ``{volume name: name in /fields}``
        also renames.
    name_map : mapping, optional
        ``{name in the file: volume name}`` renames.

    Returns
    -------
    TimeVolume
        Fields are :class:`HDF5Frames`; no frame is read yet.

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not a volume file, wrong version, missing ``/time`` or ``/grid`` data.
    ParameterError
        Bad ``fields=`` or ``name_map=``.
    ResourceError
        ``/time`` is larger than the memory available.
    FieldError
        A requested field is not in ``/fields``.
    DataError
        Bad shapes, times not strictly increasing, mismatched fields.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.zeros((2, 3, 4, 5))}, times=[0.0, 0.1])
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "v.h5"
    >>> write_hdf5(vol, f)
    >>> read_hdf5(f).dims
    (5, 4, 3)
    """
    path = Path(path).expanduser()
    require_exists(path)
    try:
        with h5py.File(path, "r") as f:
            check_self_contained(f, path)
            return _read_v1(path, f, fields=fields, name_map=name_map)
    except AuralizeError:
        raise
    except (OSError, KeyError, ValueError, RuntimeError, TypeError) as exc:
        raise _h5_error(path, exc) from exc


def _read_v1(
    path: Path, f: h5py.File, *, fields: FieldsArg, name_map: Mapping[str, str] | None
) -> TimeVolume:
    if "auralize_format" not in f.attrs:
        raise FormatError(
            f"{path}: root attribute 'auralize_format' is missing; an auralize volume file "
            f"has auralize_format='volume' and version=1 (for other HDF5 files pass "
            f"fields={{'name': '/path/to/dataset'}})"
        )
    fmt = _attr_str(f.attrs["auralize_format"])
    if fmt != FORMAT_NAME:
        raise FormatError(
            f"{path}: root attribute auralize_format={fmt!r}; a volume file needs "
            f"auralize_format={FORMAT_NAME!r}"
        )
    if "version" not in f.attrs:
        raise FormatError(
            f"{path}: root attribute 'version' is missing; this auralize reads volume "
            f"format version {FORMAT_VERSION}"
        )
    raw_version = f.attrs["version"]
    ver = np.asarray(raw_version).reshape(-1)
    if not (ver.size == 1 and ver.dtype.kind in "iuf" and float(ver[0]) == FORMAT_VERSION):
        raise FormatError(
            f"{path}: volume format version {_attr_str(raw_version)!r} is not supported; "
            f"this auralize reads version {FORMAT_VERSION}"
        )
    if "time" not in f or not isinstance(f["time"], h5py.Dataset):
        raise FormatError(f"{path}: dataset /time (float64, shape (T,), seconds) is missing")
    tds = f["time"]
    if tds.ndim != 1 or tds.dtype.kind not in "fiu" or tds.shape[0] < 1:
        raise FormatError(
            f"{path}: /time must be a 1-D array of numbers (T,); got shape {tds.shape}, "
            f"dtype {tds.dtype}"
        )
    require_memory(8.0 * tds.shape[0], f"{path}: {tds.shape[0]} time steps")
    times = np.asarray(tds[()], dtype=np.float64)
    if "grid" not in f or not isinstance(f["grid"], h5py.Group):
        raise FormatError(
            f"{path}: group /grid (attributes origin and spacing, 3 numbers each) is missing"
        )
    grid = f["grid"]
    for key in ("origin", "spacing"):
        if key not in grid.attrs:
            raise FormatError(
                f"{path}: attribute /grid.{key} is missing; it must be 3 numbers (x, y, z) in metres"
            )
    origin = _attr_vec3(grid.attrs["origin"], path=path, what="/grid.origin")
    spacing = _attr_vec3(grid.attrs["spacing"], path=path, what="/grid.spacing")
    if "fields" not in f or not isinstance(f["fields"], h5py.Group):
        raise FormatError(f"{path}: group /fields is missing")
    group = f["fields"]
    available = [k for k in group if isinstance(group[k], h5py.Dataset)]
    chosen = select_fields(available, fields, name_map, source=str(path))
    frames: dict[str, FrameSource] = {
        name: _field_frames(path, group[stored], f"field {name!r}", n_times=times.size)
        for name, stored in chosen.items()
    }
    nz, ny, nx = next(iter(frames.values())).frame_shape[:3]
    physical = True
    if "physical_times" in f.attrs:
        physical = bool(np.asarray(f.attrs["physical_times"]).reshape(-1)[0])
    valid = None
    if "valid" in f:
        obj = f["valid"]
        if not isinstance(obj, h5py.Dataset) or obj.shape != (nz, ny, nx):
            raise FormatError(
                f"{path}: /valid must be a boolean dataset of shape {(nz, ny, nx)} (the "
                f"fields' grid); got {getattr(obj, 'shape', type(obj).__name__)}"
            )
        valid = np.asarray(obj[()]).astype(bool)
    units = {
        name: _attr_str(group[stored].attrs["units"])
        for name, stored in chosen.items()
        if "units" in group[stored].attrs
    }
    volume = TimeVolume(
        origin=origin,
        spacing=spacing,
        dims=(nx, ny, nz),
        times=times,
        fields=frames,
        physical_times=physical,
        source=str(path),
        valid=valid,
    )
    if units:
        volume.attrs["units"] = units
    return volume


# --------------------------------------------------------------------------- generic reader
def read_generic_hdf5(
    path: str | os.PathLike[str],
    spec: Mapping[str, object],
    *,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open named datasets of an arbitrary HDF5 file as a volume, lazily.

    Parameters
    ----------
    path : path-like
        Any HDF5 file.
    spec : mapping
        ``{field name: dataset path}`` for each field; datasets are
        ``(T, nz, ny, nx)`` or ``(T, nz, ny, nx, 3)`` (or ``(T, nx, ny, nz[, 3])``
        with attribute ``axes="txyz"``).  The optional keys ``"time"``,
        ``"origin"`` and ``"spacing"`` give the grid and times, each as a
        dataset path, an attribute reference ``"/object@attribute"`` or a
        literal value.
    name_map : mapping, optional
        ``{field name: new name}`` renames.

    Returns
    -------
    TimeVolume
        Fields are :class:`HDF5Frames`; no frame is read yet.  Grid and times
        as the Notes say.

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not a readable HDF5 file, a field path that names a group, a dataset
        with bad ``axes``, data in other files (unless allowed).
    FieldError
        A dataset or attribute that ``spec`` names is not in the file.
    DataError
        A dataset that is not shaped like a field or holds no numbers, fields
        with different step counts, as many times as steps missing.
    ParameterError
        ``spec`` names no field dataset, or an entry is not ``{name: path}``.

    Notes
    -----
    Without the optional keys, ``time``/``times``, ``origin`` and ``spacing``
    are looked up as attributes of the first field's dataset, then of
    ``/grid`` (origin, spacing), then of the root group, then a ``/time``
    dataset of length T.  Missing values default to origin 0, spacing 1 m and
    frames at :data:`~auralize.volume.DEFAULT_FRAME_RATE_HZ` with
    ``physical_times=False``.

    Examples
    --------
    >>> import h5py, numpy as np, tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "sim.h5"
    >>> with h5py.File(f, "w") as h:
    ...     h["run/rho"] = np.ones((4, 2, 3, 5))
    >>> vol = read_generic_hdf5(f, {"density": "/run/rho", "spacing": 0.1})
    >>> vol.dims, vol.physical_times, vol.spacing.tolist()
    ((5, 3, 2), False, [0.1, 0.1, 0.1])
    """
    path = Path(path).expanduser()
    require_exists(path)
    try:
        with h5py.File(path, "r") as f:
            check_self_contained(f, path)
            return _read_generic(path, f, spec, name_map=name_map)
    except AuralizeError:
        raise
    except (OSError, KeyError, ValueError, RuntimeError, TypeError) as exc:
        raise _h5_error(path, exc) from exc


def field_candidates(f: h5py.File, *, limit: int = 12) -> list[str]:
    """Paths of datasets in ``f`` shaped like fields (4-D, or 5-D with 3 components).

    Parameters
    ----------
    f : h5py.File
        An open HDF5 file (or group); every object in it is visited.
    limit : int
        Most paths returned.

    Returns
    -------
    list of str
        Absolute dataset paths, in HDF5's visiting order (by name).

    Examples
    --------
    >>> import h5py, numpy as np, tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "sim.h5"
    >>> with h5py.File(f, "w") as h:
    ...     h["run/rho"] = np.zeros((2, 3, 3, 3))
    ...     h["run/u"] = np.zeros((2, 3, 3, 3, 3))
    ...     h["run/t"] = np.zeros(2)
    ...     field_candidates(h)
    ['/run/rho', '/run/u']
    """
    found: list[str] = []

    def visit(name: str, obj: object) -> None:
        if (
            isinstance(obj, h5py.Dataset)
            and obj.dtype.kind in "fiu"
            and (obj.ndim == 4 or (obj.ndim == 5 and obj.shape[-1] == 3))
        ):
            found.append("/" + name)

    f.visititems(visit)
    return found[:limit]


def _meta_value(f: h5py.File, value: object, *, path: Path, key: str) -> NDArray[np.float64]:
    if isinstance(value, str):
        if "@" in value:
            obj_path, attr = value.rsplit("@", 1)
            obj_path = obj_path or "/"
            if obj_path not in f or attr not in f[obj_path].attrs:
                raise FieldError(f"{path}: {key}={value!r}: no attribute {attr!r} on {obj_path!r}")
            raw = f[obj_path].attrs[attr]
        else:
            if value not in f or not isinstance(f[value], h5py.Dataset):
                raise FieldError(f"{path}: {key}={value!r}: no such dataset in the file")
            raw = f[value][()]
    else:
        raw = value
    try:
        return np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError):
        raise DataError(f"{path}: {key} must be numbers; got {raw!r}") from None


def _read_generic(
    path: Path, f: h5py.File, spec: Mapping[str, object], *, name_map: Mapping[str, str] | None
) -> TimeVolume:
    field_spec = {k: v for k, v in spec.items() if k not in GENERIC_META_KEYS}
    if not field_spec:
        raise ParameterError(
            f"{path}: fields={dict(spec)!r} names no field datasets; give "
            f"{{'name': '/path/to/dataset'}} for at least one field"
        )
    frames: dict[str, FrameSource] = {}
    for name, dpath in field_spec.items():
        if not isinstance(name, str) or not isinstance(dpath, str) or not dpath:
            raise ParameterError(
                f"{path}: fields= entries must be {{field name: dataset path}}; got "
                f"{name!r}: {dpath!r}"
            )
        if dpath not in f:
            cands = field_candidates(f)
            raise FieldError(
                f"{path}: no dataset {dpath!r} for field {name!r}; datasets that could be "
                f"fields: {', '.join(cands) or '(none)'}"
            )
        frames[name] = _field_frames(path, f[dpath], f"field {name!r}", n_times=None)
    first = f[next(iter(field_spec.values()))]
    n_steps = next(iter(frames.values())).n_steps

    def lookup(key: str, attr_names: tuple[str, ...], groups: tuple[str, ...]) -> object:
        if key in spec:
            return _meta_value(f, spec[key], path=path, key=key)
        for obj in (first, *(f[g] for g in groups if g in f)):
            for a in attr_names:
                if a in obj.attrs:
                    return _meta_value(f, obj.attrs[a], path=path, key=key)
        return None

    origin = lookup("origin", ("origin",), ("/grid", "/"))
    spacing = lookup("spacing", ("spacing",), ("/grid", "/"))
    times = lookup("time", ("time", "times"), ("/",))
    if times is None and "time" in f and isinstance(f["time"], h5py.Dataset):
        if f["time"].shape == (n_steps,) and f["time"].dtype.kind in "fiu":
            require_memory(8.0 * n_steps, f"{path}: {n_steps} time steps")
            times = np.asarray(f["time"][()], dtype=np.float64)
    physical = times is not None
    if times is None:
        times = np.arange(n_steps) / DEFAULT_FRAME_RATE_HZ
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if t.size != n_steps:
        raise DataError(
            f"{path}: {t.size} times for {n_steps} time steps; the time array must have "
            f"one entry per step"
        )
    for name, fr in frames.items():
        if fr.n_steps != n_steps:
            raise DataError(
                f"{path}: field {name!r} has {fr.n_steps} time steps but field "
                f"{next(iter(frames))!r} has {n_steps}"
            )
    nz, ny, nx = next(iter(frames.values())).frame_shape[:3]
    if name_map:
        renamed = select_fields(list(frames), None, name_map, source=str(path))
        frames = {new: frames[old] for new, old in renamed.items()}
    return TimeVolume(
        origin=_attr_vec3(0.0 if origin is None else origin, path=path, what="origin"),
        spacing=_attr_vec3(1.0 if spacing is None else spacing, path=path, what="spacing"),
        dims=(nx, ny, nz),
        times=t,
        fields=frames,
        physical_times=physical,
        source=str(path),
    )


# --------------------------------------------------------------------------- writer
def write_hdf5(
    volume: TimeVolume,
    path: str | os.PathLike[str],
    *,
    compression: Literal["gzip"] | None = None,
    compression_level: int = 4,
) -> None:
    """Write ``volume`` as an auralize HDF5 volume file (format v1), atomically.

    Frames are read one step at a time and written into chunks of one time
    step each, into a hidden temporary file next to ``path`` that is renamed
    over ``path`` only when complete; on any error no file is left behind.

    Parameters
    ----------
    volume : TimeVolume
        The volume (NaN values in frames are no-data; ``volume.frame`` checks finiteness
        when ``volume.check_finite``); ``volume.valid`` is written as ``/valid``.
    path : path-like
        Output ``.h5`` file; replaced if it exists.
    compression : {None, "gzip"}
        Compress each chunk with gzip (and the shuffle filter).
    compression_level : int
        gzip level 0–9.

    Raises
    ------
    ParameterError
        ``compression`` or ``compression_level`` is not valid.
    DataError
        A field name cannot name an HDF5 dataset (empty, ``/``), or a frame
        holds NaN/Inf at a valid point of a volume that checks
        (``check_finite``); nothing is left behind.
    OutputError
        The folder cannot be written, the disk has less free space than the
        uncompressed file needs (refused before writing), or a write failed:
        the first failed write ends it, and nothing is left behind
        (:func:`~auralize.runtime.files.atomic_hdf5`).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.zeros((2, 3, 4, 5))}, times=[0.0, 0.1])
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "v.h5"
    >>> write_hdf5(vol, out, compression="gzip")
    >>> read_hdf5(out).times.tolist()
    [0.0, 0.1]
    """
    path = Path(path).expanduser()
    if compression not in (None, "gzip"):
        raise ParameterError(f"{path}: compression={compression!r}; valid are None and 'gzip'")
    if not isinstance(compression_level, int) or not 0 <= compression_level <= 9:
        raise ParameterError(
            f"{path}: compression_level={compression_level!r}; valid are integers 0 to 9"
        )
    for name in volume.field_names:
        if not name or "/" in name or name in (".", ".."):
            raise DataError(
                f"{path}: field name {name!r} cannot be an HDF5 dataset name; use a "
                f"non-empty name without '/'"
            )
    n_steps = int(volume.n_steps)
    data_bytes = sum(
        n_steps * float(np.prod(volume.fields[n].frame_shape)) * 8 for n in volume.field_names
    )
    opts: dict[str, Any] = {}
    file_options: dict[str, Any] = {}
    if compression == "gzip":
        opts = {"compression": "gzip", "compression_opts": compression_level, "shuffle": True}
    else:
        file_options["rdcc_nbytes"] = 0  # no chunk cache: each step reaches disk when written
    with atomic_hdf5(
        path,
        nbytes=None if compression else data_bytes + 16.0 * n_steps + 65536,
        what=f"{n_steps} steps of {len(volume.field_names)} field(s)",
        **file_options,
    ) as f:
        f.attrs["auralize_format"] = FORMAT_NAME
        f.attrs["version"] = np.int64(FORMAT_VERSION)
        f.attrs["physical_times"] = bool(volume.physical_times)
        tds = f.create_dataset("time", data=np.asarray(volume.times, dtype=np.float64))
        tds.attrs["units"] = "s"
        grid = f.create_group("grid")
        grid.attrs["origin"] = np.asarray(volume.origin, dtype=np.float64)
        grid.attrs["spacing"] = np.asarray(volume.spacing, dtype=np.float64)
        grid.attrs["dims"] = np.asarray(volume.dims, dtype=np.int64)
        if volume.valid is not None:
            f.create_dataset("valid", data=np.asarray(volume.valid, dtype=bool))
        units = volume.attrs.get("units")
        units = units if isinstance(units, dict) else {}
        group = f.create_group("fields", track_order=True)
        for name in volume.field_names:
            shape = tuple(volume.fields[name].frame_shape)
            ds = group.create_dataset(
                name,
                shape=(n_steps, *shape),
                dtype=np.float64,
                chunks=(1, *shape),
                **opts,
            )
            if isinstance(units.get(name), str) and units[name]:
                ds.attrs["units"] = units[name]
            for step in range(n_steps):
                ds[step] = volume.frame(name, step)
                stop_if_failed(f)  # a full disk ends the writer at this step
