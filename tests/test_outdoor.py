"""Outdoor propagation: ISO 9613-1 air absorption and the two-ray ground, in the engine."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

from auralize.emitters import C0, Emitters, FieldSources, Sound
from auralize.emitters.engine import BlockRenderer
from auralize.emitters.outdoor import (
    Air,
    Ground,
    air_alpha,
    frame_length,
    mirror_matrix,
    received,
)
from auralize.emitters.synthesis import Rendered
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.rendering import render
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import get_layout, synthesis_layout

RATE = 48000

#: ISO 9613-1:1993 Table 1, α in dB/km at 101.325 kPa, three significant figures,
#: computed at the exact one-third-octave midband frequencies 1000·10^(k/10) Hz
#: (the standard's note to the table): (°C, % RH, nominal Hz, dB/km)
ISO_TABLE_1 = [
    (-20, 10, 50, 0.589),
    (-20, 70, 1000, 11.5),
    (-10, 10, 8000, 14.2),
    (0, 15, 1000, 18.3),
    (10, 10, 125, 0.788),
    (10, 70, 4000, 32.8),
    (15, 70, 4000, 26.4),
    (20, 10, 50, 0.270),
    (20, 100, 50, 0.0403),
    (20, 80, 50, 0.0501),
    (20, 10, 100, 0.622),
    (20, 50, 100, 0.294),
    (20, 100, 100, 0.158),
    (20, 70, 125, 0.339),
    (20, 10, 160, 0.965),
    (20, 70, 160, 0.518),
    (20, 70, 200, 0.776),
    (20, 100, 200, 0.591),
    (20, 10, 1000, 14.1),
    (20, 70, 1000, 4.98),
    (20, 80, 1000, 5.15),
    (20, 100, 1000, 5.42),
    (20, 10, 4000, 109.0),
    (20, 100, 4000, 19.4),
    (20, 15, 6300, 175.0),
    (20, 80, 10000, 105.0),
    (30, 70, 1000, 7.41),
    (30, 10, 4000, 96.0),
    (50, 70, 8000, 80.3),
]
_NOMINAL_K = {
    50: -13,
    100: -10,
    125: -9,
    160: -8,
    200: -7,
    1000: 0,
    4000: 6,
    6300: 8,
    8000: 9,
    10000: 10,
}

#: ISO 9613-2:1996 Table 2 (from ISO 9613-1), α in dB/km at the octave bands
#: 63 … 8000 Hz, rounded to 0.1 dB/km (three figures above 100)
ISO_OCTAVES = {
    (10, 70): (0.1, 0.4, 1.0, 1.9, 3.7, 9.7, 32.8, 117.0),
    (20, 70): (0.1, 0.3, 1.1, 2.8, 5.0, 9.0, 22.9, 76.6),
    (30, 70): (0.1, 0.3, 1.0, 3.1, 7.4, 12.7, 23.1, 59.3),
    (15, 20): (0.3, 0.6, 1.2, 2.7, 8.2, 28.2, 88.8, 202.0),
    (15, 50): (0.1, 0.5, 1.2, 2.2, 4.2, 10.8, 36.2, 129.0),
    (15, 80): (0.1, 0.3, 1.1, 2.4, 4.1, 8.3, 23.7, 82.8),
}


def _last_digit(v: float, figures: int) -> float:
    """One unit of the last printed digit of ``v`` at ``figures`` significant figures."""
    return 10.0 ** (math.floor(math.log10(abs(v))) - figures + 1)


@pytest.mark.parametrize(("T", "rh", "f", "table"), ISO_TABLE_1)
def test_alpha_matches_iso_9613_1_table(T: float, rh: float, f: int, table: float) -> None:
    """Eqs. (3)–(5) give the table to its rounding: within half a unit of its third figure."""
    exact = 1000.0 * 10.0 ** (_NOMINAL_K[f] / 10.0)
    got = 1e3 * float(air_alpha(exact, temperature=T, humidity=rh))
    assert abs(got - table) <= 0.5 * _last_digit(table, 3) * (1 + 1e-6)


@pytest.mark.parametrize(("T", "rh"), list(ISO_OCTAVES))
def test_alpha_matches_iso_9613_2_octave_table(T: float, rh: float) -> None:
    """Within 0.6 of the table's last unit: 47 of its 48 entries within half a unit, the 1 kHz
    entry at 15 °C, 80 % (4.1; Eqs. (3)–(5) give 4.151) 0.051 dB/km off."""
    f = 1000.0 * 10.0 ** (np.arange(-12, 10, 3) / 10.0)  # exact octave midbands 63 … 8000 Hz
    got = 1e3 * air_alpha(f, temperature=T, humidity=rh)
    table = np.array(ISO_OCTAVES[(T, rh)])
    unit = np.where(table >= 100, 1.0, 0.1)
    assert np.all(np.abs(got - table) <= 0.6 * unit)


def test_alpha_follows_pressure_and_classical_limit() -> None:
    # far above both relaxation frequencies α → 8.686 f² (1.84e-11 (p_r/p_a) (T/T0)^½ + …):
    # the classical term dominates and scales as 1/p
    f = 2e6
    lo = float(air_alpha(f, temperature=20, humidity=50, pressure=50.0))
    hi = float(air_alpha(f, temperature=20, humidity=50, pressure=100.0))
    assert lo / hi == pytest.approx(2.0, rel=0.01)
    assert Air().alpha(1000.0) == pytest.approx(4.978e-3, rel=1e-3)


def test_options_are_checked() -> None:
    assert Air.parse("10") == Air(10.0, 70.0, 101.325)
    assert Air.parse(" 25 , 40 , 90 ") == Air(25.0, 40.0, 90.0)
    assert Ground.parse("2,-0.5") == Ground(2.0, -0.5)
    for bad, match in (
        ("x", "not a number"),
        ("1,2,3,4", "T\\[,RH"),
        ("20,120", "humidity"),
        ("20,50,500", "pressure"),
        ("", "T\\[,RH"),
    ):
        with pytest.raises(ParameterError, match=match):
            Air.parse(bad)
    with pytest.raises(ParameterError, match="reflection factor"):
        Ground(0.0, 1.5)
    with pytest.raises(ParameterError, match="H\\[,Q\\]"):
        Ground.parse("1,2,3")
    with pytest.raises(ParameterError, match="Ground or None"):
        render(
            Emitters(np.zeros((1, 10)), RATE, [[0.0, 1, 1]]),
            ListenerPath.point((0, 0, 1), duration=0.01),
            ground="0",
        )


def _multisine(fs: np.ndarray, dur: float, seed: int = 1) -> np.ndarray:
    t = np.arange(int(dur * RATE)) / RATE
    ph = np.random.default_rng(seed).uniform(0, 2 * np.pi, fs.size)
    return np.sin(2 * np.pi * fs[:, None] * t + ph[:, None]).sum(0)


def _amplitudes(x: np.ndarray, fs: np.ndarray, start: float, dur: float) -> np.ndarray:
    """Amplitude of each tone of ``fs`` (integer cycles in ``dur``) in ``x`` from ``start``."""
    i0 = int(round(start * RATE))
    t = np.arange(int(round(dur * RATE))) / RATE
    seg = x[i0 : i0 + t.size]
    return 2.0 * np.abs(np.exp(-2j * np.pi * fs[:, None] * t) @ seg) / t.size


def test_air_absorbs_a_static_path_by_alpha_times_distance() -> None:
    fs = np.arange(250.0, 16001.0, 250.0)
    em = Emitters(_multisine(fs, 1.0)[None], RATE, [[0.0, 300.0, 0.0]])
    path = ListenerPath.point((0, 0, 0), duration=1.0)
    air = Air(15.0, 50.0)
    dry = render(em, path, rate=RATE)
    wet = render(em, path, rate=RATE, air=air)
    got = 20 * np.log10(
        _amplitudes(dry.audio[0], fs, 0.9, 0.08) / _amplitudes(wet.audio[0], fs, 0.9, 0.08)
    )
    want = air.alpha(fs) * 300.0
    assert np.max(want) > 100  # up to 16 kHz the air takes > 100 dB over 300 m
    ok = want < 60  # (deeper, the dry tones' leakage is what the wet ones are measured against)
    assert np.max(np.abs(got[ok] - want[ok])) < 0.05
    assert wet.meta["outdoor"]["air"] == air.describe()
    assert "outdoor" not in dry.meta


def test_air_follows_a_moving_source_at_the_frequency_in_the_air() -> None:
    """A source approaching at Mach 0.1: the attenuation is α(f/(1 − M)) D at the distance
    the sound travelled, not α(f) D."""
    f, v = 8000.0, 0.1 * C0
    dur = 1.0
    t = np.arange(int(dur * RATE)) / RATE
    traj = np.zeros((1, t.size, 3))
    traj[0, :, 1] = 200.0 - v * t
    em = Emitters(np.sin(2 * np.pi * f * t)[None], RATE, traj)
    path = ListenerPath.point((0, 0, 0), duration=dur)
    air = Air(20.0, 70.0)
    dry = render(em, path, rate=RATE).audio[0]
    wet = render(em, path, rate=RATE, air=air).audio[0]
    # around playback second 0.9 the sound left at τ with 200 − vτ = C0 (0.9 − τ)
    tau = (200.0 - C0 * 0.9) / (v - C0)
    D = 200.0 - v * tau
    w = slice(int(0.88 * RATE), int(0.92 * RATE))
    got = 20 * np.log10(np.std(dry[w]) / np.std(wet[w]))
    heard = f / (1 - 0.1)
    assert got == pytest.approx(float(air.alpha(heard)) * D, abs=0.15)
    assert abs(got - float(air.alpha(f)) * D) > 2.0  # the emitted frequency's would be far off


def _two_ray(Q: float, hs: float, hr: float, d: float, f: np.ndarray) -> np.ndarray:
    r1, r2 = math.hypot(d, hr - hs), math.hypot(d, hr + hs)
    return np.abs(1 + Q * r1 / r2 * np.exp(-2j * np.pi * f / C0 * (r2 - r1)))


@pytest.mark.parametrize("Q", [1.0, 0.6, -0.8])
def test_ground_gives_the_two_ray_pattern_over_frequency(Q: float) -> None:
    fs = np.arange(25.0, 4001.0, 25.0)
    hs, hr, d = 2.0, 1.5, 20.0
    em = Emitters(_multisine(fs, 0.6)[None], RATE, [[0.0, 0.0, hs]])
    path = ListenerPath.point((d, 0, hr), duration=0.6)
    dry = _amplitudes(render(em, path, rate=RATE).audio[0], fs, 0.2, 0.4)
    wet = _amplitudes(render(em, path, rate=RATE, ground=Ground(0.0, Q)).audio[0], fs, 0.2, 0.4)
    want = _two_ray(Q, hs, hr, d, fs)
    # within 0.5 % of the direct sound, dips included (the engine reads signals linearly
    # between samples: at 4 kHz and 48 kHz up to 3 % is lost, by the path's fractional delay)
    assert np.max(np.abs(wet / dry - want)) < 5e-3
    ok = want > 0.3
    assert np.max(np.abs(20 * np.log10(wet[ok] / dry[ok] / want[ok]))) < 0.1


def test_ground_dips_where_the_paths_differ_by_half_a_wavelength() -> None:
    """Over a rigid ground the first dip lies at f = c0 / (2 (r2 − r1)), within 5 Hz."""
    hs, hr, d = 3.0, 2.0, 30.0
    r1, r2 = math.hypot(d, hr - hs), math.hypot(d, hr + hs)
    f_dip = C0 / (2 * (r2 - r1))
    fs = np.round(f_dip) + np.arange(-100.0, 101.0, 5.0)
    em = Emitters(_multisine(fs, 0.5, seed=3)[None], RATE, [[0.0, 0.0, hs]])
    path = ListenerPath.point((d, 0, hr), duration=0.5)
    wet = _amplitudes(render(em, path, rate=RATE, ground=Ground(0.0, 1.0)).audio[0], fs, 0.2, 0.2)
    assert abs(fs[np.argmin(wet)] - f_dip) <= 5.0
    assert wet.min() < 0.2 * wet.max()


def test_ground_pattern_over_listener_height_for_a_moving_listener() -> None:
    """A listener rising slowly from 0.2 to 6 m hears a tone's level follow |1 + Q r1/r2 e^(−ikΔ)|
    at its height, the images' Doppler and delays included."""
    f, hs, d, Q = 1000.0, 1.0, 10.0, 0.9
    dur = 3.0
    t = np.arange(int(dur * RATE)) / RATE
    em = Emitters(np.sin(2 * np.pi * f * t)[None], RATE, [[0.0, 0.0, hs]])
    path = ListenerPath.line((d, 0, 0.2), (d, 0, 6.0), duration=dur)
    wet = render(em, path, rate=RATE, ground=Ground(0.0, Q)).audio[0]
    dry = render(em, path, rate=RATE).audio[0]
    win = int(0.01 * RATE)  # 10 ms windows: 10 periods, the listener moves 2 cm
    centres = np.arange(int(0.2 * RATE), t.size - win, win)
    rms = lambda x: np.sqrt(np.mean(x[centres[:, None] + np.arange(win)] ** 2, axis=1))  # noqa: E731
    got = rms(wet) / rms(dry)
    tc = (centres + win / 2) / RATE
    hr = np.interp(tc, path.times, path.positions[:, 2])  # the height where it is heard
    r1, r2 = np.hypot(d, hr - hs), np.hypot(d, hr + hs)
    want = np.abs(1 + Q * r1 / r2 * np.exp(-2j * np.pi * f / C0 * (r2 - r1)))
    ok = want > 0.3
    assert np.max(np.abs(20 * np.log10(got[ok] / want[ok]))) < 0.3
    assert want.min() < 0.3 and got.min() < 0.3  # the dips are heard where predicted


@pytest.mark.parametrize("Q", [1.0, -1.0, 0.5])
def test_a_listener_on_the_ground_hears_one_plus_q(Q: float) -> None:
    """On the plane r1 = r2 and the image arrives with the direct sound: (1 + Q) times it,
    for monopoles and for dipoles of any direction (the image's vertical part reversed)."""
    rng = np.random.default_rng(5)
    n = int(0.2 * RATE)
    mono = rng.normal(size=(2, n))
    dip = rng.normal(size=(2, 3, n))
    pos = np.array([[3.0, 4.0, 2.0], [-2.0, 5.0, 0.7]])
    path = ListenerPath.point((0.5, -1.0, 0.3), duration=0.2)
    g = Ground(0.3, Q)
    for em in (Emitters(mono, RATE, pos), Emitters(dip, RATE, pos)):
        dry = render(em, path, rate=RATE).audio
        wet = render(em, path, rate=RATE, ground=g).audio
        assert np.allclose(wet, (1 + Q) * dry, atol=1e-9 * np.max(np.abs(dry)))


def test_field_sources_get_images_and_air() -> None:
    """The volume's sources: images as more tracks (a listener on a rigid ground hears
    twice the pressure), the air at their mean distance (one source: its distance)."""
    dr = 16000
    T = np.arange(int(0.5 * dr)) / dr
    f = 3000.0
    tr = SourceTracks(
        positions=np.array([[0.0, 0.0, 2.0]]),
        q=np.sin(2 * np.pi * f * T)[None],
        radius=np.full(1, 0.1),
        times=T,
    )
    fs = FieldSources(tr, timbre="physical")
    rate = 32000
    kw: dict[str, Any] = dict(rate=rate, highpass_hz=0.0, duration=0.3)
    on_ground = ListenerPath.point((60.0, 0, 0.0), duration=0.3)
    dry = render(fs, on_ground, **kw).audio[0]
    wet = render(fs, on_ground, ground=Ground(0.0, 1.0), **kw).audio[0]
    w = slice(int(0.22 * rate), int(0.29 * rate))
    assert np.std(wet[w]) / np.std(dry[w]) == pytest.approx(2.0, rel=1e-3)
    air = Air(20.0, 70.0)
    wet = render(fs, on_ground, air=air, **kw).audio[0]
    D = math.hypot(60.0, 2.0)
    got = 20 * np.log10(np.std(dry[w]) / np.std(wet[w]))
    assert got == pytest.approx(float(air.alpha(f)) * D, abs=0.03)


def test_received_filter_joins_ranges_exactly() -> None:
    """Ranges filtered by :func:`received` join into the filter of their union (the frames
    around each range are rendered with it), whatever the range boundaries."""
    rate = 16000
    sig = np.random.default_rng(2).normal(size=(2, rate))

    def run(k: dict[str, Any]) -> Rendered:
        a = int(round(k["start"] * rate))
        n = int(round(k["duration"] * rate))
        out = np.zeros((2, n))
        m = max(0, min(n, rate - a))
        out[:, :m] = sig[:, a : a + m]
        return Rendered(audio=out, rate=rate, layout=get_layout("stereo"), meta={})

    path = ListenerPath.point((0, 0, 0), duration=1.0)
    dist = lambda t: 200.0 + 300.0 * t  # noqa: E731
    kw = dict(rate=rate, start=0.0, duration=1.0)
    whole = received(run, kw, path, Air(), dist).audio
    edges = [0, 777, 1000, 5003, 9000, 16000]
    parts = [
        received(
            run, {**kw, "start": a / rate, "duration": (b - a) / rate}, path, Air(), dist
        ).audio
        for a, b in itertools.pairwise(edges)
    ]
    assert np.allclose(np.concatenate(parts, axis=1), whole, atol=1e-12)
    # the gain is 1 where the air absorbs nothing: distance 0 gives the signal back
    same = received(run, kw, path, Air(), lambda t: np.zeros_like(t)).audio
    assert np.allclose(same, sig, atol=1e-6 * np.max(np.abs(sig)))  # (float32 transforms)
    assert frame_length(rate) == 256


def test_blocks_of_emitters_outdoors_join_into_the_render() -> None:
    n = int(0.4 * RATE)
    t = np.arange(n) / RATE
    traj = np.zeros((1, n, 3))
    traj[0, :, 0] = -30.0 + 40.0 * t
    traj[0, :, 2] = 3.0
    em = Emitters(np.random.default_rng(4).normal(size=(1, n)), RATE, traj)
    path = ListenerPath.line((0, 5, 1), (2, 5, 1.5), duration=0.4)
    kw: dict[str, Any] = dict(rate=RATE, layout="stereo", air=Air(10, 30), ground=Ground(0, 0.7))
    whole = render(em, path, **kw).audio
    br = BlockRenderer(em, path, block=3000, **kw)
    blocks = np.concatenate([br.block(i) for i in range(br.n_blocks)], axis=1)
    assert np.allclose(blocks, whole, atol=1e-9 * np.max(np.abs(whole)))


def test_off_is_the_render_as_it_was() -> None:
    n = int(0.1 * RATE)
    em = Emitters(
        np.random.default_rng(6).normal(size=(2, 3, n)),
        RATE,
        np.array([[1.0, 4.0, 2.0], [-3.0, 2.0, 1.0]]),
    )
    path = ListenerPath.line((0, 0, 1), (1, 0, 1), duration=0.1)
    for lay in ("mono", "ring8", "ambix1"):
        a = render(em, path, rate=RATE, layout=lay)
        b = render(em, path, rate=RATE, layout=lay, air=None, ground=None)
        assert np.array_equal(a.audio, b.audio) and "outdoor" not in b.meta


def test_sources_and_listeners_stay_above_the_ground() -> None:
    em = Emitters(np.zeros((1, 100)), RATE, [[0.0, 5.0, -1.0]])
    with pytest.raises(ParameterError, match="emitter set .* below the ground.*z = -1"):
        render(em, ListenerPath.point((0, 0, 1), duration=0.01), ground=Ground(0.0))
    em = Emitters(np.zeros((1, 100)), RATE, [[0.0, 5.0, 1.0]])
    with pytest.raises(ParameterError, match="listener's path goes below the ground"):
        render(em, ListenerPath.point((0, 0, -2), duration=0.01), ground=Ground(0.0))


# ------------------------------------------------------------------ a model's own parts
@dataclass
class Clicks:
    """A closed-form part as the spark model makes one: clicks of 1/D placed at the arrivals
    the engine gives (:func:`auralize.emitters.events.arrivals`), panned by their gains."""

    positions: np.ndarray
    times: np.ndarray
    name: str = "clicks"
    meta: dict[str, Any] = field(default_factory=dict)

    def render_part(
        self,
        path: ListenerPath,
        *,
        rate: int,
        layout: Any,
        duration: float,
        start: float,
        c0: float,
        backend: str,
    ) -> Rendered:
        from auralize.emitters.events import arrivals

        lay = get_layout(layout)
        a = arrivals(self.positions, self.times, path, c0=c0, layout=lay)
        out = np.zeros((lay.n_channels, int(round(duration * rate))))
        i = np.round((a.time - start) * rate).astype(np.int64)
        ok = (i >= 0) & (i < out.shape[1])
        assert a.gains is not None
        out[:, i[ok]] += a.gains[:, ok] / a.distance[ok]
        return Rendered(audio=out, rate=rate, layout=lay, meta={})


@dataclass
class Wrapped:
    """A part that renders emitters through the engine (as the vortex model's truncation
    and the aero model's windows do)."""

    em: Emitters
    name: str = "wrapped"
    meta: dict[str, Any] = field(default_factory=dict)

    def render_part(self, path: ListenerPath, **kw: Any) -> Rendered:
        from auralize.emitters import render_emitters

        return render_emitters(self.em, path, **kw)


def test_closed_form_image_is_heard_from_below_on_the_same_side() -> None:
    """The ground image of a closed form: rendered for the mirrored listener, mirrored back
    into the listener's frame: it arrives at r2/c0 with Q/r2, from the left and below."""
    src = np.array([[-10.0, 2.0, 4.0]])  # left of a listener facing +y
    part = Clicks(src, np.array([0.01]))
    path = ListenerPath.point((0.0, 0.0, 1.5), duration=0.2)
    Q = 0.8
    r1 = float(np.linalg.norm(src[0] - [0, 0, 1.5]))
    r2 = float(np.linalg.norm(src[0] * [1, 1, -1] - [0, 0, 1.5]))
    for lay in ("stereo", "ambix1"):
        out = render(Sound([part]), path, rate=RATE, layout=lay, ground=Ground(0.0, Q)).audio
        i1, i2 = round((0.01 + r1 / C0) * RATE), round((0.01 + r2 / C0) * RATE)
        gains = np.array(get_layout(lay).directions()) if lay == "stereo" else None
        if lay == "stereo":
            assert gains is not None
            assert out[0, i2] > 0.99 * Q / r2 and abs(out[1, i2]) < 1e-12  # left, as the direct
            assert out[0, i1] == pytest.approx(1 / r1)
        else:  # W, Y (left), Z (up), X (front): the image from the left and below
            w, y, z = out[0, i2], out[1, i2], out[2, i2]
            assert w == pytest.approx(Q / r2)
            assert y > 0 and z < 0 and out[2, i1] > 0
            assert z / w == pytest.approx(-(4.0 + 1.5) / r2, rel=1e-9)
        assert np.count_nonzero(np.abs(out).sum(0)) == 2


def test_closed_form_part_through_the_air_follows_its_arrivals() -> None:
    src = np.array([[0.0, 250.0, 0.0]])
    part = Clicks(src, np.array([0.02]))
    path = ListenerPath.point((0.0, 0.0, 0.0), duration=1.0)
    air = Air(20.0, 70.0)
    dry = render(Sound([part]), path, rate=RATE).audio[0]
    wet = render(Sound([part]), path, rate=RATE, air=air)
    spec = lambda x: np.abs(np.fft.rfft(x))  # noqa: E731
    f = np.fft.rfftfreq(dry.size, 1 / RATE)
    got = 20 * np.log10(spec(dry) / spec(wet.audio[0]))
    sel = (f > 500) & (f < 12000)
    assert np.max(np.abs(got[sel] - air.alpha(f[sel]) * 250.0)) < 0.1
    assert "notes" not in wet.meta["outdoor"]


def test_a_part_rendering_emitters_is_heard_as_its_emitters() -> None:
    """Air and ground reach the emitters a model part renders through the engine: the same
    sound as those emitters heard outdoors directly (the image by the mirrored listener)."""
    n = int(0.3 * RATE)
    em = Emitters(np.random.default_rng(7).normal(size=(1, 3, n)), RATE, [[-6.0, 30.0, 2.5]])
    path = ListenerPath.line((0, 0, 1.2), (1, 0, 1.2), duration=0.3)
    kw: dict[str, Any] = dict(rate=RATE, air=Air(25, 40), ground=Ground(0.0, 0.9))
    for lay in ("mono", "5.1", "ambix2", "binaural"):
        a = render(em, path, layout=lay, **kw).audio
        b = render(Sound([Wrapped(em)]), path, layout=lay, **kw).audio
        assert np.allclose(a, b, atol=2e-4 * np.max(np.abs(a))), lay


def test_mirror_matrices() -> None:
    ring = mirror_matrix(get_layout("ring8"))  # channel k at 45° k: k ↔ 8 − k
    assert np.allclose(ring, np.eye(8)[[0, 7, 6, 5, 4, 3, 2, 1]])
    five = mirror_matrix(get_layout("5.1"))  # FL↔FR, BL↔BR, FC and LFE kept
    assert np.allclose(five, np.eye(6)[[1, 0, 2, 3, 5, 4]])
    amb = mirror_matrix(get_layout("ambix2"))  # W Y Z X V T R S U: Y, V, T odd in azimuth
    assert np.allclose(np.diag(amb), [1, -1, 1, 1, -1, -1, 1, 1, 1])
    ears = mirror_matrix(synthesis_layout("binaural"))
    h = ears.shape[0] // 2
    assert np.allclose(ears[:h, h:], np.eye(h)) and np.allclose(ears[:h, :h], 0)


# ------------------------------------------------------------------ front ends
def _track(f: float = 2000.0, dur: float = 0.4, dr: int = 16000) -> SourceTracks:
    T = np.arange(int(dur * dr)) / dr
    return SourceTracks(
        positions=np.array([[0.0, 0.0, 2.0]]),
        q=np.sin(2 * np.pi * f * T)[None],
        radius=np.full(1, 0.1),
        times=T,
    )


def test_the_dask_render_hears_the_same_outdoors() -> None:
    """On Dask the volume's sources get their images and the air as they do here."""
    from auralize.distributed import Runner

    fs = FieldSources(_track(), timbre="physical")
    path = ListenerPath.line((40.0, 0, 1.0), (40.0, 5.0, 1.0), duration=0.3)
    kw: dict[str, Any] = dict(
        rate=16000,
        layout="stereo",
        highpass_hz=0.0,
        duration=0.3,
        air=Air(20, 50),
        ground=Ground(0.0, 0.7),
    )
    here = render(fs, path, **kw)
    with Runner("threads", workers=2, log=None) as run:
        there = render(fs, path, runner=run, **kw)
    assert np.max(np.abs(there.audio - here.audio)) <= 1e-5 * np.max(np.abs(here.audio))
    assert there.meta["outdoor"] == here.meta["outdoor"]
    plain = render(fs, path, **{k: v for k, v in kw.items() if k not in ("air", "ground")})
    assert not np.allclose(plain.audio, here.audio, rtol=0.05)


def test_cli_render_takes_air_and_ground(tmp_path: Any, capsys: Any) -> None:
    import json

    from auralize.cli import main

    out = tmp_path / "o.wav"
    args = [
        "render",
        "dataset:monopole",
        "--size",
        "16",
        "--steps",
        "40",
        "--listener",
        "1.9,1.9,8",
        "--duration",
        "0.05",
        "-o",
        str(out),
    ]
    assert main([*args, "--air", "10,80", "--ground", "0.2,0.5", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["outdoor"]["air"] == {
        "temperature_c": 10.0,
        "humidity_pct": 80.0,
        "pressure_kpa": 101.325,
    }
    assert rep["outdoor"]["ground"] == {"height_m": 0.2, "reflection": 0.5}
    assert main([*args, "--ground=-1"]) == 0
    assert "outdoors: ground at z = -1 m, reflection factor 1" in capsys.readouterr().out
    assert main([*args, "--ground", "3"]) != 0  # the data's sources reach below 3 m
    assert "below the ground" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main([*args, "--air", "20,150"])
    assert e.value.code == 2 and "humidity must be in 0…100" in capsys.readouterr().err


def test_simple_render_audio_outdoors() -> None:
    from auralize.simple import CreateListenerPath, OpenDataFile, RenderAudio, ResetSession

    ResetSession()
    src = OpenDataFile("dataset:monopole", size=12, steps=60)
    CreateListenerPath("point", at=src.Volume.center + [0, 0, 6.0], duration=0.05)
    dry = RenderAudio(src)
    wet = RenderAudio(src, ground=Ground(-0.5, 1.0), air=Air(20, 70))
    assert wet.meta["outdoor"]["ground"]["height_m"] == -0.5 and "outdoor" not in dry.meta
    assert wet.audio.shape == dry.audio.shape and not np.allclose(wet.audio, dry.audio)
    ResetSession()


def test_continued_renders_outdoors_join_into_the_render() -> None:
    """``render(carry=...)`` stretch by stretch (live listening) hears the same outdoors."""
    from auralize.rendering import Carry

    n = int(0.3 * RATE)
    em = Emitters(
        np.random.default_rng(8).normal(size=(2, n)),
        RATE,
        np.array([[3.0, 40.0, 2.0], [-5.0, 20.0, 6.0]]),
    )
    path = ListenerPath.line((0, 0, 1.5), (1, 0, 1.5), duration=0.3)
    kw: dict[str, Any] = dict(rate=RATE, layout="ring8", air=Air(20, 40), ground=Ground(0, 0.8))
    whole = render(em, path, **kw).audio
    carry = Carry()
    cut = [0, 4000, 9001, n]
    parts = [
        render(em, path, start=a / RATE, duration=(b - a) / RATE, carry=carry, **kw).audio
        for a, b in itertools.pairwise(cut)
    ]
    assert np.allclose(np.concatenate(parts, axis=1), whole, atol=1e-9 * np.max(np.abs(whole)))
