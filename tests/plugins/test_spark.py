"""Spark-discharge and thunder plugin (paper 002): field, leaders, N-/WM-waves, strokes, CLI."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest
from auralize_spark import (
    PRESETS,
    ChargeScene,
    Discharge,
    LiveDischarges,
    SparkSound,
    WaveParams,
    continuous_discharges,
    emissions,
    field_from_volume,
    grow_leader,
    nwave_params,
    render_discharge,
    simulate,
    solve_field,
    stroke_times,
    wm_wave,
)
from auralize_spark._kernels import accumulate_wm, wm_antiderivative

from auralize.errors import DataError, FormatError, ParameterError
from auralize.listener import ListenerPath
from auralize.plugins import get_model
from auralize.volume import TimeVolume

C = 343.0
SIGMA0 = 0.524


def eq3(r: float, r0: float, ps0: float) -> float:
    return r0 * ps0 / (r * math.sqrt(1 + SIGMA0 * math.log(r / r0)))


def eq4(r: float, r0: float, T0: float) -> float:
    return T0 * math.sqrt(1 + SIGMA0 * math.log(r / r0))


def one_segment(half_length: float = 1e-3, axis: int = 0) -> Discharge:
    a = np.zeros(3)
    b = np.zeros(3)
    a[axis], b[axis] = -half_length, half_length
    return Discharge(np.stack([a, b]), [-1, 0], [True, True])


@pytest.fixture(scope="module")
def balls_field():  # type: ignore[no-untyped-def]
    return PRESETS["spark-balls"].field()


@pytest.fixture(scope="module")
def plasma_field():  # type: ignore[no-untyped-def]
    return PRESETS["plasma-ball"].field()


# ------------------------------------------------------------- Eqs. 3–4, 5
def test_nwave_params_follow_eq3_eq4() -> None:
    r = np.array([10.0, 100.0, 1000.0])
    ps, T = nwave_params(r, r0=10.0, ps0=1000.0, T0=500e-6)
    for k, rk in enumerate(r):
        assert ps[k] == pytest.approx(eq3(rk, 10.0, 1000.0), rel=1e-12)
        assert T[k] == pytest.approx(eq4(rk, 10.0, 500e-6), rel=1e-12)
    # published shape: at 10 r0 the duration grows by sqrt(1 + 0.524 ln 10) = 1.4855
    assert T[1] / T[0] == pytest.approx(1.48545, rel=1e-4)


@pytest.mark.parametrize("r", [0.5, 2.0])
def test_broadside_segment_is_the_nwave_of_eq3_eq4(r: float) -> None:
    """θ = 0: the WM-wave is an N-wave with peak p_s (Eq. 3) and half-duration T (Eq. 4)."""
    r0, ps0, T0, hl = 0.05, 500.0, 30e-6, 1e-3
    params = WaveParams(r0=r0, T0=T0, ps0=ps0, jitter=0.0)
    seg = one_segment(hl)
    lis = np.array([0.0, r, 0.0])  # on the segment's normal
    em = emissions(seg, lis, params=params)
    assert em.s[0] == pytest.approx(0.0, abs=1e-8)
    # the continuous wave, from the renderer's own coefficients
    t = np.linspace(em.t_center[0] - 3 * T0 * 3, em.t_center[0] + 3 * T0 * 3, 400_001)
    tau = C * (t - em.t_center[0]) / hl
    p = wm_wave(tau, float(em.s[0]), float(em.psi[0]), float(em.B[0]))
    nz = np.flatnonzero(p)
    half = 0.5 * (t[nz[-1]] - t[nz[0]])
    assert p.max() == pytest.approx(eq3(r, r0, ps0), rel=0.02)
    assert -p.min() == pytest.approx(eq3(r, r0, ps0), rel=0.02)
    assert half == pytest.approx(eq4(r, r0, T0), rel=0.02)
    assert p[nz[0]] > 0 > p[nz[-1]]  # compression first: an "N"
    # the rendered (box-filtered) buffer keeps the lobe areas exactly: p_s T / 2 each
    rate = 768_000
    out = render_discharge(seg, lis, params=params, rate=rate).audio[0]
    lobe = eq3(r, r0, ps0) * eq4(r, r0, T0) / 2
    assert out[out > 0].sum() / rate == pytest.approx(lobe, rel=0.02)
    assert out[out < 0].sum() / rate == pytest.approx(-lobe, rel=0.02)
    assert out.max() == pytest.approx(eq3(r, r0, ps0), rel=0.05)


def test_wm_branches_agree_at_s_equal_psi() -> None:
    psi, B = 0.3, 2.0
    tau = np.linspace(-1.0, 1.0, 20_001)
    at = wm_wave(tau, psi, psi, B)
    for eps in (1e-3, 1e-5):
        below = wm_wave(tau, psi * (1 - eps), psi, B)  # branch s < ψ
        above = wm_wave(tau, psi * (1 + eps), psi, B)  # branch s ≥ ψ
        scale = np.abs(at).max()
        assert np.abs(below - above).max() < 20 * eps * scale
        assert np.abs(below - at).max() < 20 * eps * scale
    # s = ψ: two smoothly joined parabolas, continuous at τ = 0
    assert wm_wave(np.array([-1e-9, 1e-9]), psi, psi, B) == pytest.approx([0.0, 0.0], abs=1e-7)
    # and each branch is continuous inside (no jumps for s > 0)
    for s in (0.1, 0.6):
        p = wm_wave(tau, s, psi, B)
        assert np.abs(np.diff(p)).max() < 1e-3 * 4 * B * psi * 10


def test_large_theta_splits_into_two_pulses() -> None:
    """Fig. 7: beyond s = ψ the wave splits into two separate pulses of opposite sign."""
    psi, B = 0.2, 1.0
    for s in (0.5, 0.9):
        tau = np.linspace(-1.5, 1.5, 300_001)
        p = wm_wave(tau, s, psi, B)
        gap = (tau > psi - s + 1e-9) & (tau < s - psi - 1e-9)
        assert np.all(p[gap] == 0.0)
        assert np.all(p[(tau > -psi - s) & (tau < psi - s)] > 0)
        assert np.all(p[(tau > s - psi) & (tau < psi + s)] < 0)
        dtau = tau[1] - tau[0]
        assert p[p > 0].sum() * dtau == pytest.approx(-p[p < 0].sum() * dtau, rel=1e-4)
        # pulse width 2ψ, separation 2s
        pos = tau[p > 1e-12 * B]
        assert pos[-1] - pos[0] == pytest.approx(2 * psi, abs=2 * dtau)
    # wider angle (larger s) → lower peak: the wave gets rounder (Fig. 10)
    peaks = [wm_wave(np.linspace(-2, 2, 40_001), s, psi, B).max() for s in (0.0, 0.1, 0.3, 0.8)]
    assert all(a > b for a, b in itertools.pairwise(peaks))


def test_box_filtered_kernel_matches_the_antiderivative() -> None:
    """Each sample = (F(τ_hi) − F(τ_lo)) / Δτ with F the exact integral of Eq. 5."""
    rate, hl = 44100.0, 1.5
    for s, psi in ((0.05, 0.3), (0.3, 0.3), (0.8, 0.25), (1e-9, 0.3)):
        B = 1.7
        out = np.zeros((1, 1000))
        tc = 500 / rate + 0.3 / rate
        accumulate_wm(
            out,
            np.array([tc]),
            np.array([hl]),
            np.array([s]),
            np.array([psi]),
            np.array([B]),
            np.zeros((1, 1), np.int64),
            np.ones((1, 1)),
            rate,
            C,
        )
        n = np.arange(1000)
        lo = C * ((n - 0.5) / rate - tc) / hl
        hi = C * ((n + 0.5) / rate - tc) / hl
        ref = np.array(
            [
                wm_antiderivative(b, s, psi, B) - wm_antiderivative(a, s, psi, B)
                for a, b in zip(lo, hi, strict=True)
            ]
        ) / (hi - lo)
        np.testing.assert_allclose(out[0], ref, atol=1e-9 * 4 * B * psi)
        # F integrates the pointwise wave
        tau = np.linspace(-2, 2, 200_001)
        p = wm_wave(tau, s, psi, B)
        cum = np.concatenate([[0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(tau))])
        F = np.array([wm_antiderivative(x, s, psi, B) for x in tau[::1000]])
        np.testing.assert_allclose(
            F, cum[::1000], atol=4 * B * psi * 2e-5
        )  # trapezoid across a jump
        assert out[0].sum() == pytest.approx(0.0, abs=1e-9)  # an N-wave has no net area


def test_arrival_time_is_r_over_c() -> None:
    params = WaveParams(r0=0.05, T0=30e-6, ps0=500.0, jitter=0.0)
    rate = 384_000
    for r in (3.43, 6.86):
        out = render_discharge(
            one_segment(), np.array([0.0, r, 0.0]), params=params, rate=rate
        ).audio[0]
        nz = np.flatnonzero(np.abs(out) > 1e-9 * np.abs(out).max())
        # the N-wave is antisymmetric about its centre: the zero crossing is the arrival r/c
        mid = nz[0] + np.flatnonzero(out[nz[0] :] < 0)[0]
        t_cross = (mid - 0.5) / rate
        assert t_cross == pytest.approx(r / C, abs=1.5 / rate)
    # every emission's centre arrives at t_emit + r/c, for every stroke
    d = Discharge(np.array([[0, 0, 0], [0, 0, 1.0], [0, 0, 2.0]]), [-1, 0, 1], [True] * 3)
    lis = np.array([10.0, 0.0, 0.0])
    em = emissions(d, lis, params=params, strokes=np.array([0.0, 0.04]))
    r = np.linalg.norm(lis - d.midpoints[em.seg], axis=1)
    np.testing.assert_allclose(em.t_center, np.array([0.0, 0.04])[em.stroke] + r / C, rtol=1e-12)


def test_listener_on_a_segment_is_clamped_to_r0() -> None:
    params = WaveParams(r0=0.05, T0=30e-6, ps0=500.0, jitter=0.0)
    out = render_discharge(one_segment(), np.zeros(3), params=params, rate=192_000)
    assert np.all(np.isfinite(out.audio))
    assert out.meta["clamped_segments"] == 1
    # within r0 the level is the one at r0 (Eq. 3 is not extrapolated inwards)
    assert np.abs(out.audio).max() <= 500.0 * 1.001


# ------------------------------------------------------------ field (Eq. 1)
def test_laplace_between_plates_is_linear() -> None:
    sc = ChargeScene.from_dict(
        {
            "grid": {"dims": [21, 6, 5], "spacing": [0.01, 0.02, 0.03]},
            "charges": [
                {"shape": "plane", "axis": "x", "position": 0.0, "sign": "negative"},
                {"shape": "plane", "axis": "x", "position": 0.2, "sign": "positive"},
            ],
        }
    )
    f = solve_field(sc, tol=1e-8)
    np.testing.assert_allclose(f.phi[2, 3, :], np.linspace(0, 1, 21), atol=1e-5)
    assert f.info["converged"] and f.info["residual"] < 1e-6


def test_laplace_spherical_capacitor_and_custom_potentials() -> None:
    """Concentric spheres: φ(r) = (1/a − 1/r)/(1/a − 1/b) (analytic), potentials in volts rescaled."""
    n, h = 49, 1.0 / 48
    c = [0.5, 0.5, 0.5]
    # outer shell: a box held at +1000 V everywhere outside radius b (the solid region)
    sc = ChargeScene.from_dict(
        {
            "grid": {"dims": [n, n, n], "spacing": h},
            "boundary": 1000.0,
            "charges": [
                {
                    "shape": "sphere",
                    "center": c,
                    "radius": 0.1,
                    "sign": "negative",
                    "potential": -1000.0,
                }
            ],
        }
    )
    sign, value = sc.rasterize()
    X = np.arange(n) * h - 0.5
    R = np.sqrt(X[:, None, None] ** 2 + X[None, :, None] ** 2 + X[None, None, :] ** 2)
    b = 0.45
    sign[R >= b] = 1
    value[R >= b] = 1000.0
    from auralize_spark.field import solve_laplace

    phi, info = solve_laplace(sign != 0, (value + 1000) / 2000, spacing=h, boundary=1.0, tol=1e-7)
    a = 0.1
    ring = (R > 0.2) & (R < 0.35)
    exact = (1 / a - 1 / R[ring]) / (1 / a - 1 / b)
    # a staircase sphere on a 48³ grid: a few per cent
    assert np.abs(phi[ring] - exact).max() < 0.05
    assert np.abs(phi[ring] - exact).mean() < 0.02
    # the scene's own normalisation maps -1000 V → 0 and +1000 V (boundary) → 1
    with pytest.raises(DataError, match="no positive charge"):
        solve_field(sc)


def test_scene_errors_are_clear(tmp_path) -> None:  # type: ignore[no-untyped-def]
    grid = {"dims": [8, 8, 8], "spacing": 0.01}
    with pytest.raises(DataError, match="no positive charge"):
        solve_field(
            ChargeScene.from_dict(
                {
                    "grid": grid,
                    "charges": [
                        {"shape": "point", "position": [0.02, 0.02, 0.02], "sign": "negative"}
                    ],
                }
            )
        )
    with pytest.raises(DataError, match="no negative charge"):
        solve_field(
            ChargeScene.from_dict(
                {
                    "grid": grid,
                    "charges": [
                        {"shape": "point", "position": [0.02, 0.02, 0.02], "sign": "positive"}
                    ],
                }
            )
        )
    with pytest.raises(FormatError, match="valid shapes"):
        ChargeScene.from_dict({"grid": grid, "charges": [{"shape": "cone", "sign": "negative"}]})
    with pytest.raises(FormatError, match="sign must be"):
        ChargeScene.from_dict(
            {
                "grid": grid,
                "charges": [{"shape": "point", "position": [0, 0, 0], "sign": "neutral"}],
            }
        )
    with pytest.raises(DataError, match="outside the grid"):
        ChargeScene.from_dict(
            {
                "grid": grid,
                "charges": [
                    {"shape": "sphere", "center": [5, 5, 5], "radius": 0.01, "sign": "negative"}
                ],
            }
        ).rasterize()
    bad = tmp_path / "scene.toml"
    bad.write_text("grid = [")
    with pytest.raises(FormatError, match="cannot parse scene"):
        ChargeScene.from_file(bad)
    with pytest.raises(FormatError, match="does not exist"):
        ChargeScene.from_file(tmp_path / "missing.json")


def test_toml_scene_and_volume_charge_field(tmp_path) -> None:  # type: ignore[no-untyped-def]
    toml = tmp_path / "gap.toml"
    toml.write_text(
        "[grid]\ndims = [24, 12, 12]\nspacing = 0.002\n\n"
        '[[charges]]\nshape = "sphere"\ncenter = [0.008, 0.011, 0.011]\nradius = 0.004\nsign = "negative"\n\n'
        '[[charges]]\nshape = "box"\nmin = [0.04, 0.0, 0.0]\nmax = [0.046, 0.022, 0.022]\nsign = "positive"\n'
    )
    f = solve_field(ChargeScene.from_file(toml))
    assert f.phi.shape == (12, 12, 24)
    # the same charges as a TimeVolume field
    q = np.zeros((1, 12, 12, 24))
    q[0][f.sign < 0] = -1.0
    q[0][f.sign > 0] = 2.0
    vol = TimeVolume.from_arrays({"charge": q}, spacing=0.002)
    g = field_from_volume(vol)
    np.testing.assert_allclose(g.phi, f.phi, atol=1e-4)
    from auralize.errors import FieldError

    with pytest.raises(FieldError, match="no field 'rho'"):
        field_from_volume(vol, name="rho")


# ------------------------------------------------------ leader (§4.1, Eq. 2)
def test_leader_reaches_the_positive_charge(balls_field) -> None:  # type: ignore[no-untyped-def]
    d = grow_leader(balls_field, half_length=1e-3, seed=4, branch_probability=0.5, branch_length=10)
    main_nodes = np.flatnonzero(d.main)
    tip = d.nodes[main_nodes[-1]]
    # the strike point is on the positive ball (centre (0.02, 0, 0), radius 1 cm)
    assert np.linalg.norm(tip - [0.02, 0, 0]) <= 0.01 + 0.00125
    assert np.linalg.norm(d.nodes[0] - [-0.02, 0, 0]) <= 0.01 + 0.00125
    # the main channel is a connected path from the root; steps are 2l long
    assert d.main[0] and d.seg_main.sum() == main_nodes.size - 1
    np.testing.assert_allclose(d.half_lengths[:-1][d.parent[1:-1] >= 0][:5], 1e-3, rtol=1e-9)
    assert d.main_length() >= 0.02 * 0.95  # no shorter than the 2 cm gap


def test_branching_falls_as_gamma_grows(plasma_field) -> None:  # type: ignore[no-untyped-def]
    """Eq. 2: larger γ concentrates u on the best candidate → fewer branches, straighter paths."""

    def stats(gamma: float) -> tuple[float, float]:
        br, tort = [], []
        for seed in range(6):
            d = grow_leader(
                plasma_field,
                half_length=1e-2,
                gamma=gamma,
                seed=seed,
                branch_probability=0.3,
                branch_length=3,
            )
            br.append(d.meta["branches_started"] / max(d.seg_main.sum(), 1))
            tort.append(d.main_length() / d.meta["straight_distance"])
        return float(np.mean(br)), float(np.mean(tort))

    b_low, t_low = stats(0.5)
    b_high, t_high = stats(8.0)
    assert b_low > 1.5 * b_high
    assert t_low > t_high


def test_leader_is_seeded_and_unreachable_targets_fail(plasma_field) -> None:  # type: ignore[no-untyped-def]
    a = grow_leader(plasma_field, half_length=1e-2, seed=11)
    b = grow_leader(plasma_field, half_length=1e-2, seed=11)
    c = grow_leader(plasma_field, half_length=1e-2, seed=12)
    np.testing.assert_array_equal(a.nodes, b.nodes)
    assert a.nodes.shape != c.nodes.shape or not np.array_equal(a.nodes, c.nodes)
    with pytest.raises(DataError, match="did not reach the positive charge within 3 segments"):
        grow_leader(plasma_field, half_length=1e-3, max_segments=3, branch_probability=0)
    # a positive point sealed inside a negative shell: no free path to it
    q = np.zeros((1, 9, 9, 9))
    q[0, 2:7, 2:7, 2:7] = -1
    q[0, 4, 4, 4] = 1
    vol = TimeVolume.from_arrays({"charge": q}, spacing=0.01)
    with pytest.raises(DataError, match="unreachable"):
        grow_leader(field_from_volume(vol), half_length=0.005)
    with pytest.raises(ParameterError, match="gamma must be >= 0"):
        grow_leader(plasma_field, half_length=1e-2, gamma=-1)


# --------------------------------------------------------- discharge CSV
def test_discharge_csv_roundtrip_and_polyline(tmp_path) -> None:  # type: ignore[no-untyped-def]
    d = grow_leader(PRESETS["plasma-ball"].field(), half_length=1e-2, seed=2)
    p = tmp_path / "tree.csv"
    d.to_csv(p)
    e = Discharge.from_csv(p)
    np.testing.assert_allclose(e.nodes, d.nodes, rtol=1e-8)
    np.testing.assert_array_equal(e.parent, d.parent)
    np.testing.assert_array_equal(e.main, d.main)
    poly = tmp_path / "line.csv"
    poly.write_text("x,y,z\n0,0,0\n0,0,0.1\n0.02,0,0.2\n")
    res = simulate(str(poly), np.array([1.0, 0, 0.1]), preset="plasma-ball", seed=0)
    # segments longer than 2l = 2 cm are split: 10 + ceil(0.102/0.02) pieces
    assert res.discharge.n_segments == 5 + 6
    assert res.discharge.main.all()
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(FormatError, match="header must be"):
        Discharge.from_csv(bad)
    loop = tmp_path / "two_roots.csv"
    loop.write_text("id,parent,x,y,z\n0,-1,0,0,0\n1,-1,1,0,0\n")
    with pytest.raises(FormatError, match="exactly one root"):
        Discharge.from_csv(loop)


# ---------------------------------------------------------- strokes §4.2.3
def test_stroke_statistics_follow_the_stated_distributions() -> None:
    rng = np.random.default_rng(5)
    flashes = [stroke_times(rng) for _ in range(4000)]
    n = np.array([f.size for f in flashes])
    p = 0.85
    pmf = lambda k: -(p**k) / (k * math.log(1 - p))  # noqa: E731
    assert np.mean(n == 1) == pytest.approx(pmf(1), abs=0.025)  # 0.448: mostly single
    assert np.mean((n >= 4) & (n <= 6)) == pytest.approx(sum(pmf(k) for k in (4, 5, 6)), abs=0.02)
    assert n.mean() == pytest.approx(-p / ((1 - p) * math.log(1 - p)), rel=0.08)  # 2.99
    gaps = np.concatenate([np.diff(f) for f in flashes])
    assert gaps.min() >= 0.010 - 1e-12 and gaps.max() <= 0.240 + 1e-12
    assert gaps.mean() == pytest.approx(0.040, rel=0.05)
    vals, counts = np.unique(np.round(gaps, 3), return_counts=True)
    assert vals[np.argmax(counts)] in (0.03, 0.04)  # typically ~40 ms
    assert stroke_times(np.random.default_rng(0), n=3).size == 3
    with pytest.raises(ParameterError, match="at least 1 stroke"):
        stroke_times(rng, n=0)


def test_later_strokes_sound_along_the_main_channel_only() -> None:
    d = grow_leader(
        PRESETS["spark-balls"].field(),
        half_length=1e-3,
        seed=3,
        branch_probability=0.5,
        branch_length=10,
    )
    res = simulate(d, np.array([0, -0.5, 0]), preset="spark-balls", strokes=3, seed=1)
    meta = res.rendered.meta
    assert meta["strokes"] == 3
    assert meta["emissions"] == d.n_segments + 2 * int(d.seg_main.sum())


# ----------------------------------------------------- presets and output
def test_same_seed_same_sound_and_presets() -> None:
    a = simulate(preset="plasma-ball", seed=9).rendered.audio
    b = simulate(preset="plasma-ball", seed=9).rendered.audio
    c = simulate(preset="plasma-ball", seed=10).rendered.audio
    np.testing.assert_array_equal(a, b)
    assert a.shape != c.shape or not np.array_equal(a, c)
    for name, (hl, r0, T0) in {
        "spark-balls": (1e-3, 0.05, 30e-6),
        "plasma-ball": (1e-2, 0.1, 40e-6),
        "lightning": (1.5, 10.0, 500e-6),
    }.items():
        pre = PRESETS[name]
        assert (pre.half_length, pre.r0, pre.T0) == (hl, r0, T0)  # Table 1
    assert PRESETS["lightning"].path_m == 5000.0


def test_segments_are_panned_by_position() -> None:
    """A segment to the listener's left (azimuth +90°) lands on ring8 channel 2."""
    d = Discharge(np.array([[-5.0, 0, -0.001], [-5.0, 0, 0.001]]), [-1, 0], [True, True])
    res = simulate(d, np.zeros(3), preset="spark-balls", layout="ring8", rate=96_000)
    e = (res.rendered.audio**2).sum(axis=1)
    assert np.argmax(e) == 2 and e[2] > 0.999 * e.sum()
    mono = res.render("mono").audio[0]
    np.testing.assert_allclose(
        res.rendered.audio.sum(axis=0), mono, atol=1e-12 * np.abs(mono).max()
    )
    # a moving listener: the retarded arrival time uses the listener's position at arrival
    path = ListenerPath.line((0, 0, 0), (3.43, 0, 0), duration=1.0, face="fixed")
    em = emissions(d, path, params=WaveParams(r0=0.05, T0=30e-6, ps0=500.0))
    x = path.position_at(em.t_center)[0]
    assert em.t_center[0] == pytest.approx(np.linalg.norm(x - [-5.0, 0, 0]) / C, rel=1e-9)


# ----------------------------------------------------------- §4.2.1, §4.2.4
def test_async_generation_reports_late_delivery() -> None:
    params = WaveParams(r0=0.05, T0=30e-6, ps0=500.0, jitter=0.0)
    d = grow_leader(PRESETS["spark-balls"].field(), half_length=1e-3, seed=1)
    with LiveDischarges(np.array([0.0, 34.3, 0.0]), params=params, rate=44100) as live:
        rep = live.submit(d, at=0.0).result(timeout=30)
        assert not rep.exceeded and rep.late_s == 0.0
        assert rep.propagation_s == pytest.approx(0.1, rel=0.02)  # 34.3 m / c
        audio = live.pull(int(0.2 * 44100))
        first = np.flatnonzero(np.abs(audio[0]) > 0)[0]
        assert first / 44100 == pytest.approx(rep.propagation_s, abs=2 / 44100)
    # a listener 3 mm away: propagation (~9 µs) is shorter than any computation
    with LiveDischarges(np.array([0.0, 0.003, 0.0]), params=params, rate=44100) as live:
        rep = live.submit(d).result(timeout=30)
        assert rep.exceeded and rep.late_s > 0
        assert rep.compute_s > rep.propagation_s


def test_continuous_discharges_reuse_until_the_field_changes() -> None:
    calls = []

    def make(k: int) -> np.ndarray:
        calls.append(k)
        return simulate(preset="plasma-ball", seed=k).rendered.audio

    state = lambda t: np.array([1.0, 0.0]) if t < 0.5 else np.array([1.0, 0.5])  # noqa: E731
    res = continuous_discharges(make, state, duration=1.0, seed=3)
    gaps = np.diff(res.times)
    assert gaps.min() >= 0.010 and gaps.max() <= 0.050
    assert res.regenerated.sum() == 2 and calls == [0, 1]  # first, and once after the change
    assert res.regenerated[0] and res.regenerated[np.argmax(res.times >= 0.5)]
    # the repeats are copies of the same waveform (short plasma-ball clicks do not overlap)
    w = simulate(preset="plasma-ball", seed=0).rendered.audio[0]
    for t in res.times[1:4]:
        n = int(round(t * 44100))
        np.testing.assert_allclose(res.audio[0, n : n + w.size], w, atol=1e-12)
    with pytest.raises(ParameterError, match="interval_s"):
        continuous_discharges(make, state, duration=1.0, interval_s=(0.05, 0.01))


# ------------------------------------------------ plugin, overlay and CLI
def test_registered_model_and_overlay_off_screen() -> None:
    import pyvista as pv

    from auralize.emitters import Sound, render_sound

    model = get_model("spark")
    assert isinstance(model, SparkSound)
    snd = model.synthesize(None, preset="plasma-ball", seed=2)
    assert isinstance(snd, Sound) and len(snd.parts) == 1 and "audio" not in snd.meta
    assert snd.meta["segments"] == snd.parts[0].discharge.n_segments
    # the engine renders the part: the same sound as the end-to-end simulation
    lis = np.array([0.3, -1.0, 0.0])
    res = simulate(None, lis, preset="plasma-ball", seed=2, layout="ring8")
    path = ListenerPath.point(lis, duration=res.rendered.duration)
    out = render_sound(snd, path, layout="ring8")
    assert out.audio.shape == res.rendered.audio.shape and out.meta["parts"][0]["model"] == "spark"
    np.testing.assert_allclose(out.audio, res.rendered.audio, atol=1e-12 * np.abs(out.audio).max())
    with pytest.raises(ParameterError, match="preset"):
        model.synthesize(None, preset="volcano")
    with pytest.raises(ParameterError, match="without a listener"):
        model.synthesize((None, lis))
    blocks = model.overlay((None, None, {"preset": "spark-balls", "seed": 2, "strokes": 3}), 0)
    lines = blocks["discharge"]
    d = simulate(preset="spark-balls", seed=2, strokes=3).discharge
    assert lines.n_cells == d.n_segments
    br = np.asarray(lines.cell_data["brightness"])
    np.testing.assert_allclose(br[d.seg_main], 1.0)
    np.testing.assert_allclose(br[~d.seg_main], 0.5 / 3)
    charges = blocks["charges"]
    signs = sorted(int(charges[k].point_data["sign"][0]) for k in charges.keys())
    assert signs == [-1, 1]
    pl = pv.Plotter(off_screen=True, window_size=(160, 120))
    pl.add_mesh(lines, scalars="brightness", cmap="bone")
    for k in charges.keys():
        pl.add_mesh(charges[k], scalars="sign", cmap="coolwarm")
    img = pl.screenshot(return_img=True)
    pl.close()
    assert img.shape == (120, 160, 3) and img.max() > 0


def test_cli_render_json_and_errors(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from auralize.audio import read_wav
    from auralize.cli import main

    out = tmp_path / "spark.wav"
    rc = main(
        [
            "spark",
            "render",
            "--preset",
            "spark-balls",
            "--listener",
            "0,-0.5,0",
            "-o",
            str(out),
            "--seed",
            "4",
            "--strokes",
            "2",
            "--layout",
            "ring8",
            "--json",
            "--save-discharge",
            str(tmp_path / "d.csv"),
        ]
    )
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert info["strokes"] == 2 and info["segments"] > 0 and "waveform" in info["timing_s"]
    audio, rate, _ = read_wav(out)
    assert audio.shape[0] == 8 and rate == 44100
    assert (tmp_path / "spark.wav.json").exists()
    # the saved discharge renders the same sound
    out2 = tmp_path / "again.wav"
    assert (
        main(
            [
                "spark",
                "render",
                "--preset",
                "spark-balls",
                "--discharge",
                str(tmp_path / "d.csv"),
                "--listener",
                "0,-0.5,0",
                "-o",
                str(out2),
                "--seed",
                "4",
                "--strokes",
                "2",
                "--layout",
                "ring8",
            ]
        )
        == 0
    )
    np.testing.assert_allclose(read_wav(out2)[0], audio, atol=1e-6)
    capsys.readouterr()
    scene = tmp_path / "neg.json"
    scene.write_text(
        json.dumps(
            {
                "grid": {"dims": [8, 8, 8], "spacing": 0.01},
                "charges": [{"shape": "point", "position": [0.02, 0.02, 0.02], "sign": "negative"}],
            }
        )
    )
    bad = tmp_path / "bad.wav"
    rc = main(["spark", "render", "--scene", str(scene), "--listener", "0,0,1", "-o", str(bad)])
    err = capsys.readouterr().err
    assert rc == 3 and "no positive charge" in err and err.count("\n") == 1
    assert not bad.exists()


def test_lightning_thunder_duration_and_segments() -> None:
    """Lightning preset (Table 1/2): thousands of 3 m segments over a 5 km channel, seconds of
    thunder.  The time it takes is a row of ``auralize bench`` (spark)."""
    res = simulate(preset="lightning", seed=0, strokes=1)
    s = res.summary()
    assert s["segments"] > 1667  # at least the straight 5 km / 3 m
    assert res.discharge.main_length() >= 5000 * 0.95
    assert 8.0 < s["wave_duration_s"] < 20.0  # paper: 13.6 s


def test_overlay_as_the_viewer_calls_it() -> None:
    """The viewer passes (volume, path): any volume gets a discharge inside its bounds, cached."""
    model = SparkSound()
    vol = TimeVolume.from_arrays({"density": np.ones((2, 10, 12, 14))}, spacing=0.1)
    path = ListenerPath.point((0.5, -1.0, 0.5), duration=1.0)
    a = model.overlay((vol, path), 0)
    assert model.overlay((vol, path), 1) is a  # no charge field: the same fitted scene at any step
    lines = a["discharge"]
    b = np.asarray(lines.bounds).reshape(3, 2)
    assert np.all(b[:, 0] >= -1e-9) and np.all(b[:, 1] <= np.array([1.3, 1.1, 0.9]) + 1e-9)
    assert lines.active_scalars_name == "brightness"
    # a charge field changing over time: each step is solved and grown on its own
    q = np.zeros((2, 12, 12, 12))
    q[:, -2:, 5:7, 5:7] = -1.0
    q[0, 0, :, :] = 1.0
    q[1, :, :, 0] = 1.0  # the positive charge moves from the floor to a wall
    cvol = TimeVolume.from_arrays({"charge": q}, spacing=0.01)
    prm = {"half_length": 0.003, "branch_probability": 0.1, "branch_length": 5.0}
    m0 = model.overlay((cvol, path, prm), 0)["discharge"]
    m1 = model.overlay((cvol, path, prm), 1)["discharge"]
    end0 = m0.points[-1]
    assert m0.points[np.argmin(m0.points[:, 2])][2] == pytest.approx(0.0, abs=0.011)
    assert np.min(m1.points[:, 0]) == pytest.approx(0.0, abs=0.011)
    assert not np.array_equal(end0, m1.points[-1])


def test_load_input_reads_a_discharge_a_scene_or_a_volume(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``auralize render --model spark:FILE``: a saved discharge renders as the grown one."""
    model = get_model("spark")
    d = grow_leader(PRESETS["plasma-ball"].field(), half_length=1e-2, seed=2)
    csv = tmp_path / "tree.csv"
    d.to_csv(csv)
    got = model.load_input(str(csv))
    assert isinstance(got, Discharge)
    np.testing.assert_allclose(got.nodes, d.nodes, rtol=1e-8)
    a = model.synthesize(d, preset="plasma-ball", seed=1).parts[0]
    b = model.synthesize(got, preset="plasma-ball", seed=1).parts[0]
    assert a.discharge.n_segments == b.discharge.n_segments
    np.testing.assert_array_equal(a.strokes, b.strokes)
    scene = tmp_path / "balls.json"
    scene.write_text(
        json.dumps(
            {
                "grid": {"dims": [8, 8, 8], "spacing": 0.01},
                "charges": [{"shape": "point", "position": [0.02, 0.02, 0.02], "sign": "negative"}],
            }
        )
    )
    assert isinstance(model.load_input(str(scene)), ChargeScene)
    assert isinstance(model.load_input("dataset:monopole"), TimeVolume)
    with pytest.raises(FormatError, match="missing.csv' does not exist"):
        model.load_input(str(tmp_path / "missing.csv"))
