"""Live listening plays the rendered file's sound: the viewer's live engine high-passes
the sources at 20 Hz (as ``auralize render`` and the viewer's file), its filter state
carried from block to block, so its blocks equal the offline render filtered once."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters import Emitters, Sound, render_sound
from auralize.emitters.synthesis import C0, box_distances, source_extent
from auralize.emitters.timbre import HIGHPASS_HZ, render_timbre
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.scene.listening import LiveEngine
from auralize.sources import SourceTracks

POSE = ((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def _tracks() -> SourceTracks:
    """Two sources whose pressure is mostly a 3 Hz swell (inaudible) with a quiet
    220 Hz tone on top: the 20 Hz high-pass changes what is heard."""
    fk = 4000.0
    t = np.arange(int(1.2 * fk)) / fk
    q = np.stack(
        [
            np.sin(2 * np.pi * 3 * t) + 0.02 * np.sin(2 * np.pi * 220 * t),
            0.5 * np.cos(2 * np.pi * 3 * t),
        ]
    )
    return SourceTracks(np.array([[3.0, 0.5, 0.0], [-2.0, 2.0, 0.5]]), q, np.full(2, 0.1), t)


def _live(tracks: SourceTracks, n_blocks: int, **kw: object) -> np.ndarray:
    eng = LiveEngine(tracks, layout="stereo", block=2205, loop=False, **kw)  # type: ignore[arg-type]
    eng.set_pose(*POSE)
    return np.concatenate([eng.next_block() for _ in range(n_blocks)], axis=1)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_live_blocks_equal_the_offline_render_with_the_highpass() -> None:
    tracks = _tracks()
    n_blocks = 20  # 1 s in 50 ms blocks
    path = ListenerPath.point(POSE[0], duration=1.0)
    on = _live(tracks, n_blocks)
    # the clock of a render standing there (plan_render): the travel time from the
    # sources' box to the listener is skipped
    lo, hi, _ = source_extent(tracks)
    lead = float(box_distances(np.array([POSE[0]]), lo, hi)[0][0]) / C0
    assert lead > 0.001
    # auralize render --timbre physical (default --highpass 20)
    off = render_timbre(tracks, path, timbre="physical", layout="stereo", lead=lead).audio
    assert off.shape == on.shape == (2, 44100)
    assert _rel(on, off) < 1e-5
    # the one render of every front end, as the viewer's file is made
    from auralize.emitters import FieldSources
    from auralize.pipeline import render as render_heard

    file = render_heard(
        FieldSources(tracks, lead=lead), path, layout="stereo", highpass_hz=HIGHPASS_HZ
    )
    assert file.meta["highpass_hz"] == 20.0 and _rel(on, file.audio) < 1e-5
    # without the lead the first sound would come later: a different signal
    late = render_timbre(tracks, path, timbre="physical", layout="stereo").audio
    assert _rel(on, late) > 0.1
    # --highpass 0: the live blocks keep the swell and equal the unfiltered render
    raw = _live(tracks, n_blocks, highpass_hz=0.0)
    plain = render_timbre(
        tracks, path, timbre="physical", layout="stereo", highpass_hz=0, lead=lead
    ).audio
    assert _rel(raw, plain) < 1e-5
    # ... which is a different sound: mostly the 3 Hz swell the high-pass removes
    assert _rel(raw, off) > 1.0
    assert np.sqrt(np.mean(raw**2)) > 10 * np.sqrt(np.mean(on**2)) > 0


def test_the_highpass_filters_the_sources_not_the_overlays() -> None:
    """An overlay's sound is added unfiltered (as in the viewer's file): with a 5 Hz
    emitter the difference of the blocks with and without it is its own render."""
    tracks = _tracks()
    em = Emitters(
        np.sin(2 * np.pi * 5 * np.arange(44100) / 44100.0)[None],
        44100.0,
        np.array([[0.0, 3.0, 0.0]]),
        name="slow",
    )
    a = _live(tracks, 10)
    b = _live(tracks, 10, extra=Sound([em]))
    ref = render_sound(
        Sound([em]),
        ListenerPath.point(POSE[0], duration=1.0),
        rate=44100,
        layout="stereo",
        duration=0.5,
    ).audio
    assert _rel(b - a, ref) < 1e-9


def test_live_engine_defaults_and_bad_cutoff() -> None:
    tracks = _tracks()
    assert LiveEngine(tracks).highpass_hz == HIGHPASS_HZ == 20.0
    with pytest.raises(
        ParameterError,
        match=r"highpass must be 0 \(off\) or between 0 and "
        r"22050 Hz.*got -1",
    ):
        LiveEngine(tracks, highpass_hz=-1.0)


def test_the_highpass_starts_in_its_steady_state_so_a_sound_already_on_does_not_click() -> None:
    from auralize.emitters.timbre import highpass

    rate = 44100
    t = np.arange(rate // 2) / rate
    tone = 0.01 * np.sin(2 * np.pi * 220.0 * t)
    level = np.array([[3.0], [-1.5]])  # a sound that was on before the output starts
    both = highpass(level + tone, rate, 20.0)
    # linear, from the steady state of the first samples: the constant adds exactly
    # nothing (a filter at rest would start with a step as loud as the constant)
    assert np.max(np.abs(both - highpass(np.vstack([tone, tone]), rate, 20.0))) < 1e-9
    assert np.max(np.abs(highpass(level + 0 * t, rate, 20.0))) < 1e-9
    # one signal (1-D) as one channel
    assert np.max(np.abs(highpass(3.0 + tone, rate, 20.0) - highpass(tone, rate, 20.0))) < 1e-9


def test_a_steady_field_renders_without_a_click_at_the_start() -> None:
    """Sources of constant strength, on before the render starts: their pressure at
    the listener is constant, below any high-pass; the file starts silent (the
    filter at rest turned the constant into a click as loud as the pressure)."""
    tk = np.linspace(0.0, 1.2, 5)
    q = np.ones((2, tk.size))
    tracks = SourceTracks(np.array([[1.0, 0.5, 0.0], [-1.0, 1.0, 0.5]]), q, np.full(2, 0.1), tk)
    path = ListenerPath.point((0.0, 0.0, 0.0), duration=1.0)
    raw = render_timbre(tracks, path, timbre="physical", highpass_hz=0).audio
    level = float(np.mean(np.abs(raw[:, 4410:])))
    assert level > 0 and np.abs(raw[:, 0]).min() > 0.9 * level  # on from the first sample
    out = render_timbre(tracks, path, timbre="physical").audio  # the default 20 Hz high-pass
    assert np.max(np.abs(out)) < 0.02 * level
