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
``strength``, ``radius``, ``volume``; field data ``kind_code``/``kind_name``,
the legend of the codes) so ParaView can glyph them as spheres.  VTKHDF
(``.vtkhdf``): :func:`auralize.io.vtkhdf_write.write_sources_vtkhdf`.
"""

from __future__ import annotations

import itertools
import json
import shutil
import tempfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import h5py
import numpy as np

from auralize.errors import FormatError
from auralize.fileio import atomic_path, atomic_write
from auralize.io.vtkhdf_write import KIND_LEGEND
from auralize.sources import SourceFrame, SourceSeries

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
    with h:
        if h.attrs.get("auralize_format") != FORMAT:
            raise FormatError(f"{p}: not an auralize sources file (auralize_format != 'sources')")
        if int(h.attrs.get("version", -1)) != VERSION:
            raise FormatError(
                f"{p}: sources file version {h.attrs.get('version')} is not {VERSION}"
            )
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
    """Write ``NAME.pvd`` plus ``NAME_data/step_NNNN.vtp`` (one point set per step)."""
    import pyvista as pv

    p = Path(path)
    data_dir = p.parent / f"{p.stem}_data"
    tmp_dir = Path(tempfile.mkdtemp(prefix=f".{p.stem}_data.", dir=p.parent))
    try:
        entries = []
        for n, f in enumerate(series.frames):
            pts = series.positions(f.index) if f.index.size else np.zeros((0, 3))
            poly = pv.PolyData(pts)
            poly.point_data["kind"] = f.kind.astype(np.int8)
            poly.point_data["strength"] = f.strength
            poly.point_data["radius"] = f.radius
            poly.point_data["volume"] = f.volume
            poly.field_data["kind_code"] = np.array(list(KIND_LEGEND), dtype=np.int32)
            poly.field_data["kind_name"] = list(KIND_LEGEND.values())
            name = f"step_{n:04d}.vtp"
            poly.save(tmp_dir / name)
            entries.append((float(series.times[n]), f"{data_dir.name}/{name}"))
        if data_dir.exists():
            shutil.rmtree(data_dir)
        tmp_dir.rename(data_dir)
    except BaseException:
        shutil.rmtree(tmp_dir, ignore_errors=True)
        raise
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
        "<Collection>",
    ]
    lines += [f'<DataSet timestep="{t!r}" part="0" file={quoteattr(fn)}/>' for t, fn in entries]
    lines += ["</Collection>", "</VTKFile>", ""]
    atomic_write(p, "\n".join(lines).encode())
