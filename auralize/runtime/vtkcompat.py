"""VTK and pyvista names that moved within the releases auralize supports (pyproject's bounds).

VTK 9.6 moved the static cell-type queries from ``vtkCellTypes`` to
``vtkCellTypeUtilities`` and renamed the block access of ``vtkOverlappingAMR``
(``GetNumberOfDataSets(level)`` to ``GetNumberOfBlocks(level)``,
``GetDataSet(level, index)`` to ``GetDataSetAsImageData(level, index)``); it
deprecates the old names (a warning), and releases before it have only those.
pyvista 0.47 added ``DataSet.distinct_cell_types``.  Each helper here takes the new
name where it exists and the old one otherwise, so the callers read the same on
every supported release.

>>> import pyvista as pv
>>> cell_type_utilities().GetDimension(pv.CellType.TETRA)
3
>>> sorted(distinct_cell_types(pv.Sphere()))
[5]
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any


def cell_type_utilities() -> Any:
    """The class of VTK's static cell-type queries (``GetDimension``,
    ``GetClassNameFromTypeId``): ``vtkCellTypeUtilities`` (VTK >= 9.6), else
    ``vtkCellTypes``."""
    from vtkmodules import vtkCommonDataModel as dm

    return getattr(dm, "vtkCellTypeUtilities", None) or dm.vtkCellTypes


def distinct_cell_types(mesh: Any) -> set[int]:
    """The VTK cell types (ints) among the cells of a pyvista data set: its
    ``distinct_cell_types`` (pyvista >= 0.47), else VTK's ``GetCellTypes``."""
    types = getattr(mesh, "distinct_cell_types", None)
    if types is not None:
        return {int(t) for t in types}
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonDataModel import vtkCellTypes

    found = vtkCellTypes()
    mesh.GetCellTypes(found)
    return {int(t) for t in vtk_to_numpy(found.GetCellTypesArray())}


def amr_block_count(amr: Any, level: int) -> int:
    """Number of blocks (data sets) of ``level`` of a ``vtkOverlappingAMR``."""
    if hasattr(amr, "GetNumberOfBlocks"):
        return int(amr.GetNumberOfBlocks(level))
    return int(amr.GetNumberOfDataSets(level))


def amr_block(amr: Any, level: int, index: int) -> Any:
    """Block ``index`` of ``level`` of a ``vtkOverlappingAMR`` as a ``vtkImageData``
    (``None`` where the block is absent)."""
    if hasattr(amr, "GetDataSetAsImageData"):
        return amr.GetDataSetAsImageData(level, index)
    return amr.GetDataSet(level, index)


def amr_initialize(amr: Any, blocks_per_level: list[int]) -> None:
    """Initialize a ``vtkOverlappingAMR`` with ``blocks_per_level[level]`` blocks per level."""
    try:
        amr.Initialize(list(blocks_per_level))
    except TypeError:  # before VTK 9.6: the number of levels first
        amr.Initialize(len(blocks_per_level), list(blocks_per_level))


def dataset_surface(mesh: Any) -> Any:
    """The outer surface of a pyvista data set by ``vtkDataSetSurfaceFilter`` (pyvista's
    ``extract_surface(algorithm="dataset_surface")``; before pyvista 0.47, which has no
    ``algorithm``, ``extract_surface()`` always used that filter)."""
    import inspect

    if "algorithm" in inspect.signature(type(mesh).extract_surface).parameters:
        return mesh.extract_surface(algorithm="dataset_surface")
    return mesh.extract_surface()


@contextlib.contextmanager
def c_locale_kept() -> Iterator[None]:
    """Put the C library's locale back as it was when the block started.

    VTK's legacy reader and writer (which its marshalling uses) leave the process's
    locale at ``"C"`` when they finish in VTK 9.4 and 9.5 (not in 9.7), which turns
    Python's default text encoding to ASCII for every later ``open`` without one.
    """
    import locale

    saved = locale.setlocale(locale.LC_ALL)
    try:
        yield
    finally:
        if locale.setlocale(locale.LC_ALL) != saved:
            locale.setlocale(locale.LC_ALL, saved)
