"""VTK speaks through auralize: a corrupt file of each kind VTK reads leaves one line on
the user's stderr (auralize's, naming the file and VTK's reason); ``-v`` shows VTK's own
messages as plain log lines."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

KINDS = [".vtu", ".vts", ".vtm", ".cgns", ".exo", ".vtk", ".pvd"]
#: further kinds VTK reads, checked without ``-v`` (each run starts a process)
MORE_KINDS = [".vti", ".vtp", ".vthb", ".xdmf", ".case", ".xyz", ".cas", ".vtkhdf", ".hierarchy"]


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    code = "import sys; from auralize.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300
    )


@pytest.mark.parametrize("suffix", KINDS + MORE_KINDS)
def test_a_corrupt_file_leaves_one_line(suffix: str, tmp_path: Path) -> None:
    bad = tmp_path / f"bad{suffix}"
    rng = np.random.default_rng(len(suffix))
    if suffix == ".pvd":  # a valid collection whose piece is corrupt
        (tmp_path / "piece.vtu").write_bytes(rng.bytes(400))
        bad.write_text(
            '<?xml version="1.0"?><VTKFile type="Collection" version="0.1">'
            '<Collection><DataSet timestep="0" file="piece.vtu"/>'
            '<DataSet timestep="1" file="piece.vtu"/></Collection></VTKFile>'
        )
    else:
        bad.write_bytes(rng.bytes(400))
    r = _run("info", str(bad))
    lines = r.stderr.splitlines()
    assert r.returncode == 3, r.stderr
    assert len(lines) == 1 and lines[0].startswith("auralize info: error: "), r.stderr
    assert "bad" in lines[0] or "piece" in lines[0]
    assert "\x1b[" not in r.stderr and "ERROR:root" not in r.stderr and "0x" not in lines[0]
    if suffix in MORE_KINDS:
        return
    # -v: VTK's messages are there, as auralize's plain log lines
    v = _run("info", str(bad), "-v")
    assert v.returncode == 3 and "\x1b[" not in v.stderr
    assert all(ln.startswith("auralize") for ln in v.stderr.splitlines()), v.stderr


def test_import_auralize_leaves_vtk_as_it_is() -> None:
    code = (
        "import auralize, auralize.io, pyvista; "
        "from vtkmodules.vtkCommonCore import vtkLogger; "
        "import logging; print(vtkLogger.GetStderrVerbosity(), len(logging.getLogger().handlers))"
    )
    base = (
        "import pyvista; from vtkmodules.vtkCommonCore import vtkLogger; import logging; "
        "print(vtkLogger.GetStderrVerbosity(), len(logging.getLogger().handlers))"
    )
    got = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout
    want = subprocess.run([sys.executable, "-c", base], capture_output=True, text=True).stdout
    assert got == want
