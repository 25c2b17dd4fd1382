"""What a module exports from its private modules, documented on the module's page.

A module may keep stages of its work in private modules and export their public
names in ``__all__`` (:mod:`auralize.emitters.synthesis` exports
:func:`~auralize.emitters.synthesis.knot_times` and the checks of
``auralize.emitters._synth_prepare``; :mod:`auralize.io` its
``ResampledWarning``).  Autodoc documents a module's own members only, and the
API reference has no page for a private module, so :func:`exported_from_private`
lists those names and :func:`append_exports` adds an autodoc directive for each to
the module's page, under the module's name (the docstring rule of
``tests/test_docstrings.py`` checks the same names with the module).
"""

from __future__ import annotations

import inspect
from types import ModuleType
from typing import Any


def _private(module_name: str) -> bool:
    return any(part.startswith("_") for part in module_name.split("."))


def exported_from_private(module: ModuleType) -> list[tuple[str, str]]:
    """``(directive, name)`` of each callable in ``module.__all__`` defined in a private
    module: ``autoexception`` for exceptions and warnings, ``autoclass`` for other
    classes, ``autofunction`` for functions; in ``__all__``'s order."""
    out = []
    for name in getattr(module, "__all__", ()):
        obj = getattr(module, name, None)
        if obj is None or not callable(obj) or not _private(getattr(obj, "__module__", "") or ""):
            continue
        if inspect.isclass(obj):
            kind = "autoexception" if issubclass(obj, BaseException) else "autoclass"
        else:
            kind = "autofunction"
        out.append((kind, name))
    return out


def append_exports(  # noqa: PLR0917 (the signature of a Sphinx event handler)
    app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]
) -> None:
    """``autodoc-process-docstring`` of a module: its exports from private modules
    appended as autodoc directives (after numpydoc has read the docstring's sections)."""
    if what != "module" or not isinstance(obj, ModuleType):
        return
    for kind, export in exported_from_private(obj):
        lines.extend(["", f".. {kind}:: {name}.{export}"])
    if lines and lines[-1]:
        lines.append("")


def setup(app: Any) -> None:
    # after numpydoc (priority 500): the directives are not part of a section
    app.connect("autodoc-process-docstring", append_exports, priority=900)
