"""Kinds read through VTK that earlier versions missed or misread: VTK 5's
hierarchical box ``.vtm``, Enzo outputs, and dolfin checkpoints (refused in one
line that names the writer to use instead)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from auralize.errors import AuralizeError, FormatError
from auralize.io import ResampledWarning, open_volume


def _amr_file(folder: Path) -> Path:
    """A two-level AMR file written by VTK, then relabelled as VTK 5 wrote it."""
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkAMRBox, vtkOverlappingAMR, vtkUniformGrid
    from vtkmodules.vtkIOXML import vtkXMLUniformGridAMRWriter

    from auralize.runtime.vtkcompat import amr_initialize

    amr = vtkOverlappingAMR()
    amr_initialize(amr, [1, 1])
    amr.SetOrigin([0.0, 0.0, 0.0])
    for level, h in enumerate((1.0, 0.5)):
        grid = vtkUniformGrid()
        grid.SetOrigin(0, 0, 0)
        grid.SetSpacing(h, h, h)
        grid.SetDimensions(5, 5, 5)
        arr = numpy_to_vtk(np.arange(64, dtype=float) + 100 * level, deep=True)
        arr.SetName("rho")
        grid.GetCellData().AddArray(arr)
        amr.SetSpacing(level, [h, h, h])
        amr.SetAMRBox(level, 0, vtkAMRBox([0, 0, 0], [3, 3, 3]))
        amr.SetDataSet(level, 0, grid)
    amr.SetRefinementRatio(0, 2)
    from vtkmodules.vtkCommonDataModel import vtkAMRUtilities as utils

    utils.BlankCells(amr)
    writer = vtkXMLUniformGridAMRWriter()
    writer.SetFileName(str(folder / "a.vthb"))
    writer.SetInputData(amr)
    writer.Write()
    text = (folder / "a.vthb").read_text()
    old = folder / "old.vtm"
    old.write_text(text.replace("vtkOverlappingAMR", "vtkHierarchicalBoxDataSet"))
    return old


def test_a_vtk5_hierarchical_box_vtm_is_read_as_amr(tmp_path: Path) -> None:
    with pytest.warns(ResampledWarning, match="old.vtm"):
        vol = open_volume(_amr_file(tmp_path))
    assert vol.field_names == ["rho"]
    assert vol.n_points > 0 and vol.valid_ratio > 0.9
    values = vol.frame("rho", 0)[vol.valid_mask()]
    # the fine level (100 .. 163) covers the low corner; the coarse one (0 .. 63) the rest
    assert values.max() > 100 and np.nanmin(values) < 64


def _enzo_output(folder: Path, *, grid_name: str = "data0001.cpu0000") -> Path:
    out = folder / "DD0001"
    out.mkdir()
    n = 8
    with h5py.File(out / "data0001.cpu0000", "w") as f:
        f.create_group("Grid00000001")["Density"] = np.arange(n**3, dtype=np.float32).reshape(
            n, n, n
        )
    (out / "data0001").write_text(
        "InitialCycleNumber = 1\nInitialTime = 0.5\nTopGridRank = 3\n"
        "TopGridDimensions = 8 8 8\nDomainLeftEdge = 0 0 0\nDomainRightEdge = 1 1 1\n"
        "DataLabel[0] = Density\n"
    )
    (out / "data0001.hierarchy").write_text(
        "\nGrid = 1\nTask = 0\nGridRank = 3\nGridDimension = 8 8 8\n"
        "GridStartIndex = 0 0 0\nGridEndIndex = 7 7 7\nGridLeftEdge = 0 0 0\n"
        "GridRightEdge = 1 1 1\nTime = 0.5\nSubgridsAreStatic = 0\n"
        f"NumberOfBaryonFields = 1\nFieldType = 0\nBaryonFileName = {grid_name}\n"
        "CourantSafetyNumber = 0.3\nPPMFlatteningParameter = 0\nPPMDiffusionParameter = 0\n"
        "PPMSteepeningParameter = 0\nNumberOfParticles = 0\nGravityBoundaryType = 0\n"
        "Pointer: Grid[1]->NextGridThisLevel = 0\nPointer: Grid[1]->NextGridNextLevel = 0\n"
    )
    (out / "data0001.boundary").write_text("")
    return out


@pytest.mark.parametrize("name", ["data0001.hierarchy", "data0001", "data0001.cpu0000"])
def test_an_enzo_output_is_read_through_vtk(tmp_path: Path, name: str) -> None:
    out = _enzo_output(tmp_path)
    vol = open_volume(out / name)  # chosen by content: each of the output's files leads to it
    assert vol.attrs["reader"] == "enzo"
    assert vol.field_names == ["Density"]
    assert vol.n_steps == 1
    # 8³ cells on the unit cube: cell centres 1/16 .. 15/16, values 0 .. 511
    frame = vol.frame("Density", 0)
    assert np.nanmax(frame) == pytest.approx(511.0)
    assert np.nanmin(frame) == pytest.approx(0.0)
    assert vol.bounds[1] - vol.bounds[0] == pytest.approx(1.0)


def test_an_enzo_grid_file_outside_the_folder_is_not_followed(tmp_path: Path) -> None:
    from auralize.io.vtk_readers import read_enzo

    out = _enzo_output(tmp_path, grid_name="../elsewhere.cpu0000")
    (out / "data0001.cpu0000").unlink()
    (tmp_path / "elsewhere.cpu0000").write_bytes(b"not read")
    with pytest.raises(FormatError, match="grid file elsewhere.cpu0000 it names is missing"):
        read_enzo(out / "data0001.hierarchy")


def test_a_damaged_enzo_hierarchy_is_an_error_not_a_crash(tmp_path: Path) -> None:
    from auralize.io.vtk_readers import read_enzo

    out = _enzo_output(tmp_path)
    with h5py.File(out / "data0001.cpu0000", "w") as f:  # a grid file without its grid
        f.create_group("Other")
    hier = out / "data0001.hierarchy"
    hier.write_text(hier.read_text().replace("GridDimension = 8 8 8", "GridDimension = -5 x"))
    with pytest.raises(AuralizeError, match=str(out)):  # the child may crash, not this process
        read_enzo(hier)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("GridEndIndex = 7 7 7\n", ""), "grid 1's entry has GridEndIndex missing"),
        (("NumberOfParticles = 0\n", ""), "NumberOfParticles missing"),
        (("GridLeftEdge", "GridRightEdgeX"), "GridLeftEdge missing"),
        (
            (
                "GridStartIndex = 0 0 0\nGridEndIndex = 7 7 7",
                "GridEndIndex = 7 7 7\nGridStartIndex = 0 0 0",
            ),
            "GridEndIndex out of order",
        ),
    ],
)
def test_an_enzo_hierarchy_vtk_would_scan_forever_is_refused_at_once(
    tmp_path: Path, change: tuple[str, str], message: str
) -> None:
    """VTK's Enzo reader scans forward for each grid key in turn: a key missing or out of
    order makes it spin past the end of the file (until the child's time limit)."""
    from auralize.io.vtk_readers import read_enzo

    out = _enzo_output(tmp_path)
    hier = out / "data0001.hierarchy"
    text = hier.read_text()
    assert change[0] in text
    hier.write_text(text.replace(*change))
    with pytest.raises(FormatError, match=message):
        read_enzo(hier)


def _dolfin_checkpoint(folder: Path) -> Path:
    h5 = folder / "u.h5"
    with h5py.File(h5, "w") as f:
        f["Mesh/mesh/topology"] = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int64)
        f["Mesh/mesh/geometry"] = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=float)
        for k in range(2):
            f[f"Function/u/{k}/cell_dofs"] = np.array([0, 1, 2, 1, 3, 2], dtype=np.int64)
            f[f"Function/u/{k}/vector"] = np.arange(4, dtype=float) + k
    steps = "".join(
        f"""<Grid Name="mesh" GridType="Uniform">
 <Topology NumberOfElements="2" TopologyType="Triangle" NodesPerElement="3">
  <DataItem Dimensions="2 3" NumberType="UInt" Format="HDF">u.h5:/Mesh/mesh/topology</DataItem>
 </Topology>
 <Geometry GeometryType="XY">
  <DataItem Dimensions="4 2" Format="HDF">u.h5:/Mesh/mesh/geometry</DataItem>
 </Geometry>
 <Time Value="{k}" />
 <Attribute ItemType="FiniteElementFunction" ElementFamily="CG" ElementDegree="1"
   ElementCell="triangle" Name="u" Center="Other" AttributeType="Scalar">
  <DataItem Dimensions="6 1" NumberType="UInt" Format="HDF">u.h5:/Function/u/{k}/cell_dofs</DataItem>
  <DataItem Dimensions="4 1" Format="HDF">u.h5:/Function/u/{k}/vector</DataItem>
 </Attribute>
</Grid>"""
        for k in range(2)
    )
    xdmf = folder / "u.xdmf"
    xdmf.write_text(
        '<?xml version="1.0"?><Xdmf Version="3.0"><Domain>'
        '<Grid Name="TimeSeries_u" GridType="Collection" CollectionType="Temporal">'
        f"{steps}</Grid></Domain></Xdmf>"
    )
    return xdmf


def test_a_dolfin_checkpoint_says_which_writer_to_use(tmp_path: Path) -> None:
    xdmf = _dolfin_checkpoint(tmp_path)
    with pytest.raises(FormatError, match="write_checkpoint.*CG degree 1.*write_function"):
        open_volume(xdmf)
    # info and view give the same one line, on stderr, and nothing else
    for command in ("info", "view"):
        extra = ["--screenshot", str(tmp_path / "v.png")] if command == "view" else []
        done = subprocess.run(
            [sys.executable, "-m", "auralize", command, str(xdmf), *extra],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode != 0
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1, done.stderr
        assert "write_checkpoint" in lines[0] and "write_function" in lines[0]


def test_kinds_vtk_cannot_read_are_named_with_what_to_do(tmp_path: Path) -> None:
    cth = tmp_path / "blast.spcth.0"
    cth.write_bytes(b"spydata" + bytes(100))
    with pytest.raises(FormatError, match="Spectral CTH.*ParaView.*auralize info"):
        open_volume(cth)
    chombo = tmp_path / "plt0010.hdf5"
    with h5py.File(chombo, "w") as f:
        f.attrs["num_levels"] = 1
        f.create_group("level_0")["data:datatype=0"] = np.zeros(8)
    with pytest.raises(FormatError, match="Chombo AMR file.*yt"):
        open_volume(chombo)
    lone = tmp_path / "data0009.cpu0000"  # an Enzo grid file without its hierarchy
    with h5py.File(lone, "w") as f:
        f.create_group("Grid00000001")["Density"] = np.zeros((2, 2, 2))
    with pytest.raises(FormatError, match="Enzo output without its .hierarchy"):
        open_volume(lone)


def test_info_names_the_reader_that_took_the_file(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    from auralize.cli import main

    out = _enzo_output(tmp_path)
    assert main(["info", str(out / "data0001")]) == 0
    assert "  reader   enzo\n" in capsys.readouterr().out
