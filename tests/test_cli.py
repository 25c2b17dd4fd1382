"""The auralize command end to end, in process (fast) and its error handling."""

from __future__ import annotations

import json

import numpy as np
import pytest

from auralize.audio import read_wav
from auralize.cli import main


@pytest.fixture(scope="module")
def mono_h5(tmp_path_factory) -> str:  # type: ignore[no-untyped-def]
    out = tmp_path_factory.mktemp("d") / "mono.h5"
    assert main(["dataset", "monopole", "-o", str(out), "--size", "16", "--steps", "120"]) == 0
    return str(out)


def test_info_json(mono_h5, capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["info", mono_h5, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert (
        d["dims"] == [16, 16, 16] and d["n_steps"] == 120 and d["fields"] == {"density": "scalar"}
    )


def test_detect_json_and_outputs(mono_h5, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "s.h5"
    assert main(["detect", mono_h5, "-o", str(out), "--threshold-monopole", "1%", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    steps = d["steps"]
    assert len(steps) == 120
    assert sum(s["monopole"] for s in steps) > 0
    assert sum(s["dipole"] + s["quadrupole"] for s in steps) == 0
    from auralize.sources.sources_file import load_sources_h5

    series = load_sources_h5(out)
    assert [sum(c.values()) for c in series.counts()] == [
        s["monopole"] + s["dipole"] + s["quadrupole"] for s in steps
    ]
    pvd = tmp_path / "s.pvd"
    assert main(["detect", mono_h5, "-o", str(pvd), "--threshold-monopole", "1%"]) == 0
    assert pvd.exists() and len(list((tmp_path / "s_data").glob("*.vtp"))) == 120


def test_render_stereo_wav_with_sidecar(mono_h5, tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "a.wav"
    rc = main(
        [
            "render",
            mono_h5,
            "--listener",
            "2.5,1.875,1.875",
            "--duration",
            "0.05",
            "-o",
            str(out),
            "--layout",
            "stereo",
            "--threshold-monopole",
            "1%",
            "--normalize",
            "none",
        ]
    )
    assert rc == 0
    audio, rate, _ = read_wav(out)
    assert rate == 44100 and audio.shape == (2, 2205)
    # looking +y with up +z, -x is on the left: the source (at -x) is louder in L
    assert np.std(audio[0]) > 3 * np.std(audio[1])
    meta = json.loads((tmp_path / "a.wav.json").read_text())
    assert (
        meta["layout"]["name"] == "stereo" and meta["normalize"] == "none" and meta["gain"] == 1.0
    )


def test_path_command_and_render_with_path(mono_h5, tmp_path) -> None:  # type: ignore[no-untyped-def]
    csv = tmp_path / "p.csv"
    assert (
        main(
            [
                "path",
                "line",
                "--start",
                "0.5,1,1",
                "--end",
                "3,2,2",
                "--duration",
                "0.04",
                "-o",
                str(csv),
            ]
        )
        == 0
    )
    out = tmp_path / "b.wav"
    assert main(["render", mono_h5, "--path", str(csv), "-o", str(out), "--interp", "linear"]) == 0
    audio, _, _ = read_wav(out)
    assert audio.shape == (1, round(0.04 * 44100))
    assert np.max(np.abs(audio)) == pytest.approx(0.99, rel=1e-6)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            [
                "render",
                "dataset:monopole",
                "--size",
                "16",
                "--steps",
                "20",
                "--listener",
                "1e9,0,0",
                "--duration",
                "0.1",
                "-o",
                "{out}",
            ],
            "listeners must be within",
        ),
        (
            [
                "render",
                "dataset:monopole",
                "--size",
                "16",
                "--steps",
                "20",
                "--listener",
                "1,1,1",
                "--highpass",
                "30000",
                "-o",
                "{out}",
            ],
            "highpass must be 0 (off) or between",
        ),
        (
            ["render", "dataset:nothing", "--listener", "1,1,1", "--duration", "1", "-o", "{out}"],
            "unknown dataset 'nothing'",
        ),
        (
            [
                "render",
                "dataset:monopole",
                "--size",
                "16",
                "--steps",
                "20",
                "--listener",
                "1,1,1",
                "--duration",
                "0.1",
                "--layout",
                "9.2",
                "-o",
                "{out}",
            ],
            "unknown layout '9.2'",
        ),
        (
            ["render", "{missing}", "--listener", "1,1,1", "--duration", "0.1", "-o", "{out}"],
            "missing.h5",
        ),
        (
            [
                "render",
                "dataset:monopole",
                "--size",
                "16",
                "--steps",
                "1",
                "--listener",
                "1,1,1",
                "--duration",
                "0.1",
                "-o",
                "{out}",
            ],
            "--steps must be an integer >= 2",
        ),
        (
            [
                "detect",
                "dataset:monopole",
                "--size",
                "16",
                "--steps",
                "20",
                "--mapping",
                "cfd",
                "-o",
                "{out}.h5",
            ],
            "mapping 'cfd' needs a momentum field",
        ),
    ],
)
def test_cli_errors_are_one_line_and_leave_no_output(argv, message, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "x.wav"
    argv = [a.format(out=out, missing=tmp_path / "missing.h5") for a in argv]
    assert main(argv) in (2, 3)  # a usage or a data error
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["aero", "render", "-o", "x.wav"],
            "required: --texture; and one of --motion --wind --preset; and one of --path --listener",
        ),
        (
            ["aero", "render", "--texture=t.h5", "--preset", "sword", "-o", "x.wav"],
            "one of the arguments --path --listener is required",
        ),
        (
            ["aero", "render", "--texture", "t.h5", "--wind=3", "--path", "p.csv"],
            "required: -o/--output (see",
        ),
    ],
)
def test_usage_error_names_every_missing_option_at_once(argv, message, capsys) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err


def test_corrupt_volume_file(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(200))
    assert main(["info", str(bad)]) == 3  # a data error
    assert "bad.h5" in capsys.readouterr().err


def test_demo_writes_ring8_wav_and_pictures(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import matplotlib.image as mpimg

    assert main(["demo", "-o", str(tmp_path), "--size", "24", "--time-scale", "1"]) == 0
    audio, rate, mask = read_wav(tmp_path / "explosion_ring8.wav")
    assert audio.shape[0] == 8 and rate == 44100 and np.max(np.abs(audio)) > 0.9
    # every speaker of the ring carries the data (the head turns as the default orbit's):
    # no channel more than 20 dB below the loudest
    level = 10 * np.log10(np.mean(audio**2, axis=1))
    assert level.max() - level.min() < 20, level
    img = mpimg.imread(tmp_path / "explosion.png")[..., :3]
    assert img.std() > 0.02  # not blank

    def has_colour(hex_colour: str) -> bool:
        rgb = np.array([int(hex_colour[i : i + 2], 16) for i in (1, 3, 5)]) / 255
        return bool(np.any(np.all(np.abs(img - rgb) < 0.12, axis=-1)))

    from auralize.scene import PATH_COLOR, TYPE_COLORS

    assert has_colour(TYPE_COLORS[1]) and has_colour(PATH_COLOR)
    assert (tmp_path / "explosion_spectrogram.png").stat().st_size > 10_000
