"""WAV sample formats (``--format float32|pcm16|pcm24``), the ``fact`` chunk of float WAVs,
and the sidecar's note on float WAVs in pascals."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from auralize.audio import read_wav, wav_bytes, write_audio
from auralize.errors import ParameterError


def _chunks(raw: bytes) -> dict[bytes, bytes]:
    pos, out = 12, {}
    while pos + 8 <= len(raw):
        cid, size = raw[pos : pos + 4], struct.unpack("<I", raw[pos + 4 : pos + 8])[0]
        out[cid] = raw[pos + 8 : pos + 8 + size]
        pos += 8 + size + (size & 1)
    return out


@pytest.mark.parametrize("n_ch", [1, 2, 8])
def test_float_wavs_carry_a_fact_chunk_with_the_frame_count(n_ch: int) -> None:
    a = np.linspace(-2.0, 2.0, n_ch * 101).reshape(n_ch, 101)
    chunks = _chunks(wav_bytes(a, 8000, channel_mask=None))
    assert struct.unpack("<I", chunks[b"fact"])[0] == 101
    assert b"fact" not in _chunks(wav_bytes(a / 2, 8000, subtype="pcm16"))


@pytest.mark.parametrize(
    ("fmt", "sub", "tol"),
    [("float32", "FLOAT", 1e-7), ("pcm24", "PCM_24", 2 / 2**23), ("pcm16", "PCM_16", 2 / 2**15)],
)
def test_formats_round_trip_and_libsndfile_agrees(
    tmp_path: Path, fmt: str, sub: str, tol: float
) -> None:
    rng = np.random.default_rng(0)
    a = rng.uniform(-1, 1, size=(8, 500)) * 0.001  # pascals
    out = tmp_path / f"x_{fmt}.wav"
    gain = write_audio(out, a, 48000, subtype=fmt, layout="ring8")
    back, rate, mask = read_wav(out)
    assert rate == 48000 and mask is not None and back.shape == (8, 500)
    assert np.max(np.abs(back - a * gain)) <= tol
    info = sf.info(str(out))
    assert info.subtype == sub and info.channels == 8 and info.frames == 500
    x, _ = sf.read(str(out), always_2d=True)
    assert np.max(np.abs(x.T - a * gain)) <= tol
    assert json.loads(Path(str(out) + ".json").read_text())["format"] == fmt


def test_float_pascals_beyond_one_are_noted_and_pcm_refuses_them(tmp_path: Path) -> None:
    a = np.array([[0.0, 3.5, -7.0, 1.0]])
    out = tmp_path / "pa.wav"
    assert write_audio(out, a, 8000, normalize="none") == 1.0
    assert np.allclose(read_wav(out)[0], a)
    meta = json.loads(Path(str(out) + ".json").read_text())
    assert meta["units"] == "Pa" and "beyond ±1 are intended" in meta["note"]
    with pytest.raises(ParameterError, match=r"pcm24 output needs samples in \[-1, 1\]"):
        write_audio(tmp_path / "b.wav", a, 8000, normalize="none", subtype="pcm24")
    with pytest.raises(ParameterError, match="format must be one of"):
        write_audio(tmp_path / "c.wav", a, 8000, subtype="pcm8")
    with pytest.raises(ParameterError, match="FLAC holds integer samples"):
        write_audio(tmp_path / "d.flac", a, 8000, subtype="float32")
    assert not (tmp_path / "b.wav").exists() and not (tmp_path / "c.wav").exists()
    write_audio(tmp_path / "e.wav", a, 8000)  # peak-normalised: no note
    assert "note" not in json.loads((tmp_path / "e.wav.json").read_text())


def test_render_command_writes_the_requested_format(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    import soundfile as sf

    from auralize.cli import build_parser, main

    out = tmp_path / "x.wav"
    assert (
        main(
            [
                "render",
                "dataset:monopole",
                "--size",
                "12",
                "--steps",
                "30",
                "--listener",
                "1,1,1",
                "--duration",
                "0.1",
                "-o",
                str(out),
                "--format",
                "pcm24",
            ]
        )
        == 0
    )
    info = sf.info(str(out))
    assert info.subtype == "PCM_24" and info.frames == 4410
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(
            [
                "render",
                "dataset:monopole",
                "--listener",
                "1,1,1",
                "--duration",
                "0.1",
                "-o",
                "x.wav",
                "--format",
                "pcm8",
            ]
        )
    assert e.value.code == 2
    assert "--format: invalid choice: 'pcm8'" in capsys.readouterr().err
