"""Off-screen pictures of a volume, its ΔV spheres and a listener path (pyvista, no Qt).

Used by ``auralize demo`` and scripts; the desktop viewer builds on the same
colours so pictures and the app agree.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from auralize.listener import ListenerPath
from auralize.palette import PALETTE as PALETTE
from auralize.palette import type_rgb as type_rgb
from auralize.runtime.files import atomic_path
from auralize.runtime.vtkcompat import dataset_surface
from auralize.sources.detection import SourceSeries
from auralize.volume import TimeVolume

TYPE_LABELS = {1: "monopole", 2: "dipole", 3: "quadrupole"}
#: hex colours by type code (1 monopole, 2 dipole, 3 quadrupole)
TYPE_COLORS = {k: "#{:02x}{:02x}{:02x}".format(*PALETTE[v]) for k, v in TYPE_LABELS.items()}
#: RGB of the listener path and its glyph (amber)
PATH_RGB: tuple[int, int, int] = (255, 170, 0)
PATH_COLOR = "#{:02x}{:02x}{:02x}".format(*PATH_RGB)


def data_grid(volume: TimeVolume) -> Any:
    """The volume's grid as a pyvista dataset: ``ImageData`` for a uniform grid, a
    ``StructuredGrid`` of its own points for a curvilinear one (drawn natively).

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_monopole
    >>> grid = data_grid(make_monopole(size=8, steps=4))
    >>> type(grid).__name__, tuple(grid.dimensions)
    ('ImageData', (8, 8, 8))
    """
    import pyvista as pv

    if volume.coords is None:
        return pv.ImageData(dimensions=volume.dims, spacing=volume.spacing, origin=volume.origin)
    grid = pv.StructuredGrid()
    grid.points = volume.coords.reshape(-1, 3)
    grid.dimensions = volume.dims
    return grid


#: above this many sources, draw them as point sprites of a fixed pixel size
#: instead of sphere impostors at their ΔV radius (fill rate of software renderers)
SPRITE_LIMIT = 25_000


def source_points(centers: np.ndarray, radii: np.ndarray, kinds: np.ndarray):
    """One point set of sources: ``radius`` (m) and ``rgb`` (palette) point arrays.

    Parameters
    ----------
    centers : (N, 3) positions in metres.
    radii : (N,) ΔV-sphere radii in metres.
    kinds : (N,) type codes (1 monopole, 2 dipole, 3 quadrupole).
    """
    import pyvista as pv

    c = np.asarray(centers, dtype=np.float64).reshape(-1, 3)
    if not len(c):
        return pv.PolyData()
    mesh = pv.PolyData(c)
    mesh.point_data["rgb"] = type_rgb(kinds)  # the active scalars (the colours)
    mesh.point_data["radius"] = np.asarray(radii, dtype=np.float64).reshape(-1)
    return mesh


def add_source_actor(plotter, mesh, *, name: str = "sources"):
    """Draw a :func:`source_points` set on ``plotter`` in one GPU draw call.

    Up to :data:`SPRITE_LIMIT` sources are shaded sphere impostors of their ΔV radius
    (VTK's point-Gaussian mapper: one quad per source, the sphere is made in the
    fragment shader); more are flat point sprites of 3 pixels in the type's colour
    (a software renderer draws 100,000 of them at > 10 frames per second; sphere
    impostors reach ~2).  Either way there is one mesh and one actor, never one
    mesh per sphere.
    """
    if mesh.n_points <= SPRITE_LIMIT:
        actor = plotter.add_mesh(
            mesh,
            scalars="rgb",
            rgb=True,
            style="points_gaussian",
            emissive=False,
            render_points_as_spheres=True,
            name=name,
            reset_camera=False,
            render=False,
        )
        actor.mapper.scale_array = "radius"
    else:
        actor = plotter.add_mesh(
            mesh,
            scalars="rgb",
            rgb=True,
            style="points",
            point_size=3,
            render_points_as_spheres=False,
            name=name,
            reset_camera=False,
            render=False,
        )
    return actor


def source_glyphs(series: SourceSeries, step: int):
    """The sources of ``step`` as a :func:`source_points` set (``kind`` array too)."""
    f = series.frames[step]
    pts = source_points(
        series.positions(f.index) if f.index.size else np.zeros((0, 3)), f.radius, f.kind
    )
    if pts.n_points:
        pts.point_data["kind"] = f.kind.astype(np.int32)
    return pts


def path_tube(path: ListenerPath, radius: float):
    import pyvista as pv

    t = np.linspace(path.times[0], path.times[-1], max(2 * path.n_captures, 50))
    line = pv.lines_from_points(path.position_at(t))
    return line.tube(radius=radius)


def screenshot(
    volume: TimeVolume,
    out: str | Path,
    *,
    series: SourceSeries | None = None,
    step: int | None = None,
    path: ListenerPath | None = None,
    field: str | None = None,
    window_size: tuple[int, int] = (1280, 960),
    title: str | None = None,
) -> Path:
    """Render volume (translucent contours of ``field``), ΔV spheres and path to a PNG.

    ``title``: the caption (default the data's source, the step and its time)."""
    import pyvista as pv

    if not os.environ.get("DISPLAY"):
        # off screen without X: VTK tries an X window first and warns before it
        # falls back to EGL; the warning is noise here
        from vtkmodules.vtkCommonCore import vtkLogger

        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    step = volume.n_steps // 2 if step is None else step
    field = field or volume.field_names[0]
    grid = data_grid(volume)
    arr = volume.frame(field, step)
    if arr.ndim == 4:
        arr = np.linalg.norm(arr, axis=-1)
    grid.point_data[field] = arr.reshape(-1)
    pl = pv.Plotter(off_screen=True, window_size=list(window_size))
    pl.render_window.SetMultiSamples(0)  # 8× MSAA costs 10× per frame on software GL
    pl.set_background("#101018")  # type: ignore[arg-type]
    pl.add_mesh(pv.Box(bounds=volume.bounds).outline(), color="#888888")
    lo, hi = float(arr.min()), float(arr.max())
    if min(volume.dims) == 1:  # a one-layer grid is drawn as its coloured surface
        pl.add_mesh(
            dataset_surface(grid),
            scalars=field,
            cmap="viridis",
            clim=(lo, hi) if hi > lo else None,
            show_scalar_bar=False,
        )
    elif hi > lo:
        levels = np.linspace(lo, hi, 5)[2:-1]
        cont = grid.contour(levels.tolist(), scalars=field)
        if cont.n_points:
            pl.add_mesh(cont, scalars=field, cmap="bone", opacity=0.18, show_scalar_bar=False)
    if series is not None:
        glyphs = source_glyphs(series, step)
        if glyphs.n_points:
            add_source_actor(pl, glyphs)
        counts = series.frames[step].counts()
        shown = [k for k in TYPE_LABELS if counts[TYPE_LABELS[k]]]
        for i, k in enumerate(shown):  # the legend lists only what is shown
            pl.add_text(
                f"{TYPE_LABELS[k]}: {counts[TYPE_LABELS[k]]}",
                color=TYPE_COLORS[k],
                font_size=12,
                position=(window_size[0] - 240, window_size[1] - 40 - 28 * i),
            )
    if path is not None:
        r = 0.004 * float(np.linalg.norm(volume.spacing * volume.dims))
        if np.ptp(path.positions, axis=0).max() > 0:
            pl.add_mesh(path_tube(path, r), color=PATH_COLOR)
        else:  # a listener standing still: a dot where it stands (a tube of it is empty)
            pl.add_mesh(pv.Sphere(radius=3 * r, center=path.positions[0]), color=PATH_COLOR)
        f, _ = path.orientation_at(path.times[-1])
        tip = path.positions[-1]
        size = 0.03 * float(np.max(volume.spacing * volume.dims))
        pl.add_mesh(
            pv.Cone(center=tip, direction=f[0], height=size, radius=0.4 * size), color=PATH_COLOR
        )
    if title is None:
        title = f"{volume.source}  step {step}  t = {volume.times[step]:.3f} s"
    pl.add_text(title, font_size=10, color="white")
    pl.view_isometric()  # type: ignore[call-arg]
    pl.camera.zoom(1.2)
    out = Path(out)
    with atomic_path(out, suffix=".part.png") as tmp:
        pl.screenshot(str(tmp))
    pl.close()
    return out


def prefer_egl() -> None:
    """Without an X display, let VTK render off screen through EGL (no warnings, no X)."""
    if not os.environ.get("DISPLAY") and "VTK_DEFAULT_OPENGL_WINDOW" not in os.environ:
        os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
