"""The SoundModel contract and the plugin registry (entry-point group ``auralize.plugins``).

A plugin is a :class:`SoundModel` subclass that declares its parameters as
data (:class:`Parameter`: name, default, range or choices, unit) and turns
its inputs into what it *emits*: an :class:`auralize.emitters.Sound` (point
emitters, detected field sources or a closed-form part).  The engine
(:func:`auralize.emitters.render_sound`) does the propagation, the panning and the
mixing of several models along one listener path, so a model never sees the
listener.  A model may also offer a viewer overlay, sub-commands, benchmark
rows (:class:`BenchRow`, timed with :func:`best_of`), built-in datasets and
a loader of its inputs from a file (the hooks below, all optional).  Plugins are found through entry points, loaded once
and cached; a plugin that fails to load produces a :class:`PluginWarning`,
never a crash.

Example ``pyproject.toml`` of a plugin package::

    [project.entry-points."auralize.plugins"]
    vortex = "auralize_vortex:VortexSound"
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from auralize.errors import AuralizeError, ParameterError, PluginError
from auralize.errors import PluginWarning as PluginWarning
from auralize.runtime.entrypoints import loaded
from auralize.runtime.timing import batch_times as batch_times  # (plugin authors' import)
from auralize.runtime.timing import best_of as best_of

if TYPE_CHECKING:
    from auralize.emitters import Sound
    from auralize.listener import ListenerPath

ENTRY_POINT_GROUP = "auralize.plugins"


@dataclass(frozen=True)
class Parameter:
    """A declared model parameter.

    ``range`` is an inclusive ``(low, high)`` for numbers (None for open ends);
    ``choices`` lists allowed values for strings; ``auto`` accepts the string
    ``"auto"`` beside the numbers of ``range`` (the model then chooses).
    """

    name: str
    default: Any
    range: tuple[float | None, float | None] | None = None
    choices: tuple[Any, ...] | None = None
    unit: str = ""
    doc: str = ""
    auto: bool = False

    def check(self, value: Any) -> Any:
        if self.auto and isinstance(value, str) and value.strip().lower() == "auto":
            return "auto"
        if self.choices is not None:
            if value not in self.choices:
                raise ParameterError(
                    f"parameter {self.name!r} must be one of {list(self.choices)}, got {value!r}"
                )
            return value
        if self.range is not None:
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise ParameterError(
                    f"parameter {self.name!r} must be a number, got {value!r}"
                ) from None
            lo, hi = self.range
            if not math.isfinite(v) or (lo is not None and v < lo) or (hi is not None and v > hi):
                raise ParameterError(
                    f"parameter {self.name!r} = {value!r} {self.unit} is outside "
                    f"[{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}]"
                )
            return type(self.default)(v) if isinstance(self.default, int | float) else v
        return value


class SoundModel:
    """Base class of sound models (core field auralization and the plugins).

    A subclass sets :attr:`name` (its entry-point name), :attr:`description`,
    :attr:`paper` and :attr:`parameters`, and implements :meth:`synthesize`.
    The other methods and attributes are optional hooks with working
    defaults; the command line, the benchmark, the dataset registry, the
    scene loader and the viewer call them directly.
    """

    name: ClassVar[str] = "base"
    description: ClassVar[str] = ""
    paper: ClassVar[str] = ""
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    #: built-in datasets ``{name: factory(size=, steps=, seed=) -> TimeVolume}``
    #: (``auralize dataset NAME``, ``dataset:NAME`` inputs); default none
    datasets: ClassVar[dict[str, Any]] = {}
    #: what :meth:`synthesize` takes: ``"volume"`` when its inputs are one
    #: :class:`~auralize.volume.TimeVolume`; another word names other inputs
    #: (the default :meth:`load_input` then refuses, and the viewer does not try
    #: to hear the model's overlay); ``""`` (default) undeclared: volumes are
    #: tried (:meth:`load_input` reads one, the viewer calls ``synthesize(volume)``)
    input_kind: ClassVar[str] = ""

    def resolve(self, **params: Any) -> dict[str, Any]:
        """Fill defaults and check every given parameter against its declaration."""
        known = {p.name: p for p in self.parameters}
        unknown = sorted(set(params) - set(known))
        if unknown:
            raise ParameterError(
                f"model {self.name!r} has no parameter(s) {unknown}; it has {sorted(known)}"
            )
        return {n: p.check(params.get(n, p.default)) for n, p in known.items()}

    def synthesize(self, inputs: Any, **params: Any) -> Sound:
        """What the model emits for ``inputs``, as engine parts.

        Parameters
        ----------
        inputs : model-specific
            The model's data (a :class:`~auralize.volume.TimeVolume`, a
            texture plus an object, a discharge scene, ...), as
            :meth:`load_input` returns it.  Never the listener path: the
            engine places the sound along the path it renders.
        **params
            Values of the declared :attr:`parameters` (checked by
            :meth:`resolve`; the others keep their defaults).

        Returns
        -------
        auralize.emitters.Sound
            Parts (:class:`~auralize.emitters.Emitters` with emitted signals in
            Pa at 1 m and positions in m, :class:`~auralize.emitters.FieldSources`,
            or a model part with ``render_part``) plus metadata.  Times are
            playback seconds from the listener path's first capture.
        """
        raise NotImplementedError(f"sound model {self.name!r} does not implement synthesize")

    def plan(
        self, inputs: Any, params: dict[str, Any], path: ListenerPath, duration: float
    ) -> tuple[Any, dict[str, Any]]:
        """Inputs and parameters for a render along ``path`` of ``duration`` playback seconds.

        A scene (:func:`auralize.scene.soundscene.scene_sound`) calls it before
        :meth:`synthesize` once it knows where the listener goes; a model whose
        sound depends on the listener's place (the ``field`` model: its time
        scale, the travel time skipped, the blocks of its field near the path)
        overrides it.  The default returns ``(inputs, params)`` unchanged.
        """
        return inputs, params

    def load_input(self, spec: str) -> Any:
        """Read this model's inputs from ``spec`` (a file or ``dataset:NAME``).

        Used by ``auralize render --model NAME:FILE`` and scene files; returns
        what :meth:`synthesize` takes as ``inputs``.  The default reads a
        volume (:func:`load_volume_input`) unless :attr:`input_kind` names
        other inputs; a model with other inputs overrides it to be mixed into
        a scene from the command line.  Errors name the model and ``spec``.
        """
        if self.input_kind in ("", "volume"):
            try:
                return load_volume_input(spec)
            except AuralizeError as exc:
                if self.input_kind == "volume":
                    raise
                why = " ".join(str(exc).split())
                raise PluginError(
                    f"sound model {self.name!r} cannot read its inputs from {spec!r}: it does "
                    f"not implement SoundModel.load_input and {spec!r} is not a volume ({why})"
                ) from None
        raise PluginError(
            f"sound model {self.name!r} cannot read its inputs ({self.input_kind}) from "
            f"{spec!r}: it does not implement SoundModel.load_input (use it from Python: "
            f"auralize.simple.AddSoundModel({self.name!r}, inputs))"
        )

    def overlay(self, inputs: Any, step: int) -> Any | None:
        """Optional pyvista mesh(es) for the viewer's Overlays panel (default: none)."""
        return None

    def warm_up(self) -> None:
        """Compile the model's numba kernels on a small case (``auralize warmup
        --plugins`` calls it for every registered model; default: nothing to compile)."""
        return None

    @classmethod
    def add_cli(cls, subparsers: Any, options: Any) -> None:
        """Add the model's sub-commands to ``subparsers`` (default: none).

        Only called for plugins without an ``auralize.commands`` entry point
        (see :mod:`auralize.cli.plugin_commands`), whose ``add_commands``
        hook takes the same two arguments.

        Parameters
        ----------
        subparsers : argparse sub-parsers action
            Where the commands go (``subparsers.add_parser(name, ...)``).
        options : module
            The shared-option helpers of the ``auralize`` command
            (:mod:`auralize.cli.options`): ``add_output_options``,
            ``add_volume_options``, ``add_renamed_alias``, the argparse types
            ``positive_float``, ``finite_float``, ``positive_int``,
            ``seed_int``, ``rate_int``, and ``lazy("module:function")`` for a
            command function imported when it runs.  A plugin takes them from
            here and imports nothing from :mod:`auralize.cli`.  The commands
            themselves use public functions of the core
            (:func:`auralize.listener.listener_from_args`,
            :func:`auralize.listener.render_duration`,
            :func:`auralize.audio.fit_duration`, :func:`auralize.io.field_map`).
        """
        return None

    @classmethod
    def bench(cls, quick: bool) -> list[BenchRow]:
        """Rows (:class:`BenchRow`) for ``auralize bench`` (default: none).

        ``quick``: small sizes only (seconds).  Time with :func:`best_of`
        (or :func:`batch_times`), so model rows are measured like the core's.
        """
        return []

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "description": self.description,
            "paper": self.paper,
            "parameters": [
                {
                    "name": p.name,
                    "default": p.default,
                    "range": p.range,
                    "choices": p.choices,
                    "unit": p.unit,
                    "doc": p.doc,
                }
                for p in self.parameters
            ],
        }


@dataclass
class BenchRow:
    """One row of ``auralize bench`` (the return type of :meth:`SoundModel.bench`).

    One figure: ``value`` in ``unit``, with its target and the paper's figure.
    """

    group: str
    name: str
    value: float
    unit: str
    target: str = ""
    met: bool | None = None
    paper: str = ""
    note: str = ""


@functools.cache
def registry() -> dict[str, type[SoundModel]]:
    """All sound models registered by entry point (loaded once, cached)."""
    found: dict[str, type[SoundModel]] = {}
    for name, value, obj in loaded(ENTRY_POINT_GROUP, "sound-model plugin"):
        if not (isinstance(obj, type) and issubclass(obj, SoundModel)):
            warnings.warn(
                f"sound-model plugin {name!r} ({value}) could not be loaded: {value} is not a "
                f"SoundModel subclass",
                PluginWarning,
                stacklevel=2,
            )
            continue
        found[name] = obj
    return found


def get_model(name: str) -> SoundModel:
    """Instantiate a registered sound model by name."""
    models = registry()
    if name not in models:
        raise PluginError(f"no sound model {name!r}; registered: {sorted(models) or '(none)'}")
    return models[name]()


def load_volume_input(spec: str) -> Any:
    """A :class:`~auralize.volume.TimeVolume` from a file or ``dataset:NAME``.

    ``dataset:NAME`` also finds the datasets that plugins register (their
    :attr:`SoundModel.datasets`).  Models whose input is a volume use it as
    their :meth:`SoundModel.load_input`.  A structured curvilinear grid is read
    resampled onto a uniform grid (a model's physics takes uniform spacing).
    """
    from auralize.datasets.opener import load
    from auralize.io.options import curvilinear_mode

    with curvilinear_mode("resample"):
        return load(spec)


def check_sound(model: SoundModel | str, result: Any) -> Sound:
    """``result`` if it is an :class:`auralize.emitters.Sound`, else a clear error.

    ``model`` (a model or its name) names the culprit in the message.
    """
    from auralize.emitters import Sound

    if isinstance(result, Sound):
        return result
    name = model if isinstance(model, str) else model.name
    raise PluginError(
        f"plugin {name!r} returned {type(result).__name__}; SoundModel.synthesize must return "
        f"auralize.emitters.Sound"
    )


def synthesize(model: SoundModel | str, inputs: Any, **params: Any) -> Sound:
    """Run ``model.synthesize(inputs, **params)`` (a model or a registered name), checked."""
    m = get_model(model) if isinstance(model, str) else model
    return check_sound(m, m.synthesize(inputs, **params))
