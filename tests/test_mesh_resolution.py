"""A mesh's automatic grid comes from its own cell sizes; shells stay shells; losses are told.

Issue "Real data, round 3", item 5: an EnSight airfoil resampled at 128^2 had one
voxel across its chord, a shell model a 3.7 %-valid volume, with only a warning.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from auralize.errors import ResourceError
from auralize.io import ResampledWarning, open_volume
from auralize.io.resample import AUTO_CELL_PERCENTILE, grid_for_cells

pv = pytest.importorskip("pyvista")

CHORD, THICKNESS, R_OUT = 1.0, 0.12, 60.0


def naca_half_thickness(x: np.ndarray) -> np.ndarray:
    """Half-thickness of a NACA 00xx section of chord 1 at ``x`` in [0, 1]."""
    return (
        5
        * THICKNESS
        * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3 - 0.1036 * x**4)
    )


def airfoil_mesh(n_around: int = 120, n_layers: int = 40, unit: float = 1.0) -> pv.UnstructuredGrid:
    """An O-grid around a NACA 0012 of chord 1 in a disc of radius 60 (a 120-unit domain).

    Layers grow geometrically from 0.004 at the body to the far field, as in
    the EnSight naca case: 4840 points, most of them within a chord of the
    body.  Returned as an UnstructuredGrid of quads (not a lattice), with
    ``f = x + 2 y`` at the points; coordinates times ``unit``.
    """
    s = np.linspace(0.0, 2.0 * np.pi, n_around, endpoint=False)
    xc = 0.5 * (1.0 + np.cos(s))  # cosine clustering at both edges
    yt = naca_half_thickness(xc)
    body = np.stack([xc, np.where(s < np.pi, yt, -yt)], axis=1)
    d = 0.004 * (R_OUT / 0.004) ** (np.arange(n_layers) / (n_layers - 1))
    d[0] = 0.0
    circle = np.array([0.5, 0.0]) + R_OUT * np.stack([np.cos(s), np.sin(s)], axis=1)
    b = (d / R_OUT)[:, None, None]
    ring = (1.0 - b) * body[None] + b * circle[None]
    ring = np.concatenate([ring, ring[:, :1]], axis=1)  # close the O
    pts = np.concatenate([ring, np.zeros((*ring.shape[:2], 1))], axis=2).reshape(-1, 3)
    grid = pv.StructuredGrid()
    grid.points = pts * unit
    grid.dimensions = (n_around + 1, n_layers, 1)
    mesh = grid.cast_to_unstructured_grid()
    mesh.point_data["f"] = pts[:, 0] + 2.0 * pts[:, 1]
    return mesh


@pytest.fixture(scope="module")
def naca(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("naca") / "naca.vtu"
    airfoil_mesh().save(path)
    return path


def test_airfoil_gets_ten_voxels_across_its_chord(naca: Path) -> None:
    with pytest.warns(ResampledWarning) as rec:
        vol = open_volume(naca)
    (w,) = rec
    msg = str(w.message)
    assert "\n" not in msg and f"the {AUTO_CELL_PERCENTILE:g}th-percentile cell size" in msg
    # the grid is capped: it says so, and what to do
    assert "capped at 2,000,000 grid points" in msg and "--box" in msg and "--resolution" in msg
    assert re.search(r"lost: \d+\.\d % of the mesh's cells are smaller than a voxel", msg)
    nx, ny, nz = vol.dims
    assert nz == 1 and nx * ny <= 2_000_000
    h = float(vol.spacing[0])
    assert CHORD / h >= 10  # was 0.93-unit spacing: one voxel across the chord
    # the body is a hole resolved by the grid: grid points inside it are no-data ...
    pts = vol.points()
    valid = vol.valid_mask().reshape(-1)
    x, y = pts[:, 0], pts[:, 1]
    on_chord = (x > 0.15) & (x < 0.85)
    inside = on_chord & (np.abs(y) < 0.8 * naca_half_thickness(np.clip(x, 0, 1)))
    outside = on_chord & (np.abs(y) > naca_half_thickness(np.clip(x, 0, 1)) + h) & (np.abs(y) < 0.3)
    assert inside.sum() >= 5 and not valid[inside].any()  # 0.12 thick: a row of points
    assert valid[outside].all()
    # ... and the (linear) field is exact where the grid is valid
    f = vol.frame("f", 0).reshape(-1)
    np.testing.assert_allclose(f[valid], (x + 2 * y)[valid], atol=1e-6)
    loss = vol.attrs["resampling"]
    assert set(loss) == {"cells_below_voxel", "points_outside", "voxel", "why"}
    assert 0.2 < loss["cells_below_voxel"] < 1 and loss["points_outside"] == 0.0
    assert loss["voxel"] == pytest.approx(h) and "capped" in loss["why"]


def test_box_sets_the_region_and_its_cells_the_resolution(naca: Path) -> None:
    box = (-0.5, 1.5, -0.5, 0.5, -1.0, 1.0)
    with pytest.warns(ResampledWarning, match=r"cells in the box are smaller") as rec:
        vol = open_volume(naca, box=box)
    assert "capped" not in str(rec[0].message)
    np.testing.assert_allclose(vol.bounds[:4], box[:4], atol=1e-9)
    h = float(vol.spacing[0])
    assert CHORD / h >= 100  # the cells near the body set the voxel
    pts = np.asarray(pv.read(naca).points)
    out = ~((np.abs(pts[:, 0] - 0.5) <= 1.0) & (np.abs(pts[:, 1]) <= 0.5))
    loss = vol.attrs["resampling"]
    assert loss["points_outside"] == pytest.approx(out.mean())
    assert loss["cells_below_voxel"] == pytest.approx(AUTO_CELL_PERCENTILE / 100, abs=0.02)
    # an explicit resolution keeps its meaning, over the box
    with pytest.warns(ResampledWarning, match=r"resolution=\(21, 11, 1\)"):
        coarse = open_volume(naca, box=box, resolution=(21, 11, 1))
    assert coarse.dims == (21, 11, 1) and coarse.spacing[0] == pytest.approx(0.1)
    assert coarse.attrs["resampling"]["why"] == "resolution=(21, 11, 1)"


def test_axis_scale_applies_before_the_grid_is_chosen(naca: Path, tmp_path: Path) -> None:
    mm = tmp_path / "naca_mm.vtu"
    airfoil_mesh(unit=1000.0).save(mm)
    box = (-0.5, 1.5, -0.5, 0.5, -1.0, 1.0)
    with pytest.warns(ResampledWarning):
        metres = open_volume(naca, box=box)
    with pytest.warns(ResampledWarning):
        scaled = open_volume(mm, axis_scale=(1e-3, 1e-3, 1.0), box=box)
    assert scaled.attrs["axis_scale_applied"] == [1e-3, 1e-3, 1.0]
    assert scaled.dims == metres.dims  # the box is in metres: the same cells chosen
    np.testing.assert_allclose(scaled.spacing, metres.spacing, rtol=1e-9)
    np.testing.assert_allclose(scaled.bounds, metres.bounds, atol=1e-9)
    np.testing.assert_allclose(scaled.frame("f", 0), metres.frame("f", 0), atol=1e-9)
    # a uniform grid read on its own points is scaled once, not again by the reader options
    img = pv.ImageData(dimensions=(4, 3, 2), spacing=(10.0, 10.0, 10.0), origin=(0, 0, 100))
    img.point_data["rho"] = np.arange(img.n_points, dtype=float)
    img.save(tmp_path / "img.vti")
    vol = open_volume(tmp_path / "img.vti", axis_scale=0.1)
    assert vol.spacing.tolist() == pytest.approx([1.0, 1.0, 1.0])
    assert vol.origin.tolist() == pytest.approx([0.0, 0.0, 10.0])


def test_tetrahedra_get_a_grid_about_their_own_spacing(tmp_path: Path) -> None:
    """The equivalent edge of a tetrahedron counts the 6 a cube splits into."""
    rng = np.random.default_rng(1)
    box = pv.ImageData(dimensions=(11, 11, 11), spacing=(0.1, 0.1, 0.1)).cast_to_unstructured_grid()
    tets = box.triangulate()
    tets.points = tets.points + rng.uniform(-0.01, 0.01, tets.points.shape)  # not a lattice
    tets.point_data["f"] = tets.points[:, 0]
    tets.save(tmp_path / "tets.vtu")
    with pytest.warns(ResampledWarning, match="th-percentile cell size"):
        vol = open_volume(tmp_path / "tets.vtu")
    assert 0.07 < vol.spacing[0] < 0.1 and max(vol.dims) <= 16


def test_a_grid_bigger_than_memory_is_refused_before_it_is_made(
    naca: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("AURALIZE_MEMORY_LIMIT", "1M")
    with pytest.raises(
        ResourceError,
        match=r"400 x 400 x 1 points needs about .* refusing"
        r" to start; pass a coarser --resolution",
    ):
        open_volume(naca, resolution=(400, 400, 1))
    # the automatic grid shrinks to half of what is available, and says why
    with pytest.warns(ResampledWarning, match=r"half the 1 MiB of memory available"):
        vol = open_volume(naca)
    assert vol.dims[0] * vol.dims[1] * 128 <= 0.5 * 2**20


def _sphere_series(folder: Path, n_steps: int = 3) -> tuple[Path, np.ndarray, float]:
    """A .pvd of a sphere shell (.vtp) carrying ``f = (1 + step) z + x`` at its points."""
    centre, radius = np.array([0.2, -0.1, 0.3]), 1.0
    entries = []
    for n in range(n_steps):
        s = pv.Sphere(radius=radius, center=centre, theta_resolution=40, phi_resolution=30)
        s.clear_data()
        p = np.asarray(s.points)
        s.point_data["f"] = (1.0 + n) * p[:, 2] + p[:, 0]
        s.save(folder / f"s{n}.vtp")
        entries.append(f'<DataSet timestep="{0.1 * n}" part="0" file="s{n}.vtp"/>')
    pvd = folder / "shell.pvd"
    pvd.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
        "<Collection>\n" + "\n".join(entries) + "\n</Collection>\n</VTKFile>\n"
    )
    return pvd, centre, radius


def test_a_closed_shell_is_read_as_a_shell(tmp_path: Path) -> None:
    pvd, centre, radius = _sphere_series(tmp_path)
    with pytest.warns(ResampledWarning) as rec:
        vol = open_volume(pvd)
    (w,) = rec
    msg = str(w.message)
    k = int(np.count_nonzero(vol.valid))
    assert (
        f"a surface (PolyData with 1122 points, 2-D cells, not planar) read as a shell of {k} "
        f"voxels ({100 * vol.valid_ratio:.2f} % of the grid" in msg
    )
    assert vol.n_steps == 3 and 0.08 < vol.valid_ratio < 0.3
    h = float(np.max(vol.spacing))
    pts = vol.points()
    valid = vol.valid_mask().reshape(-1)
    r = np.linalg.norm(pts - centre, axis=1)
    assert np.all(np.abs(r[valid] - radius) <= 0.9 * h)  # the shell's voxels, no others
    assert np.all(valid[np.abs(r - radius) < 0.25 * h])  # and every voxel it passes through
    nearest = centre + (pts[valid] - centre) * (radius / r[valid])[:, None]
    for n in range(3):
        frame = vol.frame("f", n).reshape(-1)
        expect = (1.0 + n) * nearest[:, 2] + nearest[:, 0]
        gradient = np.hypot(1.0, 1.0 + n)
        assert np.all(np.abs(frame[valid] - expect) <= gradient * 0.6 * h)
        assert np.all(np.isnan(frame[~valid]))
    assert vol.attrs["resampling"]["points_outside"] == 0.0


def test_an_unstructured_shell_of_quads_with_cell_data(tmp_path: Path) -> None:
    cube = pv.Box(bounds=(-1, 1, -1, 1, -1, 1), level=4, quads=True).cast_to_unstructured_grid()
    cube.cell_data["c"] = np.asarray(cube.cell_centers().points)[:, 0]
    cube.save(tmp_path / "cube.vtu")
    with pytest.warns(ResampledWarning, match=r"UnstructuredGrid .* read as a shell of \d+ voxels"):
        vol = open_volume(tmp_path / "cube.vtu")
    h = float(np.max(vol.spacing))
    pts = vol.points()[vol.valid_mask().reshape(-1)]
    assert np.all(np.abs(np.max(np.abs(pts), axis=1) - 1.0) <= 0.9 * h)
    c = vol.frame("c", 0)[vol.valid]
    assert np.all(np.abs(c - pts[:, 0]) <= 0.5)  # cell values, averaged to the points


def test_grid_for_cells_caps_at_the_budget() -> None:
    sizes = np.full(100, 0.01)
    free = grid_for_cells(
        (0, 1, 0, 1, 0, 1), sizes, n_points=1000, resolution=None, budget=10**7, source="x"
    )
    assert free.dims == (101, 101, 101) and not free.capped
    capped = grid_for_cells(
        (0, 1, 0, 1, 0, 1), sizes, n_points=1000, resolution=None, budget=1000, source="x"
    )
    assert capped.capped and np.prod(capped.dims) <= 1000 and capped.cell == pytest.approx(0.01)
    # no sizes: about as many grid points as the mesh has
    few = grid_for_cells(
        (0, 1, 0, 1, 0, 1), np.zeros(0), n_points=1000, resolution=None, budget=10**7, source="x"
    )
    assert 500 <= np.prod(few.dims) <= 1000 and "as many grid points" in few.why
