"""Compiled inner loops (numba) of the spark plugin.

Two loops numpy cannot express without large temporaries:

* :func:`sor_sweeps` — red-black successive over-relaxation of the 7-point
  Laplacian with fixed-potential cells (paper 002 §4.1, Eq. 1).  Red-black
  ordering makes each half sweep order-independent; it is sequential in the
  number of sweeps, so it is a loop.
* :func:`accumulate_wm` — the box-filtered WM-wave (Eq. 5) of every discharge
  segment added into the output buffer at its arrival sample (§4.2.2 (a)–(c)).
  Each segment touches only the few hundred samples of its own support, so the
  whole lightning preset (~9,400 segments) is a few million cheap evaluations.
"""

from __future__ import annotations

import numba
import numpy as np

from auralize.runtime.jit import configure as _configure_numba

_configure_numba()  # cache folder, OMP wait policy, compile notice

_NJIT = {"cache": True, "fastmath": False, "nogil": True, "error_model": "numpy"}


@numba.njit(**_NJIT)
def sor_sweeps(phi, fixed, w, boundary_value, neumann, omega, max_sweeps, tol):  # type: ignore[no-untyped-def]
    """Red-black SOR sweeps on ``phi (nz, ny, nx)`` in place.

    Parameters
    ----------
    phi : (nz, ny, nx) float64, potential (fixed cells hold their values).
    fixed : (nz, ny, nx) bool, cells whose potential is imposed.
    w : (3,) float64, stencil weights ``1/h²`` along x, y, z.
    boundary_value : potential outside the box (Dirichlet), unused if ``neumann``.
    neumann : bool, zero normal derivative at the box faces instead.
    omega : relaxation factor in (0, 2).
    max_sweeps, tol : stop after ``max_sweeps`` or when the largest change of a
        sweep is below ``tol``.

    Returns
    -------
    (sweeps, last_change)
    """
    nz, ny, nx = phi.shape
    wx, wy, wz = w[0], w[1], w[2]
    change = 0.0
    sweeps = 0
    for it in range(max_sweeps):
        change = 0.0
        for colour in range(2):
            for k in range(nz):
                for j in range(ny):
                    i0 = (k + j + colour) % 2
                    for i in range(i0, nx, 2):
                        if fixed[k, j, i]:
                            continue
                        s = 0.0
                        ws = 0.0
                        # x neighbours
                        if i > 0:
                            s += wx * phi[k, j, i - 1]
                            ws += wx
                        elif not neumann:
                            s += wx * boundary_value
                            ws += wx
                        if i < nx - 1:
                            s += wx * phi[k, j, i + 1]
                            ws += wx
                        elif not neumann:
                            s += wx * boundary_value
                            ws += wx
                        # y neighbours
                        if j > 0:
                            s += wy * phi[k, j - 1, i]
                            ws += wy
                        elif not neumann:
                            s += wy * boundary_value
                            ws += wy
                        if j < ny - 1:
                            s += wy * phi[k, j + 1, i]
                            ws += wy
                        elif not neumann:
                            s += wy * boundary_value
                            ws += wy
                        # z neighbours
                        if k > 0:
                            s += wz * phi[k - 1, j, i]
                            ws += wz
                        elif not neumann:
                            s += wz * boundary_value
                            ws += wz
                        if k < nz - 1:
                            s += wz * phi[k + 1, j, i]
                            ws += wz
                        elif not neumann:
                            s += wz * boundary_value
                            ws += wz
                        if ws == 0.0:
                            continue
                        d = omega * (s / ws - phi[k, j, i])
                        phi[k, j, i] += d
                        ad = abs(d)
                        if ad > change:
                            change = ad
        sweeps = it + 1
        if change < tol:
            break
    return sweeps, change


@numba.njit(inline="always", **_NJIT)
def _qdiff(a, b, psi2):  # type: ignore[no-untyped-def]
    """q(a) - q(b) for q(x) = x³/3 - ψ² x, factored to avoid cancellation."""
    return (a - b) * ((a * a + a * b + b * b) / 3.0 - psi2)


@numba.njit(inline="always", **_NJIT)
def wm_antiderivative(tau, s, psi, b):  # type: ignore[no-untyped-def]
    """F(τ) = ∫_{-∞}^{τ} p dτ' of the WM-wave (Eq. 5), both branches.

    The three pieces of Eq. 5 occupy ``u = τ + s ∈ (-ψ, min(ψ, 2s - ψ)]``,
    ``τ ∈ (-ψ + s, ψ - s]`` (only when s < ψ) and
    ``w = τ - s ∈ (max(-ψ, ψ - 2s), ψ]``; the pressure is odd in τ, so F returns
    to zero at τ = ψ + s.
    """
    psi2 = psi * psi
    f = 0.0
    # piece 1: -(B/s)[(τ+s)² - ψ²]
    u_hi = min(psi, 2.0 * s - psi)
    u = tau + s
    if u > -psi:
        uc = min(u, u_hi)
        f -= (b / s) * _qdiff(uc, -psi, psi2)
    # piece 2: -4Bτ  (s < ψ only)
    if s < psi:
        lo = -psi + s
        if tau > lo:
            tc = min(tau, psi - s)
            f -= 2.0 * b * (tc * tc - lo * lo)
    # piece 3: (B/s)[(τ-s)² - ψ²]
    w_lo = max(-psi, psi - 2.0 * s)
    wv = tau - s
    if wv > w_lo:
        wc = min(wv, psi)
        f += (b / s) * _qdiff(wc, w_lo, psi2)
    return f


@numba.njit(inline="always", **_NJIT)
def _overlap(n, n_ref, tau_ref, dtau, h, ta, tb, a2, a1, a0):  # type: ignore[no-untyped-def]
    """Mean over sample n of p(τ) = a2 τ² + a1 τ + a0 restricted to (ta, tb] (exact integral)."""
    tcn = tau_ref + (n - n_ref) * dtau
    lo = tcn - h
    hi = tcn + h
    x0 = lo if lo > ta else ta
    x1 = hi if hi < tb else tb
    if x1 <= x0:
        return 0.0
    return (x1 - x0) * (a2 * (x1 * x1 + x1 * x0 + x0 * x0) / 3.0 + a1 * 0.5 * (x1 + x0) + a0) / dtau


@numba.njit(inline="always", **_NJIT)
def _add_piece(out, chans, gains, q, ta, tb, a2, a1, a0, tc, hl, c, rate):  # type: ignore[no-untyped-def]
    """Box-filtered samples of p(τ) = a2 τ² + a1 τ + a0 on τ ∈ (ta, tb], added to ``out``.

    The samples containing ta and tb get the exact partial integral; the ones
    in between lie wholly inside the piece, where the mean of a quadratic over
    [τ_n − h, τ_n + h] is a2 (τ_n² + h²/3) + a1 τ_n + a0.
    """
    n_out = out.shape[1]
    dtau = c / (rate * hl)
    h = 0.5 * dtau
    h2 = h * h / 3.0
    n0 = int(np.floor((tc + ta * hl / c) * rate + 0.5))
    n1 = int(np.floor((tc + tb * hl / c) * rate + 0.5))
    if n1 < 0 or n0 >= n_out:
        return 0
    tau0 = c * (n0 / rate - tc) / hl
    v0 = _overlap(n0, n0, tau0, dtau, h, ta, tb, a2, a1, a0)
    v1 = _overlap(n1, n0, tau0, dtau, h, ta, tb, a2, a1, a0) if n1 > n0 else 0.0
    i0 = max(n0 + 1, 0)
    i1 = min(n1, n_out)
    for kk in range(chans.shape[1]):
        ch = chans[q, kk]
        if ch < 0:
            continue
        g = gains[q, kk]
        row = out[ch]
        if n0 >= 0:
            row[n0] += g * v0
        if n1 > n0 and n1 < n_out:
            row[n1] += g * v1
        ga2 = g * a2
        ga1 = g * a1
        gc = g * (a2 * h2 + a0)
        for n in range(i0, i1):
            t = tau0 + (n - n0) * dtau
            row[n] += (ga2 * t + ga1) * t + gc
    return n1 - n0 + 1


@numba.njit(**_NJIT)
def accumulate_wm(out, t_center, half_len, s_arr, psi_arr, b_arr, chans, gains, rate, c):  # type: ignore[no-untyped-def]
    """Add the box-filtered WM-wave of every segment into ``out`` (in place).

    Parameters
    ----------
    out : (n_channels, n_samples) float64 output buffer; sample n covers
        playback time ``[(n - ½)/rate, (n + ½)/rate)``.
    t_center : (S,) s, arrival time of the segment's centre (emission time + r/c).
    half_len : (S,) m, segment half-length l.
    s_arr, psi_arr, b_arr : (S,) Eq. 5's s = sin θ, ψ = cT/l and B (Pa).
    chans : (S, K) int64 output channels (−1 = none); gains : (S, K) panning gains.
    rate : samples per second; c : speed of sound (m/s).

    Each sample receives the mean of p over its interval (τ = c (t − t_center)/l),
    an exact box filter of the piecewise-quadratic wave (no aliasing of the
    shock fronts).  The pieces of Eq. 5 are, with s < ψ:
    (−ψ−s, −ψ+s] −(B/s)[(τ+s)² − ψ²], (−ψ+s, ψ−s] −4Bτ, (ψ−s, ψ+s] (B/s)[(τ−s)² − ψ²];
    with s ≥ ψ the first and last pieces become (−ψ−s, ψ−s] and (s−ψ, ψ+s]
    and the middle is silent (skipped).  Returns the number of samples written.
    """
    n_seg = t_center.shape[0]
    written = 0
    for q in range(n_seg):
        hl = half_len[q]
        s = s_arr[q]
        psi = psi_arr[q]
        b = b_arr[q]
        tc = t_center[q]
        if s < psi:
            if s > 0.0:  # the rounded shock fronts (width 2s)
                bs = b / s
                written += _add_piece(
                    out,
                    chans,
                    gains,
                    q,
                    -psi - s,
                    -psi + s,
                    -bs,
                    -2.0 * b,
                    -bs * (s * s - psi * psi),
                    tc,
                    hl,
                    c,
                    rate,
                )
                written += _add_piece(
                    out,
                    chans,
                    gains,
                    q,
                    psi - s,
                    psi + s,
                    bs,
                    -2.0 * b,
                    bs * (s * s - psi * psi),
                    tc,
                    hl,
                    c,
                    rate,
                )
            written += _add_piece(
                out, chans, gains, q, -psi + s, psi - s, 0.0, -4.0 * b, 0.0, tc, hl, c, rate
            )
        else:
            bs = b / s
            written += _add_piece(
                out,
                chans,
                gains,
                q,
                -psi - s,
                psi - s,
                -bs,
                -2.0 * b,
                -bs * (s * s - psi * psi),
                tc,
                hl,
                c,
                rate,
            )
            written += _add_piece(
                out,
                chans,
                gains,
                q,
                s - psi,
                psi + s,
                bs,
                -2.0 * b,
                bs * (s * s - psi * psi),
                tc,
                hl,
                c,
                rate,
            )
    return written
