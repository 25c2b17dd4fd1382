"""Lazy import of Dask with an install hint."""

from __future__ import annotations

from types import ModuleType

from auralize.errors import MissingDependencyError

INSTALL_HINT = 'pip install "auralize[dask]"  (or: pip install "dask[array,distributed]")'


def require(module: str = "dask") -> ModuleType:
    """Import ``dask``, ``dask.array`` or ``distributed``; explain how to install it if missing.

    Raises
    ------
    MissingDependencyError
        Dask (or its distributed scheduler) is not installed.
    """
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingDependencyError(
            f"out-of-core and distributed processing needs {module!r}, which is not installed "
            f"({exc}); install it with: {INSTALL_HINT}"
        ) from None
