"""Detection on data with holes, steady flows and refinement: what is rendered is physical.

* No-data points (outside the input mesh, NaN) are never sources and never read.
* A steady flow makes no sound.
* Σ S ΔV over the sources converges as the grid is refined (analytic fields of each
  type, and the OpenFOAM cavity).
* Automatic thresholds find sources, not everything.
"""

from __future__ import annotations

import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest

from auralize.emitters.synthesis import render_tracks
from auralize.listener import ListenerPath
from auralize.sources import (
    SourceFractionWarning,
    Thresholds,
    compute_strengths,
    detect,
)
from auralize.volume import TimeVolume

REPO = Path(__file__).resolve().parent.parent
CAVITY = REPO / "auralize" / "data" / "openfoam-cavity" / "OpenFOAM.zip"
WAVY = Path("/work/shared/datasets/paraview-wavy/wavy.zip")
L = 8.0  # extent of the analytic fields (m)


def _axes(n: int) -> tuple[np.ndarray, float]:
    x = np.linspace(-L / 2, L / 2, n)
    return x, float(x[1] - x[0])


def _grid(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    x, h = _axes(n)
    z, y, xx = np.meshgrid(x, x, x, indexing="ij")
    return xx, y, z, h


def _rms(series, listener=(0.0, 0.0, 3.5), rate=4000) -> float:  # type: ignore[no-untyped-def]
    path = ListenerPath.point(listener, duration=float(series.times[-1] - series.times[0]))
    out = render_tracks(series.tracks(), path, rate=rate, interp="linear")
    return float(np.sqrt(np.mean(out.audio**2)))


# ---------------------------------------------------------------- no-data
def test_invalid_and_nan_points_are_never_sources_and_never_read() -> None:
    n = 20
    x, y, z, h = _grid(n)
    t = np.arange(10) / 200.0
    g = np.exp(-(x**2 + y**2 + z**2) / 2.0)
    rho = 1.2 + 0.05 * np.sin(2 * np.pi * 20 * t)[:, None, None, None] * g
    vel = np.zeros((*rho.shape, 3))
    vel[..., 0] = 3.0 * np.cos(2 * np.pi * 20 * t)[:, None, None, None] * g
    valid = (x**2 + y**2 + 0.5 * z**2) < 3.2**2  # an ellipsoidal mesh inside the box
    rho[:, ~valid] = np.nan
    vel[:, ~valid] = np.nan
    rho[4, 10, 10, 12] = np.nan  # a masked cell inside the mesh at one step
    vol = TimeVolume.from_arrays({"density": rho, "velocity": vel}, spacing=h, times=t)
    vol.check_finite = False
    vol.valid = valid  # type: ignore[attr-defined]
    series = detect(vol, mapping="identity", thresholds=Thresholds("top:5%", "top:5%", "top:5%"))
    flat_valid = valid.reshape(-1)
    total = 0
    for n_, f in enumerate(series.frames):
        assert np.all(flat_valid[f.index]), n_
        assert np.all(np.isfinite(f.strength)) and np.all(np.isfinite(f.radius))
        assert f.n_valid is not None and f.n_valid <= valid.sum()
        total += f.index.size
    assert total > 100
    # the NaN cell at step 4 (used by the time differences of steps 3, 4, 5) is no source there
    idx = np.ravel_multi_index((10, 10, 12), valid.shape)
    for step in (3, 4, 5):
        assert idx not in series.frames[step].index
    s = compute_strengths(vol, "identity", step=4)
    assert np.all(np.isfinite(s))
    assert np.all(s[:, ~valid] == 0)
    # a derivative that would read an invalid neighbour is no-data, not a one-sided guess
    edge = valid & ~np.roll(valid, 1, axis=2)  # valid points whose -x neighbour is invalid
    assert edge.any() and np.all(s[1:, edge] == 0)
    assert series.meta["valid_points"] < 1.0
    assert 0 < series.meta["fraction"]["any"] <= 0.25 + 1e-9


def _wavy_series(tmp: Path, steps: int = 6) -> TimeVolume:
    """ParaView's `wavy` surface series probed onto a uniform grid, with VTK's valid mask."""
    pv = pytest.importorskip("pyvista")
    with zipfile.ZipFile(WAVY) as zf:
        zf.extractall(tmp)
    files = sorted((tmp / "wavy").glob("wavy*.vts"))[:steps]
    nx, nz = 24, 9
    img = pv.ImageData(
        dimensions=(nx, nx, nz),
        spacing=(19.75 / (nx - 1), 19.75 / (nx - 1), 2.0 / (nz - 1)),
        origin=(-10.0, -10.0, -1.0),
    )
    rho, valid = [], np.zeros((nz, nx, nx), dtype=bool)
    for f in files:
        probed = img.sample(pv.read(f), tolerance=0.5 * img.spacing[2])
        ok = np.asarray(probed["vtkValidPointMask"]).reshape(nz, nx, nx).astype(bool)
        zval = np.asarray(probed["z"]).reshape(nz, nx, nx)
        rho.append(np.where(ok, 1.2 + 0.01 * zval, np.nan))
        valid |= ok
    vol = TimeVolume.from_arrays(
        {"density": np.stack(rho)},
        origin=img.origin,
        spacing=img.spacing,
        times=np.arange(len(files)) * 0.1,
    )
    vol.check_finite = False
    vol.valid = valid  # type: ignore[attr-defined]
    return vol


@pytest.mark.skipif(not WAVY.exists(), reason="ParaView's wavy series is not on this machine")
def test_no_source_outside_a_curved_surface_mesh(tmp_path: Path) -> None:
    vol = _wavy_series(tmp_path)
    valid = getattr(vol, "valid", None)
    assert valid is not None and 0.02 < valid.mean() < 0.9
    series = detect(vol, mapping="identity")
    pts = 0
    for f in series.frames:
        assert np.all(valid.reshape(-1)[f.index])
        assert np.all(np.isfinite(f.strength))
        pts += f.index.size
    assert pts > 0


# ------------------------------------------------------------------ steady
def _vortex(n: int, omega_t: np.ndarray) -> TimeVolume:
    """A vortex of angular speed ω(t) near its axis, from a stream function ψ: v = (∂ψ/∂y,
    −∂ψ/∂x, 0) by the same differences the detection uses, so ∇·v is 0 to round-off."""
    x, y, z, h = _grid(n)
    psi = -(1.2**2) * np.exp(-(x**2 + y**2) / (2 * 1.2**2)) * np.exp(-(z**2) / 2.0)
    vel = np.stack(
        [np.gradient(psi, h, axis=1), -np.gradient(psi, h, axis=2), np.zeros_like(x)], -1
    )
    v = omega_t[:, None, None, None, None] * vel
    t = np.arange(omega_t.size) / 400.0
    rho = np.full(v.shape[:4], 1.2)
    return TimeVolume.from_arrays({"density": rho, "velocity": v}, spacing=h, times=t)


def test_steady_rotating_flow_renders_to_silence() -> None:
    steps = 40
    t = np.arange(steps) / 400.0
    steady = _vortex(17, np.full(steps, 30.0))
    varying = _vortex(17, 30.0 * (1.0 + 0.5 * np.sin(2 * np.pi * 25 * t)))
    quiet = detect(steady, mapping="identity")
    assert all(f.index.size == 0 for f in quiet.frames)
    loud = detect(varying, mapping="identity")
    p_loud = _rms(loud)
    assert p_loud > 0
    out = render_tracks(quiet.tracks(), ListenerPath.point((0, 0, 3.5), duration=t[-1]), rate=4000)
    p_quiet = float(np.sqrt(np.mean(out.audio**2)))
    assert p_quiet <= 1e-3 * p_loud  # below -60 dB
    # the paper's literal form keeps the steady stress as a source
    literal = detect(steady, mapping="identity", steady="keep")
    assert sum(f.counts()["quadrupole"] for f in literal.frames) > 100
    # the fluctuating part is what remains of the literal strengths
    s_lit = compute_strengths(varying, "identity", step=7, steady="keep")
    s_fl = compute_strengths(varying, "identity", step=7, steady="remove")
    assert np.allclose(s_lit[:2], s_fl[:2])
    assert not np.allclose(s_lit[2], s_fl[2])


# ------------------------------------------------------------- convergence
def _monopole(n: int) -> TimeVolume:
    x, y, z, h = _grid(n)
    t = np.arange(24) / 800.0
    g = np.exp(-(x**2 + y**2 + z**2) / (2 * 0.8**2))
    rho = 1.2 + 0.02 * np.sin(2 * np.pi * 50 * t)[:, None, None, None] * g
    return TimeVolume.from_arrays({"density": rho}, spacing=h, times=t)


def _dipole(n: int) -> TimeVolume:
    # an oscillating force: momentum ρ v_x of a blob, displaced off the listener's axis
    x, y, z, h = _grid(n)
    t = np.arange(24) / 800.0
    g = np.exp(-((x - 0.7) ** 2 + y**2 + z**2) / (2 * 0.8**2))
    rho = np.full((t.size, *x.shape), 1.2)
    vel = np.zeros((*rho.shape, 3))
    vel[..., 0] = 2.0 * np.sin(2 * np.pi * 50 * t)[:, None, None, None] * g
    return TimeVolume.from_arrays({"density": rho, "velocity": vel}, spacing=h, times=t)


def _quadrupole(n: int) -> TimeVolume:
    # an oscillating vortex: ρ v_i v_j oscillates, density constant
    t = np.arange(24) / 800.0
    return _vortex(n, 30.0 * (1.0 + 0.5 * np.sin(2 * np.pi * 50 * t)))


@pytest.mark.parametrize(
    ("make", "kind", "sizes"),
    [
        (_monopole, "monopole", (17, 33)),
        (_dipole, "dipole", (17, 33)),
        # the stress of the vortex varies faster than the blobs: h = σ/3.6 and σ/7.2
        (_quadrupole, "quadrupole", (25, 49)),
    ],
)
def test_rendered_pressure_converges_under_refinement(make, kind, sizes) -> None:  # type: ignore[no-untyped-def]
    rms = []
    for n in sizes:  # h and h/2 on the same extent
        # (the ΔV rule is what converges; the discretisation floor, which keeps less of
        # a blob resolved by 1.6 points per σ than by 3.2, is off)
        series = detect(make(n), mapping="identity", thresholds=Thresholds(floor=0.0))
        c = {
            k: sum(f.counts()[k] for f in series.frames)
            for k in ("monopole", "dipole", "quadrupole")
        }
        assert c[kind] > 0 and all(v < c[kind] for k, v in c.items() if k != kind), c
        rms.append(_rms(series))
    assert rms[1] == pytest.approx(rms[0], rel=0.10)


def _cavity(tmp: Path, resolution: int) -> TimeVolume:
    """The cavity with density from pressure, ρ = 1.2 + p/c0² (OpenFOAM's incompressible p)."""
    from auralize.io import ResampledWarning, open_volume

    case = tmp / "OpenFOAM" / "cavity"
    if not case.exists():
        with zipfile.ZipFile(CAVITY) as zf:
            zf.extractall(tmp)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        v = open_volume(case, resolution=resolution)
    p = np.stack(list(v.iter_frames("p")))
    u = np.stack(list(v.iter_frames("U")))
    return TimeVolume.from_arrays(
        {"density": 1.2 + p / 343.0**2, "velocity": u},
        origin=v.origin,
        spacing=v.spacing,
        times=v.times,
    )


def test_cavity_pressure_does_not_depend_on_the_resampling(tmp_path: Path) -> None:
    rms = []
    for res in (24, 48):
        vol = _cavity(tmp_path, res)
        series = detect(vol, mapping="identity")
        centre = vol.center + np.array([0.0, 0.0, 0.5])
        rms.append(_rms(series, listener=tuple(centre), rate=400))
    assert rms[1] == pytest.approx(rms[0], rel=0.25)


# -------------------------------------------------------------- thresholds
def test_auto_thresholds_find_sources_not_everything_and_warn_when_they_do() -> None:
    series = detect(_monopole(17), mapping="identity")
    frac = series.meta["fraction"]
    assert 0 < frac["monopole"] < 0.25 and frac["dipole"] == 0
    # absolute thresholds at zero, without the discretisation floor, classify every
    # point that has any strength
    with pytest.warns(SourceFractionWarning, match=r"of the valid points are sources"):
        loose = detect(
            _monopole(17), mapping="identity", thresholds=Thresholds(0.0, 0.0, 0.0, floor=0.0)
        )
    assert loose.meta["fraction"]["any"] > 0.25
    top = detect(_monopole(17), mapping="identity", thresholds=Thresholds("top:1%", "auto", "auto"))
    # the top 1 % of the valid point-steps at the sample steps, about 1 % overall
    assert top.meta["fraction"]["monopole"] == pytest.approx(0.01, abs=0.005)


def test_cli_detect_reports_the_classified_fractions(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    import json

    from auralize.cli import main
    from auralize.io import save_volume

    src = tmp_path / "mono.h5"
    save_volume(_monopole(13), src)
    out = tmp_path / "s.h5"
    assert (
        main(
            [
                "detect",
                str(src),
                "-o",
                str(out),
                "--mapping",
                "identity",
                "--threshold-monopole",
                "top:2%",
                "--json",
            ]
        )
        == 0
    )
    frac = json.loads(capsys.readouterr().out)["fraction"]
    assert frac["monopole"] == pytest.approx(0.02, abs=0.01) and frac["dipole"] == 0
    assert main(["detect", str(src), "-o", str(out), "--mapping", "identity"]) == 0
    text = capsys.readouterr().out
    assert "share of the valid points classified:" in text and "% monopole" in text
    assert main(["detect", str(src), "-o", str(out), "--threshold-dipole", "..%"]) == 2
    assert "dipole threshold '..%' is not understood" in capsys.readouterr().err


def test_function_mapping_passes_no_data_through_but_not_new_nans() -> None:
    from auralize.errors import DataError

    n = 10
    x, y, z, h = _grid(n)
    t = np.arange(4) / 100.0
    rho = 1.2 + 0.01 * np.sin(40 * t)[:, None, None, None] * np.exp(-(x**2 + y**2 + z**2))
    valid = x < 2.0
    rho[:, ~valid] = np.nan
    vol = TimeVolume.from_arrays({"density": rho}, spacing=h, times=t)
    vol.check_finite = False
    vol.valid = valid  # type: ignore[attr-defined]

    def fn(frames):  # type: ignore[no-untyped-def]
        r = frames["density"]
        return r, np.zeros((*r.shape, 3))

    series = detect(vol, mapping=fn)
    assert all(valid.reshape(-1)[f.index].all() for f in series.frames)

    def broken(frames):  # type: ignore[no-untyped-def]
        r = np.sqrt(frames["density"] - 1.3)  # NaN where the input is valid
        return r, np.zeros((*r.shape, 3))

    with pytest.raises(DataError, match="NaN/Inf at step 0 at .* points whose input is valid"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            detect(vol, mapping=broken)
