"""OpenFOAM cases via pyvista's :class:`~pyvista.OpenFOAMReader`.

Every time directory of the case becomes a time step (including ``0``); the
internal mesh's cell fields are interpolated to points by the reader
(``cell_to_point_creation``) and sampled onto a uniform grid covering the
mesh (a :class:`~auralize.io.ResampledWarning` says onto what).  Only
reconstructed cases are read; run ``reconstructPar`` on decomposed ones.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from auralize.errors import FormatError
from auralize.io._common import FieldsArg, require_exists
from auralize.io._mesh import import_pyvista, open_mesh_series
from auralize.io.resample import ResolutionArg
from auralize.volume import TimeVolume


def _entry_file(path: Path) -> Path:
    if path.is_dir():
        foams = sorted(path.glob("*.foam"))
        if foams:
            return foams[0]
        control = path / "system" / "controlDict"
        if control.is_file():
            return control
        raise FormatError(
            f"{path}: a folder, but not an OpenFOAM case (no *.foam file and no "
            f"system/controlDict); open a case folder, its .foam file or a volume file"
        )
    return path


class _FoamSteps:
    """Loader over the time directories of a case (one cached reader)."""

    def __init__(self, entry: Path) -> None:
        self.entry = str(entry)
        self._reader: Any = None
        self._lock = threading.Lock()

    def _get(self) -> Any:
        if self._reader is None:
            pv = import_pyvista()
            reader = pv.OpenFOAMReader(self.entry)
            reader.skip_zero_time = False
            reader.cell_to_point_creation = True
            reader.disable_all_patch_arrays()
            reader.enable_patch_array("internalMesh")
            self._reader = reader
        return self._reader

    def times(self) -> list[float]:
        with self._lock:
            return [float(t) for t in self._get().time_values]

    def __call__(self, step: int) -> Any:
        with self._lock:
            reader = self._get()
            reader.set_active_time_value(reader.time_values[step])
            return reader.read()


_SI_BASE = ("kg", "m", "s", "K", "mol", "A", "cd")


def field_units(case: Path, names: list[str]) -> dict[str, str]:
    """Units of OpenFOAM fields from the ``dimensions [...]`` entry of their files.

    Reads only the header (first 4 kB) of each field's file in the first time
    directory holding it; ``[0 2 -2 0 0 0 0]`` becomes ``"m2 s-2"`` (the
    kinematic pressure of incompressible solvers).

    Parameters
    ----------
    case : Path
        The case folder (its time directories are ``0``, ``0.5`` ...).
    names : list of str
        Field file names (``U``, ``p`` ...).

    Returns
    -------
    dict of str to str
        ``{name: units}`` in SI base units (``"1"`` for a dimensionless
        field); names without a readable ``dimensions`` entry are left out.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> case = pathlib.Path(tempfile.mkdtemp())
    >>> (case / "0").mkdir()
    >>> _ = (case / "0" / "p").write_text("FoamFile {}\\ndimensions [0 2 -2 0 0 0 0];\\n")
    >>> _ = (case / "0" / "U").write_text("dimensions [0 1 -1 0 0 0 0];\\n")
    >>> field_units(case, ["p", "U", "T"])
    {'p': 'm2 s-2', 'U': 'm s-1'}
    """
    import re

    dirs = []
    for d in case.iterdir() if case.is_dir() else []:
        try:
            dirs.append((float(d.name), d))
        except ValueError:
            continue
    out: dict[str, str] = {}
    for name in names:
        for _t, d in sorted(dirs):
            f = d / name
            if not f.is_file():
                continue
            try:
                with f.open("rb") as fh:
                    head = fh.read(4096).decode("latin-1")
            except OSError:
                break
            m = re.search(r"dimensions\s+\[([^\]]*)\]", head)
            if m:
                try:
                    exps = [float(x) for x in m.group(1).split()]
                except ValueError:
                    break
                parts = [
                    u if e == 1 else f"{u}{e:g}"
                    for u, e in zip(_SI_BASE, exps, strict=False)
                    if e != 0
                ]
                out[name] = " ".join(parts) if parts else "1"
            break
    return out


def read_openfoam(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Open an OpenFOAM case as a lazy volume on a uniform grid.

    Parameters
    ----------
    path : path-like
        The case folder, its ``.foam`` marker file, or ``system/controlDict``.
    fields, resolution, name_map
        As in :func:`auralize.io.open_volume`; field names are OpenFOAM's
        (``U``, ``p`` ...).

    Returns
    -------
    TimeVolume
        One step per time directory, times in seconds; ``attrs["units"]``
        the fields' units (:func:`field_units`).

    Raises
    ------
    MissingFileError
        ``path`` does not exist.
    FormatError
        A folder that is not a case, a case VTK cannot read or one without
        time directories.
    FieldError
        A requested field is not in the case.
    DataError
        Steps whose meshes or arrays disagree.
    ParameterError
        Bad ``fields=``, ``resolution=`` or ``name_map=``.
    ResourceError
        The uniform grid does not fit in memory.

    Warns
    -----
    ResampledWarning
        The mesh is put on a uniform grid (unless its points form one).

    Examples
    --------
    The lid-driven cavity shipped with auralize (a zipped case):

    >>> import tempfile, zipfile
    >>> from pathlib import Path
    >>> import auralize
    >>> case = Path(auralize.__file__).parent / "data/openfoam-cavity/OpenFOAM.zip"
    >>> tmp = tempfile.TemporaryDirectory()
    >>> with zipfile.ZipFile(case) as z:
    ...     z.extractall(tmp.name)
    >>> vol = read_openfoam(Path(tmp.name) / "OpenFOAM/cavity/case.foam")
    >>> vol.times.tolist(), vol.is_vector("U")
    ([0.0, 0.5, 1.0, 1.5, 2.0, 2.5], True)
    >>> vol.frame("U", 5).shape[-1]  # frames are read when asked for
    3
    >>> tmp.cleanup()
    """
    path = Path(path).expanduser()
    require_exists(path)
    loader = _FoamSteps(_entry_file(path))
    try:
        times = loader.times()
    except Exception as exc:  # VTK reader failures; name the case
        raise FormatError(f"{path}: cannot read as an OpenFOAM case ({exc})") from exc
    if not times:
        raise FormatError(f"{path}: the OpenFOAM case has no time directories with fields")
    volume = open_mesh_series(
        source=str(path),
        loader=loader,
        labels=[f"{path} t={t:g}" for t in times],
        times=times,
        physical_times=True,
        fields=fields,
        resolution=resolution,
        name_map=name_map,
    )
    case = (
        Path(loader.entry).parent
        if Path(loader.entry).name != "controlDict"
        else (Path(loader.entry).parent.parent)
    )
    rename = dict(name_map or {})
    chosen = fields if isinstance(fields, Mapping) else None
    file_names = {
        vol_name: (str(chosen[vol_name]) if chosen and vol_name in chosen else vol_name)
        for vol_name in volume.field_names
    }
    inverse = {v: k for k, v in rename.items()}
    file_names = {k: inverse.get(v, v) for k, v in file_names.items()}
    units = field_units(case, sorted(set(file_names.values())))
    volume.attrs["units"] = {k: units[v] for k, v in file_names.items() if v in units}
    return volume
