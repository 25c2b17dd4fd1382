"""The fused floor kernel equals the unfused reference (issue "Kernels a newcomer can read", item 4).

:func:`auralize.sources._kernels.floor_strengths` computes the Richardson error
estimates of the strengths and zeroes those not above ``factor`` times the
largest estimate of the 27 points around them in one sweep along z, without
the error array.  Its results must be those of the unfused form, exactly (bit
for bit, not within a tolerance): the error array of a plain per-point
reference (written here in Python from the kernel's docstring), then the
27-point maximum, on random fields with no-data masks and on grids with axes
of 1 and 2 points (no 2h stencil).  No test here measures time.
"""

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
@pytest.mark.parametrize("bad_share", [0.0, 0.08])
@pytest.mark.parametrize("inv_dt2", [0.0, 0.45])
def test_fused_floor_equals_unfused_reference(
    shape: tuple[int, int, int], bad_share: float, inv_dt2: float
) -> None:
    s, rho_a2, rho_b2, dm, dm2, tt, bad = random_step(shape, 7, bad_share)
    h = np.array([0.3, 0.5, 0.7])
    roundoff = np.array([0.5, 0.0, 1.0])
    err = reference_errors(rho_a2, rho_b2, dm, dm2, tt, 0.9, inv_dt2, h, s, bad)
    want = reference_floor(s, err, 3.0, roundoff)
    got = s.copy()
    K.floor_strengths(got, rho_a2, rho_b2, dm, dm2, tt, bad, 0.9, inv_dt2, h, 3.0, roundoff)
    np.testing.assert_array_equal(got, want)  # exactly, not within a tolerance
    # and the plane-by-plane error array with the unfused floor: the same numbers
    e = np.empty_like(s)
    K._error_stencil(rho_a2, rho_b2, dm, dm2, tt, 0.9, inv_dt2, h, s, bad, e)
    np.testing.assert_array_equal(e, err)
    unfused = s.copy()
    K.apply_floor(unfused, e, 3.0, roundoff)
    np.testing.assert_array_equal(unfused, want)


@pytest.mark.parametrize("threads", [1, 2])
def test_fused_floor_does_not_depend_on_the_blocks(threads: int) -> None:
    """The planes are split into one block per thread; the result is the same for any split
    (a block's first and last planes read estimates of the neighbouring block's)."""
    import numba

    s, rho_a2, rho_b2, dm, dm2, tt, bad = random_step((11, 6, 7), 3, 0.05)
    h = np.array([0.2, 0.2, 0.4])
    roundoff = np.zeros(3)
    want = reference_floor(
        s, reference_errors(rho_a2, rho_b2, dm, dm2, tt, 1.3, 0.6, h, s, bad), 3.0, roundoff
    )
    old = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        got = s.copy()
        K.floor_strengths(got, rho_a2, rho_b2, dm, dm2, tt, bad, 1.3, 0.6, h, 3.0, roundoff)
    finally:
        numba.set_num_threads(old)
    np.testing.assert_array_equal(got, want)


def test_floor_keeps_nan_strengths_and_ignores_nan_estimates() -> None:
    s, rho_a2, rho_b2, dm, dm2, tt, bad = random_step((6, 6, 6), 5, 0.0)
    s[1, 3, 3, 3] = np.nan
    tt[2, 2, 2, 2] = np.nan  # NaN estimates around it: ignored by the maximum
    h = np.ones(3)
    err = reference_errors(rho_a2, rho_b2, dm, dm2, tt, 1.0, 0.5, h, s, bad)
    want = reference_floor(s, err, 3.0, np.zeros(3))
    got = s.copy()
    K.floor_strengths(got, rho_a2, rho_b2, dm, dm2, tt, bad, 1.0, 0.5, h, 3.0, np.zeros(3))
    np.testing.assert_array_equal(got, want)
    assert np.isnan(got[1, 3, 3, 3])


def test_momentum_change_is_the_numpy_expression() -> None:
    rng = np.random.default_rng(4)
    m_a, m_b = rng.normal(size=(2, 4, 5, 6, 3))
    got = np.empty((3, 4, 5, 6))
    K.momentum_change(m_a, m_b, got)
    np.testing.assert_array_equal(got, np.moveaxis(m_b - m_a, -1, 0))


@pytest.mark.parametrize("nan", [False, True])
def test_input_maxima_are_the_numpy_maxima(nan: bool) -> None:
    rng = np.random.default_rng(6)
    rho = rng.normal(size=(4, 5, 6))
    v = rng.normal(size=(4, 5, 6, 3))
    m = rho[..., None] * v
    if nan:
        m[2, 1, 1, 2] = np.nan
    want = tuple(float(np.max(np.abs(x), initial=0.0)) for x in (rho, m, m * v))
    got = K.input_maxima(rho, m, v)
    np.testing.assert_array_equal(got, want)
    assert K.input_maxima(rho[:0], m[:0], v[:0]) == (0.0, 0.0, 0.0)
