"""Scenes: several sound models heard together along one listener path.

A scene is a list of models, each with its inputs and parameters
(:class:`SceneModel`).  Every model's :meth:`~auralize.plugins.SoundModel.synthesize`
returns what it emits (an :class:`auralize.emitters.Sound`); the sounds are
concatenated and rendered by :func:`auralize.pipeline.render` along the one
listener path, so the mix is exactly the sum of the models rendered alone.

On the command line a model is written ``NAME:INPUT[:key=value,...]``
(``auralize render --model fire:dataset:fire:extend=none``), and a scene file
is a small JSON document::

    {
      "listener": {"path": "flight.csv"},          # or {"position": [x, y, z]}
      "duration": 4.0,                              # optional (default: see below)
      "layout": "ring8", "rate": 44100,             # optional
      "models": [
        {"model": "field", "input": "data.h5", "params": {"time_scale": "auto"}},
        {"model": "fire", "input": "dataset:fire", "params": {"extend": "none"}},
        {"model": "vortex", "input": "plume.h5"}
      ]
    }

Relative file names in a scene file are relative to the scene file's folder.
Without a ``duration`` a scene lasts its listener path's length, or, at a
static listener, until every part has been heard (:func:`scene_length`).
The ``field`` model accepts ``"time_scale": "auto"``: the data's span plays in
the scene's duration (:func:`auralize.pipeline.plan_render`).

One output rule (:func:`auralize.pipeline.render`'s): the output high-pass (``--highpass``,
default 20 Hz) filters the field sources, the volume's physical pressure with
its inaudible sub-20 Hz energy; the other models are heard as they made their
sound (fire's own ``highpass_hz``, paper 001 §6), so a model mixed into a
scene writes the same samples as its own command (``spark render``).

Scenes are rendered, offline and block by block for live playback, by the one
render function, :func:`auralize.pipeline.render`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from auralize.defaults import DEFAULTS
from auralize.errors import Cancelled, FormatError, MissingFileError, ParameterError
from auralize.listener import ListenerPath
from auralize.runtime.json_check import (
    AnyJSON,
    Either,
    Num,
    Obj,
    Text,
    check,
    parse_json,
    read_json,
    vec3,
)
from auralize.scene.session import DATA_SCHEMA

if TYPE_CHECKING:
    from auralize.emitters import Backend

__all__ = [
    "SceneFile",
    "SceneModel",
    "load_scene",
    "parse_model_spec",
    "part_end",
    "render_scene",
    "scene_length",
    "scene_sound",
]


@dataclass
class SceneModel:
    """One model of a scene.

    Attributes
    ----------
    model : str
        A registered sound-model name (``auralize plugins`` lists them).
    input : Any
        The model's inputs: a spec string (file or ``dataset:NAME``) read by
        the model's :meth:`~auralize.plugins.SoundModel.load_input`, or the
        inputs themselves (a TimeVolume, ...).
    params : dict
        Values of the model's declared parameters.
    """

    model: str
    input: Any
    params: dict[str, Any] = field(default_factory=dict)

    def check(self) -> None:
        """Fail now (not at the render) on an unknown model or a bad parameter."""
        from auralize.plugins import get_model

        model = get_model(self.model)
        params = dict(self.params)
        if self.model == "field" and params.get("time_scale") == "auto":
            params.pop("time_scale")  # resolved along the listener path at the render
        model.resolve(**params)

    def describe(self) -> dict[str, Any]:
        """A JSON-friendly description (for sidecars)."""
        inp = self.input
        if not isinstance(inp, str) and not (isinstance(inp, dict) and "spec" in inp):
            inp = type(inp).__name__
        return {"model": self.model, "input": inp, "params": dict(self.params)}


def _value(text: str) -> Any:
    """A parameter value from text: a JSON number/boolean/null, else the text."""
    try:
        v = parse_json(text, "--model", error=ParameterError)
    except ParameterError:
        return text
    return v if isinstance(v, int | float | bool) or v is None else text


def _params(text: str, where: str) -> dict[str, Any] | None:
    """``key=value,...`` as a dict, or None when ``text`` is not written that way."""
    out: dict[str, Any] = {}
    for item in text.split(","):
        key, sep, val = item.partition("=")
        if not sep or not key.strip().isidentifier():
            return None
        out[key.strip()] = _value(val.strip())
    if not out:
        raise ParameterError(f"{where}: empty parameter list")
    return out


def parse_model_spec(text: str) -> SceneModel:
    """Parse ``NAME:INPUT[:key=value,...]`` (the ``--model`` option).

    ``INPUT`` may itself contain colons (``dataset:fire``); a last part made
    of ``key=value`` pairs is taken as the parameters.  Values are numbers,
    ``true``/``false``/``null`` or text.

    Examples
    --------
    >>> parse_model_spec("fire:dataset:fire:extend=none,seed=3")
    SceneModel(model='fire', input='dataset:fire', params={'extend': 'none', 'seed': 3})
    """
    name, sep, rest = text.partition(":")
    if not sep or not name.strip() or not rest.strip():
        raise ParameterError(f"--model takes NAME:FILE[:key=value,...], got {text!r}")
    params: dict[str, Any] = {}
    head, sep, tail = rest.rpartition(":")
    if sep and "=" in tail:
        got = _params(tail, f"--model {text!r}")
        if got is None:
            raise ParameterError(
                f"--model {text!r}: parameters must be key=value pairs separated by commas, "
                f"got {tail!r}"
            )
        params, rest = got, head
    if not rest:
        raise ParameterError(f"--model {text!r}: no input file")
    return SceneModel(model=name.strip(), input=rest, params=params)


@dataclass
class SceneFile:
    """What a scene file holds (see the module docstring)."""

    models: list[SceneModel]
    path: ListenerPath | None = None
    listener: Any = None
    duration: float | None = None
    layout: str | None = None
    rate: int | None = None
    source: str = ""


def _resolve(spec: Any, folder: Path) -> Any:
    if not isinstance(spec, str) or spec.startswith("dataset:") or Path(spec).is_absolute():
        return spec
    return str(folder / spec)


#: a scene file's listener: a path CSV or a fixed position
_LISTENER = Either(
    Obj({"path": Text(nonempty=True)}, required=("path",)),
    Obj({"position": vec3("[x, y, z]")}, required=("position",)),
    what='{"path": CSV} or {"position": [x, y, z]}',
)
#: the ranges of a scene file's settings (their types are checked with the messages above)
_SCENE_RANGES = Obj(
    {
        "duration": Num(lo=0, lo_open=True),
        "rate": Num(lo=1, integer=True),
        "layout": Text(nonempty=True),
    },
    other=AnyJSON(),
)


def load_scene(path: str | Path) -> SceneFile:
    """Read a scene JSON file (see the module docstring).

    The file is read with :func:`auralize.runtime.json_check.read_json` (bounded
    depth and numbers) and its keys are checked for type and range; a saved
    session is checked by :meth:`auralize.scene.session.SessionState.from_dict`.

    Raises
    ------
    MissingFileError
        No such file.
    FormatError
        Not JSON, or a key of the wrong type or out of range (the message
        names the file and the key).
    """
    p = Path(path).expanduser()
    if not p.is_file():
        raise MissingFileError(f"{p}: scene file not found")
    try:
        doc = read_json(p)
    except FormatError as exc:
        raise FormatError(
            f"{p}: not a JSON scene file ({str(exc).removeprefix(f'{p}: ')})"
        ) from None
    if not isinstance(doc, dict):
        raise FormatError(f"{p}: a scene file holds a JSON object, got {type(doc).__name__}")
    if doc.get("auralize_format") == "session":
        return session_scene(doc, source=str(p))
    known = {"listener", "duration", "layout", "rate", "models"}
    extra = sorted(set(doc) - known)
    if extra:
        raise FormatError(f"{p}: unknown scene key(s) {extra}; valid: {sorted(known)}")
    items = doc.get("models")
    if not isinstance(items, list) or not items:
        raise FormatError(
            f'{p}: \'models\' must be a non-empty list of {{"model", "input", "params"}} objects'
        )
    models = []
    for k, it in enumerate(items):
        if not isinstance(it, dict) or "model" not in it or "input" not in it:
            raise FormatError(
                f"{p}: models[{k}] must be an object with 'model' and 'input', got {it!r}"
            )
        prm = it.get("params", {})
        if not isinstance(prm, dict):
            raise FormatError(f"{p}: models[{k}].params must be an object, got {prm!r}")
        check(it["model"], Text(nonempty=True), str(p), where=f"models[{k}].model")
        inp = it["input"]
        if isinstance(inp, str) or (isinstance(inp, dict) and "spec" in inp):  # else the inputs
            check(
                inp,
                Text(nonempty=True) if isinstance(inp, str) else DATA_SCHEMA,
                str(p),
                where=f"models[{k}].input",
            )
        bad = sorted(set(it) - {"model", "input", "params"})
        if bad:
            raise FormatError(f"{p}: models[{k}] has unknown key(s) {bad}")
        models.append(SceneModel(str(it["model"]), _resolve(it["input"], p.parent), dict(prm)))
    out = SceneFile(models=models, source=str(p))
    lis = doc.get("listener")
    if lis is not None:
        if not isinstance(lis, dict) or len(set(lis) & {"path", "position"}) != 1:
            raise FormatError(
                f"{p}: 'listener' must be {{\"path\": CSV}} or "
                f'{{"position": [x, y, z]}}, got {lis!r}'
            )
        check(lis, _LISTENER, str(p), where="listener")
        if "path" in lis:
            out.path = ListenerPath.from_csv(_resolve(lis["path"], p.parent))
        else:
            out.listener = [float(v) for v in lis["position"]]
    for key, kind in (("duration", (int, float)), ("rate", (int,)), ("layout", (str,))):
        if key in doc:
            val = doc[key]
            if isinstance(val, bool) or not isinstance(val, kind):
                raise FormatError(f"{p}: {key!r} must be a {kind[0].__name__}, got {val!r}")
            setattr(out, key, val)
    if out.duration is not None and not out.duration > 0:
        raise FormatError(f"{p}: 'duration' must be > 0 seconds, got {out.duration!r}")
    check(doc, _SCENE_RANGES, str(p))
    return out


def session_scene(doc: dict[str, Any], *, source: str = "<memory>") -> SceneFile:
    """The scene of a saved session (:mod:`auralize.scene.session`): what it renders.

    The session's data is a ``field`` model detected with the session's
    mapping and thresholds, heard as it was (``heard``), with its time scale
    and timbre (:data:`auralize.defaults.DEFAULTS` where it has none); its ``models`` (the
    viewer's audible overlays, :func:`auralize.simple.AddSoundModel`) follow;
    the listener is its path, ``layout``/``rate`` its audio settings.  So
    ``auralize render --scene SESSION.json -o out.wav`` renders what the
    session heard.
    """
    from auralize.scene.session import SessionState

    st = SessionState.from_dict(doc, source=source)
    models: list[SceneModel] = []
    if st.data:
        det = st.detection or {}
        a = st.audio or {}
        params: dict[str, Any] = {"mapping": det.get("mapping") or DEFAULTS.mapping}
        if det.get("mapping_fields"):
            params["fields"] = dict(det["mapping_fields"])
        for key in ("time_scale", "timbre", "heard"):  # absent: the defaults of every front end
            if a.get(key) is not None:
                params[key] = a[key]
        for kind, value in (det.get("thresholds") or {}).items():
            if kind in ("monopole", "dipole", "quadrupole") and value is not None:
                params[f"threshold_{kind}"] = value
        models.append(SceneModel("field", dict(st.data), params))
    for k, it in enumerate(st.models):
        if not isinstance(it, dict) or "model" not in it or "input" not in it:
            raise FormatError(
                f"{source}: models[{k}] must be an object with 'model' and 'input', got {it!r}"
            )
        models.append(SceneModel(str(it["model"]), it["input"], dict(it.get("params") or {})))
    if not models:
        raise FormatError(f"{source}: the session has no data and no sound models to render")
    a = st.audio or {}
    return SceneFile(
        models=models,
        path=st.listener_path(),
        layout=a.get("layout"),
        rate=int(a["rate"]) if a.get("rate") else None,
        source=source,
    )


def input_key(spec: Any) -> str | None:
    """The key of a scene entry's input in :func:`scene_sound`'s ``loaded`` (a file
    name or ``dataset:NAME``, or a session's data entry as canonical JSON), or None
    when the entry holds the inputs themselves."""
    import json

    if isinstance(spec, str):
        return spec
    if isinstance(spec, dict) and isinstance(spec.get("spec"), str):
        return json.dumps(spec, sort_keys=True, default=str)
    return None


def load_input(model: Any, spec: Any, loaded: dict[str, Any] | None = None) -> Any:
    """A scene entry's inputs: a spec string read by the model, a session's data entry
    (``{"spec": ..., "size": ..., "steps": ..., "seed": ...}``) opened as a volume, or
    the inputs themselves.  ``loaded`` maps :func:`input_key` to inputs already
    read (the viewer's volume on screen), which are taken as they are."""
    key = input_key(spec)
    if loaded and key is not None and key in loaded:
        return loaded[key]
    if isinstance(spec, str):
        return model.load_input(spec)
    if isinstance(spec, dict) and isinstance(spec.get("spec"), str):
        from auralize.scene.session import load_data

        return load_data(spec)
    return spec


def model_params(model: Any, params: dict[str, Any], rate: int | None) -> dict[str, Any]:
    """A scene entry's parameters: ``params``, plus the output ``rate`` as the emission
    rate of a model with a ``rate`` parameter that the entry leaves unset (fire,
    aero), as in the model's own command."""
    out = dict(params)
    if rate is not None and "rate" not in out and any(p.name == "rate" for p in model.parameters):
        out["rate"] = int(rate)
    return out


def scene_sound(
    models: list[SceneModel],
    path: ListenerPath | None = None,
    duration: float | None = None,
    rate: int | None = None,
    *,
    loaded: dict[str, Any] | None = None,
    progress: Callable[[int, int], bool] | None = None,
    sounds: dict[tuple[str, str | None], tuple[dict[str, Any], Any]] | None = None,
) -> Any:
    """Synthesize every model of a scene and join their sounds (one :class:`Sound`).

    ``path`` and ``duration`` go to each model's :meth:`~auralize.plugins.SoundModel.plan`
    (the ``field`` model plans as ``auralize render`` does: its automatic time
    scale, the travel time skipped, the blocks of its whole field near the
    path heard as their points).  ``rate`` (the output rate, Hz) is the emission rate
    of a model with a ``rate`` parameter that its entry leaves unset (fire,
    aero), as in the model's own command.  ``meta["scene"]`` lists the models.
    ``loaded`` as :func:`load_input`; ``progress(done, total)`` is called after
    each model (returning False cancels with :class:`~auralize.errors.Cancelled`);
    ``sounds`` maps ``(model name, input_key)`` to ``(params, Sound)`` already
    synthesized (the viewer's audible overlays), taken when the parameters
    are the same (:func:`model_params`) and the model does not plan for the
    listener.
    """
    from auralize.emitters import Sound
    from auralize.plugins import get_model, synthesize

    if not models:
        raise ParameterError("a scene needs at least one sound model")
    total = Sound(parts=[], meta={}, name="")
    for k, sm in enumerate(models):
        if progress is not None and not progress(k, len(models) + 1):
            raise Cancelled(f"scene cancelled before its {sm.model} model")
        model = get_model(sm.model)
        params = model_params(model, sm.params, rate)
        ready = (sounds or {}).get((sm.model, input_key(sm.input)))
        if ready is not None and ready[0] == params:  # made already, from the same inputs
            total = total + ready[1]
            continue
        inputs = load_input(model, sm.input, loaded)
        if path is not None:  # what depends on where the listener goes (the field's plan)
            inputs, params = model.plan(inputs, params, path, duration or path.duration)
        total = total + synthesize(model, inputs, **params)
    total.meta["scene"] = [sm.describe() for sm in models]
    return total


def _farthest(points: Any, lo: Any, hi: Any) -> float:
    """Largest distance (m) from any of ``points (N, 3)`` to the box ``[lo, hi]``."""
    from auralize.emitters.synthesis import box_distances

    _, far = box_distances(np.asarray(points, dtype=np.float64), lo, hi)
    return float(np.max(far, initial=0.0))


def part_end(part: Any, path: ListenerPath, *, c0: float | None = None) -> float | None:
    """Playback second after which ``part`` is silent along ``path``, or None if unknown.

    Times count from the path's first capture.  An emitter set ends when its
    last emitted sample has reached the listener: ``t_end + D_max / c0``, with
    ``D_max`` the largest distance between the emitters' box and a capture.
    The volume's sources end when the last data step has arrived: playback
    time ``t`` hears data time ``t0 + lead + t / time_scale``
    (:mod:`auralize.emitters.synthesis`), so the end is
    ``time_scale · (t_last − t0 − lead + D_max / c0)`` (``D_max`` from the
    sources' box), the length :func:`auralize.pipeline.plan_render` gives
    the data's sound.  A model's own part tells its end by an
    ``end_time(path, *, c0)`` method (a spark: when its last wave has
    passed); a part without one gives None.

    Parameters
    ----------
    part : Emitters, FieldSources or a model part
    path : ListenerPath
    c0 : float, optional
        Speed of sound, m/s (default :data:`auralize.emitters.C0`).

    Returns
    -------
    float or None
        Playback seconds (>= 0), or None.
    """
    from auralize.emitters import C0, Emitters, FieldSources

    c = C0 if c0 is None else float(c0)
    pts = np.asarray(path.positions, dtype=np.float64).reshape(-1, 3)
    if isinstance(part, Emitters):
        pos = part.positions.reshape(-1, 3)
        reach = _farthest(pts, pos.min(axis=0), pos.max(axis=0))
        return max(part.t_end + reach / c, 0.0)
    if isinstance(part, FieldSources):
        from auralize.emitters.synthesis import source_extent

        tracks = part.tracks
        times = np.asarray(tracks.times, dtype=np.float64)
        if tracks.n_sources == 0 or times.size == 0:
            return 0.0
        lo, hi, _ = source_extent(tracks)
        span = tracks.t_last - tracks.t_first - float(part.lead) + _farthest(pts, lo, hi) / c
        return max(float(part.time_scale) * span, 0.0)
    fn = getattr(part, "end_time", None)
    if callable(fn):
        return max(float(fn(path, c0=c)), 0.0)
    return None


def scene_length(
    sound: Any, path: ListenerPath, *, c0: float | None = None, default: float | None = None
) -> float:
    """Playback seconds long enough for every part of ``sound`` along ``path``.

    The latest :func:`part_end` of the parts; a part that cannot tell its end
    counts ``default`` seconds (default: the path's duration).  This is the
    length of a scene rendered without a duration and without a listener path
    of its own (a static listener): a spark until its waves have passed, the
    volume's sound (:func:`auralize.pipeline.plan_render`), a fire or a vortex
    until its emission has reached the listener.

    Raises
    ------
    ParameterError
        When every part is silent (nothing to render).
    """
    from auralize.emitters.engine import parts_of

    fallback = path.duration if default is None else float(default)
    ends = [part_end(p, path, c0=c0) for p in parts_of(sound)]
    length = max((fallback if e is None else e for e in ends), default=0.0)
    if not length > 0:
        raise ParameterError(
            "the scene is silent along the listener path: none of its parts "
            "sounds after the path's start; give --duration"
        )
    return float(length)


def render_scene(
    models: list[SceneModel],
    path: ListenerPath,
    *,
    rate: int = 44100,
    layout: str = "mono",
    duration: float | None = None,
    start: float = 0.0,
    backend: Backend = "auto",
    highpass_hz: float = 0.0,
) -> Any:
    """Render a scene along ``path``: the sum of every model's sound (a ``Rendered``).

    ``highpass_hz`` applies to the field sources only (:func:`auralize.pipeline.render`).
    """
    from auralize.rendering import render

    dur = path.duration - start if duration is None else float(duration)
    sound = scene_sound(models, path, dur + start, rate=rate)
    return render(
        sound,
        path,
        rate=rate,
        layout=layout,
        duration=dur,
        start=start,
        backend=backend,
        highpass_hz=highpass_hz,
    )


def render_scene_file(
    scene: SceneFile,
    *,
    highpass_hz: float = DEFAULTS.highpass_hz,
    loaded: dict[str, Any] | None = None,
    progress: Callable[[int, int], bool] | None = None,
    sounds: dict[tuple[str, str | None], tuple[dict[str, Any], Any]] | None = None,
) -> Any:
    """Render a scene file (or a session's scene) as ``auralize render --scene FILE``
    with no other option does: its layout, rate and duration (else the
    defaults: mono at 44.1 kHz, as long as its listener path or until every part
    has been heard), every model planned for its listener and mixed with
    :func:`auralize.pipeline.render`'s rule.

    Parameters
    ----------
    scene : SceneFile
        From :func:`load_scene` or :func:`session_scene`; it needs a listener
        (a path or a position).
    highpass_hz : float
        The field sources' high-pass, Hz (``--highpass``).
    loaded : dict, optional
        Inputs already read, as :func:`load_input` takes them (the viewer
        passes the volume on screen, so it is not read again).
    progress : callable, optional
        ``progress(done, total) -> bool`` after each model and after the
        render; False cancels (:class:`~auralize.errors.Cancelled`).
    sounds : dict, optional
        Models' sounds already made, as :func:`scene_sound` takes them.

    Returns
    -------
    Rendered
        As :func:`auralize.pipeline.render`; ``meta["duration_s"]`` is the length rendered.

    Raises
    ------
    ParameterError
        The scene has no listener, or a model's parameter is wrong.
    """
    from auralize.rendering import render
    from auralize.spatial.layouts import get_layout

    path = scene.path
    if path is None:
        if scene.listener is None:
            raise ParameterError(
                f"{scene.source}: the scene has no listener (a path or a position) to render for"
            )
        path = ListenerPath.point(scene.listener, duration=scene.duration or DEFAULTS.duration)
    rate = int(scene.rate or DEFAULTS.rate)
    layout = get_layout(scene.layout or DEFAULTS.layout)
    sound = scene_sound(
        scene.models,
        path,
        scene.duration,
        rate=rate,
        loaded=loaded,
        progress=progress,
        sounds=sounds,
    )
    if scene.duration is not None:
        duration = float(scene.duration)
    elif scene.path is not None:
        duration = float(path.duration)
    else:
        duration = scene_length(sound, path)
    out = render(sound, path, rate=rate, layout=layout, duration=duration, highpass_hz=highpass_hz)
    n = len(scene.models) + 1
    if progress is not None and not progress(n, n):
        raise Cancelled("scene cancelled")
    out.meta["duration_s"] = duration
    return out
