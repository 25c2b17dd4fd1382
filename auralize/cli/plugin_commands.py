"""Plugin sub-commands declared without importing the plugins' physics.

A plugin package declares its sub-commands in a small module registered under
the entry-point group ``auralize.commands`` (same name as its sound model in
``auralize.plugins``)::

    [project.entry-points."auralize.commands"]
    vortex = "auralize_vortex.commands:add_commands"

``add_commands(subparsers, options)`` adds the arguments and sets each
command's ``func`` to ``options.lazy("package.module:function")``, so the module that
runs the command (and the physics it needs) is imported only when the command
runs.  ``auralize --help`` and ``auralize vortex --help`` then load argparse
declarations only.  A plugin without a ``auralize.commands`` entry point still
works through its model's ``add_cli(subparsers, options)`` hook, at the cost
of loading the model.  ``options`` is :mod:`auralize.cli.options`, the shared
option helpers (:meth:`auralize.plugins.SoundModel.add_cli`): plugins take
them from the argument and import nothing from :mod:`auralize.cli`.
"""

from __future__ import annotations

import argparse
import importlib
import warnings
from importlib.metadata import entry_points
from typing import Any

COMMANDS_GROUP = "auralize.commands"


class LazyCommand:
    """A command function named ``"module:attr[.attr]"``, imported when called.

    Parameters
    ----------
    target : str
        ``"package.module:function"`` or ``"package.module:Class.method"``.
    """

    def __init__(self, target: str) -> None:
        module, sep, attr = target.partition(":")
        if not sep or not module or not attr:
            raise ValueError(f"command target must be 'module:function', got {target!r}")
        self.target = target

    def resolve(self) -> Any:
        """Import the module and return the function."""
        module, _, attr = self.target.partition(":")
        obj: Any = importlib.import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
        return obj

    def __call__(self, args: argparse.Namespace) -> Any:
        return self.resolve()(args)

    def __repr__(self) -> str:
        return f"LazyCommand({self.target!r})"


def lazy(target: str) -> LazyCommand:
    """The command function ``target`` (``"module:function"``), imported when it runs."""
    return LazyCommand(target)


def add_plugin_commands(subparsers: Any) -> list[str]:
    """Add every plugin's sub-commands to ``subparsers``; return the plugin names served.

    Plugins with an ``auralize.commands`` entry point declare theirs without
    loading the model; the other plugins of group ``auralize.plugins`` are
    loaded and their model's ``add_cli(subparsers, options)`` hook called.  A plugin
    whose declarations fail to load produces a
    :class:`~auralize.plugins.PluginWarning` and is left out.
    """
    from auralize.cli import options
    from auralize.plugins import ENTRY_POINT_GROUP, PluginWarning, SoundModel

    served: list[str] = []
    for ep in entry_points(group=COMMANDS_GROUP):
        if ep.name in served:
            continue
        try:
            hook = ep.load()
            hook(subparsers, options)
        except Exception as exc:  # a broken plugin must not take the command down
            warnings.warn(
                f"sub-commands of plugin {ep.name!r} ({ep.value}) could not be declared: {exc}",
                PluginWarning,
                stacklevel=2,
            )
            continue
        served.append(ep.name)
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in served:
            continue
        try:
            cls = ep.load()
        except Exception as exc:
            warnings.warn(
                f"sound-model plugin {ep.name!r} ({ep.value}) could not be loaded: {exc}",
                PluginWarning,
                stacklevel=2,
            )
            continue
        if not (isinstance(cls, type) and issubclass(cls, SoundModel)):
            continue  # registry() reports it
        if cls.add_cli.__func__ is not SoundModel.add_cli.__func__:  # type: ignore[attr-defined]
            cls.add_cli(subparsers, options)
            served.append(ep.name)
    return served
