"""netCDF files (classic CDF-1/2 and netCDF4/HDF5) with CF conventions.

Read lazily, one time step per read: classic files with
:class:`scipy.io.netcdf_file` (memory-mapped), netCDF4 files with h5py (a
netCDF4 file is an HDF5 file whose dimensions are HDF5 dimension scales).
Like every HDF5 file, a netCDF4 file that reads data from other files
(external links, external raw storage, virtual datasets) is refused unless
:func:`~auralize.io.hdf5.allow_external_data` allows it.
Both libraries are dependencies already, so reading netCDF needs nothing more.

CF conventions honoured
-----------------------
- The time axis is the coordinate whose ``axis`` is ``T``, whose
  ``standard_name`` is ``time``, or which is named ``time``/``t``; its
  ``units`` (``"days since 2001-01-01"``, ``"hours since ..."``, ``"s"``)
  are converted to seconds after the reference date (UDUNITS lengths: a
  month is 1/12 of a 365.242198781-day year).  A file without a time axis
  is a single step (``physical_times=False``).
- ``scale_factor``/``add_offset`` are applied; ``_FillValue``,
  ``missing_value`` and values outside ``valid_min``/``valid_max``/
  ``valid_range`` become NaN (no-data).
- Spatial axes are the variable's dimensions after time, in CF order
  (Z, Y, X: the last is x); their coordinate variables give the grid
  (metres, or whatever ``units`` says: degrees of longitude/latitude stay
  degrees).  Decreasing coordinates are flipped; unevenly spaced ones are
  resampled onto a uniform grid.  Dimensions without a coordinate variable
  are index coordinates 0, 1, 2 ...
- Variables ``u``, ``v`` (and ``w``), or those whose ``standard_name`` is
  ``eastward_*``/``northward_*``/``upward_*``, also form a vector field
  ``velocity``.
"""

from __future__ import annotations

import contextlib
import os
import re
import threading
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, FormatError
from auralize.io._common import FieldsArg, require_exists, select_fields
from auralize.io._mesh import import_pyvista, open_mesh_series
from auralize.io.resample import ResolutionArg, check_resolution, resample_uniform
from auralize.volume import CallableFrames, FrameSource, TimeVolume

NETCDF_SUFFIXES = (".nc", ".nc4", ".cdf", ".netcdf")

#: Seconds per CF/UDUNITS time unit.
_TIME_UNITS = {
    "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0,
    "ms": 1e-3, "millisecond": 1e-3, "milliseconds": 1e-3,
    "us": 1e-6, "microsecond": 1e-6, "microseconds": 1e-6,
    "min": 60.0, "mins": 60.0, "minute": 60.0, "minutes": 60.0,
    "h": 3600.0, "hr": 3600.0, "hrs": 3600.0, "hour": 3600.0, "hours": 3600.0,
    "d": 86400.0, "day": 86400.0, "days": 86400.0,
    "week": 604800.0, "weeks": 604800.0,
    "year": 365.242198781 * 86400.0, "years": 365.242198781 * 86400.0,
    "month": 365.242198781 * 86400.0 / 12, "months": 365.242198781 * 86400.0 / 12,
}  # fmt: skip


def time_unit_seconds(units: str, *, source: str) -> tuple[float, str | None]:
    """Seconds per unit of a CF time ``units`` string, and its reference date.

    Examples
    --------
    >>> time_unit_seconds("days since 2001-01-01", source="x.nc")
    (86400.0, '2001-01-01')
    >>> time_unit_seconds("s", source="x.nc")
    (1.0, None)
    """
    text = units.strip()
    m = re.match(r"^\s*([A-Za-z]+)\s*(?:since\s+(.+))?$", text)
    factor = _TIME_UNITS.get(m.group(1).lower()) if m else None
    if m is None or factor is None:
        raise FormatError(
            f"{source}: time units {units!r} are not understood; use CF units such as "
            f"'seconds since 2001-01-01' or 'days since 2001-01-01 00:00:00' (units: "
            f"{', '.join(sorted({'seconds', 'minutes', 'hours', 'days', 'weeks', 'months'}))})"
        )
    return factor, (m.group(2).strip() if m.group(2) else None)


def _text(value: object) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "SU" and value.size:
            return _text(value.reshape(-1)[0] if value.size == 1 else b"".join(value.tolist()))
        if value.dtype.kind == "O" and value.size:
            return _text(value.reshape(-1)[0])
    return str(value)


# --------------------------------------------------------------------------- backends
@dataclass
class _Var:
    """One variable: name, dimension names, attributes, and a slicer."""

    name: str
    dims: tuple[str, ...]
    attrs: dict[str, Any]
    shape: tuple[int, ...]
    dtype: np.dtype[Any]
    reader: Any  # reader(index) -> ndarray copy

    def read(self, index: tuple[Any, ...] = ()) -> NDArray[Any]:
        return np.asarray(self.reader(index))


class _Backend:
    """An open netCDF file: its variables (thread-safe reads)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.lock = threading.Lock()
        with path.open("rb") as fh:
            magic = fh.read(8)
        self.kind: str
        if magic[:3] == b"CDF":
            if magic[3:4] not in (b"\x01", b"\x02"):
                raise FormatError(
                    f"{path}: netCDF CDF-{magic[3]} (64-bit data) is not supported; convert it "
                    f"with 'nccopy -k nc4 {path.name} out.nc'"
                )
            self.kind = "classic"
            with self._classic() as f:
                self.vars = self._classic_vars(f)
        elif magic[:8] == b"\x89HDF\r\n\x1a\n":
            self.kind = "netCDF4"
            import h5py

            from auralize.io.hdf5 import check_self_contained

            try:
                self._file = h5py.File(path, "r")
            except OSError as exc:
                raise FormatError(
                    f"{path}: cannot read as netCDF4/HDF5 ({exc}); the file may be truncated"
                ) from exc
            try:
                check_self_contained(self._file, path)
                self.vars = self._h5_vars(self._file)
            except BaseException as exc:
                self._file.close()
                if isinstance(exc, OSError):
                    raise FormatError(
                        f"{path}: cannot read as netCDF4/HDF5 ({exc}); the file may be truncated"
                    ) from exc
                raise
        else:
            raise FormatError(
                f"{path}: not a netCDF file (it starts with neither 'CDF' nor the HDF5 "
                f"signature); the file may be truncated or of another kind"
            )

    @contextlib.contextmanager
    def _classic(self) -> Iterator[Any]:
        """The classic file, memory-mapped, closed cleanly (every view dropped first)."""
        from scipy.io import netcdf_file

        try:
            f = netcdf_file(str(self.path), "r", mmap=True, maskandscale=False)
        except Exception as exc:  # scipy raises ValueError/TypeError/OSError on bad files
            raise FormatError(
                f"{self.path}: cannot read as netCDF classic ({type(exc).__name__}: {exc}); the "
                f"file may be truncated"
            ) from exc
        try:
            yield f
        finally:
            f.variables.clear()
            f.close()

    def _classic_vars(self, f: Any) -> dict[str, _Var]:
        return {
            name: _Var(name, tuple(v.dimensions), dict(v._attributes), tuple(v.shape),
                       np.dtype(v.data.dtype), self._classic_reader(name))
            for name, v in f.variables.items()
        }  # fmt: skip

    def _classic_reader(self, name: str) -> Any:
        def read(index: tuple[Any, ...]) -> NDArray[Any]:
            with self.lock, self._classic() as f:
                data = f.variables[name].data
                try:
                    out = np.array(data[index] if index else data, copy=True)
                except (ValueError, IndexError, TypeError) as exc:
                    raise FormatError(
                        f"{self.path}: cannot read {name!r} ({exc}); the file may be truncated"
                    ) from exc
                del data
            return out

        return read

    @staticmethod
    def _h5_vars(f: Any) -> dict[str, _Var]:
        import h5py

        out: dict[str, _Var] = {}
        for name, ds in f.items():
            if not isinstance(ds, h5py.Dataset):
                continue
            attrs = {k: v for k, v in ds.attrs.items() if k not in ("DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME", "_Netcdf4Dimid", "_Netcdf4Coordinates", "_NCProperties")}  # fmt: skip
            is_bare_dim = _text(ds.attrs.get("NAME", "")).startswith(
                "This is a netCDF dimension but not a netCDF variable"
            )
            if is_bare_dim:
                continue
            dims: list[str] = []
            for axis, scales in enumerate(ds.dims):
                if len(scales) > 0:
                    dims.append(scales[0].name.rsplit("/", 1)[-1])
                elif _text(ds.attrs.get("CLASS", "")) == "DIMENSION_SCALE":
                    dims.append(name)
                else:
                    dims.append(f"{name}_dim{axis}")
            out[name] = _Var(name, tuple(dims), attrs, tuple(ds.shape), np.dtype(ds.dtype),
                             _h5_reader(ds))  # fmt: skip
        return out

    def dim_size(self, dim: str) -> int | None:
        for v in self.vars.values():
            if dim in v.dims:
                return int(v.shape[v.dims.index(dim)])
        return None


def _h5_reader(ds: Any) -> Any:
    def read(index: tuple[Any, ...]) -> NDArray[Any]:
        try:
            return np.asarray(ds[index] if index else ds[()])
        except (OSError, ValueError, KeyError) as exc:
            raise FormatError(
                f"{ds.file.filename}: cannot read {ds.name!r} ({exc}); the file may be truncated"
            ) from exc

    return read


def _decode(var: _Var, raw: NDArray[Any], *, source: str) -> NDArray[np.float64]:
    """Apply CF packing and fill/missing/valid-range masking: no-data becomes NaN."""
    a = np.asarray(raw)
    out = a.astype(np.float64)
    bad = np.zeros(a.shape, dtype=bool)
    for key in ("_FillValue", "missing_value"):
        if key in var.attrs:
            for fv in np.atleast_1d(np.asarray(var.attrs[key])).astype(a.dtype, copy=False):
                bad |= (a == fv) if not (np.issubdtype(a.dtype, np.floating) and np.isnan(fv)) else np.isnan(a)  # fmt: skip
    lo = hi = None
    if "valid_range" in var.attrs:
        vr = np.asarray(var.attrs["valid_range"]).reshape(-1)
        if vr.size == 2:
            lo, hi = vr[0], vr[1]
    lo = var.attrs.get("valid_min", lo)
    hi = var.attrs.get("valid_max", hi)
    if lo is not None:
        bad |= a < np.asarray(lo).reshape(-1)[0]
    if hi is not None:
        bad |= a > np.asarray(hi).reshape(-1)[0]
    if "scale_factor" in var.attrs:
        out *= float(np.asarray(var.attrs["scale_factor"]).reshape(-1)[0])
    if "add_offset" in var.attrs:
        out += float(np.asarray(var.attrs["add_offset"]).reshape(-1)[0])
    out[bad] = np.nan
    return out


# --------------------------------------------------------------------------- layout
def _is_time(var: _Var) -> bool:
    std = _text(var.attrs.get("standard_name", "")).lower()
    axis = _text(var.attrs.get("axis", "")).upper()
    units = _text(var.attrs.get("units", "")).lower()
    return axis == "T" or std == "time" or var.name.lower() in ("time", "t") or " since " in units


@dataclass
class _Layout:
    time_dim: str | None
    times: NDArray[np.float64]
    physical: bool
    spatial: tuple[str, ...]  # CF order (z, y, x) or shorter
    coords: list[NDArray[np.float64]]  # x, y, z coordinates (each increasing)
    flip: list[bool]  # per spatial dim (in ``spatial`` order): reversed
    variables: dict[str, _Var]  # scalar data variables by name
    vectors: dict[str, tuple[str, ...]]  # vector field name -> component variables
    units: dict[str, str]
    coord_units: list[str]
    time_units: str | None


def _layout(b: _Backend, *, source: str) -> _Layout:
    coord_vars = {n: v for n, v in b.vars.items() if v.dims == (n,)}
    time_dim: str | None = None
    for n, v in coord_vars.items():
        if _is_time(v):
            time_dim = n
            break
    if time_dim is None:  # a time dimension without a coordinate variable
        for d in {d for v in b.vars.values() for d in v.dims}:
            if d.lower() in ("time", "t"):
                time_dim = d
    data = {
        n: v
        for n, v in b.vars.items()
        if n not in coord_vars
        and v.shape
        and np.issubdtype(v.dtype, np.number)
        and 1 <= len([d for d in v.dims if d != time_dim]) <= 3
        and (time_dim is None or time_dim in v.dims)
    }
    if not data:
        raise FormatError(
            f"{source}: no data variable with 1 to 3 spatial dimensions"
            + (f" and the time dimension {time_dim!r}" if time_dim else "")
            + f"; variables: {', '.join(b.vars) or '(none)'}"
        )
    # The spatial layout of the variable with the most points (all must share it).
    first = max(data.values(), key=lambda v: int(np.prod(v.shape)))
    spatial = tuple(d for d in first.dims if d != time_dim)
    variables = {
        n: v for n, v in data.items() if tuple(d for d in v.dims if d != time_dim) == spatial
    }
    for n, v in variables.items():
        if time_dim is not None and v.dims[0] != time_dim:
            raise FormatError(
                f"{source}: variable {n!r} has dimensions {v.dims}; the time dimension "
                f"{time_dim!r} must come first"
            )
    if time_dim is not None:
        n_t = b.dim_size(time_dim) or 0
        if time_dim in coord_vars:
            tv = coord_vars[time_dim]
            units = tv.attrs.get("units")
            if units is None:
                raise FormatError(
                    f"{source}: the time coordinate {time_dim!r} has no 'units' attribute; CF "
                    f"needs e.g. units='seconds since 2001-01-01'"
                )
            factor, _ref = time_unit_seconds(_text(units), source=source)
            raw = _decode(tv, tv.read(), source=source)
            if not np.all(np.isfinite(raw)):
                raise DataError(f"{source}: the time coordinate {time_dim!r} has missing values")
            times = raw * factor
            physical, time_units = True, _text(units)
        else:
            times = np.arange(n_t) / 30.0
            physical, time_units = False, None
        if times.size == 0:
            raise FormatError(f"{source}: the time dimension {time_dim!r} has no steps")
    else:
        times, physical, time_units = np.zeros(1), False, None
    coords_cf: list[NDArray[np.float64]] = []
    coord_units: list[str] = []
    flip: list[bool] = []
    for d in spatial:
        n_d = int(first.shape[first.dims.index(d)])
        if d in coord_vars:
            c = _decode(coord_vars[d], coord_vars[d].read(), source=source)
            coord_units.append(_text(coord_vars[d].attrs.get("units", "")))
        else:
            c = np.arange(n_d, dtype=np.float64)
            coord_units.append("")
        if not np.all(np.isfinite(c)) or (
            c.size > 1 and not (np.all(np.diff(c) > 0) or np.all(np.diff(c) < 0))
        ):
            raise DataError(f"{source}: coordinate {d!r} must be finite and monotonic")  # fmt: skip
        rev = bool(c.size > 1 and c[1] < c[0])
        flip.append(rev)
        coords_cf.append(c[::-1].copy() if rev else c)
    xyz = coords_cf[::-1] + [np.zeros(1)] * (3 - len(coords_cf))
    vectors: dict[str, tuple[str, ...]] = {}
    lower = {n.lower(): n for n in variables}
    comps = [lower.get(c) for c in ("u", "v", "w")]
    if comps[0] and comps[1]:
        vectors["velocity"] = tuple(c for c in comps if c)
    else:
        by_std = {
            _text(v.attrs.get("standard_name", "")).split("_", 1)[0]: n
            for n, v in variables.items()
        }
        if "eastward" in by_std and "northward" in by_std:
            vectors["velocity"] = tuple(
                by_std[k] for k in ("eastward", "northward", "upward") if k in by_std
            )
    if "velocity" in variables:
        vectors.pop("velocity", None)
    units = {n: _text(v.attrs["units"]) for n, v in variables.items() if "units" in v.attrs}
    if "velocity" in vectors and vectors["velocity"][0] in units:
        units["velocity"] = units[vectors["velocity"][0]]
    return _Layout(time_dim, np.asarray(times, dtype=np.float64), physical, spatial,
                   xyz, flip, variables, vectors, units, coord_units[::-1], time_units)  # fmt: skip


class _NetCDFSteps:
    """Loader: one time step of every selected variable as a pyvista RectilinearGrid."""

    def __init__(self, backend: _Backend, layout: _Layout, source: str) -> None:
        self.b, self.lay, self.source = backend, layout, source

    def slab(self, var: _Var, step: int) -> NDArray[np.float64]:
        """One step of ``var``, decoded (NaN for no-data), flipped, flattened x fastest."""
        lay = self.lay
        raw = var.read((step,)) if lay.time_dim is not None else var.read()
        a = _decode(var, raw, source=self.source)
        for axis, rev in enumerate(lay.flip):
            if rev:
                a = np.flip(a, axis=axis)
        return np.ascontiguousarray(a).reshape(-1)

    def __call__(self, step: int) -> Any:
        pv = import_pyvista()
        lay = self.lay
        grid = pv.RectilinearGrid(*lay.coords)
        for name, var in lay.variables.items():
            grid.point_data[name] = self.slab(var, step)
        for name, parts in lay.vectors.items():
            cols = [self.slab(lay.variables[p], step) for p in parts]
            while len(cols) < 3:
                cols.append(np.zeros_like(cols[0]))
            grid.point_data[name] = np.stack(cols, axis=-1)
        return grid


def _evenly_spaced(c: NDArray[np.float64]) -> bool:
    if c.size < 3:
        return True
    d = np.diff(c)
    return bool(np.allclose(d, d[0], rtol=1e-6, atol=0.0))


def _uniform_volume(
    loader: _NetCDFSteps,
    lay: _Layout,
    source: str,
    fields: FieldsArg,
    name_map: Mapping[str, str] | None,
) -> TimeVolume:
    """Evenly spaced coordinates: each field reads its own variable(s), one step per read."""
    nx, ny, nz = (c.size for c in lay.coords)
    available = [*lay.variables, *lay.vectors]
    chosen = select_fields(available, fields, name_map, source=source)
    n_t = lay.times.size

    def scalar(var: _Var) -> CallableFrames:
        return CallableFrames(
            lambda step: loader.slab(var, step).reshape(nz, ny, nx), n_t, (nz, ny, nx)
        )

    def vector(parts: tuple[str, ...]) -> CallableFrames:
        def read(step: int) -> NDArray[np.float64]:
            out = np.zeros((nz * ny * nx, 3))
            for k, p in enumerate(parts):
                out[:, k] = loader.slab(lay.variables[p], step)
            return out.reshape(nz, ny, nx, 3)

        return CallableFrames(read, n_t, (nz, ny, nx, 3))

    frames: dict[str, FrameSource] = {
        vol_name: vector(lay.vectors[name]) if name in lay.vectors else scalar(lay.variables[name])
        for vol_name, name in chosen.items()
    }
    origin = np.array([c[0] for c in lay.coords])
    spacing = np.array([(c[-1] - c[0]) / (c.size - 1) if c.size > 1 else 0.0 for c in lay.coords])
    if np.any(spacing > 0):
        spacing[spacing <= 0] = spacing[spacing > 0].min()
    else:
        spacing[:] = 1.0
    volume = TimeVolume(
        origin=origin,
        spacing=spacing,
        dims=(nx, ny, nz),
        times=lay.times,
        fields=frames,
        physical_times=lay.physical,
        source=source,
    )
    volume.attrs["centring"] = dict.fromkeys(chosen, "point")
    volume.attrs["mesh"] = f"netCDF {loader.b.kind} grid of {nx}x{ny}x{nz} points"
    return volume


def read_netcdf(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open a netCDF (classic or netCDF4) file with CF conventions as a lazy volume.

    Parameters
    ----------
    path : path-like
        The ``.nc`` file.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`; names are the file's variable
        names (plus ``velocity`` when ``u``/``v``/``w`` are present).

    Returns
    -------
    TimeVolume
        Times in seconds after the time units' reference date;
        ``attrs["units"]`` holds each field's ``units``, ``attrs["time_units"]``
        the time axis' own.

    Examples
    --------
    The small pulse file shipped with auralize (time in milliseconds since a
    reference date, velocity from ``u``/``v``/``w``):

    >>> from pathlib import Path
    >>> import auralize
    >>> vol = read_netcdf(Path(auralize.__file__).parent / "data/netcdf-pulse/pulse.nc")
    >>> vol.times[:3].tolist(), vol.attrs["time_units"]
    ([0.0, 0.001, 0.002], 'milliseconds since 2001-01-01 00:00:00')
    >>> vol.is_vector("velocity")
    True
    """
    path = Path(path).expanduser()
    require_exists(path)
    backend = _Backend(path)
    lay = _layout(backend, source=str(path))
    loader = _NetCDFSteps(backend, lay, str(path))
    if all(_evenly_spaced(c) for c in lay.coords):
        volume = _uniform_volume(loader, lay, str(path), fields, name_map)
        volume = resample_uniform(volume, check_resolution(resolution, source=str(path)))
    else:
        volume = open_mesh_series(
            source=str(path),
            loader=loader,
            labels=[f"{path} step {n}" for n in range(lay.times.size)],
            times=lay.times,
            physical_times=lay.physical,
            fields=fields,
            resolution=resolution,
            name_map=name_map,
        )
    rename = dict(name_map or {})
    volume.attrs["units"] = {
        rename.get(k, k): u for k, u in lay.units.items() if rename.get(k, k) in volume.fields
    }
    volume.attrs["grid_units"] = lay.coord_units
    if lay.time_units:
        volume.attrs["time_units"] = lay.time_units
    return volume
