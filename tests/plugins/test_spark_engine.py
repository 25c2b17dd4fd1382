"""Spark through the sound engine: arrival D/c0, the Eq. 3–4 distance law, Doppler, 3-D panning."""

from __future__ import annotations

import math

import numpy as np
import pytest
from auralize_spark import Discharge, SparkSound, WaveParams
from auralize_spark.waves import DischargePart

from auralize.emitters import Sound, render_sound
from auralize.listener import ListenerPath
from auralize.spatial import Speaker, make_layout

C = 343.0
SIGMA0 = 0.524
PARAMS = WaveParams(r0=0.05, T0=30e-6, ps0=500.0, jitter=0.0)


def segment(center=(0.0, 0.0, 0.0), axis: int = 0, hl: float = 1e-3) -> Discharge:  # type: ignore[no-untyped-def]
    c = np.asarray(center, dtype=np.float64)
    d = np.zeros(3)
    d[axis] = hl
    return Discharge(np.stack([c - d, c + d]), [-1, 0], [True, True])


def lobes(x: np.ndarray, rate: int) -> tuple[float, float, float]:
    """Positive and negative lobe areas (Pa s) and the zero crossing time (s) of one N-wave."""
    nz = np.flatnonzero(np.abs(x) > 1e-9 * np.abs(x).max())
    cross = nz[0] + np.flatnonzero(x[nz[0] :] < 0)[0]
    return x[x > 0].sum() / rate, x[x < 0].sum() / rate, (cross - 0.5) / rate


def test_engine_render_arrives_at_d_over_c0_in_the_render_window() -> None:
    """A stroke at t0 reaches a listener at D after t0 + D/c0, wherever the output window starts."""
    rate, D, t0 = 384_000, 6.86, 0.013
    part = DischargePart(segment(), PARAMS, np.zeros(1), t0=t0)
    path = ListenerPath.point((0.0, D, 0.0), duration=0.2)
    for start in (0.0, 0.0125):
        out = render_sound(Sound([part]), path, rate=rate, start=start, duration=0.05).audio[0]
        _, _, t_cross = lobes(out, rate)
        assert start + t_cross == pytest.approx(t0 + D / C, abs=1.5 / rate)


def test_amplitude_follows_eq3_and_impulse_falls_as_one_over_d() -> None:
    """Broadside N-wave: peak p_s(D) of Eq. 3; lobe area p_s T / 2 = r0 p_s0 T0 / (2 D) exactly 1/D.

    The WM-wave's amplitude law is the model's own (Eqs. 3–4, weak-shock
    N-waves, Wright 1983), not 1/D: the peak falls faster than 1/D by
    √(1 + σ0 ln(D/r0)) while the duration grows by the same factor, so the
    impulse of each lobe falls exactly as 1/D.
    """
    rate = 768_000
    snd = Sound([DischargePart(segment(), PARAMS)])
    areas = {}
    for D in (0.5, 2.0, 8.0):
        path = ListenerPath.point((0.0, D, 0.0), duration=D / C + 0.002)
        out = render_sound(snd, path, rate=rate, c0=C).audio[0]
        pos, neg, _ = lobes(out, rate)
        k = math.sqrt(1 + SIGMA0 * math.log(D / PARAMS.r0))
        ps = PARAMS.r0 * PARAMS.ps0 / (D * k)
        assert out.max() == pytest.approx(ps, rel=0.05)
        assert pos == pytest.approx(ps * PARAMS.T0 * k / 2, rel=0.01)
        assert neg == pytest.approx(-pos, rel=1e-6)
        areas[D] = pos
    assert areas[0.5] / areas[2.0] == pytest.approx(4.0, rel=0.01)
    assert areas[2.0] / areas[8.0] == pytest.approx(4.0, rel=0.01)


def test_moving_listener_hears_doppler() -> None:
    """Listener approaching at v: stroke spacing and N-wave duration shrink by c0/(c0 + v)."""
    rate, v = 768_000, 40.0
    strokes = np.array([0.0, 0.02])
    part = DischargePart(segment(), PARAMS, strokes)
    # starts 10 m away on the segment's normal and walks towards it
    path = ListenerPath(
        np.array([0.0, 0.2]), np.array([[0.0, 10.0, 0.0], [0.0, 10.0 - 0.2 * v, 0.0]])
    )
    out = render_sound(Sound([part]), path, rate=rate, duration=0.06).audio[0]
    static = render_sound(
        Sound([part]), ListenerPath.point((0.0, 10.0, 0.0), duration=0.06), rate=rate
    ).audio[0]
    f = C / (C + v)
    # arrivals: t = (c0 τ + X0) / (c0 + v)
    half = int(0.04 * rate)
    _, _, t1 = lobes(out[:half], rate)
    _, _, t2 = lobes(out[half:], rate)
    t2 += half / rate
    assert t1 == pytest.approx(10.0 / (C + v), abs=1.5 / rate)
    assert t2 - t1 == pytest.approx(0.02 * f, abs=2 / rate)
    # the wave itself is compressed: same peak pressure region, duration × f, impulse × f
    pos_m, _, _ = lobes(out[:half], rate)
    D1 = 10.0 - v * t1
    k = math.sqrt(1 + SIGMA0 * math.log(D1 / PARAMS.r0))
    ps = PARAMS.r0 * PARAMS.ps0 / (D1 * k)
    assert pos_m == pytest.approx(ps * PARAMS.T0 * k / 2 * f, rel=0.02)
    width = np.ptp(np.flatnonzero(np.abs(out[:half]) > 1e-9 * np.abs(out).max())) / rate
    width_static = (
        np.ptp(np.flatnonzero(np.abs(static[:half]) > 1e-9 * np.abs(static).max())) / rate
    )
    D_ratio = math.sqrt(1 + SIGMA0 * math.log(D1 / PARAMS.r0)) / math.sqrt(
        1 + SIGMA0 * math.log(10.0 / PARAMS.r0)
    )
    assert width / width_static == pytest.approx(f * D_ratio, rel=0.02)


def dome():  # type: ignore[no-untyped-def]
    spk = [Speaker(f"S{k}", 45.0 * k) for k in range(8)]
    spk += [Speaker(f"H{k}", 90.0 * k + 45.0, 45.0) for k in range(4)]
    return make_layout("dome", spk)


def test_discharge_above_the_listener_goes_to_the_height_speakers() -> None:
    """3-D VBAP: a spark straight overhead sounds on the four height speakers only; one at
    azimuth 45°, elevation 45° on speaker H0; the mono sum of the dome's power equals mono."""
    lay = dome()
    rate = 96_000
    over = Sound([DischargePart(segment((0.0, 0.0, 5.0)), PARAMS)])
    path = ListenerPath.point((0.0, 0.0, 0.0), duration=0.02, forward=(1.0, 0.0, 0.0))
    e = (render_sound(over, path, rate=rate, layout=lay).audio ** 2).sum(axis=1)
    assert e[8:].sum() > (1 - 1e-12) * e.sum()
    np.testing.assert_allclose(e[8:] / e[8:].sum(), 0.25, atol=1e-9)
    d = np.array([0.5, 0.5, math.sqrt(0.5)])  # azimuth 45°, elevation 45° for a listener facing +x
    h0 = Sound([DischargePart(segment(tuple(4.0 * d), axis=2), PARAMS)])
    out = render_sound(h0, path, rate=rate, layout=lay).audio
    e = (out**2).sum(axis=1)
    assert e[8] > 0.999 * e.sum()
    mono = render_sound(h0, path, rate=rate).audio[0]
    np.testing.assert_allclose(
        np.sqrt((out**2).sum(axis=0)), np.abs(mono), atol=1e-9 * np.abs(mono).max()
    )


def test_model_sound_renders_like_the_cli_and_is_listener_free(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """SparkSound.synthesize gives the discharge once; any path and layout render it."""
    from auralize.audio import read_wav
    from auralize.cli import main

    snd = SparkSound().synthesize(None, preset="spark-balls", seed=4, strokes=2)
    part = snd.parts[0]
    assert snd.meta["strokes"] == 2 and part.strokes.size == 2
    out = tmp_path / "s.wav"
    assert (
        main(
            [
                "spark",
                "render",
                "--preset",
                "spark-balls",
                "--seed",
                "4",
                "--strokes",
                "2",
                "--listener",
                "0,-0.5,0",
                "--duration",
                "0.05",
                "--layout",
                "5.1",
                "-o",
                str(out),
                "--normalize",
                "none",
            ]
        )
        == 0
    )
    audio, rate, mask = read_wav(out)
    ren = render_sound(snd, ListenerPath.point((0.0, -0.5, 0.0), duration=0.05), layout="5.1")
    assert audio.shape == ren.audio.shape == (6, round(0.05 * rate))
    np.testing.assert_allclose(audio, ren.audio, atol=1e-6 * np.abs(ren.audio).max())
    assert mask == 0x3F  # FL FR FC LFE BL BR


def test_live_discharges_binaural_match_the_offline_ears() -> None:
    """LiveDischarges to ``binaural``: the waves are mixed in the ear receivers'
    channels and pulled through the ears' filters, block after block; the stream
    matches the discharge part rendered offline to ``binaural``: onset within a
    sample and ear energies within 25 % (the stream starts each wave on a whole
    sample, and an N-wave here lasts a few samples), the right ear first and
    louder for a discharge on the right."""
    from auralize_spark import LiveDischarges
    from auralize_spark.waves import DischargePart

    d = Discharge(np.array([[0.0, 0, 0], [0.0, 0, 0.01]]), [-1, 0], [True, True])
    path = ListenerPath.point((-3.43, 0.0, 0.005), duration=0.05)  # the spark on its right
    n = int(0.05 * 44100)
    with LiveDischarges(
        path, params=PARAMS, rate=44100, layout="binaural", clock=lambda: 0.0
    ) as live:
        live.submit(d, at=0.0).result(timeout=30)
        audio = np.concatenate([live.pull(441) for _ in range(n // 441)], axis=1)
    off = DischargePart(d, PARAMS, np.zeros(1)).render_part(
        path, rate=44100, layout="binaural", duration=n / 44100
    )
    assert audio.shape == (2, n // 441 * 441)
    ref = off.audio[:, : audio.shape[1]]
    # the stream places the first wave on a whole sample: within one sample of offline
    lag = np.argmax(np.abs(audio[1]) > 0.05 * np.abs(audio).max())
    lag_ref = np.argmax(np.abs(ref[1]) > 0.05 * np.abs(ref).max())
    assert abs(int(lag) - int(lag_ref)) <= 1
    np.testing.assert_allclose(np.sum(audio**2, axis=1), np.sum(ref**2, axis=1), rtol=0.25)
    left, right = np.sum(audio**2, axis=1)
    assert right > 2 * left
    onset = np.argmax(np.abs(audio) > 0.05 * np.abs(audio).max(), axis=1)
    assert onset[0] - onset[1] >= 0.5e-3 * 44100


def test_live_discharges_follow_a_moving_listener() -> None:
    """LiveDischarges with a path: the first wave is due at the exact retarded arrival."""
    from auralize_spark import LiveDischarges

    from auralize.emitters.events import arrivals

    path = ListenerPath(np.array([0.0, 1.0]), np.array([[0.0, 10.0, 0.0], [0.0, 60.0, 0.0]]))
    d = segment()
    with LiveDischarges(path, params=PARAMS, rate=44100, clock=lambda: 0.0) as live:
        rep = live.submit(d, at=0.05).result(timeout=30)
        audio = live.pull(int(0.2 * 44100))
    t = arrivals(d.midpoints, np.array([0.05]), path).time[0]
    assert t == pytest.approx(
        0.05 + (10.0 + 50.0 * 0.05) / (C - 50.0), rel=1e-12
    )  # receding at 50 m/s
    # the wave starts half an N-wave (T ≈ 70 µs at 12.5 m, Eq. 4, Doppler-stretched) before t
    assert 0.0 < t - (0.05 + rep.propagation_s) < 1e-4
    assert not rep.exceeded
    first = np.flatnonzero(np.abs(audio[0]) > 0)[0]
    assert first / 44100 == pytest.approx(0.05 + rep.propagation_s, abs=2 / 44100)


def test_binaural_discharge_is_the_ear_stage_of_its_ambix_render() -> None:
    """A discharge rendered alone to ``binaural`` = its render to the ear receivers through
    the ears' filters (the same as the engine's scene render), and a discharge on the right
    is louder right and arrives there first."""
    from auralize_spark.waves import Discharge, DischargePart, WaveParams

    from auralize.emitters import Sound, render_sound
    from auralize.spatial import output_stage

    d = Discharge(np.array([[0.0, 0, 0], [0.0, 0, 0.01]]), [-1, 0], [True, True])
    part = DischargePart(d, WaveParams(r0=0.05, T0=30e-6, ps0=500.0), np.zeros(1))
    # listener 1 m west of the spark, facing north (+y): the spark is on its right
    path = ListenerPath.point((-1.0, 0.0, 0.005), duration=0.02)
    ears = part.render_part(path, rate=44100, layout="binaural", duration=0.02)
    stage = output_stage("binaural", 44100)
    amb = part.render_part(path, rate=44100, layout=stage.synthesis_layout, duration=0.02)
    assert amb.audio.shape[0] == 8
    ref = stage.finish(amb).audio
    np.testing.assert_allclose(ears.audio, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    scene = render_sound(Sound([part]), path, rate=44100, layout="binaural", duration=0.02).audio
    np.testing.assert_allclose(scene, ears.audio, rtol=0, atol=1e-9 * np.abs(ref).max())
    left, right = np.sum(ears.audio**2, axis=1)
    assert right > 2 * left
    onset = np.argmax(np.abs(ears.audio) > 0.05 * np.abs(ears.audio).max(), axis=1)
    assert onset[0] - onset[1] >= 0.5e-3 * 44100  # the right ear hears it ≥ 0.5 ms earlier
