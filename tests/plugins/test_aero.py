"""Aerodynamic-sound plugin (paper 004): flow solver, textures, rendering, CLI, overlay."""

from __future__ import annotations

import json

import numpy as np
import pytest
from auralize_aero import (
    AeroObject,
    AeroSound,
    Motion,
    SoundTexture,
    Wind,
    circle,
    compute_texture,
    get_section,
    make_polygon,
    render,
    square,
    stick,
)
from auralize_aero.render import emission
from auralize_aero.shapes import fold_directions

from auralize.audio import read_wav
from auralize.cli import main
from auralize.emitters import Sound, render_sound
from auralize.errors import FormatError, ParameterError
from auralize.listener import ListenerPath
from auralize.plugins import get_model

RATE = 44100
TEX_KW = {"resolution": 10, "duration": 0.03}  # small and short: ~10 s, computed once


@pytest.fixture(scope="module")
def cache(tmp_path_factory):  # type: ignore[no-untyped-def]
    return tmp_path_factory.mktemp("aero-cache")


@pytest.fixture(scope="module")
def tex(cache) -> SoundTexture:  # type: ignore[no-untyped-def]
    return compute_texture(circle(0.01), cache=cache, **TEX_KW)


def peak_hz(x: np.ndarray, rate: float, lo: float = 20.0) -> float:
    """Spectral peak with 16× zero padding and parabolic interpolation."""
    n = x.size
    sp = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n), 16 * n))
    fr = np.fft.rfftfreq(16 * n, 1 / rate)
    sp[fr < lo] = 0
    k = int(np.argmax(sp))
    a, b, c = np.log(sp[k - 1 : k + 2] + 1e-300)
    return float(fr[k] + 0.5 * (a - c) / (a - 2 * b + c) * (fr[1] - fr[0]))


def band_amp(x: np.ndarray, rate: float, f: float, rel: float = 0.1) -> float:
    sp = np.abs(np.fft.rfft(x * np.hanning(x.size)))
    fr = np.fft.rfftfreq(x.size, 1 / rate)
    return float(sp[(fr > f * (1 - rel)) & (fr < f * (1 + rel))].max())


# ------------------------------------------------------------------ texture
def test_cylinder_strouhal_and_drag_at_twice_lift(tex: SoundTexture) -> None:
    st = tex.strouhal[0]
    assert 0.17 <= st <= 0.23  # experiment ≈ 0.2 (§3, Strouhal 1878)
    n = tex.lengths[0]
    lift = np.tile(tex.force[0, :n, 1], 8)
    drag = np.tile(tex.force[0, :n, 0], 8)
    f_l, f_d = peak_hz(lift, tex.rate), peak_hz(drag, tex.rate)
    assert f_l * tex.diameter / tex.speed == pytest.approx(st, rel=0.03)
    assert f_d / f_l == pytest.approx(2.0, rel=0.03)
    # g = dF/dt: for the lift harmonic, |g| = 2π f |F|
    g_l = np.tile(tex.g[0, :n, 1], 8)
    assert np.std(g_l) / np.std(lift - lift.mean()) == pytest.approx(2 * np.pi * f_l, rel=0.1)
    assert tex.meta["directions"][0]["periodic"]


def test_texture_loops_seamlessly(tex: SoundTexture) -> None:
    n = tex.lengths[0]
    g = tex.g[0, :n, 1]
    step = np.abs(np.diff(g)).max()
    assert abs(g[0] - g[-1]) <= 1.5 * step  # the wrap is no bigger than an ordinary step


def test_texture_hdf5_roundtrip_and_cache(tex: SoundTexture, cache, tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    p = tmp_path / "cyl.h5"
    tex.save(p)
    back = SoundTexture.load(p)
    np.testing.assert_allclose(back.g, tex.g, rtol=1e-6, atol=1e-6 * np.abs(tex.g).max())
    assert back.speed == 10.0 and back.diameter == 0.01 and back.section.is_circle
    assert back.meta["reynolds"] == 200.0
    import auralize_aero.texture as texture_module

    def no_simulation(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("the cached texture was simulated again")

    monkeypatch.setattr(texture_module, "simulate", no_simulation)
    again = compute_texture(circle(0.01), cache=cache, **TEX_KW)  # read from the cache
    np.testing.assert_array_equal(again.lengths, tex.lengths)
    with pytest.raises(FormatError, match="does not exist"):
        SoundTexture.load(tmp_path / "missing.h5")
    (tmp_path / "bad.h5").write_bytes(b"not hdf5")
    with pytest.raises(FormatError, match="not an HDF5 file"):
        SoundTexture.load(tmp_path / "bad.h5")


def test_square_symmetry_folding() -> None:
    sq = square(0.01)
    assert sq.symmetry == (4, 0.0)
    from auralize_aero.texture import sample_directions

    d = sample_directions(sq)
    np.testing.assert_allclose(d, np.arange(0, 46, 5))  # 1/8 of 360° at 5° (§8.1)
    th = np.deg2rad(np.array([10.0, 50.0, 100.0, 200.0, -30.0, 300.0]))
    thf, M = fold_directions(sq, th)
    assert np.all((thf >= 0) & (thf <= np.pi / 4 + 1e-12))
    u = np.stack([np.cos(thf), np.sin(thf)], -1)
    back = np.einsum("nij,nj->ni", M, u)  # M maps the folded flow back onto the query
    np.testing.assert_allclose(back, np.stack([np.cos(th), np.sin(th)], -1), atol=1e-12)


# -------------------------------------------------------------- rendering
def _wind_render(tex: SoundTexture, speed: float, listener, exponent="physical", gust=0.0, seed=0):  # type: ignore[no-untyped-def]
    path = ListenerPath.point(listener, duration=0.6)
    out = render(
        tex, stick(0.5), path, wind=Wind(speed, (0, 1, 0), gust=gust, seed=seed), exponent=exponent
    )
    return out.audio[0][int(0.05 * RATE) :]


@pytest.mark.parametrize(("exponent", "power"), [("physical", 3), ("paper", 6)])
def test_wind_20_vs_10_doubles_frequency_and_scales_pressure(
    tex: SoundTexture, exponent, power
) -> None:  # type: ignore[no-untyped-def]
    a = _wind_render(tex, 10.0, (0.25, 0.0, 2.0), exponent)
    b = _wind_render(tex, 20.0, (0.25, 0.0, 2.0), exponent)
    fa, fb = peak_hz(a, RATE), peak_hz(b, RATE)
    assert fa == pytest.approx(tex.strouhal[0] * 10 / 0.01, rel=0.03)
    assert fb / fa == pytest.approx(2.0, rel=0.03)
    assert np.std(b) / np.std(a) == pytest.approx(2.0**power, rel=0.03)


def test_curle_amplitude_of_a_static_stick(tex: SoundTexture) -> None:
    """Eq. 1 by hand: a listener far across the flow hears Σ Δh ĝ_lift / (4π c0 r)."""
    r = 50.0
    a = _wind_render(tex, 10.0, (0.25, 0.0, r))[int(0.12 * RATE) :]  # sound arrives at r/c0
    n = tex.lengths[0]
    g_lift = tex.g[0, :n, 1]  # body frame: η = lift direction for θ = 0
    expect = 0.5 * np.std(g_lift) / (4 * np.pi * 343.0 * r)
    assert np.std(a) == pytest.approx(expect, rel=0.03)


def test_dipole_directivity_cos_theta(tex: SoundTexture) -> None:
    f = tex.strouhal[0] * 10 / 0.01
    across = _wind_render(tex, 10.0, (0.25, 0.0, 2.0))  # along the lift (z)
    inline = _wind_render(tex, 10.0, (0.25, 2.0, 0.0))  # along the flow (y)
    at60 = _wind_render(tex, 10.0, (0.25, 2 * np.sin(np.pi / 3), 2 * np.cos(np.pi / 3)))
    A = band_amp(across, RATE, f)
    assert band_amp(inline, RATE, f) < 0.02 * A
    assert band_amp(at60, RATE, f) / A == pytest.approx(0.5, rel=0.03)
    assert peak_hz(inline, RATE) == pytest.approx(2 * f, rel=0.03)  # drag heard in line


def test_inclined_stick_uses_normal_speed(tex: SoundTexture) -> None:
    """Property 3 (§5.1): at φ = 30° from the normal plane, frequency × cos φ."""
    phi = np.deg2rad(30)
    tilted = AeroObject([np.array([[0, 0, 0], [0.5 * np.cos(phi), 0.5 * np.sin(phi), 0]])], 0.01)
    path = ListenerPath.point((0.2, 0.1, 2.0), duration=0.6)
    out = render(tex, tilted, path, wind=Wind(20.0, (0, 1, 0), gust=0.0)).audio[0][2000:]
    assert peak_hz(out, RATE) == pytest.approx(tex.strouhal[0] * 20 * np.cos(phi) / 0.01, rel=0.03)


def test_doppler_approach_and_recede(tex: SoundTexture) -> None:
    """A vertical stick flying at 30 m/s along x; listeners on the x axis hear the drag tone
    shifted by 1/(1 ∓ M) (Fig. 12), out of the retarded-time evaluation alone."""
    V, c0 = 30.0, 343.0
    obj = AeroObject([np.array([[0, 0, -0.15], [0, 0, 0.15]])], 0.01)
    motion = Motion.linear((0, 0, 0), (V, 0, 0), duration=1.2)
    ref = render(
        tex, obj, ListenerPath.point((100.0, 0, 0), duration=0.8), wind=Wind(V, (-1, 0, 0), gust=0)
    )
    f_drag = peak_hz(ref.audio[0][int(0.35 * RATE) :], RATE)
    assert f_drag == pytest.approx(2 * tex.strouhal[0] * V / 0.01, rel=0.03)
    for x, t0, t1, factor in (
        (100.0, 0.45, 1.25, 1 / (1 - V / c0)),
        (-100.0, 0.45, 1.45, 1 / (1 + V / c0)),
    ):
        out = render(tex, obj, ListenerPath.point((x, 0, 0), duration=t1 + 0.05), motion=motion)
        seg = out.audio[0][int(t0 * RATE) : int(t1 * RATE)]
        assert peak_hz(seg, RATE) / f_drag == pytest.approx(factor, rel=0.004)


def test_stereo_vbap_ring8_and_no_ears(tex: SoundTexture) -> None:
    path = ListenerPath.point((0.25, 0.0, 0.5), duration=0.3, forward=(1, 0, 0), up=(0, 1, 0))
    obj = AeroObject([np.array([[0.0, 0, 0], [0.5, 0, 0]])], 0.01)
    wind = Wind(10.0, (0, 1, 0), gust=0)
    st = render(tex, obj, path, wind=wind, layout="stereo").audio
    assert st.shape[0] == 2
    # listener's left is up × forward = (0,1,0)×(1,0,0) = -z: the stick (below, -z) is on the left
    assert np.std(st[0]) > 10 * np.std(st[1])
    r8 = render(tex, obj, path, wind=wind, layout="ring8").audio
    assert r8.shape[0] == 8
    e = (r8**2).sum(1)
    assert int(np.argmax(e)) == 2  # channel 2 = left (90°)
    one = AeroObject([np.array([[0.2, 0, 0], [0.3, 0, 0]])], 0.01, spacing=0.1)  # one source
    r8 = render(tex, one, path, wind=wind, layout="ring8").audio
    mono = render(tex, one, path, wind=wind).audio[0]
    np.testing.assert_allclose(np.sqrt((r8**2).sum(0)), np.abs(mono), rtol=1e-6, atol=1e-12)
    with pytest.raises(ParameterError, match="two ear receivers"):
        render(tex, obj, path, wind=wind, layout="stereo", stereo="ears")


def test_wind_gusts_are_seeded(tex: SoundTexture) -> None:
    a = _wind_render(tex, 12.0, (1, 1, 1), gust=0.08, seed=3)
    b = _wind_render(tex, 12.0, (1, 1, 1), gust=0.08, seed=3)
    c = _wind_render(tex, 12.0, (1, 1, 1), gust=0.08, seed=4)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


def test_swinging_stick_sources_and_model(tex: SoundTexture) -> None:
    obj = stick(0.5, 0.01)
    c, span, axes, refs = obj.sources()
    assert c.shape == (16, 3) and np.allclose(span, 0.5 / 16)  # §8.1: 16 sources at 3D
    assert np.allclose(np.sum(axes * refs, 1), 0)
    model = get_model("aero")
    assert isinstance(model, AeroSound)
    motion = Motion.swing(duration=0.5, swings=1, amplitude_deg=80, rate_hz=200)
    path = ListenerPath.point((0.3, 1.0, 0.2), duration=0.5)
    sound = model.synthesize({"texture": tex, "object": obj, "motion": motion})
    assert isinstance(sound, Sound) and sound.meta["n_sources"] == 16
    em = sound.parts[0].emitters()
    assert em.dipole and em.moving and em.signals.shape[:2] == (16, 3) and em.t0 == 0.0
    assert em.n_samples / em.rate == pytest.approx(0.5, abs=2e-3)  # the motion's duration
    out = render_sound(sound, path, rate=RATE)
    pressure = out.audio[0]
    assert pressure.shape == (int(0.5 * RATE),)
    assert np.all(np.isfinite(pressure)) and np.std(pressure) > 0
    # the model's sound rendered by the engine is render()'s
    ref = render(tex, obj, path, motion=motion).audio[0]
    np.testing.assert_allclose(pressure, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    with pytest.raises(ParameterError, match="exponent"):
        model.synthesize({"texture": tex, "object": obj, "motion": motion}, exponent="v7")
    with pytest.raises(ParameterError, match="no listener path"):
        model.synthesize((tex, obj, path, motion))
    with pytest.raises(ParameterError, match="duration"):
        model.synthesize({"texture": tex, "object": obj, "wind": Wind(10.0)})
    with pytest.raises(ParameterError, match="two ear receivers.*VBAP"):
        model.synthesize({"texture": tex, "object": obj, "motion": motion}, stereo="ears")


def test_overlay_offscreen(tex: SoundTexture) -> None:
    import pyvista as pv

    obj = stick(0.5, 0.01)
    motion = Motion.swing(duration=1.0, swings=1, amplitude_deg=90, rate_hz=40)
    meshes = AeroSound().overlay(
        {"texture": tex, "object": obj, "path": None, "motion": motion}, 10
    )
    body, src = meshes
    assert body.n_points == 2 and body.n_lines == 1 and src.n_points == 16
    tip = body.points[1]
    ang = np.deg2rad(90) * np.sin(2 * np.pi * motion.times[10])
    np.testing.assert_allclose(tip, [0.5 * np.cos(ang), 0.5 * np.sin(ang), 0], atol=1e-9)
    pl = pv.Plotter(off_screen=True, window_size=(64, 64))
    pl.add_mesh(body)
    pl.add_mesh(src)
    img = pl.screenshot(return_img=True)
    pl.close()
    assert img.shape[:2] == (64, 64)


# -------------------------------------------------------------- bad input
def test_bad_sections() -> None:
    with pytest.raises(ParameterError, match="self-intersecting"):
        make_polygon(np.array([[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]))
    with pytest.raises(ParameterError, match="open"):
        make_polygon(np.array([[0, 0], [1, 0], [1, 1], [0, 1]]))
    for d in (0.0, -0.01):
        with pytest.raises(ParameterError, match="diameter must be > 0"):
            circle(d)
        with pytest.raises(ParameterError, match="diameter must be > 0"):
            get_section("square", d)
    with pytest.raises(ParameterError, match="unknown shape"):
        get_section("hexagon-ish", 0.01)


def test_polygon_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    f = tmp_path / "tri.csv"
    f.write_text("x,y\n0,0\n2,0\n1,1.5\n0,0\n")
    sec = get_section(str(f), 0.01)
    assert sec.diameter == pytest.approx(0.01) and sec.symmetry == (1, 90.0)
    f.write_text("x,y\n0,0\n2,0\n1,1.5\n")
    with pytest.raises(ParameterError, match="open"):
        get_section(str(f), 0.01)


def test_bad_motion_and_render_inputs(tex: SoundTexture, tmp_path) -> None:  # type: ignore[no-untyped-def]
    f = tmp_path / "m.csv"
    f.write_text("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0.2,1,0,0,1,0,0,0\n0.1,2,0,0,1,0,0,0\n")
    with pytest.raises(ParameterError, match="strictly increasing.*t=0.1 s after t=0.2 s"):
        Motion.from_csv(f)
    f.write_text("time,x,y\n0,0,0\n")
    with pytest.raises(FormatError, match="header must start"):
        Motion.from_csv(f)
    path = ListenerPath.point((0, 1, 0), duration=0.1)
    with pytest.raises(ParameterError, match="motion .* or a wind"):
        render(tex, stick(), path)
    with pytest.raises(ParameterError, match="wind speed must be >= 0"):
        Wind(-1.0)
    with pytest.raises(ParameterError, match="zero-length segment"):
        AeroObject([np.zeros((2, 3))], 0.01)
    with pytest.raises(ParameterError, match="resolution"):
        compute_texture(circle(0.01), resolution=3, cache=False)


# --------------------------------------------------------------------- CLI
def test_cli_texture_and_render(tex, cache, tmp_path, monkeypatch, capsys) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setenv("AURALIZE_CACHE", str(cache.parent))
    # the module texture lives in cache/; the CLI's default cache is $AURALIZE_CACHE/aero
    (cache.parent / "aero").mkdir(exist_ok=True)
    for p in cache.iterdir():
        target = cache.parent / "aero" / p.name
        if not target.exists():
            target.write_bytes(p.read_bytes())
    texf = tmp_path / "cyl.h5"
    rc = main(
        [
            "aero",
            "texture",
            "--shape",
            "cylinder",
            "--diameter",
            "0.01",
            "-o",
            str(texf),
            "--resolution",
            "10",
            "--texture-duration",
            "0.03",
        ]
    )
    assert rc == 0 and texf.exists()
    # --duration with --path: the output lasts --duration, not the path's 0.2 s
    csv = tmp_path / "path.csv"
    ListenerPath.line((0.25, 0, 2), (0.35, 0, 2), duration=0.2).to_csv(csv)
    for seconds in (0.1, 0.3):
        wav = tmp_path / f"path{seconds}.wav"
        rc = main(
            [
                "aero",
                "render",
                "--texture",
                str(texf),
                "--wind",
                "10",
                "--path",
                str(csv),
                "--duration",
                str(seconds),
                "--rate",
                "16000",
                "-o",
                str(wav),
            ]
        )
        assert rc == 0 and read_wav(wav)[0].shape == (1, round(seconds * 16000))
    capsys.readouterr()
    out = tmp_path / "wind.wav"
    rc = main(
        [
            "aero",
            "render",
            "--texture",
            str(texf),
            "--wind",
            "10",
            "--wind-direction",
            "0,1,0",
            "--listener",
            "0.25,0,2",
            "--duration",
            "0.3",
            "-o",
            str(out),
            "--layout",
            "ring8",
        ]
    )
    assert rc == 0
    audio, rate, _ = read_wav(out)
    assert audio.shape == (8, int(0.3 * rate))
    side = json.loads(out.with_name(out.name + ".json").read_text())
    assert side["model"] == "aero" and side["n_sources"] == 16
    mf = tmp_path / "swing.csv"
    Motion.swing(duration=0.3, swings=1, rate_hz=100).to_csv(mf)
    out2 = tmp_path / "swing.wav"
    rc = main(
        [
            "aero",
            "render",
            "--texture",
            str(texf),
            "--motion",
            str(mf),
            "--listener",
            "0.3,1,0.2",
            "--duration",
            "0.3",
            "-o",
            str(out2),
            "--layout",
            "stereo",
            "--exponent",
            "paper",
        ]
    )
    assert rc == 0 and read_wav(out2)[0].shape[0] == 2
    capsys.readouterr()
    out3 = tmp_path / "ears.wav"
    rc = main(
        [
            "aero",
            "render",
            "--texture",
            str(texf),
            "--motion",
            str(mf),
            "--listener",
            "0.3,1,0.2",
            "--duration",
            "0.3",
            "-o",
            str(out3),
            "--layout",
            "stereo",
            "--stereo",
            "ears",
        ]
    )
    assert rc == 2 and "no longer renders two ear receivers" in capsys.readouterr().err
    assert not out3.exists()
    rc = main(
        [
            "aero",
            "texture",
            "--shape",
            "cylinder",
            "--diameter",
            "-0.01",
            "-o",
            str(tmp_path / "x.h5"),
        ]
    )
    assert rc == 2
    assert "diameter must be > 0 m, got -0.01" in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists()


def _synthetic_texture(section, m: int, rate: float = 20000.0) -> SoundTexture:  # type: ignore[no-untyped-def]
    """A texture with random looping rows (no flow solve) for rendering-path checks."""
    rng = np.random.default_rng(1)
    lengths = np.array([400 + 37 * j for j in range(m)], dtype=np.int64)
    g = np.zeros((m, int(lengths.max()), 2))
    for j, n in enumerate(lengths):
        g[j, :n] = rng.standard_normal((n, 2))
    return SoundTexture(
        section, 10.0, rate, np.linspace(0, 45, m), g, g.copy(), lengths, np.full(m, 0.2), {}
    )


def test_emission_kernel_equals_numpy_reference(tex: SoundTexture) -> None:
    """The numba kinematics and emission kernels reproduce the numpy reference path to rounding."""
    chiral = make_polygon(np.array([[1, 0], [0, 1], [-1, 0.3], [-0.2, -1], [1, 0]]) * 0.005)
    cases = [
        (tex, stick(0.5, 0.01), {"motion": Motion.swing(duration=0.2, swings=1.0, rate_hz=200.0)}),
        (tex, stick(0.5, 0.01), {"wind": Wind(12.0, (0, 1, 0.2), gust=0.1, seed=2)}),
        (
            _synthetic_texture(square(0.01), 10),
            stick(0.4, 0.01),
            {
                "motion": Motion.swing(duration=0.2, swings=1.5, rate_hz=200.0),
                "wind": Wind(5.0, (1, 1, 0)),
            },
        ),
        (
            _synthetic_texture(chiral, 6),
            stick(0.4, 0.01),
            {"motion": Motion.circle(radius=0.6, turns=1.0, duration=0.2), "exponent": "paper"},
        ),
    ]
    for t, obj, kw in cases:
        fast = emission(t, obj, duration=0.2, **kw).emitters()
        ref = emission(t, obj, duration=0.2, engine="numpy", **kw).emitters()
        assert np.abs(ref.signals).max() > 0 and fast.signals.shape == ref.signals.shape
        np.testing.assert_allclose(
            fast.signals, ref.signals, rtol=0, atol=1e-9 * np.abs(ref.signals).max()
        )
        np.testing.assert_allclose(fast.positions, ref.positions, rtol=0, atol=1e-12)
    with pytest.raises(ParameterError, match="engine"):
        render(
            tex,
            stick(),
            ListenerPath.point((0, 1, 0), duration=0.1),
            wind=Wind(10.0),
            engine="fortran",
        )


def _one_source() -> AeroObject:
    return AeroObject([np.array([[0.2, 0, 0], [0.3, 0, 0]])], 0.01, spacing=0.1)  # at (0.25, 0, 0)


def test_arrival_time_and_distance_law(tex: SoundTexture) -> None:
    """Eq. 4 through the engine: sound starts at D/c0 and p·D is the same at every distance."""
    c0, shift = 343.0, 200
    d1 = 1.0
    d2 = d1 + shift * c0 / RATE  # heard exactly 200 samples later
    wind = Wind(10.0, (0, 1, 0), gust=0)
    outs = []
    for d in (d1, d2):
        path = ListenerPath.point((0.25, 0.0, d), duration=0.1)
        p = render(tex, _one_source(), path, wind=wind, c0=c0).audio[0]
        first = int(np.flatnonzero(p)[0])
        assert first == int(np.floor(d * RATE / c0)) + 1  # emission starts at τ = 0
        outs.append(p)
    p1, p2 = outs
    n = p1.size - shift
    np.testing.assert_allclose(p2[shift:] * d2, p1[:n] * d1, rtol=0, atol=1e-9 * np.abs(p1).max())


def test_three_d_layout_pans_with_elevation(tex: SoundTexture) -> None:
    """A source 60° above the listener's front is panned by 3-D VBAP over a dome."""
    from auralize.spatial import Speaker, listener_frame, make_layout, pan_gains

    spk = [Speaker(f"M{k}", az, 0.0) for k, az in enumerate((45.0, 135.0, -135.0, -45.0))]
    spk += [Speaker(f"U{k}", az, 45.0) for k, az in enumerate((0.0, 90.0, 180.0, -90.0))]
    dome = make_layout("dome", [*spk, Speaker("T", 0.0, 90.0)])
    listener = np.array([0.25, -1.0, -np.sqrt(3.0)])  # the source at (0.25, 0, 0): 60° up, ahead
    path = ListenerPath.point(listener, duration=0.1, forward=(0, 1, 0), up=(0, 0, 1))
    wind = Wind(10.0, (0, 1, 0), gust=0)
    out = render(tex, _one_source(), path, wind=wind, layout=dome).audio
    mono = render(tex, _one_source(), path, wind=wind).audio[0]
    d = np.array([0.25, 0.0, 0.0]) - listener
    g = pan_gains(dome, listener_frame(d, np.array([0, 1.0, 0]), np.array([0, 0, 1.0])))[:, 0]
    np.testing.assert_allclose(out, g[:, None] * mono[None], rtol=0, atol=1e-9 * np.abs(mono).max())
    e = (out**2).sum(1) / (mono**2).sum()
    assert e[4] + e[8] > 0.95  # the upper front speaker and the top, not the horizontal ring
    assert e[:4].sum() < 0.05


def test_windows_join_exactly(tex: SoundTexture, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Rendered window by window (bounded memory) = one render of the whole emission."""
    import importlib

    from auralize.emitters import render_emitters

    ar = importlib.import_module(
        "auralize_aero.render"
    )  # the package exports render() by that name

    motion = Motion.swing(duration=0.3, swings=1.0, rate_hz=200.0)
    path = ListenerPath.line((0.3, 1.0, 0.2), (-0.3, 1.5, 0.0), duration=0.3)
    part = emission(tex, stick(0.5, 0.01), motion=motion, duration=0.3)
    kw = {"rate": RATE, "block": ar.CONTROL_BLOCK}  # the control points render_part uses
    whole = render_emitters(part.emitters(), path, layout="ring8", **kw).audio
    ja, jb = part._window(path, 0.1, 0.15, 343.0)  # a window needs only the emission it hears
    assert 0.05 <= (jb - ja + 1) * part.kin.dt < 0.06
    monkeypatch.setattr(ar, "CHUNK_BYTES", 1)  # windows of 256 samples
    sound = Sound([part])
    windows = render_sound(sound, path, rate=RATE, layout="ring8").audio
    assert np.abs(whole).max() > 0
    np.testing.assert_allclose(windows, whole, rtol=0, atol=1e-9 * np.abs(whole).max())
    piece = render_sound(sound, path, rate=RATE, layout="ring8", start=0.1, duration=0.05).audio
    np.testing.assert_allclose(piece, whole[:, 4410:6615], rtol=0, atol=1e-9 * np.abs(whole).max())
    # binaural: the windows are AmbiX, the ears' filters run once over their sum
    amb = part.render_part(path, rate=RATE, layout="ambix1").audio
    amb_direct = render_emitters(part.emitters(), path, layout="ambix1", **kw).audio
    np.testing.assert_allclose(amb, amb_direct, rtol=0, atol=1e-9 * np.abs(amb_direct).max())
    ears = part.render_part(path, rate=RATE, layout="binaural").audio
    direct = render_emitters(part.emitters(), path, layout="binaural", **kw).audio
    assert ears.shape == direct.shape == (2, whole.shape[1])
    # the ears' filters turn rounding differences of the AmbiX sums into ~1e-7 of the peak
    np.testing.assert_allclose(ears, direct, rtol=0, atol=1e-6 * np.abs(direct).max())


def test_inputs_are_declared_not_a_volume() -> None:
    """The viewer and ``--model aero:FILE`` say why aero cannot make sound from a volume."""
    from auralize.errors import PluginError

    model = get_model("aero")
    assert model.input_kind not in ("", "volume") and "texture" in model.input_kind
    with pytest.raises(PluginError, match=r"cannot read its inputs \(a sound texture"):
        model.load_input("dataset:monopole")


@pytest.mark.parametrize(("layout", "bound"), [("mono", 5e-4), ("ring8", 2.5e-3)])
def test_render_error_against_a_finer_reference(
    tex: SoundTexture, layout: str, bound: float
) -> None:
    """The engine's render (control points every CONTROL_BLOCK samples) against every output
    sample's retarded time solved (numpy reference) on the emission sampled 4x finer."""
    import importlib

    from auralize.emitters.reference import render_reference

    ar = importlib.import_module("auralize_aero.render")
    obj = stick(0.5, 0.01)
    motion = Motion.swing(duration=0.3, swings=1.0, amplitude_deg=80.0, rate_hz=200.0)
    path = ListenerPath.point((0.3, 1.0, 0.2), duration=0.3)
    out = emission(tex, obj, motion=motion, duration=0.3).render_part(path, layout=layout).audio
    fine = emission(
        tex, obj, motion=motion, duration=0.3, rate=4 * RATE, block=4 * 32, engine="numpy"
    )  # the same kinematics grid, 4x the samples
    truth = render_reference(fine.emitters(), path, rate=RATE, layout=layout)
    peak = np.abs(truth).max()
    err = np.abs(out - truth) / peak
    assert peak > 0 and ar.CONTROL_BLOCK == 64
    assert err.max() < bound and np.sqrt(np.mean(err**2)) < bound / 10
