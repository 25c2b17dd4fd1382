"""Check an XDMF file, and the heavy data it names, before VTK reads them.

VTK's XDMF reader trusts its input.  When an HDF5 file a ``DataItem`` names
cannot be read (zero bytes, truncated, overwritten, a flipped bit), it logs
``XDMF Error ... Can't Open Dataset`` and then ends the process with a
segmentation fault; and it reads heavy data from wherever the XML points:
absolute and ``../`` paths, raw ``Format="Binary"`` files anywhere,
``<xi:include href="/etc/passwd"/>`` (or ``/dev/zero``, which never ends).
So an XDMF file is read here first, with Python's own XML parser, and
checked:

* the file is at most :data:`MAX_XML_BYTES` and its XML declares no entity
  (internal or external) and uses none it does not define; a DOCTYPE without
  entities (``<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>``) is fine;
* every heavy-data file (``file.h5:/path`` of ``Format="HDF"``, the file of
  ``Format="Binary"``) lies inside the XDMF file's folder once symlinks are
  resolved, and an XInclude that names another file (``href``) is refused —
  unless reading other files is allowed
  (:func:`auralize.io.hdf5.allow_external_data`, ``--allow-external``,
  ``AURALIZE_HDF5_EXTERNAL=1``); an allowed XInclude must still name a
  regular file of at most :data:`MAX_XML_BYTES`, which is checked the same
  way; XIncludes within the document (``xpointer`` only, as meshio writes
  them) are always fine;
* every HDF5 file opens with h5py and refers to no other file (the check of
  :func:`auralize.io.hdf5.check_self_contained`, same switch); every dataset
  exists, holds numbers and has as many values as the ``DataItem``'s
  ``Dimensions`` declare, and contiguous data lie within the file;
* a ``Binary`` file is big enough for its ``Seek`` plus the declared values
  (compressed ones are decompressed to count), inline ``XML`` data hold as
  many numbers as declared.

A dataset is also read whole once with h5py (in blocks of at most 64 MiB),
which is what shows damage inside data blocks: the datasets of the grids
that belong to no time step when the file is opened, and those of a time
step just before VTK reads that step (:meth:`XdmfCheck.check_step`), so the
cost is one extra read of each dataset, spread over the steps as they are
read.  Damage raises in h5py; every failure becomes one
:class:`~auralize.errors.FormatError` naming the XDMF file and the heavy
data.  Number types are not compared with the dataset's own type: HDF5
converts between numeric types (dolfinx declares ``UInt`` topology stored
as 64-bit integers).
"""

from __future__ import annotations

import bz2
import contextlib
import math
import os
import stat
import threading
import xml.parsers.expat
import zlib
from collections.abc import Iterator
from dataclasses import KW_ONLY, dataclass, field
from pathlib import Path
from typing import Any, NoReturn
from xml.etree import ElementTree as ET

import numpy as np

from auralize.errors import AuralizeError, FormatError

#: Largest XDMF (or XIncluded) XML file read, in bytes.
MAX_XML_BYTES = 64 * 1024**2
#: Namespaces of XInclude elements (meshio writes the 2003 draft's).
XINCLUDE_NAMESPACES = ("http://www.w3.org/2001/XInclude", "http://www.w3.org/2003/XInclude")
#: Bytes per value of XDMF number types (``NumberType``/``DataType``) by ``Precision``.
_PRECISIONS = {
    "float": (4, 8),
    "int": (1, 2, 4, 8),
    "uint": (1, 2, 4, 8),
    "char": (1,),
    "uchar": (1,),
}
_BLOCK_BYTES = 64 * 1024**2
_MAX_DEPTH = 8


def parse_xml(data: bytes, path: Path, *, kind: str = "XDMF") -> ET.Element:
    """Parse XML bytes into an element tree, refusing entities.

    Expat is driven directly so that any entity declaration (``<!ENTITY``,
    internal or external, parameter or general) and any reference to an
    entity the document does not define (one an external DTD would supply)
    raise :class:`FormatError` before anything is expanded: no entity
    expansion (billion laughs) and no file read through an entity.

    Parameters
    ----------
    data : bytes
        The whole document.
    path : Path
        Where it comes from, for messages.
    kind : str
        What the document is, for messages (``"XDMF"``, ``"XIncluded XML"``).

    Returns
    -------
    xml.etree.ElementTree.Element
        The root element; namespaced tags as ``{namespace}name``.

    Raises
    ------
    FormatError
        An entity declared or used, malformed XML, no root element.

    Examples
    --------
    >>> from pathlib import Path
    >>> parse_xml(b'<Xdmf Version="3.0"><Domain/></Xdmf>', Path("run.xdmf")).get("Version")
    '3.0'
    >>> bomb = b'<!DOCTYPE x [<!ENTITY a "aaaa">]><Xdmf>&a;</Xdmf>'
    >>> parse_xml(bomb, Path("bomb.xdmf"))
    Traceback (most recent call last):
      ...
    auralize.errors.FormatError: bomb.xdmf: the XDMF file declares or uses an XML entity ('a'); ...
    """
    builder = ET.TreeBuilder()
    parser = xml.parsers.expat.ParserCreate(namespace_separator="}")
    parser.buffer_text = True
    parser.SetParamEntityParsing(xml.parsers.expat.XML_PARAM_ENTITY_PARSING_NEVER)

    def name(raw: str) -> str:
        return "{" + raw if "}" in raw else raw

    def refuse(*args: Any) -> NoReturn:
        raise FormatError(
            f"{path}: the {kind} file declares or uses an XML entity ({args[0]!r}); entities "
            f"are refused (they can read other files or expand without bound)"
        )

    parser.StartElementHandler = lambda tag, attrs: builder.start(
        name(tag), {name(k): v for k, v in attrs.items()}
    )
    parser.EndElementHandler = lambda tag: builder.end(name(tag))
    parser.CharacterDataHandler = builder.data
    parser.EntityDeclHandler = refuse
    parser.UnparsedEntityDeclHandler = refuse
    parser.SkippedEntityHandler = refuse
    parser.ExternalEntityRefHandler = refuse
    try:
        parser.Parse(data, True)
        return builder.close()
    except xml.parsers.expat.ExpatError as exc:
        raise FormatError(
            f"{path}: not a valid {kind} file (XML error: {exc}); the file may be truncated"
        ) from exc
    except AssertionError as exc:  # TreeBuilder: no root element
        raise FormatError(f"{path}: not a valid {kind} file (no XML element)") from exc


def read_xml_file(path: Path, kind: str = "XDMF") -> ET.Element:
    """Parse the XML file ``path`` (a regular file of at most :data:`MAX_XML_BYTES`).

    Parameters
    ----------
    path : Path
        The file.
    kind : str
        What the file is, for messages (``"XDMF"``, ``"XIncluded XML"``).

    Returns
    -------
    xml.etree.ElementTree.Element
        The root element (:func:`parse_xml`).

    Raises
    ------
    FormatError
        Not a regular file, larger than :data:`MAX_XML_BYTES`, unreadable, or
        XML that :func:`parse_xml` refuses.

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> xdmf = Path(auralize.__file__).parent / "data/xdmf-timeseries/meshio/out.xdmf"
    >>> read_xml_file(xdmf).tag
    'Xdmf'
    """
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise FormatError(f"{path}: not a regular file; an {kind} file must be one")
        if info.st_size > MAX_XML_BYTES:
            raise FormatError(
                f"{path}: {info.st_size} bytes; {kind} files over {MAX_XML_BYTES // 1024**2} MiB "
                f"are refused (keep heavy data in HDF5 files)"
            )
        with path.open("rb") as fh:
            data = fh.read(MAX_XML_BYTES + 1)
    except OSError as exc:
        raise FormatError(f"{path}: cannot read ({exc})") from exc
    return parse_xml(data, path, kind=kind)


def _local(tag: str) -> tuple[str, str]:
    """``(namespace, local name)`` of an element tag."""
    if tag.startswith("{"):
        ns, _, local = tag[1:].partition("}")
        return ns, local
    return "", tag


@dataclass(frozen=True)
class HeavyData:
    """One HDF5 dataset a ``DataItem`` names.

    Parameters
    ----------
    file : Path
        The HDF5 file (resolved).
    dataset : str
        The dataset's path in it.
    n_values : int or None
        How many values the ``DataItem``'s ``Dimensions`` declare (None: not
        declared).
    time : float or None
        The time value of the temporal-collection step whose grid holds it,
        or None when it belongs to no single step (a shared mesh, a time
        list, a file without time steps).
    text : str
        The ``DataItem``'s text (``file.h5:/path``), for messages.

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> xdmf = Path(auralize.__file__).parent / "data/xdmf-timeseries/meshio/out.xdmf"
    >>> item = check_xdmf(xdmf).items[0]
    >>> item.file.name, item.dataset, item.n_values, item.time
    ('out.h5', '/data2', 4, 0.0)
    """

    file: Path
    dataset: str
    _: KW_ONLY
    n_values: int | None
    time: float | None
    text: str


@dataclass
class XdmfCheck:
    """The checked heavy data of one XDMF file; reads each dataset once, on demand.

    Made by :func:`check_xdmf`.

    Parameters
    ----------
    path : Path
        The XDMF file.
    items : list of HeavyData
        Every HDF5 dataset the file names.

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> xdmf = Path(auralize.__file__).parent / "data/xdmf-timeseries/meshio/out.xdmf"
    >>> plan = check_xdmf(xdmf)
    >>> len(plan.items), sorted({it.time for it in plan.items if it.time is not None})
    (17, [0.0, 0.25, 0.5, 0.75, 1.0])
    """

    path: Path
    items: list[HeavyData] = field(default_factory=list)
    _done: set[tuple[Path, str]] = field(default_factory=set, init=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False, init=False)

    def check_step(self, time: float | None) -> None:
        """Read with h5py every dataset the step at ``time`` needs, once each.

        Parameters
        ----------
        time : float or None
            The step's time value; None (a file without time steps) reads
            every dataset.

        Raises
        ------
        FormatError
            A dataset that cannot be read, or that changed since the file was
            checked; the message names the XDMF file and the dataset.

        Examples
        --------
        >>> from pathlib import Path
        >>> import auralize
        >>> xdmf = Path(auralize.__file__).parent / "data/xdmf-timeseries/meshio/out.xdmf"
        >>> import shutil, tempfile, pathlib
        >>> folder = pathlib.Path(tempfile.mkdtemp())
        >>> for name in ("out.xdmf", "out.h5"):
        ...     _ = shutil.copy(xdmf.with_name(name), folder)
        >>> plan = check_xdmf(folder / "out.xdmf")
        >>> plan.check_step(0.0)  # the datasets of the step at t = 0 s, read whole
        >>> _ = (folder / "out.h5").write_bytes(b"")  # the heavy data lost since
        >>> plan.check_step(0.25)
        Traceback (most recent call last):
          ...
        auralize.errors.FormatError: .../out.xdmf: its heavy-data file .../out.h5 cannot be read ...
        """
        with self._lock:
            todo = [
                it
                for it in self.items
                if (it.file, it.dataset) not in self._done
                and (time is None or it.time is None or math.isclose(it.time, time))
            ]
            for file, group in _by_file(todo).items():
                self._read_all(file, group)

    def _read_all(self, file: Path, items: list[HeavyData]) -> None:
        import h5py

        with _h5_errors(self.path, file):
            size = file.stat().st_size
            with h5py.File(file, "r") as f:
                for it in items:
                    with _h5_errors(self.path, file, it):
                        _check_dataset(self.path, f, it, size)  # changed since opened?
                        ds = f[it.dataset]
                        if ds.ndim == 0 or ds.size == 0:
                            ds[()]
                        else:
                            row = max(1, int(ds.size // ds.shape[0]) * ds.dtype.itemsize)
                            step = max(1, _BLOCK_BYTES // row)
                            for start in range(0, ds.shape[0], step):
                                ds[start : start + step]
                    self._done.add((it.file, it.dataset))


def _by_file(items: list[HeavyData]) -> dict[Path, list[HeavyData]]:
    out: dict[Path, list[HeavyData]] = {}
    for it in items:
        out.setdefault(it.file, []).append(it)
    return out


@contextlib.contextmanager
def _h5_errors(xdmf: Path, file: Path, item: HeavyData | None = None) -> Iterator[None]:
    """Turn what h5py raises on a damaged file into one line naming the file (and item)."""
    try:
        yield
    except AuralizeError:
        raise
    except (OSError, KeyError, ValueError, RuntimeError, TypeError) as exc:
        text = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
        if item is None:
            raise FormatError(
                f"{xdmf}: its heavy-data file {file} cannot be read as HDF5 ({text}); the file "
                f"is truncated or corrupt"
            ) from exc
        raise FormatError(
            f"{xdmf}: heavy data {item.text!r} cannot be read from {file} ({text}); the HDF5 "
            f"file is truncated or corrupt"
        ) from exc


def check_xdmf(path: Path) -> XdmfCheck:
    """Check the XDMF file ``path`` and its heavy data (see the module notes).

    Parameters
    ----------
    path : Path
        The ``.xdmf``/``.xmf`` file.

    Returns
    -------
    XdmfCheck
        Its :meth:`~XdmfCheck.check_step` the reader calls before VTK reads a
        step; the datasets that belong to no step are read here already.

    Raises
    ------
    FormatError
        Not XDMF, entities, a reference outside the folder or an XInclude of
        another file (unless allowed), damaged or missing heavy data.

    Examples
    --------
    >>> from pathlib import Path
    >>> import auralize
    >>> xdmf = Path(auralize.__file__).parent / "data/xdmf-timeseries/meshio/out.xdmf"
    >>> plan = check_xdmf(xdmf)
    >>> plan.path.name, {it.file.name for it in plan.items}
    ('out.xdmf', {'out.h5'})
    """
    from auralize.io.hdf5 import external_data_allowed

    root = read_xml_file(path)
    if _local(root.tag)[1] != "Xdmf":
        raise FormatError(f"{path}: not an XDMF file (root element <{root.tag}>, expected <Xdmf>)")
    _refuse_checkpoint(root, path)
    walker = _Walker(path, allow=external_data_allowed())
    walker.walk(root, None, path, 0)
    plan = XdmfCheck(path, walker.items)
    _check_headers(plan)
    with plan._lock:
        for file, group in _by_file([it for it in plan.items if it.time is None]).items():
            plan._read_all(file, group)
    return plan


def _refuse_checkpoint(root: ET.Element, path: Path) -> None:
    """Refuse a dolfin ``write_checkpoint`` file whose functions are all coefficients.

    Such a file stores each function as ``<Attribute ItemType="FiniteElementFunction">``
    (cell dofs and coefficient vectors, not values at points), which VTK's XDMF
    reader skips: the file would open with no fields.
    """
    attributes = [e for e in root.iter() if _local(e.tag)[1] == "Attribute"]
    fe = [e for e in attributes if e.get("ItemType") == "FiniteElementFunction"]
    if not fe or len(fe) < len(attributes):
        return
    names = ", ".join(sorted({e.get("Name", "?") for e in fe}))
    kinds = ", ".join(
        sorted({f"{e.get('ElementFamily', '?')} degree {e.get('ElementDegree', '?')}" for e in fe})
    )
    raise FormatError(
        f"{path}: a checkpoint written by dolfin's XDMFFile.write_checkpoint; its functions "
        f"({names}) hold finite-element coefficients ({kinds}), not values at points, which "
        f"VTK's XDMF reader cannot read; write them with XDMFFile.write_function (dolfinx) or "
        f"XDMFFile.write (legacy dolfin) and open that file"
    )


class _Walker:
    """Collects the heavy data of an element tree; checks Binary, XML and XInclude items."""

    def __init__(self, xdmf: Path, *, allow: bool) -> None:
        self.xdmf = xdmf
        self.folder = xdmf.parent.resolve()
        self.allow = allow
        self.items: list[HeavyData] = []
        self.seen_includes: set[Path] = {xdmf.resolve()}

    def inside(self, target: Path, what: str) -> Path:
        """``target`` resolved; refused outside the XDMF's folder unless allowed."""
        resolved = target.resolve()
        if not self.allow and not resolved.is_relative_to(self.folder):
            from auralize.io.hdf5 import refused_external

            raise refused_external(
                self.xdmf,
                f"{what} reads {resolved}, outside the XDMF file's folder {self.folder}",
            )
        return resolved

    def walk(self, elem: ET.Element, time: float | None, doc: Path, depth: int) -> None:
        ns, tag = _local(elem.tag)
        if ns in XINCLUDE_NAMESPACES:
            if tag == "include":
                self.include(elem, time, doc, depth)
            for child in elem:
                self.walk(child, time, doc, depth)
            return
        if tag == "DataItem":
            children = [c for c in elem if _local(c.tag)[1] == "DataItem"]
            if not children and "Reference" not in elem.attrib:
                self.data_item(elem, time)
        temporal = (
            tag == "Grid"
            and elem.get("GridType", "").lower() == "collection"
            and elem.get("CollectionType", "").lower() == "temporal"
        )
        for child in elem:
            child_time = time
            if temporal and _local(child.tag)[1] == "Grid":
                child_time = _step_time(child)
            self.walk(child, child_time, doc, depth)

    def include(self, elem: ET.Element, time: float | None, doc: Path, depth: int) -> None:
        href = elem.get("href", "").strip()
        if not href:
            return  # within this document (xpointer only)
        target = (doc.parent / href) if not os.path.isabs(href) else Path(href)
        if target.resolve() == doc.resolve():
            return
        if not self.allow:
            from auralize.io.hdf5 import refused_external

            raise refused_external(self.xdmf, f"an XInclude reads {href!r}")
        if depth >= _MAX_DEPTH or target.resolve() in self.seen_includes:
            raise FormatError(
                f"{self.xdmf}: the XInclude of {href!r} nests more than {_MAX_DEPTH} deep or "
                f"includes itself"
            )
        if elem.get("parse", "xml").strip().lower() == "text":
            try:
                info = target.stat()
            except OSError as exc:
                raise FormatError(f"{self.xdmf}: XInclude {href!r}: {exc}") from exc
            if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_XML_BYTES:
                raise FormatError(
                    f"{self.xdmf}: XInclude {href!r} is not a regular file of at most "
                    f"{MAX_XML_BYTES // 1024**2} MiB"
                )
            return
        self.seen_includes.add(target.resolve())
        self.walk(read_xml_file(target, "XIncluded XML"), time, target, depth + 1)

    def data_item(self, elem: ET.Element, time: float | None) -> None:
        fmt = elem.get("Format", "XML").strip().lower()
        text = (elem.text or "").strip()
        n_values = _n_values(self.xdmf, elem)
        if fmt == "hdf":
            file_name, sep, dataset = text.partition(":")
            if not sep or not file_name or not dataset:
                raise FormatError(
                    f"{self.xdmf}: HDF DataItem {text[:80]!r} must read 'file.h5:/path/to/dataset'"
                )
            where = self.inside(self.xdmf.parent / file_name, f"DataItem {text!r}")
            self.items.append(HeavyData(where, dataset, n_values=n_values, time=time, text=text))
        elif fmt == "binary":
            self.binary(elem, text, n_values)
        elif fmt == "xml":
            _check_inline(self.xdmf, text, n_values)
        else:
            raise FormatError(
                f"{self.xdmf}: DataItem Format={elem.get('Format')!r} is not supported; valid "
                f"are 'XML', 'HDF' and 'Binary'"
            )

    def binary(self, elem: ET.Element, text: str, n_values: int | None) -> None:
        where = self.inside(self.xdmf.parent / text, f"Binary DataItem {text!r}")
        if n_values is None:
            raise FormatError(f"{self.xdmf}: Binary DataItem {text!r} has no Dimensions")
        need = n_values * _precision(self.xdmf, elem)
        try:
            seek = int(elem.get("Seek", "0"))
        except ValueError:
            seek = -1
        if seek < 0:
            raise FormatError(
                f"{self.xdmf}: Binary DataItem {text!r} has Seek={elem.get('Seek')!r}"
            )
        compression = elem.get("Compression", "Raw").strip().lower()
        try:
            info = where.stat()
            if not stat.S_ISREG(info.st_mode):
                raise FormatError(f"{self.xdmf}: Binary DataItem {text!r} is not a regular file")
            if compression == "raw":
                have = max(0, info.st_size - seek)
            elif compression in ("zlib", "bzip2"):
                have = _decompressed_size(where, seek, compression, need)
            else:
                raise FormatError(
                    f"{self.xdmf}: Binary DataItem {text!r} has Compression={compression!r}; "
                    f"valid are 'Raw', 'Zlib' and 'BZip2'"
                )
        except OSError as exc:
            raise FormatError(f"{self.xdmf}: Binary DataItem {text!r}: {exc}") from exc
        except (zlib.error, ValueError) as exc:
            raise FormatError(
                f"{self.xdmf}: Binary DataItem {text!r} does not decompress ({exc})"
            ) from exc
        if have < need:
            raise FormatError(
                f"{self.xdmf}: Binary DataItem {text!r} holds {have} bytes after Seek={seek}, "
                f"but its Dimensions and Precision need {need}; the file is truncated"
            )


def _step_time(grid: ET.Element) -> float | None:
    """The ``<Time Value=...>`` of a temporal collection's child grid (None if not single)."""
    for child in grid:
        if _local(child.tag)[1] == "Time":
            if child.get("TimeType", "Single").lower() != "single":
                return None
            try:
                return float(child.get("Value", ""))
            except ValueError:
                return None
    return None


def _n_values(xdmf: Path, elem: ET.Element) -> int | None:
    dims = elem.get("Dimensions")
    if dims is None:
        return None
    try:
        sizes = [int(d) for d in dims.split()]
    except ValueError:
        sizes = []
    if not sizes or min(sizes) < 0:
        raise FormatError(
            f"{xdmf}: DataItem Dimensions={dims!r}; expected whole numbers such as '729 3'"
        )
    return math.prod(sizes)


def _precision(xdmf: Path, elem: ET.Element) -> int:
    kind = (elem.get("NumberType") or elem.get("DataType") or "Float").strip().lower()
    if kind not in _PRECISIONS:
        raise FormatError(
            f"{xdmf}: DataItem NumberType {kind!r}; valid are Float, Int, UInt, Char, UChar"
        )
    default = 1 if kind in ("char", "uchar") else 4
    try:
        prec = int(elem.get("Precision", default))
    except ValueError:
        prec = -1
    if prec not in _PRECISIONS[kind]:
        raise FormatError(
            f"{xdmf}: DataItem {kind} Precision={elem.get('Precision')!r}; valid are "
            f"{', '.join(map(str, _PRECISIONS[kind]))}"
        )
    return prec


def _check_inline(xdmf: Path, text: str, n_values: int | None) -> None:
    values = text.split()
    if n_values is not None and len(values) < n_values:
        raise FormatError(
            f"{xdmf}: an XML DataItem holds {len(values)} values, but its Dimensions declare "
            f"{n_values}"
        )
    try:
        np.asarray(values, dtype=np.float64)
    except ValueError as exc:
        raise FormatError(
            f"{xdmf}: an XML DataItem holds something other than numbers ({exc})"
        ) from None


def _decompressed_size(path: Path, seek: int, compression: str, need: int) -> int:
    """Bytes a compressed Binary file decompresses to, counted up to ``need``."""
    engine: Any = zlib.decompressobj() if compression == "zlib" else bz2.BZ2Decompressor()
    total = 0
    with path.open("rb") as fh:
        fh.seek(seek)
        while total < need:
            chunk = fh.read(1 << 20)
            if not chunk:
                break
            if compression == "zlib":
                total += len(engine.decompress(chunk, need - total + 1))
                while engine.unconsumed_tail and total < need:
                    total += len(engine.decompress(engine.unconsumed_tail, need - total + 1))
            else:
                total += len(engine.decompress(chunk, max_length=need - total + 1))
                while not engine.needs_input and not engine.eof and total < need:
                    total += len(engine.decompress(b"", max_length=need - total + 1))
    return total


def _check_headers(plan: XdmfCheck) -> None:
    """Open every HDF5 file and dataset: no links out, numbers, declared sizes, data in the file."""
    import h5py

    from auralize.io.hdf5 import check_self_contained

    for file, items in _by_file(plan.items).items():
        with _h5_errors(plan.path, file):
            if not file.is_file():
                raise FormatError(
                    f"{plan.path}: heavy data {items[0].text!r}: the HDF5 file {file} does not "
                    f"exist or is not a regular file"
                )
            size = file.stat().st_size
            with h5py.File(file, "r") as f:
                check_self_contained(f, f"{plan.path}: its heavy-data file {file}")
                for it in items:
                    with _h5_errors(plan.path, file, it):
                        _check_dataset(plan.path, f, it, size)


def _check_dataset(xdmf: Path, f: Any, it: HeavyData, file_size: int) -> None:
    import h5py

    from auralize.io.hdf5 import external_data_allowed

    parts = [p for p in it.dataset.split("/") if p]
    for k in range(1, len(parts) + 1 if external_data_allowed() else 1):  # else: none in f
        link = f.get("/" + "/".join(parts[:k]), getlink=True)
        if isinstance(link, h5py.ExternalLink):  # VTK's HDF5 does not follow them
            raise FormatError(
                f"{xdmf}: heavy data {it.text!r} goes through an external link to "
                f"{link.filename}:{link.path}, which VTK's XDMF reader cannot follow; name "
                f"that file in the DataItem instead"
            )
    obj = f.get(it.dataset)
    if not isinstance(obj, h5py.Dataset):
        what = "does not exist" if obj is None else "is a group, not a dataset"
        raise FormatError(f"{xdmf}: heavy data {it.text!r}: {it.dataset} {what} in {it.file}")
    if obj.dtype.kind not in "fiub":
        raise FormatError(
            f"{xdmf}: heavy data {it.text!r} has dtype {obj.dtype}; XDMF reads numbers"
        )
    if it.n_values is not None and obj.size != it.n_values:
        raise FormatError(
            f"{xdmf}: heavy data {it.text!r} holds {obj.size} values (shape {obj.shape}), but "
            f"the DataItem's Dimensions declare {it.n_values}"
        )
    offset = obj.id.get_offset()
    if offset is not None:  # contiguous data, in the file holding the dataset (links followed)
        holder = Path(obj.file.filename)
        size = file_size if holder == it.file else holder.stat().st_size
        if offset + obj.id.get_storage_size() > size:
            raise FormatError(
                f"{xdmf}: heavy data {it.text!r} lies past the end of {holder} ({size} bytes); "
                f"the HDF5 file is truncated"
            )
