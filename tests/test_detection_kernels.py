"""The fused detection kernels equal the unfused reference, bit for bit.

:func:`auralize.sources._kernels.detect_step` takes the strengths of a step,
removes the steady state, masks no-data and floors them (the Richardson
error estimates, zeroing what is not above ``factor`` times the largest
estimate of the 27 points around) in one sweep along z, without the arrays
of the step.  Its results must be those of the passes one after the other
over whole arrays, exactly (not within a tolerance), for any split of the
planes into blocks; and the estimates (taken along whole rows where no
no-data point is near) those of a plain per-point reference written here in
Python from the kernel's docstring, then the 27-point maximum, on random
fields with no-data masks and on grids with axes of 1 and 2 points (no 2h
stencil).  No test here measures time."""

from __future__ import annotations

import numpy as np
import pytest

from auralize.sources import _kernels as K


def _lohi(i: int, n: int) -> tuple[int, int]:
    return max(i - 1, 0), min(i + 1, n - 1)


def _inner2(i: int, n: int) -> int:
    return -1 if n < 5 else min(max(i, 2), n - 3)


def reference_errors(rho_a2, rho_b2, dm, dm2, tt, inv_dt, inv_dt2, h, s, bad):  # type: ignore[no-untyped-def]
    """The error estimates ``(3, nz, ny, nx)``, point by point in Python (unfused)."""
    nz, ny, nx = s.shape[1:]
    hx, hy, hz = (float(x) for x in h)
    err = np.zeros_like(s)
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                if bad[k, j, i]:
                    continue
                k2, j2, i2 = _inner2(k, nz), _inner2(j, ny), _inner2(i, nx)
                if inv_dt2 > 0:
                    err[0, k, j, i] = (
                        abs(s[0, k, j, i] - (rho_b2[k, j, i] - rho_a2[k, j, i]) * inv_dt2) / 3.0
                    )
                ok_x = i2 >= 0 and not (bad[k, j, i2 - 2] or bad[k, j, i2 + 2])
                ok_y = j2 >= 0 and not (bad[k, j2 - 2, i] or bad[k, j2 + 2, i])
                ok_z = k2 >= 0 and not (bad[k2 - 2, j, i] or bad[k2 + 2, j, i])
                div1 = div2 = 0.0
                if ok_x:
                    div2 += (dm[0, k, j, i2 + 2] - dm[0, k, j, i2 - 2]) / (4.0 * hx)
                    div1 += (dm[0, k, j, i2 + 1] - dm[0, k, j, i2 - 1]) / (2.0 * hx)
                if ok_y:
                    div2 += (dm[1, k, j2 + 2, i] - dm[1, k, j2 - 2, i]) / (4.0 * hy)
                    div1 += (dm[1, k, j2 + 1, i] - dm[1, k, j2 - 1, i]) / (2.0 * hy)
                if ok_z:
                    div2 += (dm[2, k2 + 2, j, i] - dm[2, k2 - 2, j, i]) / (4.0 * hz)
                    div1 += (dm[2, k2 + 1, j, i] - dm[2, k2 - 1, j, i]) / (2.0 * hz)
                ed = abs(div1 - div2) * inv_dt / 3.0
                if inv_dt2 > 0:
                    (i0, i1), (j0, j1), (k0, k1) = _lohi(i, nx), _lohi(j, ny), _lohi(k, nz)
                    d2 = 0.0
                    if i1 > i0:
                        d2 += (dm2[0, k, j, i1] - dm2[0, k, j, i0]) / ((i1 - i0) * hx)
                    if j1 > j0:
                        d2 += (dm2[1, k, j1, i] - dm2[1, k, j0, i]) / ((j1 - j0) * hy)
                    if k1 > k0:
                        d2 += (dm2[2, k1, j, i] - dm2[2, k0, j, i]) / ((k1 - k0) * hz)
                    ed += abs(s[1, k, j, i] - d2 * inv_dt2) / 3.0
                err[1, k, j, i] = ed
                eq = 0.0
                t = tt
                if ok_x:
                    a = t[0, k, j, i2 + 1] - 2.0 * t[0, k, j, i2] + t[0, k, j, i2 - 1]
                    b = 0.25 * (t[0, k, j, i2 + 2] - 2.0 * t[0, k, j, i2] + t[0, k, j, i2 - 2])
                    eq += (a - b) / (hx * hx)
                if ok_y:
                    a = t[1, k, j2 + 1, i] - 2.0 * t[1, k, j2, i] + t[1, k, j2 - 1, i]
                    b = 0.25 * (t[1, k, j2 + 2, i] - 2.0 * t[1, k, j2, i] + t[1, k, j2 - 2, i])
                    eq += (a - b) / (hy * hy)
                if ok_z:
                    a = t[2, k2 + 1, j, i] - 2.0 * t[2, k2, j, i] + t[2, k2 - 1, j, i]
                    b = 0.25 * (t[2, k2 + 2, j, i] - 2.0 * t[2, k2, j, i] + t[2, k2 - 2, j, i])
                    eq += (a - b) / (hz * hz)
                if ok_x and ok_y:
                    a = (
                        t[3, k, j2 + 1, i2 + 1]
                        - t[3, k, j2 + 1, i2 - 1]
                        - t[3, k, j2 - 1, i2 + 1]
                        + t[3, k, j2 - 1, i2 - 1]
                    ) / 4.0
                    b = (
                        t[3, k, j2 + 2, i2 + 2]
                        - t[3, k, j2 + 2, i2 - 2]
                        - t[3, k, j2 - 2, i2 + 2]
                        + t[3, k, j2 - 2, i2 - 2]
                    ) / 16.0
                    eq += 2.0 * (a - b) / (hx * hy)
                if ok_x and ok_z:
                    a = (
                        t[4, k2 + 1, j, i2 + 1]
                        - t[4, k2 + 1, j, i2 - 1]
                        - t[4, k2 - 1, j, i2 + 1]
                        + t[4, k2 - 1, j, i2 - 1]
                    ) / 4.0
                    b = (
                        t[4, k2 + 2, j, i2 + 2]
                        - t[4, k2 + 2, j, i2 - 2]
                        - t[4, k2 - 2, j, i2 + 2]
                        + t[4, k2 - 2, j, i2 - 2]
                    ) / 16.0
                    eq += 2.0 * (a - b) / (hx * hz)
                if ok_y and ok_z:
                    a = (
                        t[5, k2 + 1, j2 + 1, i]
                        - t[5, k2 + 1, j2 - 1, i]
                        - t[5, k2 - 1, j2 + 1, i]
                        + t[5, k2 - 1, j2 - 1, i]
                    ) / 4.0
                    b = (
                        t[5, k2 + 2, j2 + 2, i]
                        - t[5, k2 + 2, j2 - 2, i]
                        - t[5, k2 - 2, j2 + 2, i]
                        + t[5, k2 - 2, j2 - 2, i]
                    ) / 16.0
                    eq += 2.0 * (a - b) / (hy * hz)
                err[2, k, j, i] = abs(eq) / 3.0
    return err


def reference_floor(s, err, factor, roundoff):  # type: ignore[no-untyped-def]
    """Zero what is not above ``roundoff`` or ``factor`` × the 27-point maximum of ``err``
    (NaN estimates ignored, 0 at least)."""
    out = s.copy()
    padded = np.pad(np.nan_to_num(err, nan=0.0), ((0, 0), (1, 1), (1, 1), (1, 1)), mode="edge")
    nz, ny, nx = s.shape[1:]
    for c in range(3):
        for k in range(nz):
            for j in range(ny):
                for i in range(nx):
                    a = abs(out[c, k, j, i])
                    if a == 0.0:
                        continue
                    e = max(float(padded[c, k : k + 3, j : j + 3, i : i + 3].max()), 0.0)
                    if a <= roundoff[c] or a <= factor * e:
                        out[c, k, j, i] = 0.0
    return out


def random_step(shape: tuple[int, int, int], seed: int, bad_share: float):  # type: ignore[no-untyped-def]
    """Inputs of one step, no-data points zero (as detection makes them) and
    strengths of the size of their error estimates, so the floor zeroes some."""
    rng = np.random.default_rng(seed)
    s = rng.normal(size=(3, *shape))
    dm, dm2 = rng.normal(size=(3, *shape)), rng.normal(size=(3, *shape))
    tt = rng.normal(size=(6, *shape))
    rho_a2, rho_b2 = rng.normal(size=shape), rng.normal(size=shape)
    bad = rng.random(shape) < bad_share
    for a in (s, dm, dm2, tt):
        a[:, bad] = 0.0
    rho_a2[bad] = rho_b2[bad] = 0.0
    s *= 20.0
    s[:, rng.random(shape) < 0.1] = 0.0
    return s, rho_a2, rho_b2, dm, dm2, tt, bad


SHAPES = [(6, 5, 7), (7, 9, 8), (1, 6, 7), (2, 5, 6), (6, 1, 2), (2, 2, 1), (1, 1, 1), (5, 2, 9)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("bad_share", [0.0, 0.08, -1.0])
@pytest.mark.parametrize("inv_dt2", [0.0, 0.45])
def test_error_estimates_and_floor_equal_the_python_reference(
    shape: tuple[int, int, int], bad_share: float, inv_dt2: float
) -> None:
    """The plane-by-plane estimates (runs along the rows where no no-data point is near,
    point by point elsewhere) and the 27-point floor, exactly the per-point reference."""
    s, rho_a2, rho_b2, dm, dm2, tt, bad = random_step(shape, 7, max(bad_share, 0.0))
    if bad_share < 0:  # one no-data block: clean rows, rows next to it, rows through it
        bad[:, :2, 2:4] = True
    h = np.array([0.3, 0.5, 0.7])
    roundoff = np.array([0.5, 0.0, 1.0])
    err = reference_errors(rho_a2, rho_b2, dm, dm2, tt, 0.9, inv_dt2, h, s, bad)
    e = np.empty_like(s)
    K._error_stencil(rho_a2, rho_b2, dm, dm2, tt, 0.9, inv_dt2, h, s, bad, e)
    np.testing.assert_array_equal(e, err)  # exactly, not within a tolerance
    got = s.copy()
    K.apply_floor(got, e, 3.0, roundoff)
    np.testing.assert_array_equal(got, reference_floor(s, err, 3.0, roundoff))


def _inner(i: int, n: int) -> int:
    return i if n < 3 else min(max(i, 1), n - 2)


def reference_strengths(rho_a, rho_b, dm, tt, inv_dt, h):  # type: ignore[no-untyped-def]
    """The strengths ``(3, nz, ny, nx)``, point by point in Python (paper 003 Eqs. 13, 14
    as :func:`auralize.sources._kernels.strengths` documents them)."""
    nz, ny, nx = rho_a.shape
    hx, hy, hz = (float(x) for x in h)
    g = [1.0 / (hh * hh) if n >= 3 else 0.0 for hh, n in ((hx, nx), (hy, ny), (hz, nz))]
    out = np.empty((3, nz, ny, nx))
    for k in range(nz):
        (k0, k1), kc = _lohi(k, nz), _inner(k, nz)
        fz = 1.0 / ((k1 - k0) * hz) if k1 > k0 else 0.0
        for j in range(ny):
            (j0, j1), jc = _lohi(j, ny), _inner(j, ny)
            fy = 1.0 / ((j1 - j0) * hy) if j1 > j0 else 0.0
            for i in range(nx):
                (i0, i1), ic = _lohi(i, nx), _inner(i, nx)
                fx = 1.0 / ((i1 - i0) * hx) if i1 > i0 else 0.0
                out[0, k, j, i] = (rho_b[k, j, i] - rho_a[k, j, i]) * inv_dt
                div = (
                    (dm[0, k, j, i1] - dm[0, k, j, i0]) * fx
                    + (dm[1, k, j1, i] - dm[1, k, j0, i]) * fy
                    + (dm[2, k1, j, i] - dm[2, k0, j, i]) * fz
                )
                out[1, k, j, i] = div * inv_dt
                t = tt
                q = 0.0
                if nx >= 3:
                    q += (t[0, k, j, ic + 1] - 2.0 * t[0, k, j, ic] + t[0, k, j, ic - 1]) * g[0]
                if ny >= 3:
                    q += (t[1, k, jc + 1, i] - 2.0 * t[1, k, jc, i] + t[1, k, jc - 1, i]) * g[1]
                if nz >= 3:
                    q += (t[2, kc + 1, j, i] - 2.0 * t[2, kc, j, i] + t[2, kc - 1, j, i]) * g[2]
                q += (2.0 * fx * fy) * (
                    t[3, k, j1, i1] - t[3, k, j1, i0] - t[3, k, j0, i1] + t[3, k, j0, i0]
                )
                q += (2.0 * fx * fz) * (
                    t[4, k1, j, i1] - t[4, k1, j, i0] - t[4, k0, j, i1] + t[4, k0, j, i0]
                )
                q += (2.0 * fy * fz) * (
                    t[5, k1, j1, i] - t[5, k1, j0, i] - t[5, k0, j1, i] + t[5, k0, j0, i]
                )
                out[2, k, j, i] = q
    return out


STRENGTH_SHAPES = [(6, 7, 9), (3, 1, 4), (1, 5, 3), (4, 4, 2), (2, 3, 1), (5, 2, 6)]


@pytest.mark.parametrize("shape", STRENGTH_SHAPES)
def test_strengths_equal_the_python_reference(shape: tuple[int, int, int]) -> None:
    """The strengths taken along whole rows (x stencils one-sided or kept inside at the
    ends) are the per-point ones, bit for bit."""
    rng = np.random.default_rng(9)
    rho_a, rho_b = rng.normal(size=(2, *shape))
    dm, tt = rng.normal(size=(3, *shape)), rng.normal(size=(6, *shape))
    h = np.array([0.3, 0.5, 0.7])
    got = np.empty((3, *shape))
    K.strengths(rho_a, rho_b, dm, tt, 1.7, h, got)
    np.testing.assert_array_equal(got, reference_strengths(rho_a, rho_b, dm, tt, 1.7, h))


def random_frames(shape: tuple[int, int, int], seed: int) -> tuple[np.ndarray, ...]:
    """Densities and velocities of five steps (n-1, n+1, n, n-2, n+2), as detect_step takes them."""
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    for _ in range(5):
        out += [1.0 + 0.1 * rng.normal(size=shape), rng.normal(size=(*shape, 3))]
    return tuple(out)


def the_passes(frames, steady, nodata, bad, inv_dt, inv_dt2, h, factor, roundoff):  # type: ignore[no-untyped-def]
    """The strengths of one step, pass after pass over whole arrays (what detect_step fuses)."""
    rho_a, v_a, rho_b, v_b, rho_c, v_c, rho_a2, v_a2, rho_b2, v_b2 = frames
    shape = rho_c.shape
    dm, tt, s = np.empty((3, *shape)), np.empty((6, *shape)), np.empty((3, *shape))
    K.momentum_change(rho_a, v_a, rho_b, v_b, dm)
    K.stress(rho_c, v_c, tt)
    K.strengths(rho_a, rho_b, dm, tt, inv_dt, h, s)
    mode, f, sa, sb, ra, va, rb, vb = steady
    if mode == K.STEADY_BETWEEN:
        ta, tb = np.empty((6, *shape)), np.empty((6, *shape))
        K.stress(ra, va, ta)
        K.stress(rb, vb, tb)
        K.subtract_steady(s[2], sa, sb, tt, ta, tb, f, factor > 0)
    elif mode == K.STEADY_ANCHOR:
        s[2] = 0.0
    elif mode == K.STEADY_GIVEN:
        s[2] -= sa
    K.mask_nodata(nodata, s)
    if factor > 0:
        dm2 = np.empty((3, *shape))
        K.momentum_change(rho_a2, v_a2, rho_b2, v_b2, dm2)
        err = np.empty_like(s)
        K._error_stencil(rho_a2, rho_b2, dm, dm2, tt, inv_dt, inv_dt2, h, s, bad, err)
        K.apply_floor(s, err, factor, roundoff)
    return s


def steady_of(mode: int, shape: tuple[int, int, int], seed: int) -> tuple:  # type: ignore[type-arg]
    rng = np.random.default_rng(seed)
    sa, sb, ra, rb = rng.normal(size=(4, *shape))
    va, vb = rng.normal(size=(2, *shape, 3))
    return (mode, 0.3, sa, sb, ra, va, rb, vb)


DETECT_SHAPES = [
    (9, 12, 17),
    (6, 5, 7),
    (5, 5, 5),
    (3, 4, 2),
    (1, 6, 7),
    (6, 1, 2),
    (2, 2, 1),
    (1, 1, 1),
    (12, 3, 6),
]


@pytest.mark.parametrize("shape", DETECT_SHAPES)
@pytest.mark.parametrize("mode", [K.STEADY_NONE, K.STEADY_BETWEEN, K.STEADY_ANCHOR, K.STEADY_GIVEN])
@pytest.mark.parametrize("factor", [0.0, 3.0])
def test_one_sweep_equals_the_passes(shape: tuple[int, int, int], mode: int, factor: float) -> None:
    """detect_step (one sweep along z, its planes kept in rings) gives the strengths of the
    passes one after the other, bit for bit, for any split of the planes into blocks."""
    frames = random_frames(shape, 11)
    steady = steady_of(mode, shape, 12)
    h = np.array([0.3, 0.5, 0.7])
    roundoff = np.array([1e-3, 0.0, 0.5])
    nodata = np.zeros(shape, dtype=bool)
    for masked in (False, True):
        if masked:
            nodata[tuple(np.array(shape) // 2)] = True
            nodata[0, 0, 0] = True
        bad = nodata.copy()
        if masked:
            bad[-1, -1, -1] = True
        want = the_passes(frames, steady, nodata, bad, 1.3, 0.6, h, factor, roundoff)
        for blocks in (1, 2, 3, shape[0]):
            got = np.full((3, *shape), np.nan)
            K.detect_step(
                frames, steady, nodata, bad, 1.3, 0.6, h, factor, roundoff, got, blocks=blocks
            )
            np.testing.assert_array_equal(got, want)


def test_one_sweep_keeps_nan_strengths_and_ignores_nan_estimates() -> None:
    frames = random_frames((7, 8, 9), 13)
    frames[5][3, 4, 4, 1] = np.nan  # v_c: NaN strengths around it, NaN estimates
    steady = steady_of(K.STEADY_BETWEEN, (7, 8, 9), 14)
    no = np.zeros((7, 8, 9), dtype=bool)
    args = (steady, no, no, 1.0, 0.5, np.ones(3), 3.0, np.zeros(3))
    want = the_passes(frames, *args)
    got = np.empty((3, 7, 8, 9))
    K.detect_step(frames, *args, got)
    np.testing.assert_array_equal(got, want)
    assert np.isnan(got).any() and (got == 0).any()


def test_one_sweep_floor_equals_the_python_reference() -> None:
    """The whole chain once against the per-point Python reference of the estimates."""
    shape = (8, 7, 9)
    frames = random_frames(shape, 15)
    rho_a, v_a, rho_b, v_b, rho_c, v_c, rho_a2, v_a2, rho_b2, v_b2 = frames
    h = np.array([0.3, 0.5, 0.7])
    no = np.zeros(shape, dtype=bool)
    steady = steady_of(K.STEADY_NONE, shape, 16)
    s = the_passes(frames, steady, no, no, 1.3, 0.6, h, 0.0, np.zeros(3))
    dm = np.moveaxis(rho_b[..., None] * v_b - rho_a[..., None] * v_a, -1, 0)
    dm2 = np.moveaxis(rho_b2[..., None] * v_b2 - rho_a2[..., None] * v_a2, -1, 0)
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    tt = np.stack([rho_c * v_c[..., p] * v_c[..., q] for p, q in pairs])
    err = reference_errors(rho_a2, rho_b2, dm, dm2, tt, 1.3, 0.6, h, s, no)
    roundoff = np.array([0.1, 0.0, 0.2])
    got = np.empty_like(s)
    K.detect_step(frames, steady, no, no, 1.3, 0.6, h, 3.0, roundoff, got)
    want = reference_floor(s, err, 3.0, roundoff)
    np.testing.assert_array_equal(got, want)
    assert 0 < np.count_nonzero(got) < np.count_nonzero(s)


def test_momentum_change_is_the_numpy_expression() -> None:
    rng = np.random.default_rng(4)
    rho_a, rho_b = rng.normal(size=(2, 4, 5, 6))
    v_a, v_b = rng.normal(size=(2, 4, 5, 6, 3))
    got = np.empty((3, 4, 5, 6))
    K.momentum_change(rho_a, v_a, rho_b, v_b, got)
    want = rho_b[..., None] * v_b - rho_a[..., None] * v_a
    np.testing.assert_array_equal(got, np.moveaxis(want, -1, 0))


def test_stress_is_the_numpy_expression() -> None:
    rng = np.random.default_rng(5)
    rho = rng.normal(size=(4, 5, 6))
    v = rng.normal(size=(4, 5, 6, 3))
    tt = np.empty((6, 4, 5, 6))
    K.stress(rho, v, tt)
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    np.testing.assert_array_equal(tt, np.stack([rho * v[..., p] * v[..., q] for p, q in pairs]))


@pytest.mark.parametrize("nan", [False, True])
def test_input_maxima_are_the_numpy_maxima(nan: bool) -> None:
    rng = np.random.default_rng(6)
    rho = rng.normal(size=(4, 5, 6))
    v = rng.normal(size=(4, 5, 6, 3))
    if nan:
        v[2, 1, 1, 2] = np.nan
    m = rho[..., None] * v
    want = tuple(float(np.max(np.abs(x), initial=0.0)) for x in (rho, m, m * v))
    got = K.input_maxima(rho, v)
    np.testing.assert_array_equal(got, want)
    assert K.input_maxima(rho[:0], v[:0]) == (0.0, 0.0, 0.0)


def test_step_change_is_the_numpy_maxima() -> None:
    rng = np.random.default_rng(8)
    r0, r1 = rng.normal(size=(2, 3, 4, 5))
    v0, v1 = rng.normal(size=(2, 3, 4, 5, 3))
    m0, m1 = r0[..., None] * v0, r1[..., None] * v1
    dr, dm, planes = K.step_change(r0, v0, r1, v1)
    assert (dr, dm) == (float(np.max(np.abs(r1 - r0))), float(np.max(np.abs(m1 - m0))))
    np.testing.assert_array_equal(planes, K.input_maxima_planes(r1, v1))
    np.testing.assert_array_equal(planes.max(axis=0), K.input_maxima(r1, v1))


@pytest.mark.parametrize("delta_v", ["cell", "sphere"])
@pytest.mark.parametrize("shape", [(7, 8, 9), (1, 5, 6), (4, 1, 1)])
@pytest.mark.parametrize("curvilinear", [False, True])
def test_sources_in_one_kernel_equal_classify_then_extract(
    delta_v: str, shape: tuple[int, int, int], curvilinear: bool
) -> None:
    """The source points gathered with their radii alone (classes first, then each
    source's radius) are those of classifying every point and gathering them."""
    from auralize.sources.detection import classify, classify_sources, extract

    rng = np.random.default_rng(17)
    s = rng.normal(size=(3, *shape)) * np.array([1.0, 3.0, 9.0])[:, None, None, None]
    thr = np.array([1.5, 2.0, 12.0])
    h = np.array([0.3, 0.5, 0.7])
    cell = rng.uniform(0.5, 2.0, size=shape) if curvilinear else None
    kind, radius = classify(s, thr, h, zero_fraction=0.8, delta_v=delta_v, cell=cell)
    want = extract(kind, radius, s)
    got = classify_sources(s, thr, h, zero_fraction=0.8, delta_v=delta_v, cell=cell)
    assert want.index.size > 0
    for name in ("index", "kind", "strength", "radius"):
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
