"""Source strengths, exclusive classification and ΔV spheres on constructed fields."""

from __future__ import annotations

import re

import numpy as np
import pytest

from auralize.errors import DataError, FieldError, ParameterError
from auralize.sources import StrengthStats, Thresholds, classify, compute_strengths, detect
from auralize.volume import TimeVolume

N = 16
H = 0.5


def _grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = (np.arange(N) - (N - 1) / 2) * H
    z, y, xx = np.meshgrid(x, x, x, indexing="ij")
    return xx, y, z


def _volume(rho: np.ndarray, vel: np.ndarray | None, times: np.ndarray) -> TimeVolume:
    fields = {"density": rho}
    if vel is not None:
        fields["velocity"] = vel
    return TimeVolume.from_arrays(fields, spacing=H, times=times)


def _counts(series) -> dict[str, int]:  # type: ignore[no-untyped-def]
    tot = {"monopole": 0, "dipole": 0, "quadrupole": 0}
    for c in series.counts():
        for k in tot:
            tot[k] += c[k]
    return tot


def test_density_pulsation_gives_only_monopoles() -> None:
    x, y, z = _grid()
    g = np.exp(-(x**2 + y**2 + z**2) / (2 * 1.0**2))
    t = np.arange(12) / 400.0
    rho = 1.2 + 0.01 * np.sin(2 * np.pi * 50 * t)[:, None, None, None] * g
    series = detect(_volume(rho, None, t), mapping="identity")
    c = _counts(series)
    assert c["monopole"] > 100
    assert c["dipole"] == 0 and c["quadrupole"] == 0


def test_oscillating_momentum_gives_dipoles_not_monopoles() -> None:
    x, y, z = _grid()
    g = np.exp(-(x**2 + y**2 + z**2) / (2 * 1.0**2))
    t = np.arange(12) / 400.0
    rho = np.full((t.size, N, N, N), 1.2)
    vel = np.zeros((t.size, N, N, N, 3))
    vel[..., 0] = 2.0 * np.sin(2 * np.pi * 50 * t)[:, None, None, None] * g
    series = detect(_volume(rho, vel, t), mapping="identity")
    c = _counts(series)
    assert c["monopole"] == 0
    assert c["dipole"] > 100
    # the dipole pattern of ∂(ρ v_x)/∂x: antisymmetric in x around the blob
    s = compute_strengths(_volume(rho, vel, t), "identity", step=3)
    assert np.allclose(s[0], 0.0)
    assert np.allclose(s[1], -s[1][:, :, ::-1], atol=1e-9 * np.abs(s[1]).max())


def test_steady_rotating_vortex_gives_only_quadrupoles_in_the_literal_form() -> None:
    x, y, z = _grid()
    omega = 40.0
    env = np.exp(-(x**2 + y**2) / (2 * 1.5**2))
    vel = np.stack([-omega * y * env, omega * x * env, np.zeros_like(x)], -1)
    t = np.arange(5) / 100.0
    rho = np.full((t.size, N, N, N), 1.2)
    vols = np.broadcast_to(vel, (t.size, *vel.shape)).copy()
    vol = _volume(rho, vols, t)
    series = detect(vol, mapping="identity", steady="keep")
    c = _counts(series)
    assert c["monopole"] == 0 and c["dipole"] == 0
    assert c["quadrupole"] > 100
    # solid-body rotation: Σ ∂i∂j(ρ v_i v_j) = ρ (∂_i v_j)(∂_j v_i) = -2 ρ Ω² everywhere
    solid = np.stack([-omega * y, omega * x, np.zeros_like(x)], -1)
    vol2 = _volume(rho, np.broadcast_to(solid, (t.size, *solid.shape)).copy(), t)
    s = compute_strengths(vol2, "identity", step=2, steady="keep")
    assert np.allclose(s[2][1:-1, 1:-1, 1:-1], -2 * 1.2 * omega**2)
    assert np.allclose(s[0], 0) and np.allclose(s[1], 0)


def test_quadrupole_sums_all_nine_terms() -> None:
    # T_xy only: S_q = 2 ∂x∂y(ρ v_x v_y); with v = (a y, a x, 0) and ρ = 1:
    # ρ v_x v_y = a² x y  ->  2 ∂x∂y = 2 a², diagonal terms ∂²(a² y²)/∂x² = 0 etc.
    x, y, z = _grid()
    a = 3.0
    vel = np.stack([a * y, a * x, np.zeros_like(x)], -1)
    t = np.arange(3) / 10.0
    vol = _volume(np.ones((3, N, N, N)), np.broadcast_to(vel, (3, *vel.shape)).copy(), t)
    s = compute_strengths(vol, "identity", step=1, steady="keep")
    inner = s[2][2:-2, 2:-2, 2:-2]
    # diagonal: ∂²(a²y²)/∂x² = 0, ∂²(a²x²)/∂y² = 0; off-diagonal 2·a² -> total 2a²
    assert np.allclose(inner, 2 * a**2)


def test_delta_v_radius_interior_of_source_block_is_half_spacing() -> None:
    s = np.zeros((3, 7, 7, 7))
    s[0, 1:6, 1:6, 1:6] = 10.0  # a 5³ block of monopoles
    h = np.array([0.3, 0.3, 0.3])
    kind, radius = classify(s, np.array([1.0, 1.0, 1.0]), h, delta_v="sphere")
    assert kind[3, 3, 3] == 1
    assert radius[3, 3, 3] == pytest.approx(0.15)
    assert np.all(radius[2:5, 2:5, 2:5] == pytest.approx(0.15))
    # default "cell": an interior vertex's ΔV is its whole cell h³
    kind, radius = classify(s, np.array([1.0, 1.0, 1.0]), h)
    vol = 4 / 3 * np.pi * radius**3
    assert np.allclose(vol[2:5, 2:5, 2:5], 0.3**3)


def test_delta_v_cell_volumes_sum_to_the_region() -> None:
    # a block of 5 vertices filling a 7-point axis up to the cut: interior h, the
    # block's ends reach half an edge to their same-type neighbour and the
    # threshold crossing (at 0.5 h: |S| 10 -> 0, threshold 5) on the other side
    s = np.zeros((3, 1, 1, 7))
    s[0, 0, 0, 1:6] = 10.0
    h = np.array([0.2, 1.0, 1.0])
    kind, radius = classify(s, np.array([5.0, 1.0, 1.0]), h)
    vol = 4 / 3 * np.pi * radius**3
    assert vol[0, 0, 1] == pytest.approx(0.2 * (0.5 + 0.5) * 1.0 * 1.0)
    assert vol.sum() == pytest.approx(0.2 * 5 * 1.0)
    # at a grid face there is no edge beyond: half a cell (trapezoid rule)
    s = np.zeros((3, 1, 1, 4))
    s[0] = 10.0
    kind, radius = classify(s, np.array([5.0, 1.0, 1.0]), h)
    vol = 4 / 3 * np.pi * radius**3
    assert vol.ravel().tolist() == pytest.approx([0.1, 0.2, 0.2, 0.1])


def test_delta_v_radius_cut_distances_by_hand() -> None:
    # one monopole of strength 10 (threshold 8) surrounded by 0 -> each cut at
    # h (10 - 8) / (10 - 0) = 0.2 h; anisotropic spacing -> mean over 6 edges
    s = np.zeros((3, 3, 3, 3))
    s[0, 1, 1, 1] = -10.0  # signed: thresholds apply to magnitudes
    h = np.array([1.0, 2.0, 4.0])
    kind, radius = classify(s, np.array([8.0, 1.0, 1.0]), h, delta_v="sphere")
    assert kind.sum() == 1 and kind[1, 1, 1] == 1
    expected = (2 * 0.2 * 1.0 + 2 * 0.2 * 2.0 + 2 * 0.2 * 4.0) / 6
    assert radius[1, 1, 1] == pytest.approx(expected)
    # a corner vertex has three edges only; its neighbours of the same type count h/2
    s = np.zeros((3, 2, 2, 2))
    s[0, 0, 0, 0] = 10.0
    s[0, 0, 0, 1] = 10.0
    kind, radius = classify(s, np.array([8.0, 1.0, 1.0]), np.ones(3), delta_v="sphere")
    assert radius[0, 0, 0] == pytest.approx((0.5 + 0.2 + 0.2) / 3)
    # "cell": the box (0 + 0.5) x (0 + 0.2) x (0 + 0.2) at the corner
    kind, radius = classify(s, np.array([8.0, 1.0, 1.0]), np.ones(3))
    assert 4 / 3 * np.pi * radius[0, 0, 0] ** 3 == pytest.approx(0.5 * 0.2 * 0.2)


def test_exclusive_classification_and_zero_fraction() -> None:
    s = np.zeros((3, 1, 1, 4))
    s[:, 0, 0, 0] = [5.0, 50.0, 500.0]  # monopole wins
    s[:, 0, 0, 1] = [0.5, 50.0, 500.0]  # dipole: monopole below threshold
    s[:, 0, 0, 2] = [0.5, 0.5, 500.0]  # quadrupole
    s[:, 0, 0, 3] = [0.0, 0.0, 0.5]  # nothing
    thr = np.array([1.0, 1.0, 1.0])
    kind, _ = classify(s, thr, np.ones(3))
    assert kind.ravel().tolist() == [1, 2, 3, 0]
    # stricter "almost zero": 0.5 is not below 0.1 × threshold any more
    kind, _ = classify(s, thr, np.ones(3), zero_fraction=0.1)
    assert kind.ravel().tolist() == [1, 0, 0, 0]


def test_thresholds_parsing() -> None:
    th = Thresholds(monopole=2.5, dipole="10%", quadrupole="rel:0.5")
    assert th.resolve(np.array([1.0, 20.0, 4.0])).tolist() == [2.5, 2.0, 2.0]
    sample = np.sort(np.abs(np.random.default_rng(1).normal(size=(3, 1000))), axis=1)
    stats = StrengthStats(peak=np.array([5.0, 0.0, 5.0]), sample=sample)
    thr = Thresholds(monopole="top:1%", dipole="auto", quadrupole="1e-1%").resolve(stats)
    assert thr[0] == pytest.approx(np.quantile(sample[0], 0.99))
    assert thr[1] == np.inf  # a type that never occurs
    assert thr[2] == pytest.approx(5e-3)
    with pytest.raises(ParameterError, match="needs the series' strength statistics"):
        Thresholds().resolve(np.array([1.0, 1.0, 1.0]))
    with pytest.raises(ParameterError, match="'lots' is not understood"):
        Thresholds(monopole="lots")
    for bad in ("e%", "..%", "top:x", "top:%", "1e%", "rel:", "5%%"):
        with pytest.raises(ParameterError, match=re.escape(repr(bad))):
            Thresholds(quadrupole=bad)
    with pytest.raises(ParameterError, match=">= 0"):
        Thresholds(dipole=-1.0)
    with pytest.raises(ParameterError, match="0..100 %"):
        Thresholds(dipole="150%")
    with pytest.raises(ParameterError, match=r"top fraction must be in \(0, 100\] %"):
        Thresholds(dipole="top:0%")


def test_auto_threshold_is_a_noise_floor_or_the_strong_points() -> None:
    from auralize.sources import auto_threshold

    rng = np.random.default_rng(0)
    noise = np.abs(rng.normal(size=100_000))
    # pure noise: the floor median + 5 MAD·1.4826 keeps (almost) nothing
    thr = auto_threshold(np.sort(noise))
    assert np.mean(noise > thr) <= 0.0101
    # a strong compact source in weak noise: the source points, not the noise
    x = noise * 1e-3
    x[:500] = 10.0 + rng.random(500)
    thr = auto_threshold(np.sort(x))
    assert np.sum(x[500:] > thr) == 0
    assert x[:500][x[:500] > thr].sum() >= 0.9 * x[:500].sum()


def test_points_tied_at_the_top_are_kept() -> None:
    """A uniform |S| (median = top quantile = maximum) classifies every point, not none."""
    from auralize.sources import SourceFractionWarning, auto_threshold

    x = np.full(1000, 0.25)
    assert auto_threshold(x) < 0.25
    stats = StrengthStats(peak=np.array([0.25, 0, 0]), sample=np.stack([x, 0 * x, 0 * x]))
    assert np.all(Thresholds("top:1%").resolve(stats)[:1] < 0.25)
    # a uniform density rising linearly in time: dρ/dt = 2 at every point and step
    t = np.arange(5) * 0.5
    rho = np.broadcast_to(1.0 + 2.0 * t[:, None, None, None], (5, 4, 5, 6)).copy()
    vol = TimeVolume.from_arrays({"density": rho}, times=t)
    with pytest.warns(SourceFractionWarning, match="100% of the valid points are sources"):
        series = detect(vol, mapping="identity")
    assert [c["monopole"] for c in series.counts()] == [120] * 5
    np.testing.assert_allclose(np.concatenate([f.strength for f in series.frames]), 2.0)


def test_bad_inputs_to_detection() -> None:
    x, _, _ = _grid()
    one = TimeVolume.from_arrays({"density": np.ones((1, N, N, N))}, times=[0.0])
    with pytest.raises(DataError, match="at least 2 time steps"):
        detect(one, mapping="identity")
    rho = np.ones((3, N, N, N))
    rho[1, 2, 3, 4] = np.nan
    with pytest.raises(DataError, match=r"'density' at step 1 .* 1 NaN/Inf"):
        detect(TimeVolume.from_arrays({"density": rho}, times=[0, 1, 2]), mapping="identity")
    vol = TimeVolume.from_arrays({"rho": np.ones((3, N, N, N))}, times=[0, 1, 2])
    with pytest.raises(FieldError, match=r"needs field\(s\) \['density'\]"):
        detect(vol, mapping="identity")
    with pytest.raises(ParameterError, match="unknown mapping 'fancy'"):
        detect(vol, mapping="fancy")
    with pytest.raises(DataError, match="frame shape"):
        TimeVolume.from_arrays({"a": np.ones((3, 4, 4, 4)), "b": np.ones((3, 4, 4, 5))})
    with pytest.raises(DataError, match="strictly increasing"):
        TimeVolume.from_arrays({"a": np.ones((3, 4, 4, 4))}, times=[0, 2, 1])


def test_paper_density_mapping_ranges() -> None:
    from auralize.sources.mapping import get_mapping

    x, y, z = _grid()
    frames = np.stack([-2 + 2.5 * np.exp(-(x**2 + y**2 + z**2) / (1 + k)) for k in range(3)])
    vol = TimeVolume.from_arrays({"log10_density": frames}, spacing=H, times=[0, 1, 2])
    m = get_mapping("paper-density")
    m.prepare(vol)
    rhos, vs = zip(*(m.map(vol, k) for k in range(3)), strict=True)
    assert min(r.min() for r in rhos) == pytest.approx(0.5)
    assert max(r.max() for r in rhos) == pytest.approx(15.0)
    assert max(np.abs(v).max() for v in vs) == pytest.approx(150.0)
