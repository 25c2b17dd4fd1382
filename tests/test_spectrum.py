"""``auralize spectrum``: levels checked against closed forms (a 1 Pa rms tone is
93.98 dB; Parseval: the bands sum to the overall level; the A curve; 1/r: twice as
far is 6.02 dB quieter), on renders in pascals and at observers."""

from __future__ import annotations

import json

import numpy as np
import pytest

from auralize.cli import main
from auralize.errors import FormatError, ParameterError
from auralize.spectrum import P_REF, a_weighting_db, spectrum, third_octaves

RATE = 48000


def _tone(f: float, rms: float = 1.0, seconds: float = 1.0) -> np.ndarray:
    t = np.arange(int(RATE * seconds)) / RATE
    return np.sqrt(2) * rms * np.sin(2 * np.pi * f * t)


def test_a_one_pascal_tone_is_94_db_in_its_band() -> None:
    s = spectrum(_tone(1000.0)[None], RATE)
    assert s.oaspl[0] == pytest.approx(20 * np.log10(1 / P_REF), abs=1e-3)  # 93.979 dB
    k = s.band_labels.index("1000")
    assert s.band_levels[0, k] == pytest.approx(s.oaspl[0], abs=1e-3)
    others = np.delete(s.band_levels[0], k)
    assert np.all(others < s.oaspl[0] - 60)  # nothing leaks (whole periods, no window)
    assert s.oaspl_a[0] == pytest.approx(s.oaspl[0], abs=0.01)  # A(1 kHz) = 0 dB


def test_parseval_the_bands_sum_to_the_overall_level() -> None:
    rng = np.random.default_rng(0)
    tones = [32.0, 200.0, 1000.0, 5000.0]  # whole periods in the second: no leakage
    x = sum(_tone(f, rms=r) for f, r in zip(tones, rng.uniform(0.1, 2, len(tones)), strict=True))
    s = spectrum(np.vstack([x, 0.5 * x]), RATE, channels=["a", "b"])
    total = 10 * np.log10(np.sum(10 ** (s.band_levels / 10), axis=1))
    assert total == pytest.approx(s.oaspl, abs=1e-6)
    assert s.oaspl[0] - s.oaspl[1] == pytest.approx(20 * np.log10(2), abs=1e-9)
    # a steady offset is not sound
    assert spectrum((x + 3.0)[None], RATE).oaspl[0] == pytest.approx(s.oaspl[0], abs=1e-9)


def test_the_a_curve() -> None:
    assert a_weighting_db(np.array([1000.0]))[0] == pytest.approx(0.0, abs=0.01)
    # IEC 61672-1 Table 3 (at the exact base-10 frequencies): 100 Hz −19.1 dB,
    # 10 kHz −2.5 dB, 31.5 Hz −39.4 dB
    for f, a in ((10**2, -19.1), (10**4, -2.5), (10**1.5, -39.4)):
        assert a_weighting_db(np.array([f]))[0] == pytest.approx(a, abs=0.1)
    s = spectrum(_tone(100.0)[None], RATE)
    assert s.oaspl[0] - s.oaspl_a[0] == pytest.approx(19.1, abs=0.1)
    fm, labels = third_octaves()
    assert len(fm) == 34 and labels[0] == "10" and labels[-1] == "20000"
    assert np.allclose(fm[1:] / fm[:-1], 10**0.1)


def test_bad_signals_are_refused() -> None:
    with pytest.raises(ParameterError, match="NaN or Inf"):
        spectrum(np.array([[0.0, np.nan, 1.0]]), RATE)
    with pytest.raises(ParameterError, match="at least 2 samples"):
        spectrum(np.zeros((1, 1)), RATE)
    with pytest.raises(ParameterError, match="rate"):
        spectrum(np.zeros((1, 10)), 0)


def test_a_render_normalised_or_in_pascals_has_the_same_levels(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    common = [
        "render",
        "dataset:monopole",
        "--size",
        "12",
        "--steps",
        "30",
        "--duration",
        "0.5",
        "--layout",
        "stereo",
    ]
    assert main([*common, "--normalize", "none", "-o", str(tmp_path / "pa.wav")]) == 0
    assert main([*common, "-o", str(tmp_path / "peak.wav")]) == 0
    capsys.readouterr()
    levels = []
    for name in ("pa", "peak"):
        assert (
            main(
                [
                    "spectrum",
                    str(tmp_path / f"{name}.wav"),
                    "-o",
                    str(tmp_path / f"{name}.json"),
                    "--plot",
                    str(tmp_path / f"{name}.png"),
                ]
            )
            == 0
        )
        doc = json.loads((tmp_path / f"{name}.json").read_text())
        levels.append([doc["channels"][c]["oaspl_db"] for c in ("L", "R")])
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    assert levels[0] == pytest.approx(levels[1], abs=0.01)  # float32 samples
    out = capsys.readouterr().out
    assert "<Spectrum pa.wav>" in out and "OASPL   L " in out
    assert main(["spectrum", str(tmp_path / "pa.wav"), "-o", str(tmp_path / "pa.csv")]) == 0
    rows = (tmp_path / "pa.csv").read_text().splitlines()
    assert rows[0] == "band_hz,centre_hz,L_db,R_db" and rows[-2].startswith("OASPL,,")
    assert len(rows) == 1 + 34 + 2


def test_twice_as_far_is_6_db_quieter(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The volume sum at two observers on a line through the data's centre (1.375 m
    on each axis), far away: the pressure falls as 1/r, so the level by 20 log10(2)."""
    got = []
    for d in (60.0, 120.0):
        out = tmp_path / f"{d:g}.json"
        assert (
            main(
                [
                    "spectrum",
                    "dataset:monopole",
                    "--size",
                    "12",
                    "--steps",
                    "30",
                    "--listener",
                    f"{1.375 + d},1.375,1.375",
                    "-o",
                    str(out),
                ]
            )
            == 0
        )
        got.append(json.loads(out.read_text())["channels"]["observer"]["oaspl_db"])
    assert got[0] - got[1] == pytest.approx(20 * np.log10(2), abs=0.02)


def test_clear_errors(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from auralize.audio.output import wav_bytes
    from auralize.spectrum import read_pascals

    bare = tmp_path / "bare.wav"
    bare.write_bytes(wav_bytes(np.zeros((1, 100)), RATE))
    with pytest.raises(FormatError, match="no sidecar bare.wav.json"):
        read_pascals(bare)
    assert main(["spectrum", "dataset:monopole", "--size", "12", "--steps", "8"]) == 2
    assert "give --listener X,Y,Z" in capsys.readouterr().err
    assert (
        main(
            [
                "spectrum",
                "dataset:monopole",
                "--size",
                "12",
                "--steps",
                "8",
                "--listener",
                "5,0,0",
                "--method",
                "fwh",
            ]
        )
        == 2
    )
    assert "--method fwh needs --surface" in capsys.readouterr().err
