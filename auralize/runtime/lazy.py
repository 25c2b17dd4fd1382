"""Lazy package exports: a package names its public objects without importing them.

A sound-model plugin's package is imported whenever the ``auralize`` command
declares the plugin's sub-commands; its physics (numba kernels, scipy, VTK)
must load only when a command or a script uses it.  :func:`lazy_exports`
builds the module-level ``__getattr__`` and ``__dir__`` (PEP 562) that import
each exported name from its sub-module on first access.
"""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Callable, Mapping
from typing import Any


class _LazyPackage(types.ModuleType):
    """A package whose exported names win over its sub-modules of the same name.

    Importing ``pkg.texture`` sets the attribute ``pkg.texture`` to the
    sub-module; when the package exports a function ``texture`` from that
    sub-module, the function is kept instead (as an eager ``from .texture
    import texture`` in ``__init__`` would leave it).
    """

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, types.ModuleType) and name in self.__dict__.get("_SHADOWING", ()):
            value = getattr(value, name)
        super().__setattr__(name, value)


def lazy_exports(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package`` exporting ``exports``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping of str to str
        Exported name -> sub-module holding it, relative (``".model"``) or absolute.

    Returns
    -------
    getattr_, dir_ : callable
        Assign them to the package's ``__getattr__`` and ``__dir__``.

    Examples
    --------
    In a package's ``__init__.py``: ``__getattr__, __dir__ = lazy_exports(__name__,
    {"VortexSound": ".model"})``.  Here with a throw-away package exporting
    ``math.hypot``:

    >>> import sys, types
    >>> pkg = sys.modules["lazy_demo"] = types.ModuleType("lazy_demo")
    >>> pkg.__getattr__, pkg.__dir__ = lazy_exports("lazy_demo", {"hypot": "math"})
    >>> "hypot" in dir(pkg), "hypot" in vars(pkg)
    (True, False)
    >>> pkg.hypot(3.0, 4.0)
    5.0
    >>> del sys.modules["lazy_demo"]
    """
    table = dict(exports)
    module = sys.modules[package]
    module.__class__ = _LazyPackage
    module._SHADOWING = frozenset(  # type: ignore[attr-defined]
        n for n, m in table.items() if m in (f".{n}", f"{package}.{n}")
    )

    def getattr_(name: str) -> Any:
        try:
            modname = table[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(modname, package), name)
        module.__dict__[name] = value  # later lookups skip this
        return value

    def dir_() -> list[str]:
        return sorted(set(table) | set(module.__dict__))

    return getattr_, dir_
