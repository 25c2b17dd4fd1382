"""A render tells data that hold sound from data that hold sources, and hears each rightly.

Data that hold sound: the exact linear field of a pulsating point source
(monopole) or of a dipole stored as density, velocity and pressure
(:mod:`auralize.fwh.analytic`, the fields of ``test_fwh.py``).  Data that hold sources: the built-in pulsating
blob (``dataset:monopole``) and the shipped CF pulse.  The default render
(``method="auto"``) hears the first through the FW-H integral, and gets the
analytic far field 40 m away within 2 % (the volume sum hears it at 0.42×);
the second by the volume sum, as before.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from auralize.errors import ParameterError
from auralize.fwh.analytic import pulse_field, pulse_volume
from auralize.fwh.classify import WAVE_RESIDUAL, choose_method, default_surface, wave_test
from auralize.pipeline import ListenerPath, auralize, load

RATE = 44100
XS = np.array([0.013, -0.007, 0.011])  # pulse_volume's source, off the grid nodes


def _volume(kind: str = "monopole", names: tuple[str, ...] = ("density", "velocity", "pressure")):  # type: ignore[no-untyped-def]
    return pulse_volume(kind, XS, names=names)


def _field(kind, xs, t, pts):  # type: ignore[no-untyped-def]
    return pulse_field(kind, xs, t, pts)


@pytest.fixture(scope="module")
def mono():  # type: ignore[no-untyped-def]
    return _volume("monopole")


@pytest.mark.parametrize("kind", ["monopole", "dipole"])
def test_stored_sound_obeys_the_wave_equation(kind: str) -> None:
    wt = wave_test(_volume(kind))
    assert wt is not None and wt.field == "pressure"
    assert wt.residual < 0.05 and wt.holds_sound  # discretisation error only
    assert "hold sound waves" in wt.describe()


@pytest.mark.parametrize("spec", ["dataset:monopole", "dataset:pulse"])
def test_sources_do_not(spec: str) -> None:
    wt = wave_test(load(spec))
    assert wt is not None and wt.residual > 0.8 > WAVE_RESIDUAL and not wt.holds_sound
    m = choose_method(load(spec))
    assert m.name == "volume" and m.why.startswith("the data hold sources of sound")


def test_a_steady_field_cannot_tell() -> None:
    # the spinning source's density does not change: nothing to test, the volume sum
    vol = load("dataset:spinning", size=12, steps=12)
    assert wave_test(vol) is None
    assert choose_method(vol).name == "volume"


def test_default_render_hears_stored_sound_through_fwh_40_m_away(mono) -> None:  # type: ignore[no-untyped-def]
    listener = XS + np.array([0.0, 40.0, 0.0])
    path = ListenerPath.point(listener, duration=0.03)
    out, series = auralize(mono, path, rate=RATE, duration=0.03, clip=False)
    assert series is None and out.meta["method"] == "fwh"
    assert out.meta["method_text"].startswith("method: the FW-H surface integral")
    assert out.meta["surface"] == default_surface(mono) == "box=-0.8;0.8;-0.8;0.8;-0.8;0.8"
    t = out.meta["time_origin"] + np.arange(out.audio.shape[1]) / RATE
    exact = _field("monopole", XS, t[:, None], listener[None, None, :])[0][:, 0]
    got = out.audio[0]
    assert np.max(np.abs(exact)) > 0.01  # the pulse is inside the window
    assert abs(np.max(np.abs(got)) / np.max(np.abs(exact)) - 1) < 0.02
    assert np.sqrt(np.sum((got - exact) ** 2) / np.sum(exact**2)) < 0.02
    # asked for the volume sum, the same data are heard otherwise (and say so)
    vol_out, _ = auralize(
        mono, path, rate=RATE, duration=0.03, clip=False, method="volume", time_scale=1.0
    )
    assert vol_out.meta["method"] == "volume" and "as asked" in vol_out.meta["method_text"]


def test_the_default_listener_stands_outside_and_the_sound_lasts_its_own_time(mono) -> None:  # type: ignore[no-untyped-def]
    out, _ = auralize(mono, None, rate=RATE)
    assert out.meta["method"] == "fwh"
    assert out.meta["notes"][0].startswith("listener: standing at")
    # the data's 12.6 ms, plus the spread of arrivals across the data (at most its
    # diagonal), played in data time
    span = float(mono.times[-1] - mono.times[0])
    assert span < out.meta["duration_s"] < span + 2.0 * np.sqrt(3.0) / 343.0
    assert np.max(np.abs(out.audio)) > 0


def test_fwh_refusals_are_clear(mono) -> None:  # type: ignore[no-untyped-def]
    inside = ListenerPath.point((0.1, 0.0, 0.0), duration=0.01)
    with pytest.raises(ParameterError, match="outside the FW-H surface"):
        auralize(mono, inside, rate=RATE)
    with pytest.raises(ParameterError, match="in their own time"):
        auralize(mono, None, time_scale=3.0)
    with pytest.raises(ParameterError, match="--method fwh: .*needs the flow velocity"):
        auralize(_volume("monopole", names=("density", "pressure")), None, method="fwh")
    with pytest.raises(ParameterError, match="method must be one of auto, volume, fwh"):
        choose_method(mono, "surface")
    # data that hold sound but cannot take the integral: the volume sum, and why
    m = choose_method(_volume("monopole", names=("density", "pressure")))
    assert m.name == "volume" and "cannot run" in m.why and "mis-hears" in m.why


def _write_pvd(folder: Path, n: int = 21, h: float = 0.1, steps: int = 70) -> Path:
    """The monopole's field on a coarser grid as a VTK ImageData series (.pvd of .vti
    files, written by VTK's XML writer)."""
    import pyvista as pv

    ax = -1.0 + h * np.arange(n)
    z, y, x = np.meshgrid(ax, ax, ax, indexing="ij")
    pts = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    rows = []
    for k in range(steps):
        t = 1.5e-4 * k
        p, u = _field("monopole", XS, t, pts)
        grid = pv.ImageData(dimensions=(n, n, n), spacing=(h, h, h), origin=(-1.0, -1.0, -1.0))
        grid.point_data["pressure"] = 101325.0 + p
        grid.point_data["density"] = 1.2 + p / 343.0**2
        grid.point_data["velocity"] = u
        name = f"step_{k:03d}.vti"
        grid.save(folder / name)
        rows.append(f'<DataSet timestep="{t!r}" file="{name}"/>')
    pvd = folder / "pulse.pvd"
    pvd.write_text(
        '<VTKFile type="Collection"><Collection>' + "".join(rows) + "</Collection></VTKFile>"
    )
    return pvd


def test_command_on_a_vtk_series_says_which_method(tmp_path: Path) -> None:
    pvd = _write_pvd(tmp_path)
    out = tmp_path / "fwh.wav"
    args = [
        sys.executable,
        "-m",
        "auralize",
        "render",
        str(pvd),
        "--listener",
        "0.013,20,0.011",
        "--duration",
        "0.08",
        "-o",
        str(out),
    ]
    run = subprocess.run([*args, "--json"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    rep = json.loads(run.stdout)
    assert rep["method"] == "fwh" and rep["wave_residual"] < 0.1
    side = json.loads(Path(str(out) + ".json").read_text())
    assert side["method"] == "fwh" and side["surface"].startswith("box=")
    # the printed report names the method
    text = subprocess.run(args, capture_output=True, text=True, timeout=600)
    assert text.returncode == 0, text.stderr
    assert "method: the FW-H surface integral" in text.stdout
    # --method volume overrides; --method fwh with Dask options is refused clearly
    vol = subprocess.run(
        [*args[:-2], "-o", str(tmp_path / "v.wav"), "--method", "volume"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert vol.returncode == 0, vol.stderr
    assert "method: the volume sum of its sources (paper 003); as asked" in vol.stdout
    # info says which method a render would use, and why
    info = subprocess.run(
        [sys.executable, "-m", "auralize", "info", str(pvd)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert info.returncode == 0, info.stderr
    assert "method   fwh: the data hold sound waves" in info.stdout


def test_bench_rows_report_the_fwh_error() -> None:
    from auralize.bench.fwh import fwh_rows

    rows = {r.name: r for r in fwh_rows(quick=True)}
    assert rows["FW-H error against the exact field"].met is True
    assert rows["FW-H render 40 m away, mono"].value > 0
    assert "hold sound waves" in rows["wave test, 25³ x 85 steps"].note
