"""Reader options that apply to every kind of file: the time dimension's name,
a per-axis scale to metres, and a region of interest.

:func:`auralize.io.open_volume` takes them as ``time_dim=``, ``axis_scale=`` and
``box=`` and makes them visible to the reader it calls through
:func:`current` (a context variable, set only while the file is opened), so
the mesh and netCDF readers can use them where they matter most: a mesh is
scaled before its grid is chosen, a region picks the cells whose size sets the
resolution.  Whatever a reader leaves undone, :func:`finish` does on the
volume it returns: it scales the grid's axes and keeps the grid points inside
the box (on a curvilinear grid read natively, the smallest index block whose
cells cover the box: :func:`index_block`).  Both are idempotent (a
reader marks a scale it applied in ``attrs["axis_scale_applied"]``; a volume
already inside its box is returned as it is, a curvilinear one with the box
noted in its ``attrs``).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Literal, cast

import numpy as np
from numpy.typing import NDArray

from auralize.errors import DataError, ParameterError
from auralize.volume import TimeVolume

__all__ = [
    "CURVILINEAR_MODES",
    "ReadOptions",
    "check_axis_scale",
    "check_box",
    "check_curvilinear",
    "current",
    "curvilinear_mode",
    "finish",
    "index_block",
    "reading",
]

#: How a structured curvilinear grid (PLOT3D, ``vtkStructuredGrid``) is read:
#: ``"native"`` on its own points (derivatives by its metric terms,
#: :mod:`auralize.curvilinear`), ``"resample"`` onto a uniform grid.
CURVILINEAR_MODES = ("native", "resample")
#: One of :data:`CURVILINEAR_MODES`.
CurvilinearMode = Literal["native", "resample"]

Box = tuple[float, float, float, float, float, float]


@dataclass(frozen=True, kw_only=True)
class ReadOptions:
    """What the user asked of every reader.

    Parameters
    ----------
    time_dim : str or None
        Name of the time dimension (netCDF); ``None`` finds it (CF ``axis="T"``,
        ``units="... since ..."``, or a common name).
    axis_scale : (float, float, float) or None
        Metres per file unit along x, y and z; ``None`` keeps the file's units
        (a reader that knows them, such as netCDF with degrees or pressure
        levels, converts them to metres itself).
    box : (xmin, xmax, ymin, ymax, zmin, zmax) or None
        Region of interest in metres (after ``axis_scale``); the volume keeps
        the grid points inside it (a curvilinear grid the smallest index block
        whose cells cover it), and a mesh's resolution is chosen from the cells
        inside it.
    curvilinear : {"native", "resample"}
        How a structured curvilinear grid is read (:data:`CURVILINEAR_MODES`);
        a ``resolution`` resamples it too, a ``box`` crops it natively.

    Examples
    --------
    >>> opts = ReadOptions(axis_scale=(1.0, 1.0, 1000.0))
    >>> with reading(opts):
    ...     current().axis_scale
    (1.0, 1.0, 1000.0)
    >>> current() == ReadOptions()
    True
    """

    time_dim: str | None = None
    axis_scale: tuple[float, float, float] | None = None
    box: Box | None = None
    #: ``"native"`` (default) or ``"resample"`` (:data:`CURVILINEAR_MODES`); a
    #: ``resolution`` resamples a curvilinear grid too, a ``box`` crops it natively
    curvilinear: CurvilinearMode = "native"


_CURRENT: ContextVar[ReadOptions | None] = ContextVar("auralize_read_options", default=None)
_CURVILINEAR: ContextVar[CurvilinearMode] = ContextVar("auralize_curvilinear", default="native")


def check_curvilinear(value: object, *, source: str) -> CurvilinearMode:
    """Validate ``curvilinear=``: ``None`` (the :func:`curvilinear_mode` in force, by
    default ``"native"``) or one of :data:`CURVILINEAR_MODES`.

    Parameters
    ----------
    value : object
        What the user gave.
    source : str
        File name for messages.

    Returns
    -------
    {"native", "resample"}

    Raises
    ------
    ParameterError
        Anything else.

    Examples
    --------
    >>> check_curvilinear(None, source="f.vts"), check_curvilinear("resample", source="f.vts")
    ('native', 'resample')
    """
    if value is None:
        return _CURVILINEAR.get()
    if value not in CURVILINEAR_MODES:
        raise ParameterError(
            f"{source}: curvilinear={value!r}; give one of {', '.join(CURVILINEAR_MODES)} "
            f"(--resample reads a curvilinear grid resampled onto a uniform one)"
        )
    return cast(CurvilinearMode, str(value))


@contextlib.contextmanager
def curvilinear_mode(mode: CurvilinearMode) -> Iterator[CurvilinearMode]:
    """Make ``mode`` the default ``curvilinear=`` of every file opened inside (the
    command line's ``--resample``).

    A context manager; the mode in force before is restored on leaving it.

    Parameters
    ----------
    mode : {"native", "resample"}
        The default of ``curvilinear=`` inside.

    Yields
    ------
    {"native", "resample"}
        ``mode``.

    Raises
    ------
    ParameterError
        ``mode`` is not one of :data:`CURVILINEAR_MODES`.

    Examples
    --------
    >>> with curvilinear_mode("resample"):
    ...     check_curvilinear(None, source="f.vts")
    'resample'
    >>> check_curvilinear(None, source="f.vts")
    'native'
    """
    token = _CURVILINEAR.set(check_curvilinear(mode, source="curvilinear_mode"))
    try:
        yield mode
    finally:
        _CURVILINEAR.reset(token)


def current() -> ReadOptions:
    """The options of the file being opened (defaults outside :func:`reading`).

    Returns
    -------
    ReadOptions

    Examples
    --------
    >>> with reading(ReadOptions(time_dim="t")):
    ...     current().time_dim
    't'
    >>> current().time_dim is None
    True
    """
    return _CURRENT.get() or ReadOptions()


@contextlib.contextmanager
def reading(options: ReadOptions) -> Iterator[ReadOptions]:
    """Make ``options`` the :func:`current` ones while a file is opened.

    A context manager (a context variable: each thread and task sees its
    own); the options in force before are restored on leaving it.

    Parameters
    ----------
    options : ReadOptions
        The options of the file being opened.

    Yields
    ------
    ReadOptions
        ``options``.

    Examples
    --------
    >>> with reading(ReadOptions(box=(0, 1, 0, 1, 0, 1))) as opts:
    ...     current() is opts
    True
    """
    token = _CURRENT.set(options)
    try:
        yield options
    finally:
        _CURRENT.reset(token)


def check_axis_scale(value: object, *, source: str) -> tuple[float, float, float] | None:
    """Validate ``axis_scale=``: ``None``, one positive number, or three.

    Parameters
    ----------
    value : object
        What the user gave: None, a number or three (metres per file unit
        along x, y, z).
    source : str
        File name for messages.

    Returns
    -------
    (float, float, float) or None

    Raises
    ------
    ParameterError
        Anything but one or three finite positive numbers (or None).

    Examples
    --------
    >>> check_axis_scale(2, source="f.nc"), check_axis_scale([1, 1, 1e3], source="f.nc")
    ((2.0, 2.0, 2.0), (1.0, 1.0, 1000.0))
    """
    if value is None:
        return None
    items: Sequence[object]
    if isinstance(value, int | float | np.number) and not isinstance(value, bool):
        items = [value, value, value]
    elif isinstance(value, Sequence | np.ndarray) and not isinstance(value, str):
        items = list(value)
    else:
        items = []
    try:
        out = tuple(float(v) for v in items)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        out = ()
    if len(out) != 3 or not all(math.isfinite(v) and v > 0 for v in out):
        raise ParameterError(
            f"{source}: axis_scale={value!r} is not valid; give metres per file unit as one "
            f"positive number or three (x, y, z), e.g. --axis-scale 1,1,1000 for z in km"
        )
    return (out[0], out[1], out[2])


def check_box(value: object, *, source: str) -> Box | None:
    """Validate ``box=``: ``None`` or six finite numbers with min <= max on each axis.

    Parameters
    ----------
    value : object
        What the user gave: None or ``(xmin, xmax, ymin, ymax, zmin, zmax)``
        in metres.
    source : str
        File name for messages.

    Returns
    -------
    (xmin, xmax, ymin, ymax, zmin, zmax) or None
        Floats.

    Raises
    ------
    ParameterError
        Not six finite numbers, or a minimum above its maximum.

    Examples
    --------
    >>> check_box((0, 1, 0, 1, -1, 1), source="f.vtu")
    (0.0, 1.0, 0.0, 1.0, -1.0, 1.0)
    """
    if value is None:
        return None
    try:
        out = tuple(float(v) for v in value)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        out = ()
    if len(out) != 6 or not all(math.isfinite(v) for v in out):
        raise ParameterError(
            f"{source}: box={value!r} is not valid; give six numbers xmin,xmax,ymin,ymax,"
            f"zmin,zmax in metres"
        )
    bad = [a for i, a in enumerate("xyz") if not out[2 * i] <= out[2 * i + 1]]
    if bad:
        raise ParameterError(
            f"{source}: box={value!r} has its minimum above its maximum along {', '.join(bad)}; "
            f"give xmin,xmax,ymin,ymax,zmin,zmax"
        )
    return out  # type: ignore[return-value]


@dataclass
class _Window:
    """Frames of ``inner`` cut to the index window ``(k0, k1, j0, j1, i0, i1)``."""

    inner: object
    window: tuple[int, int, int, int, int, int]

    @property
    def n_steps(self) -> int:
        return int(self.inner.n_steps)  # type: ignore[attr-defined]

    @property
    def frame_shape(self) -> tuple[int, ...]:
        k0, k1, j0, j1, i0, i1 = self.window
        rest = tuple(self.inner.frame_shape[3:])  # type: ignore[attr-defined]
        return (k1 - k0, j1 - j0, i1 - i0, *rest)

    def read(self, step: int) -> NDArray[np.floating]:
        k0, k1, j0, j1, i0, i1 = self.window
        return np.ascontiguousarray(self.inner.read(step)[k0:k1, j0:j1, i0:i1])  # type: ignore[attr-defined]


def _scaled(volume: TimeVolume, scale: tuple[float, float, float]) -> TimeVolume:
    s = np.asarray(scale, dtype=np.float64)
    out = TimeVolume(
        origin=np.asarray(volume.origin) * s,
        spacing=np.asarray(volume.spacing) * s,
        dims=volume.dims,
        times=volume.times,
        fields=volume.fields,
        physical_times=volume.physical_times,
        source=volume.source,
        check_finite=volume.check_finite,
        attrs=dict(volume.attrs),
        valid=volume.valid,
        coords=None if volume.coords is None else volume.coords * s,
    )
    out.attrs["axis_scale_applied"] = list(scale)
    return out


def index_block(
    coords: NDArray[np.float64], box: Box, *, source: str = "<memory>"
) -> tuple[int, int, int, int, int, int]:
    """The smallest index block ``(i0, i1, j0, j1, k0, k1)`` (half-open) of a curvilinear
    grid's points ``coords (nz, ny, nx, 3)`` whose cells cover ``box``: every cell
    (between neighbouring points; along an axis of one point, the point) that
    overlaps the box, with its corners.

    A cell overlaps the box when its corners' bounding box does, by more than
    1e-9 of the grid's extent (a cell that only touches a face of the box is
    left out; along an axis on which the box is thinner than that, touching
    counts), along each axis on which the grid is not flat (a one-layer grid is
    kept whatever the box says across it).  A cell of a strongly warped grid
    may overlap the box by its bounding box only: the block is then a little
    larger than it needs be.  A box that overlaps no cell is an error.

    Parameters
    ----------
    coords : ndarray, shape (nz, ny, nx, 3)
        The grid's point positions in metres.
    box : (xmin, xmax, ymin, ymax, zmin, zmax)
        Region of interest in metres.
    source : str
        File name for messages.

    Returns
    -------
    (i0, i1, j0, j1, k0, k1) : tuple of int
        Half-open index ranges along x (the last array axis), y and z.

    Raises
    ------
    DataError
        The box overlaps no cell of the grid.

    Examples
    --------
    >>> zz, yy, xx = np.meshgrid(np.arange(3.0), np.arange(4.0), np.arange(5.0), indexing="ij")
    >>> c = np.stack([xx + 0.1 * yy, yy, zz], axis=-1)  # x sheared along y
    >>> index_block(c, (0.9, 2.05, 0.0, 1.5, 1.0, 2.0))
    (0, 4, 0, 3, 1, 3)
    """
    lo_c, hi_c = coords, coords
    for ax in range(3):  # the corners' extremes, one index direction at a time
        if coords.shape[ax] > 1:
            lo_v, hi_v = np.moveaxis(lo_c, ax, 0), np.moveaxis(hi_c, ax, 0)
            lo_c = np.moveaxis(np.minimum(lo_v[:-1], lo_v[1:]), 0, ax)
            hi_c = np.moveaxis(np.maximum(hi_v[:-1], hi_v[1:]), 0, ax)
    flat = coords.reshape(-1, 3)
    lo, hi = flat.min(axis=0), flat.max(axis=0)
    tol = 1e-9 * float(np.max(hi - lo))
    meets = np.ones(lo_c.shape[:3], dtype=bool)
    for a in range(3):
        if hi[a] - lo[a] <= tol:
            continue
        b0, b1 = float(box[2 * a]), float(box[2 * a + 1])
        if b1 - b0 > 2 * tol:
            meets &= (lo_c[..., a] < b1 - tol) & (hi_c[..., a] > b0 + tol)
        else:
            meets &= (lo_c[..., a] <= b1 + tol) & (hi_c[..., a] >= b0 - tol)
    if not meets.any():
        raise DataError(
            f"{source}: the box {', '.join(f'{v:g}' for v in box)} m overlaps no cell of the "
            f"curvilinear grid (it spans x[{lo[0]:g}, {hi[0]:g}] y[{lo[1]:g}, {hi[1]:g}] "
            f"z[{lo[2]:g}, {hi[2]:g}] m)"
        )
    out: list[int] = []
    for ax in (2, 1, 0):  # i (x fastest: the last array axis), j, k
        other = tuple(o for o in range(3) if o != ax)
        hit = np.flatnonzero(meets.any(axis=other))
        out += [int(hit[0]), int(hit[-1]) + (2 if coords.shape[ax] > 1 else 1)]
    return (out[0], out[1], out[2], out[3], out[4], out[5])


def _cropped_curvilinear(volume: TimeVolume, box: Box) -> TimeVolume:
    """A curvilinear volume cut to :func:`index_block` of ``box``, natively and lazily
    (``attrs["box"]`` and ``attrs["index_block"]`` say so, also when the block is the
    whole grid: saving it resamples it over the box)."""
    import dataclasses

    from auralize.curvilinear import nominal_spacing

    assert volume.coords is not None
    i0, i1, j0, j1, k0, k1 = index_block(volume.coords, box, source=volume.source)
    nx, ny, nz = volume.dims
    said = {
        "box": list(box),
        "index_block": {
            "i": [i0, i1 - 1],
            "j": [j0, j1 - 1],
            "k": [k0, k1 - 1],
            "of": [nx, ny, nz],
        },
    }
    if (i0, i1, j0, j1, k0, k1) == (0, nx, 0, ny, 0, nz):
        return dataclasses.replace(volume, attrs={**volume.attrs, **said})
    coords = volume.coords[k0:k1, j0:j1, i0:i1].copy()
    dims = (i1 - i0, j1 - j0, k1 - k0)
    # an index direction cut to one point keeps its nominal length (its thickness)
    spacing = np.where(np.asarray(dims) > 1, nominal_spacing(coords), volume.spacing)
    window = (k0, k1, j0, j1, i0, i1)
    out = TimeVolume(
        origin=coords.reshape(-1, 3).min(axis=0),
        spacing=spacing,
        dims=dims,
        times=volume.times,
        fields={n: _Window(src, window) for n, src in volume.fields.items()},
        physical_times=volume.physical_times,
        source=volume.source,
        check_finite=volume.check_finite,
        attrs=dict(volume.attrs),
        valid=None if volume.valid is None else volume.valid[k0:k1, j0:j1, i0:i1].copy(),
        coords=coords,
    )
    out.attrs.update(said)
    return out


def _cropped(volume: TimeVolume, box: Box) -> TimeVolume:
    if volume.coords is not None:
        return _cropped_curvilinear(volume, box)
    origin = np.asarray(volume.origin, dtype=np.float64)
    spacing = np.asarray(volume.spacing, dtype=np.float64)
    lo_hi: list[tuple[int, int]] = []
    for a in range(3):
        n = int(volume.dims[a])
        if n == 1:  # a flat axis is kept whatever the box says about it
            lo_hi.append((0, 1))
            continue
        tol = 1e-9 * spacing[a]
        i0 = max(0, math.ceil((box[2 * a] - origin[a] - tol) / spacing[a]))
        i1 = min(n - 1, math.floor((box[2 * a + 1] - origin[a] + tol) / spacing[a]))
        if i1 < i0:
            b = volume.bounds
            raise DataError(
                f"{volume.source}: the box {', '.join(f'{v:g}' for v in box)} m holds no grid "
                f"point along {'xyz'[a]} (the volume spans {b[2 * a]:g} .. {b[2 * a + 1]:g} m)"
            )
        lo_hi.append((i0, i1 + 1))
    (i0, i1), (j0, j1), (k0, k1) = lo_hi
    if (i0, i1, j0, j1, k0, k1) == (0, volume.dims[0], 0, volume.dims[1], 0, volume.dims[2]):
        return volume
    window = (k0, k1, j0, j1, i0, i1)
    valid = None if volume.valid is None else volume.valid[k0:k1, j0:j1, i0:i1].copy()
    out = TimeVolume(
        origin=origin + spacing * np.array([i0, j0, k0]),
        spacing=spacing,
        dims=(i1 - i0, j1 - j0, k1 - k0),
        times=volume.times,
        fields={n: _Window(src, window) for n, src in volume.fields.items()},
        physical_times=volume.physical_times,
        source=volume.source,
        check_finite=volume.check_finite,
        attrs=dict(volume.attrs),
        valid=valid,
    )
    out.attrs["box"] = list(box)
    return out


def finish(volume: TimeVolume, options: ReadOptions) -> TimeVolume:
    """Apply what the reader left of ``options`` to ``volume``.

    The axis scale (unless the reader applied it) multiplies the origin and
    spacing (a curvilinear grid's points); the box keeps the grid points inside
    it, lazily (frames are cut as they are read): on a curvilinear grid the
    smallest index block whose cells cover the box (:func:`index_block`;
    ``attrs["index_block"]`` gives its inclusive index ranges).

    Parameters
    ----------
    volume : TimeVolume
        What the reader returned.
    options : ReadOptions
        The options the file was opened with.

    Returns
    -------
    TimeVolume
        ``volume`` itself when nothing is left to do; otherwise a new volume
        over the same frame sources (``attrs["axis_scale_applied"]``,
        ``attrs["box"]`` say what was done).

    Raises
    ------
    DataError
        The box holds no grid point (or overlaps no cell of a curvilinear grid).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.zeros((1, 3, 4, 5))}, times=[0.0])
    >>> out = finish(vol, ReadOptions(axis_scale=(2.0, 2.0, 2.0), box=(0, 4, 0, 2, 0, 8)))
    >>> vol.dims, out.dims, out.spacing.tolist()
    ((5, 4, 3), (3, 2, 3), [2.0, 2.0, 2.0])
    >>> finish(vol, ReadOptions()) is vol
    True
    """
    if options.axis_scale is not None and "axis_scale_applied" not in volume.attrs:
        volume = _scaled(volume, options.axis_scale)
    if options.box is not None:
        volume = _cropped(volume, options.box)
    return volume
