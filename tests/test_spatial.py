"""Speaker layouts and panning: real synthesis of a tone source in the listener's frame."""

from __future__ import annotations

import json

import numpy as np
import pytest

from auralize.emitters.synthesis import render_tracks
from auralize.errors import FormatError, ParameterError
from auralize.listener import ListenerPath
from auralize.sources import SourceTracks
from auralize.spatial import (
    BUILTIN_LAYOUTS,
    Speaker,
    SpeakerAlignment,
    align_speakers,
    downmix_matrix,
    get_layout,
    make_layout,
    pan_gains,
    vbap3d_gains,
    vbap_gains,
)

RATE = 44100
F_TONE = 300.0
LEFT = np.array([-1.0, 0.0, 0.0])  # up (+z) × forward (+y)
FWD = np.array([0.0, 1.0, 0.0])


def tone_tracks(
    positions: np.ndarray, *, duration: float = 0.3, fk: float = 4000.0
) -> SourceTracks:
    """Sources at ``positions (K, 3)`` all emitting a 300 Hz tone (knots at fk Hz)."""
    pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    t = np.arange(int(duration * fk)) / fk
    q = np.tile(np.sin(2 * np.pi * F_TONE * t), (pos.shape[0], 1))
    return SourceTracks(pos, q, np.full(pos.shape[0], 0.05), t)


def at_azimuth(az_deg: float, r: float = 2.0) -> np.ndarray:
    a = np.deg2rad(az_deg)
    return r * (np.cos(a) * FWD + np.sin(a) * LEFT)


def energies(layout: str, az_deg: float, *, forward=(0, 1, 0)) -> np.ndarray:  # type: ignore[no-untyped-def]
    tr = tone_tracks(at_azimuth(az_deg)[None, :])
    path = ListenerPath.point((0, 0, 0), duration=0.2, forward=forward)
    a = render_tracks(tr, path, layout=layout, rate=RATE).audio
    e = np.sum(a**2, axis=1)
    assert e.sum() > 0
    return e / e.sum()


@pytest.mark.parametrize("k", range(8))
def test_ring8_source_at_each_speaker(k: int) -> None:
    e = energies("ring8", 45.0 * k)
    assert e[k] >= 0.99
    assert np.argmax(e) == k


@pytest.mark.parametrize("name", ["FL", "FR", "FC", "BL", "BR"])
def test_51_source_at_each_speaker(name: str) -> None:
    lay = BUILTIN_LAYOUTS["5.1"]
    c = lay.channel_names.index(name)
    e = energies("5.1", lay.speakers[c].azimuth_deg)  # type: ignore[arg-type]
    assert e[c] >= 0.99
    assert e[lay.channel_names.index("LFE")] == 0.0


@pytest.mark.parametrize("k", [0, 3, 7])
def test_ring8_halfway_splits_equally(k: int) -> None:
    e = energies("ring8", 45.0 * k + 22.5)
    j = (k + 1) % 8
    assert e[k] + e[j] > 0.9999
    assert e[k] == pytest.approx(e[j], rel=1e-6)
    assert e[k] == pytest.approx(0.5, abs=1e-4)


def test_turning_listener_90deg_moves_energy_two_channels() -> None:
    # source at world azimuth 45° (channel 1) for a listener facing +y
    e0 = energies("ring8", 45.0)
    # the listener turns left by 90° (faces -x): the source is now at -45° (channel 7)
    e1 = energies("ring8", 45.0, forward=(-1, 0, 0))
    assert np.argmax(e0) == 1 and e0[1] >= 0.99
    assert np.argmax(e1) == 7 and e1[7] >= 0.99
    assert np.allclose(np.roll(e0, -2), e1, atol=1e-9)


def test_gains_power_normalized_and_kernel_consistent() -> None:
    rng = np.random.default_rng(3)
    az = rng.uniform(-np.pi, np.pi, 2000)
    for name in ("stereo", "ring8", "5.1", "7.1"):
        g = vbap_gains(get_layout(name), az)
        assert np.allclose(np.sum(g**2, axis=0), 1.0, atol=1e-12)
        assert np.all(g >= 0)
    # the kernel pans with the same law: channel amplitudes of a static source
    for a_deg in (10.0, 100.0, -160.0):
        tr = tone_tracks(at_azimuth(a_deg)[None, :])
        out = render_tracks(tr, ListenerPath.point((0, 0, 0), duration=0.2), layout="7.1").audio
        amp = np.sqrt(np.sum(out**2, axis=1))
        g = vbap_gains(get_layout("7.1"), np.deg2rad([a_deg]))[:, 0]
        assert np.allclose(amp / np.linalg.norm(amp), g, atol=1e-6)


def test_gains_change_smoothly() -> None:
    az = np.linspace(-np.pi, np.pi, 20001)
    g = vbap_gains(get_layout("ring8"), az)
    assert np.max(np.abs(np.diff(g, axis=1))) < 1e-3
    lay = _dome()
    el = np.deg2rad(30.0)
    d = np.stack(
        [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.full(az.size, np.sin(el))], 1
    )
    g3 = pan_gains(lay, d)
    assert np.allclose(np.sum(g3**2, axis=0), 1.0, atol=1e-12)
    assert np.max(np.abs(np.diff(g3, axis=1))) < 2e-3


def _dome() -> object:
    spk = [Speaker(f"S{k}", 45.0 * k) for k in range(8)]
    spk += [Speaker(f"H{k}", 90.0 * k + 45.0, 45.0) for k in range(4)]
    return make_layout("dome", spk)


def test_3d_vbap_speakers_poles_and_below() -> None:
    lay = _dome()
    g = vbap3d_gains(lay, lay.directions())  # type: ignore[attr-defined]
    assert np.allclose(np.diag(g) ** 2, 1.0, atol=1e-12)
    rng = np.random.default_rng(0)
    d = rng.normal(size=(500, 3))
    g = vbap3d_gains(lay, d)
    assert np.allclose(np.sum(g**2, axis=0), 1.0, atol=1e-12) and np.all(g >= 0)
    up, down = pan_gains(lay, np.array([[0, 0, 1.0], [0, 0, -1.0]])).T
    assert np.allclose(up[8:] ** 2, 0.25)  # zenith: the four height speakers equally
    assert np.allclose(down[:8] ** 2, 0.125)  # nadir: the ring equally
    # 30° below straight left: the ring speaker at +90° (channel 2)
    below = np.array([[0.0, np.cos(np.pi / 6), -np.sin(np.pi / 6)]])
    assert pan_gains(lay, below)[2, 0] == pytest.approx(1.0)


def test_unknown_layout_name() -> None:
    with pytest.raises(ParameterError, match=r"unknown layout 'ring9'.*ring8"):
        get_layout("ring9")


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("{not json", "not valid JSON"),
        ('{"speakers": []}', "non-empty list 'speakers'"),
        ('{"speakers": [{"azimuth": 0}]}', "at least 2 speakers"),
        ('[{"azimuth": 0}, {"azimuth": "left"}]', r"'azimuth' must be a number"),
        ('[{"azimuth": 0}, {"elevation": 10}]', "needs an 'azimuth'"),
        ('[{"azimuth": 0}, {"azimuth": 90, "elevation": 95}]', r"elevation must be in \[-90, 90\]"),
        ('[{"azimuth": 0}, {"azimuth": 360}]', "point the same way"),
        (
            '[{"azimuth": 0, "channel": 0}, {"azimuth": 90, "channel": 0}]',
            r"duplicate channel\(s\) \[0\]",
        ),
        ('[{"azimuth": 0, "channel": 0}, {"azimuth": 90, "channel": 2}]', r"missing \[1\]"),
        ('[{"azimuth": 0, "channel": 0}, {"azimuth": 90}]', "every speaker or none"),
        ('[{"azimuth": 0, "name": "A"}, {"azimuth": 90, "name": "A"}]', "duplicate speaker names"),
        ('[{"azimuth": 0, "distance": -1}, {"azimuth": 90}]', "distance must be > 0"),
    ],
)
def test_malformed_layout_json(tmp_path, content: str, match: str) -> None:  # type: ignore[no-untyped-def]
    f = tmp_path / "bad.json"
    f.write_text(content)
    with pytest.raises(FormatError, match=match):
        get_layout(str(f))


def test_missing_layout_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(FormatError, match="does not exist"):
        get_layout(str(tmp_path / "nope.json"))


def test_custom_layout_channel_order_and_roundtrip(tmp_path) -> None:  # type: ignore[no-untyped-def]
    f = tmp_path / "quad.json"
    f.write_text(
        json.dumps(
            {
                "name": "quad",
                "speakers": [
                    {"name": "RR", "azimuth": -135, "channel": 3},
                    {"name": "FL", "azimuth": 45, "channel": 0},
                    {"name": "FR", "azimuth": -45, "channel": 1},
                    {"name": "RL", "azimuth": 135, "channel": 2},
                ],
            }
        )
    )
    lay = get_layout(str(f))
    assert lay.channel_names == ["FL", "FR", "RL", "RR"]
    e = energies(str(f), 135.0)
    assert np.argmax(e) == 2 and e[2] >= 0.99
    g = tmp_path / "back.json"
    g.write_text(json.dumps(lay.describe()))
    assert get_layout(str(g)).speakers == lay.speakers
    five = tmp_path / "51.json"
    five.write_text(json.dumps(get_layout("5.1").describe()))
    assert get_layout(str(five)).speakers == get_layout("5.1").speakers


def test_speaker_alignment_delay_gain_and_blocks() -> None:
    lay = make_layout(
        "near", [Speaker("A", 0.0, 0.0, 3.43), Speaker("B", 90.0, 0.0, 1.715), Speaker("C", 180.0)]
    )
    al = SpeakerAlignment(lay, 1000)
    assert al.delays.tolist() == [0, 5, 0] and al.gains.tolist() == [1.0, 0.5, 1.0]
    x = np.random.default_rng(1).normal(size=(3, 100))
    y = align_speakers(x, lay, 1000)
    assert np.allclose(y[1, 5:], 0.5 * x[1, :-5]) and np.all(y[1, :5] == 0)
    assert np.array_equal(y[0], x[0])
    al2 = SpeakerAlignment(lay, 1000)
    blocks = np.concatenate([al2.process(x[:, i : i + 3]) for i in range(0, 100, 3)], axis=1)
    assert np.allclose(blocks, y)


def test_downmix_matrix() -> None:
    m = downmix_matrix("ring8", "stereo")
    assert m.shape == (2, 8)
    assert np.allclose(np.sum(m**2, axis=0), 1.0)
    assert np.allclose(m[:, 2], [1, 0]) and np.allclose(m[:, 6], [0, 1])  # left, right
    m = downmix_matrix("5.1", "stereo")
    assert np.allclose(m[:, 3], [2**-0.5, 2**-0.5])  # LFE shared
    assert np.allclose(downmix_matrix("7.1", "7.1"), np.eye(8))


def test_synthesis_pans_in_3d_for_layouts_with_elevation(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    from auralize.emitters.synthesis import render_reference, render_tracks
    from auralize.listener import ListenerPath

    lay = _dome()
    c = mono_params.center
    # the source 3.5 m above-front-left of a listener facing +x with +z up: the
    # direction of height speaker H0 (azimuth 45°, elevation 45°)
    d = np.array(
        [
            np.cos(np.pi / 4) * np.cos(np.pi / 4),
            np.sin(np.pi / 4) * np.cos(np.pi / 4),
            np.sin(np.pi / 4),
        ]
    )
    listener = c - 3.5 * d
    path = ListenerPath(
        np.array([0.0, 0.04]), np.array([listener, listener]), np.array([[1.0, 0, 0], [1.0, 0, 0]])
    )
    out = render_tracks(mono_tracks, path, rate=44100, layout=lay).audio
    energy = np.sum(out**2, axis=1)
    assert energy[8] / energy.sum() >= 0.99  # H0 is channel 8
    # a moving, turning listener: the kernel's 3-D law equals the per-sample one
    path = ListenerPath(
        np.array([0.0, 0.02, 0.04]),
        np.array([c + [2.0, 0.5, -1.0], c + [1.0, 1.5, -1.5], c + [-0.5, 1.8, -1.2]]),
        np.array([[0.0, 1, 0], [-1, 1, 0.3], [-1, 0, 0.5]]),
    )
    sub = type(mono_tracks)(
        positions=mono_tracks.positions[::5],
        q=mono_tracks.q[::5],
        radius=mono_tracks.radius[::5],
        times=mono_tracks.times,
    )
    fast = render_tracks(sub, path, rate=44100, layout=lay).audio
    ref = render_reference(sub, path, rate=44100, layout=lay)
    assert np.max(np.abs(fast - ref)) / np.max(np.abs(ref)) < 5e-3
    assert np.sum(fast[8:] ** 2) > 0.01 * np.sum(fast**2)  # the height speakers sound
