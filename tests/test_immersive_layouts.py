"""Immersive layouts: IEM LoudspeakerLayout JSON, FLAC channel-mask warning, layout names."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from auralize.errors import FormatError, ParameterError
from auralize.spatial import (
    flac_mask_warning,
    get_layout,
    load_layout_json,
    pan_gains,
    triangulate,
    vbap3d_gains,
)


def iem(path: Path, speakers: list[dict], name: str = "Studio") -> Path:  # type: ignore[type-arg]
    path.write_text(
        json.dumps(
            {
                "Name": "export",
                "Description": "IEM AllRADecoder export",
                "LoudspeakerLayout": {"Name": name, "Loudspeakers": speakers},
            }
        )
    )
    return path


def spk(
    az: float, el: float, ch: int, *, imag: bool = False, gain: float = 1.0, r: float = 1.5
) -> dict:  # type: ignore[type-arg]
    return {
        "Azimuth": az,
        "Elevation": el,
        "Radius": r,
        "IsImaginary": imag,
        "Channel": ch,
        "Gain": gain,
    }


def test_read_iem_layout(tmp_path: Path) -> None:
    # a ring of 4 at ear height and 4 at 35°, channels given out of order, a subwoofer
    # channel (5) without a speaker, an imaginary speaker below
    sp = [spk(45 + 90 * k, 0, ch) for k, ch in enumerate((1, 2, 3, 4))]
    sp += [spk(90 * k, 35, ch, gain=0.5 if ch == 9 else 1.0) for k, ch in enumerate((9, 8, 7, 6))]
    sp.append(spk(0, -90, 10, imag=True))
    lay = load_layout_json(iem(tmp_path / "l.json", sp))
    assert lay.name == "Studio" and lay.n_channels == 9
    assert lay.speakers[4].azimuth_deg is None  # channel 5: silent output
    assert [s.azimuth_deg for s in lay.speakers[5:]] == [270.0, 180.0, 90.0, 0.0]
    assert lay.speakers[0].distance_m == 1.5 and lay.speakers[8].elevation_deg == 35
    assert lay.meta["channel_gains"][8] == 0.5 and lay.meta["channel_gains"][4] == 0.0
    np.testing.assert_allclose(lay.meta["imaginary_directions"], [[0, 0, -1.0]], atol=1e-12)
    assert get_layout(str(tmp_path / "l.json")).n_channels == 9
    tri = triangulate(lay)
    # the file's nadir, and the zenith added because no speaker is within 20° of it
    np.testing.assert_allclose(tri.imaginary_directions, [[0, 0, -1.0], [0, 0, 1.0]], atol=1e-12)
    # a source below pans on the ring at its own azimuth (imaginary gain dropped)
    g = vbap3d_gains(lay, np.array([[math.cos(0.8), math.sin(0.8), -0.9]]))[:, 0]
    assert int(np.argmax(g)) == 0 and g[4] == 0 and math.isclose(float(np.sum(g**2)), 1.0)


def test_iem_layout_errors(tmp_path: Path) -> None:
    cases = [
        ([spk(0, 0, 1), spk(90, 0, 1)], "channel 1 is used twice"),
        ([{"Elevation": 0, "Channel": 1}, spk(90, 0, 2)], "needs 'Azimuth'"),
        ([spk(0, 0, 0), spk(90, 0, 2)], "'Channel' must be an integer ≥ 1"),
        ([spk(0, 100, 1), spk(90, 0, 2)], "Elevation must be in"),
        ([spk(0, 0, 1, imag=True)], "no real"),
    ]
    for k, (sp, match) in enumerate(cases):
        p = iem(tmp_path / f"bad{k}.json", sp)
        with pytest.raises(FormatError, match=match) as ei:
            load_layout_json(p)
        assert str(p) in str(ei.value)
    p = tmp_path / "empty.json"
    p.write_text(json.dumps({"LoudspeakerLayout": {"Loudspeakers": []}}))
    with pytest.raises(FormatError, match="needs 'LoudspeakerLayout'"):
        load_layout_json(p)


def test_flac_mask_warning() -> None:
    assert flac_mask_warning("5.1") is None and flac_mask_warning("stereo") is None
    assert flac_mask_warning("binaural") is None
    w = flac_mask_warning("ring8")
    assert w is not None and "7.1" in w and "ring8" in w
    w3 = flac_mask_warning("ambix3")
    assert w3 is not None and "AmbiX order 3" in w3


def test_layout_names() -> None:
    with pytest.raises(ParameterError, match="binaural.*ambix1|ambix1.*binaural"):
        get_layout("ambix9")
    assert get_layout("ambix2").n_channels == 9
    assert pan_gains(get_layout("ambix1"), np.array([[1.0, 0, 0]]))[:, 0].tolist() == [1, 0, 0, 1]


def test_describe_immersive(tmp_path: Path) -> None:
    d = get_layout("ambix3").describe()
    assert d["meta"]["order"] == 3 and d["channels"][:4] == ["ACN0", "ACN1", "ACN2", "ACN3"]
    assert "speakers" not in d  # components, not (LFE) speakers
    b = get_layout("binaural").describe()
    assert b["meta"]["binaural"] and b["channel_mask"] == 3
    p = iem(tmp_path / "l.json", [spk(0, 0, 1), spk(120, 0, 2), spk(-120, 0, 3)])
    lay = load_layout_json(p)
    q = tmp_path / "back.json"
    q.write_text(json.dumps(lay.describe()))
    assert [s.azimuth_deg for s in load_layout_json(q).speakers] == [0, 120, -120]


def test_iem_gains_applied(tmp_path: Path) -> None:
    """Each real speaker's ``Gain`` scales its output channel (after the Radius
    alignment) in files written with the layout and in block-wise alignment."""
    from auralize.audio import read_wav, write_audio
    from auralize.spatial import SpeakerAlignment, align_speakers

    rate = 48000
    # a triangle at 2 m, 2 m and 1 m; channel 2 at half gain, channel 3 inverted at 0.8;
    # an imaginary speaker's gain is not an output's
    sp = [
        spk(0, 0, 1, r=2.0),
        spk(120, 0, 2, gain=0.5, r=2.0),
        spk(-120, 0, 3, gain=-0.8, r=1.0),
        spk(0, 90, 4, imag=True, gain=0.3),
    ]
    lay = load_layout_json(iem(tmp_path / "g.json", sp))
    assert lay.needs_alignment and lay.channel_gains is not None
    np.testing.assert_array_equal(lay.channel_gains, [1.0, 0.5, -0.8])
    x = np.random.default_rng(0).normal(size=(3, 4800)) * 0.1
    y = align_speakers(x, lay, rate)
    k = round(1.0 / 343.0 * rate)  # the near speaker is delayed by its 1 m, halved by 1/r
    np.testing.assert_allclose(y[0], x[0], rtol=1e-15)
    np.testing.assert_allclose(y[1], 0.5 * x[1], rtol=1e-15)
    np.testing.assert_allclose(y[2, k:], -0.8 * 0.5 * x[2, :-k], rtol=1e-15)
    al = SpeakerAlignment(lay, rate)  # the same in blocks
    blocks = np.concatenate([al.process(x[:, s : s + 1000]) for s in range(0, 4800, 1000)], 1)
    np.testing.assert_allclose(blocks, y, rtol=1e-15)
    wav = tmp_path / "g.wav"
    write_audio(wav, x, rate, layout=lay, normalize="none")
    back, r, _ = read_wav(wav)
    assert r == rate
    np.testing.assert_allclose(back, y, atol=1e-7)
    # all gains 1 and no Radius: nothing to align
    plain = load_layout_json(
        iem(
            tmp_path / "p.json",
            [{**spk(a, 0, c), "Radius": None} for c, a in ((1, 0), (2, 120), (3, -120))],
        )
    )
    assert plain.channel_gains is None and not plain.needs_alignment


def test_iem_gain_must_be_a_number(tmp_path: Path) -> None:
    p = iem(tmp_path / "bad.json", [spk(0, 0, 1), {**spk(90, 0, 2), "Gain": "-6 dB"}])
    with pytest.raises(FormatError, match="'Gain' must be a number") as ei:
        load_layout_json(p)
    assert str(p) in str(ei.value)
