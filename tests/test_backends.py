"""Readers as backends: chosen by content (then suffix), and plugins by entry point."""

from __future__ import annotations

import importlib.metadata
import json
import logging
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path

import h5py
import numpy as np
import pytest
import pyvista as pv
from scipy.io import netcdf_file

from auralize.errors import FormatError
from auralize.io import backends as B
from auralize.io import open_volume, save_volume
from auralize.volume import TimeVolume

DATA = Path(__file__).resolve().parents[1] / "auralize" / "data"


def small_volume(n_steps: int = 2) -> TimeVolume:
    rho = np.arange(n_steps * 4 * 3 * 2, dtype=float).reshape(n_steps, 4, 3, 2)
    return TimeVolume.from_arrays(
        {"rho": rho}, spacing=(0.5, 0.5, 0.5), times=np.arange(n_steps) * 0.1
    )


# --------------------------------------------------------------------------- Exodus II
def write_exodus(path: Path, *, n_steps: int = 3) -> None:
    """A 2x2x2 block of HEX8 elements (27 nodes) with a nodal field ``temp`` over time.

    Exodus II is netCDF: written here as classic netCDF (CDF-2) with scipy.
    """
    n = 3
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    node = (i + n * j + n * n * k).ravel()  # node number (0-based) of each (i, j, k)
    xyz = np.zeros((27, 3))
    xyz[node] = np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1) * 0.5
    conn = []
    for c in range(2):
        for b in range(2):
            for a in range(2):
                corners = [
                    (0, 0, 0),
                    (1, 0, 0),
                    (1, 1, 0),
                    (0, 1, 0),
                    (0, 0, 1),
                    (1, 0, 1),
                    (1, 1, 1),
                    (0, 1, 1),
                ]
                conn.append(
                    [(a + da) + n * (b + db) + n * n * (c + dc) + 1 for da, db, dc in corners]
                )

    def names(*words: str) -> np.ndarray:
        out = np.zeros((len(words), 33), dtype="S1")
        for r, w in enumerate(words):
            out[r, : len(w)] = list(w)
        return out

    f = netcdf_file(str(path), "w", version=2)
    try:
        f.api_version = np.float32(8.11)
        f.version = np.float32(8.11)
        f.floating_point_word_size = np.int32(8)
        f.file_size = np.int32(1)
        f.title = b"auralize test block"
        f.createDimension("time_step", None)  # unlimited: scipy wants it first
        for dim, size in (
            ("len_string", 33),
            ("len_line", 81),
            ("four", 4),
            ("len_name", 33),
            ("num_dim", 3),
            ("num_nodes", 27),
            ("num_elem", 8),
            ("num_el_blk", 1),
            ("num_el_in_blk1", 8),
            ("num_nod_per_el1", 8),
            ("num_nod_var", 1),
        ):
            f.createDimension(dim, size)
        f.createVariable("eb_status", "i", ("num_el_blk",))[:] = [1]
        prop = f.createVariable("eb_prop1", "i", ("num_el_blk",))
        prop[:] = [1]
        prop.name = b"ID"
        for axis, name in enumerate(("coordx", "coordy", "coordz")):
            f.createVariable(name, "d", ("num_nodes",))[:] = xyz[:, axis]
        f.createVariable("coor_names", "c", ("num_dim", "len_name"))[:] = names("x", "y", "z")
        connect = f.createVariable("connect1", "i", ("num_el_in_blk1", "num_nod_per_el1"))
        connect[:] = np.array(conn, dtype=np.int32)
        connect.elem_type = b"HEX8"
        f.createVariable("name_nod_var", "c", ("num_nod_var", "len_name"))[:] = names("temp")
        time = f.createVariable("time_whole", "d", ("time_step",))
        values = f.createVariable("vals_nod_var1", "d", ("time_step", "num_nodes"))
        for s in range(n_steps):
            time[s] = 0.5 * s
            values[s] = xyz[:, 0] + 10.0 * s
    finally:
        f.close()


def test_handmade_exodus_is_read_by_vtk(tmp_path: Path) -> None:
    path = tmp_path / "case.exo"
    write_exodus(path)
    reader = pv.get_reader(str(path))
    assert list(reader.time_values) == [0.0, 0.5, 1.0]
    block = reader.read().combine()
    assert block.n_points == 27 and block.n_cells == 8 and "temp" in block.point_data


@pytest.mark.parametrize("name", ["case.nc", "case.exo"])
def test_exodus_goes_to_the_exodus_reader_whatever_its_suffix(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    write_exodus(path)
    assert B.choose(path).name == "exodus"  # type: ignore[union-attr]
    vol = open_volume(path)
    assert vol.attrs["reader"] == "exodus"
    assert "temp" in vol.field_names and "connect1" not in vol.field_names
    assert "27 points" in str(vol.attrs["mesh"]) and tuple(vol.dims) == (3, 3, 3)
    np.testing.assert_allclose(vol.times, [0.0, 0.5, 1.0])
    x = vol.origin[0] + vol.spacing[0] * np.arange(3)
    np.testing.assert_allclose(vol.frame("temp", 2), np.broadcast_to(x + 20.0, (3, 3, 3)))


def test_classic_header_names(tmp_path: Path) -> None:
    write_exodus(tmp_path / "case.nc")
    header = B.netcdf_classic_header(tmp_path / "case.nc")
    assert header is not None and header.version == 2
    assert {"num_dim", "num_nodes", "time_step"} <= header.dimensions
    assert {"api_version", "version", "title"} <= header.attributes
    assert {"coordx", "connect1", "vals_nod_var1"} <= header.variables
    cf = B.netcdf_classic_header(DATA / "netcdf-pulse" / "pulse.nc")
    assert cf is not None and not B._exodus_names(cf.dimensions, cf.attributes, cf.variables)
    (tmp_path / "cut.nc").write_bytes((tmp_path / "case.nc").read_bytes()[:40])
    assert B.netcdf_classic_header(tmp_path / "cut.nc") is None
    assert B.is_netcdf(tmp_path / "cut.nc")  # the magic is enough: the reader says what is wrong


# --------------------------------------------------------------------------- misleading suffixes
def test_vtkhdf_named_h5_opens_as_vtkhdf(tmp_path: Path) -> None:
    save_volume(small_volume(), tmp_path / "v.vtkhdf")
    (tmp_path / "v.vtkhdf").rename(tmp_path / "v.h5")
    vol = open_volume(tmp_path / "v.h5")
    assert vol.attrs["reader"] == "vtkhdf"
    np.testing.assert_allclose(vol.frame("rho", 1), small_volume().frame("rho", 1))


def test_auralize_volume_named_hdf_opens_as_auralize(tmp_path: Path) -> None:
    save_volume(small_volume(), tmp_path / "v.h5")
    (tmp_path / "v.h5").rename(tmp_path / "v.hdf")
    vol = open_volume(tmp_path / "v.hdf")
    assert vol.attrs["reader"] == "auralize-hdf5" and vol.field_names == ["rho"]
    np.testing.assert_allclose(vol.times, [0.0, 0.1])


@pytest.mark.parametrize("name", ["pulse.dat", "pulse.h5", "pulse"])
def test_classic_netcdf_with_another_suffix(tmp_path: Path, name: str) -> None:
    shutil.copy(DATA / "netcdf-pulse" / "pulse.nc", tmp_path / name)
    vol = open_volume(tmp_path / name)  # .dat would be Tecplot by suffix, .h5 HDF5
    assert vol.attrs["reader"] == "netcdf" and vol.is_vector("velocity")


@pytest.mark.parametrize("name", ["grid.xml", "grid.vtu", "grid"])
def test_vtk_xml_read_as_the_type_it_says(tmp_path: Path, name: str) -> None:
    image = pv.ImageData(dimensions=(3, 4, 5), spacing=(0.5, 0.5, 0.5))
    image.point_data["rho"] = np.arange(image.n_points, dtype=float)
    image.save(tmp_path / "grid.vti")
    if name != "grid.vti":
        (tmp_path / "grid.vti").rename(tmp_path / name)
    vol = open_volume(tmp_path / name)
    assert vol.attrs["reader"] == "vtk" and tuple(vol.dims) == (3, 4, 5)
    np.testing.assert_allclose(vol.frame("rho", 0).ravel(), np.arange(60.0))


def test_plot3d_grid_told_by_its_size(tmp_path: Path) -> None:
    grid = DATA / "plot3d-combustor" / "combxyz.bin"
    assert B.is_plot3d_grid(grid)
    assert not B.is_plot3d_grid(DATA / "plot3d-combustor" / "combq.bin")
    shutil.copy(grid, tmp_path / "comb.grid")
    assert B.choose(tmp_path / "comb.grid").name == "plot3d"  # type: ignore[union-attr]
    (tmp_path / "short.grid").write_bytes(grid.read_bytes()[:-4])
    assert B.choose(tmp_path / "short.grid") is None


# --------------------------------------------------------------------------- two claimants
def test_hdf5_layouts_beat_the_plain_hdf5_signature(tmp_path: Path) -> None:
    save_volume(small_volume(), tmp_path / "a.vtkhdf")
    save_volume(small_volume(), tmp_path / "b.h5")
    with h5py.File(tmp_path / "c.h5", "w") as f:
        f.attrs["_NCProperties"] = "version=2"
        x = f.create_dataset("x", data=np.arange(4.0))
        x.make_scale("x")
        f.create_dataset("rho", data=np.ones(4)).dims[0].attach_scale(x)
    with h5py.File(tmp_path / "d.h5", "w") as f:
        f.create_group("meshes/1")
        f.create_group("settings")
    with h5py.File(tmp_path / "e.vtkhdf", "w") as f:
        f["Grid00000001/Density"] = np.ones((4, 4, 4))
    got = {p.name: B.choose(p).name for p in sorted(tmp_path.iterdir())}  # type: ignore[union-attr]
    assert got == {
        "a.vtkhdf": "vtkhdf",
        "b.h5": "auralize-hdf5",
        "c.h5": "netcdf",
        "d.h5": "fluent-cff",
        "e.vtkhdf": "hdf5",
    }
    with pytest.raises(FormatError, match=r"d\.h5: a FLUENT CFF case file.*\.cas\.h5"):
        open_volume(tmp_path / "d.h5")


def _fake(name: str, suffixes: tuple[str, ...], *, claims: bool, specificity: int) -> B.Backend:
    return B.Backend(
        name,
        suffixes,
        lambda path, **opts: small_volume(),
        guess_can_open=lambda path: claims,
        specificity=specificity,
    )


def test_content_then_suffix_then_order_decide(tmp_path: Path) -> None:
    path = tmp_path / "x.two"
    path.write_bytes(b"TWO")
    general = _fake("general", (".one",), claims=True, specificity=10)
    specific = _fake("specific", (".three",), claims=True, specificity=30)
    named = _fake("named", (".two",), claims=True, specificity=10)
    silent = _fake("silent", (".two",), claims=False, specificity=50)
    assert B.choose(path, (general, specific, named, silent)).name == "specific"  # type: ignore[union-attr]
    assert B.choose(path, (general, named, silent)).name == "named"  # type: ignore[union-attr]
    assert B.choose(path, (general, _fake("g2", (), claims=True, specificity=10))).name == "general"  # type: ignore[union-attr]
    assert B.choose(path, (silent,)).name == "silent"  # type: ignore[union-attr]

    def broken(path: Path) -> bool:
        raise OSError("unreadable")

    odd = B.Backend("odd", (".zzz",), general.open, guess_can_open=broken)
    assert B.choose(path, (odd,)) is None  # a failing content check counts as no


def test_damaged_files_go_by_suffix(tmp_path: Path) -> None:
    save_volume(small_volume(), tmp_path / "good.h5")
    data = (tmp_path / "good.h5").read_bytes()
    for name in ("cut.h5", "cut.nc", "cut.dat"):
        (tmp_path / name).write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError, match=r"cut\.h5: .*truncated"):
        open_volume(tmp_path / "cut.h5")
    with pytest.raises(FormatError, match=r"cut\.nc: cannot read as netCDF4/HDF5.*truncated"):
        open_volume(tmp_path / "cut.nc")
    assert B.choose(tmp_path / "cut.dat").name == "hdf5"  # type: ignore[union-attr]


# --------------------------------------------------------------------------- plugins
def _read_fake(path: Path, **opts: object) -> TimeVolume:
    value = float(Path(path).read_text().split()[1])
    return TimeVolume.from_arrays({"level": np.full((2, 2, 2, 2), value)}, times=[0.0, 1.0])


FAKE_BACKEND = B.Backend(
    "fake", (".fake",), _read_fake, guess_can_open=lambda p: Path(p).read_bytes()[:4] == b"FAKE"
)
NOT_A_BACKEND = object()


@pytest.fixture
def plugins(monkeypatch: pytest.MonkeyPatch) -> Iterator[Callable[..., None]]:
    def install(*specs: tuple[str, str]) -> None:
        eps = [
            importlib.metadata.EntryPoint(name, value, B.ENTRY_POINT_GROUP) for name, value in specs
        ]

        def entry_points(**kw: object) -> list[importlib.metadata.EntryPoint]:
            return eps if kw.get("group") == B.ENTRY_POINT_GROUP else []

        monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
        B.all_backends.cache_clear()

    yield install
    B.all_backends.cache_clear()


def test_plugin_backend_is_used_and_broken_ones_are_skipped(
    plugins, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    plugins(
        ("fake", f"{__name__}:FAKE_BACKEND"),
        ("broken", "auralize_no_such_module:READER"),
        ("wrong", f"{__name__}:NOT_A_BACKEND"),
        ("again", f"{__name__}:FAKE_BACKEND"),
    )
    with caplog.at_level(logging.WARNING, logger="auralize.io.backends"):
        names = [b.name for b in B.all_backends()]
    assert names.count("fake") == 1 and names[-1] == "pyvista"
    assert "broken" not in names and "wrong" not in names
    text = caplog.text
    assert "reader plugin 'broken'" in text and "auralize_no_such_module" in text
    assert "reader plugin 'wrong'" in text and "not an auralize Backend" in text
    assert "reader plugin 'again'" in text and "'fake' is taken" in text

    (tmp_path / "run.fake").write_text("level 4.5")  # told by suffix (no FAKE magic)
    vol = open_volume(tmp_path / "run.fake")
    assert vol.attrs["reader"] == "fake" and float(vol.frame("level", 1).max()) == 4.5
    (tmp_path / "run.txt").write_text("FAKE 2")  # told by content
    assert open_volume(tmp_path / "run.txt").attrs["reader"] == "fake"


def test_plugin_factory_and_builtins_still_work(plugins, tmp_path: Path) -> None:
    plugins(("fake", f"{__name__}:_fake_factory"))
    assert "fake2" in [b.name for b in B.all_backends()]
    save_volume(small_volume(), tmp_path / "v.h5")
    assert open_volume(tmp_path / "v.h5").attrs["reader"] == "auralize-hdf5"


def _fake_factory() -> B.Backend:
    return B.Backend("fake2", (".fake2",), _read_fake)


# --------------------------------------------------------------------------- unknown kinds
def test_unknown_file_gets_the_helpful_error(tmp_path: Path) -> None:
    (tmp_path / "v.zzz").write_bytes(b"\x00\x01 nothing known")
    with pytest.raises(
        FormatError,
        match=r"v\.zzz: unknown file kind '\.zzz' \(no reader "
        r"recognises its content\).*\.nc.*auralize\.readers.*meshio convert",
    ):
        open_volume(tmp_path / "v.zzz")
    (tmp_path / "noext").write_text("just text")
    with pytest.raises(FormatError, match=r"unknown file kind '\(no suffix\)'"):
        open_volume(tmp_path / "noext")


def test_hdf5_of_no_known_layout_says_how_to_read_it(tmp_path: Path) -> None:
    path = tmp_path / "enzo.h5"
    with h5py.File(path, "w") as f:
        f["Grid00000001/Density"] = np.ones((3, 4, 4, 4))
    with pytest.raises(FormatError) as err:
        open_volume(path)
    text = str(err.value)
    assert "--field rho=/Grid00000001/Density" in text
    assert "fields={'rho': '/Grid00000001/Density'}" in text
    vol = open_volume(path, fields={"rho": "/Grid00000001/Density"})
    assert vol.attrs["reader"] == "hdf5" and vol.n_steps == 3


def test_exodus_named_nc_through_info_detect_and_render(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    from auralize.cli import main

    path = tmp_path / "case.nc"
    write_exodus(path, n_steps=4)
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "  reader   exodus" in out and "field    temp (scalar" in out
    assert "4 steps, 0 .. 1.5 s" in out
    sources = tmp_path / "s.h5"
    assert main(["detect", str(path), "--density-field", "temp", "-o", str(sources), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["steps"]) == 4 and d["mapping"]["density"] == "temp"
    wav = tmp_path / "a.wav"
    assert (
        main(
            [
                "render",
                str(path),
                "--density-field",
                "temp",
                "--duration",
                "0.05",
                "--rate",
                "8000",
                "-o",
                str(wav),
                "--json",
            ]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    assert wav.exists() and report["duration_s"] == pytest.approx(0.05)
