"""Helpers shared by the readers and writers: field selection, warnings, atomic files."""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

from auralize.errors import FieldError, MissingFileError, ParameterError

#: What ``fields=`` may be: all fields, some names, or ``{volume name: name in the file}``.
FieldsArg = str | Sequence[str] | Mapping[str, object] | None


class ResampledWarning(UserWarning):
    """A reader interpolated the data onto a uniform grid other than the file's own.

    Emitted once per :func:`auralize.io.open_volume` call for curvilinear,
    rectilinear, unstructured and OpenFOAM meshes, and whenever ``resolution=``
    changes a uniform grid.  Filter it with
    ``warnings.simplefilter("ignore", ResampledWarning)``.

    Examples
    --------
    >>> import warnings, numpy as np
    >>> from auralize.io.resample import resample_uniform
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"p": np.zeros((1, 5, 5, 5))}, times=[0.0])
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     small = resample_uniform(vol, 3)
    >>> small.dims, caught[0].category is ResampledWarning
    ((3, 3, 3), True)
    """


def warn_resampled(message: str) -> None:
    """Warn with :class:`ResampledWarning`, attributed to the first caller outside auralize.io."""
    package_dir = os.path.dirname(os.path.abspath(__file__)) + os.sep
    level = 2
    frame = sys._getframe(1)
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package_dir):
        frame = frame.f_back  # type: ignore[assignment]
        level += 1
    warnings.warn(message, ResampledWarning, stacklevel=level)


def require_exists(path: Path) -> None:
    """Raise :class:`FileNotFoundError` naming ``path`` if it does not exist."""
    if not path.exists():
        parent = path.parent if str(path.parent) else Path(".")
        hint = "" if parent.is_dir() else f" (its folder {str(parent)!r} does not exist either)"
        raise MissingFileError(f"{str(path)!r}: no such file or directory{hint}")


def select_fields(
    available: Sequence[str],
    fields: FieldsArg,
    name_map: Mapping[str, str] | None,
    *,
    source: str,
) -> dict[str, str]:
    """Resolve ``fields=`` and ``name_map=`` against the arrays a file holds.

    Parameters
    ----------
    available : sequence of str
        Names of the usable arrays in the file, in file order.
    fields : None, str, sequence of str or mapping of str to str
        ``None`` selects every available array; a name or a sequence of names
        selects those; a mapping ``{volume_name: file_name}`` selects and renames.
    name_map : mapping of str to str, optional
        ``{file_name: volume_name}`` renames applied after selection; names not
        in the file are ignored, so one map can serve many files.
    source : str
        File name for messages.

    Returns
    -------
    dict of str to str
        ``{volume_name: file_name}`` in selection order.
    """
    avail = list(available)
    if fields is None:
        chosen = {n: n for n in avail}
    elif isinstance(fields, str):
        chosen = {fields: fields}
    elif isinstance(fields, Mapping):
        chosen = {}
        for key, value in fields.items():
            if not isinstance(key, str) or not isinstance(value, str):
                raise ParameterError(
                    f"{source}: fields= mapping must be {{volume name: name in the file}} "
                    f"with string keys and values; got {key!r}: {value!r}"
                )
            chosen[key] = value
    elif isinstance(fields, Sequence) and all(isinstance(f, str) for f in fields):
        chosen = {str(f): str(f) for f in fields}
    else:
        raise ParameterError(
            f"{source}: fields= must be None, a field name, a list of names or a mapping "
            f"{{volume name: name in the file}}; got {fields!r}"
        )
    for file_name in chosen.values():
        if file_name not in avail:
            raise FieldError(
                f"{source}: no field {file_name!r}; available fields: "
                f"{', '.join(repr(a) for a in avail) or '(none)'}"
            )
    if name_map:
        if not isinstance(name_map, Mapping) or not all(
            isinstance(v, str) and v for v in name_map.values()
        ):
            raise ParameterError(
                f"{source}: name_map= must map file names to non-empty new names; got {name_map!r}"
            )
        renamed = [(name_map.get(k, k), v) for k, v in chosen.items()]
        names = [k for k, _ in renamed]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ParameterError(
                f"{source}: name_map={dict(name_map)!r} gives more than one field the "
                f"name(s) {dup}; every volume field needs its own name"
            )
        chosen = dict(renamed)
    if not chosen:
        raise FieldError(f"{source}: no usable fields (scalar or 3-component arrays) found")
    return chosen
