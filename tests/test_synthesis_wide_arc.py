"""The gains of a layout with an arc wider than 180° (stereo) are taken without
trigonometry where a direction lies clearly inside that arc: the same gains,
and the same samples, as the angular law's."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters import synthesis
from auralize.emitters.synthesis import render_tracks
from auralize.listener import ListenerPath
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import get_layout

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


def _orbit(rate_hz: float | None) -> ListenerPath:
    # head sweeping: the sources pass in front, to the side and behind (the folded rear)
    return ListenerPath.orbit(
        (0.0, 0.0, 0.0),
        radius=9.0,
        duration=2.0,
        turns=0.5,
        height=0.5,
        rate_hz=rate_hz,
        face="sweep",
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


@pytest.mark.parametrize("azimuths", [(30.0, -30.0), (0.0, 120.0), (30.0, 0.0, -30.0)])
@pytest.mark.parametrize("fold", [True, False])
def test_wide_arc_gains_are_the_angular_law(azimuths, fold) -> None:  # type: ignore[no-untyped-def]
    # a layout with an arc wider than 180° (stereo, an asymmetric pair, three
    # front speakers): the shortcut's gains are the angular law's, bit for bit
    from auralize.emitters._kernels.gains import _gains
    from auralize.spatial import Speaker, make_layout

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


@pytest.mark.parametrize("rate_hz", [None, 10.0])
def test_stereo_render_equals_the_angular_law(monkeypatch, rate_hz) -> None:  # type: ignore[no-untyped-def]
    tracks, path = _scene(), _orbit(rate_hz)
    fast = render_tracks(tracks, path, rate=RATE, layout="stereo", time_scale=2.5).audio
    # without the wide arc's table every gain comes from atan2 and sines
    monkeypatch.setattr(synthesis, "pan_table", lambda lay, az: np.zeros((0, 4)))
    law = render_tracks(tracks, path, rate=RATE, layout="stereo", time_scale=2.5).audio
    assert np.max(np.abs(law)) > 0
    assert np.array_equal(fast, law)


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
