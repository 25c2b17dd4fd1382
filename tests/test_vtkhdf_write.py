"""VTKHDF output read back with VTK's own reader (vtkHDFReader), and ``auralize convert``."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from auralize.cli import main
from auralize.errors import FormatError
from auralize.io import open_volume, save_volume
from auralize.io.vtkhdf_write import KIND_LEGEND, write_sources_vtkhdf
from auralize.sources import SourceFrame, SourceSeries
from auralize.volume import TimeVolume


def _vtk_steps(path: Path) -> tuple[list[float], list]:  # type: ignore[type-arg]
    import pyvista as pv
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as sddp
    from vtkmodules.vtkIOHDF import vtkHDFReader

    r = vtkHDFReader()
    r.SetFileName(str(path))
    r.UpdateInformation()
    times = [float(t) for t in r.GetOutputInformation(0).Get(sddp.TIME_STEPS())]
    out = []
    for step in range(len(times)):
        r = vtkHDFReader()  # a fresh reader per step (VTK 9.7 caches step 0)
        r.SetFileName(str(path))
        r.UpdateInformation()
        r.SetStep(step)
        r.Update()
        out.append(pv.wrap(r.GetOutputDataObject(0)))
    return times, out


def test_volume_round_trip_through_vtk(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    p, v = rng.normal(size=(3, 4, 5, 6)), rng.normal(size=(3, 4, 5, 6, 3))
    times = [0.0, 0.1, 0.35]
    vol = TimeVolume.from_arrays(
        {"p": p, "vel": v}, times=times, origin=(1.0, -2.0, 0.5), spacing=(0.5, 0.25, 2.0)
    )
    out = tmp_path / "v.vtkhdf"
    save_volume(vol, out)
    got_t, grids = _vtk_steps(out)
    assert got_t == times  # float64, exact
    for n, g in enumerate(grids):
        assert g.dimensions == (6, 5, 4)
        assert np.allclose(g.origin, (1.0, -2.0, 0.5)) and np.allclose(g.spacing, (0.5, 0.25, 2.0))
        assert np.array_equal(g.point_data["p"], p[n].ravel())  # x fastest, as VTK orders points
        assert np.array_equal(g.point_data["vel"], v[n].reshape(-1, 3))
    back = open_volume(out)
    assert np.array_equal(back.times, times)
    assert np.allclose(back.frame("vel", 2), v[2])
    assert not list(tmp_path.glob(".*"))  # no temporary file left


def _series() -> SourceSeries:
    rng = np.random.default_rng(5)
    frames = []
    for n in range(3):
        idx = np.sort(rng.choice(4 * 5 * 6, size=7 + n, replace=False)).astype(np.int64)
        frames.append(
            SourceFrame(
                index=idx,
                kind=rng.integers(1, 4, idx.size).astype(np.int8),
                strength=rng.normal(size=idx.size),
                radius=rng.uniform(0.1, 0.5, idx.size),
            )
        )
    return SourceSeries(
        frames=frames,
        times=np.array([0.0, 1 / 30, 2 / 30]),
        origin=np.zeros(3),
        spacing=np.array([0.5, 0.5, 0.5]),
        dims=(6, 5, 4),
        thresholds=np.array([1.0, 2.0, 3.0]),
        meta={},
    )


def test_sources_round_trip_through_vtk_with_kind_legend(tmp_path: Path) -> None:
    series = _series()
    out = tmp_path / "s.vtkhdf"
    write_sources_vtkhdf(series, out)
    got_t, polys = _vtk_steps(out)
    assert got_t == [float(t) for t in series.times]
    for f, poly in zip(series.frames, polys, strict=True):
        assert poly.n_points == f.index.size and poly.n_verts == f.index.size
        assert np.allclose(poly.points, series.positions(f.index))
        assert np.array_equal(poly.point_data["kind"], f.kind)
        assert np.array_equal(poly.point_data["strength"], f.strength)
        assert np.array_equal(poly.point_data["radius"], f.radius)
        legend = dict(
            zip(
                poly.field_data["kind_code"].tolist(),
                [str(x) for x in poly.field_data["kind_name"]],
                strict=True,
            )
        )
        assert legend == KIND_LEGEND == {1: "monopole", 2: "dipole", 3: "quadrupole"}


def test_convert_between_volume_formats_and_sources(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    a, b, c = tmp_path / "a.vtkhdf", tmp_path / "b.h5", tmp_path / "c.pvd"
    spec = ["--size", "10", "--steps", "4"]
    assert main(["convert", "dataset:explosion", str(a), *spec]) == 0
    assert main(["convert", str(a), str(b)]) == 0
    assert main(["convert", str(b), str(c)]) == 0
    va, vc = open_volume(a), open_volume(c)
    assert np.array_equal(va.times, vc.times)
    for name in va.field_names:
        assert np.allclose(va.frame(name, 3), vc.frame(name, 3))
    src = tmp_path / "src.h5"
    assert main(["detect", str(b), "-o", str(src)]) == 0
    with h5py.File(src) as h:
        assert h["kind"].attrs["legend"] == '{"1": "monopole", "2": "dipole", "3": "quadrupole"}'
    assert main(["convert", str(src), str(tmp_path / "src.vtkhdf")]) == 0
    got_t, polys = _vtk_steps(tmp_path / "src.vtkhdf")
    assert len(got_t) == 4 and sum(p.n_points for p in polys) > 0
    assert "wrote" in capsys.readouterr().out
    assert main(["convert", str(b), str(tmp_path / "x.wav")]) == 2
    assert main(["convert", str(b), str(b)]) == 2
    assert "same file" in capsys.readouterr().err
    with pytest.raises(FormatError, match="cannot write"):
        save_volume(va, tmp_path / "x.vtu")


def test_detect_writes_vtkhdf_matching_the_h5_output(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    from auralize.sources.sources_file import load_sources_h5

    spec = ["dataset:monopole", "--size", "12", "--steps", "20"]
    h5, vtkhdf = tmp_path / "s.h5", tmp_path / "s.vtkhdf"
    assert main(["detect", *spec, "-o", str(h5)]) == 0
    assert main(["detect", *spec, "-o", str(vtkhdf)]) == 0
    assert f"wrote {vtkhdf}" in capsys.readouterr().out
    series = load_sources_h5(h5)
    got_t, polys = _vtk_steps(vtkhdf)
    assert len(got_t) == series.n_steps == 20
    assert np.allclose(got_t, series.times)
    assert sum(p.n_points for p in polys) > 0
    for f, poly in zip(series.frames, polys, strict=True):
        assert poly.n_points == f.index.size
        assert np.allclose(poly.points, series.positions(f.index))
        if f.index.size:  # VTK 9.4 reads a step without points with no arrays
            assert np.array_equal(poly.point_data["kind"], f.kind)
    assert not list(tmp_path.glob(".*"))  # no temporary file left
    assert main(["detect", *spec, "-o", str(tmp_path / "s.vtu")]) == 2
    assert ".vtkhdf" in capsys.readouterr().err
