"""Tests of the vortex-sound plugin (paper 000): integral cells, texture physics, rendering."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from auralize_vortex import Texture, TextureConfig, VortexSound, compute_texture, texture
from auralize_vortex.datasets import make_fire_plume
from auralize_vortex.fluid import StableFluids, curl
from auralize_vortex.render import render_vortex, split_subvolumes, vortex_emitters
from auralize_vortex.texture import (
    howe_kernel,
    integral_cell_weights,
    receiver_ring,
    third_derivative,
)

from auralize.emitters import Emitters, Sound, render_sound
from auralize.errors import DataError, FieldError, FormatError, MissingFileError, ParameterError
from auralize.listener import ListenerPath
from auralize.spatial import Speaker, make_layout
from auralize.volume import TimeVolume

C0 = 343.0


# ---------------------------------------------------------------- integral cells (Eq. 4)
def test_integral_cell_weights_sum_to_one_per_voxel():
    offs, w = integral_cell_weights((5, 6, 7), alpha=3.0)
    assert offs.shape == (27, 3) and w.shape == (27, 5, 6, 7)
    np.testing.assert_allclose(w.sum(axis=0), 1.0, atol=1e-12)
    # interior voxel: Z = 1 + 6 e^-3 + 12 e^{-3√2} + 8 e^{-3√3}
    z = 1 + 6 * math.exp(-3) + 12 * math.exp(-3 * math.sqrt(2)) + 8 * math.exp(-3 * math.sqrt(3))
    assert w[0, 2, 3, 3] == pytest.approx(1 / z, rel=1e-12)
    face = int(np.flatnonzero(np.abs(offs).sum(1) == 1)[0])
    assert w[face, 2, 3, 3] == pytest.approx(math.exp(-3) / z, rel=1e-12)
    # a corner voxel belongs to 8 cells only
    assert np.count_nonzero(w[:, 0, 0, 0]) == 8


def test_sphere_average_of_howe_kernel_cancels_but_ring_does_not():
    rng = np.random.default_rng(1)
    om = rng.normal(size=(6, 6, 6, 3))
    sphere = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1.0]])
    # single-voxel box offsets are tiny vs 1 m: the 6-axis mean of x̂x̂ = I/3 and y·(y×ω) = 0
    gs = howe_kernel((6, 6, 6), 1e-3, sphere)
    gr = howe_kernel((6, 6, 6), 1e-3, receiver_ring(8))
    s_sphere = float(np.sum(gs * om))
    s_ring = float(np.sum(gr * om))
    assert abs(s_sphere) < 1e-5 * abs(s_ring)


def test_third_derivative_is_exact_for_cubics():
    t = np.arange(50) * 1e-3
    s = 2.0 * t**3 - t**2 + 5 * t
    np.testing.assert_allclose(third_derivative(s, 1e-3), 12.0, rtol=1e-6)


# ---------------------------------------------------------------- fluid solver (§5.1)
def test_projection_is_divergence_free_and_vorticity_matches_curl():
    fl = StableFluids((8, 6, 7), h=0.01, dt=1e-3)
    rng = np.random.default_rng(0)
    fl.u[:], fl.v[:], fl.w[:] = (
        rng.normal(size=fl.u.shape),
        rng.normal(size=fl.v.shape),
        rng.normal(size=fl.w.shape),
    )
    inflow = fl.w[0].copy()
    fl.project()
    assert np.max(np.abs(fl.divergence())) < 1e-9
    np.testing.assert_array_equal(fl.w[0], inflow)  # the inflow face is a boundary condition
    np.testing.assert_allclose(
        fl.vorticity(), curl(fl.cell_velocity(), 0.01, periodic_xy=True), atol=1e-9
    )


def test_uniform_inflow_stays_uniform():
    fl = StableFluids((6, 6, 6), h=0.02, dt=1e-3, eps0=0.3, speed_ref=2.0)
    fl.w[:] = 2.0
    for _ in range(20):
        fl.step()
    np.testing.assert_allclose(fl.w, 2.0, atol=1e-12)
    assert np.max(np.abs(fl.vorticity())) < 1e-9


# ---------------------------------------------------------------- textures (§5)
@pytest.fixture(scope="module")
def tex3() -> Texture:
    cfg = TextureConfig(speeds=(1.0, 2.0, 4.0), size=12, box_m=0.2, duration=0.3)
    return compute_texture(cfg)


def test_texture_rms_follows_u4_law(tex3):
    slope = np.polyfit(np.log(tex3.speeds), np.log(tex3.rms()), 1)[0]
    assert 3.0 <= slope <= 5.0
    assert tex3.rate == 1000.0 and tex3.n_samples == 300
    assert all(r["max_div_h_over_u"] < 1e-8 for r in tex3.meta["runs"])


def test_laminar_inflow_is_near_silent(tex3):
    lam = compute_texture(TextureConfig(speeds=(2.0,), size=12, duration=0.3, perturbation=0.0))
    assert lam.rms()[0] < 1e-6 * tex3.rms()[1]


def test_texture_is_deterministic_and_seeded():
    cfg = TextureConfig(speeds=(2.0,), size=8, duration=0.05)
    a, b = compute_texture(cfg), compute_texture(cfg)
    np.testing.assert_array_equal(a.pressure, b.pressure)
    c = compute_texture(TextureConfig(speeds=(2.0,), size=8, duration=0.05, seed=1))
    assert not np.allclose(a.pressure, c.pressure, rtol=1e-3, atol=0)


def test_paper_coefficient_is_c0_to_the_fourth_louder():
    h = compute_texture(TextureConfig(speeds=(2.0,), size=8, duration=0.05))
    p = compute_texture(TextureConfig(speeds=(2.0,), size=8, duration=0.05, coefficient="paper"))
    np.testing.assert_allclose(p.pressure, h.pressure * C0**4, rtol=1e-9)


def test_texture_cache_reuses_same_parameters(tmp_path):
    cfg = TextureConfig(speeds=(2.0, 3.0), size=8, duration=0.05)
    out = tmp_path / "tex.h5"
    t1, cached1 = texture(cfg, out)
    t2, cached2 = texture(cfg, out)
    assert (cached1, cached2) == (False, True)
    np.testing.assert_array_equal(t1.pressure, t2.pressure)
    with h5py.File(out) as f:
        assert f.attrs["auralize_format"] == "vortex-texture" and f.attrs["version"] == 1
        assert f.attrs["param_size"] == 8 and list(f["speeds"][()]) == [2.0, 3.0]
    _, cached3 = texture(TextureConfig(speeds=(2.0, 3.0), size=8, duration=0.05, seed=4), out)
    assert cached3 is False


def test_texture_default_cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("AURALIZE_CACHE_DIR", str(tmp_path))
    cfg = TextureConfig(speeds=(2.0,), size=8, duration=0.05)
    _, cached = texture(cfg)
    assert not cached and (tmp_path / f"vortex-texture-{cfg.digest()}.h5").is_file()
    assert texture(cfg)[1]


@pytest.mark.parametrize(
    ("speeds", "match"),
    [
        ((1.0, 1.0), "strictly increasing"),
        ((2.0, 1.0), "strictly increasing"),
        ((0.0, 1.0), "positive"),
        ((-1.0,), "positive"),
        ((), "at least one"),
    ],
)
def test_bad_speeds(speeds, match):
    with pytest.raises(ParameterError, match=match):
        TextureConfig(speeds=speeds)


def test_texture_from_another_version_is_rejected(tmp_path):
    tex = Texture([1.0, 2.0], np.ones((2, 16)), 1000.0, 0.2)
    p = tex.save(tmp_path / "t.h5")
    with h5py.File(p, "a") as f:
        f.attrs["version"] = 2
    with pytest.raises(FormatError, match="version 2; this auralize_vortex reads version 1"):
        Texture.load(p)
    with h5py.File(p, "a") as f:
        f.attrs["auralize_format"] = "volume"
    with pytest.raises(FormatError, match="not a vortex texture"):
        Texture.load(p)


# ---------------------------------------------------------------- rendering (§6, Eq. 5)
RATE = 8000


def _uniform_volume(u: float = 2.0, n: int = 5, steps: int = 3) -> TimeVolume:
    v = np.zeros((steps, n, n, n, 3))
    v[..., 2] = u
    return TimeVolume.from_arrays(
        {"velocity": v}, spacing=0.04, origin=-0.08, times=np.linspace(0, 1, steps)
    )


def _sine_texture(freq: float = 100.0) -> Texture:
    t = np.arange(1000) / 1000.0
    q = np.sin(2 * np.pi * freq * t)
    return Texture([1.0, 4.0], np.stack([q, 16 * q]), 1000.0, 0.2)


def _rms(x):
    return float(np.sqrt(np.mean(x**2)))


@pytest.mark.parametrize(("mode", "ratio"), [("physical", 0.5), ("paper", 0.125)])
def test_distance_law(mode, ratio):
    vol, tex = _uniform_volume(), _sine_texture()
    out = []
    for r in (10.0, 20.0):
        path = ListenerPath.point((0, -r, 0), duration=0.6)
        res = render_vortex(vol, path, tex, rate=RATE, attenuation=mode, blend=0.0)
        out.append(_rms(res.audio[0, int(0.1 * RATE) :]))
    assert out[1] / out[0] == pytest.approx(ratio, rel=0.05)


def test_amplitude_and_arrival_delay():
    vol = _uniform_volume(u=4.0)
    t = np.arange(1000) / 1000.0
    pulse = np.exp(-(((t - 0.3) / 0.01) ** 2))
    tex = Texture([1.0, 4.0], np.stack([pulse / 256, pulse]), 1000.0, 0.2)
    r = 34.3
    res = render_vortex(
        vol, ListenerPath.point((0, -r, 0), duration=0.6), tex, rate=RATE, offsets="zero", blend=0.0
    )
    a = res.audio[0]
    t_peak = np.argmax(a) / RATE
    assert t_peak == pytest.approx(0.3 + r / C0, abs=1.5 / RATE)
    # u = 4 reads the top row; the sub-volume is 5 points * 0.04 m = 0.2 m = the texture box
    assert a.max() == pytest.approx(1.0 / r, rel=0.02)


def test_speed_clamped_above_and_u4_below():
    tex = _sine_texture()
    path = ListenerPath.point((0, -10, 0), duration=0.5)
    top = _rms(render_vortex(_uniform_volume(4.0), path, tex, rate=RATE).audio)
    over = _rms(render_vortex(_uniform_volume(9.0), path, tex, rate=RATE).audio)
    low = _rms(render_vortex(_uniform_volume(0.5), path, tex, rate=RATE).audio)
    clamp = _rms(render_vortex(_uniform_volume(0.5), path, tex, rate=RATE, low_speed="clamp").audio)
    assert over == pytest.approx(top, rel=1e-6)
    assert low == pytest.approx(clamp * 0.5**4, rel=1e-3)
    assert top == pytest.approx(16 * clamp, rel=0.01)


def test_limit_pa_truncates():
    res = render_vortex(
        _uniform_volume(4.0),
        ListenerPath.point((0, -1, 0), duration=0.3),
        _sine_texture(),
        rate=RATE,
        limit_pa=1.0,
    )
    assert np.max(np.abs(res.audio)) == pytest.approx(1.0)


# ---------------------------------------------------------------- the model through the engine
def _pulse_texture() -> Texture:
    t = np.arange(1000) / 1000.0
    pulse = np.exp(-(((t - 0.3) / 0.01) ** 2))
    return Texture([1.0, 4.0], np.stack([pulse / 256, pulse]), 1000.0, 0.2)


def _arrival(a: np.ndarray) -> float:
    """Energy centroid (s) of the pulse in ``a`` (±50 ms around its peak): a symmetric
    pulse's centre, whatever symmetric interpolation the renderer used."""
    k = int(np.argmax(a))
    n = np.arange(k - 400, k + 400)
    w = a[n] ** 2
    return float(np.sum(n * w) / np.sum(w)) / RATE


@pytest.mark.parametrize("law", ["physical", "paper"])
def test_engine_arrival_is_distance_over_c0_and_amplitude_follows_the_law(law):
    vol = _uniform_volume(u=4.0)  # one sub-volume at the origin, as large as the texture box
    sound = VortexSound().synthesize(
        vol, texture=_pulse_texture(), offsets="zero", blend=0.0, attenuation=law
    )
    e = 1 if law == "physical" else 3
    for x in [(3.0, 4.0, 0.0), (0.0, 0.0, -20.0), (10.0, -24.0, 0.0)]:
        D = float(np.linalg.norm(x))
        a = render_sound(sound, ListenerPath.point(x, duration=0.5), rate=RATE).audio[0]
        # the texture's pulse is emitted at 0.3 s and heard D/c0 later, with amplitude 1/D^e
        assert _arrival(a) == pytest.approx(0.3 + D / C0, abs=0.01 / RATE)
        assert a.max() * D**e == pytest.approx(1.0, rel=2e-3)


def test_engine_doppler_of_an_approaching_listener():
    vol, tex = _uniform_volume(u=4.0), _sine_texture(100.0)
    sound = VortexSound().synthesize(vol, texture=tex, blend=0.0)
    v = C0 / 10
    moving = ListenerPath.line((0.0, -40.0, 0.0), (0.0, -40.0 + v, 0.0), duration=1.0)
    for path, f_expected in [
        (moving, 100.0 * (1 + v / C0)),
        (ListenerPath.point((0, -20, 0), duration=1.0), 100.0),
    ]:
        a = render_sound(sound, path, rate=RATE).audio[0, int(0.2 * RATE) : int(0.9 * RATE)]
        up = np.flatnonzero((a[:-1] < 0) & (a[1:] >= 0))
        t_up = (up + a[up] / (a[up] - a[up + 1])) / RATE  # upward zero crossings
        f = (t_up.size - 1) / (t_up[-1] - t_up[0])
        assert f == pytest.approx(f_expected, abs=0.2)


def test_subvolumes_as_large_as_the_texture_box_emit_its_own_samples():
    tex = _sine_texture(123.0)
    row = tex.pressure[1]  # u = 4 reads the top row
    em = vortex_emitters(_uniform_volume(4.0, n=10), tex, blend=0.0, lead=0.0123, seed=3)
    assert em.rate == tex.rate and em.n_emitters == 8 and em.t0 == -0.013
    body = em.signals[:, 40:-40]  # inside the edge fades
    n = np.arange(body.shape[1])
    for sig in body:  # a whole-sample offset into the looped texture, nothing interpolated
        errs = [np.max(np.abs(sig - row[(k + n) % row.size])) for k in range(row.size)]
        assert min(errs) < 1e-12 * np.max(np.abs(row))
    shifted = vortex_emitters(_uniform_volume(4.0, n=10), tex, blend=0.0, lead=0.0123, seed=4)
    assert not np.allclose(shifted.signals, em.signals)  # the seed moves the offsets


def _dome():
    spk = [Speaker(f"S{k}", 45.0 * k) for k in range(8)]
    spk += [Speaker(f"H{k}", 90.0 * k + 45.0, 45.0) for k in range(4)]
    return make_layout("dome", spk)


def test_engine_pans_a_subvolume_above_the_listener_to_the_height_speakers():
    vol, tex = _uniform_volume(u=4.0), _sine_texture()
    sound = VortexSound().synthesize(vol, texture=tex)
    # listener facing +x, +z up; the sub-volume (at the origin) 3.5 m away above-front-left,
    # in the direction of height speaker H0 (azimuth 45°, elevation 45°), then straight ahead
    c = np.cos(np.pi / 4)
    for d, ring8_ch, dome_ch in [
        (np.array([c * c, c * c, c]), 1, 8),
        (np.array([1.0, 0, 0]), 0, 0),
    ]:
        x = -3.5 * d
        path = ListenerPath(np.array([0.0, 0.3]), np.stack([x, x]), np.array([[1.0, 0, 0]] * 2))
        dome = render_sound(sound, path, rate=RATE, layout=_dome()).audio
        energy = np.sum(dome**2, axis=1)
        assert energy[dome_ch] / energy.sum() >= 0.99
        # a horizontal ring pans on the azimuth only (2-D VBAP)
        ring = render_sound(sound, path, rate=RATE, layout="ring8").audio
        energy = np.sum(ring**2, axis=1)
        assert energy[ring8_ch] / energy.sum() >= 0.99


def test_engine_backends_agree_on_a_moving_turning_listener(plume):
    tex = _sine_texture()
    c = plume.center
    path = ListenerPath(
        np.array([0.0, 0.1, 0.2]),
        np.array([c + [2.0, 0.5, -1.0], c + [1.0, 1.5, -0.5], c + [-0.5, 1.8, 0.2]]),
        np.array([[0.0, 1, 0], [-1, 1, 0.3], [-1, 0, 0.5]]),
    )
    # sub-volumes of 8 and 7 points: similarity-scaled, read between the texture's samples
    kw = dict(rate=RATE, layout="ring8", block=8, oversample=8)
    fast = render_vortex(plume, path, tex, **kw).audio
    ref = render_vortex(plume, path, tex, backend="reference", **kw).audio
    assert np.max(np.abs(ref)) > 0
    assert np.max(np.abs(fast - ref)) / np.max(np.abs(ref)) < 5e-3


def test_sound_limit_truncates_the_received_pressure_and_emission_has_soft_ends():
    sound = VortexSound().synthesize(_uniform_volume(4.0), texture=_sine_texture(), limit_pa=1.0)
    part = sound.parts[0]
    assert type(part).__name__ == "TruncatedEmitters" and sound.meta["limit_pa"] == 1.0
    two = render_sound(
        sound, ListenerPath.point((0, -0.5, 0), duration=0.3), rate=RATE, layout="stereo"
    )
    assert np.max(np.abs(two.audio)) == pytest.approx(1.0)
    free = render_sound(part.emitters, ListenerPath.point((0, -0.5, 0), duration=0.3), rate=RATE)
    assert np.max(np.abs(free.audio)) > 10.0  # 16 Pa at 1 m, 0.5 m away
    em = vortex_emitters(_uniform_volume(4.0), _sine_texture(), duration=0.5, lead=0.1)
    assert em.t0 == -0.1 and em.t_end == pytest.approx(0.5, abs=2 / em.rate)
    peak = np.max(np.abs(em.signals))
    assert np.max(np.abs(em.signals[:, [0, -1]])) < 0.01 * peak  # no click where emission stops
    one = _uniform_volume(4.0, steps=1)
    with pytest.raises(ParameterError, match="single time step; give the emission duration"):
        vortex_emitters(one, _sine_texture())
    assert vortex_emitters(one, _sine_texture(), duration=0.2, lead=0.0).t_end == pytest.approx(
        0.2, abs=2 / em.rate
    )


def test_no_data_points_are_left_out_of_the_subvolume_speeds():
    from auralize_vortex.render import subvolume_speeds

    v = np.zeros((2, 5, 5, 10, 3))
    v[..., 2] = 2.0
    v[:, :, :, 5:, 2] = 4.0
    v[:, 0, 0, 0] = np.nan  # a no-data point in the first sub-volume
    v[:, :, :, 5:] = np.nan  # the second sub-volume is all no-data
    vol = TimeVolume.from_arrays({"velocity": v}, spacing=0.04, times=[0.0, 1.0])
    vol.valid = np.all(np.isfinite(v[0]), axis=-1)  # as the readers mark them (nan="mask")
    sub = split_subvolumes(vol, 5)
    np.testing.assert_array_equal(subvolume_speeds(vol, sub), [[2.0, 0.0], [2.0, 0.0]])
    r = render_vortex(vol, ListenerPath.point((0, -1, 0), duration=0.2), _sine_texture(), rate=RATE)
    assert np.all(np.isfinite(r.audio)) and np.max(np.abs(r.audio)) > 0


def test_dataset_without_velocity_is_rejected():
    vol = TimeVolume.from_arrays({"density": np.ones((2, 4, 4, 4))}, times=[0, 1])
    with pytest.raises(FieldError, match=r"needs a velocity field 'velocity'.*velocity_field=NAME"):
        render_vortex(vol, ListenerPath.point((0, 0, 0), duration=0.1), _sine_texture())
    vol = TimeVolume.from_arrays({"velocity": np.ones((2, 4, 4, 4))}, times=[0, 1])
    with pytest.raises(DataError, match="is a scalar"):
        render_vortex(vol, ListenerPath.point((0, 0, 0), duration=0.1), _sine_texture())


def test_subvolumes_of_paper_fire_grid():
    vol = _uniform_volume(n=5)
    sub = split_subvolumes(vol, 5)
    assert sub.n_sources == 1
    np.testing.assert_allclose(sub.centres[0], [0.0, 0.0, 0.0], atol=1e-12)
    with pytest.raises(ParameterError, match="block must be a positive integer"):
        split_subvolumes(vol, 0)


# ---------------------------------------------------------------- dataset, model, overlay, CLI
@pytest.fixture(scope="module")
def plume() -> TimeVolume:
    return make_fire_plume(steps=10)


def test_fire_plume_dataset(plume):
    assert plume.dims == (15, 15, 20) and plume.is_vector("velocity")
    w = plume.fields["velocity"].array[..., 2]  # type: ignore[attr-defined]
    # incompressible with periodic sides: every horizontal layer carries the burner's flux
    layer = w.mean(axis=(2, 3))
    np.testing.assert_allclose(layer, layer[0, 0], rtol=1e-9)
    assert w.max() > 20 * layer[0, 0] > 0  # buoyancy accelerates the plume far above the inflow
    np.testing.assert_array_equal(w, make_fire_plume(steps=10).fields["velocity"].array[..., 2])  # type: ignore[attr-defined]
    assert "fire-plume" in VortexSound.datasets


def test_model_synthesize_and_ring8(plume, tmp_path):
    tex = _sine_texture()
    path = ListenerPath.point(plume.center + [0, -2, 0], duration=0.3)
    sound = VortexSound().synthesize(plume, texture=tex.save(tmp_path / "t.h5").as_posix())
    assert isinstance(sound, Sound) and len(sound.parts) == 1
    em = sound.parts[0]
    assert isinstance(em, Emitters) and em.n_emitters == 36 and em.positions.shape == (36, 3)
    assert (
        em.rate == tex.rate and em.t0 == -0.5
    )  # 5³ points of 0.04 m: the texture box and sound.meta["n_sources"] == 36
    # the data's 10 frames at 30 Hz are emitted (plus the lead), then the emitters fall silent
    assert em.t_end == pytest.approx(10 / 30, abs=2 / em.rate)
    mono = render_sound(sound, path, rate=RATE)
    assert mono.audio.shape == (1, int(0.3 * RATE)) and mono.meta["model"] == "vortex"
    # the mix is the sum of the sub-volumes rendered alone
    alone = sum(
        render_sound(
            Emitters(em.signals[i : i + 1], em.rate, em.positions[i : i + 1], t0=em.t0),
            path,
            rate=RATE,
        ).audio
        for i in range(0, 36, 7)
    )
    some = Emitters(em.signals[::7], em.rate, em.positions[::7], t0=em.t0)
    np.testing.assert_allclose(render_sound(some, path, rate=RATE).audio, alone, atol=1e-12)
    r8 = render_vortex(plume, path, tex, rate=RATE, layout="ring8")
    assert r8.audio.shape == (8, int(0.3 * RATE)) and r8.meta["n_sources"] == 36
    with pytest.raises(ParameterError, match="attenuation"):
        VortexSound().synthesize(plume, attenuation="cubic")
    with pytest.raises(ParameterError, match="listener path goes to"):
        VortexSound().synthesize((plume, path))


def test_model_loads_its_inputs_for_scenes(tmp_path):
    vol = VortexSound().load_input("dataset:fire-plume")
    assert vol.dims == (15, 15, 20) and vol.is_vector("velocity")
    f = tmp_path / "u.npz"
    with pytest.raises(MissingFileError, match="u.npz"):
        VortexSound().load_input(str(f))


def test_overlay_meshes(plume):
    meshes = VortexSound(isosurface="auto").overlay(plume, 5)
    boxes, centres, iso = meshes
    assert centres.n_points == 36 and boxes.n_cells == 36 * 6
    v = plume.frame("velocity", 5)
    assert centres.point_data["speed"].max() <= np.linalg.norm(v, axis=-1).max()
    assert centres.point_data["speed"].min() >= 0
    assert iso.n_points > 0


def test_cli_texture_and_render(tmp_path, capsys):
    from auralize.audio import read_wav
    from auralize.cli import main

    tex = tmp_path / "tex.h5"
    assert (
        main(
            [
                "vortex",
                "texture",
                "--speeds",
                "1,2",
                "-o",
                str(tex),
                "--size",
                "8",
                "--texture-duration",
                "0.2",
            ]
        )
        == 0
    )
    assert "computed" in capsys.readouterr().out
    # the old spelling --duration is a hidden, deprecated alias of --texture-duration
    assert (
        main(
            [
                "vortex",
                "texture",
                "--speeds",
                "1,2",
                "-o",
                str(tex),
                "--size",
                "8",
                "--duration",
                "0.2",
            ]
        )
        == 0
    )
    out, err = capsys.readouterr()
    assert "reused" in out and "--duration is deprecated; it is now --texture-duration" in err
    wav = tmp_path / "out.wav"
    assert (
        main(
            [
                "vortex",
                "render",
                "dataset:fire-plume",
                "--steps",
                "4",
                "--texture",
                str(tex),
                "--listener",
                "0.3,-2,0.4",
                "--duration",
                "0.2",
                "-o",
                str(wav),
                "--layout",
                "ring8",
                "--rate",
                "8000",
            ]
        )
        == 0
    )
    audio, rate, _ = read_wav(wav)
    assert audio.shape == (8, 1600) and rate == 8000
    # --duration with --path: that many seconds, shorter or longer than the path
    csv = tmp_path / "path.csv"
    ListenerPath.line((0.3, -2, 0.4), (0.5, -2, 0.4), duration=0.2).to_csv(csv)
    for seconds in (0.1, 0.3):
        wav = tmp_path / f"path{seconds}.wav"
        assert (
            main(
                [
                    "vortex",
                    "render",
                    "dataset:fire-plume",
                    "--steps",
                    "4",
                    "--texture",
                    str(tex),
                    "--path",
                    str(csv),
                    "--duration",
                    str(seconds),
                    "-o",
                    str(wav),
                    "--rate",
                    "8000",
                ]
            )
            == 0
        )
        assert read_wav(wav)[0].shape == (1, round(seconds * 8000))
    assert main(["vortex", "texture", "--speeds", "2,1", "-o", str(tmp_path / "x.h5")]) == 2
    assert "strictly increasing" in capsys.readouterr().err
    assert not (tmp_path / "x.h5").exists()
