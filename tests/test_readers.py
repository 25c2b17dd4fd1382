"""Readers of what ParaView reads: XDMF, netCDF (CF), PLOT3D, EnSight, .vtm, AMR, any
pyvista.get_reader kind; the valid-point mask; field roles; the CLI on each format."""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
import pyvista as pv
from scipy.io import netcdf_file

from auralize.cli import main
from auralize.errors import DataError, FormatError
from auralize.io import ResampledWarning, open_volume, save_volume
from auralize.io._mesh import MeshFrames, lattice_order
from auralize.io.netcdf import time_unit_seconds
from auralize.pipeline import auto_mapping, resolve_mapping
from auralize.sources.mapping import match_field
from auralize.volume import TimeVolume

DATA = Path(__file__).resolve().parents[1] / "auralize" / "data"
DOLFINX = DATA / "xdmf-timeseries" / "dolfinx" / "no_checkpoint.xdmf"
MESHIO = DATA / "xdmf-timeseries" / "meshio" / "out.xdmf"
ENSIGHT = DATA / "ensight-cylinder" / "cylinder_Re35.case"
COMB_XYZ = DATA / "plot3d-combustor" / "combxyz.bin"
COMB_Q = DATA / "plot3d-combustor" / "combq.bin"
PULSE = DATA / "netcdf-pulse" / "pulse.nc"


@pytest.fixture(autouse=True)
def _quiet_resampling():  # type: ignore[no-untyped-def]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        yield


# --------------------------------------------------------------------------- CF writers
def write_cf_classic(
    path: Path,
    *,
    time_units: str | None = "days since 2001-01-01",
    with_time: bool = True,
    fill: bool = True,
) -> np.ndarray:
    """A small CF file (classic): temperature (T, z, y, x) with fill values; returns it."""
    nt, nz, ny, nx = 3, 2, 3, 4
    rng = np.random.default_rng(3)
    temp = rng.normal(280.0, 5.0, (nt, nz, ny, nx)).astype(np.float32)
    if fill:
        temp[1, 0, 0, 0] = -999.0
    with netcdf_file(path, "w") as f:
        f.Conventions = "CF-1.8"
        if with_time:
            f.createDimension("time", None)
            t = f.createVariable("time", "f8", ("time",))
            if time_units is not None:
                t.units = time_units
            t[:] = [0.0, 0.5, 2.0]
        for name, n in (("z", nz), ("y", ny), ("x", nx)):
            f.createDimension(name, n)
            c = f.createVariable(name, "f8", (name,))
            c.units = "m"
            c[:] = np.arange(n) * 10.0
        dims = ("time", "z", "y", "x") if with_time else ("z", "y", "x")
        v = f.createVariable("temperature", "f4", dims)
        v.units = "K"
        v._FillValue = np.float32(-999.0)
        v[:] = temp if with_time else temp[0]
    return temp


def write_cf_netcdf4(path: Path) -> np.ndarray:
    """A netCDF4 (HDF5) file as the netCDF library lays it out: dimension scales."""
    nt, ny, nx = 4, 3, 5
    u = np.arange(nt * ny * nx, dtype=np.float64).reshape(nt, ny, nx)
    v = -u
    rho = 1.2 + 0.01 * u
    with h5py.File(path, "w") as f:
        f.attrs["_NCProperties"] = "version=2,netcdf=4.9.2,hdf5=1.14.3"
        for name, vals, units in (
            ("time", np.array([0.0, 1.0, 2.0, 3.0]), "hours since 2001-01-01 00:00"),
            ("lat", np.array([20.0, 10.0, 0.0]), "m"),  # decreasing: flipped on reading
            ("lon", np.arange(nx) * 10.0, "m"),
        ):
            ds = f.create_dataset(name, data=vals)
            ds.make_scale(name)
            ds.attrs["units"] = units
        for name, data in (("u", u), ("v", v), ("rho", rho)):
            ds = f.create_dataset(name, data=data)
            for axis, dim in enumerate(("time", "lat", "lon")):
                ds.dims[axis].attach_scale(f[dim])
        f["rho"].attrs["missing_value"] = 1.2  # the first value is missing
        f["u"].attrs["units"] = "m s-1"
    return rho


# --------------------------------------------------------------------------- XDMF
def test_xdmf_dolfinx_tetra_mesh() -> None:
    vol = open_volume(DOLFINX)
    assert vol.field_names == ["f_5"] and vol.physical_times
    np.testing.assert_allclose(vol.times, [0, 1, 2, 3, 4])
    assert vol.dims == (9, 9, 9) and vol.valid is None  # its 729 points are a lattice
    np.testing.assert_allclose(vol.bounds, (0, 1, 0, 1, 0, 1), atol=1e-12)
    reader = pv.XdmfReader(str(DOLFINX))
    reader.set_active_time_value(3.0)
    mesh = reader.read()
    mesh = mesh if isinstance(mesh, pv.DataSet) else mesh[0]
    grid_of_point = np.rint(np.asarray(mesh.points) / 0.125).astype(int)
    flat = (grid_of_point[:, 2] * 9 + grid_of_point[:, 1]) * 9 + grid_of_point[:, 0]
    np.testing.assert_array_equal(vol.frame("f_5", 3).reshape(-1)[flat], mesh.point_data["f_5"])


def test_xdmf_meshio_series_point_and_cell_data() -> None:
    vol = open_volume(MESHIO)
    assert vol.field_names == ["phi", "u", "a"] and vol.n_steps == 5
    np.testing.assert_allclose(vol.times, [0, 0.25, 0.5, 0.75, 1.0])
    assert vol.dims == (2, 2, 1)  # two triangles on the unit square: 4 points, not 8
    assert vol.attrs["centring"] == {"phi": "point", "u": "point", "a": "cell"}
    assert vol.is_vector("u") and match_field(vol, "velocity") == "u"


def test_xdmf_reads_one_step_at_a_time() -> None:
    vol = open_volume(DOLFINX)
    frames = vol.fields["f_5"]
    assert isinstance(frames, MeshFrames)
    assert frames.steps.n_loads == 0  # opening read step 0 to learn the grid, nothing more
    vol.frame("f_5", 2)
    vol.frame("f_5", 2)
    assert frames.steps.n_loads == 1 and frames.steps._step == 2


# --------------------------------------------------------------------------- netCDF
def test_netcdf_classic_cf_time_and_fill(tmp_path: Path) -> None:
    temp = write_cf_classic(tmp_path / "t.nc")
    vol = open_volume(tmp_path / "t.nc")
    np.testing.assert_allclose(vol.times, [0.0, 0.5 * 86400, 2.0 * 86400])  # days -> s
    assert vol.dims == (4, 3, 2) and vol.spacing.tolist() == [10.0, 10.0, 10.0]
    assert vol.attrs["units"] == {"temperature": "K"}
    assert vol.attrs["time_units"] == "days since 2001-01-01"
    t1 = vol.frame("temperature", 1)
    assert np.isnan(t1[0, 0, 0]) and np.count_nonzero(np.isnan(t1)) == 1
    np.testing.assert_allclose(vol.frame("temperature", 2), temp[2], rtol=1e-6)
    strict = open_volume(tmp_path / "t.nc", nan="error")
    with pytest.raises(DataError, match=r"t\.nc: field 'temperature' at step 1 .* 1 NaN/Inf"):
        strict.frame("temperature", 1)


def test_netcdf4_dimension_scales_flip_and_velocity(tmp_path: Path) -> None:
    rho = write_cf_netcdf4(tmp_path / "w.nc")
    vol = open_volume(tmp_path / "w.nc")
    np.testing.assert_allclose(vol.times, [0, 3600, 7200, 10800])
    assert vol.dims == (5, 3, 1)
    assert vol.origin.tolist() == [0.0, 0.0, 0.0]  # lat was stored decreasing
    assert set(vol.field_names) == {"u", "v", "rho", "velocity"}
    got = vol.frame("rho", 2)[0]
    np.testing.assert_allclose(got, rho[2][::-1])
    assert np.isnan(vol.frame("rho", 0)[0, 2, 0])  # missing_value at (lat=20, lon=0)
    vel = vol.frame("velocity", 1)
    np.testing.assert_allclose(vel[0, :, :, 0], -vel[0, :, :, 1])
    assert auto_mapping(vol) == "identity" and resolve_mapping(vol).describe()["density"] == "rho"


def test_netcdf_packed_pulse_dataset() -> None:
    vol = open_volume(PULSE)
    rho = vol.frame("density", 1)  # int16 with scale_factor/add_offset
    assert 1.18 < np.nanmin(rho) and np.nanmax(rho) < 1.22
    vel = vol.frame("velocity", 1)
    land = np.isnan(vel).any(axis=-1)
    assert 0 < land.mean() < 0.2 and np.all(np.isfinite(rho))


def test_cf_time_units() -> None:
    assert time_unit_seconds("hours since 1970-01-01T00:00:00Z", source="x")[0] == 3600.0
    with pytest.raises(FormatError, match=r"x\.nc: time units 'fortnights since 2000' are not"):
        time_unit_seconds("fortnights since 2000", source="x.nc")


# --------------------------------------------------------------------------- PLOT3D
def make_plot3d_series(folder: Path, n_steps: int = 3) -> Path:
    """The combustor grid with ``n_steps`` solutions whose density pulsates (a blob)."""
    grid = folder / "comb.xyz"
    shutil.copy(COMB_XYZ, grid)
    raw = np.fromfile(COMB_Q, dtype=">f4")  # big-endian, no record markers
    n = 57 * 33 * 25
    head = 7  # idim, jdim, kdim (int32) and fsmach, alpha, re, time (float32)
    pts = np.fromfile(COMB_XYZ, dtype=">f4")[3:].reshape(3, n).astype(np.float64)
    blob = np.exp(-np.sum((pts.T - pts.mean(axis=1)) ** 2, axis=1) / 4.0)
    for step in range(n_steps):
        q = raw.copy()
        q[head : head + n] *= 1.0 + 0.05 * np.sin(1.3 * step) * blob
        q.tofile(folder / f"comb_{step + 1}.q")
    return grid


def test_plot3d_series_of_q_files(tmp_path: Path) -> None:
    grid = make_plot3d_series(tmp_path)
    vol = open_volume(grid)
    assert vol.n_steps == 3 and not vol.physical_times
    assert vol.field_names == ["Density", "Momentum", "StagnationEnergy"]
    assert auto_mapping(vol) == "cfd"
    d0, d1 = vol.frame("Density", 0), vol.frame("Density", 1)
    assert np.nanmax(np.abs(d1 - d0)) > 0
    assert vol.curvilinear and vol.valid is None and np.isfinite(d0).all()  # natively
    with pytest.warns(ResampledWarning):
        res = open_volume(grid, curvilinear="resample")
    assert np.array_equal(np.isnan(res.frame("Density", 0)), ~res.valid)


def test_plot3d_cfd_from_the_cli(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    grid = make_plot3d_series(tmp_path)
    out = tmp_path / "s.h5"
    rc = main(
        [
            "detect",
            str(grid),
            "--mapping",
            "cfd",
            "--density-field",
            "Density",
            "--momentum-field",
            "Momentum",
            "-o",
            str(out),
            "--json",
        ]
    )
    assert rc == 0
    d = json.loads(capsys.readouterr().out)
    assert d["mapping"]["name"] == "cfd" and d["mapping"]["momentum"] == "Momentum"
    assert d["valid_ratio"] == 1.0 and len(d["steps"]) == 3  # natively: every point
    assert main(["info", str(grid)]) == 0
    text = capsys.readouterr().out
    assert "role     density = Density: named 'Density'" in text
    assert "role     momentum = Momentum: named 'Momentum'" in text
    assert "mapping  cfd (default" in text
    wav = tmp_path / "p.wav"
    rc = main(
        [
            "render",
            str(grid),
            "--sources",
            str(out),
            "--listener",
            "8,0,30",
            "--duration",
            "0.01",
            "--rate",
            "8000",
            "-o",
            str(wav),
        ]
    )
    assert rc == 0 and wav.exists()


# --------------------------------------------------------------------------- EnSight, vtm, AMR
def test_ensight_single_step() -> None:
    vol = open_volume(ENSIGHT)
    assert vol.n_steps == 1 and vol.dims[2] == 1
    assert vol.is_vector("velocity") and auto_mapping(vol) == "incompressible"
    np.testing.assert_allclose(vol.bounds[:4], (0, 15, -3.75, 3.75), atol=1e-6)


def test_ensight_transient(tmp_path: Path) -> None:
    """A transient case: two time steps sharing the geometry."""
    for f in ENSIGHT.parent.glob("cylinder_Re35.*"):
        shutil.copy(f, tmp_path / f.name)
    for suffix in ("scl1", "vel"):
        data = (tmp_path / f"cylinder_Re35.{suffix}").read_bytes()
        for step in (1, 2):
            (tmp_path / f"cyl{step}.{suffix}").write_bytes(data)
    (tmp_path / "t.case").write_text(
        "FORMAT\ntype: ensight gold\nGEOMETRY\nmodel: cylinder_Re35.geo\nVARIABLE\n"
        "scalar per node: pressure cyl*.scl1\nvector per node: velocity cyl*.vel\n"
        "TIME\ntime set: 1\nnumber of steps: 2\nfilename start number: 1\n"
        "filename increment: 1\ntime values: 0.5 1.5\n"
    )
    vol = open_volume(tmp_path / "t.case")
    np.testing.assert_allclose(vol.times, [0.5, 1.5])
    assert vol.physical_times and set(vol.field_names) == {"pressure", "velocity"}
    np.testing.assert_array_equal(vol.frame("pressure", 1), vol.frame("pressure", 0))
    # from the command line: a steady flow repeated makes no monopoles
    out = tmp_path / "s.h5"
    assert main(["detect", str(tmp_path / "t.case"), "-o", str(out)]) == 0
    from auralize.sources.sources_file import load_sources_h5

    assert all(c["monopole"] == 0 for c in load_sources_h5(out).counts())
    rc = main(
        [
            "render",
            str(tmp_path / "t.case"),
            "--sources",
            str(out),
            "--listener",
            "5,0,0",
            "--duration",
            "0.01",
            "--rate",
            "8000",
            "-o",
            str(tmp_path / "e.wav"),
        ]
    )
    assert rc == 1  # written, and said to be silent: a steady flow makes no sound


def test_vtm_blocks_are_merged(tmp_path: Path) -> None:
    left = pv.ImageData(dimensions=(3, 3, 3), spacing=(1, 1, 1), origin=(0, 0, 0))
    right = pv.ImageData(dimensions=(3, 3, 3), spacing=(1, 1, 1), origin=(2, 0, 0))
    for b in (left, right):
        b.point_data["rho"] = b.points[:, 0] + 1.0
    pv.MultiBlock([left, right]).save(tmp_path / "m.vtm")
    vol = open_volume(tmp_path / "m.vtm")
    assert vol.dims == (5, 3, 3) and vol.valid is None  # the shared face is merged
    np.testing.assert_allclose(vol.frame("rho", 0)[0, 0], [1, 2, 3, 4, 5])


def test_amr_vthb(tmp_path: Path) -> None:
    from vtkmodules.vtkFiltersAMR import vtkAMRGaussianPulseSource
    from vtkmodules.vtkIOXML import vtkXMLUniformGridAMRWriter

    src = vtkAMRGaussianPulseSource()
    src.SetDimension(3)
    src.SetRootSpacing(0.25)
    src.Update()
    writer = vtkXMLUniformGridAMRWriter()
    writer.SetFileName(str(tmp_path / "p.vthb"))
    writer.SetInputData(src.GetOutput())
    writer.Write()
    vol = open_volume(tmp_path / "p.vthb")
    assert "Gaussian-Pulse" in vol.field_names and vol.attrs["centring"]["Gaussian-Pulse"] == "cell"
    amr = src.GetOutput()
    bounds = [0.0] * 6
    amr.GetBounds(bounds)
    np.testing.assert_allclose(vol.bounds, bounds, atol=1e-9)
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from auralize.runtime.vtkcompat import amr_block, amr_block_count

    raw = [
        vtk_to_numpy(amr_block(amr, level, i).GetCellData().GetArray("Gaussian-Pulse"))
        for level in range(amr.GetNumberOfLevels())
        for i in range(amr_block_count(amr, level))
    ]
    pulse = vol.frame("Gaussian-Pulse", 0)
    # cell values interpolated to points: within the range of the file's values
    assert min(r.min() for r in raw) - 1e-12 <= np.nanmin(pulse)
    assert 0 < np.nanmax(pulse) <= max(r.max() for r in raw) + 1e-12


def test_generic_pyvista_reader(tmp_path: Path) -> None:
    from vtkmodules.vtkIOImage import vtkNIFTIImageWriter

    img = pv.ImageData(dimensions=(4, 3, 2), spacing=(0.5, 0.5, 0.5))
    img.point_data["density"] = np.arange(24.0)
    writer = vtkNIFTIImageWriter()  # VTK's own: older pyvista cannot save .nii
    writer.SetFileName(str(tmp_path / "img.nii"))
    writer.SetInputData(img)
    writer.Write()
    vol = open_volume(tmp_path / "img.nii")
    assert vol.dims == (4, 3, 2) and vol.n_steps == 1
    assert np.nanmax(vol.frame(vol.field_names[0], 0)) == 23.0


# --------------------------------------------------------------------------- mask and lattice
def test_valid_mask_survives_resampling_slabs_and_hdf5(tmp_path: Path) -> None:
    valid = np.ones((4, 5, 6), dtype=bool)
    valid[:, :, :2] = False
    rho = np.where(valid, 1.0, np.nan)[None].repeat(2, axis=0)
    vol = TimeVolume.from_arrays({"rho": rho}, times=[0, 1])
    vol.valid = valid
    vol.check_finite = True
    assert vol.frame("rho", 0).shape == (4, 5, 6)  # NaN off the mesh is not an error
    save_volume(vol, tmp_path / "v.h5")
    back = open_volume(tmp_path / "v.h5")
    np.testing.assert_array_equal(back.valid, valid)
    assert back.valid_ratio == pytest.approx(4 / 6)
    from auralize.distributed.chunked import slab_volume
    from auralize.io.resample import resample_uniform

    with pytest.warns(ResampledWarning):
        fine = resample_uniform(back, (11, 9, 7))
    assert fine.valid is not None and fine.valid.shape == (7, 9, 11)
    # new x index 4 sits exactly on old index 2, the first valid one
    assert not fine.valid[:, :, :4].any() and fine.valid[:, :, 4:].all()
    assert slab_volume(back, 1, 3).valid.shape == (2, 5, 6)
    assert back.load().valid is not None


def test_lattice_order_finds_shuffled_grids() -> None:
    x, y, z = np.meshgrid(np.arange(4) * 0.5, np.arange(3) * 0.25, [1.0, 2.0], indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    perm = np.random.default_rng(0).permutation(len(pts))
    (origin, spacing, dims), order = lattice_order(pts[perm])
    assert dims == (4, 3, 2) and spacing.tolist() == [0.5, 0.25, 1.0]
    np.testing.assert_allclose(pts[perm][order][:4, 0], [0, 0.5, 1.0, 1.5])
    bent = pts.copy()
    bent[5, 0] += 0.1
    assert lattice_order(bent) is None


# --------------------------------------------------------------------------- CLI on each format
@pytest.mark.parametrize(
    ("path", "extra"),
    [
        (DOLFINX, ["--density-field", "f_5"]),
        (PULSE, []),
        (MESHIO, ["--density-field", "phi"]),
    ],
)
def test_cli_info_detect_render(path: Path, extra: list[str], tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "valid" in text and "field" in text and "t = " in text
    assert main(["info", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    src = tmp_path / "s.h5"
    assert main(["detect", str(path), "-o", str(src), "--json", *extra]) == 0
    det = json.loads(capsys.readouterr().out)
    assert len(det["steps"]) == info["n_steps"] and det["valid_ratio"] == info["valid_ratio"]
    # the pulse's velocity has fill values over a "land" corner: a masked fraction is reported
    assert (det["masked_fraction"] > 0) == (path == PULSE)
    centre = ",".join(f"{c:g}" for c in np.asarray(info["bounds"]).reshape(3, 2).mean(axis=1))
    wav = tmp_path / "a.wav"
    rc = main(
        [
            "render",
            str(path),
            "--sources",
            str(src),
            "--listener",
            centre,
            "--duration",
            "0.01",
            "--rate",
            "8000",
            "-o",
            str(wav),
            *extra,
        ]
    )
    assert rc == 0 and wav.exists()
    side = json.loads((tmp_path / "a.wav.json").read_text())
    assert side["volume"] == str(path)
    # dolfinx's f_5 and meshio's phi change linearly in time: a constant dρ/dt, whose
    # pressure is DC: inaudible, so 'auto' renders 'extended'
    if path != PULSE:
        assert side["timbre"] == "extended" and side["heard"] == "detected"


def test_cli_reports_missing_velocity(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "s.h5"
    assert main(["detect", str(DOLFINX), "--density-field", "f_5", "-o", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    assert captured.err.count("no dipole or quadrupole sources: no velocity field") == 1
    assert json.loads(captured.out)["unavailable"]["quadrupole"].startswith("no velocity field")
    from auralize.sources.sources_file import load_sources_h5

    assert "dipole" in load_sources_h5(out).meta["unavailable"]


def test_cli_ensight_info_and_single_step_detect(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["info", str(ENSIGHT)]) == 0
    out = capsys.readouterr().out
    assert "velocity (vector, point data)" in out and "mapping  incompressible (default" in out
    assert main(["detect", str(ENSIGHT), "-o", str(tmp_path / "s.h5")]) == 3  # a data error
    assert "needs at least 2 time steps" in capsys.readouterr().err


def test_render_refuses_sources_of_another_grid(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    src = tmp_path / "s.h5"
    assert main(["detect", str(PULSE), "-o", str(src)]) == 0
    args = [
        "render",
        str(PULSE),
        "--listener",
        "0.05,0.04,0.03",
        "--duration",
        "0.01",
        "-o",
        str(tmp_path / "a.wav"),
    ]
    assert main([*args, "--sources", str(src), "--resolution", "10"]) == 3  # a data error
    err = capsys.readouterr().err
    assert "do not belong to the grid" in err and "dims (20, 16, 12) vs (10, 8, 6)" in err
    assert main(["detect", str(PULSE), "-o", str(tmp_path / "s.pvd")]) == 0
    assert main([*args, "--sources", str(tmp_path / "s.pvd")]) == 3
    assert "--sources needs the .h5" in capsys.readouterr().err
    assert not (tmp_path / "a.wav").exists()


def test_netcdf_uneven_coordinates_are_resampled(tmp_path: Path) -> None:
    with netcdf_file(tmp_path / "uneven.nc", "w") as f:
        f.createDimension("time", 2)
        f.createDimension("x", 4)
        t = f.createVariable("time", "f8", ("time",))
        t.units = "seconds since 2001-01-01"
        t[:] = [0.0, 1.0]
        f.createVariable("x", "f8", ("x",))[:] = [0.0, 1.0, 3.0, 6.0]
        f.createVariable("rho", "f8", ("time", "x"))[:] = [[0.0, 1.0, 3.0, 6.0]] * 2
    native = open_volume(tmp_path / "uneven.nc")  # on its own points, by default
    assert native.curvilinear and native.points()[:, 0].tolist() == [0.0, 1.0, 3.0, 6.0]
    np.testing.assert_array_equal(native.frame("rho", 1).reshape(-1), [0.0, 1.0, 3.0, 6.0])
    with pytest.warns(ResampledWarning, match="RectilinearGrid with 4 points resampled"):
        vol = open_volume(tmp_path / "uneven.nc", curvilinear="resample")
    x = vol.points()[:, 0]
    np.testing.assert_allclose(vol.frame("rho", 1).reshape(-1), x, atol=1e-12)  # rho = x


def test_every_format_reads_the_same_series(tmp_path: Path) -> None:
    """The bench series written as HDF5, netCDF classic/4, XDMF, PLOT3D and EnSight
    reads back as the same grid, times and values in each format."""
    from auralize.bench.readers import write_series

    paths = write_series(tmp_path, 8, 3)
    assert set(paths) == {"hdf5", "netcdf-classic", "netcdf4", "xdmf", "plot3d", "ensight"}
    ref = open_volume(paths["hdf5"])
    for fmt, path in paths.items():
        vol = open_volume(path)
        assert vol.dims == (8, 8, 8) and vol.valid is None, fmt
        np.testing.assert_allclose(vol.spacing, ref.spacing, rtol=1e-6, err_msg=fmt)
        if fmt != "plot3d":  # PLOT3D holds no times
            np.testing.assert_allclose(vol.times, ref.times, rtol=1e-9, atol=1e-12, err_msg=fmt)
        name = "Density" if fmt == "plot3d" else "density"
        np.testing.assert_allclose(vol.frame(name, 2), ref.frame("density", 2), rtol=1e-6)
        if fmt != "plot3d":
            np.testing.assert_allclose(
                vol.frame("velocity", 1), ref.frame("velocity", 1), rtol=1e-6, atol=1e-9
            )


def test_cartesian_structured_grid_keeps_its_points(tmp_path: Path) -> None:
    x, y, z = np.meshgrid(np.arange(4) * 0.5, 1 + np.arange(3) * 0.25, [2.0, 3.0], indexing="ij")
    grid = pv.StructuredGrid(x, y, z)
    grid.point_data["rho"] = np.arange(grid.n_points, dtype=float)
    grid.save(tmp_path / "c.vts")
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResampledWarning)
        vol = open_volume(tmp_path / "c.vts")
    assert vol.dims == (4, 3, 2) and vol.spacing.tolist() == [0.5, 0.25, 1.0]
    assert vol.origin.tolist() == [0.0, 1.0, 2.0]
    np.testing.assert_array_equal(vol.frame("rho", 0).reshape(-1), np.arange(24.0))
    bent = pv.StructuredGrid(x + 0.05 * y, y, z)  # sheared: not axis-aligned
    bent.point_data["rho"] = np.zeros(bent.n_points)
    bent.save(tmp_path / "b.vts")
    assert open_volume(tmp_path / "b.vts").curvilinear  # read on its own points
    with pytest.warns(ResampledWarning, match="resampled"):
        open_volume(tmp_path / "b.vts", curvilinear="resample")


def test_exodus_through_pyvista_get_reader(tmp_path: Path) -> None:
    from vtkmodules.vtkIOExodus import vtkExodusIIWriter

    grid = pv.ImageData(dimensions=(4, 4, 3)).cast_to_unstructured_grid()
    grid.point_data["density"] = grid.points[:, 0] + 10 * grid.points[:, 2]
    writer = vtkExodusIIWriter()
    writer.SetFileName(str(tmp_path / "t.e"))
    writer.SetInputData(grid)
    writer.Write()
    vol = open_volume(tmp_path / "t.e")
    assert vol.dims == (4, 4, 3) and "density" in vol.field_names  # a lattice: native grid
    expected = (vol.points()[:, 0] + 10 * vol.points()[:, 2]).reshape(vol.shape)
    np.testing.assert_allclose(vol.frame("density", 0), expected)


def test_netcdf_climate_layout(tmp_path: Path) -> None:
    """A reanalysis-style file: hours since 1800, north-to-south latitude, a level axis of
    one, packed int16 with valid_range and missing_value, and bounds variables beside."""
    lat = np.arange(90.0, -91.0, -30.0)
    lon = np.arange(0.0, 360.0, 60.0)
    with netcdf_file(tmp_path / "air.nc", "w") as f:
        for name, size in (
            ("time", None),
            ("level", 1),
            ("lat", lat.size),
            ("lon", lon.size),
            ("nbnds", 2),
        ):
            f.createDimension(name, size)
        t = f.createVariable("time", "f8", ("time",))
        t.units = "hours since 1800-1-1 00:00:0.0"
        t[:] = [1753152.0, 1753158.0, 1753164.0]
        f.createVariable("time_bnds", "f8", ("time", "nbnds"))[:] = np.zeros((3, 2))
        for name, vals, units in (
            ("level", [1000.0], "millibar"),
            ("lat", lat, "degrees_north"),
            ("lon", lon, "degrees_east"),
        ):
            v = f.createVariable(name, "f4", (name,))
            v.units = units
            v[:] = vals
        air = f.createVariable("air", "i2", ("time", "level", "lat", "lon"))
        air.units = "degK"
        air.scale_factor = np.float32(0.01)
        air.add_offset = np.float32(512.81)
        air.missing_value = np.int16(32766)
        air.valid_range = np.array([-32765, -2515], dtype=np.int16)
        raw = np.full((3, 1, lat.size, lon.size), -24000, dtype=np.int16)
        raw[0, 0, 0, 0] = 32766  # missing
        raw[1, 0, 1, 1] = 0  # outside valid_range
        air[:] = raw
    vol = open_volume(tmp_path / "air.nc")
    assert vol.field_names == ["air"] and vol.dims == (6, 7, 1)
    np.testing.assert_allclose(np.diff(vol.times), [21600.0, 21600.0])  # 6 hours in seconds
    # latitude flipped to increasing, and in metres (R·φ), not degrees
    assert vol.origin[:2].tolist() == pytest.approx([0.0, -6371000.0 * np.pi / 2])
    a0, a1 = vol.frame("air", 0)[0], vol.frame("air", 1)[0]
    assert np.isnan(a0[-1, 0]) and np.count_nonzero(np.isnan(a0)) == 1  # 90°N is the last row
    assert np.isnan(a1[-2, 1]) and np.count_nonzero(np.isnan(a1)) == 1
    np.testing.assert_allclose(a0[0, 0], -24000 * 0.01 + 512.81, rtol=1e-6)
    assert vol.attrs["units"] == {"air": "degK"}
    assert vol.attrs["grid_units"] == ["degrees_east", "degrees_north", "millibar"]
