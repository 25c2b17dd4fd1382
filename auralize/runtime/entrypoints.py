"""Entry-point groups, loaded once per process.

The sound-model registry (:func:`auralize.plugins.registry`) and the dataset
registry (:func:`auralize.datasets.synthetic.all_datasets`, the datasets that
sound models contribute) read the same group, ``auralize.plugins``; both take
it from here, so a plugin is imported once and a plugin that fails to load is
reported once (a :class:`~auralize.errors.PluginWarning`), never a crash.
"""

from __future__ import annotations

import functools
import warnings
from importlib.metadata import entry_points

from auralize.errors import PluginWarning

__all__ = ["loaded"]


@functools.cache
def loaded(group: str, what: str) -> tuple[tuple[str, str, object], ...]:
    """``(name, value, object)`` of every entry point of ``group`` that loads, in order.

    An entry point whose import fails is left out with a :class:`PluginWarning`
    ``"{what} {name!r} ({value}) could not be loaded: {error}"``.

    Examples
    --------
    >>> [name for name, _, _ in loaded("auralize.no-such-group", "plugin")]
    []
    """
    found = []
    for ep in entry_points(group=group):
        try:
            obj = ep.load()
        except Exception as exc:  # a broken plugin must not take the app down
            warnings.warn(
                f"{what} {ep.name!r} ({ep.value}) could not be loaded: {exc}",
                PluginWarning,
                stacklevel=3,
            )
            continue
        found.append((ep.name, ep.value, obj))
    return tuple(found)
