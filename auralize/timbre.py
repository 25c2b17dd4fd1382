"""Audible rendering modes (timbres) on top of the retarded-time synthesis.

Three timbres, each keeping what makes field auralization worth doing —
where a source is (panning), when its sound arrives (delay D/c0), how loud
it is (1/D) and the Doppler shift of a moving listener:

``physical``
    The retarded-time pressure of :func:`auralize.synthesis.render`
    (paper 003 Eqs. 15–17).  Honest, and infrasonic whenever the data's time
    steps are long in playback time.
``extended``
    Spectral bandwidth extension after paper 001 §4 (Eqs. 12–13, Table 1):
    the physical pressure is kept below the cut-off ``f_cut`` (the Nyquist
    frequency of the data's time stepping in playback time), and above it
    each source's strength envelope |q_k| drives noise with a power-law
    spectrum f^(−α) (Table 1: α 2.5–3.5).  The band split of Eq. 12 is a
    causal 4th-order Linkwitz–Riley crossover at ``f_cut`` (the paper blends
    FFT windows linearly over ±15 Hz; a causal split keeps every onset at
    its arrival time), and the noise is scaled by β, the positive root of
    the quadratic Eq. 13, which matches the blended power to the physical
    power under a Gaussian g(f) around ``f_cut`` (σ = f_cut/18 as in
    Table 1, at least three frequency bins) — once per render, on the
    channel sum, where the paper matches every 11 ms window: the envelope
    |q_k| already carries the time structure.
``tonal``
    Parameter-mapping sonification: every source type gets its own carrier
    (monopoles a one-octave noise band around 250 Hz, dipoles a 440 Hz tone,
    quadrupoles 660 Hz, a fifth above), its amplitude the source's strength
    envelope |q_k|.  Each type's strengths are divided by the type's peak so
    that the three are heard side by side (loudness across types is not
    physical; within a type, and with distance, it is).

How the carriers keep the physics.  A source k emits ``|q_k|(τ) c(τ)``
(envelope times carrier, in emission time τ); the listener hears
``Σ_k |q_k|(τ_k) c(τ_k) / D_k`` with ``τ_k = t − D_k/c0``.  The envelope
sum ``E(t) = Σ_k |q_k|(τ_k)/D_k`` is rendered exactly, per loudspeaker, by
the fast synthesis (:func:`auralize.synthesis.render` on the tracks |q|),
so the arrival time, the 1/D law and the panning are those of the physical
render.  The carrier is evaluated once per type at the envelope-weighted
mean emission time ``τ̄(t) = t − D̄(t)/c0`` with
``D̄ = Σ w_k / Σ (w_k/D_k)``, ``w_k = |q_k|(τ_k)`` (source clusters of an
8×8×8 partition of the sources' box, at 100 control points per playback
second), so a moving listener hears the carrier Doppler-shifted by
``dτ̄/dt``.  For one compact source this is exactly the propagated emission;
for many, the carrier's phase is shared (no interference between sources).
Noise carriers are fixed functions of emission time (one table per seed),
so the same source heard from two places is the same noise, delayed.

Which to use when: ``physical`` when the data are sampled fast enough to
be heard (its energy above 20 Hz, see :func:`loudness`) or to study the
pressure itself; ``extended`` to hear slow data as the sound of its
sources (power-law noise is what turbulent flows and flames radiate);
``tonal`` to tell source types apart by ear.

Examples
--------
>>> import numpy as np
>>> from auralize.sources import SourceTracks
>>> from auralize.listener import ListenerPath
>>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 4)), radius=np.full(1, 0.1),
...                   times=np.arange(4) * 0.1, kind=np.ones((1, 4), dtype=np.int8))
>>> out = render_timbre(tr, ListenerPath.point([17.0, 0, 0], duration=0.4), timbre="tonal",
...                     rate=8000)
>>> out.audio.shape, out.meta["timbre"]
((1, 3200), 'tonal')
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.sources import TYPES, SourceTracks
from auralize.spatial import Layout, output_stage
from auralize.synthesis import C0, Rendered, _cached, _knot_times, check_distance, render

TIMBRES = ("physical", "extended", "tonal")
#: ``auto`` renders ``physical`` when at least this share of its energy is above 20 Hz,
#: else ``extended``
AUDIBLE_SHARE = 0.5
#: default output high-pass (Hz): below it nothing is audible (paper 001 §6 uses 30 Hz)
HIGHPASS_HZ = 20.0
#: tonal carriers per type: ("noise", low Hz, high Hz) or ("tone", Hz)
TONAL_CARRIERS: dict[str, tuple[Any, ...]] = {
    "monopole": ("noise", 177.0, 354.0),
    "dipole": ("tone", 440.0),
    "quadrupole": ("tone", 660.0),
}
#: power-law exponent α of the extension noise (paper 001 Table 1: 2.5–3.5)
ALPHA = 2.5
#: control points of the mean emission time per playback second
CONTROL_HZ = 100.0
#: clusters per axis for the mean distance
CLUSTERS = 8
#: longest noise table (samples); a longer emission span uses the part heard
MAX_TABLE = 1 << 24


def highpass(audio: NDArray[np.float64], rate: float, hz: float) -> NDArray[np.float64]:
    """Causal 4th-order Butterworth high-pass of ``audio (n_channels, n_samples)``.

    ``hz`` 0 returns the audio unchanged.  Causal, so nothing arrives before
    its time (a zero-phase filter would ring ahead of onsets).
    """
    if not (np.isfinite(hz) and 0 <= hz < rate / 2):
        raise ParameterError(f"highpass must be 0 (off) or between 0 and {rate / 2:g} Hz (half "
                             f"the sample rate), got {hz!r}")  # fmt: skip
    if hz == 0 or audio.shape[-1] == 0:
        return audio
    from scipy.signal import sosfilt

    return np.asarray(sosfilt(butter_sos(4, float(hz), "highpass", float(rate)), audio, axis=-1))


@functools.lru_cache(maxsize=64)
def butter_sos(order: int, hz: float, kind: str, rate: float) -> NDArray[np.float64]:
    """Second-order sections of a Butterworth filter (cached: designing one costs
    more than filtering a second of audio; callers must not modify them)."""
    from scipy.signal import butter

    return np.asarray(butter(order, hz, btype=kind, fs=rate, output="sos"))


def loudness(audio: NDArray[np.float64], rate: float, *,
             split_hz: float = 20.0) -> dict[str, float]:  # fmt: skip
    """Peak and RMS (over all channels) and the share of the energy above ``split_hz``."""
    a = np.atleast_2d(audio)
    if a.size == 0:
        return {"peak": 0.0, "rms": 0.0, "above_hz": split_hz, "share_above": 0.0}
    spec = np.sum(np.abs(np.fft.rfft(a, axis=-1)) ** 2, axis=0)
    f = np.fft.rfftfreq(a.shape[-1], 1.0 / rate)
    total = float(spec.sum())
    share = float(spec[f > split_hz].sum() / total) if total > 0 else 0.0
    return {"peak": float(np.max(np.abs(a))), "rms": float(np.sqrt(np.mean(a * a))),
            "above_hz": split_hz, "share_above": share}  # fmt: skip


def _subset(tracks: SourceTracks, q: NDArray[np.float64]) -> SourceTracks:
    """The tracks with strengths ``q``, rows that never sound dropped."""
    keep = np.any(q != 0, axis=1)
    return SourceTracks(positions=np.asarray(tracks.positions).reshape(-1, 3)[keep],
                        q=np.ascontiguousarray(q[keep]), radius=np.asarray(tracks.radius)[keep],
                        times=tracks.times)  # fmt: skip


def mean_distance(tracks: SourceTracks, path: ListenerPath, t_data: NDArray[np.float64],
                  t_play: NDArray[np.float64], *, c0: float = C0) -> NDArray[np.float64]:  # fmt: skip
    """Envelope-weighted mean source distance D̄ (m) heard at data times ``t_data`` (J,)
    when the listener is at its playback times ``t_play`` (J,) on ``path``.

    ``D̄ = Σ_c w_c / Σ_c (w_c / D_c)`` over clusters c of the sources (an
    8×8×8 partition of their box; position the |q|-weighted centroid), with
    ``w_c = Σ_{k in c} |q_k|(t − D_c/c0)`` linearly interpolated between steps:
    the distance whose delay the loudest arrivals share.  Where nothing is
    heard, the nearest control's value is held.
    """
    L = path.position_at(t_play)
    if tracks.n_sources == 0:
        return np.zeros(t_data.size)
    cen, W = _cached(tracks, "timbre:clusters", "", lambda: _clusters(tracks))
    C = cen.shape[0]
    tn = _knot_times(tracks)
    D = np.maximum(np.linalg.norm(L[:, None, :] - cen[None, :, :], axis=2), 1e-9)  # (J, C)
    tau = t_data[:, None] - D / c0
    n = np.clip(np.searchsorted(tn, tau, side="right") - 1, 0, tn.size - 2)
    s = np.clip((tau - tn[n]) / (tn[n + 1] - tn[n]), 0.0, 1.0)
    cols = np.arange(C)[None, :]
    wt = W[cols, n] * (1 - s) + W[cols, n + 1] * s
    wt = np.where((tau >= tn[0]) & (tau <= tn[-1]), wt, 0.0)
    num, den = wt.sum(axis=1), (wt / D).sum(axis=1)
    ok = den > 0
    if not np.any(ok):
        return np.min(D, axis=1)
    dbar = np.where(ok, num / np.where(ok, den, 1.0), np.nan)
    idx = np.flatnonzero(ok)
    nearest = idx[np.clip(np.searchsorted(idx, np.arange(dbar.size)), 0, idx.size - 1)]
    return np.where(ok, dbar, dbar[nearest])


def _clusters(tracks: SourceTracks) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Clusters of the sources for :func:`mean_distance`: |q|-weighted centroids
    ``(C, 3)`` and summed |q| per step, padded with a silent step at both ends
    ``(C, T + 2)``."""
    pos = np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)
    w = np.abs(np.asarray(tracks.q, dtype=np.float64))
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    cell3 = np.minimum((CLUSTERS * (pos - lo) / np.maximum(hi - lo, 1e-300)).astype(np.int64),
                       CLUSTERS - 1)  # fmt: skip
    cell = (cell3[:, 0] * CLUSTERS + cell3[:, 1]) * CLUSTERS + cell3[:, 2]
    order = np.argsort(cell, kind="stable")
    cs = cell[order]
    starts = np.flatnonzero(np.append(True, cs[1:] != cs[:-1]))
    inv = np.cumsum(np.append(True, cs[1:] != cs[:-1])) - 1  # cluster of each sorted source
    C = starts.size
    ws = w[order]
    wk = ws.sum(axis=1)
    wsum = np.bincount(inv, weights=wk, minlength=C)
    ps = pos[order]
    cen = np.stack([np.bincount(inv, weights=wk * ps[:, a], minlength=C) for a in range(3)], 1)
    plain = np.stack([np.bincount(inv, weights=ps[:, a], minlength=C) for a in range(3)], 1)
    cnt = np.bincount(inv, minlength=C)
    cen = np.where(wsum[:, None] > 0, cen / np.where(wsum > 0, wsum, 1)[:, None],
                   plain / cnt[:, None])  # fmt: skip
    W = np.zeros((C, w.shape[1] + 2))  # padded with silent steps like the synthesis knots
    W[:, 1:-1] = np.add.reduceat(ws, starts, axis=0)
    return np.asarray(cen, dtype=np.float64), W


_TABLES: dict[tuple[Any, ...], NDArray[np.float64]] = {}
_TABLES_MAX = 8


def _noise_table(n: int, rate: float, seed: tuple[int, ...], shape: Any,
                 key: tuple[Any, ...]) -> NDArray[np.float64]:  # fmt: skip
    """``n`` samples of unit-RMS noise whose amplitude spectrum is ``shape(f)``, with
    uniformly random phases from ``seed`` (paper 001 §4, spectral noise synthesis).

    The last few tables are kept (``key`` names the shape): repeated renders
    (blocks, other paths, benchmarks) reuse them.
    """
    n = max(int(n), 2)
    full = (n, float(rate), seed, key)
    hit = _TABLES.get(full)
    if hit is not None:
        return hit
    f = np.fft.rfftfreq(n, 1.0 / rate)
    amp = shape(f)
    phase = np.random.default_rng(list(seed)).uniform(-np.pi, np.pi, f.size)
    x = np.fft.irfft(amp * np.exp(1j * phase), n)
    rms = float(np.sqrt(np.mean(x * x)))
    x = x / rms if rms > 0 else x
    x.flags.writeable = False
    if len(_TABLES) >= _TABLES_MAX:
        _TABLES.pop(next(iter(_TABLES)))
    _TABLES[full] = x
    return x


class _Clock:
    """Sample times of a render and the emission-time axis of its carriers."""

    def __init__(self, tracks: SourceTracks, path: ListenerPath, out: Rendered, *,
                 start: float, c0: float) -> None:  # fmt: skip
        rate, ts = out.rate, out.time_scale
        n = out.audio.shape[1]
        self.rate, self.ts = rate, ts
        t_start = float(out.meta["t_start_data"])
        self.t = t_start + np.arange(n) / (rate * ts)  # data time of each sample
        dur = n / rate
        J = max(int(np.ceil(dur * CONTROL_HZ)) + 1, 2)
        u = np.linspace(0.0, dur, J)
        dbar = mean_distance(tracks, path, t_start + u / ts, path.times[0] + start + u, c0=c0)
        self.tau = self.t - np.interp(self.t, t_start + u / ts, dbar) / c0
        tn = _knot_times(tracks)
        self.origin = float(tn[0])  # emission-time origin of every carrier
        span = (float(tn[-1]) - self.origin) * ts * rate
        if span <= MAX_TABLE:
            self.first, size = 0, int(np.ceil(span)) + 2
        else:  # only the emission times heard
            lo = (float(np.min(self.tau, initial=self.origin)) - self.origin) * ts * rate
            hi = (float(np.max(self.tau, initial=self.origin)) - self.origin) * ts * rate
            self.first = int(np.floor(max(lo, 0.0)))
            size = min(int(np.ceil(hi)) - self.first + 2, MAX_TABLE)
        self.size = max(size, 2)

    def phase_s(self) -> NDArray[np.float64]:
        """Emission time of each sample in playback seconds since the carriers' origin."""
        return (self.tau - self.origin) * self.ts

    def noise(self, table: NDArray[np.float64]) -> NDArray[np.float64]:
        """The noise ``table`` (sampled at the audio rate from the origin) at each sample's
        emission time."""
        x = self.phase_s() * self.rate - self.first
        return np.interp(x, np.arange(table.size, dtype=np.float64), table, left=0.0, right=0.0)


def render_timbre(tracks: SourceTracks, path: ListenerPath, *, timbre: str = "physical",
                  rate: int = 44100, time_scale: float = 1.0, interp: str = "cubic",
                  layout: str | Layout = "mono", c0: float = C0, duration: float | None = None,
                  bounds: tuple[float, ...] | None = None, start: float = 0.0, lead: float = 0.0,
                  highpass_hz: float = HIGHPASS_HZ, seed: int = 0, alpha: float = ALPHA,
                  carriers: dict[str, tuple[Any, ...]] | None = None,
                  hrtf: object = None) -> Rendered:  # fmt: skip
    """Render ``tracks`` along ``path`` in one of :data:`TIMBRES`, then high-pass.

    Every layout the synthesis pans to is rendered directly; ``binaural`` is
    rendered to its AmbiX intermediate and filtered once at the end by
    :func:`auralize.spatial.output_stage` (``hrtf``: its HRIRs).

    Parameters
    ----------
    tracks, path, rate, time_scale, interp, layout, c0, duration, bounds, start, lead
        As :func:`auralize.synthesis.render`.
    timbre : {"physical", "extended", "tonal", "auto"}
        See the module docstring; ``auto`` is ``physical`` when at least
        :data:`AUDIBLE_SHARE` of its energy lies above 20 Hz, else ``extended``.
    highpass_hz : float
        Cut-off of the causal output high-pass (Hz); 0 keeps everything.
    seed : int
        Seed of the noise carriers (same seed, same output).
    alpha : float
        Power-law exponent of the ``extended`` noise (power spectrum f^−α).
    carriers : dict, optional
        ``tonal`` carriers per type name (default :data:`TONAL_CARRIERS`).
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only: HRIRs or a SOFA file (default the spherical head).

    Returns
    -------
    Rendered
        ``audio (n_channels, n_samples)`` (pascals for ``physical``); ``meta``
        holds the timbre used, seed, high-pass, ``share_above_20hz_unfiltered``
        (the energy share above 20 Hz before the high-pass) and
        ``timbre_notes`` (what to tell the user: an infrasonic physical render).
    """
    if timbre not in (*TIMBRES, "auto"):
        raise ParameterError(f"timbre must be one of {', '.join(TIMBRES)} or auto, got {timbre!r}")
    if not (np.isfinite(alpha) and alpha > 0):
        raise ParameterError(f"alpha (power-law exponent) must be > 0, got {alpha!r}")
    stage = output_stage(layout, int(rate), hrtf=hrtf)
    kw: dict[str, Any] = dict(rate=rate, time_scale=time_scale, interp=interp,
                              layout=stage.synthesis_layout, c0=c0, duration=duration,
                              start=start, lead=lead)  # fmt: skip
    highpass(np.zeros((1, 0)), rate, highpass_hz)  # validate before rendering
    meta: dict[str, Any] = {"timbre": timbre, "seed": int(seed), "highpass_hz": highpass_hz}
    notes: list[str] = []
    phys = None
    if timbre in ("physical", "auto"):
        phys = render(tracks, path, bounds=bounds, **kw)
        share = loudness(phys.audio, rate)["share_above"]
        meta["physical_share_above_20hz"] = share
        if share < AUDIBLE_SHARE and tracks.n_sources:
            below = f"{100 * (1 - share):.0f} % of the physical sound lies below 20 Hz"
            if timbre == "auto":
                timbre = "extended"
                notes.append(f"timbre auto: {below} (inaudible); rendered 'extended' "
                             f"(physical below {cutoff_hz(tracks, time_scale):.3g} Hz, power-law "
                             f"noise above); --timbre physical keeps the pressure alone")  # fmt: skip
            else:
                notes.append(f"note: {below} (inaudible); try --timbre extended, or a smaller "
                             f"--time-scale (the data played faster)")  # fmt: skip
        elif timbre == "auto":
            timbre = "physical"
        meta["timbre"] = timbre
    if timbre == "physical":
        assert phys is not None
        out = phys
    elif timbre == "extended":
        out = _extended(tracks, path, kw, bounds, seed, alpha, c0, start, meta, phys,
                        highpass_hz)  # fmt: skip
    else:
        out = _tonal(tracks, path, kw, bounds, seed, carriers or TONAL_CARRIERS, c0, start, meta)
    meta["timbre_notes"] = notes
    out = stage.finish(out)  # the output channels (binaural: two ears) before the high-pass
    meta["share_above_20hz_unfiltered"] = loudness(out.audio, rate)["share_above"]
    out.audio = highpass(out.audio, rate, highpass_hz)
    out.meta.update(meta)
    return out


#: envelopes are rendered at no less than 8 f_cut and 1 kHz, at most this many
#: times below the audio rate, and interpolated linearly
MAX_DECIMATION = 32


def envelope_rate(rate: int, f_cut: float) -> int:
    """Sample rate (Hz, dividing ``rate``) of the envelope renders: ``rate`` / k with k
    the largest divisor of ``rate`` not above ``rate / max(8 f_cut, 1 kHz)`` and
    :data:`MAX_DECIMATION`."""
    k = int(min(MAX_DECIMATION, max(1.0, rate // max(8.0 * f_cut, 1000.0))))
    while rate % k:
        k -= 1
    return rate // k


def _smooth_render(tracks: SourceTracks, path: ListenerPath, kw: dict[str, Any], f_cut: float,
                   bounds: tuple[float, ...] | None = None) -> Rendered:  # fmt: skip
    """:func:`render` of a signal band-limited to about ``f_cut`` (an envelope |q|,
    or the pressure under the data's Nyquist frequency) at :func:`envelope_rate`,
    linearly interpolated to the audio rate: the retarded-time sum is evaluated
    exactly at every envelope sample, and most of the per-sample cost is saved."""
    rate = int(kw["rate"])
    er = envelope_rate(rate, f_cut)
    if er == rate:
        return render(tracks, path, bounds=bounds, **kw)
    dur = kw["duration"] if kw["duration"] is not None else path.duration - kw["start"]
    n = round(dur * rate)
    k = rate // er
    coarse = render(tracks, path, bounds=bounds,
                    **{**kw, "rate": er, "duration": (n // k + 2) / er})  # fmt: skip
    j = np.arange(n)
    i0, frac = j // k, (j % k) / k
    e = coarse.audio
    audio = e[:, i0] * (1.0 - frac) + e[:, i0 + 1] * frac
    return Rendered(audio=audio, rate=rate, layout=coarse.layout, time_scale=coarse.time_scale,
                    meta={**coarse.meta, "envelope_rate_hz": er})  # fmt: skip


def cutoff_hz(tracks: SourceTracks, time_scale: float) -> float:
    """Nyquist frequency of the data's time stepping in playback time (Hz): the
    ``extended`` cut-off (paper 001 §4 uses the simulation's Nyquist, 180 Hz)."""
    t = np.asarray(tracks.times, dtype=np.float64)
    dt = float(np.median(np.diff(t))) if t.size >= 2 else 1.0
    return 0.5 / (dt * time_scale)


def _extended(tracks: SourceTracks, path: ListenerPath, kw: dict[str, Any],
              bounds: tuple[float, ...] | None, seed: int, alpha: float, c0: float, start: float,
              meta: dict[str, Any], phys: Rendered | None = None,
              highpass_hz: float = 0.0) -> Rendered:  # fmt: skip
    f_cut = cutoff_hz(tracks, float(kw["time_scale"]))
    meta.update({"alpha": alpha, "f_cut_hz": f_cut})
    # below half the output high-pass the low band is inaudible and filtered out:
    # its mono sum (for β) is all that is needed
    keep_low = f_cut > 0.5 * highpass_hz
    if phys is None:
        phys = _smooth_render(tracks, path, kw if keep_low else {**kw, "layout": "mono"}, f_cut,
                              bounds)  # fmt: skip
    rate = phys.rate
    n = phys.audio.shape[1]
    if f_cut >= 0.45 * rate or n < 4 or tracks.n_sources == 0:
        meta["beta"] = 0.0
        return phys if keep_low else render(tracks, path, bounds=bounds, **kw)
    absq = _cached(tracks, "timbre:abs", "", lambda: _subset(tracks, np.abs(tracks.q)))
    env = _smooth_render(absq, path, kw, f_cut)
    clock = _Clock(tracks, path, env, start=start, c0=c0)

    def shape(f: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.maximum(f, 0.25 * f_cut) ** (-alpha / 2)

    table = _noise_table(clock.size, rate, (int(seed), 1), shape, ("power", alpha, f_cut))
    low = _crossover(phys.audio, rate, f_cut, "lowpass")
    high = _crossover(env.audio * clock.noise(table)[None, :], rate, f_cut, "highpass")
    # Eq. 13, power summed over the channels: low + β high matches the physical
    # power under g(f) (the cross term needs the low band in every channel;
    # without it, it is left out: random-phase noise is uncorrelated with it)
    f = np.fft.rfftfreq(n, 1.0 / rate)
    sigma = max(f_cut * 10.0 / 180.0, 3.0 * rate / n)  # Table 1: σ 10 Hz at 180 Hz
    g2 = np.exp(-(((f - f_cut) / sigma) ** 2)) * (f > 0)
    P, L, H = (np.fft.rfft(x, axis=-1) for x in (phys.audio, low, high))
    same = P.shape[0] == H.shape[0]
    a = float(np.sum(np.abs(H) ** 2 * g2))
    b = float(2 * np.sum(np.real(L * np.conj(H)) * g2)) if same else 0.0
    c = float(np.sum(np.abs(L) ** 2 * g2) - np.sum(np.abs(P) ** 2 * g2))
    disc = b * b - 4 * a * c
    beta = (-b + np.sqrt(disc)) / (2 * a) if a > 0 and disc >= 0 else 0.0
    meta["beta"] = float(max(beta, 0.0))
    meta["low_band"] = "kept" if same else "below half the high-pass: left out"
    audio = meta["beta"] * high + (low if same else 0.0)
    return Rendered(audio=audio, rate=rate, layout=env.layout, time_scale=env.time_scale,
                    meta=env.meta)  # fmt: skip


def _crossover(x: NDArray[np.float64], rate: float, f_cut: float, kind: str) -> NDArray[np.float64]:
    """One side of a causal 4th-order Linkwitz–Riley crossover at ``f_cut`` (the two
    sides sum to an all-pass: the band split of Eq. 12 without pre-echo)."""
    from scipy.signal import sosfilt

    sos = butter_sos(2, float(f_cut), kind, float(rate))
    return np.asarray(sosfilt(sos, sosfilt(sos, x, axis=-1), axis=-1))


def _type_tracks(tracks: SourceTracks) -> list[SourceTracks | None]:
    """Per type (monopole, dipole, quadrupole): the tracks of |q| where the source
    has that type, scaled so that every type's peak is the peak of all |q|
    (None for a type that never occurs)."""
    qabs = np.abs(np.asarray(tracks.q, dtype=np.float64))
    kind = np.asarray(tracks.kind)
    peak_all = float(qabs.max(initial=0.0))
    out: list[SourceTracks | None] = []
    for code in range(1, len(TYPES) + 1):
        qk = np.where(kind == code, qabs, 0.0)
        peak = float(qk.max(initial=0.0))
        out.append(_subset(tracks, qk * (peak_all / peak)) if peak > 0 else None)
    return out


def _tonal(tracks: SourceTracks, path: ListenerPath, kw: dict[str, Any],
           bounds: tuple[float, ...] | None, seed: int, carriers: dict[str, tuple[Any, ...]],
           c0: float, start: float, meta: dict[str, Any]) -> Rendered:  # fmt: skip
    if tracks.kind is None:
        raise ParameterError("the tonal timbre needs the source types of the tracks (kind); "
                             "build them with SourceSeries.tracks()")  # fmt: skip
    bad = set(carriers) - set(TYPES)
    if bad:
        raise ParameterError(f"tonal carriers are given per type {TYPES}, got {sorted(bad)}")
    if bounds is not None:
        check_distance(path, bounds)
    audio: NDArray[np.float64] | None = None
    base: Rendered | None = None
    used = {}
    f_cut = cutoff_hz(tracks, float(kw["time_scale"]))
    by_type = _cached(tracks, "timbre:types", "", lambda: _type_tracks(tracks))
    for code, name in enumerate(TYPES, start=1):
        sub = by_type[code - 1]
        if sub is None or name not in carriers:
            continue
        env = _smooth_render(sub, path, kw, f_cut)
        rate = env.rate
        if audio is None:
            base, audio = env, np.zeros_like(env.audio)
        clock = _Clock(sub, path, env, start=start, c0=c0)
        spec = carriers[name]
        if spec[0] == "tone":
            car = np.sqrt(2.0) * np.sin(2 * np.pi * float(spec[1]) * clock.phase_s())
        elif spec[0] == "noise":
            f_lo, f_hi = float(spec[1]), float(spec[2])

            def band(f: NDArray[np.float64], f_lo: float = f_lo, f_hi: float = f_hi) -> Any:
                return ((f >= f_lo) & (f <= f_hi)).astype(np.float64)

            car = clock.noise(_noise_table(clock.size, rate, (int(seed), 2, code), band,
                                           ("band", f_lo, f_hi)))  # fmt: skip
        else:
            raise ParameterError(f"tonal carrier for {name} must be ('tone', Hz) or "
                                 f"('noise', low Hz, high Hz), got {spec!r}")  # fmt: skip
        audio += env.audio * car[None, :]
        used[name] = list(spec)
    meta["carriers"] = used
    if base is None or audio is None:  # no sources: silence of the right shape
        empty = SourceTracks(positions=np.zeros((0, 3)), q=np.zeros((0, tracks.times.size)),
                             radius=np.zeros(0), times=tracks.times)  # fmt: skip
        base = render(empty, path, **kw)
        audio = base.audio
    return Rendered(audio=audio, rate=base.rate, layout=base.layout,
                    time_scale=base.time_scale, meta=base.meta)  # fmt: skip
