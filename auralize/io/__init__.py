"""Readers and writers of volume time series.

:func:`open_volume` picks a reader by what the file holds and returns a lazy
:class:`~auralize.volume.TimeVolume` (frames are read one time step at a
time); :func:`save_volume` writes one, atomically.

Each reader is a backend (:mod:`auralize.io.backends`) with a cheap content
check: magic bytes, a header, the root element of an XML file, the root of
an HDF5 file.  The most specific content wins (an Exodus II file is a netCDF
file, a VTKHDF file an HDF5 file: each goes to its own reader whatever it is
called); the file name ending only breaks ties and decides when no content
check applies (an empty ``.foam``, a ``.q`` solution, a damaged file).  The
volume's ``attrs["reader"]`` names the backend.  Packages add backends through
the entry-point group ``auralize.readers``.

==================  ==========================================  ==========================================
backend             told by (content; then endings)             reader
==================  ==========================================  ==========================================
``exodus``          netCDF (classic or HDF5) with ``num_dim``,  VTK's Exodus II reader, whatever the
                    ``coordx``, ``connect1``, ``api_version``;  ending (:func:`auralize.io.vtk_readers.
                    ``.exo``, ``.e``, ``.ex2``                  read_with_pyvista` for ``.exo`` ...)
``vtkhdf``          HDF5 with a ``/VTKHDF`` group;              :func:`auralize.io.paraview.read_vtkhdf`
                    ``.vtkhdf``
``auralize-hdf5``   HDF5 with root attribute                    :func:`auralize.io.hdf5.read_hdf5`
                    ``auralize_format``; ``.h5``, ``.hdf5``
``fluent-cff``      HDF5 with ``/meshes`` and ``/settings``;    :func:`auralize.io.vtk_readers.read_with_pyvista`
                    ``.cas.h5`` (its ``.dat.h5`` beside it)
``openfoam``        a folder, a ``FoamFile`` controlDict;       :func:`auralize.io.openfoam.read_openfoam`
                    ``.foam``
``pvd``             ``<VTKFile type="Collection">``; ``.pvd``   :func:`auralize.io.paraview.read_pvd`
``series``          JSON ``{"file-series-version": ...}``;      :func:`auralize.io.paraview.read_series`
                    ``.series``
``vtk``             ``<VTKFile type="ImageData">`` ... or       :func:`auralize.io.paraview.read_mesh_file`
                    legacy ``# vtk DataFile``; ``.vti``,        (one step; a ``.vtm`` merged); read as the
                    ``.vts``, ``.vtr``, ``.vtu``, ``.vtm`` ...  type it says whatever its ending
``xdmf``            ``<Xdmf>`` root; ``.xdmf``, ``.xmf``        :func:`auralize.io.vtk_readers.read_xdmf`
``ensight``         text with ``FORMAT`` / ``type: ensight``;   :func:`auralize.io.vtk_readers.read_ensight`
                    ``.case``
``vtk-amr``         ``<VTKFile type="vtkOverlappingAMR">``;     :func:`auralize.io.vtk_readers.read_amr`
                    ``.vthb``, ``.vth``
``netcdf``          ``CDF`` magic (CDF-1/2); HDF5 with          :func:`auralize.io.netcdf.read_netcdf`
                    ``_NCProperties`` or dimension scales;
                    ``.nc``, ``.nc4``, ``.cdf``
``plot3d``          binary grid whose header dimensions give    :func:`auralize.io.vtk_readers.read_plot3d`
                    its size; ``.xyz``, ``.x``, ``.grd``,
                    ``.q``, ``*xyz*.bin`` + ``*q*.bin``
``hdf5``            any other HDF5 (the signature), read with   :func:`auralize.io.hdf5.read_generic_hdf5`
                    ``fields={name: "/dataset/path"}``
                    (``--field NAME=/dataset/path``)
``pyvista``         last: any ending ``pyvista.get_reader``     :func:`auralize.io.vtk_readers.read_with_pyvista`
                    knows (CGNS, FLUENT ``.cas``, Tecplot ...)
==================  ==========================================  ==========================================

Uniform grids keep their points, and so do meshes whose points form an evenly
spaced axis-aligned lattice (OpenFOAM ``blockMesh`` boxes, 2-D slabs one cell
thick).  Curvilinear, rectilinear (unevenly spaced) and unstructured meshes
are sampled onto a uniform grid covering their bounds, with a
:class:`ResampledWarning`; grid points outside the mesh are never
extrapolated: they are NaN in the frames and False in
:attr:`TimeVolume.valid <auralize.volume.TimeVolume.valid>`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Literal

from auralize.errors import FormatError, ParameterError
from auralize.io._common import FieldsArg, ResampledWarning, require_exists
from auralize.io.backends import HDF5_SUFFIXES
from auralize.io.resample import ResolutionArg, check_resolution
from auralize.volume import TimeVolume

__all__ = [
    "HDF5_SUFFIXES",
    "READ_SUFFIXES",
    "WRITE_SUFFIXES",
    "ResampledWarning",
    "field_map",
    "open_volume",
    "save_volume",
]

#: Every file name ending :func:`open_volume` knows (plus OpenFOAM case folders).
READ_SUFFIXES = (
    *HDF5_SUFFIXES,
    ".pvd",
    ".series",
    ".foam",
    ".vti",
    ".vts",
    ".vtr",
    ".vtu",
    ".vtp",
    ".vtk",
    ".vtm",
    ".pvti",
    ".pvts",
    ".pvtr",
    ".pvtu",
    ".xdmf",
    ".xmf",
    ".case",
    ".xyz",
    ".x",
    ".grd",
    ".q",
    ".vthb",
    ".vth",
    ".nc",
    ".nc4",
    ".cdf",
    ".exo",
    ".e",
    ".ex2",
    ".exii",
    ".hierarchy",
)
#: File name endings :func:`save_volume` writes.
WRITE_SUFFIXES = (".h5", ".hdf5", ".pvd", ".vtkhdf")


def open_volume(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg | Mapping[str, object] = None,
    resolution: ResolutionArg = None,
    name_map: Mapping[str, str] | None = None,
    nan: Literal["mask", "error"] = "mask",
    time_dim: str | None = None,
    axis_scale: float | tuple[float, float, float] | None = None,
    box: tuple[float, float, float, float, float, float] | None = None,
    curvilinear: Literal["native", "resample"] | None = None,
) -> TimeVolume:
    """Open a volume time series, reading frames lazily.

    Parameters
    ----------
    path : path-like
        A file (kind chosen by content, then by suffix: see the module
        docstring) or an OpenFOAM case folder.
    fields : None, str, sequence of str or mapping, optional
        Which arrays become fields: ``None`` all scalar and 3-component arrays;
        a name or list of names; or ``{volume name: name in the file}``.  For
        an HDF5 file that is not an auralize volume file, a mapping
        ``{volume name: "/dataset/path"}`` reads those datasets, with optional
        keys ``"time"``, ``"origin"``, ``"spacing"`` (dataset path,
        ``"/object@attribute"`` or a value); see
        :func:`auralize.io.hdf5.read_generic_hdf5`.
    resolution : None, int or (int, int, int), optional
        Grid for meshes that are not uniform: ``None`` chooses the voxel from
        the mesh's own cell sizes inside ``box`` (their 20th percentile, so
        the finest features get several voxels; at most 4 M grid points, 2 M
        for a flat mesh, and half the free memory); an int is the number of
        points along the longest axis; a tuple is ``(nx, ny, nz)``.  For
        uniform inputs, an int caps the points per axis and a tuple sets them;
        either resamples (trilinearly) only when the grid would change.
    name_map : mapping of str to str, optional
        ``{name in the file: volume name}``, e.g. ``{"U": "velocity", "p":
        "pressure"}``; names missing from the file are ignored.
    nan : {"mask", "error"}
        What NaN, fill values and masked cells are: ``"mask"`` keeps them as
        NaN (no-data) in the frames; ``"error"`` makes reading a frame that
        holds any at a valid point raise :class:`DataError` naming the file,
        field and step.
    time_dim : str, optional
        Name of the time dimension of a netCDF file whose time is not found by
        CF's ``axis="T"``, ``units="... since ..."`` or a common name.
    axis_scale : float or (float, float, float), optional
        Metres per file unit along x, y and z, for grids in other units (km,
        cm, or to override a netCDF reader's own conversion of degrees and
        pressure levels).
    box : (xmin, xmax, ymin, ymax, zmin, zmax), optional
        Region of interest in metres (after ``axis_scale``): only grid points
        inside it are kept (of a curvilinear grid, the smallest index block
        whose cells cover the box), and a mesh's resolution is chosen from its
        cells inside it.
    curvilinear : {"native", "resample"}, optional
        How a structured curvilinear grid (PLOT3D, ``vtkStructuredGrid`` in
        ``.vts``/``.vtk``/``.vtm``/``.pvd``) is read: ``"native"`` keeps its
        points (``TimeVolume.coords``; derivatives by its metric terms,
        :mod:`auralize.curvilinear`), ``"resample"`` puts it on a uniform grid
        as any other mesh.  ``None``: the mode in force
        (:func:`auralize.io.options.curvilinear_mode`, the command line's
        ``--resample``), by default ``"native"``.  A ``resolution`` resamples
        it as well (it chooses a uniform grid); a ``box`` keeps it native,
        cropped to the smallest index block whose cells cover the box
        (:func:`auralize.io.options.index_block`).

    Returns
    -------
    TimeVolume
        ``source`` is ``str(path)``; ``attrs["reader"]`` names the backend that
        read it; no frame beyond what is needed to learn the grid has been read.

    Raises
    ------
    MissingFileError
        ``path`` does not exist (a :class:`FileNotFoundError`).
    FormatError
        Unknown kind, corrupt or truncated file, unsupported version, missing
        metadata.
    FieldError
        A requested field is not in the file.
    DataError
        Bad shapes, times not strictly increasing, fields that disagree, a
        ``box`` that holds no grid point.
    ParameterError
        Bad ``fields=``, ``resolution=``, ``name_map=``, ``nan=``,
        ``time_dim=``, ``axis_scale=``, ``box=`` or ``curvilinear=``.
    ResourceError
        The grid a mesh would be resampled onto does not fit in memory.
    MissingDependencyError
        A mesh file needs pyvista, which is not installed.

    Warns
    -----
    ResampledWarning
        When the data was interpolated onto a new uniform grid.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"rho": np.ones((3, 2, 2, 2))}, times=[0, 0.1, 0.2])
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "rho.h5"
    >>> save_volume(vol, f)
    >>> again = open_volume(f)
    >>> again.field_names, again.times.tolist()
    (['rho'], [0.0, 0.1, 0.2])
    """
    if nan not in NAN_POLICIES:
        raise ParameterError(f"{path}: nan={nan!r}; valid are {', '.join(NAN_POLICIES)}")
    from auralize.io.options import (
        ReadOptions,
        check_axis_scale,
        check_box,
        check_curvilinear,
        finish,
        reading,
    )

    src = str(path)
    if time_dim is not None and (not isinstance(time_dim, str) or not time_dim.strip()):
        raise ParameterError(f"{src}: time_dim={time_dim!r} is not a dimension name")
    options = ReadOptions(
        time_dim=time_dim,
        axis_scale=check_axis_scale(axis_scale, source=src),
        box=check_box(box, source=src),
        curvilinear=check_curvilinear(curvilinear, source=src),
    )
    with reading(options):
        volume = _open(path, fields=fields, resolution=resolution, name_map=name_map)
    if time_dim is not None and volume.attrs.get("time_dim") != time_dim:
        raise ParameterError(
            f"{src}: time_dim={time_dim!r} (--time-dim) names a netCDF time dimension; this "
            f"file is read by another reader, which finds its times itself"
        )
    volume = finish(volume, options)
    volume.check_finite = nan == "error"
    return volume


#: What ``nan=`` may be.
NAN_POLICIES = ("mask", "error")


def _open(
    path: str | os.PathLike[str],
    *,
    fields: FieldsArg | Mapping[str, object],
    resolution: ResolutionArg,
    name_map: Mapping[str, str] | None,
) -> TimeVolume:
    from auralize.io.backends import ENTRY_POINT_GROUP, choose

    p = Path(path).expanduser()
    require_exists(p)
    resolution = check_resolution(resolution, source=str(p))
    backend = choose(p)
    if backend is None:
        from auralize.io.foreign import explain

        known = explain(p)
        if known:
            raise FormatError(known)
        suffix = p.suffix.lower()
        raise FormatError(
            f"{p}: unknown file kind {suffix or '(no suffix)'!r} (no reader recognises its "
            f"content); auralize reads {', '.join(READ_SUFFIXES)} files, OpenFOAM case folders, "
            f"every kind pyvista.get_reader opens and those of reader plugins (entry points "
            f"{ENTRY_POINT_GROUP!r}); convert the data to one of them, e.g. in ParaView "
            f"(File > Save Data as .pvd/.vti or VTKHDF) or with meshio "
            f"('meshio convert {p.name} {p.stem}.vtu')"
        )
    volume = backend.open(p, fields=fields, resolution=resolution, name_map=name_map)
    volume.attrs["reader"] = backend.name
    return volume


def _not_a_volume_message(path: Path) -> str:
    from auralize.io.backends import not_a_volume_message

    return not_a_volume_message(path)


def save_volume(
    volume: TimeVolume,
    path: str | os.PathLike[str],
    *,
    compression: Literal["gzip"] | None = None,
) -> None:
    """Write a volume, atomically, in the format its suffix names.

    Parameters
    ----------
    volume : TimeVolume
        The volume; frames are read one step at a time.  NaN (no-data) is written
        as NaN, and the valid-point mask as /valid in HDF5; a volume opened with
        ``nan="error"`` refuses frames holding NaN/Inf at valid points.  Every
        format holds a uniform grid: a curvilinear volume is resampled onto one
        (:func:`auralize.io._mesh.resample_curvilinear`, with a
        :class:`ResampledWarning`).
    path : path-like
        ``.h5``/``.hdf5``: auralize HDF5 volume file (format v1), one time
        step per chunk.  ``.pvd``: ParaView collection plus one ``.vti`` per
        step in the sibling folder ``<stem>_data/``.  ``.vtkhdf``: one temporal
        VTKHDF ImageData file (:mod:`auralize.io.vtkhdf_write`; uncompressed).
    compression : {None, "gzip"}
        Compress the data (HDF5 gzip with shuffle; VTK zlib in ``.vti``).

    Raises
    ------
    FormatError
        Unknown suffix.
    ParameterError
        ``compression`` is neither None nor ``"gzip"``.
    DataError
        A frame holds NaN/Inf at a valid point and the volume checks (``check_finite``),
        or a field's name cannot name an HDF5 dataset; nothing is written.
    OutputError
        The folder cannot be written, the disk has too little free space
        (refused before writing) or a write failed; nothing is left behind.
        :class:`~auralize.errors.OutputExistsError` when a ``.pvd``'s data
        folder exists and auralize did not write it.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from auralize.volume import TimeVolume
    >>> vol = TimeVolume.from_arrays({"rho": np.ones((2, 2, 2, 2))}, times=[0, 1])
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "rho.pvd"
    >>> save_volume(vol, out)
    >>> sorted(p.name for p in out.parent.rglob("*.vt*"))
    ['rho_0000.vti', 'rho_0001.vti']
    """
    from auralize.io import hdf5, paraview

    p = Path(path).expanduser()
    suffix = p.suffix.lower()
    if volume.coords is not None and suffix in (".h5", ".hdf5", ".pvd", ".vtkhdf"):
        # these formats hold uniform grids: a curvilinear one is resampled (and says so)
        from auralize.io._mesh import resample_curvilinear

        volume = resample_curvilinear(volume)
    if suffix in (".h5", ".hdf5"):
        hdf5.write_hdf5(volume, p, compression=compression)
    elif suffix == ".pvd":
        paraview.write_pvd(volume, p, compression=compression)
    elif suffix == ".vtkhdf":
        from auralize.io.vtkhdf_write import write_volume_vtkhdf

        write_volume_vtkhdf(volume, p)
    else:
        raise FormatError(
            f"{p}: cannot write {suffix or '(no suffix)'!r} files; save_volume writes "
            f"{', '.join(WRITE_SUFFIXES)}"
        )


def field_map(items: list[str] | None) -> dict[str, str] | None:
    """``--field NAME=/DATASET`` items of the command line as a ``fields=`` mapping.

    Parameters
    ----------
    items : list of str or None
        ``NAME=/hdf5/dataset/path`` items (also ``time=``, ``origin=``,
        ``spacing=``: see :func:`auralize.io.hdf5.read_generic_hdf5`); spaces
        around the names are dropped.

    Returns
    -------
    dict of str to str or None
        ``{NAME: /DATASET}`` for :func:`open_volume`'s ``fields=``; None when
        no item is given.

    Raises
    ------
    ParameterError
        An item without ``=``.

    Examples
    --------
    >>> field_map(["rho=/run/density", "time = /run/t"])
    {'rho': '/run/density', 'time': '/run/t'}
    >>> field_map([]) is None
    True
    """
    if not items:
        return None
    out = {}
    for it in items:
        if "=" not in it:
            raise ParameterError(f"--field takes NAME=/hdf5/path, got {it!r}")
        k, v = it.split("=", 1)
        out[k.strip()] = v.strip()
    return out
