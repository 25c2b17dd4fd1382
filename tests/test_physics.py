"""Physics of the synthesis against analytic solutions (monopole dataset, identity mapping)."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.datasets import monopole_pressure
from auralize.emitters import synthesis
from auralize.emitters.synthesis import C0, render_reference, render_tracks
from auralize.listener import ListenerPath

RATE = 44100


def _static(tracks, params, D, duration=0.12, axis=0):  # type: ignore[no-untyped-def]
    offset = np.zeros(3)
    offset[axis] = D
    pos = params.center + offset
    out = render_tracks(tracks, ListenerPath.point(pos, duration=duration), rate=RATE)
    return pos, out.audio[0]


def test_waveform_matches_analytic_point_source(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    pos, p = _static(mono_tracks, mono_params, 2.0)
    t = np.arange(p.size) / RATE
    exact = monopole_pressure(mono_params, pos, t)
    assert np.corrcoef(p, exact)[0, 1] >= 0.99
    # amplitude: each source vertex's ΔV is its share of the source region (a whole
    # voxel inside it), so Σ S ΔV is ∫ S dV and the amplitude is the analytic one
    ratio = np.std(p) / np.std(exact)
    assert ratio == pytest.approx(1.0, rel=0.05)


def test_arrival_delay_is_distance_over_c0(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    D = 3.0
    _, p = _static(mono_tracks, mono_params, D)
    t = np.arange(p.size) / RATE
    # the source term is A'(t); the heard pressure is A'(t - D/c0) / D up to a gain
    lags = np.arange(0, 0.02, 1 / RATE)
    dA = np.gradient(mono_params.signal(t[None, :] - lags[:, None]), axis=1)
    score = dA @ p
    lag = lags[int(np.argmax(score))]
    assert lag == pytest.approx(D / C0, abs=0.5e-3)
    # nothing arrives before D/c0 (minus the blob's radius of ~3 sigma)
    early = t < (D - 3 * mono_params.sigma) / C0
    assert np.max(np.abs(p[early])) < 1e-6 * np.max(np.abs(p))


def test_pressure_halves_when_distance_doubles(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    _, p1 = _static(mono_tracks, mono_params, 1.7, axis=1)
    _, p2 = _static(mono_tracks, mono_params, 3.4, axis=1)
    assert np.std(p1) / np.std(p2) == pytest.approx(2.0, rel=0.05)


def _zero_crossing_frequency(x: np.ndarray, rate: int) -> float:
    s = np.signbit(x)
    idx = np.flatnonzero(s[1:] != s[:-1])
    # linear interpolation of each crossing
    tc = idx + x[idx] / (x[idx] - x[idx + 1])
    return (len(tc) - 1) / 2 / ((tc[-1] - tc[0]) / rate)


def test_moving_listener_hears_doppler_shift(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    v = 25.0
    c = mono_params.center
    start = c + np.array([3.6, 0, 0])
    dur = 0.1
    end = start - np.array([v * dur, 0, 0])
    path = ListenerPath.line(start, end, duration=dur)
    p = render_tracks(mono_tracks, path, rate=RATE).audio[0]
    _, still = _static(mono_tracks, mono_params, 2.5, duration=dur)
    # steady part: after arrival and the fade-in ramp, before the fade-out
    ramp = mono_params.ramp_periods / mono_params.frequency
    win = slice(int((ramp + 0.012) * RATE), int(0.088 * RATE))
    f_move = _zero_crossing_frequency(p[win], RATE)
    f_still = _zero_crossing_frequency(still[win], RATE)
    assert f_still == pytest.approx(mono_params.frequency, rel=0.01)
    assert f_move / f_still == pytest.approx(1 + v / C0, rel=0.01)


@pytest.mark.parametrize("interp", ["linear", "cubic"])
def test_fast_synthesis_equals_sample_by_sample(mono_tracks, mono_params, interp) -> None:  # type: ignore[no-untyped-def]
    c = mono_params.center
    # a curved, accelerating path with turns (orientation changes) and a kink
    t = np.array([0.0, 0.011, 0.025, 0.04])
    pos = c + np.array([[2.5, 0, 0], [2.0, 0.6, 0.1], [1.2, 1.1, -0.2], [1.5, 2.0, 0.3]])
    fwd = np.array([[0, 1, 0], [-1, 1, 0], [-1, 0, 0], [0, -1, 0.2]])
    path = ListenerPath(t, pos, fwd)
    sub = type(mono_tracks)(
        positions=mono_tracks.positions[::7],
        q=mono_tracks.q[::7],
        radius=mono_tracks.radius[::7],
        times=mono_tracks.times,
    )
    for layout in ("mono", "stereo", "ring8"):
        fast = render_tracks(sub, path, rate=RATE, interp=interp, layout=layout).audio
        ref = render_reference(sub, path, rate=RATE, interp=interp, layout=layout)
        assert fast.shape == ref.shape
        err = np.max(np.abs(fast - ref)) / np.max(np.abs(ref))
        # mono is smooth on every piece; the fast path takes panning gains as
        # linear within a piece (<= one data step) and gains have kinks at
        # speaker directions, where it deviates slightly from per-sample gains
        assert err < (2e-4 if layout == "mono" else 5e-3), (layout, err)


@pytest.mark.parametrize("layout", ["mono", "stereo", "ring8", "5.1"])
def test_fast_synthesis_with_dense_captures_and_short_blocks(
    mono_tracks, mono_params, layout
) -> None:  # type: ignore[no-untyped-def]
    # captures every 2 ms (many inside one data step: arrivals beyond the two
    # candidate lines, pieces split at several captures), a turning listener,
    # and output of a few accumulation blocks: every path of the kernel
    c = mono_params.center
    path = ListenerPath.orbit(c, radius=2.2, duration=0.05, turns=0.15, rate_hz=500.0)
    sub = type(mono_tracks)(
        positions=mono_tracks.positions[::5],
        q=mono_tracks.q[::5],
        radius=mono_tracks.radius[::5],
        times=mono_tracks.times,
    )
    fast = render_tracks(sub, path, rate=RATE, layout=layout).audio
    ref = render_reference(sub, path, rate=RATE, layout=layout)
    err = np.max(np.abs(fast - ref)) / np.max(np.abs(ref))
    assert err < (2e-4 if layout == "mono" else 5e-3), (layout, err)
    # the same samples rendered in short pieces join without seams
    n = fast.shape[1]
    parts = [
        render_tracks(
            sub, path, rate=RATE, layout=layout, start=a / RATE, duration=min(700, n - a) / RATE
        ).audio
        for a in range(0, n, 700)
    ]
    joined = np.concatenate(parts, axis=1)
    assert np.max(np.abs(joined - fast)) <= 1e-9 * np.max(np.abs(fast))


def test_static_fast_synthesis_is_exact(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    path = ListenerPath.point(mono_params.center + [0.5, 1.5, 0.2], duration=0.03)
    fast = render_tracks(mono_tracks, path, rate=RATE).audio
    ref = render_reference(mono_tracks, path, rate=RATE)
    assert np.max(np.abs(fast - ref)) / np.max(np.abs(ref)) < 1e-7


def test_time_scale_slows_playback(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    pos = mono_params.center + [2.0, 0, 0]
    a = render_tracks(mono_tracks, ListenerPath.point(pos, duration=0.1), rate=RATE).audio[0]
    b = render_tracks(
        mono_tracks, ListenerPath.point(pos, duration=0.2), rate=RATE, time_scale=2.0
    ).audio[0]
    assert b.size == 2 * a.size
    win = slice(int(0.03 * RATE), int(0.08 * RATE))
    winb = slice(2 * win.start, 2 * win.stop)
    fa = _zero_crossing_frequency(a[win], RATE)
    fb = _zero_crossing_frequency(b[winb], RATE)
    assert fb == pytest.approx(fa / 2, rel=0.01)


def test_listener_inside_a_sphere_is_clamped(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    out = render_tracks(
        mono_tracks, ListenerPath.point(mono_params.center, duration=0.05), rate=RATE
    )
    assert np.all(np.isfinite(out.audio))
    assert np.max(np.abs(out.audio)) > 0


def test_blockwise_rendering_has_no_seams(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    c = mono_params.center
    path = ListenerPath.line(c + [3.0, 0.5, 0], c + [-1.0, 2.0, 0.5], duration=0.09)
    whole = render_tracks(mono_tracks, path, rate=RATE, layout="ring8").audio
    block = 1000
    parts = [
        render_tracks(
            mono_tracks,
            path,
            rate=RATE,
            layout="ring8",
            start=a / RATE,
            duration=min(block, whole.shape[1] - a) / RATE,
        ).audio
        for a in range(0, whole.shape[1], block)
    ]
    joined = np.concatenate(parts, axis=1)
    assert joined.shape == whole.shape
    assert np.max(np.abs(joined - whole)) <= 1e-9 * np.max(np.abs(whole))


@pytest.mark.parametrize("layout", ["mono", "ring8", "5.1"])
def test_blocks_ending_inside_pieces_that_cross_captures_join_without_seams(
    mono_tracks, mono_params, layout
) -> None:  # type: ignore[no-untyped-def]
    # an orbit captured at 20 Hz: a block's end falls inside pieces whose
    # arrivals cross a capture just after it; the block cuts them there, the
    # whole render splits them there: the same samples either way
    c = mono_params.center
    path = ListenerPath.orbit(c, radius=2.5, duration=0.4, turns=0.3)
    whole = render_tracks(mono_tracks, path, rate=16000, layout=layout).audio
    n, block = whole.shape[1], 592
    parts = [
        render_tracks(
            mono_tracks,
            path,
            rate=16000,
            layout=layout,
            start=a / 16000,
            duration=min(block, n - a) / 16000,
        ).audio
        for a in range(0, n, block)
    ]
    joined = np.concatenate(parts, axis=1)
    # (-140 dB: the whole render's running sums carry their rounding over 6400
    # samples, the blocks' over 592; a wrongly cut piece is off by 1e-3)
    assert np.max(np.abs(joined - whole)) <= 1e-7 * np.max(np.abs(whole))


def test_blocks_longer_than_the_accumulation_block_with_time_scale(
    mono_tracks, mono_params
) -> None:  # type: ignore[no-untyped-def]
    # regression: a block starting mid-path whose samples cross the kernel's
    # internal 32768-sample accumulation blocks lost the sample at the boundary
    c = mono_params.center
    path = ListenerPath.orbit(c, radius=2.5, duration=1.6, turns=0.3)
    whole = render_tracks(mono_tracks, path, rate=RATE, time_scale=16.0, layout="ring8").audio
    peak = np.max(np.abs(whole))
    for start in (5948, 8422, 13370, 17081):  # starts at which the boundary fell between samples
        part = render_tracks(
            mono_tracks,
            path,
            rate=RATE,
            time_scale=16.0,
            layout="ring8",
            start=start / RATE,
            duration=40000 / RATE,
        ).audio
        assert np.max(np.abs(part - whole[:, start : start + 40000])) <= 1e-5 * peak, start


@pytest.mark.parametrize(
    ("interp", "layout"),
    [
        ("cubic", "mono"),
        ("linear", "mono"),
        ("cubic", "ambix3"),
        ("linear", "ambix1"),
        ("cubic", "ears"),
    ],
)
def test_runs_of_pieces_sum_to_the_piecewise_kernel(
    mono_tracks, mono_params, interp, layout, monkeypatch
) -> None:  # type: ignore[no-untyped-def]
    # unpanned and AmbiX layouts (the binaural ears too: two receivers of
    # four harmonics each, turning with the listener) sum runs of pieces with
    # one emission per knot (auralize.emitters._kernels.render_runs); the piece-wise
    # kernel sums every piece on its own.  Same signal: on a path captured at
    # 20 Hz (pieces split at captures), from a start inside pieces (restart at
    # the first sample), and over more than one 32768-sample accumulation
    # block (restarts there)
    from auralize.spatial.layouts import synthesis_layout

    lay = synthesis_layout("binaural") if layout == "ears" else layout
    c = mono_params.center
    cases = [
        (ListenerPath.orbit(c, radius=2.5, duration=0.4, turns=0.3), {}),
        (
            ListenerPath.line(c + [3.0, 0.5, 0], c + [-1.0, 2.0, 0.5], duration=0.09),
            {"start": 0.0301, "duration": 0.04},
        ),
        (
            ListenerPath.orbit(c, radius=2.5, duration=1.6, turns=0.3),
            {"time_scale": 16.0, "start": 0.11, "duration": 1.0},
        ),
    ]
    for path, kw in cases:
        monkeypatch.setattr(synthesis, "_BY_RUNS", False)
        pieces = render_tracks(mono_tracks, path, rate=RATE, interp=interp, layout=lay, **kw).audio
        monkeypatch.setattr(synthesis, "_BY_RUNS", True)
        runs = render_tracks(mono_tracks, path, rate=RATE, interp=interp, layout=lay, **kw).audio
        assert runs.shape == pieces.shape
        assert np.max(np.abs(pieces)) > 0.0
        # (rounding: the running sums over a whole 17640-sample render reach
        # ~5e-8 of the peak; a piece summed wrongly is off by 1e-3 or more)
        err = np.max(np.abs(runs - pieces)) / np.max(np.abs(pieces))
        assert err <= 3e-7, (kw, err)
