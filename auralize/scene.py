"""Off-screen pictures of a volume, its ΔV spheres and a listener path (pyvista, no Qt).

Used by ``auralize demo`` and scripts; the desktop viewer builds on the same
colours so pictures and the app agree.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from auralize.fileio import atomic_path
from auralize.listener import ListenerPath
from auralize.sources import SourceSeries
from auralize.volume import TimeVolume

#: colours of the source types (monopole, dipole, quadrupole) and the path
TYPE_COLORS = {1: "#e6194b", 2: "#3cb44b", 3: "#4363d8"}
TYPE_LABELS = {1: "monopole", 2: "dipole", 3: "quadrupole"}
PATH_COLOR = "#ffd700"


def source_glyphs(series: SourceSeries, step: int):
    """A sphere per source point of ``step`` at its ΔV radius, with a ``kind`` array."""
    import pyvista as pv

    f = series.frames[step]
    pts = pv.PolyData(series.positions(f.index) if f.index.size else np.zeros((0, 3)))
    pts.point_data["radius"] = f.radius
    pts.point_data["kind"] = f.kind.astype(np.int32)
    if f.index.size == 0:
        return pts
    return pts.glyph(scale="radius", geom=pv.Sphere(radius=1.0, theta_resolution=10,
                                                    phi_resolution=10), orient=False)  # fmt: skip


def path_tube(path: ListenerPath, radius: float):
    import pyvista as pv

    t = np.linspace(path.times[0], path.times[-1], max(2 * path.n_captures, 50))
    line = pv.lines_from_points(path.position_at(t))
    return line.tube(radius=radius)


def screenshot(volume: TimeVolume, out: str | Path, *, series: SourceSeries | None = None,
               step: int | None = None, path: ListenerPath | None = None, field: str | None = None,
               window_size: tuple[int, int] = (1280, 960)) -> Path:  # fmt: skip
    """Render volume (translucent contours of ``field``), ΔV spheres and path to a PNG."""
    import pyvista as pv

    if not os.environ.get("DISPLAY"):
        # off screen without X: VTK tries an X window first and warns before it
        # falls back to EGL; the warning is noise here
        from vtkmodules.vtkCommonCore import vtkLogger

        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    step = volume.n_steps // 2 if step is None else step
    field = field or volume.field_names[0]
    grid = pv.ImageData(dimensions=volume.dims, spacing=volume.spacing, origin=volume.origin)
    arr = volume.frame(field, step)
    if arr.ndim == 4:
        arr = np.linalg.norm(arr, axis=-1)
    grid.point_data[field] = arr.reshape(-1)
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.set_background("#101018")  # type: ignore[arg-type]
    pl.add_mesh(grid.outline(), color="#888888")
    lo, hi = float(arr.min()), float(arr.max())
    if hi > lo:
        levels = np.linspace(lo, hi, 5)[2:-1]
        cont = grid.contour(levels.tolist(), scalars=field)
        if cont.n_points:
            pl.add_mesh(cont, scalars=field, cmap="bone", opacity=0.18, show_scalar_bar=False)
    if series is not None:
        glyphs = source_glyphs(series, step)
        for k, color in TYPE_COLORS.items():
            if glyphs.n_points and "kind" in glyphs.point_data:
                part = glyphs.extract_points(glyphs.point_data["kind"] == k, adjacent_cells=False)
                if part.n_points:
                    pl.add_mesh(part, color=color, smooth_shading=True, label=TYPE_LABELS[k])
        counts = series.frames[step].counts()
        for i, (k, color) in enumerate(TYPE_COLORS.items()):
            pl.add_text(f"{TYPE_LABELS[k]}: {counts[TYPE_LABELS[k]]}", color=color, font_size=12,
                        position=(window_size[0] - 240, window_size[1] - 40 - 28 * i))  # fmt: skip
    if path is not None:
        pl.add_mesh(path_tube(path, 0.004 * float(np.linalg.norm(volume.spacing * volume.dims))),
                    color=PATH_COLOR)  # fmt: skip
        f, _ = path.orientation_at(path.times[-1])
        tip = path.positions[-1]
        size = 0.03 * float(np.max(volume.spacing * volume.dims))
        pl.add_mesh(
            pv.Cone(center=tip, direction=f[0], height=size, radius=0.4 * size), color=PATH_COLOR
        )
    pl.add_text(f"{volume.source}  step {step}  t = {volume.times[step]:.3f} s", font_size=10,
                color="white")  # fmt: skip
    pl.view_isometric()  # type: ignore[call-arg]
    pl.camera.zoom(1.2)
    out = Path(out)
    with atomic_path(out, suffix=".part.png") as tmp:
        pl.screenshot(str(tmp))
    pl.close()
    return out
