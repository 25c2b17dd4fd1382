"""Synthesis along recorded listener paths (captures every 50-100 ms) against the
sample-by-sample sum: pieces whose arrivals cross captures are split into parts."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters import synthesis
from auralize.emitters.synthesis import render_reference, render_tracks
from auralize.listener import ListenerPath

RATE = 44100


def _sub(tracks, step):  # type: ignore[no-untyped-def]
    return type(tracks)(
        positions=tracks.positions[::step],
        q=tracks.q[::step],
        radius=tracks.radius[::step],
        times=tracks.times,
    )


@pytest.mark.parametrize("layout", ["mono", "ring8", "stereo"])
@pytest.mark.parametrize("rate_hz", [10.0, 20.0])
def test_recorded_path_equals_sample_by_sample(
    mono_tracks, mono_params, layout, rate_hz, monkeypatch
) -> None:  # type: ignore[no-untyped-def]
    # an orbit recorded at 10 or 20 Hz, played 4x slower than the data: most
    # pieces' arrivals cross a capture (the listener's velocity jumps there)
    c = mono_params.center
    path = ListenerPath.orbit(c, radius=2.4, duration=0.6, turns=0.4, height=0.5, rate_hz=rate_hz)
    sub = _sub(mono_tracks, 5)
    ref = render_reference(sub, path, rate=RATE, layout=layout, time_scale=4.0)
    # (mono: the default choice, and each kernel forced: runs of pieces, or
    # the piece-wise kernel that splits pieces into parts)
    for by_runs in (None, True, False) if layout == "mono" else (None,):
        monkeypatch.setattr(synthesis, "_BY_RUNS", by_runs)
        fast = render_tracks(sub, path, rate=RATE, layout=layout, time_scale=4.0).audio
        assert fast.shape == ref.shape
        err = np.max(np.abs(fast - ref)) / np.max(np.abs(ref))
        assert err < (2e-4 if layout == "mono" else 5e-3), (layout, by_runs, err)
    # steps that cross too many captures keep the scalar split (here: all of them)
    monkeypatch.setattr(synthesis, "_BY_RUNS", False)
    monkeypatch.setattr(synthesis, "_MAX_PART_CAPTURES", 0)
    scalar = render_tracks(sub, path, rate=RATE, layout=layout, time_scale=4.0).audio
    assert np.max(np.abs(scalar - ref)) / np.max(np.abs(ref)) < (2e-4 if layout == "mono" else 5e-3)
    # (parts and the scalar split differ by rounding and by panning gains
    # taken at the same instants: the same signal)
    assert np.max(np.abs(scalar - fast)) <= 1e-6 * np.max(np.abs(ref))


def test_recorded_path_blocks_join_without_seams(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    # block-wise rendering splits the parts at the same captures as the whole render
    c = mono_params.center
    path = ListenerPath.orbit(c, radius=2.4, duration=0.6, turns=0.4, rate_hz=10.0)
    sub = _sub(mono_tracks, 3)
    whole = render_tracks(sub, path, rate=16000, layout="ring8", time_scale=4.0).audio
    n, block = whole.shape[1], 1111
    parts = [
        render_tracks(
            sub,
            path,
            rate=16000,
            layout="ring8",
            time_scale=4.0,
            start=a / 16000,
            duration=min(block, n - a) / 16000,
        ).audio
        for a in range(0, n, block)
    ]
    joined = np.concatenate(parts, axis=1)
    assert np.max(np.abs(joined - whole)) <= 1e-7 * np.max(np.abs(whole))
