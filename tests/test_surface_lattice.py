"""Surfaces over an evenly spaced lattice (height fields) are read on their own points."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from auralize.errors import DataError
from auralize.io import ResampledWarning, open_volume

pv = pytest.importorskip("pyvista")

NX, NY, H = 7, 5, 0.5  # lattice points along x and y, spacing in metres
X0, Y0, Z0 = -1.0, 2.0, 3.0


def _height(step: int) -> np.ndarray:
    """Height (nj, ni) of the surface at ``step``: a wave moving along x, ±0.4 m."""
    x = X0 + H * np.arange(NX)
    y = Y0 + H * np.arange(NY)
    return 0.4 * np.sin(1.3 * x[None, :] - 0.7 * step + 0.5 * y[:, None])


def _write_series(folder: Path, n_steps: int = 3) -> Path:
    """A .pvd of ``n_steps`` StructuredGrid surfaces z = Z0 + height(x, y, step).

    The structured index i runs along y and j along x (as in ParaView's wavy),
    so the file's point order is not the lattice's C order.  Point field
    ``h`` is the height, ``c`` a value that identifies each point and step.
    """
    entries = []
    for n in range(n_steps):
        ys, xs = np.meshgrid(Y0 + H * np.arange(NY), X0 + H * np.arange(NX), indexing="ij")
        z = Z0 + _height(n)
        # i along y (fastest), j along x
        pts = np.stack([xs.T, ys.T, z.T], axis=-1).reshape(-1, 3)
        grid = pv.StructuredGrid()
        grid.points = pts
        grid.dimensions = (NY, NX, 1)
        grid.point_data["h"] = _height(n).T.reshape(-1)
        grid.point_data["c"] = 1000.0 * n + (10 * xs + ys).T.reshape(-1)
        name = f"s{n:02d}.vts"
        grid.save(folder / name)
        entries.append(f'<DataSet timestep="{0.5 * n}" part="0" file="{name}"/>')
    pvd = folder / "surf.pvd"
    pvd.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
        "<Collection>\n" + "\n".join(entries) + "\n</Collection>\n</VTKFile>\n"
    )
    return pvd


def test_height_field_is_read_on_its_lattice_with_its_own_values(tmp_path: Path) -> None:
    pvd = _write_series(tmp_path)
    with pytest.warns(ResampledWarning) as rec:
        vol = open_volume(pvd)
    (w,) = rec
    msg = str(w.message)
    level = float(np.mean(Z0 + _height(0)))
    dev = float(np.max(np.abs(Z0 + _height(0) - level)))
    assert "a surface (StructuredGrid with 35 points, 2-D cells) read on its own points" in msg
    assert "no interpolation" in msg and "7x5x1 points, spacing (0.5, 0.5, 0.5) m" in msg
    assert f"in the plane z = {level:.6g} m" in msg
    assert f"up to ±{dev:.3g} m off it" in msg and "\n" not in msg
    assert vol.dims == (NX, NY, 1) and vol.valid is None
    np.testing.assert_allclose(vol.origin, [X0, Y0, level], rtol=0, atol=1e-12)
    np.testing.assert_allclose(vol.spacing[:2], [H, H])
    # exact values at the lattice nodes at every step (the points move along z only)
    x = X0 + H * np.arange(NX)
    y = Y0 + H * np.arange(NY)
    for n in range(3):
        np.testing.assert_array_equal(vol.frame("h", n)[0], _height(n))
        np.testing.assert_array_equal(
            vol.frame("c", n)[0], 1000.0 * n + 10 * x[None, :] + y[:, None]
        )


def test_surface_that_moves_across_its_plane_is_refused(tmp_path: Path) -> None:
    pvd = _write_series(tmp_path, n_steps=2)
    shifted = pv.read(tmp_path / "s01.vts")
    shifted.points = np.asarray(shifted.points) + [0.1, 0.0, 0.0]
    shifted.save(tmp_path / "s01.vts")
    with pytest.warns(ResampledWarning, match="a surface"):
        vol = open_volume(pvd)
    with pytest.raises(DataError, match=re.escape("moved off the first time step's lattice")):
        vol.frame("h", 1)


def test_curved_surface_off_any_lattice_is_read_as_a_shell(tmp_path: Path) -> None:
    sphere = pv.Sphere(radius=1.0, theta_resolution=12, phi_resolution=8)
    sphere.point_data["h"] = np.asarray(sphere.points)[:, 2].copy()
    f = tmp_path / "sphere.vtp"
    sphere.save(f)
    # not projected: the grid points the surface passes through (tests/test_mesh_resolution.py)
    with pytest.warns(ResampledWarning, match=r"not planar\) read as a shell of \d+ voxels"):
        vol = open_volume(f)
    assert 0.0 < vol.valid_ratio < 0.5
