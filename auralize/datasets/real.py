"""The real datasets shipped in ``auralize/data/``: where each is and how it is heard.

For every dataset in ``auralize/data/`` that this project did not make (plus the
generated netCDF case), :data:`CASES` names its file (or archive member), the
mapping and field names it is detected with, and a static listener for a short
rendered clip.  :func:`dataset_path` gives the file to open.  The regression
figures recorded for them are :mod:`auralize.regression.real`'s.
"""

from __future__ import annotations

import tempfile
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

DATASETS = Path(__file__).resolve().parents[1] / "data"
#: ``path`` inside ``auralize/data/`` (``zip`` + ``member`` for archives), detection options,
#: and a static listener for the rendered clip (timbre ``physical`` unless given; the
#: fields that do not change at the data's time step are heard ``extended``).
CASES: dict[str, dict[str, Any]] = {
    "openfoam-cavity": {
        "zip": "openfoam-cavity/OpenFOAM.zip",
        "member": "OpenFOAM/cavity/case.foam",
        "mapping": None,
        "fields": {},
        "render": {"listener": [0.05, 0.05, 0.005], "duration": 0.05, "time_scale": 0.02},
    },
    "netcdf-pulse": {
        "path": "netcdf-pulse/pulse.nc",
        "mapping": None,
        "fields": {},
        "render": {"listener": [0.05, 0.04, 0.03], "duration": 0.008, "time_scale": 1.0},
    },
    "xdmf-dolfinx": {
        "path": "xdmf-timeseries/dolfinx/no_checkpoint.xdmf",
        "mapping": "identity",
        "fields": {"density": "f_5"},
        "render": {
            "listener": [0.5, 0.5, 0.5],
            "duration": 0.05,
            "time_scale": 0.0125,
            "timbre": "extended",
        },
    },
    "xdmf-meshio": {
        "path": "xdmf-timeseries/meshio/out.xdmf",
        "mapping": "identity",
        "fields": {"density": "phi"},
        "render": {
            "listener": [0.5, 0.5, 1.0],
            "duration": 0.05,
            "time_scale": 0.05,
            "timbre": "extended",
        },
    },
    "paraview-wavy": {
        "zip": "paraview-wavy/wavy.zip",
        "member": "wavy/wavy.pvd",
        "mapping": "identity",
        "fields": {"density": "z"},
        "render": {
            "listener": [0.0, 0.0, 3.0],
            "duration": 0.1,
            "time_scale": 0.1 / 14,
            "timbre": "extended",
        },
    },
    "ensight-cylinder": {
        "path": "ensight-cylinder/cylinder_Re35.case",
        "mapping": None,
        "fields": {},
        "render": None,
    },
    "plot3d-combustor": {
        "path": "plot3d-combustor/combxyz.bin",
        "mapping": "cfd",
        "fields": {"density": "Density", "momentum": "Momentum"},
        "render": None,
    },
}


@contextmanager
def dataset_path(name: str) -> Iterator[Path]:
    """The file to open for case ``name`` (archives unpacked into a temporary folder)."""
    case = CASES[name]
    if "zip" not in case:
        yield DATASETS / case["path"]
        return
    with tempfile.TemporaryDirectory(prefix=f"auralize-{name}-") as tmp:
        with zipfile.ZipFile(DATASETS / case["zip"]) as z:
            z.extractall(tmp)
        yield Path(tmp) / case["member"]
