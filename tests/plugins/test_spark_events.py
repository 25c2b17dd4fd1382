"""Arrivals of impulsive emissions (auralize.emitters.events): analytic retarded times and panning."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.emitters.events import arrival_times, arrivals, as_path, sparse_gains
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial import Speaker, get_layout, make_layout, pan_gains

C = 343.0


def dome():  # type: ignore[no-untyped-def]
    spk = [Speaker(f"S{k}", 45.0 * k) for k in range(8)]
    spk += [Speaker(f"H{k}", 90.0 * k + 45.0, 45.0) for k in range(4)]
    return make_layout("dome", spk)


def test_static_listener_arrives_after_d_over_c0() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(-50, 50, size=(200, 3))
    tau = rng.uniform(0, 2, size=200)
    L = np.array([1.0, -2.0, 0.5])
    a = arrivals(x, tau, L, layout="ring8")
    D = np.linalg.norm(x - L, axis=1)
    np.testing.assert_allclose(a.time, tau + D / C, rtol=1e-13)
    np.testing.assert_allclose(a.distance, D, rtol=1e-13)
    np.testing.assert_allclose(a.direction, (L - x) / D[:, None], atol=1e-13)
    # static listener faces +y with +z up: local (forward, left, up) = (y, -x, z)
    u = a.direction
    np.testing.assert_allclose(
        a.direction_local, np.stack([u[:, 1], -u[:, 0], u[:, 2]], 1), atol=1e-13
    )
    # gains: the layout's own law on the direction the sound comes from
    assert a.gains is not None and a.gains.shape == (8, 200)
    np.testing.assert_allclose(
        a.gains, pan_gains(get_layout("ring8"), -a.direction_local), atol=1e-12
    )
    # a path with several captures standing still gives the same times
    path = ListenerPath(np.array([0.0, 0.7, 3.0, 9.0]), np.tile(L, (4, 1)))
    np.testing.assert_allclose(arrival_times(x, tau, path), tau + D / C, rtol=1e-13)
    np.testing.assert_array_equal(a.doppler, 1.0)


@pytest.mark.parametrize("n_captures", [2, 7, 50])
@pytest.mark.parametrize("v", [30.0, -60.0, 200.0])
def test_listener_moving_towards_the_source(n_captures: int, v: float) -> None:
    """L(t) = X0 − v t on the x axis, source at 0: t − τ = (X0 − v t)/c0 → t = (c0 τ + X0)/(c0 + v)."""
    X0, dur = 400.0, 2.0
    t_cap = np.linspace(0.0, dur, n_captures)
    pos = np.stack([X0 - v * t_cap, np.zeros(n_captures), np.zeros(n_captures)], 1)
    path = ListenerPath(t_cap, pos)
    tau = np.linspace(-1.0, 0.2, 25)  # every arrival inside the path
    a = arrivals(np.zeros((25, 3)), tau, path)
    t_exact = (C * tau + X0) / (C + v)
    assert np.all((t_exact > 0) & (t_exact < dur))
    np.testing.assert_allclose(a.time, t_exact, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a.distance, X0 - v * t_exact, rtol=1e-11)
    np.testing.assert_allclose(a.direction, np.tile([1.0, 0, 0], (25, 1)), atol=1e-12)
    # received spacing of equally spaced emissions: the Doppler factor c0/(c0 + v)
    np.testing.assert_allclose(np.diff(a.time), np.diff(tau) * C / (C + v), rtol=1e-9)
    np.testing.assert_allclose(a.doppler, C / (C + v), rtol=1e-12)


def test_curved_path_matches_brute_force_and_ends_are_held() -> None:
    """An orbit (piecewise linear, 10 Hz captures): t − τ − |L(t) − x|/c0 = 0 to rounding."""
    path = ListenerPath.orbit((0, 0, 0), radius=40.0, duration=2.0, rate_hz=10.0, height=3.0)
    rng = np.random.default_rng(1)
    x = rng.uniform(-20, 20, size=(300, 3))
    tau = rng.uniform(-0.5, 2.2, size=300)
    t = arrival_times(x, tau, path)
    L = path.position_at(path.times[0] + t)
    resid = t - tau - np.linalg.norm(L - x, axis=1) / C
    assert np.abs(resid).max() < 1e-12
    # before the first / after the last capture the listener stands at the end positions
    late = tau > 2.0
    assert np.any(late)
    np.testing.assert_allclose(
        t[late], tau[late] + np.linalg.norm(path.positions[-1] - x[late], axis=1) / C, rtol=1e-13
    )
    early = arrival_times(np.array([[0.0, 0, 0]]), np.array([-5.0]), path)
    assert early[0] == pytest.approx(-5.0 + np.linalg.norm(path.positions[0]) / C, rel=1e-13)


def test_turning_listener_directions_and_3d_gains() -> None:
    """An emission above the listener goes to the height speakers of a dome (3-D VBAP)."""
    lay = dome()
    # listener at the origin turning from facing +x to facing +y over 1 s
    path = ListenerPath(
        np.array([0.0, 1.0]),
        np.zeros((2, 3)),
        np.array([[1.0, 0, 0], [0.0, 1, 0]]),
        np.array([[0, 0, 1.0]] * 2),
    )
    d = np.array([np.cos(np.pi / 4) ** 2, np.cos(np.pi / 4) * np.sin(np.pi / 4), np.sin(np.pi / 4)])
    x = 34.3 * d  # 0.1 s away, azimuth 45°, elevation 45° in the world
    a = arrivals(x[None], np.array([-0.1]), path, layout=lay)
    assert a.time[0] == pytest.approx(0.0, abs=1e-12)  # arrives while facing +x
    assert a.gains is not None
    assert a.gains[8, 0] == pytest.approx(1.0, abs=1e-9)  # H0: azimuth 45°, elevation 45°
    np.testing.assert_allclose(a.direction_local[0], -d, atol=1e-12)
    # the same emission heard at t = 1 s (facing +y): from azimuth −45°, elevation 45° (H3)
    b = arrivals(x[None], np.array([0.9]), path, layout=lay)
    assert b.time[0] == pytest.approx(1.0, abs=1e-12)
    assert b.gains is not None and b.gains[11, 0] == pytest.approx(1.0, abs=1e-9)
    np.testing.assert_allclose(b.gains[:8, 0], 0.0, atol=1e-12)
    # straight above: the four height speakers equally, none of the ring
    c = arrivals(np.array([[0.0, 0, 10.0]]), np.zeros(1), path, layout=lay)
    assert c.gains is not None
    np.testing.assert_allclose(c.gains[8:, 0] ** 2, 0.25, atol=1e-12)
    np.testing.assert_allclose(c.gains[:8, 0], 0.0, atol=1e-12)


def test_sparse_gains_and_errors() -> None:
    g = pan_gains(dome(), np.random.default_rng(2).normal(size=(50, 3)))
    chans, gk = sparse_gains(g)
    assert chans.shape == gk.shape and chans.shape[1] <= 3
    dense = np.zeros_like(g)
    for k in range(chans.shape[1]):
        ok = chans[:, k] >= 0
        dense[chans[ok, k], np.flatnonzero(ok)] += gk[ok, k]
    np.testing.assert_array_equal(dense, g)
    ch1, g1 = sparse_gains(np.ones((1, 4)))
    assert ch1.shape == (4, 1) and np.all(ch1 == 0) and np.all(g1 == 1.0)
    with pytest.raises(ParameterError, match="E rows"):
        arrival_times(np.zeros((3, 3)), np.zeros(2), as_path(np.zeros(3)))
    with pytest.raises(ParameterError, match="finite"):
        arrival_times(np.full((1, 3), np.nan), np.zeros(1), as_path(np.zeros(3)))
    with pytest.raises(ParameterError, match="listener must be"):
        as_path(np.zeros(2))
