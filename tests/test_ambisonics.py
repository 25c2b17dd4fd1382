"""Ambisonics (AmbiX: ACN, SN3D): encoding against scipy, decoders checked by the energy vector."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auralize.errors import ParameterError
from auralize.spatial import Speaker, downmix_matrix, get_layout, make_layout, pan_gains
from auralize.spatial import ambisonics as A


def fibonacci(k: int) -> np.ndarray:
    i = np.arange(k) + 0.5
    z = 1 - 2 * i / k
    phi = np.pi * (1 + 5**0.5) * i
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


def unit(az_deg: float, el_deg: float = 0.0) -> np.ndarray:
    a, e = math.radians(az_deg), math.radians(el_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


@pytest.fixture(scope="module")
def dense() -> object:
    """60 speakers spread evenly over the sphere (a dense layout)."""
    p = fibonacci(60)
    sp = [
        Speaker(
            f"S{i}", float(np.degrees(np.arctan2(v[1], v[0]))), float(np.degrees(np.arcsin(v[2])))
        )
        for i, v in enumerate(p)
    ]
    return make_layout("fib60", sp)


def test_sh_match_scipy_in_ambix_convention() -> None:
    """Y_n^m = sqrt(4π/(2n+1)) × real orthonormal SH without the Condon–Shortley phase."""
    from scipy.special import sph_harm_y

    d = fibonacci(37)
    az, el = np.arctan2(d[:, 1], d[:, 0]), np.arcsin(d[:, 2])
    y = A.sh_gains(3, d)
    for n in range(4):
        for m in range(-n, n + 1):
            c = sph_harm_y(n, abs(m), np.pi / 2 - el, az) * (-1) ** abs(m)
            ref = {1: math.sqrt(2) * c.real, -1: math.sqrt(2) * c.imag, 0: c.real}[int(np.sign(m))]
            ref = ref * math.sqrt(4 * np.pi / (2 * n + 1))
            np.testing.assert_allclose(y[A.acn(n, m)], ref, atol=1e-12)


def test_acn_order_and_sn3d_level() -> None:
    # ACN 1 = Y (left), 2 = Z (up), 3 = X (front); W = 1 for a unit plane wave
    g = A.sh_gains(3, np.array([[0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0], [-0.3, 0.2, -0.9]]))
    np.testing.assert_allclose(g[0], 1.0)
    np.testing.assert_allclose(g[1:4, :3], np.eye(3), atol=1e-15)
    # SN3D: every order's components have unit power at their maxima, Σ_m Y² = 1
    n_of = A.acn_orders(3)
    for n in range(4):
        np.testing.assert_allclose(np.sum(g[n_of == n] ** 2, axis=0), 1.0, atol=1e-12)
    sig = np.sin(np.linspace(0, 20, 500))
    b = A.encode(sig, 3, unit(30, 10))
    np.testing.assert_allclose(b[0], sig)  # W carries the plane wave at its own level


def test_quadrature_orthogonality() -> None:
    d, w = A.sphere_quadrature()
    assert math.isclose(w.sum(), 4 * np.pi)
    y = A.sh_gains(3, d)
    n_of = A.acn_orders(3)
    np.testing.assert_allclose((y * w) @ y.T, np.diag(4 * np.pi / (2 * n_of + 1)), atol=1e-12)


def test_ambix_layouts_and_pan_gains() -> None:
    for n in (1, 2, 3):
        lay = get_layout(f"ambix{n}")
        assert lay.n_channels == (n + 1) ** 2 and lay.channel_mask is None
        assert lay.meta["ambisonic"] and lay.meta["order"] == n
        assert lay.meta["normalisation"] == "SN3D" and lay.meta["channel_order"] == "ACN"
        d = fibonacci(9)
        np.testing.assert_array_equal(pan_gains(lay, d), A.sh_gains(n, d))


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("method", ["allrad", "mode-matching"])
def test_energy_vector_points_back(dense: object, order: int, method: str) -> None:
    src = fibonacci(50)
    rng = np.random.default_rng(order)
    sig = rng.normal(size=256)
    for d in src:
        feeds = A.decode_ambisonics(A.encode(sig, order, d), order, dense, method=method)
        g = np.sqrt(np.sum(feeds**2, axis=1, keepdims=True))
        re = A.energy_vector(g, dense.directions())[0]  # type: ignore[attr-defined]
        ang = math.degrees(math.acos(min(1.0, float(re @ d) / np.linalg.norm(re))))
        assert ang < 5.0, (order, method, d, ang)
    # the spread shrinks with the order (|rE| → 1), max-rE's published |rE| for order N
    g = A.decoder_matrix(order, dense, method=method) @ A.sh_gains(order, src)
    r = np.linalg.norm(A.energy_vector(g, dense.directions()), axis=1)  # type: ignore[attr-defined]
    expect = math.cos(math.radians(137.9 / (order + 1.51)))
    assert np.all(np.abs(r - expect) < 0.03)


@pytest.mark.parametrize("method", ["allrad", "mode-matching"])
def test_decoder_energy_normalised(dense: object, method: str) -> None:
    g = A.decoder_matrix(3, dense, method=method) @ A.sh_gains(3, fibonacci(300))
    e = np.sum(g**2, axis=0)
    assert abs(e.mean() - 1) < 0.01 and e.min() > 0.95 and e.max() < 1.05


def ring8_pair_energy(order: int, weights: str, az_deg: np.ndarray) -> np.ndarray:
    dec = A.decoder_matrix(order, "ring8", weights=weights)
    g = dec @ A.sh_gains(order, np.stack([unit(a) for a in az_deg]))
    e = g**2 / np.sum(g**2, axis=0)
    k0 = (np.floor(az_deg / 45).astype(int)) % 8
    cols = np.arange(az_deg.size)
    return e[k0, cols] + e[(k0 + 1) % 8, cols]


def test_ring8_energy_in_the_two_speakers_around_the_source() -> None:
    """AllRAD, order 3, max-rE: ≥ 90 % in the two speakers around a source away from
    a speaker; a source on a speaker shares with both neighbours (86 % in two)."""
    between = np.arange(8) * 45.0 + 22.5
    assert ring8_pair_energy(3, "maxre", between).min() >= 0.98
    around = np.arange(0, 360, 2.5)
    off = np.abs(((around + 22.5) % 45) - 22.5) >= 10  # ≥ 10° from every speaker
    pair = ring8_pair_energy(3, "maxre", around)
    assert pair[off].min() >= 0.90
    assert pair.min() >= 0.85
    # lower orders spread more: order 1 cannot meet 90 % anywhere
    assert ring8_pair_energy(1, "maxre", between).max() < 0.7
    # on a speaker nearly everything stays on it and its two neighbours
    dec = A.decoder_matrix(3, "ring8")
    g = dec @ A.sh_gains(3, np.stack([unit(45 * k) for k in range(8)]))
    e = g**2 / np.sum(g**2, axis=0)
    for k in range(8):
        assert e[[k - 1, k, (k + 1) % 8], k].sum() > 0.99 and np.argmax(e[:, k]) == k


def test_decode_to_5_1_and_downmix_matrix() -> None:
    lay = get_layout("5.1")
    dec = A.decoder_matrix(3, lay)
    assert np.all(dec[3] == 0)  # LFE gets nothing
    np.testing.assert_array_equal(downmix_matrix("ambix3", "5.1"), dec)
    g = dec @ A.sh_gains(3, unit(-110)[None])
    assert int(np.argmax(g[:, 0] ** 2)) == 5  # BR
    # speakers to AmbiX: each speaker is a plane wave from its direction
    m = downmix_matrix("ring8", "ambix1")
    np.testing.assert_allclose(m, A.sh_gains(1, get_layout("ring8").directions()))
    np.testing.assert_array_equal(downmix_matrix("ambix3", "ambix1"), np.eye(4, 16))


def test_mode_matching_refuses_irregular_layouts() -> None:
    with pytest.raises(ParameterError, match="too irregular.*allrad"):
        A.decoder_matrix(1, "ring8", method="mode-matching")
    with pytest.raises(ParameterError, match="at least 16 speakers"):
        A.decoder_matrix(3, "ring8", method="mode-matching")
    with pytest.raises(ParameterError, match="binaural"):
        A.decoder_matrix(3, "binaural")
    with pytest.raises(ParameterError, match="shape \\(16, n\\)"):
        A.decode_ambisonics(np.zeros((9, 10)), 3, "ring8")
    with pytest.raises(ParameterError, match="order"):
        A.sh_gains(11, np.ones((1, 3)))


def test_reference_renderer_writes_ambix() -> None:
    """Every renderer that pans through pan_gains writes AmbiX: an emitter on the
    listener's left gives Y = W, X = Z = 0 (first order)."""
    from auralize.emitters import Emitters
    from auralize.emitters.engine import render_emitters
    from auralize.listener import ListenerPath

    rate = 8000
    sig = np.sin(2 * np.pi * 200 * np.arange(800) / rate)[None, :]
    path = ListenerPath.point((0, 0, 0), duration=0.1)  # forward +y, up +z: left is −x
    em = Emitters(sig, rate, np.array([[-3.0, 0.0, 0.0]]))
    out = render_emitters(em, path, rate=rate, layout="ambix1", backend="reference").audio
    assert out.shape == (4, 800) and np.max(np.abs(out[0])) > 0.1
    np.testing.assert_allclose(out[1], out[0], atol=1e-12)
    np.testing.assert_allclose(out[2:], 0.0, atol=1e-12)
