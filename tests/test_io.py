"""Readers and writers: HDF5 v1, generic HDF5, .pvd/.vti, .series, .vts, VTKHDF, OpenFOAM."""

from __future__ import annotations

import json
import os
import warnings
import zipfile
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
import pyvista as pv

from auralize.errors import DataError, FieldError, FormatError, ParameterError
from auralize.io import ResampledWarning, open_volume, save_volume
from auralize.io.hdf5 import HDF5Frames
from auralize.io.resample import grid_for_bounds
from auralize.volume import DEFAULT_FRAME_RATE_HZ, TimeVolume

CAVITY_ZIP = (
    Path(__file__).resolve().parents[1] / "auralize" / "data" / "openfoam-cavity" / "OpenFOAM.zip"
)


# --------------------------------------------------------------------------- helpers
def make_volume(*, n_steps: int = 3, dims: tuple[int, int, int] = (6, 5, 4)) -> TimeVolume:
    rng = np.random.default_rng(7)
    nx, ny, nz = dims
    return TimeVolume.from_arrays(
        {
            "rho": rng.normal(1.2, 0.1, (n_steps, nz, ny, nx)),
            "vel": rng.normal(0.0, 1.0, (n_steps, nz, ny, nx, 3)),
        },
        origin=(1.0, -2.0, 0.5),
        spacing=(0.1, 0.2, 0.25),
        times=np.cumsum(rng.uniform(0.01, 0.1, n_steps)),
    )


def assert_same_volume(a: TimeVolume, b: TimeVolume) -> None:
    assert a.dims == b.dims
    np.testing.assert_array_equal(a.times, b.times)
    np.testing.assert_allclose(a.origin, b.origin, rtol=0, atol=1e-15)
    np.testing.assert_allclose(a.spacing, b.spacing, rtol=1e-15)
    assert a.field_names == b.field_names
    for name in a.field_names:
        for step in range(a.n_steps):
            np.testing.assert_array_equal(a.frame(name, step), b.frame(name, step))


def write_v1(
    path: Path,
    fields: dict[str, np.ndarray],
    *,
    times: list[float] | np.ndarray,
    axes: str | None = None,
    version: object = 1,
    origin: object = (0.0, 0.0, 0.0),
    spacing: object = (1.0, 1.0, 1.0),
) -> None:
    """Write a format-v1 file by hand (independent of the writer under test)."""
    with h5py.File(path, "w") as f:
        f.attrs["auralize_format"] = "volume"
        if version is not None:
            f.attrs["version"] = version
        f["time"] = np.asarray(times, dtype=np.float64)
        grid = f.create_group("grid")
        grid.attrs["origin"] = origin
        grid.attrs["spacing"] = spacing
        for name, arr in fields.items():
            ds = f.create_dataset(f"fields/{name}", data=arr, chunks=(1, *arr.shape[1:]))
            if axes is not None:
                ds.attrs["axes"] = axes


def leftovers(folder: Path) -> list[str]:
    """Hidden temporary entries a writer might have left behind."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def warped_grid(n: tuple[int, int, int] = (9, 11, 7)) -> pv.StructuredGrid:
    """A curvilinear grid over [0,1]x[0,2]x[0,1] whose interior points are displaced."""
    u, v, w = (np.linspace(0.0, ext, k) for ext, k in zip((1.0, 2.0, 1.0), n, strict=True))
    uu, vv, ww = np.meshgrid(u, v, w, indexing="ij")
    bump = np.sin(np.pi * uu) * np.sin(np.pi * vv / 2.0) * np.sin(np.pi * ww)
    return pv.StructuredGrid(uu + 0.04 * bump, vv + 0.06 * bump, ww - 0.03 * bump)


# --------------------------------------------------------------------------- HDF5 v1
@pytest.mark.parametrize("compression", [None, "gzip"])
def test_hdf5_round_trip(tmp_path: Path, compression: str | None) -> None:
    vol = make_volume()
    out = tmp_path / "vol.h5"
    save_volume(vol, out, compression=compression)
    back = open_volume(out)
    assert_same_volume(vol, back)
    assert back.physical_times and back.source == str(out)
    with h5py.File(out, "r") as f:
        assert f.attrs["auralize_format"] == "volume" and f.attrs["version"] == 1
        assert f["fields/vel"].chunks == (1, 4, 5, 6, 3)
        assert f["fields/rho"].compression == compression
    assert leftovers(tmp_path) == []
    # A lazily read volume can be saved over its own file (temp file + rename).
    save_volume(back, out)
    assert_same_volume(vol, open_volume(out))


def test_hdf5_round_trip_keeps_frame_rate_times(tmp_path: Path) -> None:
    vol = TimeVolume.from_arrays({"p": np.zeros((4, 2, 3, 4)), "a": np.ones((4, 2, 3, 4))})
    save_volume(vol, tmp_path / "p.hdf5")
    back = open_volume(tmp_path / "p.hdf5")
    assert not back.physical_times
    assert back.field_names == ["p", "a"]  # creation order, not alphabetical
    np.testing.assert_array_equal(back.times, np.arange(4) / DEFAULT_FRAME_RATE_HZ)


@pytest.mark.parametrize("axes", [None, "tzyx", "txyz"])
def test_hdf5_axes_orders(tmp_path: Path, axes: str | None) -> None:
    vol = make_volume()
    rho = np.stack(list(vol.iter_frames("rho")))  # (T, nz, ny, nx)
    vel = np.stack(list(vol.iter_frames("vel")))  # (T, nz, ny, nx, 3)
    if axes == "txyz":
        stored = {"rho": rho.transpose(0, 3, 2, 1), "vel": vel.transpose(0, 3, 2, 1, 4)}
    else:
        stored = {"rho": rho, "vel": vel}
    path = tmp_path / "axes.h5"
    write_v1(path, stored, times=vol.times, axes=axes, origin=vol.origin, spacing=vol.spacing)
    back = open_volume(path)
    assert_same_volume(vol, back)
    assert back.frame("vel", 1).flags.c_contiguous


def test_hdf5_reads_lazily(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "lazy.h5"
    save_volume(make_volume(), path)
    calls: list[tuple[str, int]] = []
    original = HDF5Frames.read

    def counting(self: HDF5Frames, step: int) -> np.ndarray:
        calls.append((self.dataset, step))
        return original(self, step)

    monkeypatch.setattr(HDF5Frames, "read", counting)
    vol = open_volume(path)
    assert isinstance(vol.fields["rho"], HDF5Frames)
    assert calls == []
    vol.frame("rho", 2)
    assert calls == [("/fields/rho", 2)]
    # The file is opened per read: data changed on disk after opening is seen.
    with h5py.File(path, "r+") as f:
        f["fields/rho"][1] = 42.0
    assert np.all(vol.frame("rho", 1) == 42.0)


def test_hdf5_writer_is_atomic(tmp_path: Path) -> None:
    good = make_volume()
    out = tmp_path / "out.h5"
    save_volume(good, out)
    before = out.read_bytes()
    rho = np.ones((3, 2, 2, 2))
    rho[2, 0, 0, 0] = np.nan
    bad = TimeVolume.from_arrays({"rho": rho}, times=[0.0, 1.0, 2.0])
    with pytest.raises(DataError, match="NaN"):
        save_volume(bad, out)
    assert out.read_bytes() == before
    with pytest.raises(DataError, match="NaN"):
        save_volume(bad, tmp_path / "new.h5")
    assert not (tmp_path / "new.h5").exists()
    assert leftovers(tmp_path) == []


# --------------------------------------------------------------------------- generic HDF5
def test_generic_hdf5_named_datasets(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    rho = rng.random((5, 2, 3, 4))
    vel_xyz = rng.random((5, 4, 3, 2, 3))  # (T, nx, ny, nz, 3)
    path = tmp_path / "sim.h5"
    with h5py.File(path, "w") as f:
        f["run/rho"] = rho
        f["run/vel"] = vel_xyz
        f["run/vel"].attrs["axes"] = "txyz"
        f["run/t"] = np.linspace(0.0, 0.4, 5)
        f["run"].attrs["lower_corner"] = [1.0, 2.0, 3.0]
    vol = open_volume(
        path,
        fields={
            "density": "/run/rho",
            "velocity": "/run/vel",
            "time": "/run/t",
            "origin": "/run@lower_corner",
            "spacing": 0.5,
        },
    )
    assert vol.field_names == ["density", "velocity"]
    assert vol.dims == (4, 3, 2) and vol.physical_times
    np.testing.assert_array_equal(vol.times, np.linspace(0.0, 0.4, 5))
    np.testing.assert_array_equal(vol.origin, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(vol.spacing, [0.5, 0.5, 0.5])
    np.testing.assert_array_equal(vol.frame("density", 3), rho[3])
    np.testing.assert_array_equal(vol.frame("velocity", 4), vel_xyz[4].transpose(2, 1, 0, 3))


def test_generic_hdf5_defaults_and_attrs(tmp_path: Path) -> None:
    path = tmp_path / "plain.h5"
    with h5py.File(path, "w") as f:
        f["rho"] = np.ones((3, 2, 2, 2))
        f["q"] = np.ones((3, 2, 2, 2))
        f["q"].attrs["spacing"] = [0.1, 0.2, 0.3]
    vol = open_volume(path, fields={"rho": "/rho"}, name_map={"rho": "density"})
    assert vol.field_names == ["density"] and not vol.physical_times
    np.testing.assert_array_equal(vol.times, np.arange(3) / DEFAULT_FRAME_RATE_HZ)
    np.testing.assert_array_equal(vol.spacing, [1.0, 1.0, 1.0])
    np.testing.assert_array_equal(vol.origin, [0.0, 0.0, 0.0])
    assert open_volume(path, fields={"q": "q"}).spacing.tolist() == [0.1, 0.2, 0.3]
    with pytest.raises(FormatError, match=r"not an auralize volume file.*'/q'"):
        open_volume(path)
    with pytest.raises(FieldError, match=r"no dataset '/nope' for field 'x'.*/rho"):
        open_volume(path, fields={"x": "/nope"})


# --------------------------------------------------------------------------- .pvd / .vti
def test_pvd_round_trip(tmp_path: Path) -> None:
    vol = make_volume(n_steps=4)
    out = tmp_path / "run.pvd"
    save_volume(vol, out)
    files = sorted(p.name for p in (tmp_path / "run_data").iterdir())
    assert files == [".auralize-data.json"] + [f"run_{n:04d}.vti" for n in range(4)]
    assert leftovers(tmp_path) == []
    back = open_volume(out)
    assert_same_volume(vol, back)
    image = pv.read(tmp_path / "run_data" / "run_0002.vti")
    assert image.dimensions == vol.dims
    # overwrite: the new folder takes the next free name, the old one goes
    save_volume(make_volume(n_steps=2), out, compression="gzip")
    assert not (tmp_path / "run_data").exists()
    assert len(list((tmp_path / "run_data.1").glob("*.vti"))) == 2
    assert open_volume(out).n_steps == 2
    assert leftovers(tmp_path) == []


def test_pvd_reads_one_step_per_read(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "run.pvd"
    save_volume(make_volume(n_steps=4), out)
    reads: list[str] = []
    original = pv.read

    def counting(filename: str, *args: Any, **kwargs: Any) -> Any:
        reads.append(Path(filename).name)
        return original(filename, *args, **kwargs)

    monkeypatch.setattr(pv, "read", counting)
    vol = open_volume(out, name_map={"rho": "density"})
    assert reads == ["run_0000.vti"]  # step 0 only, to learn the grid and arrays
    assert vol.field_names == ["density", "vel"]
    vol.frame("density", 3)
    vol.frame("vel", 3)  # same step: no second load
    assert reads == ["run_0000.vti", "run_0003.vti"]


def test_pvd_writer_is_atomic(tmp_path: Path) -> None:
    rho = np.ones((3, 2, 2, 2))
    rho[1, 1, 1, 1] = np.inf
    bad = TimeVolume.from_arrays({"rho": rho}, times=[0.0, 1.0, 2.0])
    with pytest.raises(DataError, match="NaN/Inf"):
        save_volume(bad, tmp_path / "bad.pvd")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "mine_data").mkdir()
    (tmp_path / "mine_data" / "notes.txt").write_text("keep me")
    with pytest.raises(FileExistsError, match=r"notes\.txt"):
        save_volume(make_volume(), tmp_path / "mine.pvd")
    assert (tmp_path / "mine_data" / "notes.txt").read_text() == "keep me"
    assert not (tmp_path / "mine.pvd").exists()


def test_pvd_steps_must_share_a_grid(tmp_path: Path) -> None:
    for n, dims in enumerate([(3, 3, 3), (4, 3, 3)]):
        image = pv.ImageData(dimensions=dims)
        image.point_data["f"] = np.zeros(image.n_points)
        image.save(tmp_path / f"s{n}.vti")
    (tmp_path / "s.pvd").write_text(
        '<VTKFile type="Collection"><Collection>'
        '<DataSet timestep="0" file="s0.vti"/><DataSet timestep="1" file="s1.vti"/>'
        "</Collection></VTKFile>"
    )
    vol = open_volume(tmp_path / "s.pvd")
    vol.frame("f", 0)
    with pytest.raises(DataError, match=r"s1\.vti.*first time step has 3x3x3"):
        vol.frame("f", 1)


def test_pvd_missing_step_file(tmp_path: Path) -> None:
    (tmp_path / "m.pvd").write_text(
        '<VTKFile type="Collection"><Collection>'
        '<DataSet timestep="0" file="gone.vti"/></Collection></VTKFile>'
    )
    with pytest.raises(FormatError, match=r"m\.pvd.*'gone\.vti' does not exist"):
        open_volume(tmp_path / "m.pvd")


# --------------------------------------------------------------------------- .series
def test_series_of_vti(tmp_path: Path) -> None:
    times = [0.25, 0.0, 0.5]  # listed out of order: read in time order
    for n, t in enumerate(times):
        image = pv.ImageData(dimensions=(5, 4, 3), spacing=(0.5, 0.25, 1.0), origin=(0, 1, 2))
        image.point_data["T"] = np.arange(image.n_points, dtype=float) * (1 + t)
        image.cell_data["c"] = np.full(image.n_cells, t)  # cell data -> point data
        image.save(tmp_path / f"img_{n}.vti")
    series = {
        "file-series-version": "1.0",
        "files": [{"name": f"img_{n}.vti", "time": t} for n, t in enumerate(times)],
    }
    (tmp_path / "img.vti.series").write_text(json.dumps(series))
    vol = open_volume(tmp_path / "img.vti.series")
    np.testing.assert_array_equal(vol.times, [0.0, 0.25, 0.5])
    assert vol.dims == (5, 4, 3) and vol.field_names == ["T", "c"]
    np.testing.assert_array_equal(vol.origin, [0, 1, 2])
    np.testing.assert_array_equal(vol.spacing, [0.5, 0.25, 1.0])
    np.testing.assert_array_equal(vol.frame("T", 2), np.arange(60.0).reshape(3, 4, 5) * 1.5)
    np.testing.assert_allclose(vol.frame("c", 1), 0.25)


def test_series_bad_input(tmp_path: Path) -> None:
    image = pv.ImageData(dimensions=(2, 2, 2))
    image.point_data["f"] = np.zeros(8)
    image.save(tmp_path / "a.vti")
    path = tmp_path / "a.vti.series"
    path.write_text(
        json.dumps({"files": [{"name": "a.vti", "time": 0}, {"name": "a.vti", "time": 0}]})
    )
    with pytest.raises(DataError, match=r"same time=0\.0"):
        open_volume(path)
    path.write_text("{not json")
    with pytest.raises(FormatError, match=r"a\.vti\.series: not a valid \.series"):
        open_volume(path)


# --------------------------------------------------------------------------- .vts, resampled
def test_vts_curvilinear_is_resampled(tmp_path: Path) -> None:
    """Read with curvilinear='resample' (the default reads it natively, tests/test_curvilinear.py)."""
    grid = warped_grid()
    entries = []
    for n, scale in enumerate([1.0, 2.0]):
        grid.point_data["f"] = scale * (grid.points @ np.array([1.0, 2.0, 3.0]))
        grid.point_data["v"] = scale * grid.points
        grid.save(tmp_path / f"g_{n}.vts")
        entries.append({"name": f"g_{n}.vts", "time": 0.1 * n})
    path = tmp_path / "g.vts.series"
    path.write_text(json.dumps({"file-series-version": "1.0", "files": entries}))

    native = open_volume(path)
    assert native.curvilinear and native.dims == (9, 11, 7)
    np.testing.assert_allclose(
        native.frame("f", 1).reshape(-1),
        2.0 * (grid.points @ np.array([1.0, 2.0, 3.0])),
        rtol=1e-12,
    )
    with pytest.warns(ResampledWarning, match=r"StructuredGrid with 693 points resampled") as rec:
        vol = open_volume(path, curvilinear="resample")
    assert rec[0].filename == __file__  # attributed to the caller of open_volume
    nx, ny, nz = vol.dims
    assert max(vol.dims) <= 128 and 0.5 * 693 <= nx * ny * nz <= 2 * 693
    np.testing.assert_allclose(vol.bounds, (0, 1, 0, 2, 0, 1), atol=1e-12)
    exact = (vol.points() @ np.array([1.0, 2.0, 3.0])).reshape(vol.shape)
    for step, scale in enumerate([1.0, 2.0]):
        np.testing.assert_allclose(vol.frame("f", step), scale * exact, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(
        vol.frame("v", 1), 2.0 * vol.points().reshape((*vol.shape, 3)), rtol=1e-6, atol=1e-9
    )

    with pytest.warns(ResampledWarning, match=r"onto a uniform grid of 5x9x3 points"):
        coarse = open_volume(tmp_path / "g_0.vts", resolution=(5, 9, 3), fields="f")
    assert coarse.dims == (5, 9, 3) and not coarse.physical_times
    exact = (coarse.points() @ np.array([1.0, 2.0, 3.0])).reshape(coarse.shape)
    np.testing.assert_allclose(coarse.frame("f", 0), exact, rtol=1e-6, atol=1e-9)


def test_resolution_on_uniform_hdf5(tmp_path: Path) -> None:
    x, y, z = np.meshgrid(np.arange(9.0), np.arange(7.0), np.arange(5.0), indexing="ij")
    lin = (x + 2 * y + 3 * z).transpose(2, 1, 0)[None]  # (1, nz, ny, nx)
    vol = TimeVolume.from_arrays({"f": lin}, times=[0.0])
    save_volume(vol, tmp_path / "lin.h5")
    assert open_volume(tmp_path / "lin.h5", resolution=9).dims == (9, 7, 5)  # no change
    with pytest.warns(ResampledWarning, match="resampled the uniform 9x7x5 grid"):
        small = open_volume(tmp_path / "lin.h5", resolution=5)
    assert small.dims == (5, 4, 3)
    exact = (small.points() @ np.array([1.0, 2.0, 3.0])).reshape(small.shape)
    np.testing.assert_allclose(small.frame("f", 0), exact, rtol=1e-12)


def test_grid_for_bounds() -> None:
    _, spacing, dims = grid_for_bounds(
        (0, 1, 0, 1, 0, 0), n_points=100, resolution=None, source="x"
    )
    assert dims[2] == 1 and 81 <= dims[0] * dims[1] <= 121 and spacing[2] > 0
    _, _, dims = grid_for_bounds((0, 1e3, 0, 1, 0, 1), n_points=10**9, resolution=None, source="x")
    assert dims[0] == 128
    with pytest.raises(ParameterError, match="zero extent"):
        grid_for_bounds((0, 1, 0, 1, 0, 0), n_points=8, resolution=(4, 4, 4), source="x")


# --------------------------------------------------------------------------- VTKHDF
def test_vtkhdf_temporal_image(tmp_path: Path) -> None:
    nx, ny, nz, n_steps = 4, 3, 2, 3
    rho = np.arange(n_steps * nz * ny * nx, dtype=float).reshape(n_steps, nz, ny, nx)
    path = tmp_path / "img.vtkhdf"
    with h5py.File(path, "w") as f:
        root = f.create_group("VTKHDF")
        root.attrs["Version"] = np.array([2, 1], dtype="i8")
        root.attrs.create("Type", np.bytes_("ImageData"))
        root.attrs["WholeExtent"] = np.array([0, nx - 1, 0, ny - 1, 0, nz - 1], dtype="i8")
        root.attrs["Origin"] = np.array([0.0, 1.0, 2.0])
        root.attrs["Spacing"] = np.array([0.5, 0.5, 0.5])
        root.attrs["Direction"] = np.eye(3).ravel()
        root["PointData/rho"] = rho
        steps = root.create_group("Steps")
        steps.attrs["NSteps"] = n_steps
        steps["Values"] = np.array([0.0, 0.5, 1.0])
        steps["PointDataOffsets/rho"] = np.arange(n_steps, dtype="i8")
    vol = open_volume(path)
    np.testing.assert_array_equal(vol.times, [0.0, 0.5, 1.0])
    assert vol.dims == (4, 3, 2) and vol.physical_times
    np.testing.assert_array_equal(vol.origin, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(vol.frame("rho", 2), rho[2])
    np.testing.assert_array_equal(vol.frame("rho", 0), rho[0])


# --------------------------------------------------------------------------- OpenFOAM
def test_openfoam_cavity(tmp_path: Path) -> None:
    with zipfile.ZipFile(CAVITY_ZIP) as z:
        z.extractall(tmp_path)
    case = tmp_path / "OpenFOAM" / "cavity"
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResampledWarning)  # a blockMesh box keeps its lattice
        vol = open_volume(case / "case.foam")
    assert vol.dims == (21, 21, 2) and vol.valid is None and vol.valid_ratio == 1.0
    np.testing.assert_allclose(vol.spacing, [0.005, 0.005, 0.01], rtol=1e-6)
    np.testing.assert_allclose(vol.times, [0.0, 0.5, 1.0, 1.5, 2.0, 2.5])
    assert vol.physical_times and set(vol.field_names) == {"U", "p"}
    assert vol.is_vector("U") and not vol.is_vector("p")
    np.testing.assert_allclose(vol.bounds, (0, 0.1, 0, 0.1, 0, 0.01), atol=1e-7)
    u = vol.frame("U", 5)
    nx, ny, nz = vol.dims
    assert u.shape == (nz, ny, nx, 3)
    assert np.all(np.isfinite(u)) and 0.5 < np.abs(u[..., 0]).max() <= 1.0 + 1e-6
    assert vol.frame("p", 3).shape == (nz, ny, nx)
    # The case folder works too, with a chosen resolution and a field subset.
    with pytest.warns(ResampledWarning, match="21x21x2 grid onto 11x11x2 points"):
        sub = open_volume(case, fields=["U"], resolution=(11, 11, 2))
    assert sub.field_names == ["U"] and sub.frame("U", 1).shape == (2, 11, 11, 3)


# --------------------------------------------------------------------------- bad input
def test_nonexistent_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"nope\.h5.*no such file"):
        open_volume(tmp_path / "nope.h5")


def test_corrupt_and_truncated_hdf5(tmp_path: Path) -> None:
    junk = tmp_path / "junk.h5"
    junk.write_bytes(np.random.default_rng(0).bytes(4096))
    with pytest.raises(FormatError, match=r"junk\.h5: not an HDF5 file"):
        open_volume(junk)
    good = tmp_path / "good.h5"
    save_volume(make_volume(), good)
    cut = tmp_path / "cut.h5"
    cut.write_bytes(good.read_bytes()[: os.path.getsize(good) // 2])
    with pytest.raises(FormatError, match=r"cut\.h5: .*truncated"):
        open_volume(cut)


def test_wrong_version_and_missing_metadata(tmp_path: Path) -> None:
    f = {"rho": np.ones((2, 2, 2, 2))}
    write_v1(tmp_path / "v2.h5", f, times=[0, 1], version=2)
    with pytest.raises(FormatError, match=r"v2\.h5: volume format version '2' is not supported"):
        open_volume(tmp_path / "v2.h5")
    write_v1(tmp_path / "nov.h5", f, times=[0, 1], version=None)
    with pytest.raises(FormatError, match=r"nov\.h5: root attribute 'version' is missing"):
        open_volume(tmp_path / "nov.h5")
    write_v1(tmp_path / "badorigin.h5", f, times=[0, 1], origin=[0.0, 1.0])
    with pytest.raises(FormatError, match=r"/grid\.origin must be 3 finite numbers"):
        open_volume(tmp_path / "badorigin.h5")


def test_unknown_field_name(tmp_path: Path) -> None:
    save_volume(make_volume(), tmp_path / "v.h5")
    with pytest.raises(FieldError, match=r"no field 'pressure'; available fields: 'rho', 'vel'"):
        open_volume(tmp_path / "v.h5", fields=["pressure"])
    save_volume(make_volume(), tmp_path / "v.pvd")
    with pytest.raises(FieldError, match=r"v\.pvd: no field 'pressure'"):
        open_volume(tmp_path / "v.pvd", fields={"p": "pressure"})


def test_non_increasing_times(tmp_path: Path) -> None:
    write_v1(tmp_path / "t.h5", {"rho": np.ones((3, 2, 2, 2))}, times=[0.0, 0.2, 0.2])
    with pytest.raises(DataError, match=r"t\.h5: times must be strictly increasing"):
        open_volume(tmp_path / "t.h5")


def test_nan_field_raises_on_read(tmp_path: Path) -> None:
    rho = np.ones((3, 2, 2, 2))
    rho[1, 0, 1, 0] = np.nan
    write_v1(tmp_path / "nan.h5", {"rho": rho}, times=[0.0, 0.1, 0.2])
    vol = open_volume(tmp_path / "nan.h5", nan="error")  # lazy: opening reads no values
    vol.frame("rho", 0)
    with pytest.raises(DataError, match=r"nan\.h5: field 'rho' at step 1 .* 1 NaN/Inf"):
        vol.frame("rho", 1)
    # The default keeps NaN as no-data.
    masked = open_volume(tmp_path / "nan.h5")
    assert np.count_nonzero(np.isnan(masked.frame("rho", 1))) == 1
    with pytest.raises(ParameterError, match=r"nan='drop'; valid are mask, error"):
        open_volume(tmp_path / "nan.h5", nan="drop")


def test_mismatched_field_shapes(tmp_path: Path) -> None:
    fields = {"rho": np.ones((2, 2, 3, 4)), "p": np.ones((2, 2, 3, 5))}
    write_v1(tmp_path / "mm.h5", fields, times=[0.0, 1.0])
    with pytest.raises(DataError, match=r"mm\.h5: field 'rho' has frame shape \(2, 3, 4\)"):
        open_volume(tmp_path / "mm.h5")
    write_v1(tmp_path / "steps.h5", {"rho": np.ones((3, 2, 2, 2))}, times=[0.0, 1.0])
    with pytest.raises(DataError, match=r"3 time steps but /time has 2"):
        open_volume(tmp_path / "steps.h5")


def test_bad_arguments_and_kinds(tmp_path: Path) -> None:
    save_volume(make_volume(), tmp_path / "v.h5")
    with pytest.raises(ParameterError, match=r"resolution=1 is too small"):
        open_volume(tmp_path / "v.h5", resolution=1)
    with pytest.raises(ParameterError, match="gives more than one field the name"):
        open_volume(tmp_path / "v.h5", name_map={"rho": "x", "vel": "x"})
    (tmp_path / "v.abc").write_text("1 2 3")
    with pytest.raises(
        FormatError, match=r"v\.abc: unknown file kind '\.abc'.*\.nc.*meshio convert"
    ):
        open_volume(tmp_path / "v.abc")
    (tmp_path / "v.xyz").write_text("1 2 3")
    with pytest.raises(FormatError, match=r"v\.xyz: a PLOT3D grid file, but no solution"):
        open_volume(tmp_path / "v.xyz")
    with pytest.raises(FormatError, match=r"cannot write '\.csv' files"):
        save_volume(make_volume(), tmp_path / "v.csv")
    (tmp_path / "empty").mkdir()
    with pytest.raises(FormatError, match="not an OpenFOAM case"):
        open_volume(tmp_path / "empty")


# --------------------------------------------------------------------------- new readers
REAL = Path(__file__).resolve().parents[1] / "auralize" / "data"


def _copy_dataset(folder: str, tmp_path: Path) -> Path:
    import shutil

    dest = tmp_path / folder
    shutil.copytree(REAL / folder, dest)
    for f in dest.rglob("*"):
        f.chmod(0o644 if f.is_file() else 0o755)
    return dest


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


@pytest.mark.parametrize(
    ("folder", "opened", "cut", "message"),
    [
        (
            "xdmf-timeseries",
            "dolfinx/no_checkpoint.xdmf",
            "dolfinx/no_checkpoint.h5",
            r"no_checkpoint\.xdmf: its heavy-data file .*no_checkpoint\.h5 cannot be read as HDF5 "
            r".*truncated",
        ),
        (
            "xdmf-timeseries",
            "dolfinx/no_checkpoint.xdmf",
            "dolfinx/no_checkpoint.xdmf",
            r"no_checkpoint\.xdmf: not a valid XDMF file .*truncated",
        ),
        (
            "netcdf-pulse",
            "pulse.nc",
            "pulse.nc",
            r"pulse\.nc: cannot read as netCDF classic .*truncated",
        ),
        (
            "ensight-cylinder",
            "cylinder_Re35.case",
            "cylinder_Re35.geo",
            r"cylinder_Re35\.case: VTK's EnSight reader failed .*truncated or corrupt",
        ),
        (
            "plot3d-combustor",
            "combxyz.bin",
            "combq.bin",
            r"combq\.bin: VTK's PLOT3D reader returned no data .* truncated",
        ),
    ],
)
def test_new_readers_truncated_files(
    folder: str, opened: str, cut: str, message: str, tmp_path: Path
) -> None:
    root = _copy_dataset(folder, tmp_path)
    _truncate(root / cut)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        with pytest.raises(FormatError, match=message):
            vol = open_volume(root / opened)
            vol.frame(vol.field_names[0], vol.n_steps - 1)


def test_new_readers_truncated_netcdf4(tmp_path: Path) -> None:
    path = tmp_path / "w.nc"
    with h5py.File(path, "w") as f:
        t = f.create_dataset("time", data=np.arange(3.0))
        t.make_scale("time")
        t.attrs["units"] = "s"
        x = f.create_dataset("x", data=np.arange(4.0))
        x.make_scale("x")
        d = f.create_dataset("rho", data=np.ones((3, 4)))
        d.dims[0].attach_scale(t)
        d.dims[1].attach_scale(x)
    _truncate(path)
    with pytest.raises(FormatError, match=r"w\.nc: .*truncated"):
        open_volume(path)


@pytest.mark.parametrize(
    ("folder", "opened", "available"),
    [
        ("xdmf-timeseries", "meshio/out.xdmf", "'phi', 'u', 'a'"),
        ("netcdf-pulse", "pulse.nc", "'density', 'u', 'v', 'w', 'velocity'"),
        ("ensight-cylinder", "cylinder_Re35.case", "'pressure', 'vorticity_mag', 'velocity'"),
        ("plot3d-combustor", "combxyz.bin", "'Density', 'Momentum', 'StagnationEnergy'"),
    ],
)
def test_new_readers_unknown_field(folder: str, opened: str, available: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        with pytest.raises(FieldError, match=rf"no field 'nope'; available fields: {available}"):
            open_volume(REAL / folder / opened, fields=["nope"])


def test_new_readers_missing_time_axis(tmp_path: Path) -> None:
    from scipy.io import netcdf_file

    # netCDF: a time coordinate without units is refused; no time dimension is one step
    with netcdf_file(tmp_path / "nounits.nc", "w") as f:
        f.createDimension("time", 2)
        f.createDimension("x", 3)
        f.createVariable("time", "f8", ("time",))[:] = [0.0, 1.0]
        f.createVariable("rho", "f8", ("time", "x"))[:] = np.ones((2, 3))
    with pytest.raises(
        FormatError, match=r"nounits\.nc: the time coordinate 'time' has no 'units'"
    ):
        open_volume(tmp_path / "nounits.nc")
    with netcdf_file(tmp_path / "static.nc", "w") as f:
        f.createDimension("x", 3)
        f.createVariable("rho", "f8", ("x",))[:] = [1.0, 2.0, 3.0]
    vol = open_volume(tmp_path / "static.nc")
    assert vol.n_steps == 1 and not vol.physical_times and vol.dims == (3, 1, 1)
    # XDMF without <Time>: one step, frames at 30 Hz
    text = (REAL / "xdmf-timeseries" / "meshio" / "out.xdmf").read_text()
    import re

    static = re.sub(r"<Time Value=\"[^\"]*\" />", "", text)
    for name in ("out.h5",):
        (tmp_path / name).write_bytes((REAL / "xdmf-timeseries" / "meshio" / name).read_bytes())
    (tmp_path / "static.xdmf").write_text(static)
    vol = open_volume(tmp_path / "static.xdmf")
    assert not vol.physical_times
    # PLOT3D has no times at all: its .q files are frames at 30 Hz
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        vol = open_volume(REAL / "plot3d-combustor" / "combxyz.bin")
    assert not vol.physical_times and vol.times.tolist() == [0.0]
