"""Files that read data from other files: refused unless allowed (every HDF5-based reader).

An HDF5 file can point outside itself: external links, datasets whose bytes
live in external raw files, virtual datasets.  The readers of volume and
sources files, VTKHDF, netCDF4, SOFA and the HDF5 companions of XDMF all
check a file with :func:`check_self_contained` before reading it, and give
the same message (:func:`refused_external`).  :mod:`auralize.io.hdf5`
re-exports these names.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py

from auralize.errors import FormatError

#: Whether files may read data from other files (external links, external
#: storage, virtual datasets); see :func:`allow_external_data`.
_ALLOW_EXTERNAL = os.environ.get("AURALIZE_HDF5_EXTERNAL", "") == "1"


def allow_external_data(allow: bool = True) -> None:
    """Let HDF5 files read data from other files, or refuse it again (the default).

    An HDF5 file can point outside itself: external links, datasets whose
    bytes live in external raw files, virtual datasets.  A crafted file can so
    make a reader return any readable file on the machine (``/etc/passwd``) as
    field data, so readers refuse such files unless this is allowed (the
    ``--allow-external`` option, or ``AURALIZE_HDF5_EXTERNAL=1``).
    """
    global _ALLOW_EXTERNAL
    _ALLOW_EXTERNAL = bool(allow)


def external_data_allowed() -> bool:
    """Whether files may read data from other files (see :func:`allow_external_data`)."""
    return _ALLOW_EXTERNAL


def refused_external(path: Path | str, what: str) -> FormatError:
    """The error for a file that reads data from elsewhere: ``"{path}: {what}; ... refused"``.

    One message for every reader that refuses such files (HDF5, netCDF4,
    SOFA, XDMF), naming the way to allow it.
    """
    return FormatError(
        f"{path}: {what}; reading data from other files is refused (give "
        f"--allow-external, or set AURALIZE_HDF5_EXTERNAL=1, if you trust the file)"
    )


def check_self_contained(f: h5py.File, path: Path | str) -> None:
    """Raise :class:`FormatError` if ``f`` refers to other files (unless allowed).

    Used by every reader of HDF5-based files (volume and sources ``.h5``,
    VTKHDF, netCDF4, SOFA, the HDF5 companions of XDMF).  Links are inspected
    without being followed, so dangling links and link loops are reported
    instead of raised by h5py.
    """
    if _ALLOW_EXTERNAL:
        return
    found: list[str] = []

    def visit(name: str, link: object) -> None:
        if isinstance(link, h5py.ExternalLink):
            found.append(f"/{name} is an external link to {link.filename}:{link.path}")

    f.visititems_links(visit)
    if not found:

        def visit_obj(name: str, obj: object) -> None:
            if isinstance(obj, h5py.Dataset) and (obj.external or obj.is_virtual):
                kind = (
                    "virtual (data from other files)"
                    if obj.is_virtual
                    else "stored in external files"
                )
                found.append(f"dataset /{name} is {kind}")

        f.visititems(visit_obj)
    if found:
        raise refused_external(path, found[0])
