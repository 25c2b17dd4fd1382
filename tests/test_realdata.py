"""Real-data regression: the shipped real datasets read, detect and render as recorded.

Figures live in ``auralize/data/regression/realdata.json`` (refresh with
``python -m auralize.regression.real --update`` after an intended change in detection
or synthesis).  Beside the stored figures, each test checks facts of the data
that hold whatever the detector does (grids, times, the mesh's shape).
"""

from __future__ import annotations

import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from scipy.spatial import cKDTree

from auralize.datasets.real import CASES, DATASETS, dataset_path
from auralize.io import ResampledWarning, open_volume
from auralize.regression.real import compare, compute

# a compact blob that fills much of a small grid is legitimately a large share of
# its points; the warning is for the command line, not a failure here
pytestmark = pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")


@pytest.fixture(scope="module")
def figures() -> dict[str, dict[str, object]]:
    return {name: compute(name) for name in CASES}


@pytest.mark.parametrize("name", list(CASES))
def test_matches_stored_figures(name: str, figures: dict[str, dict[str, object]]) -> None:
    problems = compare(name, figures[name])
    assert problems == [], problems


def test_no_source_outside_the_mesh(figures: dict[str, dict[str, object]]) -> None:
    for name, got in figures.items():
        assert got.get("sources_outside_mesh", 0) == 0, name


def test_cavity_keeps_its_native_points() -> None:
    """A blockMesh box (20x20x1 cells) is its 21x21x2 points, values exactly VTK's."""
    with dataset_path("openfoam-cavity") as path:
        with warnings.catch_warnings():
            warnings.simplefilter("error", ResampledWarning)
            vol = open_volume(path)
        reader = pv.OpenFOAMReader(str(path))
        reader.set_active_time_value(2.5)
        reader.cell_to_point_creation = True
        mesh = reader.read()["internalMesh"]
        p = vol.frame("p", 5)  # lazy: read while the unpacked case exists
    assert vol.dims == (21, 21, 2) and vol.valid is None
    np.testing.assert_allclose(vol.times, [0, 0.5, 1, 1.5, 2, 2.5])
    pts = vol.points()
    # every grid point's value is the mesh point's value at the same position
    idx = cKDTree(np.asarray(mesh.points)).query(pts[::37])[1]
    np.testing.assert_allclose(np.asarray(mesh.points)[idx], pts[::37], atol=1e-7)
    np.testing.assert_array_equal(p.reshape(-1)[::37], np.asarray(mesh.point_data["p"])[idx])
    assert vol.attrs["units"] == {"U": "m s-1", "p": "m2 s-2"}


def test_cavity_gives_sound_with_the_incompressible_mapping(figures: dict) -> None:  # type: ignore[type-arg]
    got = figures["openfoam-cavity"]
    assert got["mapping"]["name"] == "incompressible"  # chosen: p and U, no density
    assert got["mapping"]["kinematic_scale"] == pytest.approx(1.2)  # p in m2 s-2 times rho0
    assert sum(c["monopole"] for c in got["counts"]) > 0 and got["rms"] > 0


def test_netcdf_pulse_times_and_tone(figures: dict) -> None:  # type: ignore[type-arg]
    got = figures["netcdf-pulse"]
    np.testing.assert_allclose(got["times"], np.arange(10) * 1e-3)  # milliseconds -> seconds
    assert got["dims"] == [20, 16, 12] and got["spacing"] == [0.005] * 3
    # the blob pulsates at 250 Hz as a linear sound wave: continuity holds (no mass source
    # above its discretisation error), and the whole field's Lighthill stress ρ v_i v_j
    # oscillates at 250 and 2 × 250 Hz: the clip's spectral centroid lies between
    assert 250 < got["centroid"] < 500


def test_wavy_surface_is_read_on_its_own_lattice() -> None:
    """A 2-D height field z(x, y, t) on an 80x80 lattice: its own points, nothing invented."""
    with dataset_path("paraview-wavy") as path:
        with pytest.warns(
            ResampledWarning,
            match=r"a surface .* no interpolation: the lattice "
            r"80x80x1 points, spacing \(0.25, 0.25, 0.25\) m",
        ):
            vol = open_volume(path)
        surface = pv.read(path.parent / "wavy" / "wavy00.vts")
        z = vol.frame("z", 0)[0]
    assert vol.n_steps == 15 and vol.physical_times and vol.valid_ratio == 1.0
    pts = np.asarray(surface.points)
    i = np.rint((pts[:, 0] - vol.origin[0]) / vol.spacing[0]).astype(int)
    j = np.rint((pts[:, 1] - vol.origin[1]) / vol.spacing[1]).astype(int)
    np.testing.assert_array_equal(z[j, i], np.asarray(surface.point_data["z"]))
    # the plane at the points' mean height; 'z' is that height itself
    assert vol.origin[2] == pytest.approx(float(pts[:, 2].mean()))
    np.testing.assert_array_equal(z[j, i], pts[:, 2])


def test_ensight_cylinder_hole_is_invalid() -> None:
    """The 2-D cross-flow mesh has a hole where the cylinder is: those points are no-data."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        vol = open_volume(DATASETS / "ensight-cylinder" / "cylinder_Re35.case")
    assert vol.dims[2] == 1 and vol.n_steps == 1 and not vol.physical_times
    assert set(vol.field_names) == {"pressure", "vorticity_mag", "velocity"}
    pts = vol.points()
    r = np.hypot(pts[:, 0] - 2.5, pts[:, 1])
    valid = vol.valid_mask().reshape(-1)
    assert not valid[r < 0.45].any() and valid[r > 0.55].all()
    assert np.all(np.isnan(vol.frame("pressure", 0).reshape(-1)[r < 0.45]))


def test_plot3d_combustor_fields_and_mask() -> None:
    path = DATASETS / "plot3d-combustor" / "combxyz.bin"
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResampledWarning)
        native = open_volume(path)  # on its own 57 x 33 x 25 points, every one valid
    assert native.curvilinear and native.dims == (57, 33, 25) and native.valid is None
    assert native.field_names == ["Density", "Momentum", "StagnationEnergy"]
    assert np.all(native.frame("Density", 0) > 0)
    with pytest.warns(ResampledWarning, match="StructuredGrid with 47025 points"):
        vol = open_volume(path, curvilinear="resample")
    assert vol.field_names == ["Density", "Momentum", "StagnationEnergy"]
    assert vol.is_vector("Momentum") and 0.3 < vol.valid_ratio < 0.6
    rho = vol.frame("Density", 0)
    assert np.all(rho[vol.valid] > 0) and np.all(np.isnan(rho[~vol.valid]))


def test_datasets_have_licences_and_provenance() -> None:
    text = (DATASETS / "PROVENANCE.md").read_text()
    import hashlib

    for folder in (
        "paraview-wavy",
        "xdmf-timeseries",
        "ensight-cylinder",
        "plot3d-combustor",
        "openfoam-cavity",
    ):
        assert list((DATASETS / folder).glob("LICENSE*")), folder
        for f in (DATASETS / folder).rglob("*"):
            if f.is_file():
                digest = hashlib.sha256(f.read_bytes()).hexdigest()
                assert digest in text, f
    assert "scripts/make_netcdf_pulse.py" in text
    with zipfile.ZipFile(DATASETS / "paraview-wavy" / "wavy.zip") as z:
        assert "wavy/wavy.pvd" in z.namelist()
    assert Path(DATASETS / "netcdf-pulse" / "pulse.nc").stat().st_size < 1_000_000


def test_every_dataset_opens_by_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``dataset:NAME`` opens each shipped file as its own path does (archives unpacked
    once into the cache), and the command's help lists every name."""
    from auralize.cli import main
    from auralize.datasets.shipped import GENERATED, SHIPPED, describe, shipped_path
    from auralize.datasets.synthetic import DATASETS as GENERATORS
    from auralize.errors import ParameterError
    from auralize.pipeline import load

    assert tuple(GENERATORS) == GENERATED
    assert set(SHIPPED) == {
        "cavity",
        "pulse",
        "dolfinx",
        "meshio",
        "wavy",
        "cylinder",
        "combustor",
    } and {c for c, _ in SHIPPED.values()} == set(CASES)
    monkeypatch.setenv("AURALIZE_CACHE_DIR", str(tmp_path / "cache"))
    warnings.simplefilter("ignore", ResampledWarning)
    for name, (case, _) in SHIPPED.items():
        by_name = load(f"dataset:{name}")
        with dataset_path(case) as path:
            direct = open_volume(path)
            assert by_name.dims == direct.dims and by_name.field_names == direct.field_names
            assert np.array_equal(by_name.times, direct.times), name
    assert shipped_path("cavity").is_relative_to(tmp_path / "cache")
    assert len(list((tmp_path / "cache" / "data").iterdir())) == 2  # cavity and wavy
    with pytest.raises(ParameterError, match="shipped file .* --size and --steps"):
        load("dataset:cavity", size=8)
    out = tmp_path / "cavity.h5"
    assert main(["dataset", "cavity", "-o", str(out)]) == 0
    assert load(out).dims == load("dataset:cavity").dims
    for name in (*GENERATED, *SHIPPED):
        assert name in describe()
