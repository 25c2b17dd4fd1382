"""Detected sources to and from files: HDF5 and ParaView ``.pvd`` + ``.vtp`` point sets.

HDF5 layout (``auralize_format="sources"``, ``version=1``)::

    /time (T,)            step times, s
    /offsets (T+1,)       sources of step n are rows offsets[n]:offsets[n+1]
    /index (N,) int64     flat vertex index (C order of (nz, ny, nx))
    /position (N, 3)      metres
    /kind (N,) int8       1 monopole, 2 dipole, 3 quadrupole (attr legend, JSON)
    /strength (N,)        signed strength of the vertex's type
    /radius (N,)          ΔV-sphere radius, m
    attrs: origin, spacing, dims, thresholds (3,), meta (JSON)

The ``.pvd`` export writes one ``.vtp`` per step (point data ``kind``,
``strength``, ``radius``, ``volume``, and ``rgb``: the type's colour in the
palette of :mod:`auralize.palette`, shown as is with "Map Scalars" off; field
data ``kind_code``/``kind_name``, the legend of the codes) so ParaView can
glyph them as spheres in the viewer's colours.  VTKHDF (``.vtkhdf``):
:func:`auralize.io.vtkhdf_write.write_sources_vtkhdf`.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from numpy.typing import NDArray

from auralize.errors import AuralizeError, DataError, FormatError
from auralize.io.vtkhdf_write import KIND_LEGEND
from auralize.runtime.files import atomic_hdf5, stop_if_failed, write_collection
from auralize.runtime.json_check import parse_json
from auralize.sources.detection import SourceFrame, SourceSeries

FORMAT = "sources"
VERSION = 1


def save_sources_h5(series: SourceSeries, path: str | Path) -> None:
    """Write a :class:`SourceSeries` to HDF5 atomically.

    The layout is the module docstring's (``auralize_format="sources"``,
    version 1): the grid, the thresholds and ``meta`` (as JSON) in root
    attributes, the sources of every step as rows.  The file is written to
    a temporary beside ``path`` and renamed onto it, so a failed write
    leaves ``path`` as it was.

    Parameters
    ----------
    series : SourceSeries
        The sources of every step (:func:`auralize.sources.detection.detect`).
    path : str or Path
        The ``.h5`` file to write (replaced if it exists); its folder must exist.

    Raises
    ------
    OutputError
        The folder cannot be written, the disk has too little space for the
        file, or a write failed; ``path`` is untouched.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.sources.detection import SourceFrame, SourceSeries
    >>> frame = SourceFrame(index=np.array([0, 7]), kind=np.array([1, 3], dtype=np.int8),
    ...                     strength=np.array([2.0, -0.5]), radius=np.array([0.1, 0.2]))
    >>> series = SourceSeries(frames=[frame], times=np.array([0.0]), origin=np.zeros(3),
    ...                       spacing=np.full(3, 0.5), dims=(2, 2, 2), thresholds=np.zeros(3))
    >>> save_sources_h5(series, "sources.h5")
    >>> load_sources_h5("sources.h5").frames[0].strength.tolist()
    [2.0, -0.5]
    """
    frames = series.frames
    offsets = np.zeros(len(frames) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([f.index.size for f in frames])

    def cat(name, dt):
        return (
            np.concatenate([getattr(f, name) for f in frames]).astype(dt)
            if frames
            else np.zeros(0, dt)
        )

    index = cat("index", np.int64)
    n, steps = int(index.size), len(frames)
    nbytes = 57.0 * n + 16.0 * steps + 65536.0  # rows, times and offsets, HDF5 overhead
    what = f"{n} source points over {steps} steps"
    with atomic_hdf5(path, nbytes=nbytes, what=what) as h:
        h.attrs["auralize_format"] = FORMAT
        h.attrs["version"] = VERSION
        h.attrs["origin"] = series.origin
        h.attrs["spacing"] = series.spacing
        h.attrs["dims"] = np.asarray(series.dims)
        h.attrs["thresholds"] = series.thresholds
        h.attrs["meta"] = json.dumps(series.meta, default=str)
        h["time"] = series.times
        h["offsets"] = offsets
        h["index"] = index
        stop_if_failed(h)
        h["position"] = series.positions(index) if index.size else np.zeros((0, 3))
        stop_if_failed(h)
        h["kind"] = cat("kind", np.int8)
        h["kind"].attrs["legend"] = json.dumps(KIND_LEGEND)  # {"1": "monopole", ...}
        h["strength"] = cat("strength", np.float64)
        stop_if_failed(h)
        h["radius"] = cat("radius", np.float64)


def load_sources_h5(path: str | Path) -> SourceSeries:
    """Read a sources file written by :func:`save_sources_h5`, checking every field.

    Parameters
    ----------
    path : str or Path
        The ``.h5`` sources file.

    Returns
    -------
    SourceSeries
        One frame per step; positions from the grid (``origin``, ``spacing``,
        ``dims``), or from ``/position`` for sources detected on a curvilinear
        grid (``coords``, NaN at the points that are no source: see
        :func:`load_sources_for`).

    Raises
    ------
    FormatError
        Missing, not HDF5, not a sources file, another version, or links to
        other files.
    DataError
        A field out of its valid range, in one line naming the file, the field
        (and the first bad row) and what is valid: missing datasets or
        attributes; ``dims`` not 3 whole numbers >= 1; ``origin``/``spacing``
        not finite (spacing > 0); thresholds NaN or negative; ``meta`` not a
        JSON object; step times not finite and strictly increasing;
        ``offsets`` not rising from 0 to the number of sources, one more than
        the steps; ``index``, ``kind``, ``strength``, ``radius`` (and
        ``position``) of other lengths; an index outside the grid or listed
        twice in a step; a kind code other than 1, 2, 3; a strength not finite;
        a radius not finite and > 0; a position not where its index lies.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.sources.detection import SourceFrame, SourceSeries
    >>> frame = SourceFrame(index=np.array([0, 7]), kind=np.array([1, 3], dtype=np.int8),
    ...                     strength=np.array([2.0, -0.5]), radius=np.array([0.1, 0.2]))
    >>> series = SourceSeries(frames=[frame], times=np.array([0.0]), origin=np.zeros(3),
    ...                       spacing=np.full(3, 0.5), dims=(2, 2, 2), thresholds=np.zeros(3))
    >>> save_sources_h5(series, "sources.h5")
    >>> back = load_sources_h5("sources.h5")
    >>> back.dims, back.frames[0].kind.tolist(), back.frames[0].radius.tolist()
    ((2, 2, 2), [1, 3], [0.1, 0.2])
    >>> back.positions(back.frames[0].index).tolist()  # vertex 7: (x, y, z) = (1, 1, 1) · 0.5 m
    [[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]]
    >>> load_sources_h5("missing.h5")
    Traceback (most recent call last):
    ...
    auralize.errors.FormatError: sources file 'missing.h5' does not exist
    """
    p = Path(path)
    if not p.exists():
        raise FormatError(f"sources file {str(p)!r} does not exist")
    try:
        h = h5py.File(p, "r")
    except OSError as exc:
        raise FormatError(f"{p}: not a readable HDF5 file ({exc})") from None
    try:
        with h:
            return _read_sources(h, p)
    except AuralizeError:
        raise
    except (OSError, KeyError, ValueError, RuntimeError, TypeError, IndexError) as exc:
        raise FormatError(
            f"{p}: not a readable auralize sources file ({type(exc).__name__}: "
            f"{' '.join(str(exc).split())})"
        ) from None


#: the datasets and root attributes :func:`load_sources_h5` reads (``/position`` is checked
#: when present: it repeats what ``/index`` says on the grid)
DATASETS = ("time", "offsets", "index", "kind", "strength", "radius")
ATTRS = ("origin", "spacing", "dims", "thresholds", "meta")
#: the kind codes a sources file may hold
KIND_CODES = tuple(int(k) for k in KIND_LEGEND)
#: largest grid (points) a sources file may describe
MAX_POINTS = 2**40


def _fault(p: Path, field: str, what: str) -> DataError:
    return DataError(f"{p}: {field} {what}")


def _first(bad: Any) -> int:
    """Index of the first True of a boolean array."""
    return int(np.argmax(bad))


def _attr(h: h5py.File, p: Path, name: str, *, kinds: str = "iuf") -> np.ndarray:
    """A root attribute of 3 numbers as an array (3,)."""
    a = np.asarray(h.attrs[name])
    if a.dtype.kind not in kinds or a.shape != (3,):
        raise _fault(p, f"attribute {name!r}", f"must be 3 numbers, got {a.tolist()!r:.80}")
    return a


def _dataset(
    h: h5py.File, p: Path, name: str, shape: tuple[int, ...], *, kinds: str, what: str
) -> np.ndarray:
    """Dataset ``/name`` read after its shape and type are checked."""
    ds = h[name]
    if not isinstance(ds, h5py.Dataset):
        raise _fault(p, f"/{name}", f"must be a dataset of {what}, not a group")
    if ds.dtype.kind not in kinds or ds.shape != shape:
        raise _fault(
            p, f"/{name}", f"must be {what} of shape {shape}, got {ds.dtype} of shape {ds.shape}"
        )
    return np.asarray(ds[()])


def _read_grid(
    h: h5py.File, p: Path
) -> tuple[
    tuple[int, ...],
    int,
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    dict[str, Any],
]:
    """The grid's attributes of a sources file, checked: dims, their product, origin,
    spacing, the detection thresholds and the metadata."""
    dims_a = _attr(h, p, "dims")
    if not (
        np.all(np.isfinite(dims_a)) and np.all(dims_a == np.round(dims_a)) and np.all(dims_a >= 1)
    ):
        raise _fault(
            p,
            "attribute 'dims'",
            f"must be 3 whole numbers >= 1 (nx, ny, nz), got {dims_a.tolist()}",
        )
    dims = tuple(int(d) for d in dims_a)
    n_points = math.prod(dims)
    if n_points > MAX_POINTS:
        raise _fault(
            p,
            "attribute 'dims'",
            f"{dims} make {n_points:.3g} grid points; at most {MAX_POINTS:.3g} are read",
        )
    origin = _attr(h, p, "origin").astype(np.float64)
    spacing = _attr(h, p, "spacing").astype(np.float64)
    if not np.all(np.isfinite(origin)):
        raise _fault(p, "attribute 'origin'", f"must be 3 finite numbers, got {origin.tolist()}")
    if not (np.all(np.isfinite(spacing)) and np.all(spacing > 0)):
        raise _fault(
            p, "attribute 'spacing'", f"must be 3 finite numbers > 0 m, got {spacing.tolist()}"
        )
    thresholds = _attr(h, p, "thresholds", kinds="iuf").astype(np.float64)
    if np.any(np.isnan(thresholds)) or np.any(thresholds < 0):
        raise _fault(
            p,
            "attribute 'thresholds'",
            f"must be 3 numbers >= 0 (inf: none), got {thresholds.tolist()}",
        )
    meta_raw = h.attrs["meta"]
    if isinstance(meta_raw, bytes):
        meta_raw = meta_raw.decode("utf-8", "replace")
    if not isinstance(meta_raw, str):
        raise _fault(p, "attribute 'meta'", f"must be JSON text, got {type(meta_raw).__name__}")
    meta = parse_json(meta_raw, f"{p}: attribute 'meta'", error=DataError, nonfinite=True)
    if not isinstance(meta, dict):
        raise _fault(p, "attribute 'meta'", f"must be a JSON object, got {type(meta).__name__}")
    return dims, n_points, origin, spacing, thresholds, meta


def _read_times(h: h5py.File, p: Path) -> NDArray[np.float64]:
    """The step times of a sources file, checked: finite and strictly increasing."""
    t_ds = h["time"]
    if not isinstance(t_ds, h5py.Dataset) or t_ds.ndim != 1 or t_ds.shape[0] < 1:
        raise _fault(p, "/time", "must be a 1-D dataset of at least one step time in seconds")
    n_steps = int(t_ds.shape[0])
    times = _dataset(h, p, "time", (n_steps,), kinds="iuf", what="step times (s)").astype(
        np.float64
    )
    if not np.all(np.isfinite(times)):
        k = _first(~np.isfinite(times))
        raise _fault(p, f"/time[{k}]", f"= {times[k]} is not finite; step times are finite seconds")
    if np.any(np.diff(times) <= 0):
        k = _first(np.diff(times) <= 0)
        raise _fault(
            p,
            "/time",
            f"must be strictly increasing; t[{k}]={times[k]:g} >= t[{k + 1}]={times[k + 1]:g} s",
        )
    return times


def _read_sources(h: h5py.File, p: Path) -> SourceSeries:
    """Read a sources file and check every field the writer puts there (one-line DataError)."""
    from auralize.runtime.hdf5safe import check_self_contained

    check_self_contained(h, p)
    if h.attrs.get("auralize_format") != FORMAT:
        raise FormatError(f"{p}: not an auralize sources file (auralize_format != 'sources')")
    version = np.asarray(h.attrs.get("version", -1))
    if version.shape != () or version.dtype.kind not in "iu" or int(version) != VERSION:
        raise FormatError(f"{p}: sources file version {h.attrs.get('version')} is not {VERSION}")
    missing = [f"/{n}" for n in DATASETS if n not in h] + [
        f"attribute {n!r}" for n in ATTRS if n not in h.attrs
    ]
    if missing:
        raise DataError(
            f"{p}: missing {', '.join(missing)}; a sources file holds "
            f"{', '.join('/' + n for n in DATASETS)} and the attributes "
            f"{', '.join(ATTRS)} ('auralize detect -o SOURCES.h5' writes them)"
        )

    dims, n_points, origin, spacing, thresholds, meta = _read_grid(h, p)
    times = _read_times(h, p)
    n_steps = times.size

    # the sources: sizes before contents (nothing larger than the grid is read)
    i_ds = h["index"]
    if not isinstance(i_ds, h5py.Dataset) or i_ds.ndim != 1:
        raise _fault(p, "/index", "must be a 1-D dataset of flat grid indices")
    n = int(i_ds.shape[0])
    if n > n_steps * n_points:
        raise _fault(
            p, "/index", f"holds {n} sources, more than {n_steps} steps x {n_points} grid points"
        )
    for name in ("kind", "strength", "radius"):
        ds = h[name]
        if not isinstance(ds, h5py.Dataset) or ds.shape != (n,):
            got = ds.shape if isinstance(ds, h5py.Dataset) else "a group"
            raise _fault(
                p,
                f"/{name}",
                f"must hold one value per source, shape ({n},) like /index, got {got}",
            )
    off = _dataset(
        h,
        p,
        "offsets",
        (n_steps + 1,),
        kinds="iu",
        what=f"integer row offsets (one more than the {n_steps} steps)",
    ).astype(np.int64)
    if off[0] != 0 or off[-1] != n or np.any(np.diff(off) < 0):
        raise _fault(
            p,
            "/offsets",
            f"must rise from 0 to {n} (the number of sources) without "
            f"decreasing, got {off[:8].tolist()}"
            f"{'...' if off.size > 8 else ''} ending {int(off[-1])}",
        )
    idx = _dataset(h, p, "index", (n,), kinds="iu", what="flat grid indices").astype(np.int64)
    bad = (idx < 0) | (idx >= n_points)
    if bad.any():
        k = _first(bad)
        raise _fault(
            p,
            f"/index[{k}]",
            f"= {idx[k]} is outside the grid {dims}: valid flat indices are 0..{n_points - 1}",
        )
    kind = _dataset(h, p, "kind", (n,), kinds="iu", what="kind codes")
    bad = ~np.isin(kind, KIND_CODES)
    if bad.any():
        k = _first(bad)
        raise _fault(
            p,
            f"/kind[{k}]",
            f"= {kind[k]} is not a kind code; valid: "
            f"{', '.join(f'{c} {m}' for c, m in KIND_LEGEND.items())}",
        )
    strength = _dataset(h, p, "strength", (n,), kinds="iuf", what="strengths").astype(np.float64)
    bad = ~np.isfinite(strength)
    if bad.any():
        k = _first(bad)
        raise _fault(
            p, f"/strength[{k}]", f"= {strength[k]} is not finite; strengths are finite numbers"
        )
    radius = _dataset(h, p, "radius", (n,), kinds="iuf", what="radii (m)").astype(np.float64)
    bad = ~(np.isfinite(radius) & (radius > 0))
    if bad.any():
        k = _first(bad)
        raise _fault(p, f"/radius[{k}]", f"= {radius[k]} m; ΔV-sphere radii are finite and > 0 m")
    step = np.repeat(np.arange(n_steps), np.diff(off))
    order = np.lexsort((idx, step))
    dup = (np.diff(step[order]) == 0) & (np.diff(idx[order]) == 0)
    if dup.any():
        r = int(order[_first(dup)])
        raise _fault(
            p,
            "/index",
            f"lists vertex {idx[r]} twice at step {step[r]}; each vertex "
            f"is at most one source per step",
        )
    series = SourceSeries(
        frames=[],
        times=times,
        origin=origin,
        spacing=spacing,
        dims=dims,  # type: ignore[arg-type]
        thresholds=thresholds,
        meta=meta,
    )
    if meta.get("grid") == "curvilinear":
        # detected on a curvilinear grid: the positions are its points (no formula gives
        # them); the points of the sources are known, the others NaN until
        # load_sources_for() puts the volume's own points in
        if "position" not in h:
            raise _fault(
                p,
                "/position",
                "is missing; sources detected on a curvilinear grid need their positions",
            )
        pos = _dataset(h, p, "position", (n, 3), kinds="iuf", what="positions (m)").astype(
            np.float64
        )
        nx, ny, nz = (int(d) for d in dims)
        coords = np.full((nz * ny * nx, 3), np.nan)
        coords[idx] = pos
        series.coords = coords.reshape(nz, ny, nx, 3)
    elif "position" in h:
        pos = _dataset(h, p, "position", (n, 3), kinds="iuf", what="positions (m)").astype(
            np.float64
        )
        tol = 1e-6 * float(spacing.min())
        far = ~(np.abs(pos - series.positions(idx)) <= tol + 1e-9 * np.abs(pos)).all(axis=1)
        if far.any():
            k = _first(far)
            raise _fault(
                p,
                f"/position[{k}]",
                f"= {pos[k].tolist()} is not where /index[{k}] "
                f"= {idx[k]} lies on the grid "
                f"({series.positions(idx[k]).tolist()})",
            )
    kind8 = kind.astype(np.int8)
    series.frames = [
        SourceFrame(index=idx[a:b], kind=kind8[a:b], strength=strength[a:b], radius=radius[a:b])
        for a, b in itertools.pairwise(off)
    ]
    return series


def save_sources_pvd(series: SourceSeries, path: str | Path) -> None:
    """Write ``NAME.pvd`` plus ``NAME_data/step_NNNN.vtp`` (one point set per step), atomically.

    The folder is written under a fresh name (``NAME_data``, or ``NAME_data.1``
    ... while the previous version holds that name) and the ``.pvd`` replaced
    in one rename (:func:`auralize.runtime.files.write_collection`); an existing
    ``NAME_data`` that auralize did not write is never replaced.  Each point
    set holds the point data ``kind``, ``strength``, ``radius`` (m),
    ``volume`` (ΔV, m³) and ``rgb`` (the type's colour), and the field data
    ``kind_code``/``kind_name`` (the legend of the codes).

    Parameters
    ----------
    series : SourceSeries
        The sources of every step.
    path : str or Path
        The ``.pvd`` file to write; the data folder goes beside it.

    Raises
    ------
    OutputError
        The data folder's name is taken by a folder auralize did not write
        for this ``.pvd``, or the files cannot be written.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.sources.detection import SourceFrame, SourceSeries
    >>> frame = SourceFrame(index=np.array([0, 7]), kind=np.array([1, 3], dtype=np.int8),
    ...                     strength=np.array([2.0, -0.5]), radius=np.array([0.1, 0.2]))
    >>> series = SourceSeries(frames=[frame], times=np.array([0.0]), origin=np.zeros(3),
    ...                       spacing=np.full(3, 0.5), dims=(2, 2, 2), thresholds=np.zeros(3))
    >>> save_sources_pvd(series, "sources.pvd")
    >>> import pyvista as pv
    >>> step = pv.read("sources_data/step_0000.vtp")
    >>> step.n_points, step.point_data["kind"].tolist(), step.point_data["strength"].tolist()
    (2, [1, 3], [2.0, -0.5])
    """
    import pyvista as pv

    from auralize.palette import type_rgb

    p = Path(path)

    def write_steps(folder: Path) -> list[tuple[float, str]]:
        entries = []
        for n, f in enumerate(series.frames):
            pts = series.positions(f.index) if f.index.size else np.zeros((0, 3))
            poly = pv.PolyData(pts)
            poly.point_data["kind"] = f.kind.astype(np.int8)
            poly.point_data["strength"] = f.strength
            poly.point_data["radius"] = f.radius
            poly.point_data["volume"] = f.volume
            if f.index.size:  # the palette: colour by it with "Map Scalars" off
                poly.point_data["rgb"] = type_rgb(f.kind)
            poly.field_data["kind_code"] = np.array(list(KIND_LEGEND), dtype=np.int32)
            poly.field_data["kind_name"] = list(KIND_LEGEND.values())
            name = f"step_{n:04d}.vtp"
            poly.save(folder / name)
            entries.append((float(series.times[n]), name))
        return entries

    write_collection(p, f"{p.stem}_data", write_steps)


def load_sources_for(path: str | Path, volume: Any) -> SourceSeries:
    """Read a sources file and check it was detected on ``volume``'s grid and times.

    Parameters
    ----------
    path : path-like
        The ``.h5`` written by ``auralize detect -o S.h5``.  A ``.pvd`` (for
        ParaView) is refused with a message saying so: it holds positions,
        not the grid the sources were detected on.
    volume : TimeVolume
        The volume about to be rendered.

    Returns
    -------
    SourceSeries
        The sources; for a curvilinear grid with ``coords`` the volume's own
        point positions.

    Raises
    ------
    FormatError
        ``path`` is a ``.pvd`` or not a sources file.
    DataError
        The sources belong to another grid (dims, origin, spacing, uniform or
        curvilinear, the curvilinear grid's points) or other times; the
        message names both.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.datasets.synthetic import make_monopole
    >>> from auralize.sources.detection import SourceFrame, SourceSeries
    >>> vol = make_monopole(size=4, steps=2)
    >>> frames = [SourceFrame(index=np.array([5]), kind=np.array([1], dtype=np.int8),
    ...                       strength=np.array([1.0]), radius=np.array([0.1]))] * 2
    >>> series = SourceSeries(frames=frames, times=vol.times, origin=vol.origin,
    ...                       spacing=vol.spacing, dims=vol.dims, thresholds=np.zeros(3))
    >>> save_sources_h5(series, "sources.h5")
    >>> load_sources_for("sources.h5", vol).n_steps
    2
    >>> load_sources_for("sources.h5", make_monopole(size=5, steps=2))
    Traceback (most recent call last):
    ...
    auralize.errors.DataError: sources.h5: these sources (...) do not belong to the grid of dataset:monopole: dims (4, 4, 4) vs (5, 5, 5) (sources vs volume); ...
    """
    p = Path(path)
    if p.suffix.lower() == ".pvd":
        raise FormatError(
            f"{p}: --sources needs the .h5 file 'auralize detect -o SOURCES.h5' writes; a .pvd "
            f"is for viewing in ParaView and does not record the grid the sources were "
            f"detected on (run detect again with -o {p.stem}.h5)"
        )
    series = load_sources_h5(p)
    mismatches = []
    if tuple(series.dims) != tuple(volume.dims):
        mismatches.append(f"dims {tuple(series.dims)} vs {tuple(volume.dims)}")
    if not np.allclose(series.origin, volume.origin, rtol=1e-9, atol=1e-12):
        mismatches.append(f"origin {series.origin.tolist()} vs {volume.origin.tolist()}")
    if not np.allclose(series.spacing, volume.spacing, rtol=1e-9, atol=1e-12):
        mismatches.append(f"spacing {series.spacing.tolist()} vs {volume.spacing.tolist()}")
    t_s, t_v = np.asarray(series.times), np.asarray(volume.times)
    if t_s.shape != t_v.shape or not np.allclose(t_s, t_v, rtol=1e-9, atol=1e-12):
        mismatches.append(
            f"{t_s.size} times {t_s[0]:g}..{t_s[-1]:g} s vs {t_v.size} times "
            f"{t_v[0]:g}..{t_v[-1]:g} s"
        )
    curvilinear = getattr(volume, "coords", None)
    if (series.coords is None) != (curvilinear is None):
        mismatches.append(
            "a curvilinear grid vs a uniform one"
            if series.coords is not None
            else "a uniform grid vs a curvilinear one"
        )
    elif series.coords is not None and curvilinear is not None and not mismatches:
        known = np.isfinite(series.coords[..., 0])
        scale = float(np.max(np.abs(curvilinear))) if curvilinear.size else 1.0
        if not np.allclose(series.coords[known], curvilinear[known], rtol=0.0, atol=1e-9 * scale):
            mismatches.append("source positions that are not the curvilinear grid's points")
        series.coords = curvilinear
    if mismatches:
        origin = series.meta.get("source", "another volume")
        raise DataError(
            f"{p}: these sources (detected on {origin}) do not belong to the grid of "
            f"{volume.source}: {'; '.join(mismatches)} (sources vs volume); detect them on this "
            f"volume with 'auralize detect {volume.source} -o SOURCES.h5' (same --resolution)"
        )
    return series
