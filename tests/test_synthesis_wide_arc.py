"""The gains of a layout with an arc wider than 180° are taken without
trigonometry where a direction lies clearly inside that arc: the same gains,
and the same samples, as the angular law's.  Two speakers in front of a folding
layout (stereo) are panned as a speaker pair, in the SIMD loops: the same gains
as the angular law's (to round-off), every direction but straight above or
below taken by the pair."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters import synthesis
from auralize.emitters._kernels.common import _CHUNK, KIND_GENERAL, KIND_SIMPLE, ROW
from auralize.emitters._kernels.gains import _gains
from auralize.emitters._kernels.lane_gains import _part_pair_gains
from auralize.emitters.synthesis import render_tracks
from auralize.listener import ListenerPath
from auralize.sources.detection import SourceTracks
from auralize.spatial import Speaker, make_layout
from auralize.spatial.layouts import Layout, get_layout, pan_gains, vbap_gains

RATE = 8000


def _scene(n: int = 300, steps: int = 24, seed: int = 0) -> SourceTracks:
    """``n`` sources in a 4 m cube sounding at random steps (random strengths)."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, steps)) * (rng.uniform(size=(n, steps)) < 0.6)
    return SourceTracks(
        positions=rng.uniform(-2.0, 2.0, size=(n, 3)),
        q=q,
        radius=np.full(n, 0.05),
        times=np.arange(steps) / 30.0,
    )


def _orbit(rate_hz: float | None, face: str = "sweep") -> ListenerPath:
    # head sweeping: the sources pass in front, to the side and behind (the folded rear)
    return ListenerPath.orbit(
        (0.0, 0.0, 0.0),
        radius=9.0,
        duration=2.0,
        turns=0.5,
        height=0.5,
        rate_hz=rate_hz,
        face=face,
    )


def _directions() -> np.ndarray:
    """Directions (x, y, z) all around, and those where the law changes: at the
    speakers (0°, ±30°, 120°, 180°) and their middles, 1e-12 rad off them, on
    the axes, straight up, and zero."""
    rng = np.random.default_rng(4)
    ang = np.radians([0.0, 30.0, -30.0, 90.0, -90.0, 120.0, 180.0, -150.0, 60.0, 75.0, -105.0])
    ang = np.concatenate([ang, ang + 1e-12, ang - 1e-12, rng.uniform(-np.pi, np.pi, 400)])
    d = np.stack([np.cos(ang), np.sin(ang), rng.normal(scale=0.3, size=ang.size)], axis=1)
    return np.vstack([d, [[0, 0, 1.0], [0, 0, 0], [-0.0, 1e-300, 0], [1e-300, -1e-300, 0]]])


@pytest.mark.parametrize("azimuths", [(100.0, -100.0), (0.0, 120.0), (30.0, 0.0, -30.0)])
@pytest.mark.parametrize("fold", [True, False])
def test_wide_arc_gains_are_the_angular_law(azimuths, fold) -> None:  # type: ignore[no-untyped-def]
    # a layout with an arc wider than 180° (a pair not both in front, whose
    # front arc is the wide one; an asymmetric pair; three front speakers): the
    # shortcut's gains are the angular law's, bit for bit
    lay = make_layout("wide", [Speaker(f"S{k}", a) for k, a in enumerate(azimuths)])
    az, ch = synthesis.panning_arrays(lay)
    tab = synthesis.pan_table(lay, az)
    assert tab.shape == (1, 7)
    fast, law = np.zeros(ch.size), np.zeros(ch.size)
    whole = 0
    # forward and up: facing +x (the directions' angles are azimuths), and turned
    for frame in ((1.0, 0.0, 0.0, 0.0, 0.0, 1.0), (0.6, 0.8, 0.0, 0.0, 0.0, 1.0)):
        for v in _directions():
            _gains((v[0], v[1], v[2]), frame, az, ch, fold, tab, fast)
            _gains((v[0], v[1], v[2]), frame, az, ch, fold, np.zeros((0, 4)), law)
            assert np.array_equal(fast, law), (v, fast, law)
            whole += int(np.sum(law == 1.0) == 1 and np.sum(law == 0.0) == ch.size - 1)
    assert whole > 100  # (many directions on the wide arc: one speaker takes them whole)


#: two-speaker layouts whose speakers are both in front (stereo; asymmetric; one
#: speaker at exactly 90°, the law's edge; a pair 5° apart; stereo with an LFE
#: channel), and a folding ring of three
PAIRS = {
    "stereo": get_layout("stereo"),
    "45/-10": make_layout("p", [Speaker("A", 45.0), Speaker("B", -10.0)]),
    "90/-30": make_layout("p", [Speaker("A", 90.0), Speaker("B", -30.0)]),
    "80/85": make_layout("p", [Speaker("A", 80.0), Speaker("B", 85.0)]),
    "2.1": make_layout("p", [Speaker("L", 30.0), Speaker("R", -30.0), Speaker("LFE", None)]),
}


def test_pan_table_of_two_speakers() -> None:
    # both in front and folding: the front pair alone; otherwise the wide arc's table
    for lay in PAIRS.values():
        assert synthesis.pan_table(lay, synthesis.panning_arrays(lay)[0]).shape == (1, 4)
    for lay in (
        make_layout("p", [Speaker("A", 100.0), Speaker("B", -100.0)]),
        make_layout("p", [Speaker("A", 0.0), Speaker("B", 120.0)]),
        Layout("p", (Speaker("L", 30.0), Speaker("R", -30.0)), fold_front=False),
    ):
        assert synthesis.pan_table(lay, synthesis.panning_arrays(lay)[0]).shape == (1, 7)


def _sweep() -> np.ndarray:
    """Unit directions (N, 3) at every 0.05° of azimuth and 13 elevations, at the
    azimuths where a two-speaker law changes (0°, ±90°, 180°, the speakers and
    their mirror images across the left-right axis) and 1e-12 rad off them;
    straight up and down."""
    special = np.radians([0.0, 90.0, -90.0, 180.0, 30.0, -30.0, 150.0, -150.0, 45.0, -10.0])
    special = np.concatenate([special, np.radians([135.0, -170.0, 80.0, 85.0, 100.0, 95.0])])
    az = np.concatenate([np.radians(np.arange(-180.0, 180.0, 0.05)), special])
    az = np.concatenate([az, special + 1e-12, special - 1e-12])
    el = np.radians(np.linspace(-85.0, 85.0, 13))
    a, e = np.meshgrid(az, el, indexing="ij")
    d = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1).reshape(-1, 3)
    return np.vstack([d, [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]])


def _lane_gains(lay, d, d1, frame, const):  # type: ignore[no-untyped-def]
    """The SIMD loops' pair gains (``_part_pair_gains``) of directions ``d`` and
    ``d1`` (N, 3), the first and second arrival of N parts, in the listener's
    ``frame`` (forward, up): gains (2, n_channels, N) and whether each part
    is left to the scalar code (general)."""
    az, ch = synthesis.panning_arrays(lay)
    tab = synthesis.pan_table(lay, az)
    nxt = np.roll(ch, -1)
    table = np.array([frame] if const else [frame, frame], dtype=np.float64)
    clock = np.array([0.0, 1.0])
    gains = np.zeros((2, lay.n_channels, len(d)))
    general = np.zeros(len(d), dtype=bool)
    for s in range(0, len(d), _CHUNK):
        n = min(_CHUNK, len(d) - s)
        w = np.zeros(ROW.END * _CHUNK)

        def row(r, v, w=w, n=n):  # type: ignore[no-untyped-def]
            w[r * _CHUNK : r * _CHUNK + n] = v

        for c in range(3):  # source at d, listener at 0 and at d - d1
            row(ROW.X + c, d[s : s + n, c])
            row(ROW.L1 + c, d[s : s + n, c] - d1[s : s + n, c])
        row(ROW.A0, 0.25)
        row(ROW.A1, 0.75)
        row(ROW.KIND, KIND_SIMPLE)
        _part_pair_gains(w, n, table, clock, tab, lay.fold_front, const)
        general[s : s + n] = w[ROW.KIND * _CHUNK : ROW.KIND * _CHUNK + n] == KIND_GENERAL
        for k, rp in enumerate((ROW.P0, ROW.P1)):
            p = w[rp * _CHUNK : rp * _CHUNK + n].astype(np.int64)
            lanes = np.arange(s, s + n)
            gains[k, ch[p], lanes] += w[(rp + 1) * _CHUNK : (rp + 1) * _CHUNK + n]
            gains[k, nxt[p], lanes] += w[(rp + 2) * _CHUNK : (rp + 2) * _CHUNK + n]
    return gains, general


@pytest.mark.parametrize("name", list(PAIRS))
def test_front_pair_gains_are_vbap_gains(name) -> None:  # type: ignore[no-untyped-def]
    # over a dense sweep of azimuths and elevations, for a listener facing +x
    # and one turned: the SIMD loops' gains (orientation constant, and read
    # from its table) and the scalar code's equal the numpy law (vbap_gains of
    # the azimuth, pan_gains of the direction) to 1e-12; only straight above
    # and below is left to the scalar code (the even spread)
    lay = PAIRS[name]
    d = _sweep()
    d1 = d[::-1].copy()
    az, ch = synthesis.panning_arrays(lay)
    tab = synthesis.pan_table(lay, az)
    vertical = (d[:, 0] == 0.0) & (d[:, 1] == 0.0)
    out = np.zeros(lay.n_channels)
    for fwd in ((1.0, 0.0, 0.0), (0.6, 0.8, 0.0)):
        f, u = np.array(fwd), np.array([0.0, 0.0, 1.0])
        local = np.stack([d @ f, d @ np.cross(u, f), d @ u], -1)
        law = pan_gains(lay, local)
        flat = ~vertical
        az_law = vbap_gains(lay, np.arctan2(local[flat, 1], local[flat, 0]))
        np.testing.assert_allclose(law[:, flat], az_law, rtol=0, atol=1e-12)
        law1 = pan_gains(lay, local[::-1])
        for const in (True, False):
            lane, general = _lane_gains(lay, d, d1, (*fwd, *u), const)
            assert np.array_equal(general, vertical | vertical[::-1])
            np.testing.assert_allclose(lane[0][:, flat], law[:, flat], rtol=0, atol=1e-12)
            np.testing.assert_allclose(lane[1][:, flat[::-1]], law1[:, flat[::-1]], atol=1e-12)
        scalar = np.empty_like(law)
        for j, v in enumerate(d):
            _gains((v[0], v[1], v[2]), (*fwd, *u), az, ch, lay.fold_front, tab, out)
            scalar[:, j] = out
        np.testing.assert_allclose(scalar, law, rtol=0, atol=1e-12)
    # (many directions outside the pair: one speaker takes them whole)
    assert np.sum(np.isclose(np.max(law, axis=0), 1.0, rtol=0, atol=1e-15)) > d.shape[0] // 4


@pytest.mark.parametrize("rate_hz", [None, 10.0])
@pytest.mark.parametrize("face", ["sweep", "center"])
@pytest.mark.parametrize("name", ["stereo", "45/-10", "2.1", "ring8"])
def test_pair_render_equals_the_angular_law(monkeypatch, rate_hz, face, name) -> None:  # type: ignore[no-untyped-def]
    # a two-speaker layout is panned by its pair in the SIMD loops; its render
    # differs from that of the angular law (atan2 and sines, every piece through
    # the scalar code) by round-off, as ring8's pairs do from ring8's law.  (The
    # accumulator's integration turns gains 1e-16 apart, or a piece summed by
    # the SIMD loops instead of the scalar code, into 1e-11 of the peak.)
    lay = PAIRS.get(name) or get_layout(name)
    tracks, path = _scene(), _orbit(rate_hz, face)
    made = []
    real = synthesis.Panning

    def spy(*args):  # type: ignore[no-untyped-def]
        made.append(real(*args))
        return made[-1]

    monkeypatch.setattr(synthesis, "Panning", spy)
    fast = render_tracks(tracks, path, rate=RATE, layout=lay, time_scale=2.5).audio
    assert made[-1].pairs
    monkeypatch.setattr(synthesis, "pan_table", lambda lay, az: np.zeros((0, 4)))
    law = render_tracks(tracks, path, rate=RATE, layout=lay, time_scale=2.5).audio
    assert not made[-1].pairs
    peak = np.max(np.abs(law))
    assert peak > 0
    assert np.max(np.abs(fast - law)) <= 1e-9 * peak
    if name == "2.1":
        assert not np.any(fast[2]) and not np.any(law[2])  # LFE: nothing panned to it


def test_stereo_rear_source_is_heard_from_the_nearer_speaker() -> None:
    # one source behind and to the left of a listener facing +y: the folded
    # direction is left of the left speaker (30°), on the wide arc, whose nearer
    # end takes everything; the right channel stays exactly silent
    tr = SourceTracks(
        positions=np.array([[-3.0, -4.0, 0.0]]),
        q=np.sin(np.arange(12))[None, :],
        radius=np.full(1, 0.05),
        times=np.arange(12) / 30.0,
    )
    path = ListenerPath.point([0.0, 0.0, 0.0], duration=0.5)
    out = render_tracks(tr, path, rate=RATE, layout="stereo").audio
    mono = render_tracks(tr, path, rate=RATE, layout="mono").audio[0]
    lay = get_layout("stereo")
    left = [s.name for s in lay.speakers].index("L")
    assert np.max(np.abs(out[1 - left])) == 0.0
    assert np.max(np.abs(out[left] - mono)) <= 1e-9 * np.max(np.abs(mono))
