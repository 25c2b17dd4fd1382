"""Hostile heavy data: damaged files never crash the process, other files are read only
when allowed.

Every hostile file is built here, in ``tmp_path``.  Damaged HDF5 companions of XDMF
files and damaged EnSight geometry run through the command line in a child process,
so that a segmentation fault shows as a negative return code instead of ending the
test run.  The files that read other files (netCDF4 and SOFA with external storage,
virtual datasets or external links; XDMF with absolute, ``..``, symlinked, Binary and
XInclude references) are refused by default and read — giving the referenced data —
once :func:`~auralize.io.hdf5.allow_external_data` allows it.
"""

from __future__ import annotations

import os
import random
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import h5py
import numpy as np
import pytest
import pyvista as pv

from auralize.cli import main
from auralize.errors import DataError, FormatError
from auralize.io import open_volume
from auralize.io.hdf5 import allow_external_data
from auralize.io.xdmf_check import MAX_XML_BYTES
from auralize.spatial import hrtf as H
from auralize.spatial.sofa import read_sofa, write_sofa

DATA = Path(__file__).resolve().parents[1] / "auralize" / "data"
MESHIO = DATA / "xdmf-timeseries" / "meshio"
DOLFINX = DATA / "xdmf-timeseries" / "dolfinx" / "no_checkpoint.xdmf"
ENSIGHT = DATA / "ensight-cylinder"
#: the field of the small XDMF grids below, (nz, ny, nx) as XDMF lists it (slowest first)
RHO = np.arange(24.0).reshape(2, 3, 4)
CLI = "import sys; from auralize.cli import main; sys.exit(main(sys.argv[1:]))"


@pytest.fixture(autouse=True)
def _refused_by_default() -> Iterator[None]:
    allow_external_data(False)
    yield
    allow_external_data(False)


@pytest.fixture
def allowed() -> Iterator[None]:
    allow_external_data(True)
    yield
    allow_external_data(False)


def _cli_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run the CLI in this process: exit status 3 and one line on stderr, returned."""
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 3, err
    assert len(err) == 1, err
    return err[0]


def _cli_child(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "AURALIZE_HDF5_EXTERNAL"}
    return subprocess.run(
        [sys.executable, "-c", CLI, *argv],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env,
        timeout=300,
        check=False,
    )


# --------------------------------------------------------------------------- netCDF4
def _netcdf4(path: Path, make_rho: Callable[[h5py.File], h5py.Dataset]) -> None:
    """A netCDF4 file: time (3 steps, seconds), x (4 points), rho(time, x) from ``make_rho``."""
    with h5py.File(path, "w") as f:
        f.attrs["_NCProperties"] = "version=2"
        t = f.create_dataset("time", data=np.arange(3.0))
        t.make_scale("time")
        t.attrs["units"] = "s"
        x = f.create_dataset("x", data=np.arange(4.0))
        x.make_scale("x")
        rho = make_rho(f)
        rho.dims[0].attach_scale(t)
        rho.dims[1].attach_scale(x)


def _external_storage(tmp_path: Path, data: np.ndarray) -> Callable[[h5py.File], h5py.Dataset]:
    raw = tmp_path / "elsewhere" / "raw.bin"
    raw.parent.mkdir(exist_ok=True)
    data.astype("<f8").tofile(raw)
    return lambda f: f.create_dataset(
        "rho", shape=data.shape, dtype="<f8", external=[(str(raw), 0, data.size * 8)]
    )


def _virtual(tmp_path: Path, data: np.ndarray) -> Callable[[h5py.File], h5py.Dataset]:
    src = tmp_path / "elsewhere" / "src.h5"
    src.parent.mkdir(exist_ok=True)
    with h5py.File(src, "w") as g:
        g["rho"] = data

    def make(f: h5py.File) -> h5py.Dataset:
        layout = h5py.VirtualLayout(shape=data.shape, dtype="<f8")
        layout[:] = h5py.VirtualSource(str(src), "rho", shape=data.shape)
        return f.create_virtual_dataset("rho", layout)

    return make


@pytest.mark.parametrize(
    ("make", "what"), [(_external_storage, "stored in external files"), (_virtual, "virtual")]
)
def test_netcdf4_reading_other_files_is_refused_unless_allowed(
    make: Callable[..., Callable[[h5py.File], h5py.Dataset]],
    what: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    data = np.arange(12.0).reshape(3, 4) + 0.5
    path = tmp_path / "w.nc"
    _netcdf4(path, make(tmp_path, data))
    with pytest.raises(FormatError, match=rf"w\.nc: dataset /rho is {what}.*--allow-external"):
        open_volume(path)
    line = _cli_error(["info", str(path)], capsys)
    assert str(path) in line and "refused" in line
    allow_external_data(True)
    try:
        vol = open_volume(path)
        np.testing.assert_array_equal([vol.frame("rho", k).reshape(-1) for k in range(3)], data)
    finally:
        allow_external_data(False)
    assert main(["info", str(path), "--allow-external"]) == 0


def test_netcdf4_external_link_is_refused(tmp_path: Path) -> None:
    src = tmp_path / "src.h5"
    with h5py.File(src, "w") as g:
        g["rho"] = np.ones((3, 4))
    path = tmp_path / "w.nc"
    with h5py.File(path, "w") as f:
        f.attrs["_NCProperties"] = "version=2"
        f["time"] = np.arange(3.0)
        f["rho"] = h5py.ExternalLink(str(src), "/rho")
    with pytest.raises(FormatError, match=r"w\.nc: /rho is an external link to .*src\.h5"):
        open_volume(path)


# --------------------------------------------------------------------------- SOFA
def _sofa_with_external_ir(tmp_path: Path) -> tuple[Path, np.ndarray]:
    """A SOFA file whose Data.IR bytes live in another file (a real HRIR set's bytes)."""
    directions = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0], [0, 0, 1.0]])
    sofa = write_sofa(tmp_path / "ext.sofa", H.spherical_head_hrirs(directions, 48000))
    raw = tmp_path / "elsewhere.bin"
    with h5py.File(sofa, "a") as h:
        ir = np.asarray(h["Data.IR"][()], dtype="<f8")
        ir.tofile(raw)
        del h["Data.IR"]
        ds = h.create_dataset(
            "Data.IR", shape=ir.shape, dtype="<f8", external=[(str(raw), 0, ir.nbytes)]
        )
        for axis, dim in enumerate(("M", "R", "N")):
            ds.dims[axis].attach_scale(h[dim])
    return sofa, ir


def test_sofa_external_hrirs_are_refused_unless_allowed(tmp_path: Path, allowed: None) -> None:
    sofa, ir = _sofa_with_external_ir(tmp_path)
    allow_external_data(False)
    with pytest.raises(FormatError, match=r"ext\.sofa: dataset /Data\.IR is stored in external"):
        read_sofa(sofa)
    allow_external_data(True)
    np.testing.assert_array_equal(read_sofa(sofa).ir, ir)


def test_cli_hrtf_follows_allow_external(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sofa, _ = _sofa_with_external_ir(tmp_path)
    missing = tmp_path / "missing.h5"
    argv = [
        "render",
        str(missing),
        "--listener",
        "0,0,0",
        "--duration",
        "0.1",
        "--layout",
        "binaural",
        "--hrtf",
        str(sofa),
        "-o",
        str(tmp_path / "out.wav"),
    ]
    line = _cli_error(argv, capsys)
    assert "ext.sofa" in line and "refused" in line and "--allow-external" in line
    # allowed, the SOFA file is read and the command goes on to the (missing) volume
    line = _cli_error([*argv, "--allow-external"], capsys)
    assert "missing.h5" in line and "ext.sofa" not in line
    assert not (tmp_path / "out.wav").exists()


# --------------------------------------------------------------------------- XDMF
def _xdmf(item: str, *, head: str = "") -> str:
    """A one-step XDMF file: a 4x3x2 uniform grid whose field ``rho`` is ``item``."""
    return (
        f'<?xml version="1.0"?>{head}'
        '<Xdmf Version="2.0" xmlns:xi="http://www.w3.org/2001/XInclude"><Domain>'
        '<Grid Name="g" GridType="Uniform"><Topology TopologyType="3DCoRectMesh" '
        'Dimensions="2 3 4"/><Geometry GeometryType="ORIGIN_DXDYDZ">'
        '<DataItem Dimensions="3" Format="XML">0 0 0</DataItem>'
        '<DataItem Dimensions="3" Format="XML">1 1 1</DataItem></Geometry>'
        f'<Attribute Name="rho" AttributeType="Scalar" Center="Node">{item}</Attribute>'
        "</Grid></Domain></Xdmf>"
    )


def _hdf(ref: str, dims: str = "2 3 4") -> str:
    return f'<DataItem Dimensions="{dims}" NumberType="Float" Precision="8" Format="HDF">{ref}</DataItem>'


def _binary(ref: str) -> str:
    return (
        f'<DataItem Dimensions="2 3 4" NumberType="Float" Precision="8" Format="Binary" '
        f'Endian="Little">{ref}</DataItem>'
    )


def _h5(path: Path, data: np.ndarray = RHO) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        f["rho"] = data
    return path


def _case_absolute(case: Path, out: Path) -> str:
    return _xdmf(_hdf(f"{_h5(out / 'data.h5')}:/rho"))


def _case_dotdot(case: Path, out: Path) -> str:
    _h5(out / "data.h5")
    return _xdmf(_hdf(f"../{out.name}/data.h5:/rho"))


def _case_symlink(case: Path, out: Path) -> str:
    (case / "link.h5").symlink_to(_h5(out / "data.h5"))
    return _xdmf(_hdf("link.h5:/rho"))


def _case_binary(case: Path, out: Path) -> str:
    out.mkdir(exist_ok=True)
    RHO.astype("<f8").tofile(out / "raw.bin")
    return _xdmf(_binary(f"../{out.name}/raw.bin"))


def _case_xinclude(case: Path, out: Path) -> str:
    out.mkdir(exist_ok=True)
    (out / "item.xml").write_text(
        '<DataItem Dimensions="2 3 4" NumberType="Float" Precision="8" Format="XML">'
        + " ".join(f"{v:g}" for v in RHO.ravel())
        + "</DataItem>"
    )
    return _xdmf(f'<xi:include href="../{out.name}/item.xml"/>')


def _case_external_storage(case: Path, out: Path) -> str:
    out.mkdir(exist_ok=True)
    RHO.astype("<f8").tofile(out / "raw.bin")
    with h5py.File(case / "data.h5", "w") as f:
        f.create_dataset(
            "rho", shape=RHO.shape, dtype="<f8", external=[(str(out / "raw.bin"), 0, RHO.nbytes)]
        )
    return _xdmf(_hdf("data.h5:/rho"))


def _case_virtual(case: Path, out: Path) -> str:
    src = _h5(out / "src.h5")
    with h5py.File(case / "data.h5", "w") as f:
        layout = h5py.VirtualLayout(shape=RHO.shape, dtype="<f8")
        layout[:] = h5py.VirtualSource(str(src), "rho", shape=RHO.shape)
        f.create_virtual_dataset("rho", layout)
    return _xdmf(_hdf("data.h5:/rho"))


def _case_external_link(case: Path, out: Path) -> str:
    src = _h5(out / "src.h5")
    with h5py.File(case / "data.h5", "w") as f:
        f["rho"] = h5py.ExternalLink(str(src), "/rho")
    return _xdmf(_hdf("data.h5:/rho"))


OUTSIDE_CASES = {
    "absolute": (_case_absolute, "outside the XDMF file's folder"),
    "dotdot": (_case_dotdot, "outside the XDMF file's folder"),
    "symlink": (_case_symlink, "outside the XDMF file's folder"),
    "binary": (_case_binary, "Binary DataItem .* outside the XDMF file's folder"),
    "xinclude": (_case_xinclude, "an XInclude reads"),
    "external-storage": (_case_external_storage, "dataset /rho is stored in external files"),
    "virtual": (_case_virtual, "dataset /rho is virtual"),
}


@pytest.mark.parametrize("name", list(OUTSIDE_CASES))
def test_xdmf_reading_other_files_is_refused_unless_allowed(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    build, message = OUTSIDE_CASES[name]
    case, out = tmp_path / "case", tmp_path / "outside"
    case.mkdir()
    xdmf = case / "x.xmf"
    xdmf.write_text(build(case, out))
    with pytest.raises(FormatError, match=rf"{message}.*refused.*--allow-external"):
        open_volume(xdmf)
    line = _cli_error(["info", str(xdmf)], capsys)
    assert str(xdmf) in line and "refused" in line
    allow_external_data(True)
    try:
        vol = open_volume(xdmf)
        np.testing.assert_array_equal(vol.frame("rho", 0), RHO)  # the referenced data
    finally:
        allow_external_data(False)
    assert main(["info", str(xdmf), "--allow-external"]) == 0


def test_xdmf_companion_with_an_external_link_is_refused(tmp_path: Path) -> None:
    """Refused by default like every HDF5 file; allowed, still refused: VTK's XDMF reader
    cannot follow the link (and ends the process when a mesh's data cannot be read)."""
    case, out = tmp_path / "case", tmp_path / "outside"
    case.mkdir()
    xdmf = case / "x.xmf"
    xdmf.write_text(_case_external_link(case, out))
    with pytest.raises(
        FormatError,
        match=r"x\.xmf: its heavy-data file .*data\.h5: /rho is an "
        r"external link .*refused",
    ):
        open_volume(xdmf)
    allow_external_data(True)
    try:
        with pytest.raises(FormatError, match=r"x\.xmf: .* external link .* cannot follow"):
            open_volume(xdmf)
    finally:
        allow_external_data(False)


def test_xdmf_inside_its_folder_reads(tmp_path: Path) -> None:
    _h5(tmp_path / "sub" / "data.h5")
    RHO.astype("<f8").tofile(tmp_path / "raw.bin")
    for item in (_hdf("data.h5:/rho"), _binary("raw.bin")):
        xdmf = tmp_path / "x.xmf"
        xdmf.write_text(_xdmf(item).replace("data.h5", "sub/data.h5"))
        np.testing.assert_array_equal(open_volume(xdmf).frame("rho", 0), RHO)


@pytest.mark.parametrize(
    ("head", "item", "message"),
    [
        (
            '<!DOCTYPE Xdmf [<!ENTITY e "1 2 3">]>',
            _hdf("data.h5:/rho"),
            "declares or uses an XML entity",
        ),
        (
            '<!DOCTYPE Xdmf [<!ENTITY e SYSTEM "/etc/passwd">]>',
            '<DataItem Dimensions="3" Format="XML">&e;</DataItem>',
            "declares or uses an XML entity",
        ),
        (
            '<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd">',
            '<DataItem Dimensions="3" Format="XML">&e;</DataItem>',
            "declares or uses an XML entity",
        ),
        ("", _hdf("data.h5:/rho", "2 3 5"), r"holds 24 values .* declare 30"),
        ("", _hdf("data.h5:/nope"), "/nope does not exist"),
        ("", _hdf("gone.h5:/rho"), r"gone\.h5 does not exist"),
        ("", _hdf("data.h5"), "must read 'file.h5:/path/to/dataset'"),
        ("", _binary("short.bin"), r"holds 95 bytes .* need 192; the file is truncated"),
        ("", '<DataItem Dimensions="24" Format="XML">1 2 3</DataItem>', "holds 3 values"),
        (
            "",
            '<DataItem Dimensions="24" Format="TIFF">x.tif</DataItem>',
            "Format='TIFF' is not supported",
        ),
        ("", '<xi:include href="/dev/zero"/>', "not a regular file"),
        ("", '<xi:include href="/etc/passwd"/>', r"/etc/passwd: not a valid XIncluded XML file"),
    ],
)
def test_xdmf_malformed_or_hostile_is_refused_even_when_allowed(
    head: str, item: str, message: str, tmp_path: Path, allowed: None
) -> None:
    _h5(tmp_path / "data.h5")
    (tmp_path / "short.bin").write_bytes(bytes(95))
    xdmf = tmp_path / "x.xmf"
    xdmf.write_text(_xdmf(item, head=head))
    with pytest.raises(FormatError, match=message):
        open_volume(xdmf)


def test_xinclude_of_system_files_is_refused_by_default(tmp_path: Path) -> None:
    for href in ("/etc/passwd", "/dev/zero"):
        xdmf = tmp_path / "x.xmf"
        xdmf.write_text(_xdmf(f'<xi:include href="{href}"/>'))
        with pytest.raises(FormatError, match=rf"XInclude reads '{href}'.*refused"):
            open_volume(xdmf)


def test_xdmf_larger_than_the_bound_is_refused(tmp_path: Path) -> None:
    xdmf = tmp_path / "big.xmf"
    xdmf.write_text(_xdmf(_hdf("data.h5:/rho")))
    with xdmf.open("r+b") as fh:
        fh.truncate(MAX_XML_BYTES + 1)  # sparse: no disk used
    with pytest.raises(FormatError, match=r"big\.xmf: \d+ bytes; XDMF files over 64 MiB"):
        open_volume(xdmf)


def _damage(path: Path, kind: str) -> None:
    data = bytearray(path.read_bytes())
    if kind == "zero-bytes":
        data = bytearray()
    elif kind == "truncated-by-7":
        data = data[:-7]
    elif kind == "random-bytes":
        data = bytearray(random.Random(7).randbytes(len(data)))
    elif kind == "flipped-superblock":
        for i in (44, 45):  # two bits of the end-of-file address
            data[i] ^= 1
    elif kind == "flipped-header":
        with h5py.File(path, "r") as f:
            addr = h5py.h5o.get_info(f["data1"].id).addr
        data[addr + 8] ^= 1 << 3  # two bits of /data1's object header
        data[addr + 9] ^= 1 << 5
    path.write_bytes(bytes(data))


DAMAGES = ["zero-bytes", "truncated-by-7", "random-bytes", "flipped-superblock", "flipped-header"]


@pytest.mark.parametrize("kind", DAMAGES)
def test_damaged_xdmf_companion_exits_3_without_crashing(kind: str, tmp_path: Path) -> None:
    folder = tmp_path / "meshio"
    shutil.copytree(MESHIO, folder)
    _damage(folder / "out.h5", kind)
    xdmf = folder / "out.xdmf"
    with pytest.raises(FormatError, match=r"out\.xdmf: .*out\.h5.*(truncated or corrupt|group)"):
        open_volume(xdmf)
    argv = ["info", str(xdmf)]
    if kind == "truncated-by-7":
        argv = ["detect", str(xdmf), "-o", str(tmp_path / "s.h5")]
    done = _cli_child(*argv, cwd=tmp_path)
    assert done.returncode == 3, (done.returncode, done.stderr[-2000:])
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "out.xdmf" in lines[0] and "out.h5" in lines[0], lines
    assert not (tmp_path / "s.h5").exists()


def test_xdmf_reads_the_same_arrays_as_vtk(tmp_path: Path) -> None:
    """The shipped meshio and dolfinx series, and a written 3DCoRectMesh series, read
    as before: the values VTK's reader gives, at every step."""
    vol = open_volume(MESHIO / "out.xdmf")
    reader = pv.XdmfReader(str(MESHIO / "out.xdmf"))
    for step, t in enumerate(reader.time_values):
        reader.set_active_time_value(t)
        mesh = reader.read()
        mesh = mesh if isinstance(mesh, pv.DataSet) else mesh[0]
        order = np.lexsort((mesh.points[:, 0], mesh.points[:, 1]))  # grid order: x fastest
        np.testing.assert_array_equal(
            vol.frame("phi", step).reshape(-1), np.asarray(mesh.point_data["phi"])[order]
        )
    vol = open_volume(DOLFINX)
    reader = pv.XdmfReader(str(DOLFINX))
    reader.set_active_time_value(4.0)
    mesh = reader.read()
    mesh = mesh if isinstance(mesh, pv.DataSet) else mesh[0]
    ijk = np.rint(np.asarray(mesh.points) / 0.125).astype(int)
    flat = (ijk[:, 2] * 9 + ijk[:, 1]) * 9 + ijk[:, 0]
    np.testing.assert_array_equal(vol.frame("f_5", 4).reshape(-1)[flat], mesh.point_data["f_5"])
    from auralize.bench.readers import write_series

    paths = write_series(tmp_path, 6, 3)
    ref, vol = open_volume(paths["hdf5"]), open_volume(paths["xdmf"])
    for step in range(3):
        np.testing.assert_array_equal(vol.frame("density", step), ref.frame("density", step))
        np.testing.assert_array_equal(vol.frame("velocity", step), ref.frame("velocity", step))


def test_xdmf_checks_each_step_before_vtk_reads_it(tmp_path: Path) -> None:
    """A dataset damaged after opening is found when its step is read, not by VTK."""
    from auralize.bench.readers import write_series

    xdmf = write_series(tmp_path, 4, 3)["xdmf"]
    vol = open_volume(xdmf)
    with h5py.File(tmp_path / "xdmf_data.h5", "a") as f:
        del f["density/2"]
        f["density/2"] = np.zeros(5)  # the wrong size for the declared 4x4x4
    with pytest.raises(FormatError, match=r"series\.xdmf: heavy data 'xdmf_data\.h5:/density/2'"):
        vol.frame("density", 2)


# --------------------------------------------------------------------------- EnSight
def _ensight_copy(tmp_path: Path) -> Path:
    folder = tmp_path / "ensight"
    shutil.copytree(ENSIGHT, folder)
    return folder / "cylinder_Re35.case"


def _connectivity_offset(geo: Path) -> int:
    """Where the first part's first tria3/quad4 connectivity values lie in the binary .geo."""
    data = geo.read_bytes()
    for name in (b"tria3", b"quad4"):
        at = data.find(name)
        if at >= 0:
            return at + 80 + 4  # the element type's 80-byte name, then the element count
    raise AssertionError("no tria3/quad4 block in the geometry file")


def test_ensight_with_flipped_connectivity_bits_is_a_data_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    case = _ensight_copy(tmp_path)
    geo = case.with_suffix(".geo")
    data = bytearray(geo.read_bytes())
    at = _connectivity_offset(geo)
    data[at + 3] ^= 1 << 6  # the high byte of the first point id: a point far past the end
    data[at + 7] ^= 1 << 4
    geo.write_bytes(bytes(data))
    with pytest.raises(
        DataError,
        match=r"cylinder_Re35\.case: the mesh is corrupt: a cell "
        r"refers to point \d+, but the mesh has 14831 points",
    ):
        open_volume(case)
    line = _cli_error(["info", str(case)], capsys)
    assert "cylinder_Re35.case" in line and "corrupt" in line
    done = _cli_child("info", str(case), cwd=tmp_path)
    assert done.returncode == 3 and "corrupt" in done.stderr, done.stderr[-2000:]


RANDOM_FLIPS = r"""
import contextlib, io, json, sys
from auralize.cli import main
codes = []
for case in sys.argv[1:]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["info", case])
    codes.append([code, err.getvalue().strip().splitlines()[-1:]])
print(json.dumps(codes))
"""


def test_ensight_with_random_flipped_bits_never_crashes(tmp_path: Path) -> None:
    """Two random bits of the geometry, six times, in one child process: each case is
    read (0) or refused with a line naming it (3); the process never crashes."""
    import json

    cases = []
    for seed in range(6):
        case = _ensight_copy(tmp_path / f"s{seed}")
        geo = case.with_suffix(".geo")
        data = bytearray(geo.read_bytes())
        rng = random.Random(seed)
        for _ in range(2):
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
        geo.write_bytes(bytes(data))
        cases.append(str(case))
    env = {k: v for k, v in os.environ.items() if k != "AURALIZE_HDF5_EXTERNAL"}
    done = subprocess.run(
        [sys.executable, "-c", RANDOM_FLIPS, *cases],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
    codes = json.loads(done.stdout.strip().splitlines()[-1])
    for case, (code, last) in zip(cases, codes, strict=True):
        assert code in (0, 3), (case, code, last)
        if code == 3:
            assert case in last[0], last


def test_ensight_truncated_geometry_is_a_format_error(tmp_path: Path) -> None:
    case = _ensight_copy(tmp_path)
    geo = case.with_suffix(".geo")
    geo.write_bytes(geo.read_bytes()[:-7])
    with pytest.raises(FormatError, match=r"cylinder_Re35\.case: VTK's EnSight reader failed"):
        open_volume(case)
    done = _cli_child("detect", str(case), "-o", str(tmp_path / "s.h5"), cwd=tmp_path)
    assert done.returncode == 3, done.stderr[-2000:]
    assert len(done.stderr.strip().splitlines()) == 1 and "cylinder_Re35.case" in done.stderr


def test_ensight_reads_the_same_arrays_as_vtk(tmp_path: Path) -> None:
    """The mesh the child process reads is the one VTK reads here, array for array; a
    written transient block case reads the values of its HDF5 twin."""
    from auralize.io._mesh import as_dataset
    from auralize.io.vtk_readers import ChildEnSightSteps

    case = ENSIGHT / "cylinder_Re35.case"
    loader = ChildEnSightSteps(case)
    try:
        got = loader(0)
    finally:
        loader.close()
    want = as_dataset(pv.EnSightReader(str(case)).read(), label=str(case))
    assert type(got) is type(want) and got.n_cells == want.n_cells
    assert list(got.point_data.keys()) == list(want.point_data.keys())  # the fields' order
    np.testing.assert_array_equal(got.points, want.points)
    np.testing.assert_array_equal(got.cell_connectivity, want.cell_connectivity)
    for name in want.point_data.keys():
        np.testing.assert_array_equal(got.point_data[name], want.point_data[name])
    from auralize.bench.readers import write_series

    paths = write_series(tmp_path, 6, 3)
    ref, vol = open_volume(paths["hdf5"]), open_volume(paths["ensight"])
    np.testing.assert_allclose(vol.times, ref.times, rtol=1e-6)
    for step in range(3):
        np.testing.assert_allclose(
            vol.frame("density", step), ref.frame("density", step), rtol=1e-6
        )
        np.testing.assert_allclose(
            vol.frame("velocity", step), ref.frame("velocity", step), rtol=1e-6, atol=1e-9
        )


def test_a_mesh_with_bad_cells_never_reaches_vtk_filters() -> None:
    from auralize.io._mesh import check_mesh

    grid = pv.ImageData(dimensions=(3, 3, 3)).cast_to_unstructured_grid()
    check_mesh(grid, label="ok")
    bad = grid.copy()
    conn = bad.GetCells().GetConnectivityArray()
    conn.SetValue(5, 10**6)
    with pytest.raises(
        DataError, match=r"bad: the mesh is corrupt: a cell refers to point 1000000"
    ):
        check_mesh(bad, label="bad")
    pts = grid.copy()
    pts.points[0] = np.nan
    with pytest.raises(DataError, match="NaN or infinite"):
        check_mesh(pts, label="nan")
