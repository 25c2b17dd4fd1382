"""The 3-D scene of the viewer, on any pyvista plotter (Qt window or off screen).

:class:`Scene` owns the actors the viewer shows: the volume of the chosen field
(volume rendering, orthogonal slices or a contour), the ΔV spheres of the
detected sources coloured by type, the listener path as a polyline with a
camera-like glyph at the current listener, and plugin overlays.  It never
imports Qt, so the same code draws the desktop window, off-screen screenshots,
``auralize.simple`` views and the interactivity benchmark.

Colours are the one palette of :mod:`auralize.scene.pictures` (:data:`TYPE_COLORS`:
monopole red, dipole blue, quadrupole green; :data:`PATH_COLOR` amber), so
screenshots can be checked pixel by pixel; the volume uses a grey colour map, so
every saturated pixel comes from a source or the path.  The data's bounding box
is always drawn (grey outline) and the displayed field has a colour bar whose
range is robust (1st–99th percentile of the finite values: outliers and fill
values do not swamp it).  Sources are one point set drawn by the GPU
(:func:`auralize.scene.pictures.add_source_actor`), never one mesh per sphere.

Examples
--------
>>> import pyvista as pv
>>> from auralize.pipeline import load
>>> from auralize.scene.view import Scene
>>> scene = Scene(pv.Plotter(off_screen=True))
>>> scene.set_volume(load("dataset:monopole", size=8, steps=4))
>>> scene.set_step(2) < 5.0  # seconds the redraw took
True
>>> scene.plotter.close()
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import AuralizeError, ParameterError
from auralize.listener import ListenerPath
from auralize.runtime.vtkcompat import dataset_surface
from auralize.scene.pictures import (
    PALETTE,
    PATH_RGB,
    SPRITE_LIMIT,
    add_source_actor,
    data_grid,
    source_points,
)
from auralize.sources.detection import TYPES, SourceFrame
from auralize.volume import TimeVolume

#: RGB colours of the source types: the one palette of :mod:`auralize.scene.pictures`
TYPE_COLORS: dict[str, tuple[int, int, int]] = PALETTE
#: RGB colour of the listener path and its glyph
PATH_COLOR: tuple[int, int, int] = PATH_RGB
#: background colour (dark, unsaturated)
BACKGROUND: tuple[int, int, int] = (26, 26, 34)
REPRESENTATIONS = ("volume", "slices", "contour", "glyphs", "none")
#: view direction of the default (isometric) view, as ParaView's: from (+1, +1, +1)
ISOMETRIC: tuple[float, float, float] = (-1.0, -1.0, -1.0)
#: pixels between the rays of volume rendering (per side; 1 = one ray per pixel): the
#: volume is smooth, and 2 keeps a 1024×768 redraw near 80 ms on a software renderer
IMAGE_SAMPLE_DISTANCE = 2.0
#: most arrows the ``glyphs`` representation draws (the grid is subsampled evenly)
MAX_GLYPHS = 4000
#: percentiles of the finite values that span the colour bar
CLIM_PERCENTILES = (1.0, 99.0)
#: values at or beyond this magnitude are taken as fill values (not data)
FILL_MAGNITUDE = 1e20
#: display frames kept in memory (float32), in bytes
FRAME_CACHE_BYTES = 512 * 1024**2


def camera_pose(
    camera: Any,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(position, forward, up)`` of a pyvista camera (unit forward, up orthogonal to it)."""
    pos = np.asarray(camera.position, dtype=np.float64)
    fwd = np.asarray(camera.focal_point, dtype=np.float64) - pos
    fwd /= np.linalg.norm(fwd)
    up = np.asarray(camera.up, dtype=np.float64)
    up = up - (up @ fwd) * fwd
    up /= np.linalg.norm(up)
    return pos, fwd, up


def listener_glyph(
    position: NDArray[np.floating],
    forward: NDArray[np.floating],
    up: NDArray[np.floating],
    size: float,
) -> Any:
    """A camera-like glyph: a cone looking along ``forward`` plus a short up marker."""
    import pyvista as pv

    p = np.asarray(position, dtype=np.float64)
    f = np.asarray(forward, dtype=np.float64)
    u = np.asarray(up, dtype=np.float64)
    body = pv.Cube(
        center=p - 0.35 * size * f, x_length=0.5 * size, y_length=0.5 * size, z_length=0.5 * size
    )
    # align the cube roughly: it is small, the cone carries the direction
    cone = pv.Cone(
        center=p + 0.25 * size * f,
        direction=-f,
        height=0.6 * size,
        radius=0.35 * size,
        resolution=16,
    )
    mast = pv.Line(p, p + 0.6 * size * u)
    return body.triangulate().append_polydata(cone.triangulate(), mast)


class Scene:
    """The viewer's actors on a pyvista plotter.

    Parameters
    ----------
    plotter : pyvista.Plotter or pyvistaqt.QtInteractor
        Where to draw; ``pv.Plotter(off_screen=True)`` for headless use.
    """

    def __init__(self, plotter: Any) -> None:
        self.plotter = plotter
        self.volume: TimeVolume | None = None
        self.field: str | None = None
        self.representation = "volume"
        self.cmap = "gray"
        self.opacity = 0.35
        self.step = 0
        self.clim: tuple[float, float] = (0.0, 1.0)
        self.visible_types = dict.fromkeys(TYPES, True)
        self.show_sources = True
        self.show_volume = True
        self.sources: Callable[[int], SourceFrame | None] | None = None
        self.path: ListenerPath | None = None
        self.listener: tuple[NDArray[np.float64], ...] | None = None
        self.time_scale = 1.0
        self.overlays: dict[str, Callable[[int], Any]] = {}
        self.overlay_visible: dict[str, bool] = {}
        #: overlays that could not be drawn on this data, with the reason (they are hidden)
        self.overlay_errors: dict[str, str] = {}
        #: the time step whose meshes each overlay shows (absent: nothing drawn yet)
        self.overlay_shown: dict[str, int] = {}
        self._frames: OrderedDict[tuple[str, int], NDArray[np.float32]] = OrderedDict()
        self._grid: Any = None
        self._actors: dict[str, Any] = {}
        self.timings: dict[str, float] = {}
        plotter.set_background(np.asarray(BACKGROUND) / 255.0)
        rw = getattr(plotter, "render_window", None)
        if rw is not None:
            rw.SetMultiSamples(0)  # 8× MSAA costs ~10× per frame on software GL
        self._legend_key: tuple[str, ...] | None = None

    # ---------------------------------------------------------------- volume
    def set_volume(
        self,
        volume: TimeVolume,
        *,
        field: str | None = None,
        representation: str | None = None,
        frames: list[NDArray[np.floating]] | None = None,
    ) -> None:
        """Show ``volume``; ``field`` defaults to the first scalar field (else a vector
        magnitude).  ``frames`` are that field's display frames already read (one per step)."""
        self.volume = volume
        self._frames.clear()
        name = field or default_field(volume)
        for n, a in enumerate(frames or []):
            self._frames[(name, n)] = np.ascontiguousarray(a, dtype=np.float32).reshape(-1)
        self.field = None
        self.sources = None
        self.step = 0
        if self.representation == "glyphs" and not any(map(volume.is_vector, volume.field_names)):
            self.representation = "volume"  # nothing to draw as arrows in this volume
        self.set_field(name, render=False)
        if representation is not None:
            self.set_representation(representation, render=False)
        self._remove("outline")
        import pyvista as pv

        self._actors["outline"] = self.plotter.add_mesh(
            pv.Box(bounds=volume.bounds).outline(),
            color=(0.6, 0.6, 0.6),
            line_width=1,
            lighting=False,
            name="outline",
            reset_camera=False,
            render=False,
        )
        self._shown_frame: SourceFrame | None = None
        self._legend(None)
        self.set_step(0, render=False)
        # frame the new data (not a listener path or overlay of other data still shown)
        self.reset_camera(ISOMETRIC, (0.0, 0.0, 1.0))

    def set_field(self, name: str, *, render: bool = True) -> None:
        """Choose the displayed field (raises FieldError for an unknown name)."""
        vol = self._need_volume()
        vol._get(name)  # FieldError names the valid fields
        self.field = name
        self._remove("volume")
        self.clim = robust_range([self.frame(self.step), self.frame(vol.n_steps - 1)])
        self._grid = None
        self.set_step(self.step, render=render)

    def set_representation(self, rep: str, *, render: bool = True) -> None:
        """``volume`` (ray casting), ``slices`` (three orthogonal), ``contour``, ``glyphs``
        (arrows of a vector field on an evenly subsampled grid, coloured by the displayed
        field) or ``none``."""
        if rep not in REPRESENTATIONS:
            raise ParameterError(f"representation must be one of {REPRESENTATIONS}, got {rep!r}")
        if rep == "glyphs" and self.volume is not None:
            self._vector_field()  # ParameterError when there is none
        self.representation = rep
        self._remove("volume")
        if self.volume is not None:
            self._update_volume()
            if render:
                self.plotter.render()

    def set_colormap(self, cmap: str | None = None, opacity: float | None = None) -> None:
        """Change the colour map and/or the overall opacity (0..1) and redraw."""
        if cmap is not None:
            self.cmap = cmap
        if opacity is not None:
            if not 0 <= opacity <= 1:
                raise ParameterError(f"opacity must be in [0, 1], got {opacity!r}")
            self.opacity = float(opacity)
        self.set_representation(self.representation)

    def frame(self, step: int) -> NDArray[np.float32]:
        """Display scalars of the current field at ``step`` (vector fields: magnitude), cached."""
        vol = self._need_volume()
        assert self.field is not None
        key = (self.field, int(step))
        if key in self._frames:
            self._frames.move_to_end(key)
            return self._frames[key]
        a = vol.frame(self.field, int(step))
        if a.ndim == 4:
            a = np.linalg.norm(a, axis=-1)
        a = np.ascontiguousarray(a, dtype=np.float32).reshape(-1)
        self._frames[key] = a
        while sum(v.nbytes for v in self._frames.values()) > FRAME_CACHE_BYTES:
            self._frames.popitem(last=False)
        return a

    def prefetch(self, progress: Callable[[int, int], bool] | None = None) -> None:
        """Read every display frame into the cache; ``progress(done, total)`` returning
        False stops early."""
        vol = self._need_volume()
        for n in range(vol.n_steps):
            self.frame(n)
            if progress is not None and progress(n + 1, vol.n_steps) is False:
                return

    def _ensure_grid(self) -> Any:

        vol = self._need_volume()
        if self._grid is None:
            self._grid = data_grid(vol)
            self._grid.point_data["value"] = self.frame(self.step).copy()
        return self._grid

    def _update_volume(self) -> None:
        grid = self._ensure_grid()
        arr = self.frame(self.step)
        grid.point_data["value"][:] = arr
        grid.Modified()
        rep = self.representation if self.show_volume else "none"
        if rep in ("volume", "contour") and min(self._need_volume().dims) == 1:
            rep = "surface"  # a one-layer grid has no inside to ray-cast or contour
        if rep == "volume" and self._need_volume().coords is not None:
            rep = "slices"  # a curvilinear grid is drawn on its own points: no ray casting
        if rep == "volume":
            if "volume" not in self._actors:
                self._actors["volume"] = self.plotter.add_volume(
                    grid,
                    scalars="value",
                    cmap=self.cmap,
                    clim=self.clim,
                    opacity=_opacity_tf(self.opacity),
                    show_scalar_bar=False,
                    name="volume",
                    reset_camera=False,
                    render=False,
                    mapper="gpu",
                )
                # fixed sampling: one ray per IMAGE_SAMPLE_DISTANCE² pixels (the smart
                # mapper's automatic sampling cost ~5× more per frame on software GL)
                m = self._actors["volume"].mapper
                m.SetAutoAdjustSampleDistances(False)
                m.SetImageSampleDistance(IMAGE_SAMPLE_DISTANCE)
                self._scalar_bar()
                # the mapper keeps its own input: update that one from now on
                self._grid = self._actors["volume"].mapper.dataset
            else:
                self._actors["volume"].mapper.dataset.Modified()
        elif rep in ("slices", "contour", "glyphs", "surface"):
            kw: dict[str, Any]
            if rep == "surface":
                mesh = dataset_surface(grid)
                kw = {"opacity": 1.0}
            elif rep == "glyphs":
                mesh = self._glyphs()
                kw = {"opacity": 1.0}
            elif rep == "slices":
                mesh = grid.slice_orthogonal().combine(merge_points=False)
                kw = {"opacity": max(self.opacity, 0.6)}
            else:
                iso = self.clim[0] + 0.6 * (self.clim[1] - self.clim[0])
                mesh = grid.contour([iso], scalars="value")
                kw = {"opacity": self.opacity}
            if mesh.n_points == 0:
                self._remove("volume")
            elif "volume" in self._actors and getattr(self, "_vol_mesh", None) is not None:
                self._vol_mesh.copy_from(mesh)
            else:
                self._remove("volume")
                self._vol_mesh = mesh
                self._actors["volume"] = self.plotter.add_mesh(
                    mesh,
                    scalars="value",
                    cmap=self.cmap,
                    clim=self.clim,
                    show_scalar_bar=False,
                    name="volume",
                    reset_camera=False,
                    render=False,
                    **kw,
                )
                self._scalar_bar()
        else:
            self._remove("volume")
            self._remove_scalar_bar()

    def _vector_field(self) -> str:
        """The displayed field if it is a vector field, else the volume's first one."""
        vol = self._need_volume()
        if self.field is not None and vol.is_vector(self.field):
            return self.field
        for name in vol.field_names:
            if vol.is_vector(name):
                return name
        raise ParameterError(
            f"{vol.source}: no vector field to draw as glyphs (fields: "
            f"{', '.join(vol.field_names)})"
        )

    def _glyphs(self) -> Any:
        """Arrows of the vector field at the current step on an evenly subsampled grid."""
        import pyvista as pv

        vol = self._need_volume()
        name = self._vector_field()
        k = max(1, int(np.ceil((vol.n_points / MAX_GLYPHS) ** (1 / 3))))
        v = vol.frame(name, self.step)[::k, ::k, ::k].reshape(-1, 3)
        nx, ny, nz = vol.dims
        ix, iy, iz = np.arange(0, nx, k), np.arange(0, ny, k), np.arange(0, nz, k)
        zz, yy, xx = np.meshgrid(iz, iy, ix, indexing="ij")
        flat = (zz * ny + yy) * nx + xx
        pts = pv.PolyData(vol.points(flat.reshape(-1)))
        mag = np.linalg.norm(v, axis=1)
        pts.point_data["vectors"] = v
        pts.point_data["value"] = self.frame(self.step)[flat.reshape(-1)]
        top = float(np.percentile(mag, 99)) if mag.size else 0.0
        pts.point_data["length"] = np.minimum(mag / top, 1.0) if top > 0 else mag * 0
        length = float(k * vol.spacing.min())
        return pts.glyph(
            orient="vectors",
            scale="length",
            factor=length,
            geom=pv.Arrow(tip_length=0.35, tip_radius=0.12, shaft_radius=0.04),
        )

    def _scalar_bar(self) -> None:
        """The colour bar of the displayed field (its robust range, with units if known)."""
        self._remove_scalar_bar()
        vol = self.volume
        units = (vol.attrs.get("units") or {}) if vol is not None else {}
        u = units.get(self.field) if isinstance(units, dict) else None
        title = f"{self.field} ({u})" if u else str(self.field)
        if self.field and vol is not None and vol.is_vector(self.field):
            title = f"|{title}|"
        self._bar_title = title
        bar = self.plotter.add_scalar_bar(
            title=title,
            mapper=self._actors["volume"].mapper,
            n_labels=3,
            fmt=label_format(self.clim),
            vertical=False,
            position_x=0.55,
            position_y=0.03,
            height=0.1,
            width=0.4,
            title_font_size=12,
            label_font_size=11,
        )
        bar.SetTextPositionToPrecedeScalarBar()  # labels below the bar, the title above

    def _remove_scalar_bar(self) -> None:
        title = getattr(self, "_bar_title", None)
        if title is not None and title in self.plotter.scalar_bars:
            self.plotter.remove_scalar_bar(title, render=False)
        self._bar_title = None

    # --------------------------------------------------------------- sources
    def set_sources(self, getter: Callable[[int], SourceFrame | None] | None) -> None:
        """``getter(step)`` returns the sources of a step (or None if not detected yet)."""
        self.sources = getter
        self._update_sources()

    def set_type_visible(self, kind: str, visible: bool, *, render: bool = True) -> None:
        if kind not in self.visible_types:
            raise ParameterError(f"source type must be one of {TYPES}, got {kind!r}")
        self.visible_types[kind] = bool(visible)
        self._update_sources()
        if render:
            self.plotter.render()

    def _update_sources(self) -> None:
        frame = self.sources(self.step) if (self.sources and self.volume is not None) else None
        if frame is None or not self.show_sources:
            self._remove("sources")
            self._shown_frame = None
            self._legend(None)
            return
        keep = np.zeros(frame.kind.size, dtype=bool)
        for k, name in enumerate(TYPES, start=1):
            if self.visible_types[name]:
                keep |= frame.kind == k
        if not keep.any():
            self._remove("sources")
            self._shown_frame = None
            self._legend(None)
            return
        vol = self._need_volume()
        mesh = source_points(
            vol.points(frame.index[keep]),
            np.maximum(frame.radius[keep], 1e-3 * vol.spacing.min()),
            frame.kind[keep],
        )
        mode = "sprite" if mesh.n_points <= SPRITE_LIMIT else "point"
        if "sources" in self._actors and self._src_mode == mode:
            self._src_mesh.copy_from(mesh)
        else:
            self._remove("sources")
            self._src_mesh, self._src_mode = mesh, mode
            self._actors["sources"] = add_source_actor(self.plotter, mesh)
        self._shown_frame = frame
        self._legend(frame)

    def _legend(self, frame: SourceFrame | None = None) -> None:
        """Legend of what is shown: the source types present and visible, and the path."""
        items: list[str] = []
        if frame is not None:
            for k, name in enumerate(TYPES, start=1):
                if self.visible_types[name] and np.any(frame.kind == k):
                    items.append(name)
        if self.path is not None:
            items.append("listener path")
        key = tuple(items)
        if key == self._legend_key:
            return
        self._legend_key = key
        self.plotter.remove_legend(render=False)
        if not items:
            return
        colors = {**TYPE_COLORS, "listener path": PATH_COLOR}
        labels = [[k, tuple(c / 255 for c in colors[k])] for k in items]
        # (pyvista's add_legend redraws: the caller redraws once, after everything)
        quiet = self.plotter.suppress_rendering
        self.plotter.suppress_rendering = True
        try:
            self.plotter.add_legend(
                labels,
                bcolor=np.asarray(BACKGROUND) / 255,
                size=(0.22, 0.035 * len(items) + 0.01),
                face="circle",
                name="legend",
                loc="upper left",
            )
        finally:
            self.plotter.suppress_rendering = quiet

    # -------------------------------------------------------------- listener
    def set_path(
        self, path: ListenerPath | None, *, time_scale: float | None = None, render: bool = True
    ) -> None:
        """Draw ``path`` as a polyline (None removes it); the glyph follows the time slider."""
        self.path = path
        if time_scale is not None:
            self.time_scale = float(time_scale)
        self._update_path()
        if render:
            self.plotter.render()

    def set_listener(self, position: Any, forward: Any, up: Any, *, render: bool = False) -> None:
        """Place the listener glyph explicitly (recording / live listening)."""
        self.listener = tuple(np.asarray(v, dtype=np.float64) for v in (position, forward, up))
        self._update_glyph()
        if render:
            self.plotter.render()

    def _glyph_size(self) -> float:
        vol = self.volume
        if vol is None:
            return 1.0
        b = np.asarray(vol.bounds).reshape(3, 2)
        return float(0.04 * np.linalg.norm(b[:, 1] - b[:, 0]))

    def _update_path(self) -> None:
        import pyvista as pv

        p = self.path
        if p is None or p.n_captures == 0:
            self._remove("path")
        else:
            pts = p.positions if p.n_captures > 1 else np.repeat(p.positions, 2, axis=0)
            line = pv.lines_from_points(pts)
            if "path" in self._actors:
                self._path_mesh.copy_from(line)
            else:
                self._path_mesh = line
                self._actors["path"] = self.plotter.add_mesh(
                    line,
                    color=np.asarray(PATH_COLOR) / 255,
                    line_width=5,
                    lighting=False,
                    name="path",
                    reset_camera=False,
                    render=False,
                )
        self._legend(getattr(self, "_shown_frame", None))
        if p is not None and self.listener is None:
            self._update_glyph()
        elif p is None and self.listener is None:
            self._remove("glyph")

    def listener_at_step(self) -> tuple[NDArray[np.float64], ...] | None:
        """Listener pose on the path at the current step's playback time."""
        if self.path is None or self.volume is None:
            return None
        t = (self.volume.times[self.step] - self.volume.times[0]) * self.time_scale
        t = t + self.path.times[0]
        f, u = self.path.orientation_at(t)
        return self.path.position_at(t)[0], f[0], u[0]

    def _update_glyph(self) -> None:
        pose = self.listener if self.listener is not None else self.listener_at_step()
        if pose is None:
            self._remove("glyph")
            return
        g = listener_glyph(*pose, self._glyph_size())
        if "glyph" in self._actors:
            self._glyph_mesh.copy_from(g)
        else:
            self._glyph_mesh = g
            self._actors["glyph"] = self.plotter.add_mesh(
                g,
                color=np.asarray(PATH_COLOR) / 255,
                lighting=False,
                name="glyph",
                reset_camera=False,
                render=False,
                line_width=3,
            )

    # -------------------------------------------------------------- overlays
    def set_overlay(
        self, name: str, fn: Callable[[int], Any] | None, *, visible: bool = True
    ) -> None:
        """Register ``fn(step) -> mesh | list of meshes | None`` as overlay ``name`` (None removes).

        ``fn`` may return :data:`PENDING` when the step's meshes are still being
        computed elsewhere: the overlay keeps what it shows until
        :meth:`refresh_overlay` is called with them ready.
        """
        if fn is None:
            self.overlays.pop(name, None)
            self.overlay_visible.pop(name, None)
            self.overlay_shown.pop(name, None)
            self._remove_prefix(f"overlay:{name}")
            return
        self.overlays[name] = fn
        self.overlay_visible[name] = visible
        self.overlay_errors.pop(name, None)
        self.overlay_shown.pop(name, None)
        self._remove_prefix(f"overlay:{name}")
        self._update_overlay(name, fn)

    def refresh_overlay(self, name: str, *, render: bool = True) -> None:
        """Draw overlay ``name`` for the current step again (its meshes became ready)."""
        if name in self.overlays:
            self._update_overlay(name, self.overlays[name])
            if render:
                self.plotter.render()

    def _update_overlays(self) -> None:
        for name, fn in self.overlays.items():
            self._update_overlay(name, fn)

    def _update_overlay(self, name: str, fn: Callable[[int], Any]) -> None:
        if not self.overlay_visible.get(name, True):
            self._remove_prefix(f"overlay:{name}")
            self.overlay_shown.pop(name, None)
            return
        try:
            meshes = fn(self.step)
        except AuralizeError as exc:  # does not apply to this data: say so once, hide it
            self.overlay_errors[name] = str(exc)
            self.overlay_visible[name] = False
            self._remove_prefix(f"overlay:{name}")
            self.overlay_shown.pop(name, None)
            return
        if meshes is PENDING:
            return
        self._remove_prefix(f"overlay:{name}")
        self.overlay_shown[name] = self.step
        if meshes is None:
            return
        if not isinstance(meshes, list | tuple):
            meshes = [meshes]
        for i, m in enumerate(meshes):
            key = f"overlay:{name}:{i}"
            self._actors[key] = self.plotter.add_mesh(
                m, name=key, reset_camera=False, render=False, opacity=0.6, show_scalar_bar=False
            )
        self._overlay_bars()

    def _overlay_bars(self) -> None:
        """One colour bar per coloured overlay, stacked at the bottom left, clear of the
        field's bar (bottom right): its title names the overlay and the quantity."""
        for title in [t for t in self.plotter.scalar_bars.keys() if " overlay: " in t]:
            self.plotter.remove_scalar_bar(title, render=False)
        k = 0
        for key, actor in self._actors.items():
            if not key.startswith("overlay:") or not key.endswith(":0"):
                continue
            mapper = actor.mapper
            data = getattr(mapper, "dataset", None)
            scalars = getattr(data, "active_scalars_name", None) if data is not None else None
            if not scalars or not mapper.GetScalarVisibility():
                continue
            name = key.split(":")[1]
            lo, hi = mapper.scalar_range
            bar = self.plotter.add_scalar_bar(
                title=f"{name} overlay: {scalars}",
                mapper=mapper,
                n_labels=3,
                fmt=label_format((lo, hi)),
                vertical=False,
                position_x=0.05,
                position_y=0.03 + 0.14 * k,
                height=0.1,
                width=0.4,
                title_font_size=12,
                label_font_size=11,
            )
            bar.SetTextPositionToPrecedeScalarBar()
            k += 1

    # ------------------------------------------------------------------ time
    def set_step(self, step: int, *, render: bool = True) -> float:
        """Show time step ``step``; returns the seconds the update (and redraw) took."""
        vol = self._need_volume()
        if not 0 <= step < vol.n_steps:
            raise ParameterError(f"time step must be in 0..{vol.n_steps - 1}, got {step!r}")
        t0 = time.perf_counter()
        self.step = int(step)
        self._update_volume()
        self._update_sources()
        if self.listener is None:
            self._update_glyph()
        self._update_overlays()
        if render:
            self.plotter.render()
        el = time.perf_counter() - t0
        self.timings["set_step"] = el
        return el

    # ---------------------------------------------------------------- camera
    def camera(self) -> dict[str, list[float]]:
        c = self.plotter.camera
        return {
            "position": list(map(float, c.position)),
            "focal_point": list(map(float, c.focal_point)),
            "up": list(map(float, c.up)),
            "view_angle": float(c.view_angle),
        }

    def set_camera(self, cam: dict[str, Any]) -> None:
        c = self.plotter.camera
        c.position = tuple(cam["position"])
        c.focal_point = tuple(cam["focal_point"])
        c.up = tuple(cam["up"])
        if "view_angle" in cam:
            c.view_angle = float(cam["view_angle"])
        self.plotter.renderer.ResetCameraClippingRange()

    def reset_camera(self, direction: Any = None, up: Any = None) -> None:
        """Frame the data: the focal point at the centre of the volume's bounding box,
        which fits the view (ParaView's Reset Camera; listener paths and overlays are
        not framed, so a path far away does not shrink the data to a dot).

        ``direction`` (the view direction, from the camera to the data) and ``up``
        set the view (a standard view); without them it is kept.  No redraw."""
        vol = self._need_volume()
        cam = self.plotter.camera
        b = np.asarray(vol.bounds, dtype=np.float64).reshape(3, 2)
        centre = b.mean(axis=1)
        if direction is None:
            d = np.asarray(cam.focal_point, dtype=np.float64) - np.asarray(cam.position)
            u = np.asarray(cam.up, dtype=np.float64)
        else:
            d, u = np.asarray(direction, dtype=np.float64), np.asarray(up, dtype=np.float64)
        d = d / np.linalg.norm(d)
        u = u - (u @ d) * d
        if not np.linalg.norm(u) > 1e-9:  # up along the view: any perpendicular
            u = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
        cam.focal_point = tuple(centre)
        cam.position = tuple(centre - d)
        cam.up = tuple(u / np.linalg.norm(u))
        ren = self.plotter.renderer
        ren.ResetCamera(*b.reshape(-1))  # keeps the direction, fits the box's sphere
        ren.ResetCameraClippingRange()  # everything shown stays unclipped
        ren.camera_set = True  # pyvista resets no more on its own

    def frame_all(self) -> None:
        """Fit the camera to everything shown (isometric)."""
        self.plotter.view_isometric()
        self.plotter.reset_camera()

    # ------------------------------------------------------------------ misc
    def _need_volume(self) -> TimeVolume:
        if self.volume is None:
            raise ParameterError("no volume loaded; open a data file first")
        return self.volume

    def _remove(self, key: str) -> None:
        a = self._actors.pop(key, None)
        if a is not None:
            self.plotter.remove_actor(a, render=False)

    def _remove_prefix(self, prefix: str) -> None:
        for k in [k for k in self._actors if k.startswith(prefix)]:
            self._remove(k)
        if prefix.startswith("overlay:"):
            self._overlay_bars()


#: what an overlay function returns for a step whose meshes are not ready yet
PENDING = object()


def default_field(volume: TimeVolume) -> str:
    """First scalar field of ``volume``, else its first (vector) field."""
    for name in volume.field_names:
        if not volume.is_vector(name):
            return name
    return volume.field_names[0]


def robust_range(frames: list[NDArray[np.floating]]) -> tuple[float, float]:
    """Colour range of display frames: the 1st–99th percentile of their finite values
    below :data:`FILL_MAGNITUDE` (so outliers and fill values do not swamp it).

    Examples
    --------
    >>> a = np.r_[np.linspace(0.0, 1.0, 1000), 1e30, np.nan]
    >>> [round(v, 2) for v in robust_range([a])]
    [0.01, 0.99]
    """
    v = np.concatenate([np.asarray(f, dtype=np.float64).reshape(-1) for f in frames])
    v = v[np.isfinite(v) & (np.abs(v) < FILL_MAGNITUDE)]
    if v.size == 0:
        return (0.0, 1.0)
    if v.size > 200_000:  # a strided sample is enough for percentiles
        v = v[:: v.size // 200_000]
    lo, hi = (float(x) for x in np.percentile(v, CLIM_PERCENTILES))
    if not hi > lo:
        lo, hi = float(v.min()), float(v.max())
    return (lo, hi if hi > lo else lo + 1.0)


def label_format(clim: tuple[float, float]) -> str:
    """A printf format whose three labels over ``clim`` differ: enough significant
    digits for the range's width relative to its size (at least 3).

    Examples
    --------
    >>> label_format((0.0, 1.0)), label_format((1.1997, 1.2))
    ('%.3g', '%.7g')
    """
    lo, hi = clim
    size = max(abs(lo), abs(hi))
    width = hi - lo
    if not (width > 0 and np.isfinite(size)) or size == 0:
        return "%.3g"
    return f"%.{int(min(12, max(3, np.ceil(np.log10(size / width)) + 3)))}g"


def _opacity_tf(scale: float) -> NDArray[np.float64]:
    """A ramp transfer function (low values transparent), scaled by ``scale``."""
    return np.clip(np.linspace(-0.15, 1.0, 64), 0, 1) ** 1.5 * scale
