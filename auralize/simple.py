"""pvpython-like scripting: ``from auralize.simple import *``.

Reads like a ``paraview.simple`` session: functions in CamelCase act on the
*active* source and view unless told otherwise, and remember what they made.
All state lives in a :class:`Session` (the module keeps one default session,
reachable with :func:`GetSession`; :func:`ResetSession` starts afresh) — never
in the caller's globals.  Views render off screen with pyvista, so scripts run
headless (``auralize script FILE.py`` or ``python FILE.py``); inside the
desktop viewer the active view is the window's.

Errors are the library's own (:mod:`auralize.errors`): a missing file raises
``FormatError``/``MissingFileError``, an unknown field ``FieldError``, no sound
device ``DeviceError``, and so on.

Filters take their input positionally or as ``Input=`` / ``source=`` (as
``paraview.simple`` filters do), and writers take the file name first:
``DetectSources(src)``, ``RenderAudio(src, path=path)``,
``SaveAudio("out.wav", rendered)``.  Every public function has an example
below its description; the test suite runs them all (doctest).

Examples
--------
>>> from auralize.simple import *
>>> session = ResetSession()
>>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
>>> series = DetectSources(src, monopole="1%")
>>> path = CreateListenerPath("line", start=src.Volume.center + [0.5, 0, 0],
...                           end=src.Volume.center + [1, 0, 0], duration=0.02)
>>> RenderAudio(src, path=path, layout="stereo").audio.shape
(2, 882)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from auralize.defaults import DEFAULTS, TIMBRE_CHOICES, Interp
from auralize.emitters.synthesis import Rendered
from auralize.errors import ArgumentError, ParameterError
from auralize.listener import ListenerPath
from auralize.scene.soundscene import SceneModel
from auralize.sources.detection import SourceSeries, Thresholds
from auralize.volume import TimeVolume

if TYPE_CHECKING:
    from auralize.audio.output import Normalize

__all__ = [
    "AddSoundModel",
    "ApplyMapping",
    "CreateListenerPath",
    "CreateView",
    "Describe",
    "DetectSources",
    "GetActiveSource",
    "GetActiveView",
    "GetListenerPath",
    "GetSession",
    "Hide",
    "LoadSession",
    "OpenDataFile",
    "PlayAudio",
    "RecordListenerPath",
    "RemoveSoundModel",
    "Render",
    "RenderAudio",
    "ResetSession",
    "SaveAudio",
    "SaveListenerPath",
    "SaveScreenshot",
    "SaveSession",
    "Session",
    "SetActiveSource",
    "SetActiveView",
    "Show",
]


@dataclass(eq=False, repr=False)
class DataSource:
    """An opened volume and what was derived from it (the "source proxy").

    Attributes mirror ParaView's CamelCase properties: ``FileName``,
    ``Volume``, ``Mapping``, ``MappingFields``, ``Thresholds``, ``Sources``
    (the detected :class:`SourceSeries`, or None).
    """

    FileName: str
    Volume: TimeVolume
    LoadOptions: dict[str, Any] = field(default_factory=dict)
    Mapping: str | None = None
    MappingFields: dict[str, str] = field(default_factory=dict)
    Thresholds: Thresholds | None = None
    Sources: SourceSeries | None = None
    Field: str | None = None

    @property
    def Detection(self) -> Any:  # the viewer's step-wise detection (built lazily)
        if getattr(self, "_detection", None) is None:
            from auralize.scene.detection import Detection

            self._detection = Detection(
                self.Volume, mapping=self.Mapping, thresholds=self.Thresholds, **self.MappingFields
            )
            if self.Sources is not None:
                self._detection.frames.update(enumerate(self.Sources.frames))
        return self._detection

    def _invalidate(self) -> None:
        self.Sources = None
        self._detection = None

    def __repr__(self) -> str:
        v = self.Volume
        det = (
            "not detected"
            if self.Sources is None
            else f"{sum(sum(c.values()) for c in self.Sources.counts())} detected"
        )
        return (
            f"<DataSource {self.FileName!r}: {v.dims[0]}×{v.dims[1]}×{v.dims[2]} points, "
            f"{v.n_steps} steps, fields {', '.join(v.field_names)}; sources {det}>"
        )

    def _repr_html_(self) -> str:
        return self.Volume._repr_html_() if hasattr(self.Volume, "_repr_html_") else repr(self)


class View:
    """A 3-D view: an off-screen pyvista plotter with the viewer's :class:`Scene`.

    Properties ``CameraPosition``, ``CameraFocalPoint``, ``CameraViewUp``,
    ``ViewTime`` (time step) and ``ViewSize`` (pixels) can be read and set.
    In a Jupyter notebook a view displays as a static picture (``_repr_png_``).

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=6)
    >>> v = Show(src, CreateView(size=(160, 120)))
    >>> v.ViewTime = 3
    >>> v.ViewTime
    3
    >>> v._repr_png_()[:4]
    b'\x89PNG'
    """

    def _repr_png_(self) -> bytes:
        """The view as PNG bytes (what a notebook shows for ``Show(...)``)."""
        import io

        from PIL import Image

        img = self.plotter.screenshot(None, return_img=True)
        buf = io.BytesIO()
        Image.fromarray(np.asarray(img)).save(buf, format="PNG")
        return buf.getvalue()

    def __init__(
        self, session: Session, *, size: tuple[int, int] = (800, 600), plotter: Any = None
    ) -> None:
        from auralize.scene.pictures import prefer_egl
        from auralize.scene.view import Scene

        if plotter is None:
            prefer_egl()
            import pyvista as pv

            plotter = pv.Plotter(off_screen=True, window_size=list(size))
        self.session = session
        self.plotter = plotter
        self.scene = Scene(plotter)
        self.shown: DataSource | None = None
        self.show_path = True

    # camera properties, ParaView style
    @property
    def CameraPosition(self) -> list[float]:
        return list(map(float, self.plotter.camera.position))

    @CameraPosition.setter
    def CameraPosition(self, v: ArrayLike) -> None:
        self.plotter.camera.position = tuple(np.asarray(v, float).reshape(3))

    @property
    def CameraFocalPoint(self) -> list[float]:
        return list(map(float, self.plotter.camera.focal_point))

    @CameraFocalPoint.setter
    def CameraFocalPoint(self, v: ArrayLike) -> None:
        self.plotter.camera.focal_point = tuple(np.asarray(v, float).reshape(3))

    @property
    def CameraViewUp(self) -> list[float]:
        return list(map(float, self.plotter.camera.up))

    @CameraViewUp.setter
    def CameraViewUp(self, v: ArrayLike) -> None:
        self.plotter.camera.up = tuple(np.asarray(v, float).reshape(3))

    @property
    def ViewTime(self) -> int:
        return self.scene.step

    @ViewTime.setter
    def ViewTime(self, step: int) -> None:
        self.scene.set_step(int(step), render=False)

    @property
    def ViewSize(self) -> list[int]:
        return list(self.plotter.window_size)

    @ViewSize.setter
    def ViewSize(self, wh: tuple[int, int]) -> None:
        self.plotter.window_size = [int(wh[0]), int(wh[1])]

    def close(self) -> None:
        self.plotter.close()


class Session:
    """Everything a scripting session knows: data sources, views, paths, renders.

    Attributes
    ----------
    sources : list of DataSource
    active_source, active_view : the current ones (or None)
    path : ListenerPath or None, the active listener path
    rendered : Rendered or None, the last render
    audio : dict, audio settings (layout, rate, time_scale, device); ``time_scale`` is
        ``"auto"`` (the default, as ``auralize render``'s: the data's sound fits the
        path's duration) or playback seconds per data second
    models : list of SceneModel, sound models heard with the data (:func:`AddSoundModel`)

    Examples
    --------
    >>> s = Session()
    >>> s.active_source is None, s.audio["layout"], s.audio["time_scale"]
    (True, 'mono', 'auto')
    """

    def __init__(self) -> None:
        self.sources: list[DataSource] = []
        self.views: list[View] = []
        self.active_source: DataSource | None = None
        self.active_view: View | None = None
        self.path: ListenerPath | None = None
        self.rendered: Rendered | None = None
        self.audio: dict[str, Any] = {
            "layout": DEFAULTS.layout,
            "rate": DEFAULTS.rate,
            "time_scale": DEFAULTS.time_scale,
            "device": None,
            "heard": DEFAULTS.heard,
            "timbre": DEFAULTS.timbre,
        }
        self.models: list[SceneModel] = []

    def source(self, src: DataSource | None) -> DataSource:
        s = src or self.active_source
        if s is None:
            raise ParameterError("no active source; call OpenDataFile(...) first")
        return s

    def view(self, view: View | None = None, *, create: bool = True, caller: str = "") -> View:
        if view is not None and not isinstance(view, View):
            hint = (
                f"; to show a listener path, give it as the first argument: {caller}(path)"
                if isinstance(view, ListenerPath) and caller == "Show"
                else ""
            )
            raise ArgumentError(
                f"{caller or 'the'} view argument must be a View (from "
                f"CreateView() or GetActiveView()) or None for the active "
                f"view, got a {type(view).__name__}{hint}"
            )
        v = view or self.active_view
        if v is None:
            if not create:
                raise ParameterError("no active view")
            v = View(self)
            self.views.append(v)
            self.active_view = v
        return v

    def close(self) -> None:
        for v in self.views:
            v.close()
        self.views.clear()
        self.active_view = None


_SESSION = Session()


def GetSession() -> Session:
    """The session the module-level functions act on.

    Examples
    --------
    >>> GetSession().audio["rate"]
    44100
    """
    return _SESSION


def ResetSession() -> Session:
    """Close the views and start a new, empty session.

    Examples
    --------
    >>> ResetSession().sources
    []
    """
    global _SESSION
    _SESSION.close()
    _SESSION = Session()
    return _SESSION


# ------------------------------------------------------------------ sources
def OpenDataFile(
    filename: str | Path,
    *,
    size: int | None = None,
    steps: int | None = None,
    seed: int = 0,
    fields: dict[str, str] | None = None,
) -> DataSource:
    """Open a volume file or ``"dataset:NAME"`` and make it the active source.

    Raises the reader's errors (e.g. :class:`~auralize.errors.FormatError`) for
    unreadable files.  Nothing is detected yet (see :func:`DetectSources`).

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> src  # doctest: +ELLIPSIS
    <DataSource 'dataset:monopole': 12×12×12 points, 60 steps, fields density; sources not detected>
    """
    from auralize.pipeline import auto_mapping, load

    vol = load(filename, size=size, steps=steps, seed=seed, fields=fields)
    src = DataSource(
        FileName=str(filename),
        Volume=vol,
        LoadOptions={"size": size, "steps": steps, "seed": seed},
        Mapping=auto_mapping(vol),
    )
    s = GetSession()
    s.sources.append(src)
    s.active_source = src
    return src


def GetActiveSource() -> DataSource | None:
    """The active data source (the last opened or set), or None.

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> GetActiveSource() is src
    True
    """
    return GetSession().active_source


def SetActiveSource(source: DataSource) -> None:
    """Make ``source`` the one filters act on by default.

    Examples
    --------
    >>> a = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> b = OpenDataFile("dataset:monopole", size=10, steps=60)
    >>> SetActiveSource(a); GetActiveSource() is a
    True
    """
    s = GetSession()
    if source not in s.sources:
        s.sources.append(source)
    s.active_source = source


def ApplyMapping(
    Input: DataSource | str | None = None,
    mapping: str | None = None,
    *,
    source: DataSource | None = None,
    **fields: str,
) -> DataSource:
    """Choose the acoustic mapping (``paper-density``, ``identity``, ``cfd``) and its fields.

    ``ApplyMapping(src, "identity", density="rho")`` or, on the active source,
    ``ApplyMapping("identity", density="rho")``.  Checked at once: a field the
    volume lacks raises :class:`~auralize.errors.FieldError`.

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> ApplyMapping(src, "identity", density="density").Mapping
    'identity'
    """
    from auralize.sources.mapping import get_mapping

    if isinstance(Input, str):  # ApplyMapping("cfd", ...) on the active source
        if mapping is not None:
            raise ParameterError(f"give the mapping once, got {Input!r} and {mapping!r}")
        Input, mapping = None, Input
    mapping = mapping or "paper-density"
    src = GetSession().source(_input(Input, source))
    m = get_mapping(mapping, **fields)
    m.prepare(src.Volume)
    src.Mapping, src.MappingFields = mapping, dict(fields)
    src._invalidate()
    return src


def DetectSources(
    Input: DataSource | None = None,
    *,
    source: DataSource | None = None,
    monopole: float | str | None = None,
    dipole: float | str | None = None,
    quadrupole: float | str | None = None,
    zero_fraction: float = 1.0,
) -> SourceSeries:
    """Detect sources at every step of ``Input`` (default: the active source).

    Thresholds are absolute, ``"N%"`` of the peak, or ``"auto"``; unset ones are
    ``"auto"``, as in ``auralize detect`` and the viewer.  Single-step data raises
    :class:`~auralize.errors.DataError` (strengths are time derivatives).

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> series = DetectSources(src, monopole="1%")
    >>> series.n_steps, series.counts()[30]["monopole"] > 0
    (60, True)
    """
    src = GetSession().source(_input(Input, source))
    given = (monopole, dipole, quadrupole)
    th = Thresholds(
        *(g if g is not None else d for g, d in zip(given, DEFAULTS.thresholds, strict=True)),
        zero_fraction=zero_fraction,
    )
    det = getattr(src, "_detection", None)
    if det is None or det.thresholds.describe() != th.describe():
        src.Thresholds = th
        src._invalidate()
    src.Sources = src.Detection.run()
    for v in GetSession().views:
        if v.shown is src:
            v.scene.set_sources(src.Detection.get)
    return src.Sources


# ------------------------------------------------------------------ listener
def CreateListenerPath(
    kind: str = "orbit",
    *,
    Input: DataSource | None = None,
    source: DataSource | None = None,
    duration: float | None = None,
    **kw: Any,
) -> ListenerPath:
    """Make the active listener path.

    ``kind`` is ``"line"`` (``start``, ``end``, optional ``n``, ``face``),
    ``"orbit"`` (``center``, ``radius``, ``turns``, ``height``, ``rate_hz``),
    ``"point"`` (``at``) or the name of a CSV file.  Defaults come from the
    source (``Input=``/``source=``, else the active one): centre of the grid,
    radius 30 % of the smallest extent, and the duration of the data at the session's
    ``time_scale`` (at 1 when it is ``"auto"``: the data's span in real time; the
    render then fits the data's sound in the path's duration).

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> CreateListenerPath("orbit", radius=1.0, duration=2.0).duration
    2.0
    """
    s = GetSession()
    source = _input(Input, source)
    if kind not in ("line", "orbit", "point"):
        if not Path(kind).suffix.lower() == ".csv" and not Path(kind).exists():
            raise ParameterError(
                f"kind must be 'line', 'orbit', 'point' or a CSV file, got {kind!r}"
            )
        path = ListenerPath.from_csv(kind)
    else:
        src = s.active_source if source is None else source
        vol = src.Volume if src is not None else None
        if duration is None:
            if vol is None:
                raise ParameterError("give duration= (no active source to take it from)")
            duration = float(vol.times[-1] - vol.times[0]) * _fixed_scale(s)
        if kind == "orbit":
            center = kw.pop("center", vol.center if vol is not None else None)
            radius = kw.pop("radius", None)
            if radius is None and vol is not None:
                # 0.3 of the box's smallest side; a one-layer grid's zero side is no side
                sides = np.asarray(vol.bounds, dtype=np.float64).reshape(3, 2) @ [-1.0, 1.0]
                if np.any(sides > 0):
                    radius = 0.3 * float(np.min(sides[sides > 0]))
            if center is None or radius is None:
                raise ParameterError("orbit needs center= and radius=")
            path = ListenerPath.orbit(center, radius=radius, duration=duration, **kw)
        elif kind == "line":
            if "start" not in kw or "end" not in kw:
                raise ParameterError("a line path needs start=(x, y, z) and end=(x, y, z)")
            path = ListenerPath.line(kw.pop("start"), kw.pop("end"), duration=duration, **kw)
        else:
            at = kw.pop("at", vol.center if vol is not None else None)
            path = ListenerPath.point(at, duration=duration, **kw)
    s.path = path
    for v in s.views:
        v.scene.set_path(
            path if v.show_path else None, time_scale=_time_scale(s, v, path), render=False
        )
    return path


def GetListenerPath() -> ListenerPath | None:
    """The active listener path (None before one is made).

    Examples
    --------
    >>> p = CreateListenerPath("point", at=(0, 0, 0), duration=1.0)
    >>> GetListenerPath() is p
    True
    """
    return GetSession().path


def SaveListenerPath(filename: str | Path, path: ListenerPath | None = None) -> None:
    """Write the (active) listener path as a CSV file (``t,x,y,z,fx,fy,fz,ux,uy,uz``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "path.csv"
    >>> SaveListenerPath(out, CreateListenerPath("point", at=(0, 0, 0), duration=1.0))
    >>> out.read_text().splitlines()[0]
    't,x,y,z,fx,fy,fz,ux,uy,uz'
    """
    p = path or GetSession().path
    if p is None:
        raise ParameterError("no listener path; call CreateListenerPath or RecordListenerPath")
    p.to_csv(filename)


def RecordListenerPath(
    keyframes: list[dict[str, ArrayLike]] | None = None,
    *,
    duration: float | None = None,
    rate_hz: float = 10.0,
    view: View | None = None,
    autosave: str | Path | None = None,
    render: bool = False,
) -> ListenerPath:
    """Fly the view's camera through ``keyframes`` and record the listener path.

    Each keyframe is a dict with ``position`` and ``focal_point`` (and
    optionally ``up``); the camera moves linearly between them over
    ``duration`` playback seconds (default: the data's duration) and is
    captured ``rate_hz`` times a second, exactly as the desktop viewer records
    a flight (same :class:`~auralize.scene.recorder.PathRecorder`, same
    autosave CSV).  Without keyframes the current camera is held.

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> c = src.Volume.center
    >>> p = RecordListenerPath([{"position": c + [3, 0, 0], "focal_point": c},
    ...                         {"position": c + [0, 3, 0], "focal_point": c}],
    ...                        duration=1.0, rate_hz=10)
    >>> p.n_captures
    11
    """
    from auralize.scene.recorder import PathRecorder
    from auralize.scene.view import camera_pose

    s = GetSession()
    v = s.view(view, caller="RecordListenerPath")
    cam = v.plotter.camera
    if not keyframes:
        keyframes = [{"position": cam.position, "focal_point": cam.focal_point, "up": cam.up}]
    if duration is None:
        src = v.shown or s.active_source
        if src is None:
            raise ParameterError("give duration= (no data source to take it from)")
        duration = float(src.Volume.times[-1] - src.Volume.times[0]) * _fixed_scale(s)
    rec = PathRecorder(rate_hz=rate_hz, autosave=autosave)
    n = max(int(math.floor(duration * rec.rate_hz + 1e-9)) + 1, 2)
    kf = [
        {
            k: np.asarray(f.get(k, (0, 0, 1) if k == "up" else None), dtype=float)
            for k in ("position", "focal_point", "up")
        }
        for f in keyframes
    ]
    rec.start()
    for i in range(n):
        t = i / rec.rate_hz if i < n - 1 else duration
        w = t / duration * (len(kf) - 1)
        a = min(int(w), len(kf) - 2) if len(kf) > 1 else 0
        b = min(a + 1, len(kf) - 1)
        f = w - a if len(kf) > 1 else 0.0
        cam.position = tuple((1 - f) * kf[a]["position"] + f * kf[b]["position"])
        cam.focal_point = tuple((1 - f) * kf[a]["focal_point"] + f * kf[b]["focal_point"])
        cam.up = tuple((1 - f) * kf[a]["up"] + f * kf[b]["up"])
        if render:
            v.plotter.render()
        rec.capture(*camera_pose(cam), t=t)
    path = rec.stop()
    assert path is not None
    s.path = path
    v.scene.set_path(
        path if v.show_path else None, time_scale=_time_scale(s, v, path), render=False
    )
    return path


# --------------------------------------------------------------------- audio
def RenderAudio(
    Input: DataSource | None = None,
    *,
    source: DataSource | None = None,
    path: ListenerPath | None = None,
    layout: str | None = None,
    rate: int | None = None,
    time_scale: float | str | None = None,
    interp: Interp = DEFAULTS.interp,
    timbre: str | None = None,
    heard: str | None = None,
    air: Any = None,
    ground: Any = None,
) -> Rendered:
    """Render the sound heard along ``path`` (default: the active path) from ``Input``
    (default: the active source), plus every sound model added with :func:`AddSoundModel`.

    What is heard is the session's ``audio["heard"]`` (``heard`` sets it):
    ``"field"`` (default) the whole field, ``"detected"`` the detected sources
    (detected first with the current thresholds if needed), ``"dipole,quadrupole"``
    some of their types, ``"field:quadrupole"`` one term of the whole field
    (:func:`auralize.sources.field.parse_heard`).

    The audio lasts the path's duration, clipped to the time the data's sound
    lasts at the session's ``time_scale`` (then ``r.meta["notes"]`` says so)
    unless models are added: a scene lasts the path's whole duration,
    whenever the data's sound ends (as ``auralize render --path``).
    The added models are rendered along the same path with the same layout
    and rate, and summed (``r.meta["parts"]`` lists them); the 20 Hz output
    high-pass filters the data's sources only (a ``field`` model's too: the
    rule of :func:`auralize.pipeline.render`); without a data
    source the render is the models' alone, for the path's duration.

    The defaults are those of ``auralize render`` and the viewer
    (:data:`auralize.defaults.DEFAULTS`): the session's ``timbre`` ``"auto"``
    (physical if most of its energy is above 20 Hz, else extended; ``timbre``
    sets it), a 20 Hz high-pass, the steady part removed, the time scale
    ``"auto"`` (the data's sound fits the path's duration) and ``auto``
    detection thresholds (:func:`DetectSources`).  The listener path is the
    session's (no default orbit).

    ``air`` and ``ground`` hear it outdoors (off by default): air absorption
    after ISO 9613-1 and a flat reflecting ground, for the data's sources and
    every model (:class:`auralize.emitters.outdoor.Air`,
    :class:`auralize.emitters.outdoor.Ground`; :func:`auralize.pipeline.render`).

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> p = CreateListenerPath("point", at=src.Volume.center + [1, 0, 0], duration=0.02)
    >>> r = RenderAudio(src, path=p, layout="stereo")
    >>> r.audio.shape, r.rate
    ((2, 882), 44100)
    """
    from auralize.emitters.timbre import HIGHPASS_HZ
    from auralize.pipeline import auralize, render
    from auralize.scene.soundscene import scene_sound

    s = GetSession()
    given = _input(Input, source)
    src = s.source(given) if given is not None or not s.models else s.active_source
    p = path or s.path
    if p is None:
        raise ParameterError("no listener path; call CreateListenerPath or RecordListenerPath")
    if heard is not None:
        from auralize.sources.field import parse_heard

        s.audio["heard"] = parse_heard(heard).label
    if timbre is not None:
        if timbre not in TIMBRE_CHOICES:
            raise ParameterError(f"timbre must be one of {list(TIMBRE_CHOICES)}, got {timbre!r}")
        s.audio["timbre"] = timbre
    if time_scale is not None:
        _check_time_scale(time_scale)
    for k, val in (("layout", layout), ("rate", rate), ("time_scale", time_scale)):
        if val is not None:
            s.audio[k] = val
    rate = int(s.audio["rate"])
    outdoor = {} if air is None and ground is None else {"air": air, "ground": ground}
    models = scene_sound(s.models, p, p.duration, rate=rate) if s.models else None
    out: Rendered
    if src is not None:
        from auralize.sources.field import parse_heard

        hd = parse_heard(s.audio.get("heard") or "field")
        if src.Sources is None and hd.mode == "detected":
            src.Sources = src.Detection.run()
        out, _ = auralize(
            src.Volume,
            p,
            series=src.Sources,
            rate=rate,
            time_scale=_check_time_scale(s.audio["time_scale"]),
            layout=s.audio["layout"],
            interp=interp,
            timbre=s.audio.get("timbre", DEFAULTS.timbre),
            clip=not s.models,
            heard=hd,
            extra=models,
            thresholds=src.Thresholds,
            mapping=src.Mapping,
            **outdoor,
            **dict[str, Any](src.MappingFields),
        )
    else:
        assert models is not None
        out = render(
            models,
            p,
            rate=rate,
            layout=s.audio["layout"],
            duration=p.duration,
            highpass_hz=HIGHPASS_HZ,
            **outdoor,
        )
    assert out is not None
    s.rendered = out
    return out


def Describe(
    Input: DataSource | None = None,
    *,
    source: DataSource | None = None,
    path: ListenerPath | None = None,
    time_scale: float | str | None = None,
    heard: str | None = None,
) -> Any:
    """Describe the sources of ``Input`` (default: the active source) in words, and when
    the listener hears them: an :class:`auralize.describe.Description` (``print`` it for
    the text; ``.rows`` and ``.events`` hold the figures, ``.save("d.csv")`` writes them).

    The sources are the source's detected ones (detected first, as
    :func:`DetectSources` does, if needed); the render described is
    :func:`RenderAudio`'s: the session's listener path (``path`` overrides it;
    with none, the default orbit of ``auralize render``), its time scale and
    what it hears.  Levels are those of each type's detected sources at the
    listener, in dB relative to the loudest (:mod:`auralize.describe`).

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=16)
    >>> p = CreateListenerPath("point", at=(0.9, 0.5, 0.5), duration=1.0)
    >>> d = Describe(src)
    >>> [e.type for e in d.events], d.plan["duration_s"]
    (['monopole'], 1.0)
    >>> str(d).splitlines()[0]
    'Sources in dataset:monopole (12 × 12 × 12 points, 16 steps, 0 .. 0.005 s)'
    """
    from auralize.describe import describe
    from auralize.sources.field import parse_heard

    s = GetSession()
    src = s.source(_input(Input, source))
    if src.Sources is None:
        src.Sources = src.Detection.run()
    ts = _check_time_scale(time_scale if time_scale is not None else s.audio["time_scale"])
    hd = parse_heard(heard if heard is not None else s.audio.get("heard") or DEFAULTS.heard)
    return describe(
        src.Volume,
        series=src.Sources,
        path=path or s.path,
        time_scale=ts,
        heard=hd.label,
        name=src.FileName,
    )


def AddSoundModel(name: str, input: Any, **params: Any) -> SceneModel:
    """Add a sound model to the session's scene: :func:`RenderAudio` (and so
    :func:`SaveAudio` and :func:`PlayAudio`) then mixes its sound with the data's.

    ``input`` is the model's input (a file or ``dataset:NAME`` read by the
    model's ``load_input``, or the inputs themselves); ``params`` are the
    model's parameters (``auralize plugins`` lists them).  Returns the entry
    (give it to :func:`RemoveSoundModel` to take it out again).

    Examples
    --------
    >>> from auralize.pipeline import load
    >>> s = ResetSession()
    >>> vol = load("dataset:monopole", size=12, steps=60)  # a spec string works too
    >>> m = AddSoundModel("field", vol, threshold_monopole="1%")
    >>> p = CreateListenerPath("point", at=vol.center + [0.5, 0, 0], duration=0.02)
    >>> r = RenderAudio(path=p)
    >>> [part["model"] for part in r.meta["parts"]], r.audio.shape
    (['field'], (1, 882))
    """
    entry = SceneModel(model=name, input=input, params=dict(params))
    entry.check()  # an unknown model or parameter fails here, not at the render
    GetSession().models.append(entry)
    return entry


def RemoveSoundModel(entry: SceneModel | str) -> None:
    """Take a model added by :func:`AddSoundModel` out of the scene (the entry, or
    every entry of a model name).

    Examples
    --------
    >>> s = ResetSession()
    >>> m = AddSoundModel("field", "dataset:monopole")
    >>> RemoveSoundModel("field"); GetSession().models
    []
    """
    s = GetSession()
    before = len(s.models)
    s.models = [m for m in s.models if m is not entry and m.model != entry]
    if len(s.models) == before:
        raise ParameterError(f"no sound model {entry!r} in the session's scene")


def SaveAudio(
    filename: str | Path, rendered: Rendered | None = None, *, normalize: Normalize = "peak"
) -> float:
    """Write ``rendered`` (default: the last render) as WAV/FLAC + sidecar JSON, as
    ParaView's ``SaveData(filename, proxy)``; returns the gain applied.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> r = RenderAudio(src, path=CreateListenerPath("point", duration=0.05))
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "tone.wav"
    >>> SaveAudio(out, r) > 0, out.exists(), pathlib.Path(f"{out}.json").exists()
    (True, True, True)
    """
    from auralize.pipeline import save_rendered
    from auralize.runtime.files import check_output_path

    check_output_path(filename)  # a bad place fails before anything else
    r = rendered or GetSession().rendered
    if r is None:
        raise ParameterError("nothing rendered yet; call RenderAudio() first")
    return save_rendered(r, filename, normalize=normalize)


def PlayAudio(
    rendered: Rendered | None = None,
    *,
    device: Any = None,
    gain_db: float = 0.0,
    blocking: bool = True,
) -> Any:
    """Play the last render on a sound device through a gain control and a limiter.

    The loudest sample is put at full scale (``gain_db`` adds to that; what would
    exceed full scale is limited, see :class:`auralize.audio.output.Limiter`).  Returns
    the :class:`auralize.audio.output.Playback` (``.stop()``, ``.limiter`` level meter).
    Raises :class:`~auralize.errors.DeviceError` when no device is usable.

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> r = RenderAudio(src, path=CreateListenerPath("point", duration=0.05))
    >>> PlayAudio(r, device="no such device")  # the device is checked first
    Traceback (most recent call last):
    auralize.errors.DeviceError: ...

    ``PlayAudio(r, device="auralize_file")`` plays it on the device of that name
    (the test suite's file-backed ALSA device) and waits until it has played.
    """
    from auralize.audio.output import play

    r = rendered or GetSession().rendered
    if r is None:
        raise ParameterError("nothing rendered yet; call RenderAudio() first")
    dev = device if device is not None else GetSession().audio.get("device")
    return play(r.audio, r.rate, device=dev, gain_db=gain_db, blocking=blocking)


# ---------------------------------------------------------------------- views
def CreateView(*, size: tuple[int, int] = (800, 600)) -> View:
    """A new off-screen view, made active.

    Examples
    --------
    >>> v = CreateView(size=(320, 240))
    >>> v.ViewSize, GetActiveView() is v
    ([320, 240], True)
    """
    s = GetSession()
    v = View(s, size=size)
    s.views.append(v)
    s.active_view = v
    return v


def GetActiveView() -> View:
    """The active view (created off screen if there is none).

    Examples
    --------
    >>> GetActiveView() is GetActiveView()
    True
    """
    return GetSession().view()


def SetActiveView(view: View) -> None:
    """Make ``view`` the one :func:`Show`, :func:`Render` and screenshots use.

    Examples
    --------
    >>> a, b = CreateView(), CreateView()
    >>> SetActiveView(a); GetActiveView() is a
    True
    """
    GetSession().active_view = view


def Show(
    obj: DataSource | ListenerPath | None = None,
    view: View | None = None,
    *,
    field: str | None = None,
    representation: str | None = None,
    step: int | None = None,
) -> View:
    """Show a data source (its volume, and its sources once detected) or a listener path
    in a view.  In a Jupyter notebook the returned view displays as a picture.

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> v = Show(src, step=30)
    >>> v.ViewTime, v.scene.field
    (30, 'density')
    """
    s = GetSession()
    v = s.view(view, caller="Show")
    if obj is not None and not isinstance(obj, DataSource | ListenerPath):
        raise ArgumentError(
            f"Show's first argument must be a data source (OpenDataFile), a "
            f"ListenerPath or None for the active source, got a "
            f"{type(obj).__name__}"
        )
    if isinstance(obj, ListenerPath):
        s.path = obj
        obj = None
        v.show_path = True
        v.scene.set_path(s.path, time_scale=_time_scale(s, v, s.path), render=False)
        return v
    src = s.source(obj)
    if v.shown is not src:
        v.scene.set_volume(src.Volume, field=field or src.Field, representation=representation)
        v.shown = src
    else:
        if field is not None:
            v.scene.set_field(field, render=False)
        if representation is not None:
            v.scene.set_representation(representation, render=False)
    v.scene.show_volume = True
    v.scene.show_sources = True
    src.Field = v.scene.field
    # look first: sources are drawn once detected (DetectSources), never detected here
    v.scene.set_sources(src.Detection.get if src.Sources is not None else None)
    if s.path is not None and v.show_path:
        v.scene.set_path(s.path, time_scale=_time_scale(s, v, s.path), render=False)
    if step is not None:
        v.scene.set_step(step, render=False)
    return v


def Hide(obj: DataSource | ListenerPath | str | None = None, view: View | None = None) -> None:
    """Hide a source, the listener path (a ListenerPath or ``"path"``), or ``"sources"``.

    Examples
    --------
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> v = Show(src)
    >>> Hide("sources"); v.scene.show_sources
    False
    """
    s = GetSession()
    v = s.view(view, caller="Hide")
    if isinstance(obj, ListenerPath) or obj == "path":
        v.show_path = False
        v.scene.set_path(None, render=False)
    elif obj == "sources":
        v.scene.show_sources = False
        v.scene.set_step(v.scene.step, render=False)
    else:
        v.scene.show_volume = False
        v.scene.show_sources = False
        if v.scene.volume is not None:
            v.scene.set_step(v.scene.step, render=False)


def Render(view: View | None = None) -> View:
    """Redraw the (active) view.

    Examples
    --------
    >>> v = Render(Show(OpenDataFile("dataset:monopole", size=12, steps=60)))
    >>> v is GetActiveView()
    True
    """
    v = GetSession().view(view, caller="Render")
    v.plotter.render()
    return v


def SaveScreenshot(
    filename: str | Path, view: View | None = None, *, resolution: tuple[int, int] | None = None
) -> Path:
    """Render the view off screen to a PNG.

    As ParaView's ``SaveScreenshot``, the view is rendered with what is shown in
    it; a view nothing was shown in first shows the active source (as
    :func:`Show` would), and with no source (and no listener path) to show
    ``ParameterError`` says so rather than writing a dark picture.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> Show(OpenDataFile("dataset:monopole", size=12, steps=60))  # doctest: +ELLIPSIS
    <auralize.simple.View ...>
    >>> out = SaveScreenshot(pathlib.Path(tempfile.mkdtemp()) / "v.png", resolution=(160, 120))
    >>> out.stat().st_size > 1000
    True
    """
    s = GetSession()
    v = s.view(view, caller="SaveScreenshot")
    if v.shown is None and v.scene.volume is None:
        if s.active_source is not None:
            Show(s.active_source, v)
        elif s.path is not None and v.show_path:
            Show(s.path, v)
            v.plotter.reset_camera()
        else:
            raise ParameterError(
                f"nothing to show in the screenshot {str(filename)!r}: open "
                f"data first (OpenDataFile) and Show it, or Show a listener "
                f"path"
            )
    if resolution is not None:
        v.ViewSize = resolution
    out = Path(filename)
    out.parent.mkdir(parents=True, exist_ok=True)
    v.plotter.render()
    v.plotter.screenshot(str(out))
    return out


# ------------------------------------------------------------------- session
def SaveSession(filename: str | Path) -> Path:
    """Save the session (data, mapping, thresholds, path, audio settings, camera, and the
    sound models added with :func:`AddSoundModel`) as JSON.

    Models are saved with their input's file name or ``dataset:NAME``; a model
    given its inputs in memory cannot be saved and raises ``ParameterError``.

    Examples
    --------
    >>> import json, tempfile, pathlib
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> f = SaveSession(pathlib.Path(tempfile.mkdtemp()) / "s.json")
    >>> json.loads(f.read_text())["data"]["spec"]
    'dataset:monopole'
    """
    from auralize.scene.session import SessionState, data_spec

    s = GetSession()
    st = SessionState(audio=dict(s.audio))
    src = s.active_source
    if src is not None:
        st.data = data_spec(src.FileName, **src.LoadOptions)
        st.detection = {
            "mapping": src.Mapping,
            "mapping_fields": src.MappingFields,
            "thresholds": (src.Thresholds or Thresholds(*DEFAULTS.thresholds)).describe(),
        }
        st.view = {"field": src.Field}
    st.set_listener_path(s.path)
    for m in s.models:
        if not isinstance(m.input, str):
            raise ParameterError(
                f"cannot save sound model {m.model!r}: its input is a "
                f"{type(m.input).__name__} in memory; add it with a file name "
                f"or dataset:NAME to save the session"
            )
        spec = m.input
        if not spec.startswith("dataset:") and Path(spec).expanduser().exists():
            spec = str(Path(spec).expanduser().resolve())
        st.models.append({"model": m.model, "input": spec, "params": dict(m.params)})
    if s.active_view is not None:
        sc = s.active_view.scene
        st.camera = sc.camera()
        st.view.update(
            {
                "representation": sc.representation,
                "step": sc.step,
                "cmap": sc.cmap,
                "opacity": sc.opacity,
                "types": dict(sc.visible_types),
            }
        )
    st.save(filename)
    return Path(filename)


def LoadSession(filename: str | Path) -> Session:
    """Replace the session by one saved with :func:`SaveSession` or the desktop viewer.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> src = OpenDataFile("dataset:monopole", size=12, steps=60)
    >>> f = SaveSession(pathlib.Path(tempfile.mkdtemp()) / "s.json")
    >>> LoadSession(f).active_source.Volume.dims
    (12, 12, 12)
    >>> _ = ResetSession()
    >>> m = AddSoundModel("field", "dataset:explosion", time_scale="auto")
    >>> f = SaveSession(pathlib.Path(tempfile.mkdtemp()) / "s.json")
    >>> [(m.model, m.input) for m in LoadSession(f).models]
    [('field', 'dataset:explosion')]
    """
    from auralize.scene.session import SessionState

    st = SessionState.load(filename)
    ResetSession()
    s = GetSession()
    s.audio.update(st.audio or {})
    if st.data:
        d = st.data
        src = OpenDataFile(
            d["spec"], size=d.get("size"), steps=d.get("steps"), seed=d.get("seed") or 0
        )
        det = st.detection or {}
        if det.get("mapping"):
            ApplyMapping(det["mapping"], **(det.get("mapping_fields") or {}))
        if det.get("thresholds"):
            t = det["thresholds"]
            src.Thresholds = Thresholds(
                t["monopole"],
                t["dipole"],
                t["quadrupole"],
                zero_fraction=t.get("zero_fraction", 1.0),
            )
        src.Field = (st.view or {}).get("field")
    s.path = st.listener_path()
    for m in st.models:
        AddSoundModel(m["model"], m["input"], **(m.get("params") or {}))
    if st.camera and s.active_source is not None:
        view = st.view or {}
        v = Show(field=view.get("field"), representation=view.get("representation"))
        if "step" in view:
            v.scene.set_step(int(view["step"]), render=False)
        v.scene.set_camera(st.camera)
    return s


def _is_auto(time_scale: Any) -> bool:
    return isinstance(time_scale, str) and time_scale.strip().lower() == "auto"


def _check_time_scale(time_scale: Any) -> float | str:
    """``"auto"`` or a number > 0 (playback seconds per data second), else ParameterError."""
    if _is_auto(time_scale):
        return "auto"
    try:
        ts = float(time_scale)
    except (TypeError, ValueError):
        ts = math.nan
    if not (math.isfinite(ts) and ts > 0):
        raise ParameterError(
            f"time_scale must be 'auto' or a number > 0 of playback seconds "
            f"per data second, got {time_scale!r}"
        )
    return ts


def _fixed_scale(s: Session) -> float:
    """The session's time scale where a number is needed before there is a path (default
    durations): 1 for ``"auto"`` (the data's span in real time)."""
    ts = _check_time_scale(s.audio["time_scale"])
    return 1.0 if isinstance(ts, str) else ts


def _time_scale(s: Session, view: View, path: ListenerPath | None) -> float:
    """The time scale a view places the listener glyph with: the session's, or for
    ``"auto"`` the one a render along ``path`` uses (:func:`auralize.pipeline.plan_render`)."""
    ts = _check_time_scale(s.audio["time_scale"])
    if not isinstance(ts, str):
        return ts
    vol = view.scene.volume
    if vol is None or path is None or vol.n_steps < 2:
        return 1.0
    from auralize.pipeline import plan_render

    return plan_render(vol, path=path, time_scale="auto", clip=False).time_scale


def _input(Input: DataSource | None, source: DataSource | None) -> DataSource | None:
    """The input a filter was given positionally / as ``Input=`` or as ``source=``."""
    if Input is not None and source is not None and Input is not source:
        raise ParameterError("give the input once: positionally, as Input= or as source=")
    if Input is not None and not isinstance(Input, DataSource):
        raise ParameterError(
            f"the input must be a data source from OpenDataFile, got {type(Input).__name__}"
        )
    return Input if Input is not None else source
