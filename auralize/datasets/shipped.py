"""The datasets that come with auralize, by name: ``dataset:NAME`` wherever a volume
file is accepted (as ``pyvista.examples`` or ``xarray.tutorial`` name theirs).

Two kinds: *generated* datasets (:data:`GENERATED`, made on demand at any
``--size``/``--steps``, see :mod:`auralize.datasets.synthetic`; plugins add
theirs) and *shipped* real files (:data:`SHIPPED`, written by other software
and kept under ``auralize/data/``, plus one netCDF file of ours; see
``auralize/data/PROVENANCE.md``).  A
shipped file inside a zip archive is unpacked once into the cache folder
(:func:`auralize.runtime.cache.cache_root`), so its readers can read it lazily.

This module is light (no numpy): the command line lists the names in its help.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import zipfile
from pathlib import Path

from auralize.errors import ParameterError

#: The core's generated datasets (plugins add theirs; ``auralize plugins`` lists them).
GENERATED = ("explosion", "monopole", "spinning")

#: Shipped real datasets: name -> (case of :data:`auralize.datasets.real.CASES`, what it is).
SHIPPED: dict[str, tuple[str, str]] = {
    "cavity": ("openfoam-cavity", "OpenFOAM's lid-driven cavity tutorial (case.foam)"),
    "pulse": ("netcdf-pulse", "a pulsating density blob in a CF netCDF file (made by auralize)"),
    "dolfinx": ("xdmf-dolfinx", "a dolfinx XDMF time series"),
    "meshio": ("xdmf-meshio", "a meshio XDMF time series"),
    "wavy": ("paraview-wavy", "ParaView's wavy surface series (.pvd)"),
    "cylinder": ("ensight-cylinder", "an EnSight Gold flow past a cylinder, Re 35"),
    "combustor": ("plot3d-combustor", "NASA's PLOT3D combustor (one step)"),
}


def describe() -> str:
    """One line per name, for help texts."""
    rows = [f"{n} (generated)" for n in GENERATED]
    rows += [f"{n} ({what})" for n, (_, what) in SHIPPED.items()]
    return "; ".join(rows)


def shipped_path(name: str) -> Path:
    """The file to open for the shipped dataset ``name`` (archives unpacked once).

    Examples
    --------
    >>> shipped_path("pulse").name
    'pulse.nc'
    """
    from auralize.datasets.real import CASES, DATASETS
    from auralize.runtime.cache import cache_root

    if name not in SHIPPED:
        raise ParameterError(f"unknown shipped dataset {name!r}; choose one of {sorted(SHIPPED)}")
    case = CASES[SHIPPED[name][0]]
    if "zip" not in case:
        return DATASETS / case["path"]
    archive = DATASETS / case["zip"]
    digest = hashlib.sha256(archive.read_bytes()).hexdigest()[:16]
    folder = cache_root() / "data" / f"{name}-{digest}"
    if not (folder / case["member"]).is_file():
        # unpacked beside its final place and renamed in: a reader never sees half a case
        folder.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=folder.parent))
        try:
            with zipfile.ZipFile(archive) as z:
                z.extractall(tmp)  # member names are made relative to tmp by zipfile
            try:
                os.replace(tmp, folder)
            except OSError:
                if not (folder / case["member"]).is_file():  # not another process's copy
                    raise
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return folder / case["member"]
