"""Fire through the sound engine: arrival D/c0, 1/D, Doppler of a moving listener, 3-D panning."""

from __future__ import annotations

import numpy as np
import pytest
from auralize_fire import FireSound, make_fire
from auralize_fire.model import MONOPOLE_1M, fire_sound, render_chain

from auralize.emitters import Emitters, Sound, render_sound
from auralize.listener import ListenerPath
from auralize.spatial import Speaker, make_layout
from auralize.volume import TimeVolume

RATE = 44100
C = 343.0


@pytest.fixture(scope="module")
def fire() -> tuple[TimeVolume, Sound]:
    vol = make_fire(size=12, steps=10, seed=0)
    return vol, FireSound().synthesize(vol, extend="bandwidth", seed=1)


def heard(em: Emitters, t: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Emitted pressure at the retarded time t − D/c0, over D (linear interpolation)."""
    ts = em.t0 + np.arange(em.n_samples) / em.rate
    return np.interp(t - D / C, ts, em.signals[0], left=0.0, right=0.0) / D


def test_emitter_is_the_chain_in_pascals_at_1m(fire) -> None:  # type: ignore[no-untyped-def]
    vol, snd = fire
    em = snd.parts[0]
    sig, fs = render_chain(vol, extend="bandwidth", seed=1)
    np.testing.assert_allclose(em.signals[0], sig * MONOPOLE_1M, rtol=1e-12)
    assert MONOPOLE_1M == pytest.approx(1.2 / (4 * np.pi))
    assert (
        snd.meta["emitter_units"] == "Pa at 1 m" and "units" not in snd.meta and em.name == "fire"
    )
    # the emitter sits at the front's area-weighted centre
    ok = fs.area > 0
    pos = em.positions[0] if em.moving else em.positions
    np.testing.assert_allclose(pos[0], fs.centroid[ok][0], atol=1e-12)
    later = fire_sound(vol, extend="none", t0=0.25).parts[0]
    assert later.t0 == 0.25


@pytest.mark.parametrize("D", [5.0, 20.0])
def test_static_listener_hears_the_fire_after_d_over_c0_at_one_over_d(fire, D: float) -> None:  # type: ignore[no-untyped-def]
    _, snd = fire
    em = snd.parts[0]
    x = em.positions[0, 0] if em.moving else em.positions[0]
    lis = x + np.array([0.0, -D, 0.0])
    dur = D / C + em.n_samples / em.rate + 0.005
    out = render_sound(snd, ListenerPath.point(lis, duration=dur), rate=RATE).audio[0]
    t = np.arange(out.size) / RATE
    ref = heard(em, t, np.full(out.size, D))
    assert np.abs(out).max() > 0
    np.testing.assert_allclose(out, ref, atol=1e-9 * np.abs(ref).max())
    # silence before the first arrival; the heard peak is the emitted peak over D
    assert np.all(out[t < D / C - 1.0 / RATE] == 0.0)
    assert np.abs(out).max() == pytest.approx(np.abs(em.signals).max() / D, rel=0.02)


def test_approaching_listener_hears_doppler(fire) -> None:  # type: ignore[no-untyped-def]
    """L(t) = x + (X0 − v t) ŷ: τ = t − (X0 − v t)/c0, so emitted time runs (1 + v/c0) times faster."""
    _, snd = fire
    em = snd.parts[0]
    x = em.positions[0, 0] if em.moving else em.positions[0]
    X0, v, dur = 10.0, 60.0, 0.06
    path = ListenerPath(np.array([0.0, dur]), np.stack([x + [0, X0, 0], x + [0, X0 - v * dur, 0]]))
    out = render_sound(snd, path, rate=RATE).audio[0]
    t = np.arange(out.size) / RATE
    D = X0 - v * t
    ref = heard(em, t, D)
    # the sampled backend interpolates the retarded time in 32-sample blocks (~1e-4 of the peak)
    np.testing.assert_allclose(out, ref, atol=3e-4 * np.abs(ref).max())
    # against a static listener the same emitted samples arrive (1 + v/c0) faster
    tau = t - D / C
    assert np.diff(tau).mean() * RATE == pytest.approx(1 + v / C, rel=1e-9)
    static = heard(em, t, np.full(t.size, X0))
    assert np.abs(out * D - static * X0).max() > 0.1 * np.abs(static * X0).max()


def test_fire_above_the_listener_goes_to_the_height_speakers(fire) -> None:  # type: ignore[no-untyped-def]
    spk = [Speaker(f"S{k}", 45.0 * k) for k in range(8)]
    spk += [Speaker(f"H{k}", 90.0 * k + 45.0, 45.0) for k in range(4)]
    dome = make_layout("dome", spk)
    _, snd = fire
    em = snd.parts[0]
    x = em.positions[0, 0] if em.moving else em.positions[0]
    below = ListenerPath.point(x - [0.0, 0.0, 3.0], duration=0.04)
    out = render_sound(snd, below, rate=RATE, layout=dome).audio
    e = (out**2).sum(axis=1)
    assert e[8:].sum() > 0.999 * e.sum()  # straight overhead: the height ring only
    # azimuth 135°, elevation 45°: speaker H1 (channel 9) for a listener facing +y
    d = np.array([-0.5, -0.5, np.sqrt(0.5)])  # world direction to the fire (left-behind, up)
    lis = x - 3.0 * d
    out = render_sound(snd, ListenerPath.point(lis, duration=0.04), rate=RATE, layout=dome).audio
    e = (out**2).sum(axis=1)
    assert e[9] > 0.99 * e.sum()


def test_a_moving_flame_is_a_moving_emitter() -> None:
    """A burning ball drifting along +x: the emitter follows the front's centre, sample by sample."""
    n, steps, dt = 14, 6, 1 / 360
    ax = np.linspace(-0.5, 0.5, n)
    z, y, x = np.meshgrid(ax, ax, ax, indexing="ij")
    burn = np.zeros((steps, n, n, n))
    vel = np.zeros((steps, n, n, n, 3))
    for k in range(steps):
        cx = -0.2 + 0.08 * k
        r2 = (x - cx) ** 2 + y**2 + z**2
        burn[k] = np.exp(-r2 / 0.02) * (1.0 + 0.1 * k)
        vel[k] = np.stack([x - cx, y, z], axis=-1) * (1.0 + 0.3 * np.sin(k))
    vol = TimeVolume.from_arrays(
        {"burn": burn, "velocity": vel},
        spacing=1.0 / (n - 1),
        origin=(-0.5, -0.5, -0.5),
        times=np.arange(steps) * dt,
    )
    snd = FireSound().synthesize(vol, extend="none", highpass_hz=0.0)
    em = snd.parts[0]
    assert em.moving and snd.meta["moving"]
    assert em.positions.shape == (1, em.n_samples, 3)
    xs = em.positions[0, :, 0]
    i = np.round(np.arange(steps) * dt * RATE).astype(int)
    i = i[i < em.n_samples]
    # the centre moves 0.08 m per step (front centroid of a sampled ball: a few mm off)
    np.testing.assert_allclose(xs[i], -0.2 + 0.08 * np.arange(i.size), atol=0.01)
    assert np.all(np.diff(xs) >= -1e-12)


def test_fire_and_spark_mix_along_one_path(fire) -> None:  # type: ignore[no-untyped-def]
    """A scene of two models: the mix is the sum of each rendered alone, on any layout."""
    from auralize_spark import SparkSound

    _, snd = fire
    spark = SparkSound().synthesize(None, preset="spark-balls", seed=3, t0=0.01)
    scene = snd + spark
    assert [type(p).__name__ for p in scene.parts] == ["Emitters", "DischargePart"]
    path = ListenerPath.line((0.3, -1.0, 0.2), (-0.3, -1.0, 0.2), duration=0.04, n=5)
    for lay in ("mono", "ring8"):
        mix = render_sound(scene, path, rate=RATE, layout=lay).audio
        alone = (
            render_sound(snd, path, rate=RATE, layout=lay).audio
            + render_sound(spark, path, rate=RATE, layout=lay).audio
        )
        assert np.abs(render_sound(spark, path, rate=RATE, layout=lay).audio).max() > 0
        np.testing.assert_allclose(mix, alone, atol=1e-12 * np.abs(mix).max())
