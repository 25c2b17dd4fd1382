"""netCDF files (classic CDF-1/2 and netCDF4/HDF5) with CF conventions.

Read lazily, one time step per read: classic files with
:class:`scipy.io.netcdf_file` (memory-mapped), netCDF4 files with h5py (a
netCDF4 file is an HDF5 file whose dimensions are HDF5 dimension scales).
Like every HDF5 file, a netCDF4 file that reads data from other files
(external links, external raw storage, virtual datasets) is refused unless
:func:`~auralize.io.hdf5.allow_external_data` allows it.
Both libraries are dependencies already, so reading netCDF needs nothing more.
Section numbers below are those of the CF conventions (1.11).

Time
----
- The time dimension is the one the user names (``open_volume(time_dim=)``,
  ``--time-dim NAME``: a name the file does not have is an error listing its
  dimensions); else a coordinate CF marks as time (§4.4: ``axis="T"``,
  ``standard_name="time"`` or ``units="<unit> since <date>"``); else a
  dimension with a common name (:data:`TIME_NAMES`: ``time``, ``t``,
  ``month``, ``ocean_time``, ``valid_time`` ..., case-insensitive).  A file
  with 4-D variables and none of these is refused with a message saying so.
  ``attrs["time_dim"]`` names the dimension used.
- Its ``units`` (``"days since 2001-01-01"``, ``"hours since ..."``, ``"s"``,
  ``"months"``) are converted to seconds after the reference date (UDUNITS
  lengths: a month is 1/12 of a 365.242198781-day year).  A coordinate
  without units is refused if it calls itself time (CF needs units), and
  otherwise (``month`` = 1 .. 12, or the one ``--time-dim`` names) gives
  frames at 30 Hz (``physical_times=False``), as does a time dimension
  without a coordinate; ``attrs["time_units"]`` says which.  A file without
  a time dimension is a single step.

Values
------
- ``scale_factor``/``add_offset`` are applied (§8.1, packed integers are
  made float64 first); ``_FillValue``, ``missing_value`` and values outside
  ``valid_min``/``valid_max``/``valid_range`` become NaN (no-data, §2.5.1).
- Variables whose names or ``standard_name`` are velocity components
  (:data:`auralize.roles.COMPONENT_NAMES`: ``u``/``v``/``w``,
  ``eastward_wind``/``northward_wind``/``upward_air_velocity`` ...) also form a
  vector field ``velocity`` (units those of its x component), stacked by
  :func:`auralize.roles.assemble_vector` like every reader's components.

Spatial axes: always metres
---------------------------
The spatial axes are the variable's dimensions after time, in CF order
(Z, Y, X: the last is x, §2.4); their coordinate variables give the grid,
converted to metres so that the speed of sound applies to it:

- longitude/latitude (``units`` ``degrees_east``/``degrees_north`` §4.1-4.2,
  or ``degrees`` with ``standard_name``, ``axis`` or the axis' place telling
  which): the local equirectangular projection about the grid's middle
  latitude φm, ``x = R cos(φm) λ``, ``y = R φ`` (``R`` = 6 371 000 m, angles
  in radians).  The grid stays uniform; distances are exact along φm and the
  meridians only, east-west ones off by ``cos φm / cos φ`` elsewhere (a
  :class:`~auralize.io.ResampledWarning` when the latitudes span more than
  30°).  ``attrs["projection"]`` states it.
- pressure levels (``hPa``, ``mbar``, ``millibar``, ``Pa``, or
  ``standard_name="air_pressure"``, §4.3.1): geopotential height in the
  ICAO standard atmosphere (:func:`standard_height`), so they are unevenly
  spaced and resampled (below).
- lengths: ``km`` x 1000, ``cm`` x 0.01, ``m``/``metre(s)``/``meter(s)`` as
  they are; ``positive="down"`` (depth, §4.3) is negated into height.
  Coordinates without units, or with units that are not lengths, and
  dimensions without a coordinate variable (index 0, 1, 2 ...) are taken as
  metres, and ``attrs["axis_units"]`` says so.
- a vertical position that varies from point to point makes the grid
  curvilinear, read on its own points (``TimeVolume.coords``, heights in
  metres): a 3-D height or depth named by the data variable's CF
  ``coordinates`` (§5; a 4-D one, with time, at its time mean; ``positive="down"``
  negated), else a parametric vertical coordinate (§4.3.3, Appendix D: sigma,
  s-levels, hybrid height, sigma and hybrid pressure: :data:`VERTICAL_FORMULAS`)
  evaluated from its ``formula_terms`` (pressures to heights in the standard
  atmosphere; a term that changes over time, such as the free surface, at its
  time mean: the grid is fixed, ``attrs["axis_units"]["z"]`` says by how much it
  moves).  Other parametric coordinates are refused, naming ``--axis-scale``
  (one height per level: its values times the scale).
- ``axis_scale=`` (``--axis-scale``) replaces all of this: the file's
  coordinates times the scale (``attrs["axis_scale_applied"]``); a
  parametric coordinate's values are then one height per level.

``attrs["axis_units"]`` tells for each axis how it became metres
(``{"x": "degrees_east -> m (R cos 45.0°)", "y": "degrees_north -> m",
"z": "hPa -> m (standard atmosphere)"}``), ``attrs["grid_units"]`` keeps the
file's units.  Decreasing coordinates are flipped.  Unevenly spaced ones are
read on their own points (a rectilinear grid: ``TimeVolume.coords``, the
derivatives by its metric terms, :mod:`auralize.curvilinear`; a ``box``
keeps the smallest index block whose cells cover it); with
``curvilinear="resample"`` (``--resample``) or a ``resolution`` they are
resampled onto a uniform grid (with a
:class:`~auralize.io.ResampledWarning` saying why): the evenly spaced axes
keep their points, an uneven one takes its finest step (at most twice its
points) unless ``resolution=`` says otherwise.  A curvilinear lat/lon grid
(2-D longitude/latitude variables over the last two spatial dimensions, named
by the data variable's CF ``coordinates`` attribute, §5.2: ocean and regional
models) is read on its own points likewise, each point's longitude/latitude
projected as above (``attrs["axis_units"]`` says ``longitude (2-D)``)."""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re
import threading
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, FormatError
from auralize.io._common import (
    FieldsArg,
    ResampledWarning,
    require_exists,
    select_fields,
    warn_resampled,
)
from auralize.io._mesh import import_pyvista, open_mesh_series
from auralize.io.options import current as read_options
from auralize.io.resample import ResolutionArg, check_resolution, resample_uniform
from auralize.roles import COMPONENT_NAMES, assemble_vector
from auralize.volume import CallableFrames, FrameSource, TimeVolume

NETCDF_SUFFIXES = (".nc", ".nc4", ".cdf", ".netcdf")

#: Seconds per CF/UDUNITS time unit.
_TIME_UNITS = {
    "s": 1.0,
    "sec": 1.0,
    "secs": 1.0,
    "second": 1.0,
    "seconds": 1.0,
    "ms": 1e-3,
    "millisecond": 1e-3,
    "milliseconds": 1e-3,
    "us": 1e-6,
    "microsecond": 1e-6,
    "microseconds": 1e-6,
    "min": 60.0,
    "mins": 60.0,
    "minute": 60.0,
    "minutes": 60.0,
    "h": 3600.0,
    "hr": 3600.0,
    "hrs": 3600.0,
    "hour": 3600.0,
    "hours": 3600.0,
    "d": 86400.0,
    "day": 86400.0,
    "days": 86400.0,
    "week": 604800.0,
    "weeks": 604800.0,
    "year": 365.242198781 * 86400.0,
    "years": 365.242198781 * 86400.0,
    "month": 365.242198781 * 86400.0 / 12,
    "months": 365.242198781 * 86400.0 / 12,
}


def time_unit_seconds(units: str, *, source: str) -> tuple[float, str | None]:
    """Seconds per unit of a CF time ``units`` string, and its reference date.

    Parameters
    ----------
    units : str
        ``"<unit>"`` or ``"<unit> since <date>"`` (CF): seconds, milliseconds,
        microseconds, minutes, hours, days, weeks, months, years and their
        abbreviations (``s``, ``ms``, ``min``, ``h``, ``d`` ...).
    source : str
        File name for messages.

    Returns
    -------
    factor : float
        Seconds per unit (a year is 365.242198781 days, a month a twelfth of it).
    reference : str or None
        The text after ``since``, None without one.

    Raises
    ------
    FormatError
        Units that are not a CF time unit.

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
            name: _Var(
                name,
                tuple(v.dimensions),
                dict(v._attributes),
                tuple(v.shape),
                np.dtype(v.data.dtype),
                self._classic_reader(name),
            )
            for name, v in f.variables.items()
        }

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
            attrs = {
                k: v
                for k, v in ds.attrs.items()
                if k
                not in (
                    "DIMENSION_LIST",
                    "REFERENCE_LIST",
                    "CLASS",
                    "NAME",
                    "_Netcdf4Dimid",
                    "_Netcdf4Coordinates",
                    "_NCProperties",
                )
            }
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
            out[name] = _Var(
                name, tuple(dims), attrs, tuple(ds.shape), np.dtype(ds.dtype), _h5_reader(ds)
            )
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


def _is_fill(a: NDArray[Any], r: NDArray[np.float64], fill: object) -> NDArray[np.bool_]:
    """Where the raw values ``a`` (``r``: the same as float64) equal the fill value ``fill``.

    Floating data compare in their own precision (a float64 fill attribute of a
    float32 variable matches the rounded value the file stores); integer data
    compare as float64, so a NaN or out-of-range fill value is never cast to an
    integer type (that cast warns and yields an arbitrary integer).
    """
    if a.dtype.kind == "f":
        with np.errstate(all="ignore"):
            f = np.asarray(fill).astype(a.dtype)
        return np.isnan(a) if np.isnan(f) else a == f
    fv = float(np.asarray(fill, dtype=np.float64))
    return r == fv if np.isfinite(fv) else np.zeros(a.shape, dtype=bool)


def _decode(var: _Var, raw: NDArray[Any], *, source: str) -> NDArray[np.float64]:
    """Apply CF packing and fill/missing/valid-range masking: no-data becomes NaN.

    Packed integers are converted to float64 first, and every comparison with
    ``_FillValue``/``missing_value``/``valid_*`` (in packed units, CF §8.1) is
    made on those floats, so NaN fill values of integer data cast nothing.
    """
    a = np.asarray(raw)
    out = a.astype(np.float64)
    bad = np.zeros(a.shape, dtype=bool)
    for key in ("_FillValue", "missing_value"):
        if key in var.attrs:
            for fv in np.atleast_1d(np.asarray(var.attrs[key])).reshape(-1):
                bad |= _is_fill(a, out, fv)
    lo = hi = None
    if "valid_range" in var.attrs:
        vr = np.asarray(var.attrs["valid_range"]).reshape(-1)
        if vr.size == 2:
            lo, hi = vr[0], vr[1]
    lo = var.attrs.get("valid_min", lo)
    hi = var.attrs.get("valid_max", hi)
    with np.errstate(invalid="ignore"):
        if lo is not None:
            bad |= out < float(np.asarray(lo, dtype=np.float64).reshape(-1)[0])
        if hi is not None:
            bad |= out > float(np.asarray(hi, dtype=np.float64).reshape(-1)[0])
    if "scale_factor" in var.attrs:
        out *= float(np.asarray(var.attrs["scale_factor"]).reshape(-1)[0])
    if "add_offset" in var.attrs:
        out += float(np.asarray(var.attrs["add_offset"]).reshape(-1)[0])
    out[bad] = np.nan
    return out


# --------------------------------------------------------------------------- time
#: Dimension names taken as time when no coordinate says so (compared case-insensitively,
#: in this order of preference).
TIME_NAMES = (
    "time",
    "t",
    "month",
    "months",
    "ocean_time",
    "valid_time",
    "date",
    "year",
    "day",
    "step",
)


def _is_time(var: _Var) -> bool:
    """A coordinate that CF marks as time (§4.4): ``axis="T"``, ``standard_name="time"`` or
    ``units="<unit> since <date>"``."""
    std = _text(var.attrs.get("standard_name", "")).lower()
    axis = _text(var.attrs.get("axis", "")).upper()
    units = _text(var.attrs.get("units", "")).lower()
    return axis == "T" or std == "time" or " since " in f" {units} "


def _dims_text(b: _Backend, dims: list[str]) -> str:
    return ", ".join(f"{d} ({b.dim_size(d)})" for d in dims) or "(none)"


def _find_time(
    b: _Backend, coord_vars: dict[str, _Var], wanted: str | None, *, source: str
) -> str | None:
    """The time dimension: the user's ``wanted``, a CF time coordinate, or a common name."""
    by_rank = sorted(b.vars.values(), key=lambda v: -len(v.dims))  # data variables' order
    all_dims = list(dict.fromkeys(d for v in by_rank for d in v.dims))
    if wanted is not None:
        if wanted not in all_dims:
            raise FormatError(
                f"{source}: --time-dim {wanted!r}: the file has no such dimension; its "
                f"dimensions are {_dims_text(b, all_dims)}"
            )
        return wanted
    used = (
        list(
            dict.fromkeys(
                d
                for n, v in b.vars.items()
                if n not in coord_vars and len(v.dims) >= 2
                for d in v.dims
            )
        )
        or all_dims
    )
    for n, v in coord_vars.items():
        if n in used and _is_time(v):
            return n
    for name in TIME_NAMES:
        for d in used:
            if d.lower() == name:
                return d
    return None


def _time_axis(
    b: _Backend, coord_vars: dict[str, _Var], time_dim: str, *, named: bool, source: str
) -> tuple[NDArray[np.float64], bool, str | None]:
    """``(times in s, physical, time_units)`` of the time dimension ``time_dim``."""
    n_t = b.dim_size(time_dim) or 0
    if n_t == 0:
        raise FormatError(f"{source}: the time dimension {time_dim!r} has no steps")
    frames = np.arange(n_t) / 30.0
    if time_dim not in coord_vars:
        return (
            frames,
            False,
            f"none: no coordinate variable {time_dim!r}, its steps are frames at 30 Hz",
        )
    tv = coord_vars[time_dim]
    units = _text(tv.attrs.get("units", "")).strip()
    cf_time = (_is_time(tv) or time_dim.lower() in ("time", "t")) and not named
    if not units:
        if cf_time:
            raise FormatError(
                f"{source}: the time coordinate {time_dim!r} has no 'units' attribute; CF "
                f"needs e.g. units='seconds since 2001-01-01'"
            )
        return frames, False, f"none: {time_dim!r} has no units, its steps are frames at 30 Hz"
    try:
        factor, ref = time_unit_seconds(units, source=source)
    except FormatError:
        if cf_time:
            raise
        return frames, False, f"{units!r}, not a time unit: its steps are frames at 30 Hz"
    raw = _decode(tv, tv.read(), source=source).reshape(-1)
    if not np.all(np.isfinite(raw)):
        raise DataError(f"{source}: the time coordinate {time_dim!r} has missing values")
    if ref is None:
        return raw * factor, True, f"{units} (no reference date; one unit = {factor:g} s)"
    return raw * factor, True, units


# --------------------------------------------------------------------------- spatial axes
#: Mean Earth radius (m) of the local projection of longitude/latitude.
EARTH_RADIUS = 6_371_000.0
_LON_UNITS = {"degrees_east", "degree_east", "degrees_e", "degree_e", "degreese", "degreee"}
_LAT_UNITS = {"degrees_north", "degree_north", "degrees_n", "degree_n", "degreesn", "degreen"}
_DEG_UNITS = {"degrees", "degree", "deg", "arc_degree", "angular_degree"}
#: Metres per length unit.
_LENGTH_UNITS = {
    "m": 1.0,
    "metre": 1.0,
    "metres": 1.0,
    "meter": 1.0,
    "meters": 1.0,
    "km": 1e3,
    "kilometre": 1e3,
    "kilometres": 1e3,
    "kilometer": 1e3,
    "kilometers": 1e3,
    "cm": 1e-2,
    "centimetre": 1e-2,
    "centimetres": 1e-2,
    "centimeter": 1e-2,
    "centimeters": 1e-2,
    "mm": 1e-3,
    "ft": 0.3048,
    "feet": 0.3048,
}
#: Pascals per pressure unit.
_PRESSURE_UNITS = {
    "pa": 1.0,
    "hpa": 100.0,
    "mbar": 100.0,
    "millibar": 100.0,
    "millibars": 100.0,
    "mb": 100.0,
    "kpa": 1e3,
    "bar": 1e5,
    "bars": 1e5,
    "atm": 101325.0,
}
#: CF parametric vertical coordinates (CF Appendix D): heights vary from point to point.
_PARAMETRIC = {
    "atmosphere_ln_pressure_coordinate",
    "atmosphere_sigma_coordinate",
    "atmosphere_hybrid_sigma_pressure_coordinate",
    "atmosphere_hybrid_height_coordinate",
    "atmosphere_sleve_coordinate",
    "ocean_sigma_coordinate",
    "ocean_s_coordinate",
    "ocean_s_coordinate_g1",
    "ocean_s_coordinate_g2",
    "ocean_sigma_z_coordinate",
    "ocean_double_sigma_coordinate",
}
#: ICAO standard atmosphere (ISO 2533): layer base geopotential height (m) and
#: temperature gradient (K/m), from sea level (288.15 K, 101325 Pa).
_ICAO = (
    (0.0, -0.0065),
    (11000.0, 0.0),
    (20000.0, 0.001),
    (32000.0, 0.0028),
    (47000.0, 0.0),
    (51000.0, -0.0028),
    (71000.0, -0.002),
)
_T0, _P0, _G0, _R_AIR = 288.15, 101325.0, 9.80665, 287.05287


def _icao_bases() -> list[tuple[float, float, float, float]]:
    """``(base height m, base temperature K, base pressure Pa, gradient K/m)`` per layer."""
    out = []
    t, p = _T0, _P0
    for k, (h, a) in enumerate(_ICAO):
        out.append((h, t, p, a))
        if k + 1 < len(_ICAO):
            dh = _ICAO[k + 1][0] - h
            t1 = t + a * dh
            p = p * (t1 / t) ** (-_G0 / (a * _R_AIR)) if a else p * np.exp(-_G0 * dh / (_R_AIR * t))
            t = t1
    return out


def standard_height(p: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Geopotential height (m) of pressure ``p`` (Pa) in the ICAO standard atmosphere.

    Troposphere: ``z = T0/L (1 - (p/p0)^(R L/g))`` with ``T0 = 288.15 K``,
    ``L = 0.0065 K/m``, ``p0 = 101325 Pa``, ``R = 287.05287 J/(kg K)``,
    ``g = 9.80665 m/s²``; above 11 km the isothermal and warming layers of
    ISO 2533 up to 71 km (the top layer extends beyond).  Pressures above
    ``p0`` give heights below 0.

    Parameters
    ----------
    p : float or array_like
        Pressure in Pa, any shape.

    Returns
    -------
    ndarray
        Height in m, the shape of ``p`` (float64).

    Examples
    --------
    >>> standard_height([101325.0, 50000.0, 22632.06]).round(1).tolist()
    [0.0, 5574.4, 11000.0]
    """
    p = np.asarray(p, dtype=np.float64)
    z = np.empty_like(p)
    bases = _icao_bases()
    for k, (h, t, pb, a) in enumerate(bases):
        top = bases[k + 1][2] if k + 1 < len(bases) else 0.0
        sel = (p <= pb) & (p > top) if k else p > top
        z[sel] = (
            h + t / a * ((p[sel] / pb) ** (-a * _R_AIR / _G0) - 1.0)
            if a
            else h + _R_AIR * t / _G0 * np.log(pb / p[sel])
        )
    return z


_LON_NAMES = ("lon", "longitude", "long", "x_lon", "nav_lon")
_LAT_NAMES = ("lat", "latitude", "y_lat", "nav_lat")


def _axis_kind(name: str, var: _Var | None, letter: str) -> str:
    """What an axis measures: lon, lat, pressure, parametric, depth, length, index, none, other."""
    if var is None:
        return "index"
    units = _text(var.attrs.get("units", "")).strip().lower()
    std = _text(var.attrs.get("standard_name", "")).strip().lower()
    axis = _text(var.attrs.get("axis", "")).strip().upper()
    positive = _text(var.attrs.get("positive", "")).strip().lower()
    if std in _PARAMETRIC or "formula_terms" in var.attrs:
        return "parametric"
    if units in _LENGTH_UNITS:
        return "depth" if positive == "down" else "length"
    if units in _PRESSURE_UNITS or std == "air_pressure":
        return "pressure"
    if units in _LON_UNITS:
        return "lon"
    if units in _LAT_UNITS:
        return "lat"
    if units in _DEG_UNITS or (not units and std in ("longitude", "latitude")):
        if std in ("longitude", "grid_longitude") or axis == "X" or name.lower() in _LON_NAMES:
            return "lon"
        if std in ("latitude", "grid_latitude") or axis == "Y" or name.lower() in _LAT_NAMES:
            return "lat"
        return {"x": "lon", "y": "lat"}.get(letter, "degrees")
    return "none" if not units else "other"


@dataclass
class _Axis:
    """One spatial axis: its dimension, the file's coordinate, and what it measures."""

    dim: str
    letter: str  # x, y or z
    raw: NDArray[np.float64]
    units: str  # the file's ``units`` ("" if none)
    kind: str


def _unwrap_longitude(c: NDArray[np.float64]) -> NDArray[np.float64]:
    """Longitudes that cross the date line (350, 355, 0, 5) made monotonic (.., 360, 365)."""
    if c.size < 2 or np.all(np.diff(c) > 0) or np.all(np.diff(c) < 0):
        return c
    return np.rad2deg(np.unwrap(np.deg2rad(c)))


def _to_metres(
    axes: list[_Axis], scale: tuple[float, float, float] | None, *, source: str
) -> tuple[list[NDArray[np.float64]], dict[str, str], str | None]:
    """Each axis' coordinates in metres (upward for z), how each was converted, and the
    map projection used (None if no longitude/latitude)."""
    out: list[NDArray[np.float64]] = []
    notes: dict[str, str] = {}
    if scale is not None:
        for ax in axes:
            s = scale["xyz".index(ax.letter)]
            out.append(ax.raw * s)
            notes[ax.letter] = f"{ax.units or 'no units'} x {s:g} (--axis-scale)"
        return out, notes, None
    lat = next((ax for ax in axes if ax.kind == "lat"), None)
    mid = 0.0 if lat is None else 0.5 * float(np.nanmin(lat.raw) + np.nanmax(lat.raw))
    if lat is not None:
        lo, hi = float(np.nanmin(lat.raw)), float(np.nanmax(lat.raw))
        if hi - lo > 30.0:
            edge = np.cos(np.deg2rad(max(abs(lo), abs(hi))))
            off = f"{np.cos(np.deg2rad(mid)) / edge:.3g}" if edge > 1e-9 else "an unbounded factor"
            warn_resampled(
                f"{source}: latitude spans {hi - lo:g}° ({lo:g}° .. {hi:g}°); the grid is the "
                f"local equirectangular projection about {mid:.1f}° (x = R cos({mid:.1f}°) λ, "
                f"y = R φ), whose east-west distances are off by up to {off} at its edges; cut "
                f"a smaller region or give --axis-scale"
            )
    for ax in axes:
        u, c = ax.units, ax.raw
        if ax.kind == "lon":
            c = _unwrap_longitude(c)
            out.append(EARTH_RADIUS * np.cos(np.deg2rad(mid)) * np.deg2rad(c))
            at = f"R cos {mid:.1f}°" if lat is not None else "R: no latitude axis, at the equator"
            notes[ax.letter] = f"{u or 'degrees'} -> m ({at})"
        elif ax.kind == "lat":
            out.append(EARTH_RADIUS * np.deg2rad(c))
            notes[ax.letter] = f"{u or 'degrees'} -> m"
        elif ax.kind == "pressure":
            factor = _PRESSURE_UNITS.get(u.lower())
            if factor is None:
                raise FormatError(
                    f"{source}: the pressure coordinate {ax.dim!r} has units {u!r}; use hPa, "
                    f"mbar or Pa, or give --axis-scale"
                )
            if np.any(c <= 0):
                raise DataError(f"{source}: the pressure coordinate {ax.dim!r} has values <= 0")
            out.append(standard_height(c * factor))
            notes[ax.letter] = f"{u} -> m (standard atmosphere)"
        elif ax.kind == "aux3d":  # heights per point: the layout's 3-D vertical coordinate
            out.append(c)
            notes[ax.letter] = "3-D (per point)"
        elif ax.kind == "parametric":
            raise FormatError(
                f"{source}: {ax.dim!r} is a parametric vertical coordinate (CF Appendix D) "
                f"whose formula auralize does not evaluate (it evaluates "
                f"{', '.join(sorted(VERTICAL_FORMULAS))} from their formula_terms); give "
                f"--axis-scale SX,SY,SZ to use its values ({np.nanmin(c):g} .. "
                f"{np.nanmax(c):g}) times SZ metres as one height per level"
            )
        elif ax.kind == "degrees":
            raise FormatError(
                f"{source}: the {ax.letter} axis {ax.dim!r} is in {u!r}, neither longitude nor "
                f"latitude; give --axis-scale to turn it into metres"
            )
        elif ax.kind in ("length", "depth"):
            f = _LENGTH_UNITS[u.lower()]
            sign = -1.0 if ax.kind == "depth" else 1.0
            out.append(sign * f * c)
            notes[ax.letter] = u if f == 1.0 else f"{u} -> m"
            if ax.kind == "depth":
                notes[ax.letter] += " (positive down -> height: negated)"
        elif ax.kind == "index":
            out.append(c)
            notes[ax.letter] = "index 0, 1, 2 ... (no coordinate variable): taken as m"
        elif ax.kind == "none":
            out.append(c)
            notes[ax.letter] = "no units: taken as m"
        else:
            out.append(c)
            notes[ax.letter] = f"{u} (not a length) taken as m"
    projection = None
    if any(ax.kind in ("lon", "lat") for ax in axes):
        projection = (
            f"local equirectangular about latitude {mid:.4g}°: x = R cos({mid:.4g}°) λ, "
            f"y = R φ, R = {EARTH_RADIUS:.0f} m (distances exact along the middle latitude "
            f"and the meridians only)"
        )
    return out, notes, projection


# --------------------------------------------------------------------------- layout
@dataclass
class _Layout:
    time_dim: str | None
    times: NDArray[np.float64]
    physical: bool
    spatial: tuple[str, ...]  # CF order (z, y, x) or shorter
    coords: list[NDArray[np.float64]]  # x, y, z coordinates in metres (each increasing)
    flip: list[bool]  # per spatial dim (in ``spatial`` order): reversed
    variables: dict[str, _Var]  # scalar data variables by name
    vectors: dict[str, tuple[str | None, ...]]  # vector name -> (x, y, z) component variables
    units: dict[str, str]
    coord_units: list[str]
    time_units: str | None
    axis_units: dict[str, str]  # x/y/z -> how the file's coordinate became metres
    projection: str | None  # how longitude/latitude became x/y
    #: points (nz, ny, nx, 3) in metres of a grid whose horizontal position is given by
    #: 2-D longitude/latitude auxiliary coordinates (CF ``coordinates``) or whose height
    #: by a 3-D vertical coordinate (None: neither)
    aux: NDArray[np.float64] | None = None
    #: what made the grid curvilinear (for ``attrs["mesh"]``)
    aux_why: str = ""


def _velocity_parts(variables: dict[str, _Var]) -> tuple[str | None, ...] | None:
    """The variables that are the x, y (and z) components of a velocity.

    Matched against :data:`auralize.roles.COMPONENT_NAMES` (the names every
    reader's scalar components go by: ``u``/``v``/``w``, ``eastward_wind`` ...)
    first by variable name, then by ``standard_name`` (CF standard names).
    """
    names = {n.lower(): n for n in reversed(variables)}
    stds = {
        _text(v.attrs.get("standard_name", "")).lower(): n for n, v in reversed(variables.items())
    }
    for table in (names, stds):
        for triple in COMPONENT_NAMES["velocity"]:
            found = tuple(table.get(c) for c in triple)
            if found[0] is not None and found[1] is not None:
                return found
    return None


def _layout(b: _Backend, *, source: str) -> _Layout:
    opts = read_options()
    coord_vars = {n: v for n, v in b.vars.items() if v.dims == (n,)}
    time_dim = _find_time(b, coord_vars, opts.time_dim, source=source)
    numeric = {
        n: v
        for n, v in b.vars.items()
        if n not in coord_vars and v.shape and np.issubdtype(v.dtype, np.number)
    }
    data = {
        n: v
        for n, v in numeric.items()
        if 1 <= len([d for d in v.dims if d != time_dim]) <= 3
        and (time_dim is None or time_dim in v.dims)
    }
    four = [v for v in numeric.values() if len(v.dims) == 4]
    if time_dim is None and four:
        raise FormatError(
            f"{source}: no time dimension found among ({', '.join(four[0].dims)}): name it "
            f"with --time-dim NAME (CF: a coordinate with axis='T' or units '<unit> since "
            f"<date>')"
        )
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
        times, physical, time_units = _time_axis(
            b, coord_vars, time_dim, named=opts.time_dim is not None, source=source
        )
    else:
        times, physical, time_units = np.zeros(1), False, None
    axes: list[_Axis] = []
    for k, d in enumerate(spatial):
        letter = "xyz"[len(spatial) - 1 - k]
        cv = coord_vars.get(d)
        if cv is not None:
            c = _decode(cv, cv.read(), source=source).reshape(-1)
        else:
            c = np.arange(int(first.shape[first.dims.index(d)]), dtype=np.float64)
        c_units = _text(cv.attrs.get("units", "")).strip() if cv is not None else ""
        axes.append(_Axis(d, letter, c, c_units, _axis_kind(d, cv, letter)))
    vertical = _vertical_3d(
        b, first, spatial, axes, time_dim=time_dim, scale=opts.axis_scale, source=source
    )
    if vertical is not None:  # the levels' own values stand for the index (a monotonic one)
        raw = axes[0].raw
        raw = raw if _monotonic(raw) else np.arange(raw.size, dtype=np.float64)
        axes[0] = dataclasses.replace(axes[0], kind="aux3d", raw=raw)
    metres, axis_units, projection = _to_metres(axes, opts.axis_scale, source=source)
    coords_cf: list[NDArray[np.float64]] = []
    flip: list[bool] = []
    for ax, c in zip(axes, metres, strict=True):
        if not np.all(np.isfinite(c)) or (
            c.size > 1 and not (np.all(np.diff(c) > 0) or np.all(np.diff(c) < 0))
        ):
            raise DataError(f"{source}: coordinate {ax.dim!r} must be finite and monotonic")
        rev = bool(c.size > 1 and c[1] < c[0])
        flip.append(rev)
        coords_cf.append(c[::-1].copy() if rev else c)
    xyz = coords_cf[::-1] + [np.zeros(1)] * (3 - len(coords_cf))
    vectors: dict[str, tuple[str | None, ...]] = {}
    parts = _velocity_parts(variables)
    if parts is not None and "velocity" not in variables:
        vectors["velocity"] = parts
    units = {n: _text(v.attrs["units"]) for n, v in variables.items() if "units" in v.attrs}
    if "velocity" in vectors and vectors["velocity"][0] in units:
        units["velocity"] = units[str(vectors["velocity"][0])]
    coord_units = [ax.units for ax in axes][::-1]
    aux = _aux_lonlat(b, first, spatial, source=source)
    points = None
    why = []
    if aux is not None or vertical is not None:
        nz, ny, nx = xyz[2].size, xyz[1].size, xyz[0].size
        points = np.empty((nz, ny, nx, 3))
        if aux is not None:
            lon, lat = aux
            xs, ys, note_x, note_y, projection = _lonlat_metres(
                lon, lat, opts.axis_scale, source=source
            )
            axis_units["x"], axis_units["y"] = note_x, note_y
            points[..., 0] = xs[None]
            points[..., 1] = ys[None]
            why.append("2-D longitude/latitude coordinates")
        else:
            points[..., 0] = xyz[0][None, None, :]
            points[..., 1] = xyz[1][None, :, None]
        if vertical is not None:
            z, note = vertical
            for axis, rev in enumerate(flip):  # as the data's slabs are flipped
                if rev:
                    z = np.flip(z, axis=axis)
            points[..., 2] = z
            axis_units["z"] = note
            why.append(f"a 3-D vertical coordinate ({note.split(' ->')[0]})")
        else:
            points[..., 2] = xyz[2][:, None, None]
    return _Layout(
        time_dim,
        np.asarray(times, dtype=np.float64),
        physical,
        spatial,
        xyz,
        flip,
        variables,
        vectors,
        units,
        coord_units,
        time_units,
        dict(sorted(axis_units.items())),
        projection,
        points,
        " and ".join(why),
    )


def _aux_lonlat(
    b: _Backend, var: _Var, spatial: tuple[str, ...], *, source: str
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """2-D longitude and latitude ``(ny, nx)`` that CF's ``coordinates`` attribute of
    ``var`` names over its last two spatial dimensions (a curvilinear lat/lon grid:
    ocean and regional models), or None."""
    names = _text(var.attrs.get("coordinates", "")).split()
    if len(spatial) < 2 or not names:
        return None
    horizontal = spatial[-2:]
    found: dict[str, NDArray[np.float64]] = {}
    for name in names:
        cv = b.vars.get(name)
        if cv is None or tuple(cv.dims) != horizontal:
            continue
        kind = _axis_kind(name, cv, "x")
        if kind == "lon" or (kind == "degrees" and name.lower() in _LON_NAMES):
            found.setdefault("lon", _decode(cv, cv.read(), source=source))
        elif _axis_kind(name, cv, "y") == "lat":
            found.setdefault("lat", _decode(cv, cv.read(), source=source))
    if set(found) != {"lon", "lat"}:
        return None
    lon, lat = found["lon"], found["lat"]
    if not (np.all(np.isfinite(lon)) and np.all(np.isfinite(lat))):
        raise DataError(f"{source}: the 2-D longitude/latitude coordinates hold NaN or fill values")
    return lon, lat


def _monotonic(c: NDArray[np.float64]) -> bool:
    return bool(
        np.all(np.isfinite(c)) and (c.size < 2 or np.all(np.diff(c) > 0) or np.all(np.diff(c) < 0))
    )


#: CF Appendix D formulas evaluated into a height per point: standard name -> the
#: terms it needs (hybrid sigma-pressure: ap, b, ps or, without ap, a, b, ps, p0)
VERTICAL_FORMULAS: dict[str, tuple[str, ...]] = {
    "ocean_sigma_coordinate": ("sigma", "eta", "depth"),
    "ocean_s_coordinate": ("s", "eta", "depth", "a", "b", "depth_c"),
    "ocean_s_coordinate_g1": ("s", "C", "eta", "depth", "depth_c"),
    "ocean_s_coordinate_g2": ("s", "C", "eta", "depth", "depth_c"),
    "atmosphere_hybrid_height_coordinate": ("a", "b", "orog"),
    "atmosphere_sigma_coordinate": ("sigma", "ps", "ptop"),
    "atmosphere_hybrid_sigma_pressure_coordinate": ("ap", "b", "ps"),
    "atmosphere_ln_pressure_coordinate": ("p0", "lev"),
}
#: terms that are lengths (m after their units) and pressures (Pa); the rest are numbers
_LENGTH_TERMS = ("eta", "depth", "depth_c", "orog")
_PRESSURE_TERMS = ("ps", "ptop", "p0", "ap")
#: standard names of a height (or a depth: positive down) given per point
_HEIGHT_NAMES = {
    "height",
    "altitude",
    "height_above_mean_sea_level",
    "height_above_reference_ellipsoid",
    "height_above_geopotential_datum",
    "geopotential_height",
    "depth",
    "depth_below_geoid",
    "sea_floor_depth",
}


class _Terms:
    """The variables a vertical coordinate's formula reads, each broadcast onto the
    spatial dimensions (time-varying ones averaged over the steps)."""

    def __init__(
        self, b: _Backend, spatial: tuple[str, ...], time_dim: str | None, source: str
    ) -> None:
        self.b, self.spatial, self.time_dim, self.source = b, spatial, time_dim, source
        #: the largest change over the steps of a time-varying term (with its unit), by name
        self.moves: dict[str, str] = {}

    def read(self, var: _Var, kind: str) -> NDArray[np.float64]:
        """``var`` decoded, in metres (``kind="length"``), pascals (``"pressure"``) or as
        it is, shaped to broadcast over the spatial dimensions (CF order)."""
        dims = list(var.dims)
        if self.time_dim is not None and self.time_dim in dims:
            if dims.index(self.time_dim) != 0:
                raise FormatError(
                    f"{self.source}: {var.name!r} has dimensions {var.dims}; the "
                    f"time dimension {self.time_dim!r} must come first"
                )
            n_t = int(var.shape[0])
            lo = hi = total = None
            for n in range(n_t):  # a step at a time: a 4-D height need not fit twice
                a = _decode(var, var.read((n,)), source=self.source)
                total = a.copy() if total is None else total + a
                lo = a.copy() if lo is None else np.fmin(lo, a)
                hi = a.copy() if hi is None else np.fmax(hi, a)
            assert total is not None and lo is not None and hi is not None
            values = total / n_t
            dims = dims[1:]
            move = float(np.nanmax(hi - lo, initial=0.0))
        else:
            values, move = _decode(var, var.read(), source=self.source), 0.0
        extra = [d for d in dims if d not in self.spatial]
        if extra:
            raise FormatError(
                f"{self.source}: the vertical coordinate's term {var.name!r} has dimensions "
                f"{var.dims}, not among the data's ({', '.join(self.spatial)})"
            )
        units = _text(var.attrs.get("units", "")).strip().lower()
        factor = 1.0
        if kind == "length" and units:
            if units not in _LENGTH_UNITS:
                raise FormatError(
                    f"{self.source}: {var.name!r} has units {units!r}, not a length (m, km, ...)"
                )
            factor = _LENGTH_UNITS[units]
        elif kind == "pressure" and units:
            if units not in _PRESSURE_UNITS:
                raise FormatError(
                    f"{self.source}: {var.name!r} has units {units!r}, not a "
                    f"pressure (Pa, hPa, ...)"
                )
            factor = _PRESSURE_UNITS[units]
        if move > 0.0:
            unit = {"length": " m", "pressure": " Pa"}.get(kind, "")
            self.moves[var.name] = f"{move * factor:.3g}{unit}"
        present = sorted(dims, key=self.spatial.index)
        values = np.transpose(
            np.asarray(values, dtype=np.float64) * factor, [dims.index(d) for d in present]
        )
        shape = [values.shape[present.index(d)] if d in present else 1 for d in self.spatial]
        return values.reshape(shape)


def _formula_height(
    b: _Backend, coord: _Var, terms: _Terms, *, source: str
) -> tuple[NDArray[np.float64], str] | None:
    """Height (m, up) per point of a parametric vertical coordinate by its CF Appendix D
    formula (:data:`VERTICAL_FORMULAS`), and how it was made; None for a formula not
    evaluated here."""
    std = _text(coord.attrs.get("standard_name", "")).strip().lower()
    if std not in VERTICAL_FORMULAS:
        return None
    text = _text(coord.attrs.get("formula_terms", ""))
    pairs = re.findall(r"(\w+)\s*:\s*(\S+)", text)
    names = dict(pairs)
    need: tuple[str, ...]
    if std == "atmosphere_hybrid_sigma_pressure_coordinate" and "ap" not in names:
        need = ("a", "b", "ps", "p0")
    else:
        need = VERTICAL_FORMULAS[std]
    missing = [t for t in need if t not in names or names[t] not in b.vars]
    if missing:
        raw = _decode(coord, coord.read(), source=source)
        raise FormatError(
            f"{source}: {coord.name!r} is a parametric vertical coordinate ({std}, CF Appendix "
            f"D) whose formula_terms {text!r} leave out or name no variable for "
            f"{', '.join(missing)} (it needs {', '.join(need)}); give them, or --axis-scale "
            f"SX,SY,SZ to use its values ({np.nanmin(raw):g} .. {np.nanmax(raw):g}) times SZ "
            f"metres as one height per level"
        )

    def term(t: str) -> NDArray[np.float64]:
        kind = "length" if t in _LENGTH_TERMS else "pressure" if t in _PRESSURE_TERMS else "number"
        return terms.read(b.vars[names[t]], kind)

    if std == "ocean_sigma_coordinate":
        eta, depth = term("eta"), term("depth")
        z = eta + term("sigma") * (depth + eta)
    elif std == "ocean_s_coordinate":
        sv, a, bb, eta, depth, hc = (term(t) for t in ("s", "a", "b", "eta", "depth", "depth_c"))
        c = (1 - bb) * np.sinh(a * sv) / np.sinh(a) + bb * (
            np.tanh(a * (sv + 0.5)) / (2 * np.tanh(0.5 * a)) - 0.5
        )
        z = eta * (1 + sv) + hc * sv + (depth - hc) * c
    elif std == "ocean_s_coordinate_g1":
        sv, c, eta, depth, hc = (term(t) for t in ("s", "C", "eta", "depth", "depth_c"))
        big_s = hc * sv + (depth - hc) * c
        z = big_s + eta * (1 + big_s / depth)
    elif std == "ocean_s_coordinate_g2":
        sv, c, eta, depth, hc = (term(t) for t in ("s", "C", "eta", "depth", "depth_c"))
        big_s = (hc * sv + depth * c) / (hc + depth)
        z = eta + (eta + depth) * big_s
    elif std == "atmosphere_hybrid_height_coordinate":
        z = term("a") + term("b") * term("orog")
    else:  # pressure: heights of the ICAO standard atmosphere
        if std == "atmosphere_sigma_coordinate":
            ptop = term("ptop")
            p = ptop + term("sigma") * (term("ps") - ptop)
        elif std == "atmosphere_ln_pressure_coordinate":
            p = term("p0") * np.exp(-term("lev"))
        elif "ap" in names:
            p = term("ap") + term("b") * term("ps")
        else:
            p = term("a") * term("p0") + term("b") * term("ps")
        if np.any(~(p > 0)):
            raise DataError(
                f"{source}: the vertical coordinate {coord.name!r} ({std}) gives "
                f"pressures <= 0 or missing"
            )
        z = standard_height(np.asarray(p, dtype=np.float64))
    shape = tuple(int(terms.b.dim_size(d) or 1) for d in terms.spatial)
    z = np.broadcast_to(np.asarray(z, dtype=np.float64), shape).copy()
    used = ", ".join(f"{t}: {names[t]}" for t in need)
    note = f"{std} -> m per point (formula_terms {used}"
    if std.startswith("atmosphere") and std != "atmosphere_hybrid_height_coordinate":
        note += "; pressure -> height in the standard atmosphere"
    return z, note + ")"


def _height_variable(
    b: _Backend, var: _Var, spatial: tuple[str, ...], time_dim: str | None
) -> _Var | None:
    """The variable that CF's ``coordinates`` attribute of ``var`` names as its height (or
    depth) per point: over the spatial dimensions (after time), a length."""
    for name in _text(var.attrs.get("coordinates", "")).split():
        cv = b.vars.get(name)
        if cv is None:
            continue
        dims = tuple(d for d in cv.dims if d != time_dim)
        if dims != spatial or (len(cv.dims) > len(dims) and cv.dims[0] != time_dim):
            continue
        units = _text(cv.attrs.get("units", "")).strip().lower()
        std = _text(cv.attrs.get("standard_name", "")).strip().lower()
        axis = _text(cv.attrs.get("axis", "")).strip().upper()
        if units in _LENGTH_UNITS or (not units and (axis == "Z" or std in _HEIGHT_NAMES)):
            return cv
    return None


def _vertical_3d(
    b: _Backend,
    var: _Var,
    spatial: tuple[str, ...],
    axes: list[_Axis],
    *,
    time_dim: str | None,
    scale: tuple[float, float, float] | None,
    source: str,
) -> tuple[NDArray[np.float64], str] | None:
    """A height per point ``(nz, ny, nx)`` in metres (CF order, as the file holds it) and
    how it was made, for a data variable ``var`` over three spatial dimensions whose
    vertical position varies from point to point: a 3-D (or 4-D with time) height
    named by its CF ``coordinates`` (§5), else the vertical axis' CF Appendix D
    formula (``formula_terms``, :data:`VERTICAL_FORMULAS`).  Terms or heights that
    change over time are taken at their time mean (the grid is fixed); the note
    says by how much they move.  None for a grid of one height per level."""
    if len(spatial) != 3:
        return None
    terms = _Terms(b, spatial, time_dim, source)
    hv = _height_variable(b, var, spatial, time_dim)
    if hv is not None:
        std = _text(hv.attrs.get("standard_name", "")).strip().lower()
        positive = _text(hv.attrs.get("positive", "")).strip().lower()
        down = positive == "down" or (std.startswith("depth") and positive != "up")
        units = _text(hv.attrs.get("units", "")).strip() or "no units: taken as m"
        z = terms.read(hv, "number" if scale is not None else "length")
        z = np.broadcast_to(z, tuple(int(b.dim_size(d) or 1) for d in spatial)).copy()
        if scale is not None:
            z = z * scale[2]
            note = f"{hv.name} (3-D, {units}) x {scale[2]:g} (--axis-scale)"
        else:
            note = f"{hv.name} (3-D, {units}) -> m per point"
        if down:
            z = -z
            note += " (positive down -> height: negated)"
    else:
        coord = b.vars.get(spatial[0])
        if coord is None or axes[0].kind != "parametric" or scale is not None:
            return None  # with --axis-scale, a parametric axis' values times SZ (see _to_metres)
        made = _formula_height(b, coord, terms, source=source)
        if made is None:
            return None
        z, note = made
    if not np.all(np.isfinite(z)):
        raise DataError(
            f"{source}: the 3-D vertical coordinate holds NaN or fill values "
            f"({int(np.count_nonzero(~np.isfinite(z)))} points)"
        )
    if terms.moves:
        moved = ", ".join(f"{k} by up to {v}" for k, v in terms.moves.items())
        note += f"; at the time mean of what moves ({moved}): a fixed grid"
    return z, note


def _lonlat_metres(
    lon: NDArray[np.float64],
    lat: NDArray[np.float64],
    scale: tuple[float, float, float] | None,
    *,
    source: str,
) -> tuple[NDArray[np.float64], NDArray[np.float64], str, str, str | None]:
    """2-D longitude/latitude in metres: the local equirectangular projection of
    :func:`_to_metres` (or ``--axis-scale``), with the notes of ``axis_units``."""
    if scale is not None:
        return (
            lon * scale[0],
            lat * scale[1],
            f"longitude (2-D) x {scale[0]:g} (--axis-scale)",
            f"latitude (2-D) x {scale[1]:g} (--axis-scale)",
            None,
        )
    mid = 0.5 * float(lat.min() + lat.max())
    if float(lat.max() - lat.min()) > 30.0:
        warn_resampled(
            f"{source}: latitude spans {float(lat.max() - lat.min()):g}°; the grid is the local "
            f"equirectangular projection about {mid:.1f}°, whose east-west distances are off "
            f"away from it; cut a smaller region or give --axis-scale"
        )
    lon = np.rad2deg(np.unwrap(np.deg2rad(lon), axis=-1))
    x = EARTH_RADIUS * np.cos(np.deg2rad(mid)) * np.deg2rad(lon)
    y = EARTH_RADIUS * np.deg2rad(lat)
    projection = (
        f"local equirectangular about latitude {mid:.4g}°: x = R cos({mid:.4g}°) λ, "
        f"y = R φ, R = {EARTH_RADIUS:.0f} m, of the 2-D longitude/latitude of each point"
    )
    return (x, y, f"longitude (2-D) -> m (R cos {mid:.1f}°)", "latitude (2-D) -> m", projection)


class _NetCDFSteps:
    """Loader: one time step of the variables ``names`` as a pyvista RectilinearGrid."""

    def __init__(self, backend: _Backend, layout: _Layout, source: str, names: list[str]) -> None:
        self.b, self.lay, self.source, self.names = backend, layout, source, names

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
        if self.lay.aux is not None:  # 2-D longitude/latitude: a curvilinear grid
            grid = pv.StructuredGrid()
            grid.points = self.lay.aux.reshape(-1, 3)
            grid.dimensions = (self.lay.aux.shape[2], self.lay.aux.shape[1], self.lay.aux.shape[0])
            for name in self.names:
                grid.point_data[name] = self.slab(self.lay.variables[name], step)
            return grid
        grid = pv.RectilinearGrid(*self.lay.coords)
        for name in self.names:
            grid.point_data[name] = self.slab(self.lay.variables[name], step)
        return grid


def _evenly_spaced(c: NDArray[np.float64]) -> bool:
    if c.size < 3:
        return True
    d = np.diff(c)
    return bool(np.allclose(d, d[0], rtol=1e-6, atol=0.0))


def _uniform_volume(loader: _NetCDFSteps, lay: _Layout, source: str) -> TimeVolume:
    """Evenly spaced coordinates: each of ``loader.names`` reads its variable, a step a read."""
    nx, ny, nz = (c.size for c in lay.coords)
    n_t = lay.times.size

    def scalar(var: _Var) -> CallableFrames:
        return CallableFrames(
            lambda step: loader.slab(var, step).reshape(nz, ny, nx), n_t, (nz, ny, nx)
        )

    frames: dict[str, FrameSource] = {n: scalar(lay.variables[n]) for n in loader.names}
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
    volume.attrs["mesh"] = f"netCDF {loader.b.kind} grid of {nx}x{ny}x{nz} points"
    return volume


def _rectilinear_volume(loader: _NetCDFSteps, lay: _Layout, source: str) -> TimeVolume:
    """Unevenly spaced coordinates, read natively: the grid of the coordinates' points
    (``TimeVolume.coords``, a rectilinear grid; derivatives by its metric terms)."""
    from auralize.curvilinear import nominal_spacing

    nx, ny, nz = (c.size for c in lay.coords)
    n_t = lay.times.size
    if lay.aux is not None:
        coords = lay.aux
    else:
        zz, yy, xx = np.meshgrid(lay.coords[2], lay.coords[1], lay.coords[0], indexing="ij")
        coords = np.stack([xx, yy, zz], axis=-1)

    def scalar(var: _Var) -> CallableFrames:
        return CallableFrames(
            lambda step: loader.slab(var, step).reshape(nz, ny, nx), n_t, (nz, ny, nx)
        )

    volume = TimeVolume(
        origin=np.array([c[0] for c in lay.coords]),
        spacing=nominal_spacing(coords),
        dims=(nx, ny, nz),
        times=lay.times,
        fields={n: scalar(lay.variables[n]) for n in loader.names},
        physical_times=lay.physical,
        source=source,
        coords=coords,
    )
    why = lay.aux_why if lay.aux is not None else _uneven_reason(lay, None)
    volume.attrs["mesh"] = (
        f"netCDF {loader.b.kind} grid of {nx}x{ny}x{nz} points, {why}: read on its own points"
    )
    return volume


def _assembled(volume: TimeVolume, parts: tuple[str | None, ...]) -> FrameSource:
    """The vector of the scalar fields ``parts`` (x, y, z; None: 0), stacked the one way
    every reader's components are: :func:`auralize.roles.assemble_vector`."""
    keys = ("u", "v", "w")  # a triple of COMPONENT_NAMES["velocity"]
    comps = {k: volume.fields[p] for k, p in zip(keys, parts, strict=False) if p is not None}
    view = dataclasses.replace(volume, fields=comps, attrs={})
    name = assemble_vector(view, "velocity")
    if name is None:  # pragma: no cover - keys are one of COMPONENT_NAMES' triples
        raise AssertionError(f"{volume.source}: velocity components {parts} not assembled")
    return view.fields[name]


def _reissue(caught: list[warnings.WarningMessage], why: str) -> None:
    """Issue the warnings ``caught`` again, each :class:`ResampledWarning` with ``why``."""
    for w in caught:
        if issubclass(w.category, ResampledWarning):
            warn_resampled(f"{w.message}; resampled because {why}")
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def _native_resolution(lay: _Layout, box: Sequence[float] | None) -> tuple[int, int, int]:
    """Grid points per axis for unevenly spaced coordinates: an evenly spaced axis keeps
    its step, an uneven one gets its finest step, with at most twice its points; over
    the region ``box`` (of interest) when there is one."""
    out = []
    for a, c in enumerate(lay.coords):
        if c.size < 2:
            out.append(c.size)
            continue
        lo, hi = float(c[0]), float(c[-1])
        if box is not None:
            lo, hi = max(lo, float(box[2 * a])), min(hi, float(box[2 * a + 1]))
        if hi <= lo:  # the box misses it: open_mesh_series says so
            out.append(c.size)
            continue
        even = _evenly_spaced(c)
        step = float(c[-1] - c[0]) / (c.size - 1) if even else float(np.diff(c).min())
        n = int(np.ceil((hi - lo) / step - 1e-6)) + 1
        out.append(n if even else min(n, 2 * c.size))
    return (out[0], out[1], out[2])


def _uneven_reason(lay: _Layout, dims: tuple[int, int, int] | None) -> str:
    out = []
    for k, c in enumerate(lay.coords):
        if not _evenly_spaced(c):
            d = np.diff(c)
            letter = "xyz"[k]
            out.append(
                f"the {letter} coordinate ({lay.axis_units.get(letter, '')}) is unevenly "
                f"spaced: {c.size} points, {c[0]:.6g} .. {c[-1]:.6g} m in steps of "
                f"{d.min():.4g} .. {d.max():.4g} m"
                + (
                    f", taken as {dims[k]} points (its finest step, at most twice its "
                    f"{c.size} points)"
                    if dims is not None
                    else ""
                )
            )
    return "; ".join(out)


def read_netcdf(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open a netCDF (classic or netCDF4) file with CF conventions as a lazy volume.

    The time dimension and the axis units follow the rules of this module's
    docstring; the reader options of :func:`auralize.io.open_volume`
    (``time_dim=``, ``axis_scale=``) are read from
    :func:`auralize.io.options.current`.

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
        Times in seconds after the time units' reference date; grid in
        metres.  ``attrs``: ``units`` (each field's), ``time_units`` (the
        time axis' own), ``time_dim`` (the time dimension's name, if any),
        ``axis_units`` (``{"x": "degrees_east -> m (R cos 45.0°)", ...}``),
        ``grid_units`` (the coordinates' units in the file, x, y, z),
        ``projection`` (for longitude/latitude) and ``axis_scale_applied``
        (when ``axis_scale=`` replaced the conversions).

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        Not a readable netCDF file, time units or coordinates it cannot
        understand, no time or spatial dimensions it can use.
    FieldError
        A requested field is not in the file.
    DataError
        Missing time or coordinate values, coordinates that are not finite and
        monotonic, pressure levels <= 0, times not strictly increasing.
    ParameterError
        Bad ``fields=``, ``resolution=`` or ``name_map=``.

    Examples
    --------
    The small pulse file shipped with auralize (time in milliseconds since a
    reference date, velocity from ``u``/``v``/``w``):

    >>> from pathlib import Path
    >>> import auralize
    >>> vol = read_netcdf(Path(auralize.__file__).parent / "data/netcdf-pulse/pulse.nc")
    >>> vol.times[:3].tolist(), vol.attrs["time_units"]
    ([0.0, 0.001, 0.002], 'milliseconds since 2001-01-01 00:00:00')
    >>> vol.is_vector("velocity"), vol.attrs["time_dim"], vol.attrs["axis_units"]["x"]
    (True, 'time', 'm')
    """
    path = Path(path).expanduser()
    require_exists(path)
    src = str(path)
    backend = _Backend(path)
    lay = _layout(backend, source=src)
    chosen = select_fields([*lay.variables, *lay.vectors], fields, name_map, source=src)
    needed = list(
        dict.fromkeys(p for f in chosen.values() for p in lay.vectors.get(f, (f,)) if p is not None)
    )
    loader = _NetCDFSteps(backend, lay, src, needed)
    options = read_options()
    on_points = options.curvilinear == "native" and resolution is None
    if lay.aux is None and all(_evenly_spaced(c) for c in lay.coords):
        base = _uniform_volume(loader, lay, src)
        base = resample_uniform(base, check_resolution(resolution, source=src))
    elif on_points:
        base = _rectilinear_volume(loader, lay, src)
    elif lay.aux is not None:  # resampled as any curvilinear mesh
        base = open_mesh_series(
            source=src,
            loader=loader,
            labels=[f"{path} step {n}" for n in range(lay.times.size)],
            times=lay.times,
            physical_times=lay.physical,
            fields=needed,
            resolution=resolution,
            name_map=None,
            apply_axis_scale=False,
        )
    else:
        native = _native_resolution(lay, read_options().box) if resolution is None else None
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            base = open_mesh_series(
                source=src,
                loader=loader,
                labels=[f"{path} step {n}" for n in range(lay.times.size)],
                times=lay.times,
                physical_times=lay.physical,
                fields=needed,
                resolution=native or resolution,
                name_map=None,
                apply_axis_scale=False,  # the coordinates are scaled already
            )
        _reissue(caught, _uneven_reason(lay, native))
    frames: dict[str, FrameSource] = {
        vol_name: _assembled(base, lay.vectors[f]) if f in lay.vectors else base.fields[f]
        for vol_name, f in chosen.items()
    }
    volume = dataclasses.replace(base, fields=frames, attrs=dict(base.attrs))
    volume.attrs["centring"] = dict.fromkeys(chosen, "point")
    volume.attrs["units"] = {v: lay.units[f] for v, f in chosen.items() if f in lay.units}
    volume.attrs["grid_units"] = lay.coord_units
    volume.attrs["axis_units"] = lay.axis_units
    if lay.projection:
        volume.attrs["projection"] = lay.projection
    scale = read_options().axis_scale
    if scale is not None:
        volume.attrs["axis_scale_applied"] = list(scale)
    if lay.time_dim is not None:
        volume.attrs["time_dim"] = lay.time_dim
    if lay.time_units:
        volume.attrs["time_units"] = lay.time_units
    return volume
