"""`auralize render` with no options: time mapping, default listener, timbre, report; real data."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from auralize.audio import read_wav
from auralize.cli import main
from auralize.datasets.real import CASES, dataset_path
from auralize.emitters.timbre import loudness
from auralize.listener import ListenerPath

DATASETS = Path(__file__).resolve().parent.parent / "auralize" / "data"
MONO = ["dataset:monopole", "--size", "12", "--steps", "60"]


def _real_input(folder: Path, tmp: Path) -> str:
    """The file (or case folder) a user would pass for a shipped dataset folder."""
    for z in sorted(folder.glob("*.zip")):
        with zipfile.ZipFile(z) as zf:
            zf.extractall(tmp)
    cases = sorted(p.parent.parent for p in tmp.glob("**/system/controlDict"))
    if cases:  # OpenFOAM: the first case folder (the cavity)
        return str(next((c for c in cases if c.name == "cavity"), cases[0]))
    raise AssertionError(f"{folder}: no OpenFOAM case to render")


#: shipped real datasets with at least two steps that change: they render audibly (wavy
#: is a surface read on its own 80x80 lattice)
AUDIBLE = ["openfoam-cavity", "netcdf-pulse", "paraview-wavy"]
#: dolfinx's and meshio's fields rise linearly in time at every point: ∂ρ/∂t is
#: constant, so the pressure is constant and nothing sounds; the render says so
STEADY_RATE = ["xdmf-dolfinx", "xdmf-meshio"]
#: a single step (EnSight's steady cylinder, the PLOT3D snapshot): a clear one-line refusal
SINGLE_STEP = ["ensight-cylinder", "plot3d-combustor"]


def _check_audible(wav: Path, report: str, duration: float) -> None:
    audio, rate, _ = read_wav(wav)
    assert audio.shape[1] == round(duration * rate)  # the stated duration
    assert f"{duration:.2f} s" in report
    ld = loudness(audio, rate)
    assert ld["share_above"] >= 0.5  # at least half the energy above 20 Hz
    assert ld["rms"] > 0.01  # not silent (peak-normalised to 0.99)
    assert np.all(np.abs(audio.mean(axis=1)) < 1e-3 * ld["peak"])  # no DC


def test_every_shipped_real_dataset_is_classified() -> None:
    assert sorted(AUDIBLE + STEADY_RATE + SINGLE_STEP) == sorted(CASES)


@pytest.mark.parametrize("name", STEADY_RATE)
def test_plain_render_of_a_field_changing_at_a_constant_rate_is_silent(
    name, tmp_path, capsys
) -> None:  # type: ignore[no-untyped-def]
    wav = tmp_path / "out.wav"
    with dataset_path(name) as src:
        code = main(["render", str(src), "-o", str(wav)])
    out, err = capsys.readouterr()
    assert code == 1 and "silent" in err, err  # written, marked silent (EXIT_SILENT)
    assert "silent: nothing in the data changes in a way that sounds" in out
    audio, _, _ = read_wav(wav)
    assert not np.any(audio)


@pytest.mark.parametrize("name", AUDIBLE)
@pytest.mark.filterwarnings("ignore::auralize.sources.SourceFractionWarning")
def test_plain_render_of_real_data_is_audible(name, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    wav = tmp_path / "out.wav"
    with dataset_path(name) as src:
        code = main(["render", str(src), "-o", str(wav)])
    out, err = capsys.readouterr()
    assert code == 0, err
    report = out.strip().splitlines()[-1]
    _check_audible(wav, report, 10.0)


@pytest.mark.parametrize("name", SINGLE_STEP)
def test_plain_render_of_a_single_step_is_refused_in_one_line(name, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    with dataset_path(name) as src:
        code = main(["render", str(src), "-o", str(tmp_path / "out.wav")])
    err = capsys.readouterr().err
    assert code == 3 and "needs at least 2 time steps" in err and err.count("\n") == 1
    assert not (tmp_path / "out.wav").exists()


def test_uniform_ramp_is_silent_and_said(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """meshio's phi = t on every point: ∂ρ/∂t is the same constant everywhere, so the
    pressure is constant: nothing changes that sounds, in any timbre."""
    for timbre in ("auto", "tonal"):
        wav = tmp_path / f"{timbre}.wav"
        with dataset_path("xdmf-meshio") as src:
            code = main(["render", str(src), "--timbre", timbre, "-o", str(wav)])
        out, err = capsys.readouterr()
        assert code == 1 and "silent" in err, err  # EXIT_SILENT: written, flagged
        assert "silent: nothing in the data changes in a way that sounds" in out
        side = json.loads(Path(str(wav) + ".json").read_text())
        assert side["silent"] is True and side["heard"] == "field"
        audio, _, _ = read_wav(wav)
        assert not np.any(audio)


def test_python_render_equals_the_plain_command(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    import auralize.pipeline as ap

    with dataset_path("netcdf-pulse") as src:
        assert main(["render", str(src), "-o", str(tmp_path / "cli.wav")]) == 0
        capsys.readouterr()
        out, _ = ap.auralize(ap.load(src))
    ap.save_rendered(out, tmp_path / "py.wav")
    a, rate_a, _ = read_wav(tmp_path / "cli.wav")
    b, rate_b, _ = read_wav(tmp_path / "py.wav")
    assert rate_a == rate_b == 44100 and a.shape == b.shape == (1, 441000)
    np.testing.assert_array_equal(a, b)
    cli = json.loads((tmp_path / "cli.wav.json").read_text())
    py = json.loads((tmp_path / "py.wav.json").read_text())
    for key in (
        "timbre",
        "time_mapping",
        "highpass_hz",
        "listener",
        "heard",
        "heard_text",
        "field",
    ):
        assert py[key] == cli[key], key


def test_cavity_with_a_density_field_is_audible(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """The OpenFOAM cavity (6 steps over 2.5 s) heard with p as the density field."""
    src = _real_input(DATASETS / "openfoam-cavity", tmp_path / "data")
    wav = tmp_path / "c.wav"
    code = main(["render", src, "--density-field", "p", "--velocity-field", "U", "-o", str(wav)])
    out, err = capsys.readouterr()
    assert code == 0, err
    lines = out.strip().splitlines()
    assert any(ln.startswith("listener: orbit of radius") for ln in lines)
    assert "1 s of playback = 250 ms of data (auto)" in lines
    assert "timbre auto" in out and "below 20 Hz" in out
    _check_audible(wav, lines[-1], 10.0)
    side = json.loads(Path(str(wav) + ".json").read_text())
    assert side["time_mapping"] == "1 s of playback = 250 ms of data"
    assert side["time_scale"] == pytest.approx(4.0, rel=1e-3)
    assert side["timbre"] == "extended" and side["time_scale_auto"] is True


def test_report_line_and_json(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    wav = tmp_path / "m.wav"
    assert main(["render", *MONO, "--timbre", "tonal", "-o", str(wav)]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith(f"wrote {wav}: 10.00 s, mono (1 ch) at 44100 Hz; 1 s of playback = ")
    assert "timbre tonal; heard whole field: mass sources (continuity residual), " in line.replace(
        " + Lighthill stress", ""
    )
    assert "% of the energy above 20 Hz" in line and "peak " in line and "RMS " in line
    assert main(["render", *MONO, "--timbre", "tonal", "-o", str(wav), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["timbre"] == "tonal" and rep["time_scale_auto"] is True
    assert rep["loudness"]["share_above"] > 0.9 and rep["default_listener"] is True
    assert rep["time_mapping"].startswith("1 s of playback = ")


def test_duration_beyond_the_data_is_clipped(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    wav = tmp_path / "c.wav"
    assert (
        main(
            [
                "render",
                *MONO,
                "--time-scale",
                "1",
                "--duration",
                "5",
                "--listener",
                "1.4,1.4,1.4",
                "--timbre",
                "physical",
                "-o",
                str(wav),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "5 s requested" in out and "clipped to" in out
    audio, rate, _ = read_wav(wav)
    # 60 frames at 3 kHz: 20 ms of data, plus the arrival spread inside the grid
    assert 0.019 < audio.shape[1] / rate < 0.04


def test_physical_below_20_hz_is_said(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    wav = tmp_path / "p.wav"
    assert main(["render", *MONO, "--timbre", "physical", "--duration", "20", "-o", str(wav)]) == 0
    out = capsys.readouterr().out
    assert "below 20 Hz (inaudible); try --timbre extended, or a smaller --time-scale" in out


def test_path_commands_default_around_the_data_and_render(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    for kind in ("orbit", "line"):
        csv = tmp_path / f"{kind}.csv"
        assert main(["path", kind, *MONO, "--duration", "2", "-o", str(csv)]) == 0
        p = ListenerPath.from_csv(csv)
        assert p.duration == pytest.approx(2.0)
        # outside the data's box (12 points at 0.25 m)
        assert np.all(np.any((p.positions < 0) | (p.positions > 2.75), axis=1))
        wav = tmp_path / f"{kind}.wav"
        assert main(["render", *MONO, "--path", str(csv), "-o", str(wav)]) == 0
        audio, rate, _ = read_wav(wav)
        assert audio.shape[1] == 2 * rate and np.max(np.abs(audio)) > 0.5
    assert main(["path", "orbit", "-o", str(tmp_path / "x.csv")]) == 2
    assert "give --center, or a volume" in capsys.readouterr().err
