"""Scenes: several sound models heard together along one listener path.

A scene is a list of models, each with its inputs and parameters
(:class:`SceneModel`).  Every model's :meth:`~auralize.plugins.SoundModel.synthesize`
returns what it emits (an :class:`auralize.emitters.Sound`); the sounds are
concatenated and rendered by :func:`auralize.emitters.render` along the one
listener path, so the mix is exactly the sum of the models rendered alone.

On the command line a model is written ``NAME:INPUT[:key=value,...]``
(``auralize render --model fire:dataset:fire:extend=none``), and a scene file
is a small JSON document::

    {
      "listener": {"path": "flight.csv"},          # or {"position": [x, y, z]}
      "duration": 4.0,                              # optional (default: the path's)
      "layout": "ring8", "rate": 44100,             # optional
      "models": [
        {"model": "field", "input": "data.h5", "params": {"time_scale": "auto"}},
        {"model": "fire", "input": "dataset:fire", "params": {"extend": "none"}},
        {"model": "vortex", "input": "plume.h5"}
      ]
    }

Relative file names in a scene file are relative to the scene file's folder.
The ``field`` model accepts ``"time_scale": "auto"``: the data's span plays in
the scene's duration (:func:`auralize.pipeline.plan_render`).

``SceneBlocks(sound, path, rate=, layout=, block=, duration=)`` renders a
scene block by block for live playback (:func:`auralize.audio.live.play` takes it in
place of source tracks); it is the engine's
:class:`auralize.emitters.engine.BlockRenderer`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from auralize.errors import FormatError, MissingFileError, ParameterError
from auralize.listener import ListenerPath

__all__ = [
    "SceneFile",
    "SceneModel",
    "load_scene",
    "parse_model_spec",
    "render_scene",
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
        inp = self.input if isinstance(self.input, str) else type(self.input).__name__
        return {"model": self.model, "input": inp, "params": dict(self.params)}


def _value(text: str) -> Any:
    """A parameter value from text: a JSON number/boolean/null, else the text."""
    try:
        v = json.loads(text)
    except ValueError:
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


def load_scene(path: str | Path) -> SceneFile:
    """Read a scene JSON file (see the module docstring)."""
    p = Path(path).expanduser()
    if not p.is_file():
        raise MissingFileError(f"{p}: scene file not found")
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise FormatError(f"{p}: not a JSON scene file ({exc})") from None
    if not isinstance(doc, dict):
        raise FormatError(f"{p}: a scene file holds a JSON object, got {type(doc).__name__}")
    known = {"listener", "duration", "layout", "rate", "models"}
    extra = sorted(set(doc) - known)
    if extra:
        raise FormatError(f"{p}: unknown scene key(s) {extra}; valid: {sorted(known)}")
    items = doc.get("models")
    if not isinstance(items, list) or not items:
        raise FormatError(f"{p}: 'models' must be a non-empty list of "
                          f"{{\"model\", \"input\", \"params\"}} objects")  # fmt: skip
    models = []
    for k, it in enumerate(items):
        if not isinstance(it, dict) or "model" not in it or "input" not in it:
            raise FormatError(f"{p}: models[{k}] must be an object with 'model' and 'input', "
                              f"got {it!r}")  # fmt: skip
        prm = it.get("params", {})
        if not isinstance(prm, dict):
            raise FormatError(f"{p}: models[{k}].params must be an object, got {prm!r}")
        bad = sorted(set(it) - {"model", "input", "params"})
        if bad:
            raise FormatError(f"{p}: models[{k}] has unknown key(s) {bad}")
        models.append(SceneModel(str(it["model"]), _resolve(it["input"], p.parent), dict(prm)))
    out = SceneFile(models=models, source=str(p))
    lis = doc.get("listener")
    if lis is not None:
        if not isinstance(lis, dict) or len(set(lis) & {"path", "position"}) != 1:
            raise FormatError(f"{p}: 'listener' must be {{\"path\": CSV}} or "
                              f"{{\"position\": [x, y, z]}}, got {lis!r}")  # fmt: skip
        if "path" in lis:
            out.path = ListenerPath.from_csv(_resolve(str(lis["path"]), p.parent))
        else:
            pos = lis["position"]
            if not (isinstance(pos, list) and len(pos) == 3
                    and all(isinstance(v, int | float) for v in pos)):  # fmt: skip
                raise FormatError(f"{p}: listener.position must be [x, y, z], got {pos!r}")
            out.listener = [float(v) for v in pos]
    for key, kind in (("duration", (int, float)), ("rate", (int,)), ("layout", (str,))):
        if key in doc:
            val = doc[key]
            if isinstance(val, bool) or not isinstance(val, kind):
                raise FormatError(f"{p}: {key!r} must be a {kind[0].__name__}, got {val!r}")
            setattr(out, key, val)
    if out.duration is not None and not out.duration > 0:
        raise FormatError(f"{p}: 'duration' must be > 0 seconds, got {out.duration!r}")
    return out


def _field_params(inputs: Any, params: dict[str, Any], path: ListenerPath,
                  duration: float) -> dict[str, Any]:  # fmt: skip
    """Resolve the field model's ``time_scale="auto"`` and its lead for ``path``."""
    from auralize.pipeline import plan_render

    if params.get("time_scale", 1.0) != "auto":
        return params
    volume = inputs[0] if isinstance(inputs, tuple) else inputs
    plan = plan_render(volume, None, path=path, duration=duration, time_scale="auto")
    return {**params, "time_scale": plan.time_scale, "lead": params.get("lead", plan.lead)}


def scene_sound(models: list[SceneModel], path: ListenerPath | None = None,
                duration: float | None = None) -> Any:  # fmt: skip
    """Synthesize every model of a scene and join their sounds (one :class:`Sound`).

    ``path`` and ``duration`` are only used to resolve the field model's
    automatic time scale.  ``meta["scene"]`` lists the models.
    """
    from auralize.emitters import Sound
    from auralize.plugins import get_model, synthesize

    if not models:
        raise ParameterError("a scene needs at least one sound model")
    total = Sound(parts=[], meta={}, name="")
    for sm in models:
        model = get_model(sm.model)
        inputs = model.load_input(sm.input) if isinstance(sm.input, str) else sm.input
        params = dict(sm.params)
        if sm.model == "field" and path is not None:
            params = _field_params(inputs, params, path, duration or path.duration)
        total = total + synthesize(model, inputs, **params)
    total.meta["scene"] = [sm.describe() for sm in models]
    return total


def render_scene(models: list[SceneModel], path: ListenerPath, *, rate: int = 44100,
                 layout: str = "mono", duration: float | None = None, start: float = 0.0,
                 backend: str = "auto") -> Any:  # fmt: skip
    """Render a scene along ``path``: the sum of every model's sound (a ``Rendered``)."""
    from auralize.emitters import render

    dur = path.duration - start if duration is None else float(duration)
    sound = scene_sound(models, path, dur + start)
    return render(sound, path, rate=rate, layout=layout, duration=dur, start=start,
                  backend=backend)  # fmt: skip


def __getattr__(name: str) -> Any:
    # SceneBlocks is the engine's block renderer (it imports the numba kernels: on first use)
    if name == "SceneBlocks":
        from auralize.emitters.engine import BlockRenderer

        return BlockRenderer
    raise AttributeError(name)
