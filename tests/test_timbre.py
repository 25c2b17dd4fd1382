"""A listener outside the grid, and the timbres: delay D/c0, 1/D, Doppler, carriers, high-pass.

The compact pulsating source is the ``monopole`` dataset (a Gaussian blob,
σ = 0.3 m, 150 Hz, in a 7.75 m grid); the listener is 17 m and 34 m away,
far outside the grid.
"""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters import timbre
from auralize.emitters.synthesis import C0, check_arrival, render_tracks
from auralize.emitters.timbre import (
    TONAL_CARRIERS,
    highpass,
    loudness,
    merge_size,
    merged,
    near_path,
    render_timbre,
)
from auralize.errors import ListenerPathError, ParameterError
from auralize.listener import ListenerPath
from auralize.sources import SourceTracks

RATE = 44100


def _at(params, D, duration):  # type: ignore[no-untyped-def]
    return ListenerPath.point(params.center + np.array([D, 0.0, 0.0]), duration=duration)


def _envelope(x: np.ndarray, ms: float = 1.0) -> np.ndarray:
    k = max(int(ms * 1e-3 * RATE), 1)
    return np.convolve(np.abs(x), np.ones(k) / k, mode="same")


def _lag(a: np.ndarray, b: np.ndarray) -> float:
    """Delay of b after a (s) by cross-correlating their envelopes."""
    ea, eb = _envelope(a), _envelope(b)
    ea, eb = ea - ea.mean(), eb - eb.mean()
    xc = np.correlate(eb, ea, mode="full")
    return (int(np.argmax(xc)) - (ea.size - 1)) / RATE


def test_far_listener_delay_and_distance_law(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    outs = {}
    for D in (17.0, 34.0):
        p = render_timbre(mono_tracks, _at(mono_params, D, 0.25), rate=RATE).audio[0]
        t = np.arange(p.size) / RATE
        # the source term is A'(t); the heard pressure is A'(t - D/c0) / D
        lags = np.arange(0.0, 0.15, 1 / RATE)
        dA = np.gradient(mono_params.signal(t[None, :] - lags[:, None]), axis=1)
        assert lags[int(np.argmax(dA @ p))] == pytest.approx(D / C0, abs=0.5e-3)
        early = t < (D - 3 * mono_params.sigma) / C0
        assert np.max(np.abs(p[early])) < 1e-6 * np.max(np.abs(p))
        outs[D] = p
    assert np.std(outs[17.0]) / np.std(outs[34.0]) == pytest.approx(2.0, rel=0.05)


def _zero_crossing_frequency(x: np.ndarray) -> float:
    s = np.signbit(x)
    idx = np.flatnonzero(s[1:] != s[:-1])
    tc = idx + x[idx] / (x[idx] - x[idx + 1])
    return (len(tc) - 1) / 2 / ((tc[-1] - tc[0]) / RATE)


def test_listener_flying_at_60_m_per_s_hears_doppler(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    v, x0, dur = 60.0, 20.0, 0.2
    c = mono_params.center
    path = ListenerPath.line(c + [x0, 0, 0], c + [x0 - v * dur, 0, 0], duration=dur)
    p = render_timbre(mono_tracks, path, rate=RATE, timbre="physical").audio[0]
    still = render_timbre(mono_tracks, _at(mono_params, x0, dur), rate=RATE).audio[0]
    # steady emission (after the fade-in ramp, before the fade-out): tau in [15, 85] ms
    # arrives at t = (tau + x0/c0) / (1 + v/c0) moving, tau + x0/c0 still
    moving = slice(
        int((0.015 + x0 / C0) / (1 + v / C0) * RATE) + 20,
        int((0.085 + x0 / C0) / (1 + v / C0) * RATE),
    )
    fixed = slice(int((0.015 + x0 / C0) * RATE) + 20, int((0.085 + x0 / C0) * RATE))
    f_move, f_still = _zero_crossing_frequency(p[moving]), _zero_crossing_frequency(still[fixed])
    assert f_still == pytest.approx(mono_params.frequency, rel=0.01)
    assert f_move / f_still == pytest.approx(1 + v / C0, rel=0.01)


@pytest.mark.parametrize("timbre", ["extended", "tonal"])
def test_timbres_keep_arrival_time_and_distance_law(mono_tracks, mono_params, timbre) -> None:  # type: ignore[no-untyped-def]
    outs = {}
    for D in (17.0, 34.0):
        out = render_timbre(mono_tracks, _at(mono_params, D, 0.25), rate=RATE, timbre=timbre)
        p = out.audio[0]
        t = np.arange(p.size) / RATE
        early = t < (D - 3 * mono_params.sigma) / C0
        assert np.max(np.abs(p[early])) < 1e-6 * np.max(np.abs(p))
        # the sound sits where the physical one does: energy-weighted times agree
        # (with a tone for the monopoles' noise band, whose local power fluctuates)
        tone = render_timbre(
            mono_tracks,
            _at(mono_params, D, 0.25),
            rate=RATE,
            timbre=timbre,
            carriers={"monopole": ("tone", 300.0)},
        ).audio[0]
        phys = render_tracks(mono_tracks, _at(mono_params, D, 0.25), rate=RATE).audio[0]
        t_mean = np.sum(t * tone**2) / np.sum(tone**2)
        t_phys = np.sum(t * phys**2) / np.sum(phys**2)
        assert t_mean == pytest.approx(t_phys, abs=1e-3)  # (filters: ~0.3 ms group delay)
        outs[D] = p
    assert _lag(outs[17.0], outs[34.0]) == pytest.approx(17.0 / C0, abs=0.5e-3)
    assert np.std(outs[17.0]) / np.std(outs[34.0]) == pytest.approx(2.0, rel=0.05)
    # audible: the data's 3 kHz frames put the physical sound at 150 Hz already,
    # and the extension adds noise above 1.5 kHz
    assert loudness(outs[17.0][None], RATE)["share_above"] > 0.9


@pytest.mark.parametrize("timbre", ["extended", "tonal"])
def test_timbres_are_deterministic_with_a_seed(timbre) -> None:  # type: ignore[no-untyped-def]
    # slow data (20 steps per second): the extension is most of the sound
    tr, path = _typed_tracks(), ListenerPath.point([0.0, 0.0, 30.0], duration=2.0)
    a = render_timbre(tr, path, rate=RATE, timbre=timbre, seed=3).audio
    b = render_timbre(tr, path, rate=RATE, timbre=timbre, seed=3).audio
    c = render_timbre(tr, path, rate=RATE, timbre=timbre, seed=4).audio
    assert np.array_equal(a, b)
    assert np.max(np.abs(a - c)) > 0.1 * np.max(np.abs(a))


def _typed_tracks(steps: int = 40, dt: float = 0.05) -> SourceTracks:
    """Three sources, one of each type, changing over the data (strengths of very
    different size: the tonal timbre balances types)."""
    q = np.zeros((3, steps))
    wobble = 1.0 + 0.5 * np.sin(2 * np.pi * 2.0 * np.arange(steps - 4) * dt)
    q[:, 2:-2] = np.array([[1e-3], [1.0], [50.0]]) * wobble
    kind = np.zeros((3, steps), dtype=np.int8)
    kind[:, 2:-2] = np.array([[1], [2], [3]])
    pos = np.array([[5.0, 0, 0], [0, 5.0, 0], [-5.0, 0, 0]])
    return SourceTracks(
        positions=pos, q=q, radius=np.full(3, 0.1), times=np.arange(steps) * dt, kind=kind
    )


def test_tonal_carriers_per_type_appear_in_the_spectrum() -> None:
    tr = _typed_tracks()
    path = ListenerPath.point([0.0, 0.0, 30.0], duration=2.0)
    out = render_timbre(tr, path, rate=RATE, timbre="tonal", layout="mono")
    x = out.audio[0, int(0.5 * RATE) : int(1.5 * RATE)]
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size))) ** 2
    f = np.fft.rfftfreq(x.size, 1 / RATE)

    def band(lo: float, hi: float) -> float:
        return float(spec[(f >= lo) & (f <= hi)].sum())

    total = float(spec.sum())
    _, lo_m, hi_m = TONAL_CARRIERS["monopole"]
    f_d, f_q = TONAL_CARRIERS["dipole"][1], TONAL_CARRIERS["quadrupole"][1]
    # each type is heard: its carrier holds a fair share of the energy
    # (the carriers follow the strengths' 2 Hz wobble: sidebands within ±15 Hz)
    shares = [
        band(lo_m - 15, hi_m + 15) / total,
        band(f_d - 15, f_d + 15) / total,
        band(f_q - 15, f_q + 15) / total,
    ]
    assert min(shares) > 0.15 and sum(shares) > 0.97
    # the tones are spectral peaks at their frequencies
    for fc in (f_d, f_q):
        near = (f > fc - 30) & (f < fc + 30)
        assert f[near][np.argmax(spec[near])] == pytest.approx(fc, abs=1.5)
    assert out.meta["carriers"]["dipole"] == ["tone", f_d]


def test_tonal_needs_source_types() -> None:
    tr = _typed_tracks()
    tr = SourceTracks(tr.positions, tr.q, tr.radius, tr.times)
    with pytest.raises(ParameterError, match="source types"):
        render_timbre(tr, ListenerPath.point([0, 0, 30.0], duration=0.1), timbre="tonal")


def test_highpass_removes_dc() -> None:
    tr = _typed_tracks()
    steady_q = np.where(tr.q != 0, np.array([[1e-3], [1.0], [50.0]]), 0.0)  # constant strengths
    tr = SourceTracks(tr.positions, steady_q, tr.radius, tr.times, kind=tr.kind)
    path = ListenerPath.point([0.0, 0.0, 30.0], duration=2.0)
    raw = render_timbre(tr, path, rate=8000, highpass_hz=0).audio[0]
    hp = render_timbre(tr, path, rate=8000).audio[0]  # default 20 Hz
    steady = slice(int(0.6 * 8000), int(1.6 * 8000))
    assert abs(np.mean(raw[steady])) > 0.9 * np.max(np.abs(raw))  # a constant pressure
    assert abs(np.mean(hp[steady])) < 1e-3 * np.max(np.abs(raw))
    with pytest.raises(ParameterError, match="highpass"):
        highpass(np.zeros((1, 10)), 8000, 5000.0)


def test_nonsense_listeners_are_clear_errors(mono_tracks, mono_params) -> None:  # type: ignore[no-untyped-def]
    bounds = (0.0, 7.75, 0.0, 7.75, 0.0, 7.75)
    with pytest.raises(ListenerPathError, match="within"):
        render_tracks(mono_tracks, _at(mono_params, 1e9, 0.1), rate=8000, bounds=bounds)
    # 1 km away: sound arrives after 2.9 s; a 0.1 s render hears nothing
    with pytest.raises(ListenerPathError, match="nothing can be heard"):
        check_arrival(mono_tracks, _at(mono_params, 1000.0, 0.1), time_scale=1.0)
    check_arrival(mono_tracks, _at(mono_params, 17.0, 0.1), time_scale=1.0)


@pytest.mark.parametrize("timbre", ["extended", "tonal"])
def test_timbres_keep_panning(timbre) -> None:  # type: ignore[no-untyped-def]
    """A source on the listener's left (ring8 channel 2) stays there."""
    tr = _typed_tracks()
    keep = np.array([False, True, False])  # the dipole at +y ...
    tr = SourceTracks(
        positions=np.array([[-5.0, 0.0, 0.0]]),
        q=tr.q[keep],
        radius=tr.radius[keep],
        times=tr.times,
        kind=tr.kind[keep],
    )  # ... moved to the left
    out = render_timbre(
        tr,
        ListenerPath.point([0.0, 0.0, 0.0], duration=2.0),
        rate=8000,
        timbre=timbre,
        layout="ring8",
    )
    e = np.sum(out.audio**2, axis=1)
    assert np.argmax(e) == 2 and e[2] / e.sum() > 0.99


def _cloud(n: int = 600, steps: int = 24, dt: float = 0.05) -> SourceTracks:
    """``n`` sources on a 0.25 m lattice in a 3 m box, strengths of both signs
    switching on and off at random (slow data: the timbres' envelopes change
    once per 50 ms step, while sound crosses the box in 9 ms)."""
    rng = np.random.default_rng(1)
    pos = rng.integers(0, 12, size=(n, 3)) * 0.25
    pos = np.unique(pos, axis=0)
    q = rng.normal(size=(pos.shape[0], steps)) * (rng.random((pos.shape[0], steps)) < 0.4)
    kind = np.where(q != 0, rng.integers(1, 4, size=q.shape), 0).astype(np.int8)
    return SourceTracks(
        positions=pos,
        q=q,
        radius=np.full(pos.shape[0], 0.1),
        times=np.arange(steps) * dt,
        kind=kind,
    )


def test_merged_sources_keep_the_sum_and_the_centroid() -> None:
    tr = _cloud()
    tr = SourceTracks(tr.positions, np.abs(tr.q), tr.radius, tr.times)
    size = merge_size(tr)
    assert size == pytest.approx(timbre.MERGE * C0 * 0.05)
    m = merged(tr, size)
    assert 0 < m.n_sources < tr.n_sources / 2
    assert np.allclose(m.q.sum(axis=0), tr.q.sum(axis=0))
    # the |q|-weighted centroid of all sources is kept
    w, wm = tr.q.sum(axis=1), m.q.sum(axis=1)
    assert np.allclose(wm @ m.positions / wm.sum(), w @ tr.positions / w.sum(), atol=1e-12)
    # one source per occupied cube, inside it
    lo = tr.positions.min(axis=0)
    cubes = np.unique(np.floor((tr.positions - lo) / size), axis=0)
    mine = np.floor((m.positions - lo) / size)
    assert np.array_equal(np.unique(mine, axis=0), cubes) and mine.shape[0] == cubes.shape[0]
    # sources farther apart than the cube are left alone (the tracks themselves)
    assert merged(tr, 0.2) is tr


@pytest.mark.parametrize("timbre_name", ["extended", "tonal"])
def test_merging_changes_the_timbres_little(timbre_name, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Envelopes from merged sources (cubes of 0.54 m here) stay within 2 % of
    the unmerged render in every loudspeaker; near the listener nothing merges."""
    tr = _cloud()
    kw = dict(rate=8000, timbre=timbre_name, layout="ring8", seed=2)
    far = ListenerPath.line([20.0, -6.0, 1.0], [20.0, 6.0, 1.0], duration=1.0)
    through = ListenerPath.line([1.5, -4.0, 1.0], [1.5, 4.0, 1.0], duration=1.0)
    fast = [render_timbre(tr, p, **kw).audio for p in (far, through)]
    monkeypatch.setattr(timbre, "MERGE", 0.0)
    exact = [render_timbre(tr, p, **kw).audio for p in (far, through)]
    a, b = fast[0], exact[0]
    assert not np.array_equal(a, b)
    # per loudspeaker, relative to the loudest one: panning and levels kept
    err = np.sqrt(np.mean((a - b) ** 2, axis=1)) / np.sqrt(np.max(np.mean(b**2, axis=1)))
    assert np.max(err) < 0.02
    assert np.array_equal(fast[1], exact[1])


def test_near_path_finds_the_points_near_the_listeners_polyline() -> None:
    path = ListenerPath.line([0.0, 0.0, 0.0], [10.0, 0.0, 0.0], duration=1.0)
    # beside the middle of the path, beyond its end, and off its corner
    pts = np.array(
        [
            [5.0, 0.9, 0.0],
            [5.0, 0.0, 1.2],
            [10.9, 0.0, 0.0],
            [11.5, 0.0, 0.0],
            [-0.6, 0.6, 0.0],
            [-0.8, 0.8, 0.0],
        ]
    )
    assert near_path(pts, path, 1.0).tolist() == [True, False, True, False, True, False]
    point = ListenerPath.point([0.0, 0.0, 0.0], duration=1.0)
    assert near_path(pts[4:], point, 1.0).tolist() == [True, False]


def test_change_tracks_are_zero_where_nothing_changes() -> None:
    """The drive of ``extended`` and ``tonal``: the change per step of each strength,
    0 over steady stretches, so that a steady field adds nothing, whatever the
    listener does; tracks held before and after their data have no change there."""
    from auralize.emitters.timbre import change_tracks

    q = np.array([[0.0, 1.0, 2.0, 2.0, 2.0, 2.0]])
    tr = SourceTracks(np.zeros((1, 3)), q, np.ones(1), np.arange(6.0))
    np.testing.assert_allclose(change_tracks(tr).q, [[0.5, 1.0, 0.5, 0.0, 0.0, -1.0]])
    held = SourceTracks(np.zeros((1, 3)), q, np.ones(1), np.arange(6.0) - 2.0, origin=0.0)
    np.testing.assert_allclose(change_tracks(held).q, [[0.5, 1.0, 0.5, 0.0, 0.0, 0.0]])


def test_tonal_without_sources_is_silence_not_a_type_error() -> None:
    """Data where no sources were found renders ``tonal`` as silence of the stated length
    (the command then reports a silent output), not a complaint about source types."""
    from auralize.emitters.timbre import render_timbre
    from auralize.listener import ListenerPath
    from auralize.sources import SourceTracks

    empty = SourceTracks(
        positions=np.zeros((0, 3)),
        q=np.zeros((0, 5)),
        radius=np.zeros(0),
        times=np.linspace(0.0, 0.4, 5),
    )
    out = render_timbre(
        empty,
        ListenerPath.point((1.0, 0.0, 0.0), duration=0.5),
        timbre="tonal",
        rate=8000,
        layout="ring8",
    )
    assert out.audio.shape == (8, 4000)
    assert not np.any(out.audio)
