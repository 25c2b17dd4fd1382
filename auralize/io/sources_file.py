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
palette of :mod:`auralize.scene.pictures`, shown as is with "Map Scalars" off; field
data ``kind_code``/``kind_name``, the legend of the codes) so ParaView can
glyph them as spheres in the viewer's colours.  VTKHDF (``.vtkhdf``):
:func:`auralize.io.vtkhdf_write.write_sources_vtkhdf`.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from auralize.errors import AuralizeError, DataError, FormatError
from auralize.io.files import atomic_path, write_collection
from auralize.io.vtkhdf_write import KIND_LEGEND
from auralize.sources.detection import SourceFrame, SourceSeries

FORMAT = "sources"
VERSION = 1


def save_sources_h5(series: SourceSeries, path: str | Path) -> None:
    """Write a :class:`SourceSeries` to HDF5 atomically."""
    frames = series.frames
    offsets = np.zeros(len(frames) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([f.index.size for f in frames])

    def cat(name, dt):
        return (np.concatenate([getattr(f, name) for f in frames]).astype(dt)
               if frames else np.zeros(0, dt))  # fmt: skip

    index = cat("index", np.int64)
    with atomic_path(path, suffix=".part.h5") as tmp, h5py.File(tmp, "w") as h:
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
        h["position"] = series.positions(index) if index.size else np.zeros((0, 3))
        h["kind"] = cat("kind", np.int8)
        h["kind"].attrs["legend"] = json.dumps(KIND_LEGEND)  # {"1": "monopole", ...}
        h["strength"] = cat("strength", np.float64)
        h["radius"] = cat("radius", np.float64)


def load_sources_h5(path: str | Path) -> SourceSeries:
    """Read a sources file written by :func:`save_sources_h5`."""
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


def _read_sources(h: h5py.File, p: Path) -> SourceSeries:
    from auralize.io.hdf5 import check_self_contained

    check_self_contained(h, p)
    if h.attrs.get("auralize_format") != FORMAT:
        raise FormatError(f"{p}: not an auralize sources file (auralize_format != 'sources')")
    if int(h.attrs.get("version", -1)) != VERSION:
        raise FormatError(f"{p}: sources file version {h.attrs.get('version')} is not {VERSION}")
    off = h["offsets"][()]
    idx, kind = h["index"][()], h["kind"][()]
    strength, radius = h["strength"][()], h["radius"][()]
    frames = [
        SourceFrame(index=idx[a:b], kind=kind[a:b], strength=strength[a:b], radius=radius[a:b])
        for a, b in itertools.pairwise(off)
    ]
    return SourceSeries(
        frames=frames, times=h["time"][()], origin=h.attrs["origin"][()],
        spacing=h.attrs["spacing"][()], dims=tuple(int(d) for d in h.attrs["dims"]),  # type: ignore[arg-type]
        thresholds=h.attrs["thresholds"][()], meta=json.loads(h.attrs["meta"]),
    )  # fmt: skip


def save_sources_pvd(series: SourceSeries, path: str | Path) -> None:
    """Write ``NAME.pvd`` plus ``NAME_data/step_NNNN.vtp`` (one point set per step), atomically.

    The folder is written under a fresh name (``NAME_data``, or ``NAME_data.1``
    ... while the previous version holds that name) and the ``.pvd`` replaced
    in one rename (:func:`auralize.io.files.write_collection`); an existing
    ``NAME_data`` that auralize did not write is never replaced.
    """
    import pyvista as pv

    from auralize.scene.pictures import type_rgb

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

    Raises
    ------
    FormatError
        ``path`` is a ``.pvd`` or not a sources file.
    DataError
        The sources belong to another grid (dims, origin, spacing) or other
        times; the message names both.
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
    if mismatches:
        origin = series.meta.get("source", "another volume")
        raise DataError(
            f"{p}: these sources (detected on {origin}) do not belong to the grid of "
            f"{volume.source}: {'; '.join(mismatches)} (sources vs volume); detect them on this "
            f"volume with 'auralize detect {volume.source} -o SOURCES.h5' (same --resolution)"
        )
    return series
