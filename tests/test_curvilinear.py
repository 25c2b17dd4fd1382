"""Structured curvilinear grids read and differentiated natively (metric terms), not resampled.

Closed forms: on warped and polar grids the metric gradient of a linear field
is exact (to 1e-12), of a smooth field second order; the points' ΔV sum to
the domain's volume; a monopole blob detected on a warped grid gives the
sources it gives on a uniform grid; a ``.vts`` series written by VTK's
writer goes through ``auralize info``, ``detect`` and ``render`` natively.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from auralize.curvilinear import CurvilinearMetric, index_derivative, interp_coords
from auralize.errors import DataError, ParameterError
from auralize.volume import TimeVolume

pv = pytest.importorskip("pyvista")


def warped(n: tuple[int, int, int], a: float = 0.1) -> np.ndarray:
    """x = ξ + a sin(2πη), y = η + a sin(2πζ), z = ζ + a ξ² on [0, 1]³: coords (nz, ny, nx, 3)."""
    nx, ny, nz = n
    zz, yy, xx = np.meshgrid(*(np.linspace(0.0, 1.0, m) for m in (nz, ny, nx)), indexing="ij")
    return np.stack(
        [xx + a * np.sin(2 * np.pi * yy), yy + a * np.sin(2 * np.pi * zz), zz + a * xx**2], axis=-1
    )


def shell(
    n: tuple[int, int, int],
    r0: float = 1.0,
    r1: float = 2.0,
    span: float = 0.5 * np.pi,
    height: float = 1.0,
) -> np.ndarray:
    """A cylindrical shell sector: i along r in [r0, r1], j along θ in [0, span], k along z."""
    nr, nt, nz = n
    z, t, r = np.meshgrid(
        np.linspace(0, height, nz), np.linspace(0, span, nt), np.linspace(r0, r1, nr), indexing="ij"
    )
    return np.stack([r * np.cos(t), r * np.sin(t), z], axis=-1)


def test_index_derivative_is_numpy_gradient_second_order_at_faces() -> None:
    f = np.random.default_rng(0).normal(size=(4, 5, 7))
    for ax in range(3):
        np.testing.assert_array_equal(
            index_derivative(f, ax), np.gradient(f, axis=ax, edge_order=2)
        )
    # the 2h stencil: central over every second point inside
    g = index_derivative(np.arange(10.0) ** 2, 0, wide=True)
    np.testing.assert_allclose(g, 2 * np.arange(10.0), atol=1e-12)


@pytest.mark.parametrize(
    "make",
    [lambda: warped((9, 11, 7)), lambda: shell((8, 13, 5)), lambda: shell((8, 13, 1))],
    ids=["warped", "shell", "one-layer"],
)
def test_gradient_of_a_linear_field_is_exact(make) -> None:  # type: ignore[no-untyped-def]
    c = make()
    m = CurvilinearMetric(c, thickness=np.full(3, 0.1))
    x, y, z = c[..., 0], c[..., 1], c[..., 2]
    flat = c.shape[0] == 1
    coef = np.array([3.0, -2.0, 0.0 if flat else 0.5])
    g = m.gradient(1.0 + coef[0] * x + coef[1] * y + coef[2] * z)
    assert np.abs(g - coef).max() < 1e-12
    # divergence of the linear vector field (x, 2y, 3z): 1 + 2 + 3 (no z across one layer)
    div = m.divergence((x, 2 * y, 3 * z))
    assert np.abs(div - (3.0 if flat else 6.0)).max() < 1e-12
    # Σ ∂²T_ij/∂x_i∂x_j of a stress linear in x: ∂_i T_ij is constant, so exactly 0
    tt = np.zeros((6, *c.shape[:3]))
    tt[0], tt[3], tt[5] = 2 * x - y, 3 * y + z, x - z
    assert np.abs(m.quadrupole(tt)).max() < 1e-10


@pytest.mark.parametrize(
    "n", [(9, 11, 7), (2, 5, 7), (6, 1, 8), (5, 6, 3), (1, 7, 7), (13, 2, 6), (7, 7, 1), (3, 3, 3)]
)
def test_compiled_divergence_is_the_numpy_one(n: tuple[int, int, int]) -> None:
    """The compiled divergence (every strength and error estimate is made of it) gives
    the numpy reference's numbers (to 1e-12; the same arithmetic in the same order):
    h and 2h stencils, axes of 1, 2, 3, 5 and ≥ 6 points; one compiled specialization
    whatever the arrays' dtype and layout."""
    from auralize.curvilinear import _kernel

    rng = np.random.default_rng(sum(n))
    m = CurvilinearMetric(warped(n), thickness=np.full(3, 0.3))
    shape = m.shape
    f = rng.normal(size=(3, *shape))
    tt = rng.normal(size=(6, *shape))
    for wide in (False, True):
        ref = m.divergence((f[0], f[1], f[2]), wide=wide, compiled=False)
        got = m.divergence(f, wide=wide)
        assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()
        q_ref = m.quadrupole(tt, wide=wide, compiled=False)
        assert np.abs(m.quadrupole(tt, wide=wide) - q_ref).max() <= 1e-12 * np.abs(q_ref).max()
    # float32 components, a strided view: the same one specialization
    f32 = np.ascontiguousarray(f.transpose(0, 3, 2, 1)).transpose(0, 3, 2, 1).astype(np.float32)
    np.testing.assert_allclose(
        m.divergence(f32),
        m.divergence(f32.astype(np.float64), compiled=False),
        rtol=1e-12,
        atol=1e-12,
    )
    assert len(_kernel().signatures) == 1


def test_gradient_of_a_smooth_field_converges_at_second_order() -> None:
    errs, qerrs = [], []
    for n in (12, 24, 48):
        c = warped((n, n, n))
        m = CurvilinearMetric(c, thickness=np.ones(3))
        x, y, z = c[..., 0], c[..., 1], c[..., 2]
        f = np.sin(2 * x) * np.cos(y) * np.exp(z)
        exact = np.stack(
            [2 * np.cos(2 * x) * np.cos(y) * np.exp(z), -np.sin(2 * x) * np.sin(y) * np.exp(z), f],
            axis=-1,
        )
        errs.append(float(np.abs(m.gradient(f) - exact).max()))
        # Σ ∂²T_ij/∂x_i∂x_j of T_xx = x², T_xy = xy, T_zz = z³: 2 + 2 + 6z (∂x∂y counted twice)
        tt = np.zeros((6, *c.shape[:3]))
        tt[0], tt[3], tt[2] = x * x, x * y, z**3
        q_err = np.abs(m.quadrupole(tt) - (4.0 + 6 * z))
        qerrs.append((float(q_err[2:-2, 2:-2, 2:-2].max()), float(q_err.max())))
    order = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(order > 1.8), (errs, order)  # every point, faces included
    q = np.array(qerrs)
    inner, faces = np.log2(q[:-1, 0] / q[1:, 0]), np.log2(q[:-1, 1] / q[1:, 1])
    # the second derivative (two first ones): second order inside (1.8 at 12..48 points, the
    # faces' influence still felt 2 points in), first at the faces (as the
    # uniform stencil shifted inwards there)
    assert np.all(inner > 1.7) and np.all(faces > 0.9), (q, inner, faces)  # 1.77, 1.80; 1.10, 1.05


def test_cell_volumes_sum_to_the_domain_volume() -> None:
    exact = 0.5 * (2.0**2 - 1.0**2) * 0.5 * np.pi * 1.0  # the shell sector: 3π/4 m³
    errs = []
    for n in (10, 20, 40):
        m = CurvilinearMetric(shell((n, n, 4)), thickness=np.ones(3))
        errs.append(abs(m.cell_volume().sum() - exact) / exact)
    # 3.4e-3, 9.6e-4, 2.5e-4: second order
    assert errs[-1] < 3e-4 and errs[0] / errs[1] > 3.4 and errs[1] / errs[2] > 3.4, errs
    # one layer: the area times the thickness across it
    m1 = CurvilinearMetric(shell((40, 40, 1)), thickness=np.array([1.0, 1.0, 0.25]))
    assert m1.cell_volume().sum() == pytest.approx(0.25 * 0.75 * np.pi, rel=3e-4)
    # warped unit cube (x = ξ + a sin 2πη ...): volume 1 + O(h²)
    assert CurvilinearMetric(
        warped((40, 40, 40)), thickness=np.ones(3)
    ).cell_volume().sum() == pytest.approx(1.0, rel=1e-5)


def test_degenerate_grid_is_refused_with_the_point() -> None:
    c = shell((5, 6, 3), r0=0.0)  # r = 0: the whole first i-line is one point
    with pytest.raises(
        DataError, match=r"18 degenerate points .*point \(i, j, k\) = \(0, 0, 0\).*--resample"
    ):
        CurvilinearMetric(c, thickness=np.ones(3))


def test_interp_coords_is_multilinear() -> None:
    c = warped((5, 6, 7))
    np.testing.assert_allclose(interp_coords(c, np.array([[2, 3, 4]])), c[4, 3, 2][None])
    mid = interp_coords(c, np.array([[2.5, 3.0, 4.0]]))
    np.testing.assert_allclose(mid[0], 0.5 * (c[4, 3, 2] + c[4, 3, 3]))


# ----------------------------------------------------------------- detection
def _blob(c: np.ndarray, times: np.ndarray, sigma: float = 0.08) -> np.ndarray:
    r2 = ((c - 0.5) ** 2).sum(axis=-1)
    return (
        1.2
        + 0.01
        * np.sin(2 * np.pi * 5 * times)[:, None, None, None]
        * np.exp(-r2 / (2 * sigma**2))[None]
    )


def test_monopole_detected_natively_matches_the_uniform_grid() -> None:
    from auralize.sources.detection import Thresholds, detect
    from auralize.sources.field import field_tracks
    from auralize.sources.mapping import get_mapping

    n, times = 24, np.arange(12) / 100.0
    s = np.linspace(0.0, 1.0, n)
    zz, yy, xx = np.meshgrid(s, s, s, indexing="ij")
    uniform = np.stack([xx, yy, zz], axis=-1)
    # a warp that keeps the unit cube: x = ξ + a sin(πξ) sin(πη), y = η + a sin(πη) sin(πζ)
    a = 0.04
    c = np.stack(
        [
            xx + a * np.sin(np.pi * xx) * np.sin(np.pi * yy),
            yy + a * np.sin(np.pi * yy) * np.sin(np.pi * zz),
            zz,
        ],
        axis=-1,
    )
    uni = TimeVolume.from_arrays({"density": _blob(uniform, times)}, spacing=s[1], times=times)
    cur = TimeVolume.from_arrays({"density": _blob(c, times)}, times=times, coords=c)
    assert cur.curvilinear and not uni.curvilinear
    assert cur.bounds == pytest.approx((0, 1, 0, 1, 0, 1), abs=1e-12)
    thr = Thresholds(monopole=0.005)
    got = {}
    for name, vol in (("uniform", uni), ("curvilinear", cur)):
        series = detect(vol, mapping="identity", thresholds=thr)
        assert series.counts()[2]["monopole"] > 10
        tr = series.tracks()
        w = np.abs(tr.q).sum(axis=1)
        centre = (tr.positions * w[:, None]).sum(axis=0) / w.sum()
        strongest = tr.positions[np.argmax(w)]
        # positions are grid points of the volume
        assert np.isin(tr.index, np.arange(vol.n_points)).all()
        np.testing.assert_allclose(tr.positions, vol.points(tr.index))
        got[name] = (tr.q.sum(axis=0), centre, strongest)
        # the whole field heard: Σ S ΔV = d/dt ∫ρ dV = 0.01 A'(t) (2π)^{3/2} σ³
        ft = field_tracks(vol, get_mapping("identity"), block=1)
        q = ft.q["monopole"].sum(axis=0)
        exact = 0.01 * 2 * np.pi * 5 * np.cos(2 * np.pi * 5 * times) * (2 * np.pi) ** 1.5 * 0.08**3
        inner = slice(1, -1)  # central time differences: the ends are one-sided
        err = np.abs(q[inner] - exact[inner]).max() / np.abs(exact).max()
        assert err < 0.03, (name, err)  # 2.2 % on both grids (1.6 % of it the Δt difference)
        # compressed into blocks of proxies (Lagrange weights: a partition of unity), the
        # same total, the proxies inside the grid
        fb = field_tracks(vol, get_mapping("identity"), block=8)
        assert fb.meta["rows"] < ft.meta["rows"]
        np.testing.assert_allclose(fb.q["monopole"].sum(axis=0), q, rtol=1e-9, atol=1e-15)
        assert np.all(vol.contains(fb.positions, tol=1e-9))
    (qu, cu, su), (qc, cc, sc) = got["uniform"], got["curvilinear"]
    h = 1.0 / (n - 1)
    assert np.linalg.norm(cu - 0.5) < 0.1 * h and np.linalg.norm(cc - 0.5) < 0.1 * h
    assert np.linalg.norm(su - 0.5) < h and np.linalg.norm(sc - 0.5) < h
    # the detected Σ S ΔV agree to within 3 % of their peak (1.5 %: the threshold cuts the two
    # grids' tails at different points)
    assert np.abs(qc - qu).max() < 0.03 * np.abs(qu).max()


def test_uniform_volumes_have_no_coords() -> None:
    vol = TimeVolume.from_arrays({"d": np.ones((2, 3, 3, 3))}, spacing=0.5)
    assert vol.coords is None and vol.metric is None and vol.describe()["grid"] == "uniform"
    with pytest.raises(DataError, match="coordinates have shape"):
        TimeVolume.from_arrays({"d": np.ones((2, 3, 3, 3))}, coords=np.zeros((3, 3, 4, 3)))


# ------------------------------------------------------------------ readers
def write_vts_series(
    folder: Path,
    n: tuple[int, int, int] = (10, 24, 5),
    steps: int = 8,
    *,
    swirl: float = 0.0,
    width: float = 0.02,
    block: tuple[int, ...] | None = None,
) -> tuple[Path, np.ndarray, np.ndarray]:
    """A ``.pvd`` of ``.vts`` files (VTK's vtkXMLStructuredGridWriter, via pyvista) of a
    pulsating blob on a cylindrical shell; returns the path, the points and the times.

    ``swirl``: the blob also turns about the z axis through (0, 1) at that peak speed
    (m/s), pulsating (dipoles and quadrupoles too); ``width``: the blob's 2σ² (m²).  ``block (i0, i1, j0, j1, k0, k1)``:
    only those points of the shell (the same values at the same points)."""
    folder.mkdir(parents=True, exist_ok=True)
    c = shell(n, r0=0.5, r1=1.5, span=np.pi, height=0.5)
    if block is not None:
        i0, i1, j0, j1, k0, k1 = block
        c = c[k0:k1, j0:j1, i0:i1]
    grid = pv.StructuredGrid(*(c[..., a].transpose(2, 1, 0) for a in range(3)))
    times = np.arange(steps) * 0.01
    entries = []
    for k, t in enumerate(times):
        g = grid.copy()
        p = np.asarray(g.points)
        blob = np.exp(-((p[:, 0]) ** 2 + (p[:, 1] - 1.0) ** 2 + (p[:, 2] - 0.25) ** 2) / width)
        g.point_data["density"] = 1.2 + 0.01 * np.sin(2 * np.pi * 10 * t) * blob
        turn = swirl * np.sin(2 * np.pi * 10 * t) * blob
        g.point_data["velocity"] = np.stack(
            [-(p[:, 1] - 1.0) * turn, p[:, 0] * turn, np.zeros(g.n_points)], axis=-1
        )
        g.save(folder / f"step_{k}.vts")
        entries.append(f'<DataSet timestep="{float(t)!r}" file="step_{k}.vts"/>')
    path = folder / "series.pvd"
    path.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">'
        f"<Collection>{''.join(entries)}</Collection></VTKFile>\n"
    )
    return path, c, times


@pytest.fixture(scope="module")
def vts_series(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray, np.ndarray]:
    return write_vts_series(tmp_path_factory.mktemp("vts"))


def test_vts_series_is_read_natively(vts_series) -> None:  # type: ignore[no-untyped-def]
    from auralize.io import ResampledWarning, open_volume

    path, c, times = vts_series
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResampledWarning)
        vol = open_volume(path)
    assert vol.curvilinear and vol.dims == (10, 24, 5) and vol.valid is None
    np.testing.assert_allclose(vol.coords, c, atol=1e-12)
    np.testing.assert_allclose(vol.times, times)
    assert vol.field_names == ["density", "velocity"] and vol.is_vector("velocity")
    p = vol.points()
    blob = np.exp(-((p[:, 0]) ** 2 + (p[:, 1] - 1.0) ** 2 + (p[:, 2] - 0.25) ** 2) / 0.02)
    np.testing.assert_allclose(
        vol.frame("density", 3).reshape(-1),
        1.2 + 0.01 * np.sin(2 * np.pi * 10 * times[3]) * blob,
        rtol=1e-12,
    )
    ymax = 1.5 * np.sin(np.linspace(0, np.pi, 24)).max()  # no point at θ = π/2
    assert vol.bounds == pytest.approx((-1.5, 1.5, 0.0, ymax, 0.0, 0.5), abs=1e-12)
    # resampling stays reachable
    with pytest.warns(ResampledWarning, match="resampled"):
        res = open_volume(path, curvilinear="resample")
    assert not res.curvilinear and res.valid is not None
    with pytest.warns(ResampledWarning):
        assert not open_volume(path, resolution=16).curvilinear
    with pytest.raises(ParameterError, match="curvilinear='sometimes'"):
        open_volume(path, curvilinear="sometimes")


def test_moving_curvilinear_grid_is_refused(tmp_path: Path) -> None:
    from auralize.io import open_volume

    path, c, _ = write_vts_series(tmp_path, steps=2)
    g = pv.read(tmp_path / "step_1.vts")
    g.points = np.asarray(g.points) * 1.1
    g.save(tmp_path / "step_1.vts")
    vol = open_volume(path)
    with pytest.raises(
        DataError,
        match=r"step_1.vts\): the curvilinear grid.s points moved \(by up to 0.15 m\).*--resample",
    ):
        vol.frame("density", 1)


def test_cli_info_detect_render_natively(vts_series, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    import h5py

    from auralize.audio import read_wav
    from auralize.cli import main

    path, c, times = vts_series
    assert main(["info", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["grid"] == "curvilinear, native" and d["dims"] == [10, 24, 5]
    assert d["times"] == pytest.approx(times.tolist()) and set(d["fields"]) == {
        "density",
        "velocity",
    }
    chord = 2 * np.sin(0.5 * np.pi / 23)  # the angular edges, from r = 0.5 to 1.5 m
    assert d["edge_lengths"] == pytest.approx([0.5 * chord, 1.5 * chord], rel=1e-9)
    assert main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "curvilinear, native: 10 x 24 x 5 points" in text and "x[-1.5, 1.5]" in text
    assert main(["info", str(path), "--resample"]) == 0
    assert "curvilinear" not in capsys.readouterr().out

    out = tmp_path / "s.h5"
    assert main(["detect", str(path), "-o", str(out), "--threshold-monopole", "10%", "--json"]) == 0
    steps = json.loads(capsys.readouterr().out)["steps"]
    assert len(steps) == times.size and sum(s["monopole"] for s in steps) > 0
    with h5py.File(out) as h:
        pos, index = h["position"][...], h["index"][...]
    np.testing.assert_allclose(pos, c.reshape(-1, 3)[index])  # the grid's own points
    centre = pos.mean(axis=0)
    assert np.linalg.norm(centre - [0.0, 1.0, 0.25]) < 0.15

    from auralize.sources.sources_file import load_sources_h5

    again = load_sources_h5(out)  # alone: the sources' own points known, the others NaN
    assert again.coords is not None and np.isnan(again.coords).any()
    np.testing.assert_allclose(again.positions(index), pos)
    wav_s = tmp_path / "s.wav"
    assert (
        main(
            [
                "render",
                str(path),
                "--sources",
                str(out),
                "--heard",
                "detected",
                "--listener",
                "0,-1,0.25",
                "--duration",
                "0.05",
                "--rate",
                "8000",
                "-o",
                str(wav_s),
            ]
        )
        == 0
    )
    capsys.readouterr()
    # the sources file's points put back on the grid: the same sound as detecting here
    wav_d = tmp_path / "d.wav"
    assert (
        main(
            [
                "render",
                str(path),
                "--heard",
                "detected",
                "--threshold-monopole",
                "10%",
                "--listener",
                "0,-1,0.25",
                "--duration",
                "0.05",
                "--rate",
                "8000",
                "-o",
                str(wav_d),
            ]
        )
        == 0
    )
    capsys.readouterr()
    from_file, here = read_wav(wav_s)[0], read_wav(wav_d)[0]
    assert np.abs(here).max() > 0.5 and np.array_equal(from_file, here)
    wav = tmp_path / "a.wav"
    assert (
        main(
            [
                "render",
                str(path),
                "--listener",
                "0,-1,0.25",
                "--duration",
                "0.05",
                "--rate",
                "8000",
                "-o",
                str(wav),
                "--normalize",
                "none",
                "--json",
            ]
        )
        == 0
    )
    meta = json.loads(capsys.readouterr().out)
    audio, rate, _ = read_wav(wav)
    assert rate == 8000 and audio.shape[1] == 400 and np.isfinite(audio).all()
    assert np.abs(audio).max() > 0 and meta["output"] == str(wav)


def test_saving_a_curvilinear_volume_resamples_it(vts_series, tmp_path) -> None:  # type: ignore[no-untyped-def]
    from auralize.io import ResampledWarning, open_volume, save_volume

    path, c, times = vts_series
    vol = open_volume(path)
    with pytest.warns(ResampledWarning, match="StructuredGrid with 1200 points resampled"):
        save_volume(vol, tmp_path / "u.h5")
    back = open_volume(tmp_path / "u.h5")
    assert not back.curvilinear and back.n_steps == times.size
    assert back.bounds == pytest.approx(vol.bounds, abs=1e-9)
    # inside the shell the resampled density is the blob's, to interpolation error (2.7e-3 of
    # the blob's 5.9e-3 at this step: what resampling the coarse shell loses)
    d = back.frame("density", 2)
    p = back.points()[back.valid_mask().reshape(-1)]
    blob = np.exp(-((p[:, 0]) ** 2 + (p[:, 1] - 1.0) ** 2 + (p[:, 2] - 0.25) ** 2) / 0.02)
    exact = 1.2 + 0.01 * np.sin(2 * np.pi * 10 * times[2]) * blob
    assert np.abs(d.reshape(-1)[back.valid_mask().reshape(-1)] - exact).max() < 4e-3


def test_view_and_pictures_draw_the_grid_natively(vts_series, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The viewer's scene and the pictures draw a curvilinear volume on its own points
    (a StructuredGrid; the volume representation as slices), with its detected sources."""
    import matplotlib.image as mpimg

    from auralize.cli import main
    from auralize.io import open_volume
    from auralize.scene.pictures import data_grid, screenshot

    path, c, _ = vts_series
    vol = open_volume(path)
    grid = data_grid(vol)
    assert type(grid).__name__ == "StructuredGrid" and grid.n_points == vol.n_points
    np.testing.assert_allclose(np.asarray(grid.points), c.reshape(-1, 3))
    shots = [tmp_path / "view.png", tmp_path / "picture.png"]
    assert (
        main(
            [
                "view",
                str(path),
                "--detect",
                "--time",
                "3",
                "--window-size",
                "400x300",
                "--screenshot",
                str(shots[0]),
            ]
        )
        == 0
    )
    screenshot(vol, shots[1], step=3, window_size=(400, 300))
    for shot in shots:
        grey = (mpimg.imread(shot)[:250, :, :3] * 255).mean(axis=2)
        assert (grey > 60).mean() > 0.02, shot.name  # more than the outline on black


def test_sound_models_resample_and_fwh_refuses_in_one_line(vts_series, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """Sound models read a curvilinear grid resampled (their physics takes uniform
    spacing); the FW-H sampling refuses it in one line naming --resample, with which
    the same command runs."""
    from auralize.cli import main
    from auralize.fwh.sampling import trilinear_weights
    from auralize.io import ResampledWarning, open_volume
    from auralize.plugins import load_volume_input

    path, _, _ = vts_series
    with pytest.warns(ResampledWarning):
        assert not load_volume_input(str(path)).curvilinear
    with pytest.raises(DataError, match="FW-H integral .* add --resample"):
        trilinear_weights(open_volume(path), np.zeros((1, 3)))
    fwh = [
        str(path),
        "--method",
        "fwh",
        "--surface",
        "box=-0.3;0.3;0.7;1.2;0.1;0.4",
        "--listener",
        "0,-2,0.25",
    ]
    assert main(["spectrum", *fwh]) == 3
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err, err
    assert err == (
        f"auralize spectrum: error: {path}: the FW-H integral samples its surface on "
        f"a uniform grid, and this curvilinear grid is read on its own points: add "
        f"--resample (curvilinear='resample' in Python) to read it resampled onto a "
        f"uniform grid"
    )
    assert main(["spectrum", *fwh, "--resample", "--json"]) == 0
    got = capsys.readouterr()
    assert "FW-H on box" in json.loads(got.out)["source"] and "resampled by linear" in got.err


def _warped_series(n: tuple[int, int, int] = (14, 12, 22), steps: int = 7) -> TimeVolume:
    """A pulsating blob in a pulsating swirl on a warped grid (curvilinear, in memory)."""
    c = warped(n, a=0.08)
    t = np.arange(steps) * 0.01
    blob = np.exp(-((c - 0.5) ** 2).sum(-1) / 0.02)
    rho = 1.2 + 0.01 * np.sin(2 * np.pi * 7 * t)[:, None, None, None] * blob[None]
    vel = np.stack([np.sin(3 * c[..., 1]), np.cos(2 * c[..., 2]), np.sin(2 * c[..., 0])], -1)
    amp = 1 + 0.3 * np.sin(2 * np.pi * 5 * t)
    return TimeVolume.from_arrays(
        {"density": rho, "velocity": amp[:, None, None, None, None] * vel[None]}, times=t, coords=c
    )


@pytest.mark.parametrize("mapping", ["identity", "paper-density"])
@pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")  # low thresholds
def test_distributed_detection_on_a_curvilinear_grid_is_the_serial_one(mapping: str) -> None:
    """Dask's z-slabs of a curvilinear grid hold their points; with the ghost planes of its
    stencils (a divergence of divergences, the 2h ones of the floor) every slab's
    sources are the whole grid's, bit for bit, as on a uniform grid."""
    pytest.importorskip("dask")
    from auralize.distributed import chunked_volume, detect_distributed
    from auralize.sources.detection import Thresholds, detect

    vol = _warped_series()
    kw = {"field": "density"} if mapping == "paper-density" else {}
    for thr in (Thresholds(), Thresholds(1e-3, 1e-3, 1e-3, floor=0.0)):
        serial = detect(vol, mapping=mapping, thresholds=thr, **kw)
        dask = detect_distributed(
            chunked_volume(vol),
            mapping=mapping,
            thresholds=thr,
            slab_planes=4,
            chunk_steps=3,
            log=None,
            **kw,
        )
        assert len(dask.meta["scale"]["slabs"]) == 6 and dask.meta["grid"] == "curvilinear"
        np.testing.assert_array_equal(dask.thresholds, serial.thresholds)
        n = 0
        for a, b in zip(serial.frames, dask.frames, strict=True):
            for key in ("index", "kind", "strength", "radius"):
                np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)
            n += a.index.size
        assert n > 500
        np.testing.assert_array_equal(
            dask.positions(serial.frames[3].index), vol.points(serial.frames[3].index)
        )


@pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")
def test_one_ghost_plane_fewer_changes_the_sources(monkeypatch: pytest.MonkeyPatch) -> None:
    """The curvilinear ghost planes are no more than the stencils need: with one fewer,
    the slabs' sources differ from the whole grid's (so the test above can fail)."""
    pytest.importorskip("dask")
    import auralize.distributed.detect as dd
    from auralize.sources.detection import Thresholds, detect

    vol = _warped_series()
    need = dd.ghost_planes
    monkeypatch.setattr(dd, "ghost_planes", lambda v, *, floor: need(v, floor=floor) - 1)
    for thr in (Thresholds(1e-3, 1e-3, 1e-3), Thresholds(1e-3, 1e-3, 1e-3, floor=0.0)):
        serial = detect(vol, mapping="identity", thresholds=thr)
        short = dd.detect_distributed(vol, thresholds=thr, slab_planes=4, chunk_steps=3, log=None)
        assert not all(
            np.array_equal(a.strength, b.strength) and np.array_equal(a.radius, b.radius)
            for a, b in zip(serial.frames, short.frames, strict=True)
        )


@pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")
def test_cli_detect_and_render_on_dask_natively(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """``detect``/``render`` with a Dask scheduler on a curvilinear series: the serial
    sources, bit for bit; the Dask render detecting on its workers sounds as the Dask
    render of the serial sources file."""
    pytest.importorskip("dask")
    from auralize.audio import read_wav
    from auralize.cli import main

    path, c, _ = write_vts_series(tmp_path / "s", n=(8, 16, 12), swirl=0.5)
    dask = ["--scheduler", "threads", "--workers", "2"]
    assert main(["detect", str(path), *THRESHOLDS, "-o", str(tmp_path / "serial.h5")]) == 0
    assert (
        main(
            [
                "detect",
                str(path),
                *THRESHOLDS,
                "-o",
                str(tmp_path / "dask.h5"),
                *dask,
                "--chunk-steps",
                "3",
                "--slab-planes",
                "4",
            ]
        )
        == 0
    )
    assert "3 slabs" in capsys.readouterr().out
    serial, on_dask = _sources(tmp_path / "serial.h5"), _sources(tmp_path / "dask.h5")
    assert serial["index"].size > 50
    for key, value in serial.items():
        np.testing.assert_array_equal(on_dask[key], value, err_msg=key)
    np.testing.assert_array_equal(serial["position"], c.reshape(-1, 3)[serial["index"]])
    wavs = []
    for extra in ([], ["--sources", str(tmp_path / "serial.h5")]):
        wav = tmp_path / f"{len(wavs)}.wav"
        assert (
            main(
                [
                    "render",
                    str(path),
                    "--heard",
                    "detected",
                    *THRESHOLDS,
                    *dask,
                    "--listener",
                    "0,-1,0.25",
                    "--duration",
                    "0.05",
                    "--rate",
                    "8000",
                    "--normalize",
                    "none",
                    "-o",
                    str(wav),
                    *extra,
                ]
            )
            == 0
        )
        wavs.append(read_wav(wav)[0])
    capsys.readouterr()
    assert np.abs(wavs[0]).max() > 0 and np.array_equal(wavs[0], wavs[1])


def test_uneven_rectilinear_vtr_is_read_natively(tmp_path: Path) -> None:
    from auralize.io import ResampledWarning, open_volume

    x, y, z = np.array([0.0, 0.1, 0.3, 0.7, 1.5]), np.array([0.0, 1.0, 2.0]), np.array([0.0, 0.5])
    grid = pv.RectilinearGrid(x, y, z)
    grid.point_data["rho"] = np.asarray(grid.points)[:, 0] * 2.0
    grid.save(tmp_path / "r.vtr")
    vol = open_volume(tmp_path / "r.vtr")
    assert vol.curvilinear and vol.dims == (5, 3, 2)
    np.testing.assert_array_equal(vol.coords[0, 0, :, 0], x)
    g = vol.metric.gradient(vol.frame("rho", 0))
    assert np.abs(g - [2.0, 0.0, 0.0]).max() < 1e-12  # ∂(2x)/∂x on the uneven axis
    with pytest.warns(ResampledWarning, match="RectilinearGrid"):
        assert not open_volume(tmp_path / "r.vtr", curvilinear="resample").curvilinear


def write_curvilinear_nc(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A netCDF file on a rotated lat/lon grid (2-D ``lon(y, x)``, ``lat(y, x)`` named by
    CF's ``coordinates``), three depth levels; ``rho`` is linear in longitude."""
    from scipy.io import netcdf_file

    j, i = np.meshgrid(np.arange(7.0), np.arange(9.0), indexing="ij")
    a = np.deg2rad(30.0)
    lon = 10.0 + 0.1 * (np.cos(a) * i - np.sin(a) * j)
    lat = 45.0 + 0.1 * (np.sin(a) * i + np.cos(a) * j)
    with netcdf_file(path, "w") as f:
        for name, n in (("time", 3), ("depth", 3), ("eta", 7), ("xi", 9)):
            f.createDimension(name, n)
        t = f.createVariable("time", "f8", ("time",))
        t.units = "hours since 2001-01-01"
        t[:] = [0.0, 1.0, 2.0]
        d = f.createVariable("depth", "f8", ("depth",))
        d.units, d.positive = "m", "down"
        d[:] = [0.0, 10.0, 30.0]
        for name, values, units in (("lon", lon, "degrees_east"), ("lat", lat, "degrees_north")):
            v = f.createVariable(name, "f8", ("eta", "xi"))
            v.units = units
            v[:] = values
        rho = f.createVariable("rho", "f8", ("time", "depth", "eta", "xi"))
        rho.coordinates = "lon lat"
        rho[:] = 1025.0 + np.arange(3.0)[:, None, None, None] * 1e-3 + 0.0 * lon + lon[None, None]
    return lon, lat


def test_netcdf_2d_lat_lon_is_read_natively(tmp_path: Path) -> None:
    from auralize.io import ResampledWarning, open_volume

    lon, lat = write_curvilinear_nc(tmp_path / "roms.nc")
    vol = open_volume(tmp_path / "roms.nc")
    assert vol.curvilinear and vol.dims == (9, 7, 3) and vol.n_steps == 3
    mid = np.deg2rad(0.5 * (lat.min() + lat.max()))
    R = 6371000.0
    np.testing.assert_allclose(vol.coords[0, ..., 0], R * np.cos(mid) * np.deg2rad(lon))
    np.testing.assert_allclose(vol.coords[0, ..., 1], R * np.deg2rad(lat))
    np.testing.assert_allclose(vol.coords[:, 0, 0, 2], [-30.0, -10.0, 0.0])  # depth: flipped up
    assert vol.attrs["axis_units"]["x"].startswith("longitude (2-D) -> m")
    # rho - 1025 - step/1000 is the longitude: its gradient is 1 / (R cos φm) per degree, east
    g = vol.metric.gradient(vol.frame("rho", 0))
    np.testing.assert_allclose(g[..., 0], 1.0 / (R * np.cos(mid) * np.deg2rad(1.0)), rtol=1e-9)
    assert np.abs(g[..., 1:]).max() < 1e-12  # 0 to round-off (g_x is 1.3e-5)
    with pytest.warns(ResampledWarning, match="StructuredGrid with 189 points resampled"):
        assert not open_volume(tmp_path / "roms.nc", curvilinear="resample").curvilinear


# ------------------------------------------------- netCDF: 3-D vertical coordinates
def write_nc4(
    path: Path,
    dims: dict[str, np.ndarray | int],
    variables: dict[str, tuple[tuple[str, ...], np.ndarray, dict[str, str]]],
) -> None:
    """A netCDF4 file (HDF5 with dimension scales, as the netCDF library writes it):
    ``dims`` name -> coordinate values (or a length: a dimension without a variable),
    ``variables`` name -> (dimensions, values, attributes)."""
    import h5py

    with h5py.File(path, "w") as f:
        for name, vals in dims.items():
            if isinstance(vals, int):
                ds = f.create_dataset(name, data=np.zeros(vals))
                ds.make_scale("This is a netCDF dimension but not a netCDF variable.")
            else:
                ds = f.create_dataset(name, data=np.asarray(vals, dtype=np.float64))
                ds.make_scale(name)
        for name, (vdims, vals, attrs) in variables.items():
            ds = f[name] if name in f else f.create_dataset(name, data=np.asarray(vals, float))
            for k, v in attrs.items():
                ds.attrs[k] = v
            for axis, d in enumerate(vdims):
                if d != name:
                    ds.dims[axis].attach_scale(f[d])


def roms_like(
    path: Path, *, nt: int = 6, nk: int = 6, ny: int = 7, nx: int = 9
) -> dict[str, np.ndarray]:
    """A ROMS-like file: 2-D ``lon_rho``/``lat_rho`` named by ``coordinates``, s-levels
    ``ocean_s_coordinate_g2`` (``formula_terms``: s_rho, Cs_r, zeta, h, hc) under a free
    surface ``zeta`` that moves, ``rho`` a pulsating blob, ``temp`` linear in height.
    Returns the closed forms: ``z`` (the heights at zeta's time mean), ``lon``, ``lat``."""
    t = np.arange(nt) * 0.01
    j, i = np.meshgrid(np.arange(ny, dtype=float), np.arange(nx, dtype=float), indexing="ij")
    lon, lat = 10.0 + 0.002 * i + 0.0005 * j, 45.0 + 0.0004 * i + 0.0015 * j
    s_rho = (np.arange(nk) - nk + 0.5) / nk
    cs = -(s_rho**2) + 0.2 * s_rho  # stretching: C(0) = 0, C(-1) = -1.2
    h = 40.0 + 1.5 * i + 0.8 * j
    hc = 5.0
    zeta = 0.05 * np.sin(2 * np.pi * 10 * t)[:, None, None] * (1 + 0.01 * i)[None]
    eta = zeta.mean(axis=0)
    big_s = (hc * s_rho[:, None, None] + h[None] * cs[:, None, None]) / (hc + h[None])
    z = eta[None] + (eta[None] + h[None]) * big_s
    x = 6371000.0 * np.cos(np.deg2rad(0.5 * (lat.min() + lat.max()))) * np.deg2rad(lon)
    y = 6371000.0 * np.deg2rad(lat)
    r2 = ((x - x.mean()) / 120.0) ** 2 + ((y - y.mean()) / 120.0) ** 2
    blob = np.exp(-0.5 * (r2[None] + ((z + 20.0) / 8.0) ** 2))
    rho = 1025.0 + 0.01 * np.sin(2 * np.pi * 10 * t)[:, None, None, None] * blob[None]
    hor = ("eta_rho", "xi_rho")
    write_nc4(
        path,
        {"ocean_time": t, "s_rho": s_rho, "eta_rho": ny, "xi_rho": nx},
        {
            "ocean_time": (("ocean_time",), t, {"units": "seconds since 2001-01-01"}),
            "s_rho": (
                ("s_rho",),
                s_rho,
                {
                    "standard_name": "ocean_s_coordinate_g2",
                    "positive": "up",
                    "formula_terms": "s: s_rho C: Cs_r eta: zeta depth: h depth_c: hc",
                },
            ),
            "Cs_r": (("s_rho",), cs, {}),
            "hc": ((), np.asarray(hc), {"units": "m"}),
            "h": (hor, h, {"units": "m"}),
            "zeta": (("ocean_time", *hor), zeta, {"units": "m"}),
            "lon_rho": (hor, lon, {"units": "degree_east"}),
            "lat_rho": (hor, lat, {"units": "degree_north"}),
            "rho": (
                ("ocean_time", "s_rho", *hor),
                rho,
                {"units": "kg m-3", "coordinates": "lon_rho lat_rho"},
            ),
            "temp": (
                ("ocean_time", "s_rho", *hor),
                np.broadcast_to(20.0 + 0.1 * z, rho.shape),
                {"units": "degC", "coordinates": "lon_rho lat_rho"},
            ),
        },
    )
    return {"z": z, "x": x, "y": y, "zeta": zeta}


def test_netcdf_s_levels_are_read_natively(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """CF ocean_s_coordinate_g2 (formula_terms) under 2-D lon/lat: the heights of every
    point, in metres, at the free surface's time mean; a field linear in height has the
    gradient (0, 0, k) on them; info, detect and render through the command line."""
    from auralize.audio import read_wav
    from auralize.cli import main
    from auralize.io import ResampledWarning, open_volume

    path = tmp_path / "roms.nc"
    want = roms_like(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResampledWarning)
        vol = open_volume(path)
    assert vol.curvilinear and vol.dims == (9, 7, 6) and vol.n_steps == 6
    np.testing.assert_allclose(vol.coords[..., 2], want["z"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(vol.coords[..., 0], np.broadcast_to(want["x"], want["z"].shape))
    np.testing.assert_allclose(vol.coords[..., 1], np.broadcast_to(want["y"], want["z"].shape))
    note = vol.attrs["axis_units"]["z"]
    assert note.startswith(
        "ocean_s_coordinate_g2 -> m per point (formula_terms s: s_rho, C: "
        "Cs_r, eta: zeta, depth: h, depth_c: hc)"
    )
    moved = float(np.ptp(want["zeta"], axis=0).max())
    assert f"at the time mean of what moves (zeta by up to {moved:.3g} m): a fixed grid" in note
    g = vol.metric.gradient(vol.frame("temp", 2))
    assert np.abs(g - [0.0, 0.0, 0.1]).max() < 1e-9  # (levels taken flat: |g_x| ~ 1e-3)

    assert main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "grid     curvilinear, native: 9 x 7 x 6 points" in text
    assert "z: ocean_s_coordinate_g2 -> m per point" in text
    assert "a 3-D vertical coordinate (ocean_s_coordinate_g2): read on its own points" in text
    out = tmp_path / "s.h5"
    assert (
        main(
            [
                "detect",
                str(path),
                "--density-field",
                "rho",
                "--threshold-monopole",
                "10%",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    got = _sources(out)
    assert (got["kind"] == 1).sum() > 20
    np.testing.assert_allclose(got["position"], vol.points(got["index"]))
    centre = got["position"].mean(axis=0)
    assert abs(centre[2] + 20.0) < 4.0  # the blob's height
    wav = tmp_path / "a.wav"
    listener = ",".join(f"{v:.6f}" for v in (want["x"].mean(), want["y"].mean() - 500, -20.0))
    assert (
        main(
            [
                "render",
                str(path),
                "--density-field",
                "rho",
                "--listener",
                listener,
                "--duration",
                "0.05",
                "--rate",
                "8000",
                "-o",
                str(wav),
                "--normalize",
                "none",
            ]
        )
        == 0
    )
    audio = read_wav(wav)[0]
    assert np.isfinite(audio).all() and np.abs(audio).max() > 0
    capsys.readouterr()
    # --resample: onto a uniform grid over the same heights
    with pytest.warns(ResampledWarning, match="StructuredGrid with 378 points resampled"):
        res = open_volume(path, curvilinear="resample")
    assert not res.curvilinear
    assert res.bounds[4:] == pytest.approx((want["z"].min(), want["z"].max()), abs=1e-6)


@pytest.mark.parametrize("kind", ["height in km", "depth, moving"])
def test_netcdf_3d_height_named_by_coordinates(tmp_path: Path, kind: str) -> None:
    """A height (or depth) per point named by CF ``coordinates`` is the grid's z: its
    units to metres, positive down negated, a 4-D one at its time mean."""
    from auralize.io import open_volume

    nt, nk, ny, nx = 3, 4, 5, 6
    k, j, i = np.meshgrid(
        np.arange(nk, dtype=float),
        np.arange(ny, dtype=float),
        np.arange(nx, dtype=float),
        indexing="ij",
    )
    height = (0.1 + 0.02 * i) * (k + 1) + 0.01 * j  # km, increasing with k
    t = np.arange(nt) * 0.5
    variables = {
        "time": (("time",), t, {"units": "s"}),
        "x": (("x",), np.arange(nx) * 100.0, {"units": "m"}),
        "y": (("y",), np.arange(ny) * 100.0, {"units": "m"}),
        "rho": (("time", "lev", "y", "x"), np.ones((nt, nk, ny, nx)), {"coordinates": "zz"}),
    }
    if kind == "height in km":
        variables["zz"] = (("lev", "y", "x"), height, {"units": "km", "axis": "Z"})
        want = 1000.0 * height
    else:
        depth = 1000.0 * height[None] + np.array([0.0, 0.3, 0.9])[:, None, None, None]
        variables["zz"] = (
            ("time", "lev", "y", "x"),
            depth,
            {"units": "m", "standard_name": "depth", "positive": "down"},
        )
        want = -depth.mean(axis=0)
    write_nc4(
        tmp_path / "z.nc",
        {"time": t, "lev": nk, "y": np.arange(ny) * 100.0, "x": np.arange(nx) * 100.0},
        variables,
    )
    vol = open_volume(tmp_path / "z.nc")
    assert vol.curvilinear and vol.dims == (nx, ny, nk)
    np.testing.assert_allclose(vol.coords[..., 2], want, rtol=1e-12)
    np.testing.assert_array_equal(vol.coords[0, 0, :, 0], np.arange(nx) * 100.0)
    note = vol.attrs["axis_units"]["z"]
    if kind == "height in km":
        assert note == "zz (3-D, km) -> m per point"
    else:
        assert note == (
            "zz (3-D, m) -> m per point (positive down -> height: negated); at "
            "the time mean of what moves (zz by up to 0.9 m): a fixed grid"
        )


#: CF Appendix D, written out: formula_terms -> height (m) of the terms below
_CF = {
    "ocean_sigma_coordinate": (
        "sigma: lev eta: eta depth: depth",
        lambda v: v["eta"] + v["lev"] * (v["depth"] + v["eta"]),
    ),
    "ocean_s_coordinate": (
        "s: lev eta: eta depth: depth a: a b: b depth_c: hc",
        lambda v: (
            v["eta"] * (1 + v["lev"])
            + v["hc"] * v["lev"]
            + (v["depth"] - v["hc"])
            * (
                (1 - v["b"]) * np.sinh(v["a"] * v["lev"]) / np.sinh(v["a"])
                + v["b"] * (np.tanh(v["a"] * (v["lev"] + 0.5)) / (2 * np.tanh(0.5 * v["a"])) - 0.5)
            )
        ),
    ),
    "ocean_s_coordinate_g1": (
        "s: lev C: cs eta: eta depth: depth depth_c: hc",
        lambda v: (
            (v["hc"] * v["lev"] + (v["depth"] - v["hc"]) * v["cs"]) * (1 + v["eta"] / v["depth"])
            + v["eta"]
        ),
    ),
    "atmosphere_hybrid_height_coordinate": (
        "a: ah b: cs orog: orog",
        lambda v: v["ah"] + v["cs"] * v["orog"],
    ),
    "atmosphere_sigma_coordinate": (
        "sigma: sig ps: ps ptop: ptop",
        lambda v: v["ptop"] + v["sig"] * (v["ps"] - v["ptop"]),
    ),
    "atmosphere_ln_pressure_coordinate": ("p0: p0 lev: lnp", lambda v: v["p0"] * np.exp(-v["lnp"])),
}


@pytest.mark.parametrize("std", sorted(_CF))
def test_netcdf_parametric_formulas(tmp_path: Path, std: str) -> None:
    """Every CF Appendix D formula evaluated gives the heights it defines per point
    (pressures through the standard atmosphere); time-varying terms at their mean."""
    from auralize.io import open_volume
    from auralize.io.netcdf import standard_height

    nt, nk, ny, nx = 3, 4, 3, 5
    rng = np.random.default_rng(len(std))
    lev = np.linspace(-0.9, -0.1, nk)
    v = {
        "lev": lev[:, None, None],
        "cs": (lev**3)[:, None, None],
        "hc": np.array(8.0),
        "a": np.array(3.0),
        "b": np.array(0.4),
        "ah": np.linspace(10, 900, nk)[:, None, None],
        "depth": 30.0 + rng.uniform(0, 20, (ny, nx)),
        "orog": rng.uniform(0, 500, (ny, nx)),
        "sig": np.linspace(0.95, 0.2, nk)[:, None, None],
        "ptop": np.array(1000.0),
        "ps": 1e5 + rng.uniform(-500, 500, (ny, nx)),
        "p0": np.array(1e5),
        "lnp": np.linspace(0.05, 1.5, nk)[:, None, None],
    }
    eta_t = rng.uniform(-0.2, 0.2, (nt, ny, nx))
    v["eta"] = eta_t.mean(axis=0)
    terms, height = _CF[std]
    want = np.broadcast_to(height(v), (nk, ny, nx))
    if not std.startswith("ocean") and std != "atmosphere_hybrid_height_coordinate":
        want = standard_height(np.ascontiguousarray(want))
    dims = {
        "time": np.arange(nt) * 1.0,
        "lev": lev,
        "y": np.arange(ny) * 10.0,
        "x": np.arange(nx) * 10.0,
    }
    shapes = {3: ("lev", "y", "x"), 2: ("y", "x"), 0: ()}
    variables = {
        "time": (("time",), dims["time"], {"units": "s"}),
        "lev": (("lev",), lev, {"standard_name": std, "formula_terms": terms}),
        "eta": (("time", "y", "x"), eta_t, {"units": "m"}),
        "f": (("time", "lev", "y", "x"), np.zeros((nt, nk, ny, nx)), {}),
    }
    for name, value in v.items():
        if name in ("lev", "eta") or f": {name}" not in terms:
            continue
        a = np.asarray(value)
        a = a.reshape(-1) if a.ndim == 3 else a  # 1-D over lev
        dn = ("lev",) if np.asarray(value).ndim == 3 else shapes[a.ndim]
        variables[name] = (dn, a, {"units": "Pa"} if name in ("ps", "ptop", "p0") else {})
    write_nc4(tmp_path / "v.nc", dims, variables)
    vol = open_volume(tmp_path / "v.nc")
    assert vol.curvilinear and vol.attrs["axis_units"]["z"].startswith(f"{std} -> m per point")
    np.testing.assert_allclose(vol.coords[..., 2], want, rtol=1e-12, atol=1e-9)


def test_netcdf_pressure_formula_and_what_is_not_evaluated(tmp_path: Path) -> None:
    """atmosphere_hybrid_sigma_pressure_coordinate (ap, b, ps): heights of the standard
    atmosphere per point; a formula not evaluated is refused naming those that are and
    --axis-scale, which gives one height per level (its values times SZ)."""
    from auralize.errors import FormatError
    from auralize.io import open_volume
    from auralize.io.netcdf import standard_height

    nt, nk, ny, nx = 2, 3, 4, 5
    ap, b = np.array([5000.0, 20000.0, 0.0]), np.array([0.0, 0.3, 0.9])
    ps = 100000.0 + 200.0 * np.arange(nx)[None, :] + 50.0 * np.arange(ny)[:, None]
    dims = {"time": np.arange(nt) * 1.0, "lev": np.arange(nk) * 1.0, "y": ny, "x": nx}
    variables = {
        "time": (("time",), dims["time"], {"units": "s"}),
        "lev": (
            ("lev",),
            dims["lev"],
            {
                "standard_name": "atmosphere_hybrid_sigma_pressure_coordinate",
                "formula_terms": "ap: hyam b: hybm ps: PS",
            },
        ),
        "hyam": (("lev",), ap, {"units": "Pa"}),
        "hybm": (("lev",), b, {}),
        "PS": (("y", "x"), ps / 100.0, {"units": "hPa"}),
        "ua": (("time", "lev", "y", "x"), np.ones((nt, nk, ny, nx)), {}),
    }
    write_nc4(tmp_path / "p.nc", dims, variables)
    vol = open_volume(tmp_path / "p.nc")
    p = ap[:, None, None] + b[:, None, None] * ps[None]
    np.testing.assert_allclose(vol.coords[..., 2], standard_height(p), rtol=1e-12)
    assert vol.attrs["axis_units"]["z"].endswith("pressure -> height in the standard atmosphere)")
    # ocean_sigma_z_coordinate: not evaluated
    variables["lev"] = (
        ("lev",),
        dims["lev"],
        {"standard_name": "ocean_sigma_z_coordinate", "formula_terms": "sigma: lev"},
    )
    write_nc4(tmp_path / "q.nc", dims, variables)
    with pytest.raises(
        FormatError,
        match=r"'lev' is a parametric vertical coordinate .* "
        r"evaluates atmosphere_hybrid_height_coordinate, .*ocean_s_coordinate_g2, "
        r"ocean_sigma_coordinate from their formula_terms\); give --axis-scale ",
    ):
        open_volume(tmp_path / "q.nc")
    levels = open_volume(tmp_path / "q.nc", axis_scale=(1.0, 1.0, 100.0))
    assert not levels.curvilinear and levels.spacing[2] == pytest.approx(100.0)


def test_sessions_and_convert_keep_the_resample_choice(vts_series, tmp_path) -> None:  # type: ignore[no-untyped-def]
    from auralize.cli import main
    from auralize.io import ResampledWarning, open_volume
    from auralize.scene.session import data_spec, load_data

    path, _, times = vts_series
    assert load_data(data_spec(str(path))).curvilinear
    d = data_spec(str(path), curvilinear="resample")
    assert d["curvilinear"] == "resample"
    with pytest.warns(ResampledWarning):
        assert not load_data(d).curvilinear
    out = tmp_path / "c.h5"  # a uniform format: resampled either way
    assert main(["convert", str(path), str(out), "--resample"]) == 0
    back = open_volume(out)
    assert not back.curvilinear and back.n_steps == times.size


def test_convert_saves_a_curvilinear_series_resampled_correctly(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """``convert`` to the uniform formats: read natively and resampled on saving, or read
    resampled (--resample), the same frames in .h5, .pvd and .vtkhdf, on the points of
    the shell equal to the blob to interpolation error; with --box (cropped natively,
    then saved) the uniform grid over the box that --resample --box gives."""
    from auralize.cli import main
    from auralize.io import open_volume

    path, c, times = write_vts_series(tmp_path / "s", swirl=0.5)
    box = "--box=" + ",".join(f"{v:g}" for v in BOX)
    runs = {
        "native.h5": [],
        "resampled.h5": ["--resample"],
        "native.pvd": [],
        "native.vtkhdf": [],
        "box.h5": [box],
        "resampled-box.h5": ["--resample", box],
    }
    vols = {}
    for name, extra in runs.items():
        assert main(["convert", str(path), str(tmp_path / name), *extra]) == 0
        assert "resampled by linear interpolation" in capsys.readouterr().err
        vols[name] = open_volume(tmp_path / name)
    ref = vols["native.h5"]
    assert not ref.curvilinear and ref.dims == (29, 15, 6) and ref.n_steps == times.size
    assert ref.bounds == pytest.approx(open_volume(path).bounds, abs=1e-9)
    assert 0.6 < ref.valid_ratio < 0.7  # the half-annulus in its bounding box
    for a, b in (
        ("native.h5", "resampled.h5"),
        ("native.h5", "native.pvd"),
        ("native.h5", "native.vtkhdf"),
        ("box.h5", "resampled-box.h5"),
    ):
        va, vb = vols[a], vols[b]
        assert (va.dims, va.origin.tolist(), va.spacing.tolist()) == (
            vb.dims,
            vb.origin.tolist(),
            vb.spacing.tolist(),
        ), (a, b)
        for n in range(times.size):
            for f in ("density", "velocity"):
                np.testing.assert_array_equal(va.frame(f, n), vb.frame(f, n), err_msg=f"{b} {f}")
    # inside the shell, the blob to interpolation error (the coarse shell: 2.7e-3 of 5.9e-3)
    ok = ref.valid_mask().reshape(-1)
    p = ref.points()[ok]
    blob = np.exp(-(p[:, 0] ** 2 + (p[:, 1] - 1.0) ** 2 + (p[:, 2] - 0.25) ** 2) / 0.02)
    exact = 1.2 + 0.01 * np.sin(2 * np.pi * 10 * times[2]) * blob
    err = np.abs(ref.frame("density", 2).reshape(-1)[ok] - exact)
    assert err.max() < 4e-3 and np.isnan(ref.frame("density", 2).reshape(-1)[~ok]).all()
    # the box: a uniform grid over it (not over the index block, which is larger)
    vb = vols["box.h5"]
    b = vb.bounds
    assert b[0] == pytest.approx(BOX[0]) and b[2] == pytest.approx(BOX[2]) and b[4] == 0.0
    assert all(b[2 * a + 1] <= BOX[2 * a + 1] + 1e-9 for a in range(3))
    assert vb.valid_ratio > 0.85


def test_divergence_free_flow_has_no_dipoles_on_a_warped_grid() -> None:
    """∇·(ρv) of a divergence-free flow at constant density is truncation error on the
    warped grid (not 0 as on the uniform one): the floor (its Richardson estimate) keeps
    it from being a dipole; the quadrupoles are those of the uniform grid."""
    from auralize.sources.detection import compute_strengths, detect

    n, times = 20, np.arange(10) * 0.01
    s = np.linspace(0.0, 1.0, n)
    zz, yy, xx = np.meshgrid(s, s, s, indexing="ij")
    a = 0.04
    c = np.stack(
        [
            xx + a * np.sin(np.pi * xx) * np.sin(np.pi * yy),
            yy + a * np.sin(np.pi * yy) * np.sin(np.pi * zz),
            zz,
        ],
        axis=-1,
    )
    amp = (1 + 0.5 * np.sin(2 * np.pi * 5 * times))[:, None, None, None, None]
    rho = np.full((times.size, n, n, n), 1.2)

    def flow(p: np.ndarray) -> np.ndarray:
        return (
            amp
            * np.stack(
                [np.sin(3 * p[..., 1]), np.sin(3 * p[..., 0]), np.zeros(p.shape[:3])], axis=-1
            )[None]
        )

    cur = TimeVolume.from_arrays({"density": rho, "velocity": flow(c)}, times=times, coords=c)
    uniform = np.stack([xx, yy, zz], axis=-1)
    uni = TimeVolume.from_arrays(
        {"density": rho, "velocity": flow(uniform)}, times=times, spacing=s[1]
    )
    assert np.abs(compute_strengths(cur, "identity", 4)[1]).max() > 1e-3  # truncation error
    counts = {}
    for name, vol in (("uniform", uni), ("curvilinear", cur)):
        series = detect(vol, mapping="identity")
        counts[name] = [
            sum(c[k] for c in series.counts()) for k in ("monopole", "dipole", "quadrupole")
        ]
    assert counts["curvilinear"][:2] == [0, 0] and counts["uniform"][:2] == [0, 0]
    assert counts["curvilinear"][2] == pytest.approx(counts["uniform"][2], rel=0.1)


# ---------------------------------------------------------- box: index space
BOX = (-0.6, 0.6, 0.6, 1.6, 0.0, 0.5)
#: absolute thresholds (the same in every run, whatever region it sees)
THRESHOLDS = [
    "--threshold-monopole",
    "0.05",
    "--threshold-dipole",
    "0.5",
    "--threshold-quadrupole",
    "0.01",
]


def _sources(path: Path) -> dict[str, np.ndarray]:
    import h5py

    with h5py.File(path) as h:
        return {
            k: h[k][...] for k in ("offsets", "index", "position", "kind", "strength", "radius")
        }


def test_a_box_around_or_beside_a_curvilinear_grid(vts_series) -> None:  # type: ignore[no-untyped-def]
    """A box holding the whole grid keeps it all (and says so); one beside it is refused
    with the grid's extent."""
    from auralize.io import open_volume

    path, c, _ = vts_series
    whole = open_volume(path, box=(-2, 2, -1, 2, -1, 1))
    assert whole.dims == (10, 24, 5) and whole.attrs["index_block"] == {
        "i": [0, 9],
        "j": [0, 23],
        "k": [0, 4],
        "of": [10, 24, 5],
    }
    np.testing.assert_array_equal(whole.coords, c)
    with pytest.raises(
        DataError,
        match=r"the box 2, 3, 0, 1, 0, 1 m overlaps no cell of the "
        r"curvilinear grid \(it spans x\[-1.5, 1.5\] y\[0, 1.4965\] "
        r"z\[0, 0.5\] m\)",
    ):
        open_volume(path, box=(2, 3, 0, 1, 0, 1))


def test_box_crops_a_curvilinear_grid_in_index_space(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """--box keeps a curvilinear grid native: the smallest index block whose cells cover
    the box.  info, detect and render on it equal those on a file of that block alone
    (bit for bit), and detection inside it equals the whole grid's away from the cut faces."""
    from auralize.audio import read_wav
    from auralize.cli import main
    from auralize.io import ResampledWarning, open_volume

    full, c, times = write_vts_series(tmp_path / "full", swirl=0.5, width=0.5)  # broad
    box = "--box=" + ",".join(f"{v:g}" for v in BOX)  # '=': it starts with a minus sign
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResampledWarning)
        vol = open_volume(full, box=BOX)
    blk = vol.attrs["index_block"]
    (i0, i1), (j0, j1), (k0, k1) = blk["i"], blk["j"], blk["k"]
    assert blk["of"] == [10, 24, 5] and (i0, i1, j0, j1, k0, k1) == (0, 9, 5, 18, 0, 4)
    assert vol.curvilinear and vol.dims == (i1 - i0 + 1, j1 - j0 + 1, k1 - k0 + 1)
    assert vol.n_points == 10 * 14 * 5 < c.shape[0] * c.shape[1] * c.shape[2]
    np.testing.assert_array_equal(vol.coords, c[k0 : k1 + 1, j0 : j1 + 1, i0 : i1 + 1])
    # the block's cells cover the box: VTK's cell locator puts every point of the box that
    # lies in the grid in one of them, and such points reach every face of the block
    grid = pv.StructuredGrid(*(c[..., a].transpose(2, 1, 0) for a in range(3)))
    p = np.random.default_rng(0).uniform(BOX[::2], BOX[1::2], size=(20000, 3))
    cell = grid.find_containing_cell(p)
    assert (cell >= 0).mean() > 0.8
    ck, cj, ci = np.unravel_index(cell[cell >= 0], (4, 23, 9))
    assert (ci.min(), ci.max() + 1, cj.min(), cj.max() + 1, ck.min(), ck.max() + 1) == (
        i0,
        i1,
        j0,
        j1,
        k0,
        k1,
    )
    tol = 1e-9 * 3.0
    inside = np.ones(c.shape[:3], dtype=bool)
    for a in range(3):
        inside &= (c[..., a] >= BOX[2 * a] - tol) & (c[..., a] <= BOX[2 * a + 1] + tol)
    in_block = np.zeros_like(inside)
    in_block[k0 : k1 + 1, j0 : j1 + 1, i0 : i1 + 1] = True
    assert inside.sum() == 340 and not (inside & ~in_block).any()
    b = vol.bounds
    flat = c[in_block]
    assert b == pytest.approx(
        tuple(v for a in range(3) for v in (flat[:, a].min(), flat[:, a].max()))
    )
    np.testing.assert_array_equal(
        vol.frame("density", 3),
        open_volume(full).frame("density", 3)[k0 : k1 + 1, j0 : j1 + 1, i0 : i1 + 1],
    )

    assert main(["info", str(full), box, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["grid"] == "curvilinear, native" and d["dims"] == [10, 14, 5]
    assert d["index_block"] == blk and d["bounds"] == pytest.approx(list(b))
    assert main(["info", str(full), box]) == 0
    text = capsys.readouterr().out
    assert "curvilinear, native: 10 x 14 x 5 points" in text
    assert "box      index block i 0..9, j 5..18, k 0..4 of 10 x 24 x 5 points" in text

    # the same block written alone: the same sources and sound, bit for bit
    part, _, _ = write_vts_series(
        tmp_path / "part", swirl=0.5, width=0.5, block=(i0, i1 + 1, j0, j1 + 1, k0, k1 + 1)
    )
    got = {}
    for name, args in (("box", [str(full), box]), ("part", [str(part)]), ("full", [str(full)])):
        out = tmp_path / f"{name}.h5"
        assert main(["detect", *args, *THRESHOLDS, "-o", str(out)]) == 0
        got[name] = _sources(out)
    capsys.readouterr()
    for k in got["box"]:
        np.testing.assert_array_equal(got["box"][k], got["part"][k], err_msg=k)
    wavs = {}
    for name, args in (("box", [str(full), box]), ("part", [str(part)])):
        wav = tmp_path / f"{name}.wav"
        assert (
            main(
                [
                    "render",
                    *args,
                    "--listener",
                    "0,-1,0.25",
                    "--duration",
                    "0.05",
                    "--rate",
                    "8000",
                    "-o",
                    str(wav),
                    "--normalize",
                    "none",
                ]
            )
            == 0
        )
        wavs[name] = read_wav(wav)[0]
    capsys.readouterr()
    assert np.abs(wavs["box"]).max() > 0 and np.array_equal(wavs["box"], wavs["part"])

    # against the whole grid's sources in the block: equal (1e-12) where no stencil
    # reaches a cut face (3 index points: the quadrupole's two divergences and the ΔV
    # radius's neighbours; a face of the whole grid is no cut: i and k span it all);
    # near them, the cropped grid's one-sided differences and half cells differ
    shape = (k1 - k0 + 1, j1 - j0 + 1, i1 - i0 + 1)
    inner = np.zeros(shape, dtype=bool).reshape(-1)
    inner.reshape(shape)[:, 3:-3, :] = True
    to_full = np.ravel_multi_index(
        tuple(
            g + o
            for g, o in zip(
                np.unravel_index(np.arange(inner.size), shape), (k0, j0, i0), strict=True
            )
        ),
        c.shape[:3],
    )
    box_s, full_s = got["box"], got["full"]
    compared, sums = 0, np.zeros(2)
    for n in range(times.size):
        b_rows = np.arange(*box_s["offsets"][n : n + 2])
        f_rows = np.arange(*full_s["offsets"][n : n + 2])
        f_at = dict(zip(full_s["index"][f_rows].tolist(), f_rows.tolist(), strict=True))
        here = b_rows[inner[box_s["index"][b_rows]]]
        there = [f_at.get(int(to_full[x])) for x in box_s["index"][here]]
        assert None not in there, n  # every inner source of the crop is one of the grid's
        wanted = set(to_full[inner].tolist())
        assert sum(int(x) in wanted for x in full_s["index"][f_rows]) == here.size, n
        for key in ("kind", "strength", "radius", "position"):
            np.testing.assert_allclose(
                box_s[key][here], full_s[key][there], rtol=1e-12, err_msg=f"step {n}: {key}"
            )
        compared += here.size
        # monopoles at the points inside the box, whole block (cut faces included)
        pts = box_s["position"][b_rows]
        sel = (box_s["kind"][b_rows] == 1) & np.all(
            (pts >= np.array(BOX[::2]) - tol) & (pts <= np.array(BOX[1::2]) + tol), axis=1
        )
        sums[0] += np.abs(box_s["strength"][b_rows][sel] * box_s["radius"][b_rows][sel] ** 3).sum()
        pts = full_s["position"][f_rows]
        sel = (full_s["kind"][f_rows] == 1) & np.all(
            (pts >= np.array(BOX[::2]) - tol) & (pts <= np.array(BOX[1::2]) + tol), axis=1
        )
        sums[1] += np.abs(
            full_s["strength"][f_rows][sel] * full_s["radius"][f_rows][sel] ** 3
        ).sum()
    assert compared > 1000, compared  # (compared at every point: 86 radii differ at step 0)
    # the monopoles at the points in the box (all inside the block: its cells cover the
    # box): Σ |S| r³ as the whole grid's (measured: equal; their strengths are point-wise,
    # and only a neighbour's kind near a cut face could change a ΔV radius)
    assert sums[1] > 0 and sums[0] == pytest.approx(sums[1], rel=1e-9), sums
