"""Sampled backend of the emitters engine: audio-rate point emitters, compiled.

For every emitter the smooth quantities of the received sum (paper 003
§3.2.4.2 for the retarded time; far-field point-source law, paper 000 §6,
Eq. 5 and paper 004 §6, Eq. 4)

    p(t) = Σ_s  a_s(τ_s) · g(D_s),   t − τ_s = |L(t) − x_s(τ_s)| / c0

are evaluated at *control points* every ``K`` samples of the evaluation rate:
the retarded time τ (Newton's method for a moving emitter, from the delay of
the emitter's place at t) and its rate ``dτ/dt = (1 − n·v_L/c0) / (1 − n·v_s/c0)``, the clamped
distance law ``1/D^e`` (the delay uses the unclamped distance), a dipole's
projection on the unit vector n from the emitter to the listener, and the
layout's panning gains (the synthesis kernel's own law,
:func:`auralize.emitters._kernels.gains._gains`: pairwise 2-D VBAP, 3-D VBAP for
layouts with elevation, the AmbiX encoding for ``ambix1..3``; equal to
:func:`auralize.spatial.layouts.pan_gains`).  Inside
a block the emission index is the cubic Hermite interpolant of τ and dτ/dt,
the weights and gains are interpolated linearly; a block holding a listener
capture (where the listener's velocity jumps) is split there into two linear
pieces.  The emitted signal is read linearly at the emission index, weighted
and added to the channels with non-zero gains.  Table emitters
(:class:`auralize.emitters.TableEmitters`) are evaluated at the emission index
itself: inside each of their table blocks the table position is linear in the
index (exact) and the weights of the table components are taken linear
through their values at the block's ends and at the control points; the
index advances by forward differences of its cubic.  Against the per-sample numpy
reference (:mod:`auralize.emitters.reference`) this is within about 1e-4 of
the peak in mono and 1e-3 panned (the gains have kinks at speaker
directions) for a turning, moving listener and emitters at tens of m/s.

Control points lie on a grid fixed in playback time (multiples of ``K``
evaluation samples), so a render split into consecutive windows gives the
same samples as one render: live playback renders block by block.

Emitters sampled well below the output rate are first upsampled band-limited
(at most ``oversample`` ×) and, when the output rate is an integer multiple
of that, evaluated at the lower *internal rate* and resampled band-limited to
the output rate (the signal holds nothing above its own Nyquist frequency, so
the anti-imaging filter is short).  The output blocks are split between up to
two threads (the kernel releases the GIL) over disjoint ranges of samples.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.emitters._kernels.emission import Tables, table_samples
from auralize.emitters._kernels.sampled import (
    CHUNK_BLOCKS,
    ControlPoints,
    Sources,
    Speakers,
    bounding_box,
    render,
)
from auralize.emitters.parallel import N_THREADS, run_pieces
from auralize.runtime.jit import kernel_arg, kernel_args

#: evaluation samples between control points
BLOCK = 32
#: evaluation samples below which one thread does all the work
_MIN_SPLIT = 16384
_N_THREADS = N_THREADS


def scratch(cw: int, n_ch: int, K: int) -> NDArray[np.float64]:
    """Scratch of one :func:`auralize.emitters._kernels.sampled.render` call: ``cw``
    weights per control point (signal components and table components), ``n_ch``
    channels, ``K`` samples per block."""
    CB = CHUNK_BLOCKS
    return np.empty(5 * CB + 4 + (2 * CB + 1) * (cw + n_ch) + K)


def table_signals(em: Any) -> NDArray[np.float64]:
    """The emission samples ``(S, C, n)`` of :class:`auralize.emitters.TableEmitters` ``em``."""
    S, B, C, _ = em.qa.shape
    out = np.empty((S, C, B * em.block))
    n_pieces = max(1, min(S, 4 * _N_THREADS)) if out.size >= _MIN_SPLIT else 1
    edges = [S * i // n_pieces for i in range(n_pieces + 1)]
    tables, out = _tables(em, True), kernel_arg(out)
    _run(lambda i: table_samples(tables, out, edges[i], edges[i + 1]), n_pieces, _N_THREADS)
    return out


def _tables(em: Any, gen: bool) -> Tables:
    """The :class:`~auralize.emitters._kernels.emission.Tables` of table emitters ``em``
    (``gen``), or placeholders (stored signals)."""
    if gen:
        return Tables(
            *kernel_args(
                True,
                em.padded_table,
                _lengths(em),
                em.qa,
                em.qb,
                em.phase,
                em.r0,
                em.r1,
                em.w,
                int(em.block),
            )
        )
    zi = np.zeros((1, 1), dtype=np.int64)
    return Tables(
        False,
        np.zeros((1, 2, 1)),
        np.ones((1, 2)),
        np.zeros((1, 1, 1, 1)),
        np.zeros((1, 1, 1, 1)),
        np.zeros((1, 2)),
        zi,
        zi,
        np.zeros((1, 1)),
        1,
    )


def _lengths(em: Any) -> NDArray[np.float64]:
    """``(R, 2)``: the table rows' lengths and their inverses."""
    n = em.lengths.astype(np.float64)
    return np.ascontiguousarray(np.stack([n, 1.0 / n], axis=1))


def _run(fn: Callable[[int], None], n: int, nt: int) -> None:
    """``fn(i)`` for every i < n on up to ``nt`` threads (:func:`auralize.emitters.parallel.run_pieces`)."""
    run_pieces(fn, n, nt)


@dataclass
class Prepared:
    """Emitted signals ready for the kernel: ``sig (S, C, n)`` (C-contiguous, writable
    float64: :func:`auralize.runtime.jit.kernel_arg`) at rate ``fs`` from ``t0``
    (band-limited upsampled by ``up`` from the emitters' own rate)."""

    sig: NDArray[np.float64]
    fs: float
    t0: float
    up: int


def upsampling(rate_in: float, rate_out: int, oversample: int) -> int:
    """Integer band-limited upsampling factor of emitted signals (1: none).

    Emitters below half the output rate are upsampled to about ``oversample``
    × their rate (never above the output rate), so that the linear read at
    the retarded time has no audible images.
    """
    if oversample <= 1 or rate_in * 1.5 > rate_out:
        return 1
    return int(max(1, min(int(oversample), math.floor(rate_out / rate_in + 1e-9))))


def prepare(
    signals: NDArray[np.float64],
    rate: float,
    t0: float,
    up: int,
    i_lo: int = 0,
    i_hi: int | None = None,
) -> Prepared:
    """Samples ``i_lo:i_hi`` of ``signals (S, n)`` or ``(S, 3, n)``, upsampled ``up`` ×."""
    from scipy.signal import resample_poly

    sig = signals[:, None, :] if signals.ndim == 2 else signals
    n = sig.shape[2]
    i_hi = n if i_hi is None else i_hi
    if up == 1:  # read in place when contiguous float64 (float32 of a model: widened, exactly)
        return Prepared(kernel_arg(sig), float(rate), float(t0), 1)
    seg = sig[:, :, i_lo:i_hi]
    S, C, m = seg.shape
    flat = np.ascontiguousarray(seg, dtype=np.float64).reshape(S * C, m)
    # resample_poly's rows are padded apart: one contiguous copy, so that the kernel has
    # one signature (a strided 'A' array would be a second specialization to compile)
    y = kernel_arg(resample_poly(flat, up, 1, axis=1))
    return Prepared(
        y.reshape(S, C, m * up), float(rate) * up, float(t0) + i_lo / float(rate), int(up)
    )


#: half-length (input samples) of :func:`scipy.signal.resample_poly`'s default filter
_UP_HALF = 12


def _internal_factor(rate: int, fs: float) -> int:
    """Largest k with ``rate % k == 0`` and ``rate / k >= fs`` (1: evaluate at the output rate)."""
    k = int(math.floor(rate / fs + 1e-9))
    while k > 1 and rate % k:
        k -= 1
    return max(k, 1)


def _anti_image(k: int, rate: int, band: float) -> NDArray[np.float64]:
    """Kaiser FIR (80 dB) at ``rate`` passing ``band`` Hz and stopping from ``rate/k − band``."""
    from scipy.signal import firwin, kaiserord

    R = rate / k
    band = min(band, 0.45 * R)
    width = max(R - 2 * band, 0.05 * R)
    numtaps, beta = kaiserord(80.0, width / (0.5 * rate))
    numtaps += 1 - numtaps % 2
    return np.asarray(firwin(numtaps, band + 0.5 * width, fs=rate, window=("kaiser", beta)))


def _path_velocities(path: Any, t: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Listener velocity (m/s) at path times ``t`` on the segment after and before each."""
    T, P = path.times, path.positions
    n = T.size
    if n < 2:
        z = np.zeros((t.size, 3))
        return z, z.copy()
    dt = np.diff(T)
    v = np.diff(P, axis=0) / np.where(dt > 0, dt, 1.0)[:, None]
    v[dt <= 0] = 0.0
    v = np.vstack([np.zeros((1, 3)), v, np.zeros((1, 3))])  # held outside the path
    iR = np.searchsorted(T, t, side="right")
    iL = np.searchsorted(T, t, side="left")
    return np.ascontiguousarray(v[iR]), np.ascontiguousarray(v[iL])


def _orientations(path: Any, t: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Forward and up ``(len(t), 3)`` at path times t: :meth:`ListenerPath.orientation_at`,
    or its one orientation repeated when the path never turns."""
    f, u = path.forward, path.up
    if f is not None and u is not None and np.all(f == f[0]) and np.all(u == u[0]):
        F, U = path.orientation_at(t[:1])
        return np.repeat(F, t.size, axis=0), np.repeat(U, t.size, axis=0)
    return tuple(path.orientation_at(t))


def render_sampled(
    em: Any,
    path: Any,
    *,
    rate: int,
    layout: Any,
    n_out: int,
    start: float,
    c0: float,
    block: int = BLOCK,
    oversample: int = 4,
    internal: bool = True,
    prepared: Prepared | None = None,
    threads: int | None = None,
) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """Pressure ``(n_channels, n_out)`` of :class:`auralize.emitters.Emitters` ``em``.

    Output sample n is heard at playback second ``start + n / rate``.

    Parameters
    ----------
    block : int
        Evaluation samples between control points.
    oversample : int
        Emitters below the output rate are upsampled band-limited to at most
        this × their rate (1: read as given).
    internal : bool
        Evaluate at an integer fraction of the output rate when the
        (upsampled) signals allow it, then resample band-limited.
    prepared : Prepared, optional
        The whole signals already prepared (:func:`prepare`; block renderers
        reuse them).
    threads : int, optional
        Threads (default: up to 2 for long windows).

    Returns
    -------
    audio, meta (``internal_rate_hz``, ``signal_rate_hz``, ``block``, ``threads``)
    """
    from auralize.emitters import TableEmitters, law_exponent
    from auralize.emitters.synthesis import pan_table, panning_arrays
    from auralize.spatial.layouts import receiver_paths

    ears = receiver_paths(layout, path)
    if ears:  # several receivers (the ears): each along its own path, channels stacked
        outs = [
            render_sampled(
                em,
                p,
                rate=rate,
                layout=rl,
                n_out=n_out,
                start=start,
                c0=c0,
                block=block,
                oversample=oversample,
                internal=internal,
                prepared=prepared,
                threads=threads,
            )
            for rl, p in ears
        ]
        return np.concatenate([o[0] for o in outs]), outs[0][1]

    # table emitters are read from their tables, unless they need upsampling
    gen = isinstance(em, TableEmitters) and upsampling(em.rate, rate, oversample) == 1
    lay = layout
    n_ch = lay.n_channels
    e = law_exponent(em.law)
    K = int(block)
    if gen:
        up = 1
    else:
        up = prepared.up if prepared is not None else upsampling(em.rate, rate, oversample)
    fs = em.rate * up
    k = _internal_factor(int(rate), fs) if internal else 1
    m0f = start * rate
    m0 = int(round(m0f))
    aligned = abs(m0f - m0) < 1e-6
    if not aligned:
        k = 1
    R = rate / k
    h = _anti_image(k, int(rate), 0.5 * em.rate * 1.25) if k > 1 else np.zeros(0)
    P = (h.size // (2 * k) + 2) if k > 1 else 0
    # evaluation sample j is at playback second j / R (a grid fixed in time, so
    # windows join without seams) or, for a start off the output grid, start + j / R
    if aligned:
        j_lo = m0 // k - P
        n_int = -(-(m0 + n_out) // k) - j_lo + P + 1 if k > 1 else n_out
        t_base = 0.0
    else:
        j_lo, n_int = 0, n_out
        t_base = float(start)

    def t_of(j: Any) -> Any:
        return t_base + j / R

    K = max(4, int(round(K / k)))  # control points as often in time as at the output rate
    meta = {"internal_rate_hz": float(R), "signal_rate_hz": float(fs), "block": K}
    if n_out <= 0:
        return np.zeros((n_ch, max(n_out, 0))), {**meta, "threads": 0}
    t_lo, t_hi = t_of(j_lo), t_of(j_lo + n_int)
    tp0 = path.times[0]
    if gen:  # generated where they are read: no signal window
        prepared = Prepared(np.zeros((1, em.qa.shape[2], 1)), float(em.rate), float(em.t0), 1)
    elif prepared is None:
        # emission window: every retarded time of the window, bounded by distances
        lp = path.position_at(tp0 + np.linspace(t_lo, t_hi, 16))
        lo, hi = bounding_box(*kernel_args(em.positions.reshape(-1, 3), lp))
        d_max = float(np.linalg.norm(hi - lo))
        tau_lo, tau_hi = t_lo - d_max / c0, t_hi
        i_lo = max(0, int(math.floor((tau_lo - em.t0) * em.rate)) - _UP_HALF)
        i_hi = min(em.n_samples, int(math.ceil((tau_hi - em.t0) * em.rate)) + _UP_HALF + 1)
        if i_hi <= i_lo:
            return np.zeros((n_ch, n_out)), {**meta, "threads": 0}
        prepared = prepare(em.signals, em.rate, em.t0, up, i_lo, i_hi)
    B = -(-(n_int + (j_lo % K)) // K)
    off = j_lo % K
    tb = t_of(j_lo - off + np.arange(B + 1, dtype=np.float64) * K)
    L = np.ascontiguousarray(path.position_at(tp0 + tb))
    VR, VL = _path_velocities(path, tp0 + tb)
    if n_ch > 1:
        F, U = _orientations(path, tp0 + tb)
        spk_az, spk_ch = panning_arrays(lay)
        pinv = pan_table(lay, spk_az)
    else:
        F = U = np.zeros((B + 1, 3))
        spk_az, spk_ch, pinv = np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, 4))
    F, U = np.ascontiguousarray(F), np.ascontiguousarray(U)
    # listener captures strictly inside a block: kinks of the listener's path
    kf = np.full(B, -1.0)
    tcap = path.times - tp0
    inside = (tcap > tb[0]) & (tcap < tb[-1])
    if np.any(inside):
        tc = tcap[inside]
        bi = np.clip(np.searchsorted(tb, tc, side="right") - 1, 0, B - 1)
        frac = (tc - tb[bi]) / (tb[bi + 1] - tb[bi]) * K
        keep = (frac > 1e-6) & (frac < K - 1e-6)
        bi, frac = bi[keep], frac[keep]
        if bi.size:
            first = np.r_[True, bi[1:] != bi[:-1]]  # one kink per block (the first)
            kf[bi[first]] = frac[first]
    tk = np.where(kf >= 0, tb[:-1] + np.maximum(kf, 0.0) / K * np.diff(tb), 0.0)
    if np.any(kf >= 0):
        Lk = np.ascontiguousarray(path.position_at(tp0 + tk))
    else:  # read only at kinks
        Lk = np.zeros((B, 3))
    if n_ch > 1 and np.any(kf >= 0):
        Fk, Uk = (np.ascontiguousarray(a) for a in path.orientation_at(tp0 + tk))
    else:
        Fk = Uk = np.zeros((B, 3))
    pos = em.positions if em.moving else em.positions[:, None, :]
    out = np.zeros((n_ch, n_int))
    nt = threads if threads is not None else (_N_THREADS if n_int >= _MIN_SPLIT else 1)
    nt = max(1, min(int(nt), _N_THREADS, B))
    n_pieces = min(B, 4 * nt) if nt > 1 else 1  # taken in turn by the threads
    edges = [B * i // n_pieces for i in range(n_pieces + 1)]
    tables = _tables(em, gen)
    # one compiled signature whatever the arrays' dtype, layout and write flag (the
    # outputs are this function's own C-contiguous float64 arrays, passed as they are)
    src = Sources(
        *kernel_args(
            prepared.sig,
            prepared.fs,
            prepared.t0,
            pos,
            float(em.pos_rate),
            float(em.t0),
            em.radius,
            float(e),
        )
    )
    lis = ControlPoints(*kernel_args(tb, L, VR, VL, F, U, kf, tk, Lk, Fk, Uk))
    spk = Speakers(
        *kernel_args(
            np.asarray(spk_az, dtype=np.float64),
            np.asarray(spk_ch, dtype=np.int64),
            bool(lay.fold_front),
            pinv,
        )
    )
    # weights per control point: the signal components, then the table components (one
    # placeholder for stored signals)
    cw = (em.qa.shape[2] if gen else prepared.sig.shape[1]) + tables.qa.shape[3]
    c0, K, off = float(c0), int(K), int(off)

    def one(i: int) -> None:
        render(src, lis, spk, tables, c0, K, off, out, scratch(cw, n_ch, K), edges[i], edges[i + 1])

    _run(one, n_pieces, nt)
    if k > 1:
        from scipy.signal import resample_poly

        y = resample_poly(out, k, 1, axis=1, window=h)
        a = m0 - j_lo * k
        out = np.ascontiguousarray(y[:, a : a + n_out])
    return out, {**meta, "threads": nt}
