"""Multichannel files per layout, downmix, and sound-device selection errors.

Device tests use file-backed ALSA devices defined in a temporary
``$XDG_CONFIG_HOME/alsa/asoundrc`` (no sound card needed); PortAudio is
re-initialised so it enumerates them, and restored afterwards.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from auralize.audio import (
    choose_output_device,
    downmix,
    list_devices,
    read_wav,
    refresh_devices,
    write_audio,
)
from auralize.emitters.synthesis import render_tracks
from auralize.errors import DeviceError, ParameterError
from auralize.listener import ListenerPath
from auralize.pipeline import save_rendered
from auralize.sources import SourceTracks
from auralize.spatial import BUILTIN_LAYOUTS, Speaker, get_layout, make_layout

MASKS = {"mono": 0x4, "stereo": 0x3, "5.1": 0x3F, "7.1": 0x63F}

ASOUNDRC = """
pcm.auralize_file {{
    type file
    slave.pcm "null"
    file "{out}"
    format "raw"
}}
pcm.auralize_two {{
    type file
    file "{out2}"
    format "raw"
    slave.pcm {{
        type multi
        slaves.a.pcm "null"
        slaves.a.channels 2
        bindings.0 {{ slave a; channel 0; }}
        bindings.1 {{ slave a; channel 1; }}
    }}
}}
"""


def tone_tracks(
    positions: np.ndarray, *, duration: float = 0.3, fk: float = 4000.0
) -> SourceTracks:
    """Sources at ``positions (K, 3)`` emitting a 300 Hz tone (knots at fk Hz)."""
    pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    t = np.arange(int(duration * fk)) / fk
    q = np.tile(np.sin(2 * np.pi * 300.0 * t), (pos.shape[0], 1))
    return SourceTracks(pos, q, np.full(pos.shape[0], 0.05), t)


def at_azimuth(az_deg: float, r: float = 2.0) -> np.ndarray:
    """A point at ``az_deg`` in the frame of a listener at the origin facing +y, up +z."""
    a = np.deg2rad(az_deg)
    return r * np.array([-np.sin(a), np.cos(a), 0.0])


def parse_wav_header(path: Path) -> dict[str, int]:
    """fmt chunk fields, parsed independently of auralize.audio.read_wav."""
    raw = path.read_bytes()
    assert raw[:4] == b"RIFF" and raw[8:12] == b"WAVE"
    pos = 12
    while pos < len(raw):
        cid, size = raw[pos : pos + 4], struct.unpack("<I", raw[pos + 4 : pos + 8])[0]
        if cid == b"fmt ":
            tag, ch, rate, _, align, bits = struct.unpack("<HHIIHH", raw[pos + 8 : pos + 24])
            out = {"tag": tag, "channels": ch, "rate": rate, "bits": bits, "align": align}
            if tag == 0xFFFE:
                out["mask"] = struct.unpack("<I", raw[pos + 28 : pos + 32])[0]
                out["subformat"] = struct.unpack("<H", raw[pos + 32 : pos + 34])[0]
            return out
        pos += 8 + size + (size & 1)
    raise AssertionError("no fmt chunk")


@pytest.mark.parametrize("name", ["mono", "stereo", "ring8", "5.1", "7.1"])
def test_wav_per_layout_reads_back(tmp_path, name: str) -> None:  # type: ignore[no-untyped-def]
    lay = get_layout(name)
    path = ListenerPath.point((0, 0, 0), duration=0.1)
    panned = [c for c, s in enumerate(lay.speakers) if s.azimuth_deg is not None]
    for c in panned:
        tr = tone_tracks(at_azimuth(lay.speakers[c].azimuth_deg)[None, :])  # type: ignore[arg-type]
        out = tmp_path / f"{name}_{c}.wav"
        save_rendered(render_tracks(tr, path, layout=lay), out)
        hdr = parse_wav_header(out)
        assert hdr["channels"] == lay.n_channels and hdr["rate"] == 44100 and hdr["bits"] == 32
        if lay.n_channels > 2:
            assert hdr["tag"] == 0xFFFE and hdr["subformat"] == 3  # extensible, IEEE float
            assert hdr["mask"] == MASKS.get(name, 0)
        a, rate, mask = read_wav(out)
        b, rate_sf = sf.read(str(out), always_2d=True)
        assert sf.info(str(out)).channels == lay.n_channels and rate_sf == rate == 44100
        assert np.allclose(a, b.T, atol=1e-7)
        e = np.sum(a**2, axis=1)
        assert np.argmax(e) == c and e[c] / e.sum() >= 0.99  # channel order
        meta = json.loads(Path(str(out) + ".json").read_text())
        assert meta["layout"]["name"] == name and meta["channels"] == lay.n_channels
        assert meta["rate"] == 44100 and "gain" in meta and "time_scale" in meta


def test_flac_and_layout_alignment(tmp_path) -> None:  # type: ignore[no-untyped-def]
    a = np.random.default_rng(0).uniform(-1, 1, (6, 4410))
    write_audio(tmp_path / "x.flac", a, 44100, layout="5.1")
    info = sf.info(str(tmp_path / "x.flac"))
    assert info.channels == 6 and info.samplerate == 44100
    lay = make_layout("near", [Speaker("A", 30.0, 0.0, 2.0), Speaker("B", -30.0, 0.0, 1.0)])
    x = np.zeros((2, 1000))
    x[:, 10] = 1.0
    write_audio(tmp_path / "n.wav", x, 34300, layout=lay, normalize="none")
    y, _, _ = read_wav(tmp_path / "n.wav")
    assert y[0, 10] == 1.0 and y[1, 110] == pytest.approx(0.5)  # 1 m nearer: 100 samples, 1/2
    meta = json.loads((tmp_path / "n.wav.json").read_text())
    assert meta["layout"]["speakers"][1]["distance"] == 1.0
    with pytest.raises(ParameterError, match="layout 'ring8' has 8 channels"):
        write_audio(tmp_path / "bad.wav", x, 44100, layout="ring8")
    assert not (tmp_path / "bad.wav").exists()


def test_downmix_ring8_to_stereo() -> None:
    a = np.zeros((8, 10))
    a[2] = 1.0  # left speaker
    a[6] = 2.0  # right speaker
    assert np.allclose(downmix(a, "ring8", "stereo"), [[1.0] * 10, [2.0] * 10])
    with pytest.raises(ParameterError, match="has 8 channels"):
        downmix(a[:6], "ring8", "stereo")


@pytest.fixture
def alsa_files(tmp_path, monkeypatch):  # type: ignore[no-untyped-def]
    cfg = tmp_path / "cfg"
    (cfg / "alsa").mkdir(parents=True)
    (cfg / "alsa" / "asoundrc").write_text(
        ASOUNDRC.format(out=tmp_path / "out.raw", out2=tmp_path / "out2.raw")
    )
    monkeypatch.setenv("XDG_CONFIG_HOME", str(cfg))
    refresh_devices()
    yield tmp_path
    monkeypatch.undo()
    refresh_devices()


def _has_sound_card() -> bool:
    p = Path("/proc/asound/cards")
    return p.exists() and "no soundcards" not in p.read_text() and p.read_text().strip() != ""


def test_list_and_choose_devices(alsa_files) -> None:  # type: ignore[no-untyped-def]
    devs = {d["name"]: d for d in list_devices()}
    assert devs["auralize_file"]["max_output_channels"] >= 8
    assert devs["auralize_two"]["max_output_channels"] == 2
    assert choose_output_device("auralize_file", 8)["name"] == "auralize_file"
    idx = devs["auralize_two"]["index"]
    assert choose_output_device(idx, 2)["name"] == "auralize_two"
    assert choose_output_device(str(idx), 8, downmix=True)["name"] == "auralize_two"


def test_device_index_out_of_range(alsa_files) -> None:  # type: ignore[no-untyped-def]
    n = len(list_devices(outputs_only=False))
    with pytest.raises(
        DeviceError, match=rf"device index 99 is out of range: there are {n} devices"
    ):
        choose_output_device(99, 2)


def test_device_without_enough_channels(alsa_files) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(
        DeviceError,
        match=r"\(auralize_two\) has 2 output channels but the layout "
        r"needs 8; add --downmix to fold it to stereo",
    ):
        choose_output_device("auralize_two", BUILTIN_LAYOUTS["ring8"].n_channels)


def test_device_name_not_found(alsa_files) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(DeviceError, match=r"no output device matches 'speakers'.*auralize_file"):
        choose_output_device("speakers", 2)
    with pytest.raises(DeviceError, match="matches several devices"):
        choose_output_device("auralize", 2)


def test_no_device_at_all(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    if _has_sound_card():
        pytest.skip("this machine has a sound card, so PortAudio always sees a device")
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))  # no asoundrc: no devices
    refresh_devices()
    try:
        assert list_devices() == []
        with pytest.raises(
            DeviceError, match=r"no audio output device found.*write a file instead"
        ):
            choose_output_device(None, 8)
        from auralize.cli import main

        assert main(["devices"]) == 0
    finally:
        monkeypatch.undo()
        refresh_devices()


def test_import_opens_no_device() -> None:
    import subprocess
    import sys

    code = "import sys, auralize, auralize.audio, auralize.audio.live, auralize.cli.audio; print('sounddevice' in sys.modules)"
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1])},
    )
    assert out.stdout.strip() == "False"
