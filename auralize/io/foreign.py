"""Kinds of files auralize recognises but cannot read, each explained in one line.

Asked by the reader selection when no reader takes a file: instead of
"unknown file kind", the user learns what the file is and which tool turns it
into something auralize reads, in command-line terms.
"""

from __future__ import annotations

import re
from pathlib import Path

__all__ = ["explain"]

#: What to convert to: kinds every user's tools can write and auralize reads.
_TARGETS = "a .pvd series or a temporal VTKHDF file (.vtkhdf)"


def _head(path: Path, n: int = 64) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read(n)
    except OSError:
        return b""


def _spyplot(path: Path) -> str | None:
    name = path.name.lower()
    head = _head(path)
    if head.startswith((b"spydata", b"spycase")) or re.search(r"\.spcth(\.\d+)?$", name):
        return (
            f"{path}: a Spectral CTH (SpyPlot) file; VTK's Python packages have no reader for "
            f"it (ParaView's SpyPlot reader does): open it in ParaView and save {_TARGETS} "
            f"(File > Save Data), then run 'auralize info' on that file"
        )
    return None


def _hdf5_layout(path: Path) -> str | None:
    import h5py

    try:
        if not h5py.is_hdf5(str(path)):
            return None
        with h5py.File(path, "r") as f:
            keys = list(f.keys())[:64]
            attrs = set(f.attrs.keys())
    except (OSError, ValueError):
        return None
    if "level_0" in keys and ("num_levels" in attrs or "num_components" in str(attrs)):
        return (
            f"{path}: a Chombo AMR file; auralize reads AMR data through VTK, which has no "
            f"Chombo reader: convert it with VisIt or yt (e.g. yt's covering_grid written as "
            f"HDF5 datasets, then 'auralize info FILE --field density=/density') or save "
            f"{_TARGETS} from VisIt"
        )
    if any(re.fullmatch(r"Grid\d{8}", k) for k in keys):
        return (
            f"{path}: a grid file of an Enzo output without its .hierarchy beside it; open "
            f"the output's .hierarchy (or its parameter file) instead, with all its files in "
            f"one folder"
        )
    return None


def explain(path: str | Path) -> str | None:
    """One line naming the kind of ``path`` and what to do, or ``None`` if unknown.

    Knows Spectral CTH (SpyPlot) files, Chombo AMR files and the grid files
    of an Enzo output without its ``.hierarchy``.

    Parameters
    ----------
    path : str or Path
        Any path; folders and files that cannot be read are unknown.

    Returns
    -------
    str or None
        The message: the file, its kind, and which tool converts it into a
        kind auralize reads (in command-line terms).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "blast.spcth.0"
    >>> _ = f.write_bytes(b"spydata 1")
    >>> "Spectral CTH" in explain(f)
    True
    """
    p = Path(path)
    if not p.is_file():
        return None
    return _spyplot(p) or _hdf5_layout(p)
