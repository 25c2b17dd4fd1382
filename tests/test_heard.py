"""What is heard is what the data does: the whole field against closed forms, no
invented source types, silence when nothing changes, no sounds made by the renderer.

Tolerances: the far field of a compact spinning quadrupole within 10 % of
Lighthill's compact formula (computed from the same arrays) at two azimuths and
two compactnesses, below 5 % of it on the spin axis; Doppler frequencies within
1 %; a field that freezes at least 40 dB quieter after its last arrival; the
capture rate of a recorded path and its harmonics at least 60 dB below the signal.
"""

from __future__ import annotations

import numpy as np
import pytest

import auralize.pipeline as ap
from auralize.datasets.synthetic import (
    SpinningParams,
    lighthill_far_field,
    make_monopole,
    make_moving_pulse,
    make_spinning,
)
from auralize.emitters.synthesis import C0
from auralize.listener import ListenerPath
from auralize.sources.detection import detect
from auralize.sources.field import block_plan, field_tracks, parse_heard
from auralize.volume import CallableFrames, TimeVolume

RATE = 44100


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _far_render(vol: TimeVolume, direction: np.ndarray, r: float, **kw) -> tuple[np.ndarray, float]:  # type: ignore[no-untyped-def]
    """The default render (whole field, auto timbre, 20 Hz high-pass) at ``r`` along
    ``direction`` from the grid's centre: its samples (Pa) from the first arrival on."""
    d = np.asarray(direction, dtype=np.float64) / np.linalg.norm(direction)
    span = float(vol.times[-1] - vol.times[0])
    out, _ = ap.auralize(
        vol, listener=vol.center + r * d, duration=span, time_scale=1.0, layout="mono", **kw
    )
    return out.audio[0], out.meta


@pytest.mark.parametrize("kL", [0.4, 0.04])
def test_compact_spinning_quadrupole_matches_lighthill(kL: float) -> None:
    """Every point heard, with the default settings: Lighthill's compact far field
    within 10 % at two azimuths, silent (< 5 %) on the spin axis."""
    vol = make_spinning(kL=kL).load()
    p = SpinningParams(kL=kL)
    r = 30 * C0 / p.frequency  # thirty wavelengths: the far field
    levels = {}
    for name, d in (
        ("x", [1.0, 0.0, 0.0]),
        ("oblique", [np.cos(0.6), np.sin(0.6), 0.3]),
        ("axis", [0.0, 0.0, 1.0]),
    ):
        x, meta = _far_render(vol, np.array(d), r)
        # (on the axis, where the render is nearly silent, auto may pick another timbre)
        assert meta["heard"] == "field" and (meta["timbre"] == "physical" or name == "axis")
        _, ref = lighthill_far_field(vol, np.array(d), r)
        # the whole periods after the high-pass has settled, against the reference's RMS
        levels[name] = (_rms(x[x.size // 4 :]), _rms(ref))
    for name in ("x", "oblique"):
        got, want = levels[name]
        assert got == pytest.approx(want, rel=0.10), (name, got / want)
    assert levels["axis"][0] < 0.05 * levels["x"][1]


def test_detected_thresholds_would_have_made_it_too_loud() -> None:
    """The reason the whole field is heard: the paper's detected sources, gated by
    thresholds, lose the cancelling tails of a compact flow (kL 0.04)."""
    vol = make_spinning(kL=0.04).load()
    p = SpinningParams(kL=0.04)
    r = 30 * C0 / p.frequency
    field, _ = _far_render(vol, np.array([1.0, 0.0, 0.0]), r)
    detected, _ = _far_render(vol, np.array([1.0, 0.0, 0.0]), r, heard="detected")
    _, ref = lighthill_far_field(vol, np.array([1.0, 0.0, 0.0]), r)
    assert _rms(field[field.size // 4 :]) == pytest.approx(_rms(ref), rel=0.10)
    assert _rms(detected[detected.size // 4 :]) > 3 * _rms(ref)


def _tone_hz(x: np.ndarray, rate: int) -> float:
    """The frequency of the strongest spectral peak (parabolic interpolation on a
    zero-padded, windowed spectrum)."""
    n = 1 << int(np.ceil(np.log2(x.size * 8)))
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size), n))
    k = int(np.argmax(spec[1:])) + 1
    a, b, c = np.log(spec[k - 1 : k + 2])
    return float((k + 0.5 * (a - c) / (a - 2 * b + c)) * rate / n)


def test_source_moving_through_the_grid_is_heard_with_its_doppler_shift() -> None:
    """A pulsating blob crossing the grid at Mach 0.3: f0/(1 − M) ahead, f0/(1 + M)
    behind, within 1 % (the shift comes out of the retarded time alone)."""
    vol = make_moving_pulse().load()
    f0, M = 200.0, 0.3
    centre = np.array([3.0, 0.0, 0.0])
    for sign, want in ((1.0, f0 / (1 - M)), (-1.0, f0 / (1 + M))):
        listener = centre + sign * np.array([300.0, 0.0, 0.0])
        out, _ = ap.auralize(
            vol,
            listener=listener,
            duration=float(vol.times[-1]) / (1 + sign * M),
            time_scale=1.0,
            timbre="physical",
            highpass_hz=0.0,
        )
        x = out.audio[0]
        on = np.flatnonzero(np.abs(x) > 0.05 * np.max(np.abs(x)))
        seg = x[on[0] + x.size // 10 : on[-1] - x.size // 10]  # the steady middle
        assert _tone_hz(seg, out.rate) == pytest.approx(want, rel=0.01), sign


def _count(series) -> dict[str, int]:  # type: ignore[no-untyped-def]
    return {k: sum(c[k] for c in series.counts()) for k in ("monopole", "dipole", "quadrupole")}


def _pulsating_swirl() -> TimeVolume:
    """Constant density, a divergence-free swirl whose strength pulsates."""
    base = make_spinning(kL=0.4, steps=33)
    amp = 1.0 + 0.5 * np.sin(2 * np.pi * np.arange(33) / 16)
    frozen = SpinningParams(kL=0.4, steps=33)
    turn0 = make_spinning(kL=0.4, steps=33, freeze_after=0.0)  # the vortex held still
    shape = base.shape
    return TimeVolume(
        origin=base.origin,
        spacing=base.spacing,
        dims=base.dims,
        times=base.times,
        fields={
            "density": CallableFrames(lambda k: np.full(shape, frozen.rho0), 33, shape),
            "velocity": CallableFrames(
                lambda k: amp[k] * turn0.frame("velocity", k), 33, (*shape, 3)
            ),
        },
        source="pulsating-swirl",
    )


def test_no_invented_source_types() -> None:
    """Constant density gives no monopole; a divergence-free flow at constant density
    gives < 1 % dipoles of the detected points; a pulsating blob only monopoles."""
    spin = _count(detect(make_spinning(kL=0.4, steps=33).load(), mapping="identity"))
    assert spin["monopole"] == 0 and spin["quadrupole"] > 0
    assert spin["dipole"] < 0.01 * sum(spin.values()), spin
    swirl = _count(detect(_pulsating_swirl().load(), mapping="identity"))
    assert swirl["monopole"] == 0 and swirl["quadrupole"] > 0
    assert swirl["dipole"] < 0.01 * sum(swirl.values()), swirl
    blob = _count(detect(make_monopole(size=16, steps=60), mapping="identity"))
    assert blob["monopole"] > 0 and blob["dipole"] == blob["quadrupole"] == 0
    # the paper's literal detection (no floor) invents dipoles in the same flow
    from auralize.sources.detection import Thresholds

    literal = _count(
        detect(
            make_spinning(kL=0.4, steps=33).load(),
            mapping="identity",
            thresholds=Thresholds(floor=0.0),
        )
    )
    assert literal["dipole"] > 0.05 * sum(literal.values())


@pytest.mark.parametrize("timbre", ["physical", "extended", "tonal", "auto"])
@pytest.mark.parametrize("moving", [False, True])
def test_a_field_that_freezes_falls_silent(timbre: str, moving: bool) -> None:
    """The vortex turns for 3 periods of its sound, then stops: after the last
    arrival of a change the render is at least 40 dB below its level while turning,
    in every timbre, for a fixed and for a moving listener."""
    p = SpinningParams(kL=0.4, freeze_after=3.0)
    # 3 periods turning, 22 still (122 ms)
    vol = make_spinning(kL=0.4, size=20, steps=16 * 25 + 1, freeze_after=3.0).load()
    span = float(vol.times[-1])
    r = 30 * C0 / p.frequency
    c = vol.center
    if moving:  # 20 m/s past the source, captured at 20 Hz
        path = ListenerPath.line(
            c + [r, -0.5 * 20 * span, 0.0],
            c + [r, 0.5 * 20 * span, 0.0],
            duration=span,
            n=max(int(span * 20), 2) + 1,
        )
        out, _ = ap.auralize(vol, path, time_scale=1.0, timbre=timbre, layout="stereo")
    else:
        out, _ = ap.auralize(
            vol,
            listener=c + [r, 0.0, 0.0],
            duration=span,
            time_scale=1.0,
            timbre=timbre,
            layout="stereo",
        )
    x = out.audio
    rate = out.rate
    t_freeze = 3.0 / p.frequency  # data time of the last change
    # playback starts at the first arrival (lead); the last change arrives r/c0 after
    # t_freeze, plus the sound's crossing of the source region and two data steps
    # of interpolation, plus 50 ms for the high-pass and the envelopes to settle
    lead = float(out.meta["lead_data_s"])
    t_last = t_freeze + r / C0 - lead + 4 * p.dt
    before = x[:, int(0.3 * t_freeze * rate) : int(0.9 * t_freeze * rate)]
    after = x[:, int((t_last + 0.05) * rate) :]
    assert after.shape[1] > 0.04 * rate
    drop = 20 * np.log10(max(_rms(after), 1e-300) / _rms(before))
    assert drop <= -40.0, (timbre, moving, drop)


def test_capture_rate_of_a_recorded_path_is_not_heard() -> None:
    """A path recorded at 10 Hz (a hand-held wobble): no tone at 10 Hz or its harmonics
    within 60 dB of the signal."""
    # one second of the tone (8 frames a period, a coarse grid: the tone is all it needs)
    vol = make_spinning(kL=0.4, size=16, per_period=8, steps=8 * 180 + 1).load()
    span = float(vol.times[-1])
    p = SpinningParams(kL=0.4)
    r = 20 * C0 / p.frequency
    t = np.arange(0.0, span + 1e-9, 0.1)
    if t[-1] < span:
        t = np.append(t, span)
    rng = np.random.default_rng(5)
    ang = 0.4 * t / span + 0.02 * rng.standard_normal(t.size)  # an uneven sweep
    pos = vol.center + np.stack(
        [r * np.cos(ang), r * np.sin(ang), 0.3 * rng.standard_normal(t.size)], 1
    )
    path = ListenerPath(t, pos, source="recorded")
    out, _ = ap.auralize(vol, path, time_scale=1.0, timbre="physical", highpass_hz=0.0)
    x = out.audio[0]
    f = np.fft.rfftfreq(x.size, 1 / out.rate)
    spec = np.abs(np.fft.rfft(x * np.hanning(x.size))) ** 2
    total = spec.sum()
    for k in range(1, 9):
        band = (f > 10.0 * k - 1.5) & (f < 10.0 * k + 1.5)
        assert 10 * np.log10(spec[band].sum() / total) < -60.0, k


def test_default_orbit_uses_the_whole_ring() -> None:
    """On ring8 the default render (the orbit's head sweeping the data round) gives at
    least 6 of the 8 channels 1 % or more of the energy."""
    vol = ap.load("dataset:explosion", size=32).load()
    out, _ = ap.auralize(vol, layout="ring8")
    e = np.sum(out.audio**2, axis=1)
    assert np.sum(e / e.sum() >= 0.01) >= 6, e / e.sum()
    assert "the head turning so the data pass" in " ".join(out.meta["notes"])


def test_round_off_is_written_as_silence() -> None:
    """A steady vortex: its pressure is round-off; nothing amplifies it."""
    vol = make_spinning(kL=0.4, steps=17, freeze_after=0.0).load()
    p = SpinningParams(kL=0.4)
    out, _ = ap.auralize(
        vol, listener=vol.center + [30 * C0 / p.frequency, 0, 0], duration=0.05, time_scale=1.0
    )
    assert not np.any(out.audio) and "nothing in the data changes" in out.meta["silent_why"]


def test_the_silence_warning_gives_the_renders_reason(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """meshio's shipped XDMF series rises linearly in time: its pressure is round-off, and
    the command's warning says that (not 'no sources or the listener too far')."""
    from auralize.cli import main

    out = tmp_path / "m.wav"
    code = main(
        ["render", "dataset:meshio", "--density-field", "phi", "--duration", "1", "-o", str(out)]
    )
    err = capsys.readouterr().err
    assert code == 1 and "nothing in the data changes in a way that sounds" in err, err
    assert "listener too far away" not in err and out.exists()


def test_block_compression_matches_every_point_within_two_percent() -> None:
    """The proxies of each block (Chebyshev nodes) against every point heard as itself,
    below the data's Nyquist frequency (what the data hold), for a listener beyond
    two block sizes: within 2 % RMS."""
    vol = ap.load("dataset:explosion", size=32).load()
    m = ap.resolve_mapping(vol)
    plan = ap.plan_render(vol, None)
    every = field_tracks(vol, m, block=1).tracks()
    fast = field_tracks(vol, m, path=plan.path)
    assert fast.meta["rows"] < 0.6 * every.n_sources
    kw = dict(time_scale=plan.time_scale, duration=plan.duration, lead=plan.lead, rate=4000)
    from auralize.emitters.synthesis import render_tracks

    a = render_tracks(every, plan.path, **kw).audio[0]
    b = render_tracks(fast.tracks(), plan.path, **kw).audio[0]
    f = np.fft.rfftfreq(a.size, 1 / 4000)
    nyq = 0.5 / ((vol.times[1] - vol.times[0]) * plan.time_scale)
    A, B = np.fft.rfft(a), np.fft.rfft(b)
    band = f <= nyq
    err = np.sqrt(np.sum(np.abs(A - B)[band] ** 2) / np.sum(np.abs(A)[band] ** 2))
    assert err < 0.02, err
    assert block_plan(vol).compresses


def test_heard_specs() -> None:
    assert parse_heard("field").types == ("monopole", "quadrupole")
    assert parse_heard("detected:quadrupole").label == "detected:quadrupole"
    with pytest.raises(ValueError, match="not a term of the whole field"):
        parse_heard("field:dipole")
    with pytest.raises(ValueError, match="not a source type"):
        parse_heard("hexapole")


def test_a_pressure_below_anything_audible_is_not_amplified(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A vortex model of a field at 1e-17 m/s makes 1e-78 Pa: written as silence, said
    so, never normalised to full scale (the gain stays 1)."""
    import json
    import warnings

    from auralize.audio import SilentAudioWarning, write_audio

    x = np.full((1, 100), 4e-78)
    with pytest.warns(SilentAudioWarning, match="round-off or nothing"):
        gain = write_audio(tmp_path / "q.wav", x, 8000)
    side = json.loads((tmp_path / "q.wav.json").read_text())
    assert gain == 1.0 and side["silent"] is True and "1e-15 Pa" in side["silent_why"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert write_audio(tmp_path / "p.wav", x * 1e70, 8000) > 1.0  # small but real: normalised
