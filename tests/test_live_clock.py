"""Live listening places its clock as a render does: each loop starts when the first
sound can reach the camera, so a listener a kilometre away hears the data at once,
and when nothing can be heard the engine says why in words."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters.synthesis import C0, box_distances, source_extent
from auralize.emitters.timbre import render_timbre
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.scene.listening import LiveEngine
from auralize.sources import SourceTracks

FAR = np.array([1000.0, 0.0, 0.0])
POSE = (FAR, np.array([-1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))


def _tracks(span: float = 0.6) -> SourceTracks:
    """Two sources in a 2 m box, a 150 Hz tone swelling over ``span`` data seconds."""
    fk = 4000.0
    t = np.arange(int(span * fk)) / fk
    q = np.stack(
        [
            np.sin(2 * np.pi * 150 * t) * np.sin(np.pi * t / span),
            0.5 * np.sin(2 * np.pi * 150 * t + 1.0),
        ]
    )
    return SourceTracks(np.array([[1.0, 0.5, 0.0], [-1.0, -0.5, 0.5]]), q, np.full(2, 0.1), t)


def test_a_kilometre_away_the_first_block_is_heard_and_equals_the_render() -> None:
    tracks = _tracks()
    eng = LiveEngine(tracks, layout="stereo", block=2205, loop=False)
    eng.set_pose(*POSE)
    first = eng.next_block()
    # sound takes 2.9 s to come 1 km, five times the data's 0.6 s: without the lead the
    # whole loop would be silent; with it the first 50 ms block already holds the tone
    assert np.sqrt(np.mean(first**2)) > 0.05 * np.max(np.abs(first)) > 0
    lo, hi, _ = source_extent(tracks)
    near = float(box_distances(FAR[None], lo, hi)[0][0])
    assert eng.lead == pytest.approx(near / C0, rel=1e-12) and eng.lead > 2.8
    blocks = [first] + [eng.next_block() for _ in range(9)]
    on = np.concatenate(blocks, axis=1)
    path = ListenerPath.point(FAR, duration=0.5, forward=tuple(POSE[1]))
    off = render_timbre(tracks, path, timbre="physical", layout="stereo", lead=eng.lead).audio
    assert on.shape == off.shape
    assert np.max(np.abs(on - off)) <= 1e-6 * np.max(np.abs(off))  # (the blockwise high-pass)
    assert "the data are 999 m away: sound takes 2.91 s" in eng.describe_distance()
    assert eng.why_silent() is None


def test_each_loop_lasts_the_data_plus_the_spread_of_arrivals() -> None:
    tracks = _tracks()
    eng = LiveEngine(tracks, layout="mono", block=1024)
    eng.set_pose(*POSE)
    eng.next_block()
    lo, hi, _ = source_extent(tracks)
    near, far = (float(d[0]) for d in box_distances(FAR[None], lo, hi))
    assert eng.span_s == pytest.approx(tracks.t_last - tracks.t_first + (far - near) / C0)


def test_a_fixed_lead_is_kept_and_a_bad_one_refused() -> None:
    eng = LiveEngine(_tracks(), layout="mono", lead=0.0)
    eng.set_pose(*POSE)
    eng.next_block()
    assert eng.lead == 0.0 and "skipped" not in eng.describe_distance()
    with pytest.raises(ParameterError, match="lead must be 'auto' or data seconds >= 0"):
        LiveEngine(_tracks(), lead=-1.0)


def test_silence_is_explained() -> None:
    tracks = _tracks()
    none = SourceTracks(
        np.zeros((0, 3)), np.zeros((0, tracks.times.size)), np.zeros(0), tracks.times
    )
    assert "no sources" in (LiveEngine(none).why_silent() or "")
    held = SourceTracks(tracks.positions, np.ones_like(tracks.q), tracks.radius, tracks.times)
    assert "field is steady" in (LiveEngine(held).why_silent() or "")
    # the whole field with its steady part removed: every strength is zero
    steady = SourceTracks(tracks.positions, np.zeros_like(tracks.q), tracks.radius, tracks.times)
    eng = LiveEngine(steady, layout="mono")
    assert "field is steady" in (eng.why_silent() or "")
    eng.set_pose(*POSE)
    assert not np.any(eng.next_block())  # ... and it is indeed silent
