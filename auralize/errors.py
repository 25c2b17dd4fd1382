"""One exception hierarchy for the whole package.

Every error subclasses both :class:`AuralizeError` and the builtin it refines,
so callers can catch either ``auralize.errors.FieldError`` or ``KeyError``.
Messages name the file, field or value at fault and what would be valid.
"""

from __future__ import annotations


class AuralizeError(Exception):
    """Base class of every error raised by auralize on purpose."""


class DataError(AuralizeError, ValueError):
    """Input data is malformed: NaN/Inf values, wrong shapes, too few steps."""


class FieldError(AuralizeError, KeyError):
    """A named field does not exist in a volume."""

    def __str__(self) -> str:  # KeyError quotes its message; we do not want that
        return str(self.args[0]) if self.args else ""


class FormatError(AuralizeError, ValueError):
    """A file is corrupt, of an unknown kind, or of an unsupported version."""


class ListenerPathError(AuralizeError, ValueError):
    """A listener path is invalid: decreasing times, outside the grid, too fast."""


class ParameterError(AuralizeError, ValueError):
    """A parameter is out of its valid range or of the wrong kind."""


class ArgumentError(ParameterError, TypeError):
    """An argument of the wrong kind (a listener path where a view goes, ...): a
    :class:`ParameterError` that is also a ``TypeError``."""


class DeviceError(AuralizeError, RuntimeError):
    """No usable sound device, or the device cannot do what was asked."""


class PluginError(AuralizeError, RuntimeError):
    """A sound-model plugin could not be loaded or run."""


class MissingDependencyError(AuralizeError, ImportError):
    """An optional dependency is not installed; the message says how to get it."""


class MissingFileError(AuralizeError, FileNotFoundError):
    """An input file or folder does not exist."""


class OutputError(AuralizeError, OSError):
    """An output cannot be written where asked: a folder, a missing folder, no permission,
    or a folder that auralize did not write and will not replace."""


class ResourceError(AuralizeError, MemoryError):
    """A request needs more memory than the machine has; the message gives the figure."""


class OutputExistsError(OutputError, FileExistsError):
    """The output would replace something that auralize did not write."""


class Cancelled(AuralizeError):
    """Long work was cancelled by the user."""


class PluginWarning(UserWarning):
    """A plugin could not be loaded; the rest of the application carries on."""
