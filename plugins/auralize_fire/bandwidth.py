"""Spectral bandwidth extension (paper 001 §4, Algorithm 1, Eqs. 12–13, Table 1).

The low-frequency sound p is cut into linear (hat) windows w_i of half-width
w_H centred at i·w_H (Algorithm 1, line 4), which sum to one.  In each
window, power-law noise N (|Ñ(f)| = f^(-α/2), uniformly random phases,
high-passed by F_high) is multiplied by |p w_i| so that it follows the
signal's temporal structure (Fig. 4).  The spectra are blended (Eq. 12)::

    p̃_blend(f; β) = F_low(f) p̃_W(f) + β F_high(f) Ñ_W(f)

with F_low/F_high linear ramps over the blend range (165–195 Hz) and β > 0
the root of the quadratic of Eq. 13, which matches the power in a Gaussian
band g(f) (mean f_cut, σ_cut) around f_cut.  The blended windows are
overlap-added (Algorithm 1, line 9).

Implementation choices (not fixed by the paper): every window is zero-padded
to ``pad · w_H`` samples (default 8, i.e. 4000 samples, 11 Hz bins) so that
the 30 Hz blend range spans several FFT bins and the blend filters'
impulse responses do not wrap around; the padded frames are overlap-added in
full.  All windows are processed at once as a 2-D array (one batched FFT),
which is what makes a 10 s clip take well under 0.2 s.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import fft as sfft

from auralize.errors import DataError, ParameterError


@dataclass(frozen=True)
class ExtensionParams:
    """Parameters of Algorithm 1 (defaults: paper 001 Table 1)."""

    alpha: float = 3.0  # power-law exponent, P(f) ∝ f^-α
    f_cut: float = 180.0  # Hz, Nyquist frequency of a 360 Hz simulation
    sigma_cut: float = 10.0  # Hz, std of the Gaussian weight g(f) of Eq. 13
    w_h: int = 500  # samples, window half-width (11.34 ms at 44.1 kHz)
    blend_lo: float = 165.0  # Hz, F_low = 1 below
    blend_hi: float = 195.0  # Hz, F_high = 1 above
    pad: int = 8  # FFT frame length in units of w_H (even, >= 4)
    beta: str = "expected"  # Eq. 13 with the noise band power "expected" or "realised"

    def check(self, rate: float) -> None:
        if not 0 < self.alpha <= 10:
            raise ParameterError(f"alpha must be in (0, 10], got {self.alpha!r}")
        if int(self.w_h) != self.w_h or self.w_h < 4:
            raise ParameterError(f"w_h must be an integer >= 4 samples, got {self.w_h!r}")
        if int(self.pad) != self.pad or self.pad < 4 or self.pad % 2:
            raise ParameterError(f"pad must be an even integer >= 4, got {self.pad!r}")
        if self.beta not in ("expected", "realised"):
            raise ParameterError(f"beta must be 'expected' or 'realised', got {self.beta!r}")
        if not self.sigma_cut > 0:
            raise ParameterError(f"sigma_cut must be positive (Hz), got {self.sigma_cut!r}")
        if not 0 < self.blend_lo <= self.f_cut <= self.blend_hi:
            raise ParameterError(
                f"need 0 < blend_lo <= f_cut <= blend_hi, got blend [{self.blend_lo}, "
                f"{self.blend_hi}] Hz and f_cut {self.f_cut} Hz"
            )
        if self.blend_hi >= rate / 2:
            raise ParameterError(
                f"blend range up to {self.blend_hi} Hz does not fit below the Nyquist "
                f"frequency {rate / 2:g} Hz of a {rate:g} Hz signal"
            )


def blend_filters(
    freqs: NDArray[np.floating], params: ExtensionParams
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """F_low, F_high (linear ramps over the blend range, F_low + F_high = 1) and g(f) (Eq. 13)."""
    f = np.asarray(freqs, dtype=np.float64)
    width = max(params.blend_hi - params.blend_lo, 1e-12)
    f_low = np.clip((params.blend_hi - f) / width, 0.0, 1.0)
    if params.blend_hi == params.blend_lo:
        f_low = (f < params.blend_lo).astype(np.float64)
    g = np.exp(-0.5 * ((f - params.f_cut) / params.sigma_cut) ** 2)
    return f_low, 1.0 - f_low, g


def choose_beta(
    P: NDArray[np.complexfloating],
    N: NDArray[np.complexfloating],
    f_low: NDArray[np.floating],
    f_high: NDArray[np.floating],
    g: NDArray[np.floating],
) -> NDArray[np.float64]:
    """β > 0 solving Eq. 13 for each window (rows of P, N).

    ∫|(F_low P + β F_high N) g|² df = ∫|P g|² df is a β² + b β + c = 0 with
    a = Σ|F_high N g|², b = 2 Re Σ F_low F_high P N* g², c = Σ (F_low² - 1)|P|² g²
    (c ≤ 0, so the larger root is ≥ 0).  Windows without noise power get β = 0.

    Parameters
    ----------
    P, N : (W, F) spectra of the windowed signal and windowed noise.
    f_low, f_high, g : (F,) blend filters and weight.

    Returns
    -------
    (W,) β.
    """
    g2 = g**2
    a = np.sum(np.abs(N) ** 2 * (f_high**2 * g2), axis=-1)
    b = 2 * np.sum((P * np.conj(N)).real * (f_low * f_high * g2), axis=-1)
    c = np.sum(np.abs(P) ** 2 * ((f_low**2 - 1) * g2), axis=-1)
    disc = np.maximum(b * b - 4 * a * c, 0.0)
    ok = a > 0
    beta = np.zeros_like(a)
    beta[ok] = (-b[ok] + np.sqrt(disc[ok])) / (2 * a[ok])
    return np.maximum(beta, 0.0)


def expected_band_kernel(
    mag: NDArray[np.floating], weight: NDArray[np.floating], L: int, *, ratio: int = 1
) -> NDArray[np.float64]:
    """Vector v with E[Σ_k |weight_k Ñ_W[k]|²] = |Ỹ|² · v over random phases.

    Ñ_W = DFT_L(N · y) with N = IDFT_Ln(mag · e^{-iθ}) (uniform independent
    θ, Ln = L / ratio samples) and y = |p w| the window's envelope, Ỹ = DFT_L(y).
    Since E[n_t n_t'] = (1/Ln²) Σ_m |X_m|² e^{2πi m (t - t')/Ln},
    E|Ñ_W[k]|² = (1/Ln²) Σ_{m>0} mag_m² (|Ỹ[k - ratio m]|² + |Ỹ[k + ratio m]|²),
    with |Ỹ[-q]| = |Ỹ[q]| = |Ỹ[L - q]| for a real envelope.

    Parameters
    ----------
    mag : (Ln // 2 + 1,) noise magnitudes on the noise's rfft bins.
    weight : (F,) band weight F_high g of Eq. 13 on the frame's bins (F = L // 2 + 1).
    L : frame length.
    ratio : L / Ln (integer).

    Returns
    -------
    (F,) v such that the expected band power is ``abs(rfft(y))**2 @ v``.
    """
    F = L // 2 + 1
    w2 = np.asarray(weight, dtype=np.float64) ** 2
    band = np.flatnonzero(w2 > 1e-12 * w2.max()) if w2.max() > 0 else np.zeros(0, np.int64)
    s2 = np.asarray(mag, dtype=np.float64) ** 2
    m = np.arange(1, s2.size)
    v = np.zeros(F)
    for k in band:
        for q in (np.abs(k - ratio * m), k + ratio * m):
            q = np.abs(q) % L
            q = np.where(q > L // 2, L - q, q)
            v += w2[k] * np.bincount(q, weights=s2[m], minlength=F)[:F]
    return v / (L // ratio) ** 2


def check_signal(p: NDArray[np.floating], what: str = "input") -> NDArray[np.float64]:
    """A finite, non-silent 1-D signal, or a DataError naming the problem."""
    x = np.asarray(p, dtype=np.float64)
    if x.ndim != 1:
        raise DataError(f"{what} must be a mono signal (n_samples,), got shape {x.shape}")
    if x.size == 0:
        raise DataError(f"{what} signal is empty")
    bad = int(np.count_nonzero(~np.isfinite(x)))
    if bad:
        raise DataError(
            f"{what} signal has {bad} NaN/Inf samples (first at index "
            f"{int(np.argmax(~np.isfinite(x)))})"
        )
    if not np.any(x):
        raise DataError(f"{what} signal is silent (all samples are zero)")
    return x


def bandwidth_extend(
    p: NDArray[np.floating],
    rate: float,
    *,
    alpha: float = 3.0,
    f_cut: float = 180.0,
    sigma_cut: float = 10.0,
    w_h: int = 500,
    blend: tuple[float, float] = (165.0, 195.0),
    pad: int = 8,
    beta: str = "expected",
    seed: int | None = 0,
    return_beta: bool = False,
) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Extend a low-frequency fire sound with power-law noise (Algorithm 1).

    Parameters
    ----------
    p : (n,) low-frequency pressure (any units), e.g. from §3 after the 30 Hz high-pass.
    rate : sample rate in Hz.
    alpha : power-law exponent of the added noise, P(f) ∝ f^-α (paper: 2.5–3.5).
    f_cut : Hz, centre of the blend; Table 1: 180 Hz (Nyquist of 360 Hz steps).
    sigma_cut : Hz, std of the Gaussian weight g(f) of Eq. 13.
    w_h : window half-width in samples (Table 1: 500).
    blend : (lo, hi) Hz, the linear blend range of F_low/F_high.
    pad : FFT frame length in units of w_h (zero-padding; even, >= 4).
    beta : how Eq. 13 is solved.  ``"realised"`` uses the band power of the
        window's own noise draw (the paper, literally): that power is
        χ²-distributed with about two degrees of freedom (the 30 Hz band holds
        ~one independent bin of a 23 ms window), so 1/β² has no finite mean
        and single windows can carry most of the high-band energy.
        ``"expected"`` (default) uses the noise band power averaged over the
        random phases (:func:`expected_band_kernel`; the cross term then
        vanishes), which keeps Eq. 13's power balance on average and the
        slope of the added noise stable from seed to seed.
    seed : seed of the random phases (same seed, same output).
    return_beta : also return β of each window.

    Returns
    -------
    (n,) extended pressure (same units as ``p``) [, (W,) β].

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(44100) / 44100
    >>> low = np.sin(2 * np.pi * 60 * t) + 0.5 * np.sin(2 * np.pi * 170 * t)
    >>> out = bandwidth_extend(low, 44100, seed=1)
    >>> out.shape
    (44100,)
    """
    prm = ExtensionParams(
        float(alpha),
        float(f_cut),
        float(sigma_cut),
        w_h,
        float(blend[0]),
        float(blend[1]),
        pad,
        beta,
    )
    prm.check(rate)
    x = check_signal(p)
    wh, m = int(prm.w_h), int(prm.pad)
    L, Ln = m * wh, 2 * wh  # FFT frame length; window support (and noise length)
    n = x.size
    n_win = -(-(n - 1) // wh) + 1  # centres 0, w_H, …, ≥ n - 1
    # window i covers samples c_i - w_H + j, j = 0 … 2 w_H - 1 (the hat is 0 at both ends)
    xp = np.zeros((n_win + 1) * wh)
    xp[wh : wh + n] = x
    frames = np.lib.stride_tricks.sliding_window_view(xp, Ln)[::wh][:n_win]
    j = np.arange(Ln)
    win = (wh - np.abs(j - wh)) / wh  # Algorithm 1 line 4, normalised: Σ_i w_i = 1
    # single precision from here on (float32 output files; 1e-7 relative error)
    pw = (frames * win).astype(np.float32)  # (W, 2 w_H), windowed signal p_W
    env = np.abs(pw)  # |p(t) w(t)| (Fig. 4)
    freqs = sfft.rfftfreq(L, 1.0 / rate)
    f_low, f_high, g = blend_filters(freqs, prm)
    # power-law noise |Ñ(f)| = f^(-α/2) with uniform random phases, high-passed by
    # F_high (§4 background), generated on the window's own length 2 w_H; the
    # noise path runs in single precision (it is random to begin with)
    fn = sfft.rfftfreq(Ln, 1.0 / rate)
    mag = np.zeros_like(fn)
    mag[1:-1] = fn[1:-1] ** (-prm.alpha / 2) * blend_filters(fn[1:-1], prm)[1]
    mag /= max(float(np.sqrt(np.sum(mag**2))), 1e-300)
    rng = np.random.default_rng(seed)
    theta = rng.random((n_win, fn.size), dtype=np.float32)
    theta = theta * np.float32(2 * np.pi) - np.float32(np.pi)
    spec = np.empty(theta.shape, dtype=np.complex64)
    spec.real = np.cos(theta)
    spec.imag = -np.sin(theta)
    spec *= mag.astype(np.float32)
    nw = sfft.irfft(spec, n=Ln, axis=1) * env  # N_W (Fig. 4)
    # spectra on the zero-padded frame (content at the frame start; placed below)
    P = sfft.rfft(pw, n=L, axis=1)
    N = sfft.rfft(nw, n=L, axis=1)
    band = np.flatnonzero(g > 1e-6)  # g² > 1e-12: the rest of Eq. 13's integrals is nil
    Pb = P[:, band].astype(np.complex128)
    if prm.beta == "realised":
        beta = choose_beta(Pb, N[:, band].astype(np.complex128), f_low[band], f_high[band], g[band])
    else:
        env2 = np.abs(sfft.rfft(env, n=L, axis=1)) ** 2
        v = expected_band_kernel(mag, (f_high * g), L, ratio=m // 2).astype(np.float32)
        a = (env2 @ v).astype(np.float64)
        c = np.sum(np.abs(Pb) ** 2 * ((f_low[band] ** 2 - 1) * g[band] ** 2), axis=-1)
        beta = np.sqrt(np.where(a > 0, -c / np.where(a > 0, a, 1.0), 0.0))
    f_low32 = f_low.astype(np.float32)
    N *= beta.astype(np.float32)[:, None] * f_high.astype(np.float32)
    P *= f_low32
    P += N
    blended = sfft.irfft(P, n=L, axis=1)  # Eq. 12
    # overlap-add (Algorithm 1 line 9).  Frame block b holds samples c_i + (b - 1) w_H …;
    # blocks past the middle are the wrapped-around acausal tail of the zero-phase
    # blend filters and belong before the window: (b - 1 - m) w_H.
    base = m + m // 2  # array block of sample block q is base + q
    blocks = np.zeros((n_win + 2 * m + 1, wh), dtype=np.float32)
    b3 = blended.reshape(n_win, m, wh)
    for b in range(m):
        d = base + (b - 1 if b <= m // 2 else b - 1 - m)
        blocks[d : d + n_win] += b3[:, b]
    out = blocks.reshape(-1)[base * wh : base * wh + n].astype(np.float64)
    return (out, beta) if return_beta else out


def params_dict(**kw: object) -> dict[str, object]:
    """Table 1 defaults merged with ``kw`` (for sidecars and reports)."""
    return {**asdict(ExtensionParams()), **kw}
