"""Readers as backends, chosen by what a file holds.

A :class:`Backend` names a reader, the file name endings it takes, a cheap
content check (``guess_can_open``: magic bytes, a header, an XML root
element, the root of an HDF5 file) and the function that opens the file.
:func:`choose` picks the backend for a path:

1. every backend whose ``guess_can_open`` says yes is a candidate; the most
   specific content wins (:attr:`Backend.specificity`: an Exodus II file is
   a netCDF file with ``num_dim``/``coordx``/``connect1``/``api_version``,
   a VTKHDF file an HDF5 file with a ``/VTKHDF`` group ...); among equally
   specific ones the suffix decides, then the order of :func:`all_backends`;
2. when no content check applies (an empty ``.foam`` file, a PLOT3D ``.q``
   file, a damaged file), the backend taking the file name does, the longest
   ending first (``.cas.h5`` before ``.h5``);
3. last, any kind ``pyvista.get_reader`` knows by its suffix.

Built-in backends are registered here, in code.  Other packages add theirs
through the entry-point group ``auralize.readers``: each entry point names a
:class:`Backend` or a callable returning one, e.g. in a plugin's
``pyproject.toml``::

    [project.entry-points."auralize.readers"]
    mymodel = "mymodel.auralize_reader:BACKEND"

A plugin that fails to load, or does not give a Backend, is logged (logger
``auralize.io.backends``) and skipped; it never stops a file from opening.
Among equally good candidates, built-in backends come first and the pyvista
catch-all last, so a plugin taking ``.dat`` wins over pyvista's Tecplot reader.
"""

from __future__ import annotations

import functools
import importlib.metadata
import logging
import re
import struct
from collections.abc import Callable, Mapping
from dataclasses import KW_ONLY, dataclass
from pathlib import Path
from typing import Any

from auralize.errors import FormatError
from auralize.volume import TimeVolume

__all__ = [
    "ENTRY_POINT_GROUP",
    "HDF5_SUFFIXES",
    "Backend",
    "all_backends",
    "choose",
    "not_a_volume_message",
]

log = logging.getLogger(__name__)

#: Entry-point group of third-party reader backends.
ENTRY_POINT_GROUP = "auralize.readers"
#: File name endings read as HDF5 (auralize v1, VTKHDF or generic).
HDF5_SUFFIXES = (".h5", ".hdf5", ".he5", ".hdf", ".vtkhdf")

Opener = Callable[..., TimeVolume]


@dataclass(frozen=True)
class Backend:
    """One reader: its name, the endings it takes, a content check and an opener.

    Parameters
    ----------
    name : str
        Short name, e.g. ``"netcdf"``; a volume it opens carries it as
        ``attrs["reader"]``.
    suffixes : tuple of str
        File name endings taken when no content check decides (``".nc"``,
        ``".cas.h5"``), lower case.
    open : callable
        ``open(path, *, fields, resolution, name_map)`` returning a
        :class:`~auralize.volume.TimeVolume`.
    guess_can_open : callable, optional
        ``guess_can_open(path) -> bool``: whether the file's content is this
        kind.  Reads a few bytes or the root of the file, never the data;
        an exception counts as no.
    specificity : int
        When several content checks say yes, the highest wins: a plain
        container signature (HDF5) is 0, a format's own magic 10-20, a layout
        inside a container (VTKHDF group, Exodus variables) 30-40.
    name_pattern : str, optional
        Regular expression (case-insensitive, searched in the file name) for
        kinds told by name rather than by ending (PLOT3D ``*xyz*.bin``,
        OpenFOAM's ``controlDict``).
    description : str
        What it reads, for messages and docs.
    catch_all : bool
        Consulted only when no other backend takes the file, by content or by
        name (the pyvista catch-all).

    Examples
    --------
    >>> from pathlib import Path
    >>> def read_mine(path, **opts): ...
    >>> mine = Backend("mine", (".mine",), read_mine,
    ...                guess_can_open=lambda p: Path(p).read_bytes()[:4] == b"MINE")
    >>> mine.takes_name(Path("run.MINE"))
    True
    """

    name: str
    suffixes: tuple[str, ...]
    open: Opener
    _: KW_ONLY
    guess_can_open: Callable[[Path], bool] | None = None
    specificity: int = 20
    name_pattern: str | None = None
    description: str = ""
    #: Consulted only when nothing else takes the file (the pyvista catch-all).
    catch_all: bool = False

    def name_match(self, path: Path) -> int:
        """How well the file name fits: the length of the matching ending, 0 if none.

        Parameters
        ----------
        path : Path
            The file; only its name is looked at.

        Returns
        -------
        int
            The length of the longest of ``suffixes`` the name ends with
            (case-insensitive); 1 when only ``name_pattern`` matches; 0 when
            neither does.

        Examples
        --------
        >>> from pathlib import Path
        >>> b = Backend("mine", (".mine", ".mine.gz"), lambda path, **opts: None)
        >>> b.name_match(Path("run.MINE.gz")), b.name_match(Path("run.txt"))
        (8, 0)
        """
        low = path.name.lower()
        best = max((len(s) for s in self.suffixes if low.endswith(s.lower())), default=0)
        if not best and self.name_pattern and re.search(self.name_pattern, path.name, re.I):
            best = 1
        return best

    def takes_name(self, path: Path) -> bool:
        """Whether the file name is one this backend takes.

        Parameters
        ----------
        path : Path
            The file; only its name is looked at.

        Returns
        -------
        bool
            ``name_match(path) > 0``.

        Examples
        --------
        >>> from pathlib import Path
        >>> b = Backend("mine", (".mine",), lambda path, **opts: None)
        >>> b.takes_name(Path("a.mine")), b.takes_name(Path("a.h5"))
        (True, False)
        """
        return self.name_match(path) > 0

    def claims(self, path: Path) -> bool:
        """``guess_can_open(path)``, with any exception counted as no.

        Parameters
        ----------
        path : Path
            The file or folder whose content is checked.

        Returns
        -------
        bool
            False as well when the backend has no content check.

        Examples
        --------
        >>> from pathlib import Path
        >>> def unreadable(path):
        ...     raise OSError("permission denied")
        >>> b = Backend("mine", (".mine",), lambda path, **opts: None,
        ...             guess_can_open=unreadable)
        >>> b.claims(Path("run.mine"))
        False
        """
        if self.guess_can_open is None:
            return False
        try:
            return bool(self.guess_can_open(path))
        except Exception as exc:  # a content check must never stop a file from opening
            log.debug("reader %s: content check of %s failed: %s", self.name, path, exc)
            return False


# --------------------------------------------------------------------------- choosing
def choose(path: Path, backends: tuple[Backend, ...] | None = None) -> Backend | None:
    """The backend that reads ``path`` (see the module docstring), or None.

    Parameters
    ----------
    path : Path
        The file or folder to read.
    backends : tuple of Backend, optional
        The candidates, in order of preference among equals; default
        :func:`all_backends`.

    Returns
    -------
    Backend or None
        None when no backend takes the file, by content or by name.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from auralize.io import save_volume
    >>> from auralize.volume import TimeVolume
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "rho.hdf"   # an auralize file, told by content
    >>> save_volume(TimeVolume.from_arrays({"rho": np.ones((2, 2, 2, 2))}, times=[0, 1]),
    ...             f.with_suffix(".h5"))
    >>> f.with_suffix(".h5").rename(f)
    PosixPath(...)
    >>> choose(f).name
    'auralize-hdf5'
    """
    table = all_backends() if backends is None else backends
    order = {b.name: n for n, b in enumerate(table)}
    claimed = [b for b in table if not b.catch_all and b.claims(path)]
    if claimed:
        return max(claimed, key=lambda b: (b.specificity, b.name_match(path), -order[b.name]))
    for group in ([b for b in table if not b.catch_all], [b for b in table if b.catch_all]):
        named = [b for b in group if b.takes_name(path)]
        if named:
            return max(named, key=lambda b: (b.name_match(path), -order[b.name]))
    return None


@functools.cache
def all_backends() -> tuple[Backend, ...]:
    """Built-in backends, then those of the ``auralize.readers`` entry points, then pyvista's.

    Loaded once and cached; ``all_backends.cache_clear()`` reads the entry
    points again.

    Returns
    -------
    tuple of Backend
        A plugin that fails to load, gives no :class:`Backend` or takes a
        name already taken is logged and left out.

    Examples
    --------
    >>> names = [b.name for b in all_backends()]
    >>> names[0], names[-1], "netcdf" in names
    ('openfoam', 'pyvista', True)
    """
    builtins = _builtin_backends()
    taken = {b.name for b in builtins}
    plugins: list[Backend] = []
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        try:
            obj = ep.load()
            backend = obj if isinstance(obj, Backend) else obj() if callable(obj) else obj
            if not isinstance(backend, Backend):
                raise TypeError(f"gives a {type(backend).__name__}, not an auralize Backend")
            if backend.name in taken:
                raise ValueError(f"the reader name {backend.name!r} is taken")
        except Exception as exc:  # a broken plugin must not stop files from opening
            log.warning(
                "reader plugin %r (%s, entry-point group %s) skipped: %s",
                ep.name,
                ep.value,
                ENTRY_POINT_GROUP,
                exc,
            )
            continue
        taken.add(backend.name)
        plugins.append(backend)
    return (*builtins, *plugins, _PYVISTA)


# --------------------------------------------------------------------------- content probes
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def _head(path: Path, n: int = 4096) -> bytes:
    """The first ``n`` bytes of a regular file (empty for folders and unreadable files)."""
    if not path.is_file():
        return b""
    try:
        with path.open("rb") as fh:
            return fh.read(n)
    except OSError:
        return b""


def has_hdf5_signature(path: Path) -> bool:
    """Whether the HDF5 signature is at offset 0, 512, 1024, 2048 ... (after a user block).

    Parameters
    ----------
    path : Path
        Any path; folders and unreadable files have no signature.

    Returns
    -------
    bool

    Examples
    --------
    >>> import h5py, tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "any.dat"
    >>> with h5py.File(f, "w") as h:
    ...     h["x"] = [1.0]
    >>> has_hdf5_signature(f), has_hdf5_signature(f.parent)
    (True, False)
    """
    if not path.is_file():
        return False
    try:
        size = path.stat().st_size
        with path.open("rb") as fh:
            offset = 0
            while offset + 8 <= size:
                fh.seek(offset)
                if fh.read(8) == HDF5_SIGNATURE:
                    return True
                offset = 512 if offset == 0 else 2 * offset
    except OSError:
        return False
    return False


@dataclass(frozen=True)
class HDF5Root:
    """What the root of an HDF5 file holds (links are listed, never followed).

    Parameters
    ----------
    damaged : bool
        The file has the HDF5 signature but its root cannot be read.
    groups, datasets : frozenset of str
        Names of the groups and datasets at the root (hard links only).
    attrs : frozenset of str
        Names of the root group's attributes.
    scales : bool
        Some root dataset is a dimension scale or attached to one (netCDF4's
        dimensions).

    Examples
    --------
    >>> import h5py, tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "case.h5"
    >>> with h5py.File(f, "w") as h:
    ...     _ = h.create_group("VTKHDF")
    ...     h.attrs["auralize_format"] = "volume"
    >>> root = hdf5_root(f)
    >>> root.damaged, sorted(root.groups), sorted(root.attrs)
    (False, ['VTKHDF'], ['auralize_format'])
    """

    damaged: bool
    _: KW_ONLY
    groups: frozenset[str] = frozenset()
    datasets: frozenset[str] = frozenset()
    attrs: frozenset[str] = frozenset()
    #: Some root dataset is a dimension scale or attached to one (netCDF4's dimensions).
    scales: bool = False


#: Root names looked up even in files with very many root objects.
_KEY_NAMES = ("VTKHDF", "meshes", "settings", "coordx", "coord", "connect1", "num_dim")


def hdf5_root(path: Path, *, limit: int = 512) -> HDF5Root | None:
    """The root of an HDF5 file; None without the HDF5 signature, ``damaged`` if unreadable.

    Parameters
    ----------
    path : Path
        Any path.
    limit : int
        Most root objects listed (besides the names that tell kinds apart,
        such as ``VTKHDF``, ``meshes`` or ``coordx``, which are always looked up).

    Returns
    -------
    HDF5Root or None

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> bad = folder / "bad.h5"
    >>> _ = bad.write_bytes(HDF5_SIGNATURE + bytes(100))  # a signature, no file
    >>> hdf5_root(bad).damaged
    True
    >>> _ = (folder / "notes.txt").write_text("not HDF5")
    >>> hdf5_root(folder / "notes.txt") is None
    True
    """
    if not has_hdf5_signature(path):
        return None
    import itertools

    import h5py

    groups: set[str] = set()
    datasets: set[str] = set()
    scales = False
    try:
        with h5py.File(path, "r") as f:
            names = list(itertools.islice(iter(f), limit))
            for name in dict.fromkeys([*names, *_KEY_NAMES]):
                link = f.get(name, getlink=True)
                if not isinstance(link, h5py.HardLink):
                    continue  # soft and external links are not followed
                obj = f.get(name)
                if isinstance(obj, h5py.Group):
                    groups.add(name)
                elif isinstance(obj, h5py.Dataset):
                    datasets.add(name)
                    if not scales:
                        keys = set(obj.attrs.keys())
                        scales = "DIMENSION_LIST" in keys or "REFERENCE_LIST" in keys
            attrs = frozenset(f.attrs.keys())
    except Exception as exc:  # h5py raises many kinds on damaged files
        log.debug("%s: HDF5 root unreadable: %s", path, exc)
        return HDF5Root(damaged=True)
    return HDF5Root(
        False, groups=frozenset(groups), datasets=frozenset(datasets), attrs=attrs, scales=scales
    )


_NC_TYPE_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 4, 6: 8, 7: 1, 8: 2, 9: 4, 10: 8, 11: 8}


@dataclass(frozen=True)
class ClassicHeader:
    """Names in a classic netCDF (CDF-1, CDF-2 or CDF-5) header.

    Parameters
    ----------
    version : int
        1, 2 or 5 (the fourth byte of the file).
    dimensions, attributes, variables : frozenset of str
        Names of the dimensions, the global attributes and the variables.

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> h = netcdf_classic_header(Path(auralize.__file__).parent / "data/netcdf-pulse/pulse.nc")
    >>> h.version, sorted(h.dimensions), "density" in h.variables
    (2, ['time', 'x', 'y', 'z'], True)
    """

    version: int
    _: KW_ONLY
    dimensions: frozenset[str]
    attributes: frozenset[str]
    variables: frozenset[str]


def netcdf_classic_header(path: Path, *, limit: int = 1 << 20) -> ClassicHeader | None:
    """The dimension, global attribute and variable names of a classic netCDF file.

    Parses the header only (at most ``limit`` bytes); None if the file does
    not start with ``CDF\\x01``, ``CDF\\x02`` or ``CDF\\x05`` or the header
    cannot be parsed.

    Parameters
    ----------
    path : Path
        Any path.
    limit : int
        Most bytes read; a longer header gives None.

    Returns
    -------
    ClassicHeader or None

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> data = Path(auralize.__file__).parent / "data"
    >>> sorted(netcdf_classic_header(data / "netcdf-pulse/pulse.nc").variables)
    ['density', 'time', 'u', 'v', 'w', 'x', 'y', 'z']
    >>> netcdf_classic_header(data / "plot3d-combustor/combxyz.bin") is None
    True
    """
    data = _head(path, limit)
    if data[:3] != b"CDF" or len(data) < 4 or data[3] not in (1, 2, 5):
        return None
    version = data[3]
    count = 8 if version == 5 else 4  # NON_NEG: 64 bits in CDF-5
    pos = 4

    def uint(n: int) -> int:
        nonlocal pos
        (value,) = struct.unpack_from(">Q" if n == 8 else ">I", data, pos)
        pos += n
        return int(value)

    def skip(n: int) -> None:
        nonlocal pos
        pos += n + (-n % 4)
        if pos > len(data):
            raise ValueError("header longer than read")

    def name() -> str:
        n = uint(count)
        start = pos
        skip(n)
        return data[start : start + n].decode("utf-8", "replace")

    def tagged(tag: int) -> int:
        got, n = uint(4), uint(count)
        if got not in (0, tag) or (got == 0 and n != 0):
            raise ValueError(f"bad header tag {got}")
        return n

    def attribute_names() -> list[str]:
        out = []
        for _ in range(tagged(0x0C)):
            out.append(name())
            size = _NC_TYPE_SIZES[uint(4)]
            skip(size * uint(count))
        return out

    try:
        uint(count)  # numrecs
        dims = []
        for _ in range(tagged(0x0A)):
            dims.append(name())
            uint(count)
        gatts = attribute_names()
        variables = []
        for _ in range(tagged(0x0B)):
            variables.append(name())
            skip(count * uint(count))  # dimension ids
            attribute_names()
            uint(4)  # type
            uint(count)  # vsize
            uint(4 if version == 1 else 8)  # begin
    except (struct.error, ValueError, KeyError):
        return None
    return ClassicHeader(
        version,
        dimensions=frozenset(dims),
        attributes=frozenset(gatts),
        variables=frozenset(variables),
    )


def _exodus_names(dims: frozenset[str], attrs: frozenset[str], variables: frozenset[str]) -> bool:
    """Whether netCDF names are Exodus II's (a mesh, not a CF grid)."""
    coords = bool({"coordx", "coord"} & variables)
    if "num_dim" not in dims or not ("num_nodes" in dims or coords):
        return False
    return bool({"api_version", "version"} & attrs) or any(
        re.fullmatch(r"connect\d+", v) for v in variables
    )


def is_exodus(path: Path) -> bool:
    """Exodus II: netCDF (classic or netCDF4/HDF5) with Exodus' dimensions and variables.

    ``num_dim`` and ``num_nodes`` (or a ``coordx``/``coord`` variable), and
    an ``api_version``/``version`` attribute or a ``connect1`` ... variable.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from scipy.io import netcdf_file
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "mesh.nc"
    >>> with netcdf_file(f, "w") as nc:
    ...     nc.api_version = 8.0
    ...     nc.createDimension("num_dim", 3)
    ...     nc.createDimension("num_nodes", 4)
    ...     nc.createVariable("coordx", "d", ("num_nodes",))[:] = np.arange(4.0)
    >>> is_exodus(f), is_netcdf(f)
    (True, True)
    """
    header = netcdf_classic_header(path)
    if header is not None:
        return _exodus_names(header.dimensions, header.attributes, header.variables)
    root = hdf5_root(path)
    if root is None or root.damaged:
        return False
    return _exodus_names(root.datasets, root.attrs, root.datasets)


def is_netcdf(path: Path) -> bool:
    """netCDF classic (``CDF`` magic, any version) or netCDF4 (``_NCProperties``, dimension scales).

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> import h5py, tempfile, pathlib
    >>> from pathlib import Path
    >>> import auralize
    >>> is_netcdf(Path(auralize.__file__).parent / "data/netcdf-pulse/pulse.nc")
    True
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "plain.h5"
    >>> with h5py.File(f, "w") as h:
    ...     h["rho"] = [1.0, 2.0]
    >>> is_netcdf(f)
    False
    """
    head = _head(path, 4)
    if head[:3] == b"CDF":
        return True
    root = hdf5_root(path)
    return root is not None and not root.damaged and ("_NCProperties" in root.attrs or root.scales)


def _hdf5_has(*, group: str | None = None, attr: str | None = None) -> Callable[[Path], bool]:
    def check(path: Path) -> bool:
        root = hdf5_root(path)
        if root is None or root.damaged:
            return False
        return (group is None or group in root.groups) and (attr is None or attr in root.attrs)

    return check


def is_fluent_cff(path: Path) -> bool:
    """A FLUENT CFF case (HDF5 with ``/meshes`` and ``/settings``, as VTK checks).

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> import h5py, tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "wing.cas.h5"
    >>> with h5py.File(f, "w") as h:
    ...     _ = h.create_group("meshes"), h.create_group("settings")
    >>> is_fluent_cff(f)
    True
    """
    root = hdf5_root(path)
    return root is not None and not root.damaged and {"meshes", "settings"} <= root.groups


def xml_root(path: Path) -> tuple[str, str] | None:
    """``(element name, its attribute text)`` of an XML file's root element, or None.

    Reads the first 8 KiB; the XML declaration, comments and a DOCTYPE before
    the root are skipped.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    (str, str) or None
        None when the file does not start like XML.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "run.xmf"
    >>> _ = f.write_text('<?xml version="1.0"?>\\n<!-- a run -->\\n<Xdmf Version="3.0">')
    >>> xml_root(f)
    ('Xdmf', ' Version="3.0"')
    """
    head = _head(path, 8192)
    text = head.decode("utf-8", "replace").lstrip("\ufeff \t\r\n")
    if not text.startswith("<"):
        return None
    text = re.sub(r"<\?.*?\?>|<!--.*?-->|<!DOCTYPE[^>]*>", "", text, flags=re.S)
    m = re.match(r"\s*<([A-Za-z_][\w.:-]*)([^>]*)>?", text)
    return (m.group(1), m.group(2)) if m else None


def vtk_file_type(path: Path) -> str | None:
    """``type`` of a VTK XML file's ``<VTKFile>`` root, ``"legacy"`` for a legacy ``.vtk``.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    str or None
        E.g. ``"ImageData"``, ``"Collection"``, ``"vtkOverlappingAMR"``; None
        when the file is not a VTK data file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "a.dat").write_text('<VTKFile type="ImageData" version="1.0">')
    >>> _ = (folder / "b.dat").write_text("# vtk DataFile Version 3.0\\nb\\nASCII\\n")
    >>> vtk_file_type(folder / "a.dat"), vtk_file_type(folder / "b.dat")
    ('ImageData', 'legacy')
    """
    if _head(path, 22).startswith(b"# vtk DataFile Version"):
        return "legacy"
    root = xml_root(path)
    if root is None or root[0] != "VTKFile":
        return None
    m = re.search(r"\btype\s*=\s*[\"']([^\"']*)", root[1])
    return m.group(1) if m else None


#: File ending of each VTK data-set type (the reader pyvista picks).
VTK_TYPE_SUFFIXES = {
    "legacy": ".vtk",
    "ImageData": ".vti",
    "StructuredGrid": ".vts",
    "RectilinearGrid": ".vtr",
    "UnstructuredGrid": ".vtu",
    "PolyData": ".vtp",
    "PImageData": ".pvti",
    "PStructuredGrid": ".pvts",
    "PRectilinearGrid": ".pvtr",
    "PUnstructuredGrid": ".pvtu",
    "vtkMultiBlockDataSet": ".vtm",
}
_AMR_TYPES = ("vtkOverlappingAMR", "vtkHierarchicalBoxDataSet", "vtkNonOverlappingAMR")


def is_xdmf(path: Path) -> bool:
    """XML whose root element is ``<Xdmf>``.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "run.xml"
    >>> _ = f.write_text('<Xdmf Version="3.0"><Domain/></Xdmf>')
    >>> is_xdmf(f)
    True
    """
    root = xml_root(path)
    return root is not None and root[0] == "Xdmf"


def is_series(path: Path) -> bool:
    """ParaView's JSON ``.series``: ``{"file-series-version": ...}``.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> import json, tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "run.json"
    >>> _ = f.write_text(json.dumps({"file-series-version": "1.0", "files": []}))
    >>> is_series(f)
    True
    """
    text = _head(path, 1024).decode("utf-8", "replace").lstrip("\ufeff \t\r\n")
    return text.startswith("{") and '"file-series-version"' in text


def is_ensight(path: Path) -> bool:
    """EnSight case text: a ``FORMAT`` section saying ``type: ensight``.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> case = Path(auralize.__file__).parent / "data/ensight-cylinder/cylinder_Re35.case"
    >>> is_ensight(case), is_ensight(case.with_suffix(".geo"))
    (True, False)
    """
    head = _head(path, 4096)
    if b"\0" in head:
        return False
    text = head.decode("utf-8", "replace")
    return bool(
        re.search(r"^\s*FORMAT\s*$", text, re.M)
        and re.search(r"^\s*type\s*:\s*ensight", text, re.M | re.I)
    )


def is_openfoam(path: Path) -> bool:
    """An OpenFOAM case folder (any folder: the reader says what is missing) or a controlDict.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> import tempfile, pathlib
    >>> case = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (case / "controlDict").write_text("FoamFile { object controlDict; }")
    >>> _ = (case / "notes.txt").write_text("FoamFile")
    >>> is_openfoam(case), is_openfoam(case / "controlDict"), is_openfoam(case / "notes.txt")
    (True, True, False)
    """
    if path.is_dir():
        return True
    text = _head(path, 2048).decode("utf-8", "replace")
    return "FoamFile" in text and re.search(r"\bobject\s+controlDict\s*;", text) is not None


def is_plot3d_grid(path: Path) -> bool:
    """A binary PLOT3D grid (3-D, single or multi-grid): header dimensions that give its size.

    Tries both byte orders, single and double precision, with and without
    Fortran record markers and IBLANK; the file's size must match exactly.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> data = Path(auralize.__file__).parent / "data/plot3d-combustor"
    >>> is_plot3d_grid(data / "combxyz.bin"), is_plot3d_grid(data / "combq.bin")
    (True, False)
    """
    head = _head(path, 4 + 4 * (3 * 64 + 8))
    if len(head) < 12:
        return False
    size = path.stat().st_size
    for endian in "<>":
        ints = list(struct.unpack(f"{endian}{len(head) // 4}i", head[: len(head) // 4 * 4]))
        layouts: list[tuple[int, list[int], bool]] = [(12, ints[0:3], False)]  # header, dims
        k = ints[0]
        if 1 <= k <= 64 and len(ints) >= 1 + 3 * k:
            layouts.append((4 + 12 * k, ints[1 : 1 + 3 * k], False))
        if ints[0] == 12 and len(ints) >= 5 and ints[4] == 12:
            layouts.append((20, ints[1:4], True))
        k = ints[1] if len(ints) > 1 else 0
        if ints[0] == 4 and 1 <= k <= 64 and len(ints) >= 5 + 3 * k and ints[2] == 4:
            if ints[3] == 12 * k == ints[4 + 3 * k]:
                layouts.append((20 + 12 * k, ints[4 : 4 + 3 * k], True))
        for header, dims, markers in layouts:
            if len(dims) % 3 or any(d < 1 for d in dims):
                continue
            counts = [dims[i] * dims[i + 1] * dims[i + 2] for i in range(0, len(dims), 3)]
            for prec in (4, 8):
                for iblank in (0, 4):
                    data = sum(n * (3 * prec + iblank) + (8 if markers else 0) for n in counts)
                    if header + data == size:
                        return True
    return False


# --------------------------------------------------------------------------- openers
def is_enzo(path: Path) -> bool:
    """An Enzo output: its ``.hierarchy`` (``Grid = 1`` in its first lines), or its parameter
    or ``.cpuNNNN`` grid file with the hierarchy beside it.

    Parameters
    ----------
    path : Path
        Any path.

    Returns
    -------
    bool

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (out / "data0001.hierarchy").write_text("\\nGrid = 1\\nTask = 0\\n")
    >>> _ = (out / "data0001").write_text("InitialTime = 0.5\\n")
    >>> is_enzo(out / "data0001"), is_enzo(out / "data0001.cpu0000")
    (True, True)
    """
    from auralize.io.vtk_readers import enzo_hierarchy

    hierarchy = enzo_hierarchy(path)
    if hierarchy is None:
        return False
    return re.search(rb"^\s*Grid\s*=\s*1\b", _head(hierarchy), flags=re.M) is not None


def _opener(module: str, function: str) -> Opener:
    """``auralize.io.<module>.<function>``, imported when a file is opened."""

    def open_(path: Path, **opts: Any) -> TimeVolume:
        mod = importlib.import_module(f"auralize.io.{module}")
        volume: TimeVolume = getattr(mod, function)(path, **opts)
        return volume

    open_.__qualname__ = open_.__name__ = f"open_with_{function}"
    return open_


def _open_vtk_file(path: Path, **opts: Any) -> TimeVolume:
    """A VTK data file; one whose ending is not its type's is read as its type."""
    from auralize.io import paraview

    kind = vtk_file_type(path)
    suffix = VTK_TYPE_SUFFIXES.get(kind or "")
    if (
        suffix is None
        or path.suffix.lower() == suffix
        or (kind == "legacy" and path.suffix.lower() in paraview.MESH_SUFFIXES)
    ):
        return paraview.read_mesh_file(path, **opts)
    from auralize.io._mesh import import_pyvista, open_mesh_series

    def load(step: int) -> Any:
        return import_pyvista().read(str(path), force_ext=suffix)

    return open_mesh_series(
        source=str(path), loader=load, labels=[str(path)], times=[0.0], physical_times=False, **opts
    )


def _open_exodus(path: Path, **opts: Any) -> TimeVolume:
    """Exodus II with VTK's Exodus reader, whatever the file is called (``.nc``, ``.exo`` ...)."""
    from auralize.io import vtk_readers

    if path.suffix.lower() in _EXODUS_SUFFIXES:  # pyvista.get_reader picks Exodus itself
        return vtk_readers.read_with_pyvista(path, **opts)

    def make() -> Any:
        from auralize.io._mesh import import_pyvista

        return import_pyvista().ExodusIIReader(str(path))

    return vtk_readers._open_reader_series(path, make, kind="Exodus II", **opts)


def _open_netcdf(path: Path, **opts: Any) -> TimeVolume:
    """netCDF classic or netCDF4; a netCDF4 file not named ``.nc`` given ``fields={name: path}``
    is read as plain HDF5, as before."""
    from auralize.io import netcdf

    named_nc = path.suffix.lower() in netcdf.NETCDF_SUFFIXES
    if not named_nc and has_hdf5_signature(path):
        return _open_hdf5(path, **opts)
    return netcdf.read_netcdf(path, **opts)


def _open_fluent(path: Path, **opts: Any) -> TimeVolume:
    """A FLUENT CFF case (``.cas.h5``, its data beside it in ``.dat.h5``)."""
    from auralize.io import vtk_readers

    if not path.name.lower().endswith(".cas.h5"):
        raise FormatError(
            f"{path}: a FLUENT CFF case file, but VTK finds its data file by name: rename it "
            f"<name>.cas.h5, with its data file as <name>.dat.h5 beside it"
        )
    return vtk_readers.read_with_pyvista(path, **opts)


def _open_hdf5(
    path: Path,
    *,
    fields: Any = None,
    resolution: Any = None,
    name_map: Mapping[str, str] | None = None,
) -> TimeVolume:
    """Any HDF5 file: told apart by :func:`auralize.io.hdf5.sniff`, read as before."""
    from auralize.io import hdf5, netcdf, paraview
    from auralize.io.resample import resample_uniform

    opts: dict[str, Any] = {"fields": fields, "resolution": resolution, "name_map": name_map}
    root = hdf5_root(path)
    if root is not None and root.damaged and path.suffix.lower() in netcdf.NETCDF_SUFFIXES:
        return netcdf.read_netcdf(path, **opts)  # the netCDF reader says what is wrong
    kind = hdf5.sniff(path)
    if kind == "vtkhdf":
        return paraview.read_vtkhdf(path, **opts)
    generic = hdf5.wants_generic(kind, fields)
    if kind == "netcdf4" and not generic:
        return netcdf.read_netcdf(path, **opts)
    if generic:
        assert isinstance(fields, Mapping)
        volume = hdf5.read_generic_hdf5(path, fields, name_map=name_map)
    elif kind == "auralize":
        volume = hdf5.read_hdf5(path, fields=fields, name_map=name_map)
    else:
        raise FormatError(not_a_volume_message(path))
    return resample_uniform(volume, resolution)


def not_a_volume_message(path: Path) -> str:
    """Why an HDF5 file of no known layout (Chombo, a simulation's own) is not read, and how to.

    Parameters
    ----------
    path : Path
        An HDF5 file none of the HDF5 backends reads.

    Returns
    -------
    str
        One message naming the file, what it is when :func:`auralize.io.foreign.explain`
        knows, and how to name its datasets (``--field``, ``fields=``), with the
        datasets shaped like fields as examples.

    Examples
    --------
    >>> import h5py, numpy as np, tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "sim.h5"
    >>> with h5py.File(f, "w") as h:
    ...     h["run/rho"] = np.zeros((2, 3, 3, 3))
    >>> "--field rho=/run/rho" in not_a_volume_message(f)
    True
    """
    import h5py

    from auralize.io.foreign import explain
    from auralize.io.hdf5 import field_candidates

    try:
        with h5py.File(path, "r") as f:
            cands = field_candidates(f)
    except OSError:
        cands = []
    example = cands[0] if cands else "/path/to/dataset"
    known = explain(path)
    if known and cands:  # a kind auralize knows of, whose datasets can still be named
        return (
            f"{known}; or read its datasets as a uniform grid: --field rho={example} on the "
            f"command line, fields={{'rho': {example!r}}} in Python"
        )
    if known:
        return known
    return (
        f"{path}: an HDF5 file, but not an auralize volume file (root attribute "
        f"auralize_format='volume' is missing) nor VTKHDF, netCDF4 or FLUENT; name the "
        f"datasets to read: --field rho={example} on the command line, "
        f"fields={{'rho': {example!r}}} in Python (datasets shaped like fields: "
        f"{', '.join(cands) or 'none'})"
    )


_EXODUS_SUFFIXES = (".exo", ".e", ".ex2", ".exii")


class _PyVistaBackend(Backend):
    """Every other kind ``pyvista.get_reader`` knows by its ending."""

    def name_match(self, path: Path) -> int:
        from auralize.io.vtk_readers import pyvista_suffixes

        low = path.name.lower()
        return max((len(s) for s in pyvista_suffixes() if low.endswith(s)), default=0)


_PYVISTA = _PyVistaBackend(
    "pyvista",
    (),
    _opener("vtk_readers", "read_with_pyvista"),
    catch_all=True,
    description="any other kind pyvista.get_reader opens (CGNS, FLUENT .cas, Tecplot ...)",
)


def _builtin_backends() -> tuple[Backend, ...]:
    from auralize.io.netcdf import NETCDF_SUFFIXES
    from auralize.io.paraview import MESH_SUFFIXES
    from auralize.io.vtk_readers import AMR_SUFFIXES, PLOT3D_GRID_SUFFIXES, XDMF_SUFFIXES

    def vtk_type(*types: str) -> Callable[[Path], bool]:
        return lambda path: vtk_file_type(path) in types

    return (
        Backend(
            "openfoam",
            (".foam",),
            _opener("openfoam", "read_openfoam"),
            guess_can_open=is_openfoam,
            specificity=30,
            name_pattern=r"^controlDict$",
            description="OpenFOAM case folder, .foam file or system/controlDict",
        ),
        Backend(
            "pvd",
            (".pvd",),
            _opener("paraview", "read_pvd"),
            guess_can_open=vtk_type("Collection"),
            specificity=30,
            description='ParaView collection (<VTKFile type="Collection">)',
        ),
        Backend(
            "series",
            (".series",),
            _opener("paraview", "read_series"),
            guess_can_open=is_series,
            specificity=30,
            description="ParaView JSON file series",
        ),
        Backend(
            "vtk",
            MESH_SUFFIXES,
            _open_vtk_file,
            guess_can_open=vtk_type(*VTK_TYPE_SUFFIXES),
            specificity=30,
            description="VTK XML or legacy data file (one step)",
        ),
        Backend(
            "xdmf",
            XDMF_SUFFIXES,
            _opener("vtk_readers", "read_xdmf"),
            guess_can_open=is_xdmf,
            specificity=30,
            description="XDMF 2/3 (<Xdmf> root)",
        ),
        Backend(
            "ensight",
            (".case",),
            _opener("vtk_readers", "read_ensight"),
            guess_can_open=is_ensight,
            specificity=30,
            description="EnSight Gold case",
        ),
        Backend(
            "vtk-amr",
            AMR_SUFFIXES,
            _opener("vtk_readers", "read_amr"),
            guess_can_open=vtk_type(*_AMR_TYPES),
            specificity=30,
            description="VTK XML AMR (overlapping or hierarchical boxes)",
        ),
        Backend(
            "enzo",
            (".hierarchy",),
            _opener("vtk_readers", "read_enzo"),
            guess_can_open=is_enzo,
            specificity=35,
            name_pattern=r"[.]cpu[0-9]{4,}$",
            description="Enzo AMR output (.hierarchy, parameter or .cpuNNNN grid file)",
        ),
        Backend(
            "exodus",
            _EXODUS_SUFFIXES,
            _open_exodus,
            guess_can_open=is_exodus,
            specificity=40,
            description="Exodus II (netCDF with num_dim, coordx, connect1, api_version)",
        ),
        Backend(
            "netcdf",
            NETCDF_SUFFIXES,
            _open_netcdf,
            guess_can_open=is_netcdf,
            specificity=20,
            description="netCDF classic (CDF-1/2) or netCDF4 with CF conventions",
        ),
        Backend(
            "plot3d",
            (*PLOT3D_GRID_SUFFIXES, ".q"),
            _opener("vtk_readers", "read_plot3d"),
            guess_can_open=is_plot3d_grid,
            specificity=10,
            name_pattern=r"(xyz.*|q[_.-]?\d*)\.bin$",
            description="PLOT3D grid + .q solutions (binary grid told by its size)",
        ),
        Backend(
            "fluent-cff",
            (".cas.h5",),
            _open_fluent,
            guess_can_open=is_fluent_cff,
            specificity=30,
            description="FLUENT CFF case (HDF5 /meshes + /settings)",
        ),
        Backend(
            "vtkhdf",
            (".vtkhdf",),
            _opener("paraview", "read_vtkhdf"),
            guess_can_open=_hdf5_has(group="VTKHDF"),
            specificity=32,
            description="VTKHDF (HDF5 with a /VTKHDF group)",
        ),
        Backend(
            "auralize-hdf5",
            (".h5", ".hdf5"),
            _open_hdf5,
            guess_can_open=_hdf5_has(attr="auralize_format"),
            specificity=31,
            description="auralize HDF5 volume file (root attribute auralize_format)",
        ),
        Backend(
            "hdf5",
            HDF5_SUFFIXES,
            _open_hdf5,
            guess_can_open=has_hdf5_signature,
            specificity=0,
            description="any other HDF5 file, read with fields={name: '/dataset/path'}",
        ),
    )
