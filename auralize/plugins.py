"""The SoundModel contract and the plugin registry (entry-point group ``auralize.plugins``).

A plugin is a :class:`SoundModel` subclass that declares its parameters as
data (:class:`Parameter`: name, default, range or choices, unit) and turns
inputs into sound: either one pressure signal, or per-source signals with
positions so that :mod:`auralize.spatial` can place them.  It may offer a
viewer overlay.  Plugins are found through entry points, loaded once and
cached; a plugin that fails to load produces a :class:`PluginWarning`, never
a crash.

Example ``pyproject.toml`` of a plugin package::

    [project.entry-points."auralize.plugins"]
    vortex = "auralize_vortex:VortexSound"
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from auralize.errors import ParameterError, PluginError

ENTRY_POINT_GROUP = "auralize.plugins"


class PluginWarning(UserWarning):
    """A plugin could not be loaded; the rest of the application carries on."""


@dataclass(frozen=True)
class Parameter:
    """A declared model parameter.

    ``range`` is an inclusive ``(low, high)`` for numbers (None for open ends);
    ``choices`` lists allowed values for strings.
    """

    name: str
    default: Any
    range: tuple[float | None, float | None] | None = None
    choices: tuple[Any, ...] | None = None
    unit: str = ""
    doc: str = ""

    def check(self, value: Any) -> Any:
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


@dataclass
class SoundOutput:
    """What a model produces.

    Either ``pressure (n_samples,)`` heard at the listener, or
    ``signals (n_sources, n_samples)`` emitted at ``positions (n_sources, 3)``
    (already delayed and attenuated, so that only panning remains).
    """

    rate: int
    pressure: NDArray[np.float64] | None = None
    signals: NDArray[np.float64] | None = None
    positions: NDArray[np.float64] | None = None
    meta: dict[str, Any] = field(default_factory=dict)


class SoundModel:
    """Base class of sound models (core field auralization and the plugins)."""

    name: ClassVar[str] = "base"
    description: ClassVar[str] = ""
    paper: ClassVar[str] = ""
    parameters: ClassVar[tuple[Parameter, ...]] = ()

    def resolve(self, **params: Any) -> dict[str, Any]:
        """Fill defaults and check every given parameter against its declaration."""
        known = {p.name: p for p in self.parameters}
        unknown = sorted(set(params) - set(known))
        if unknown:
            raise ParameterError(
                f"model {self.name!r} has no parameter(s) {unknown}; it has {sorted(known)}"
            )
        return {n: p.check(params.get(n, p.default)) for n, p in known.items()}

    def synthesize(self, inputs: Any, **params: Any) -> SoundOutput:
        raise NotImplementedError  # pragma: no cover - each model implements it

    def overlay(self, inputs: Any, step: int) -> Any | None:
        """Optional pyvista mesh(es) for the viewer's Overlays panel (default: none)."""
        return None

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
                }  # fmt: skip
                for p in self.parameters
            ],
        }


@functools.cache
def registry() -> dict[str, type[SoundModel]]:
    """All sound models registered by entry point (loaded once, cached)."""
    found: dict[str, type[SoundModel]] = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            obj = ep.load()
            if not (isinstance(obj, type) and issubclass(obj, SoundModel)):
                raise TypeError(f"{ep.value} is not a SoundModel subclass")
        except Exception as exc:  # a broken plugin must not take the app down
            warnings.warn(
                f"sound-model plugin {ep.name!r} ({ep.value}) could not be loaded: {exc}",
                PluginWarning, stacklevel=2,
            )  # fmt: skip
            continue
        found[ep.name] = obj
    return found


def get_model(name: str) -> SoundModel:
    """Instantiate a registered sound model by name."""
    models = registry()
    if name not in models:
        raise PluginError(f"no sound model {name!r}; registered: {sorted(models) or '(none)'}")
    return models[name]()
