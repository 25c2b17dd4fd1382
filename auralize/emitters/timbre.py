"""Audible rendering modes (timbres) on top of the retarded-time synthesis.

Three timbres, each keeping what makes field auralization worth doing —
where a source is (panning), when its sound arrives (delay D/c0), how loud
it is (1/D) and the Doppler shift of a moving listener:

``physical``
    The retarded-time pressure of :func:`auralize.emitters.synthesis.render_tracks`
    (paper 003 Eqs. 15–17).  Honest, and infrasonic whenever the data's time
    steps are long in playback time.
``extended``
    Spectral bandwidth extension after paper 001 §4 (Eqs. 12–13, Table 1):
    the physical pressure is kept below the cut-off ``f_cut`` (the Nyquist
    frequency of the data's time stepping in playback time), and above it
    noise with a power-law spectrum f^(−α) (Table 1: α 2.5–3.5) follows the
    power of what changes: in each channel its amplitude is the standard
    deviation, over two data steps, of the pressure rendered from the
    sources' change per step (:func:`change_tracks`, :func:`change_envelope`).
    Sources that do not change drive nothing, also for a listener moving
    through their steady field: nothing changing means nothing added.  The band split of Eq. 12 is a
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
    quadrupoles 660 Hz, a fifth above), its amplitude the envelope of that
    type's changes (as ``extended``'s).  Each type's envelope is
    divided by its peak so that the types are heard side by side (loudness
    across types is not physical; within a type, and with distance, it is).
    Of the whole field (``heard="field"``) the types are its terms: the
    continuity residual (monopole) and Lighthill's stress (quadrupole).

How the carriers keep the physics.  The change pressure
``C(t) = Σ_k Δq_k(τ_k)/D_k`` (``τ_k = t − D_k/c0``, Δq the change per step)
is rendered per loudspeaker by the fast synthesis
(:func:`auralize.emitters.synthesis.render_tracks`), so the arrival time, the 1/D
law and the panning are those of the physical render; its standard
deviation over two data steps (:func:`change_envelope`) is the envelope
E(t) of each channel.  C changes once per data step Δt, so it is rendered
at a reduced rate
(:func:`envelope_rate`) and from sources merged inside cubes of side
c0 Δt / 32 (:func:`merged`: arrivals within a cube differ by less than a
sixteenth of a step; the change pressure is signed, so its envelope moves
with the merged arrivals' spread to first order), except within four cubes of the listener's path,
where direction and 1/D change fastest; the ``extended`` low band (the
pressure below the data's Nyquist frequency) is rendered the same way.  The carrier is evaluated once
per type at the envelope-weighted mean emission time ``τ̄(t) = t − D̄(t)/c0`` with
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
>>> from auralize.sources.detection import SourceTracks
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

from auralize.defaults import DEFAULTS, TIMBRE_CHOICES
from auralize.emitters.synthesis import (
    C0,
    Rendered,
    cached_on_tracks,
    check_distance,
    knot_times,
    render_tracks,
)
from auralize.errors import ParameterError
from auralize.listener import ListenerPath, near_path
from auralize.sources.detection import TYPES, SourceTracks
from auralize.spatial.layouts import (
    Layout,
    is_ambisonic,
    output_stage,
    receiver_paths,
    receivers_of,
)

TIMBRES = tuple(t for t in TIMBRE_CHOICES if t != "auto")
#: ``auto`` renders ``physical`` when at least this share of its energy is above 20 Hz,
#: else ``extended``
AUDIBLE_SHARE = 0.5
#: default output high-pass (Hz): below it nothing is audible (paper 001 §6 uses 30 Hz)
HIGHPASS_HZ = DEFAULTS.highpass_hz
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


def highpass(
    audio: NDArray[np.float64], rate: float, hz: float, *, single: bool = False
) -> NDArray[np.float64]:
    """Causal 4th-order Butterworth high-pass of ``audio (n_channels, n_samples)``.

    Causal, so nothing arrives before its time (a zero-phase filter would
    ring ahead of onsets).  The filter starts in its steady state for the
    first sample (:func:`highpass_start`), so that a sound already going on
    when the output starts begins without a click.  The output high-pass of
    every timbre (paper 001 §6 high-passes its sounds at 30 Hz).

    Parameters
    ----------
    audio : ndarray, shape (n_channels, n_samples)
        The signal (any unit, pascals for a pressure), time last.
    rate : float
        Sample rate of ``audio`` in Hz.
    hz : float
        Cut-off in Hz, ``0 <= hz < rate / 2``; 0 returns ``audio`` itself,
        unfiltered.
    single : bool
        Filter in single precision (for the added timbres' noise and tones,
        never for a physical pressure, whose offsets can dwarf its sound).

    Returns
    -------
    ndarray, shape (n_channels, n_samples)
        The filtered signal, float64 (``audio`` itself when ``hz`` is 0 or
        it holds no samples).

    Raises
    ------
    ParameterError
        ``hz`` not finite, negative, or at or above half the sample rate.

    Examples
    --------
    A constant, already going on at the start, gives nothing; a 1 kHz tone
    passes a 30 Hz high-pass whole:

    >>> import numpy as np
    >>> float(np.max(np.abs(highpass(np.ones((1, 100)), 8000, 30.0)))) < 1e-12
    True
    >>> tone = np.sin(2 * np.pi * 1000 * np.arange(800) / 8000)[None]
    >>> round(float(np.max(np.abs(highpass(tone, 8000, 30.0)[:, 400:]))), 3)
    0.998
    >>> highpass(tone, 8000, 4000.0)
    Traceback (most recent call last):
    ...
    auralize.errors.ParameterError: highpass must be 0 (off) or between 0 and 4000 Hz ...
    """
    if not (np.isfinite(hz) and 0 <= hz < rate / 2):
        raise ParameterError(
            f"highpass must be 0 (off) or between 0 and {rate / 2:g} Hz (half "
            f"the sample rate), got {hz!r}"
        )
    if hz == 0 or audio.shape[-1] == 0:
        return audio
    from scipy.signal import sosfilt

    sos = butter_sos(4, float(hz), "highpass", float(rate))
    a = np.asarray(audio)
    zi = highpass_start(sos, a[..., 0])  # (solved in double precision)
    if single:  # noise carriers: single precision is 1e-6 of their level, at a third of the cost
        sos, a, zi = sos.astype(np.float32), a.astype(np.float32), zi.astype(np.float32)
    out, _ = sosfilt(sos, a, axis=-1, zi=zi)
    return np.asarray(out, dtype=np.float64)


def highpass_start(sos: NDArray[np.float64], first: NDArray[np.float64]) -> NDArray[np.float64]:
    """Initial state ``zi`` of ``sosfilt(sos, x, axis=-1, zi=...)`` for signals
    ``x (n_channels, n)`` whose first samples are ``first (n_channels,)`` (or
    one signal ``x (n,)`` and its first sample): the state after a constant
    input equal to them, forever.

    Field sources sound from the first sample of a render (their emission
    was going on before it); a filter started at rest would see a step
    there, and a high-pass passes a step whole: a click at the start that
    can be louder than everything after it (on a slowly varying field,
    whose sound lies mostly under the cut-off, the whole file is then
    normalised to the click).  From this state the high-pass of a constant
    is exactly 0 (to round-off).  Live playback starts its filter the same
    way, so live blocks equal the rendered file.

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6)
        Second-order sections of the filter (:func:`butter_sos`).
    first : ndarray, shape (n_channels,), or float
        The first sample of each signal (of one signal: a scalar).

    Returns
    -------
    ndarray, shape (n_sections, n_channels, 2), or (n_sections, 2)
        The filter state, ``first`` times the state after a unit step.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import sosfilt
    >>> sos = butter_sos(4, 30.0, "highpass", 8000.0)
    >>> zi = highpass_start(sos, np.array([1.0, 2.0]))
    >>> zi.shape
    (2, 2, 2)
    >>> out, _ = sosfilt(sos, np.array([[1.0] * 50, [2.0] * 50]), axis=-1, zi=zi)
    >>> float(np.max(np.abs(out))) < 1e-12
    True
    """
    from scipy.signal import sosfilt_zi

    zi = np.asarray(sosfilt_zi(sos))  # (sections, 2), for a unit step
    f = np.asarray(first, dtype=np.float64)
    return zi.reshape(zi.shape[0], *([1] * f.ndim), 2) * f[None, ..., None]


@functools.lru_cache(maxsize=64)
def butter_sos(order: int, hz: float, kind: str, rate: float) -> NDArray[np.float64]:
    """Second-order sections of a Butterworth filter (cached: designing one costs
    more than filtering a second of audio; callers must not modify them).

    Parameters
    ----------
    order : int
        Filter order (the sections: ``ceil(order / 2)``).
    hz : float
        Cut-off in Hz, below ``rate / 2``.
    kind : {"highpass", "lowpass"}
        The filter's type (scipy's ``btype``).
    rate : float
        Sample rate in Hz.

    Returns
    -------
    ndarray, shape (n_sections, 6)
        The sections, as :func:`scipy.signal.butter` gives them with
        ``output="sos"``; shared between callers: read-only by contract.

    Examples
    --------
    >>> butter_sos(4, 30.0, "highpass", 8000.0).shape
    (2, 6)
    >>> butter_sos(4, 30.0, "highpass", 8000.0) is butter_sos(4, 30.0, "highpass", 8000.0)
    True
    """
    from scipy.signal import butter

    return np.asarray(butter(order, hz, btype=kind, fs=rate, output="sos"))


def loudness(
    audio: NDArray[np.float64], rate: float, *, split_hz: float = 20.0
) -> dict[str, float]:
    """Peak and RMS (over all channels) and the share of the energy above
    ``split_hz`` (from the power spectrum, the signal zero-padded to a fast
    FFT length).

    ``auto`` timbre decides with it (:data:`AUDIBLE_SHARE` of the energy
    above 20 Hz).

    Parameters
    ----------
    audio : ndarray, shape (n_channels, n_samples) or (n_samples,)
        The signal (pascals for a pressure).
    rate : float
        Sample rate in Hz.
    split_hz : float
        Frequency (Hz) above which the energy share is taken.

    Returns
    -------
    dict
        ``peak`` (largest |sample|), ``rms`` (over all channels and samples),
        both in the unit of ``audio``; ``above_hz`` (``split_hz``);
        ``share_above`` (0–1; 0 for silence or no samples).

    Examples
    --------
    >>> import numpy as np
    >>> tone = np.sin(2 * np.pi * 1000 * np.arange(800) / 8000)[None]
    >>> d = loudness(tone, 8000)
    >>> d["peak"], round(d["rms"], 4), d["share_above"]
    (1.0, 0.7071, 1.0)
    >>> loudness(np.ones((2, 100)), 8000)["share_above"]  # a constant: all at 0 Hz
    0.0
    """
    from scipy.fft import next_fast_len, rfft

    a = np.atleast_2d(audio)
    if a.size == 0:
        return {"peak": 0.0, "rms": 0.0, "above_hz": split_hz, "share_above": 0.0}
    n_fft = next_fast_len(a.shape[-1], real=True)
    spec = np.sum(np.abs(rfft(a, n_fft, axis=-1)) ** 2, axis=0)
    f = np.fft.rfftfreq(n_fft, 1.0 / rate)
    total = float(spec.sum())
    share = float(spec[f > split_hz].sum() / total) if total > 0 else 0.0
    return {
        "peak": float(np.max(np.abs(a))),
        "rms": float(np.sqrt(np.mean(a * a))),
        "above_hz": split_hz,
        "share_above": share,
    }


def _subset(tracks: SourceTracks, q: NDArray[np.float64]) -> SourceTracks:
    """The tracks with strengths ``q``, rows that never sound dropped."""
    keep = np.any(q != 0, axis=1)
    return SourceTracks(
        positions=np.asarray(tracks.positions).reshape(-1, 3)[keep],
        q=np.ascontiguousarray(q[keep]),
        radius=np.asarray(tracks.radius)[keep],
        times=tracks.times,
        origin=tracks.origin,
        end=tracks.end,
    )


#: the envelope renders merge the sources inside cubes whose side is this
#: fraction of the distance sound travels in one data step (see :func:`merged`)
MERGE = 1.0 / 32.0


def merge_size(tracks: SourceTracks, c0: float = C0) -> float:
    """Side (m) of the cubes inside which :func:`merged` joins sources:
    :data:`MERGE` × c0 × the data's (median) time step.

    Arrivals from within such a cube differ by at most √3/32 of a data step.

    Parameters
    ----------
    tracks : SourceTracks
        The sources; their ``times (T,)`` set the data step (s).
    c0 : float
        Speed of sound, m/s.

    Returns
    -------
    float
        The cube side in metres (0 for tracks of a single step).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 4)),
    ...                   radius=np.full(1, 0.05), times=np.arange(4) * 0.1)
    >>> round(merge_size(tr), 6)  # 343 m/s * 0.1 s / 32
    1.071875
    """
    return MERGE * c0 * (_data_step(tracks) if tracks.times.size >= 2 else 0.0)


def _data_step(tracks: SourceTracks) -> float:
    """The median time step of the data (s; 1 for a single step), cached on the tracks."""
    t = np.asarray(tracks.times, dtype=np.float64)
    return float(
        cached_on_tracks(
            tracks, "timbre:step", "", lambda: np.median(np.diff(t)) if t.size >= 2 else 1.0
        )
    )


def merged(
    tracks: SourceTracks, size: float, keep: NDArray[np.bool_] | None = None
) -> SourceTracks:
    """The tracks with the sources inside each cube of side ``size`` (m; cubes
    aligned with the sources' box) joined into one: strengths summed, at the
    centroid weighted by Σ_t |q|, clamp radius the largest.  Sources where
    ``keep (K,)`` is True are left as they are.

    For a signal band-limited to the data's Nyquist frequency (an envelope
    |q|, or the pressure below it) this changes little: with ``size``
    c0 Δt / 32 (:func:`merge_size`) the arrivals of sources within a cube
    differ by at most √3/32 ≈ 0.054 of a data step; the 1/D of a source at D
    changes by about (size/D)² / 3 and its direction by about size/D, which
    :func:`_joined` keeps small by keeping the sources near the listener.
    The tracks themselves are returned when no two sources share a cube.

    Parameters
    ----------
    tracks : SourceTracks
        ``K`` sources: ``positions (K, 3)`` in m, ``q (K, T)``, ``radius (K,)``.
    size : float
        Cube side in metres; not finite or <= 0: nothing is merged.
    keep : ndarray of bool, shape (K,), optional
        Sources left unmerged (default none).

    Returns
    -------
    SourceTracks
        The kept sources first, then one per occupied cube (``times``,
        ``origin`` and ``end`` those of ``tracks``; no ``kind``); ``tracks``
        itself when nothing is joined.

    Examples
    --------
    Two sources 0.1 m apart join in a 1 m cube, at their |q|-weighted
    centroid; the third stays:

    >>> import numpy as np
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.array([[0.0, 0, 0], [0.1, 0, 0], [5.0, 0, 0]]),
    ...                   q=np.array([[1.0, 1, 1, 1], [3.0, 3, 3, 3], [1.0, 2, 3, 4]]),
    ...                   radius=np.full(3, 0.05), times=np.arange(4) * 0.1)
    >>> m = merged(tr, 1.0)
    >>> m.n_sources, m.positions[:, 0].round(9).tolist(), m.q[0].tolist()
    (2, [0.075, 5.0], [4.0, 4.0, 4.0, 4.0])
    >>> merged(tr, 1.0, keep=np.array([True, False, False])) is tr  # one left to join
    True
    """
    pos = np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)
    if pos.shape[0] < 2 or not (np.isfinite(size) and size > 0):
        return tracks
    join = np.ones(pos.shape[0], dtype=bool) if keep is None else ~keep
    pj = pos[join]
    if pj.shape[0] < 2:
        return tracks
    cell = np.floor((pj - pos.min(axis=0)) / size)
    order = np.lexsort((cell[:, 2], cell[:, 1], cell[:, 0]))
    cs = cell[order]
    new = np.append(True, np.any(cs[1:] != cs[:-1], axis=1))
    if np.all(new):
        return tracks
    starts = np.flatnonzero(new)
    inv = np.cumsum(new) - 1  # cube of each sorted source
    q = np.asarray(tracks.q, dtype=np.float64)
    qs = q[join][order]
    w = np.abs(qs).sum(axis=1)
    wsum = np.bincount(inv, weights=w)
    cnt = np.bincount(inv).astype(np.float64)
    ps = pj[order]
    cen = np.stack([np.bincount(inv, weights=w * ps[:, a]) for a in range(3)], 1)
    plain = np.stack([np.bincount(inv, weights=ps[:, a]) for a in range(3)], 1)
    cen = np.where(
        wsum[:, None] > 0, cen / np.where(wsum > 0, wsum, 1.0)[:, None], plain / cnt[:, None]
    )
    radius = np.asarray(tracks.radius, dtype=np.float64)
    rj = np.maximum.reduceat(radius[join][order], starts)
    return SourceTracks(
        positions=np.concatenate([pos[~join], cen]),
        q=np.concatenate([q[~join], np.add.reduceat(qs, starts, axis=0)]),
        radius=np.concatenate([radius[~join], rj]),
        times=tracks.times,
        origin=tracks.origin,
        end=tracks.end,
    )


#: sources nearer to the listener's path than this many merging cubes are not merged
NEAR = 4.0


def _shared(points: NDArray[np.float64], size: float) -> NDArray[np.bool_]:
    """Which ``points (K, 3)`` share their cube of side ``size`` (the cubes of
    :func:`merged`) with another point."""
    cell = np.floor((points - points.min(axis=0)) / size)
    _, inv, cnt = np.unique(cell, axis=0, return_inverse=True, return_counts=True)
    return np.asarray(cnt[inv.ravel()] > 1)


def _joined(tracks: SourceTracks, path: ListenerPath, name: str, build: Any, c0: float) -> Any:
    """``build(join)`` with ``join(t)`` the tracks ``t`` merged for the envelope
    renders (:func:`merged`, cubes of :func:`merge_size`, the sources nearer to
    ``path`` than :data:`NEAR` cubes kept), cached on ``tracks`` for this path."""
    size = merge_size(tracks, c0)

    def join(t: SourceTracks) -> SourceTracks:
        if not (size > 0) or t.n_sources < 2:
            return t
        pos = np.asarray(t.positions, dtype=np.float64).reshape(-1, 3)
        keep = ~_shared(pos, size)
        if np.all(keep):
            return t
        keep[~keep] = near_path(pos[~keep], path, NEAR * size)
        return merged(t, size, keep)

    tkey = (id(tracks.q), tracks.q.shape, id(tracks.times), id(tracks.positions), size)
    hit = tracks.cache.get(name)  # (the path's arrays are held: their ids stay theirs)
    if hit is not None and hit[0] == tkey and hit[1] is path.times and hit[2] is path.positions:
        return hit[3]
    out = build(join)
    tracks.cache[name] = (tkey, path.times, path.positions, out)
    return out


def mean_distance(
    tracks: SourceTracks,
    path: ListenerPath,
    t_data: NDArray[np.float64],
    t_play: NDArray[np.float64],
    *,
    c0: float = C0,
) -> NDArray[np.float64]:
    """Envelope-weighted mean source distance D̄ (m) heard at data times ``t_data`` (J,)
    when the listener is at its playback times ``t_play`` (J,) on ``path``.

    ``D̄ = Σ_c w_c / Σ_c (w_c / D_c)`` over clusters c of the sources (an
    8×8×8 partition of their box; position the |q|-weighted centroid), with
    ``w_c = Σ_{k in c} |q_k|(t − D_c/c0)`` linearly interpolated between steps:
    the distance whose delay the loudest arrivals share.  Where nothing is
    heard, the nearest control's value is held; where nothing is heard at
    all, the nearest cluster's distance.  The carriers of the ``extended``
    and ``tonal`` timbres are read at the emission time t − D̄/c0.

    Parameters
    ----------
    tracks : SourceTracks
        The sources: ``positions (K, 3)`` in m, ``q (K, T)`` at ``times (T,)``.
    path : ListenerPath
        The listener's path (positions in m, playback times in s).
    t_data : ndarray, shape (J,)
        Data times (s) of the controls.
    t_play : ndarray, shape (J,)
        Playback times (s) on ``path`` of the same controls.
    c0 : float
        Speed of sound, m/s.

    Returns
    -------
    ndarray, shape (J,)
        D̄ in metres (zeros when there are no sources).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.array([[0.0, 1, 2, 3]]),
    ...                   radius=np.full(1, 0.1), times=np.arange(4) * 0.1)
    >>> path = ListenerPath.point([17.0, 0, 0], duration=0.4)
    >>> mean_distance(tr, path, np.array([0.1, 0.2]), np.array([0.1, 0.2])).tolist()
    [17.0, 17.0]
    """
    L = path.position_at(t_play)
    if tracks.n_sources == 0:
        return np.zeros(t_data.size)
    cen, W = cached_on_tracks(tracks, "timbre:clusters", "", lambda: _clusters(tracks))
    C = cen.shape[0]
    tn = knot_times(tracks)
    J = t_data.size
    num, den, d_min = np.empty(J), np.empty(J), np.empty(J)
    # controls in blocks whose (rows, C) temporaries stay in cache
    rows = max(1, _MEAN_BLOCK // max(C, 1))
    for j in range(0, J, rows):
        sl = slice(j, min(j + rows, J))
        num[sl], den[sl], d_min[sl] = _mean_terms(L[sl], t_data[sl], cen, W, tn=tn, c0=c0)
    ok = den > 0
    if not np.any(ok):
        return d_min
    dbar = np.where(ok, num / np.where(ok, den, 1.0), np.nan)
    idx = np.flatnonzero(ok)
    nearest = idx[np.clip(np.searchsorted(idx, np.arange(dbar.size)), 0, idx.size - 1)]
    return np.where(ok, dbar, dbar[nearest])


#: elements of the (controls, clusters) arrays of :func:`mean_distance` per block
_MEAN_BLOCK = 16384


def _mean_terms(
    L: NDArray[np.float64],
    t_data: NDArray[np.float64],
    cen: NDArray[np.float64],
    W: NDArray[np.float64],
    *,
    tn: NDArray[np.float64],
    c0: float,
) -> tuple[NDArray[np.float64], ...]:
    """For controls at listener positions ``L (J, 3)`` and data times ``t_data (J,)``:
    Σ_c w_c, Σ_c w_c / D_c and min_c D_c over the clusters ``cen (C, 3)`` whose
    summed |q| per padded knot ``tn`` is ``W (C, T + 2)`` (see :func:`mean_distance`)."""
    C = cen.shape[0]
    shape = (t_data.size, C)  # (J, C); the operations in place, in this order
    D, d = np.empty(shape), np.empty(shape)
    np.subtract(L[:, 0, None], cen[None, :, 0], out=d)
    np.multiply(d, d, out=D)
    for a in (1, 2):
        np.subtract(L[:, a, None], cen[None, :, a], out=d)
        d *= d
        D += d
    np.sqrt(D, out=D)
    np.maximum(D, 1e-9, out=D)
    tau = np.divide(D, c0, out=d)
    np.subtract(t_data[:, None], tau, out=tau)
    step = np.diff(tn)
    if np.all(np.abs(step - step[0]) <= 1e-9 * step[0]):  # even steps: the row by division
        x = (tau - tn[0]) / step[0]
        fl = np.floor(x)
        np.clip(fl, 0, tn.size - 2, out=fl)
        n = fl.astype(np.int64)
        s = np.subtract(x, fl, out=x)  # (fl holds n exactly)
        np.clip(s, 0.0, 1.0, out=s)
    else:
        n = np.clip(np.searchsorted(tn, tau, side="right") - 1, 0, tn.size - 2)
        s = np.clip((tau - tn[n]) / step[n], 0.0, 1.0)
    flat = W.ravel()
    n += np.arange(C) * W.shape[1]  # flat index of (cluster, step)
    wt = flat[n]
    wt *= 1 - s
    n += 1
    g = flat[n]
    g *= s
    wt += g
    wt[(tau < tn[0]) | (tau > tn[-1])] = 0.0
    return wt.sum(axis=1), np.divide(wt, D, out=g).sum(axis=1), np.min(D, axis=1)


def _clusters(tracks: SourceTracks) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Clusters of the sources for :func:`mean_distance`: |q|-weighted centroids
    ``(C, 3)`` and summed |q| per step, padded with a silent step at both ends
    ``(C, T + 2)``."""
    pos = np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)
    w = np.abs(np.asarray(tracks.q, dtype=np.float64))
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    cell3 = np.minimum(
        (CLUSTERS * (pos - lo) / np.maximum(hi - lo, 1e-300)).astype(np.int64), CLUSTERS - 1
    )
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
    cen = np.where(
        wsum[:, None] > 0, cen / np.where(wsum > 0, wsum, 1)[:, None], plain / cnt[:, None]
    )
    W = np.zeros((C, w.shape[1] + 2))  # padded with silent steps like the synthesis knots
    W[:, 1:-1] = np.add.reduceat(ws, starts, axis=0)
    return np.asarray(cen, dtype=np.float64), W


#: the envelope of the physical changes is the standard deviation of the change
#: pressure over this many data steps (:func:`change_envelope`)
ENVELOPE_STEPS = 2.0


def change_tracks(tracks: SourceTracks) -> SourceTracks:
    """The tracks of the strengths' change per step, ``(q(n+1) − q(n−1)) / 2`` at
    every knot (the padded silent knots included), cached on ``tracks``: exactly
    0 wherever the sources do not change, whatever the listener does.

    Rendered, they give the pressure of what changes in the data
    (:func:`change_envelope`), the drive of the ``extended`` and ``tonal``
    timbres: a listener moving through a steady field hears no change.
    Beyond the first and last knots the strengths are taken as 0 (the data
    start and end there), or held at their edge values for tracks whose
    knots are held before and after the data
    (:meth:`auralize.sources.field.FieldTracks.tracks`).

    Parameters
    ----------
    tracks : SourceTracks
        ``q (K, T)`` at ``times (T,)``.

    Returns
    -------
    SourceTracks
        ``q`` the change per step ``(K', T)``, rows that never change
        dropped; positions, radii, times, origin and end those of ``tracks``.

    Examples
    --------
    A ramp changes by 1 per step; a constant only where the data start
    and end:

    >>> import numpy as np
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((2, 3)),
    ...                   q=np.array([[0.0, 1, 2, 3], [1.0, 1, 1, 1]]),
    ...                   radius=np.full(2, 0.1), times=np.arange(4) * 0.1)
    >>> change_tracks(tr).q.tolist()
    [[0.5, 1.0, 1.0, -1.0], [0.5, 0.0, 0.0, -0.5]]
    """

    def build() -> SourceTracks:
        q = np.asarray(tracks.q, dtype=np.float64)
        # tracks held before and after the data (their first knots lie before
        # their origin) go on as they were there: no change beyond them
        held = tracks.origin is not None and float(tracks.times[0]) < tracks.origin
        padded = np.pad(q, ((0, 0), (1, 1)), mode="edge" if held else "constant")
        return _subset(tracks, 0.5 * (padded[:, 2:] - padded[:, :-2]))

    out: SourceTracks = cached_on_tracks(tracks, "timbre:change", "", build)
    return out


def change_envelope(
    audio: NDArray[np.float64], rate: float, step_s: float, *, ambisonic: bool = False
) -> NDArray[np.float64]:
    """The envelope of the change pressure ``audio (n_channels, n)`` (the render of
    :func:`change_tracks`): its standard deviation over a centred window of
    :data:`ENVELOPE_STEPS` data steps (``step_s`` playback seconds each; at
    least 4 samples).

    Sources that do not change, or change at a constant rate, give none;
    changing ones their local RMS: the drive of the ``extended`` and
    ``tonal`` timbres follows the power of what changes, and nothing
    changing adds nothing.

    ``ambisonic``: the channels are spherical-harmonic components (channel
    0 the omnidirectional one), whose signs carry the direction: each
    channel's envelope is its covariance with channel 0 over the window,
    divided by channel 0's standard deviation (for sound from one direction,
    channel 0's envelope times that channel's encoding gain).

    Parameters
    ----------
    audio : ndarray, shape (n_channels, n)
        The change pressure (Pa) per channel.
    rate : float
        Sample rate of ``audio`` in Hz.
    step_s : float
        The data's time step in playback seconds.
    ambisonic : bool
        The channels are AmbiX components (see above).

    Returns
    -------
    ndarray, shape (n_channels, n)
        The envelope per channel (Pa): >= 0, or signed for ``ambisonic``.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.tile([1.0, -1.0], 50)[None]  # changes of ±1 Pa
    >>> change_envelope(x, 100, 0.02)[0, 40:44].tolist()
    [1.0, 1.0, 1.0, 1.0]
    >>> float(change_envelope(np.ones((1, 50)), 100, 0.02).max())  # no change
    0.0
    >>> amb = np.vstack([x, 0.5 * x, -0.5 * x])  # AmbiX W and two encoding gains
    >>> change_envelope(amb, 100, 0.02, ambisonic=True)[:, 50].tolist()
    [1.0, 0.5, -0.5]
    """
    from scipy.ndimage import uniform_filter1d

    w = max(int(round(ENVELOPE_STEPS * step_s * rate)), 4)
    x = np.asarray(audio, dtype=np.float64)
    m1 = uniform_filter1d(x, size=w, axis=-1, mode="nearest")
    if ambisonic and x.shape[0] > 1:
        cov = uniform_filter1d(x * x[:1], size=w, axis=-1, mode="nearest") - m1 * m1[:1]
        var0 = cov[0].copy()
        floor = 1e-12 * uniform_filter1d(x[0] * x[0], size=w, mode="nearest")
        sd0 = np.sqrt(np.where(var0 > floor, var0, 0.0))
        return np.where(sd0 > 0, cov / np.where(sd0 > 0, sd0, 1.0), 0.0)
    m2 = uniform_filter1d(x * x, size=w, axis=-1, mode="nearest")
    var = m2 - m1 * m1
    # (a difference of two means: below their round-off it is no change at all)
    var[var <= 1e-12 * m2] = 0.0
    return np.sqrt(var)


#: a render whose pressure is below this fraction of the size of the terms it
#: sums (:func:`term_level`) is round-off: silent
ROUNDOFF_LEVEL = 1e-10


def term_level(tracks: SourceTracks, path: ListenerPath) -> float:
    """The pressure (Pa) the tracks' rows would make if none cancelled another:
    Σ_k max_t |q_k| / (4π D_k), D_k the row's nearest distance to the path's
    captures (at least its clamp radius).  A render far below it is round-off
    (:data:`ROUNDOFF_LEVEL`).

    Parameters
    ----------
    tracks : SourceTracks
        ``positions (K, 3)`` in m, ``q (K, T)``, clamp ``radius (K,)`` in m.
    path : ListenerPath
        The listener's captures (positions in m).

    Returns
    -------
    float
        The level in pascals (0 without sources).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.array([[0.0, 1, 2, 3]]),
    ...                   radius=np.full(1, 0.1), times=np.arange(4) * 0.1)
    >>> level = term_level(tr, ListenerPath.point([17.0, 0, 0], duration=0.4))
    >>> bool(np.isclose(level, 3 / (4 * np.pi * 17)))
    True
    """
    if tracks.n_sources == 0:
        return 0.0
    # the same for every render of these tracks along this path: kept on the
    # tracks (the path's arrays are held, so their identity stays theirs)
    key = (id(tracks.q), tracks.q.shape, id(tracks.positions), id(tracks.radius))
    hit = tracks.cache.get("timbre:terms")
    if hit is not None and hit[0] == key and hit[1] is path.positions:
        return float(hit[2])
    from scipy.spatial import cKDTree

    pos = np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)
    d, _ = cKDTree(np.asarray(path.positions, dtype=np.float64)).query(pos)
    d = np.maximum(d, np.maximum(np.asarray(tracks.radius, dtype=np.float64), 1e-9))
    peak = np.max(np.abs(np.asarray(tracks.q, dtype=np.float64)), axis=1)
    level = float(np.sum(peak / (4 * np.pi * d)))
    tracks.cache["timbre:terms"] = (key, path.positions, level)
    return level


_TABLES: dict[tuple[Any, ...], NDArray[np.float64]] = {}
_TABLES_MAX = 8


def _noise_table(
    n: int, rate: float, seed: tuple[int, ...], shape: Any, key: tuple[Any, ...]
) -> NDArray[np.float64]:
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

    def __init__(
        self, tracks: SourceTracks, path: ListenerPath, out: Rendered, *, start: float, c0: float
    ) -> None:
        rate, ts = out.rate, out.time_scale
        n = out.audio.shape[1]
        self.rate, self.ts = rate, ts
        t_start = float(out.meta["t_start_data"])
        dur = n / rate
        # controls every 1/CONTROL_HZ s of playback from the render's start, the last
        # at or past its end
        J = max(int(np.ceil(dur * CONTROL_HZ)) + 1, 2)
        u = np.arange(J) / CONTROL_HZ
        # the same controls serve every clock of a render (the audio rate's and the
        # envelope rate's, whose durations differ by a fraction of an envelope
        # sample) and of its repeats: kept on the tracks for each path (its arrays
        # are held, so their identity stays theirs); a clock with fewer controls
        # takes the first of them
        key = (id(path.positions), id(path.times), t_start, ts, start, c0)
        held = tracks.cache.setdefault("timbre:dbar", {})
        hit = held.get(key)
        if (
            hit is not None
            and hit[0] is path.positions
            and hit[1] is path.times
            and hit[2].size >= J
        ):
            dbar = hit[2][:J]
        else:  # (two controls more than this clock needs, for the next clock's)
            w = np.arange(J + 2) / CONTROL_HZ
            dbar = mean_distance(tracks, path, t_start + w / ts, path.times[0] + start + w, c0=c0)
            if len(held) >= 8:  # the paths of a few renders (binaural: one per ear)
                held.pop(next(iter(held)))
            held[key] = (path.positions, path.times, dbar)
            dbar = dbar[:J]
        # the mean emission time at the controls; between them the data time
        # and D̄ are linear in the sample index, and so is the emission time
        tau = t_start + u / ts - dbar / c0
        tn = knot_times(tracks)
        self.origin = float(tn[0])  # emission-time origin of every carrier
        span = (float(tn[-1]) - self.origin) * ts * rate
        if span <= MAX_TABLE:
            self.first, size = 0, int(np.ceil(span)) + 2
        else:  # only the emission times heard
            lo = (float(np.min(tau, initial=self.origin)) - self.origin) * ts * rate
            hi = (float(np.max(tau, initial=self.origin)) - self.origin) * ts * rate
            self.first = int(np.floor(max(lo, 0.0)))
            size = min(int(np.ceil(hi)) - self.first + 2, MAX_TABLE)
        self.size = max(size, 2)
        self._phase = np.interp(_sample_index(n), u * rate, (tau - self.origin) * ts)

    def phase_s(self) -> NDArray[np.float64]:
        """Emission time of each sample in playback seconds since the carriers' origin."""
        return self._phase

    def noise(self, table: NDArray[np.float64]) -> NDArray[np.float64]:
        """The noise ``table`` (sampled at the audio rate from the origin) at each sample's
        emission time."""
        x = self._phase * self.rate - self.first
        return np.interp(x, _sample_index(table.size), table, left=0.0, right=0.0)


def _carriers(
    tracks: SourceTracks,
    path: ListenerPath,
    out: Rendered,
    carrier: Any,
    *,
    start: float,
    c0: float,
) -> NDArray[np.float64]:
    """The carrier of each channel of ``out``, ``(1 or n_channels, n)``.

    ``carrier(clock)`` gives a carrier ``(n,)`` read on a :class:`_Clock`.  One
    clock for a layout heard at one place; for a layout of several receivers
    (the ears of ``binaural``) each receiver's channels get the carrier read on
    its own clock, at its own emission times, so that the same emitted noise or
    tone reaches each ear with that ear's delay.  The receivers' clocks share
    one table span (the same noise)."""
    ears = receiver_paths(out.layout, path)
    if not ears:
        return carrier(_Clock(tracks, path, out, start=start, c0=c0))[None, :]  # type: ignore[no-any-return]
    clocks = [_Clock(tracks, p, out, start=start, c0=c0) for _, p in ears]
    first = min(ck.first for ck in clocks)
    end = max(ck.first + ck.size for ck in clocks)
    rows = []
    for (lay, _), ck in zip(ears, clocks, strict=True):
        ck.first, ck.size = first, end - first
        rows.append(np.broadcast_to(carrier(ck), (lay.n_channels, out.audio.shape[1])))
    return np.concatenate(rows)


@functools.lru_cache(maxsize=8)
def _sample_index(n: int) -> NDArray[np.float64]:
    """``0, 1, …, n − 1`` as floats (cached, read-only)."""
    j = np.arange(n, dtype=np.float64)
    j.flags.writeable = False
    return j


def render_timbre(  # noqa: PLR0913 (keyword-only options)
    tracks: SourceTracks,
    path: ListenerPath,
    *,
    timbre: str = "physical",
    rate: int = 44100,
    time_scale: float = 1.0,
    interp: str = "cubic",
    layout: str | Layout = "mono",
    c0: float = C0,
    duration: float | None = None,
    bounds: tuple[float, ...] | None = None,
    start: float = 0.0,
    lead: float = 0.0,
    highpass_hz: float = HIGHPASS_HZ,
    seed: int = 0,
    alpha: float = ALPHA,
    carriers: dict[str, tuple[Any, ...]] | None = None,
    hrtf: object = None,
    by_type: dict[str, SourceTracks] | None = None,
) -> Rendered:
    """Render ``tracks`` along ``path`` in one of :data:`TIMBRES`, then high-pass.

    Every layout the synthesis pans to is rendered directly; ``binaural`` is
    rendered to its AmbiX intermediate and filtered once at the end by
    :func:`auralize.spatial.layouts.output_stage` (``hrtf``: its HRIRs).

    ``physical`` is the retarded-time pressure of paper 003 §3.2.4.4
    (Eqs. 15–17); ``extended`` its bandwidth extension after paper 001 §4
    (Alg. 1, Eqs. 12–13, Table 1: f_cut the data's Nyquist frequency
    (:func:`cutoff_hz`), β the positive root of Eq. 13); ``tonal`` a
    carrier per source type.  A render whose pressure is round-off (below
    :data:`ROUNDOFF_LEVEL` of :func:`term_level`) is silence: its samples
    are 0 and ``meta["silent_why"]`` says why, so that nothing amplifies
    round-off to full scale.

    Parameters
    ----------
    tracks : SourceTracks
        The sources: ``positions (K, 3)`` in m, ``q (K, T)`` (S·ΔV) at data
        ``times (T,)`` in s (:meth:`auralize.sources.detection.SourceSeries.tracks`,
        :meth:`auralize.sources.field.FieldTracks.tracks`).
    path : ListenerPath
        Playback-time captures of the listener (m, s); held at the ends.
    timbre : {"physical", "extended", "tonal", "auto"}
        See the module docstring; ``auto`` is ``physical`` when at least
        :data:`AUDIBLE_SHARE` of its energy lies above 20 Hz, else ``extended``.
    rate : int
        Audio sample rate, Hz.
    time_scale : float
        Playback seconds per data second.
    interp : {"linear", "cubic"}
        Time interpolation of the strengths (paper 003 §3.2.4.3).
    layout : str or Layout
        Any layout of :func:`auralize.spatial.layouts.get_layout`, ``binaural``
        included.
    c0 : float
        Speed of sound, m/s.
    duration : float, optional
        Playback seconds (default: the path's duration after ``start``).
    bounds : tuple of 6 float, optional
        Grid bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)`` in m; a listener
        absurdly far from them is refused
        (:func:`auralize.emitters.synthesis.check_distance`).
    start : float
        Playback seconds into the path of the first output sample (blocks
        rendered with increasing ``start`` join without seams).
    lead : float
        Data seconds between the data's first step and the first output sample.
    highpass_hz : float
        Cut-off of the causal output high-pass (Hz, :func:`highpass`); 0 keeps
        everything.
    seed : int
        Seed of the noise carriers (same seed, same output).
    alpha : float
        Power-law exponent α of the ``extended`` noise (power spectrum f^−α,
        paper 001 §4; Table 1: 2.5–3.5), > 0.
    carriers : dict, optional
        ``tonal`` carriers per type name, ``("tone", Hz)`` or
        ``("noise", low Hz, high Hz)`` (default :data:`TONAL_CARRIERS`).
    hrtf : HRIRSet, str or Path, optional
        ``binaural`` only: HRIRs or a SOFA file (default the spherical head).
    by_type : dict, optional
        ``tonal``: the tracks of each type (``{name: SourceTracks}``, the
        whole field's terms); default from ``tracks.kind``.

    Returns
    -------
    Rendered
        ``audio (n_channels, n_samples)`` (pascals for ``physical``); ``meta``
        holds the timbre used, seed, high-pass, ``share_above_20hz_unfiltered``
        (the energy share above 20 Hz before the high-pass) and
        ``timbre_notes`` (what to tell the user: an infrasonic physical render).

    Raises
    ------
    ParameterError
        An unknown ``timbre``; ``alpha`` not > 0; ``highpass_hz`` outside
        [0, rate / 2); ``tonal`` on tracks without ``kind`` and no
        ``by_type``, or ``carriers`` for unknown types or of another form;
        the options :func:`auralize.emitters.synthesis.render_tracks` refuses.
    ListenerPathError
        A listener absurdly far from ``bounds``
        (:func:`auralize.emitters.synthesis.check_distance`).

    Examples
    --------
    One monopole whose strength ramps up, heard from 17 m: the pressure
    is q(t − D/c0) / (4π D), silent until the sound has come 17 m (49.6 ms,
    sample 396.5 at 8 kHz):

    >>> import numpy as np
    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.array([[0.0, 1, 2, 3]]),
    ...                   radius=np.full(1, 0.1), times=np.arange(4) * 0.1,
    ...                   kind=np.ones((1, 4), dtype=np.int8))
    >>> path = ListenerPath.point([17.0, 0, 0], duration=0.4)
    >>> out = render_timbre(tr, path, rate=8000, interp="linear", highpass_hz=0.0)
    >>> out.audio.shape, out.meta["timbre"], int(np.flatnonzero(out.audio[0])[0])
    ((1, 3200), 'physical', 397)
    >>> q = np.interp(0.15 - 17.0 / 343.0, tr.times, tr.q[0])  # emitted for t = 0.15 s
    >>> bool(np.isclose(out.audio[0, 1200], q / (4 * np.pi * 17.0)))
    True

    Data this slow sound below 20 Hz: ``auto`` extends them; ``tonal``
    gives monopoles their noise band:

    >>> render_timbre(tr, path, timbre="auto", rate=8000).meta["timbre"]
    'extended'
    >>> render_timbre(tr, path, timbre="tonal", rate=8000).meta["carriers"]
    {'monopole': ['noise', 177.0, 354.0]}
    """
    if timbre not in (*TIMBRES, "auto"):
        raise ParameterError(f"timbre must be one of {', '.join(TIMBRES)} or auto, got {timbre!r}")
    if not (np.isfinite(alpha) and alpha > 0):
        raise ParameterError(f"alpha (power-law exponent) must be > 0, got {alpha!r}")
    stage = output_stage(layout, int(rate), hrtf=hrtf)
    kw: dict[str, Any] = dict(
        rate=rate,
        time_scale=time_scale,
        interp=interp,
        layout=stage.synthesis_layout,
        c0=c0,
        duration=duration,
        start=start,
        lead=lead,
    )
    highpass(np.zeros((1, 0)), rate, highpass_hz)  # validate before rendering
    meta: dict[str, Any] = {"timbre": timbre, "seed": int(seed), "highpass_hz": highpass_hz}
    notes: list[str] = []
    phys = None
    finished = timbre == "physical"  # (its output's share: the ears', not their harmonics')
    coarse: tuple[Rendered, int, int] | None = None
    if timbre in ("physical", "auto"):
        f_cut = cutoff_hz(tracks, time_scale) if tracks.times.size >= 2 else 0.0
        if not finished and 0 < f_cut and envelope_rate(int(rate), f_cut) < rate:
            # data too slow to sound above the envelope rate's band: whether the
            # physical render is audible is decided from its envelope-rate render
            # (the images of the interpolation above it hold a negligible share)
            joined = _joined(tracks, path, "timbre:joined", lambda join: join(tracks), c0)
            # (below half the high-pass the physical low band is not kept by
            # `extended`: its mono sum decides, and sets β)
            low_kw = kw if f_cut > 0.5 * highpass_hz else {**kw, "layout": "mono"}
            coarse = _coarse_render(joined, path, low_kw, f_cut, bounds)
            share = _share_above(coarse[0].audio, float(coarse[0].rate), 20.0)
            phys = None
        else:
            phys = render_tracks(tracks, path, bounds=bounds, **kw)
            if finished:
                phys = stage.finish(phys)
                meta["share_above_20hz_unfiltered"] = loudness(phys.audio, rate)["share_above"]
                share = meta["share_above_20hz_unfiltered"]
            else:
                share = loudness(phys.audio, rate)["share_above"]
        meta["physical_share_above_20hz"] = share
        if share < AUDIBLE_SHARE and tracks.n_sources:
            below = f"{100 * (1 - share):.0f} % of the physical sound lies below 20 Hz"
            if timbre == "auto":
                timbre = "extended"
                f_cut = cutoff_hz(tracks, time_scale)
                how = (
                    f"physical below {f_cut:.3g} Hz, power-law noise above"
                    if f_cut > 0.5 * highpass_hz
                    else f"power-law noise above {f_cut:.3g} Hz; the physical part below "
                    f"it is under the {highpass_hz:g} Hz high-pass, left out"
                )
                notes.append(
                    f"timbre auto: {below} (inaudible); rendered 'extended' ({how}); "
                    f"--timbre physical keeps the pressure alone"
                )
            else:
                notes.append(
                    f"note: {below} (inaudible); try --timbre extended, or a smaller "
                    f"--time-scale (the data played faster)"
                )
        elif timbre == "auto":
            timbre = "physical"
        if phys is None and timbre == "physical":
            phys = render_tracks(tracks, path, bounds=bounds, **kw)
        meta["timbre"] = timbre
    if timbre == "physical":
        assert phys is not None
        out = phys
    elif timbre == "extended":
        out = _extended(
            tracks,
            path,
            kw,
            bounds=bounds,
            seed=seed,
            alpha=alpha,
            c0=c0,
            start=start,
            meta=meta,
            coarse=coarse,
            highpass_hz=highpass_hz,
        )
    else:
        out = _tonal(
            tracks,
            path,
            kw,
            bounds=bounds,
            seed=seed,
            carriers=carriers or TONAL_CARRIERS,
            c0=c0,
            start=start,
            meta=meta,
            by_type=by_type,
        )
    if meta.get("beta_rule") == "rms":
        notes.append(
            "the field changes slowly against the data's time step (no physical "
            "sound at the cut-off to extend): the noise is scaled to the RMS of the "
            "physical pressure's changes"
        )
    meta["timbre_notes"] = notes
    if not finished:
        out = stage.finish(out)  # the output channels (binaural: two ears) before the high-pass
    if "share_above_20hz_unfiltered" not in meta:
        meta["share_above_20hz_unfiltered"] = loudness(out.audio, rate)["share_above"]
    out.audio = highpass(
        out.audio,
        rate,
        highpass_hz,
        single=meta["timbre"] != "physical" and not meta.get("low_band") == "kept",
    )
    level = ROUNDOFF_LEVEL * term_level(tracks, path)
    peak = float(np.max(np.abs(out.audio), initial=0.0))
    if peak <= level:
        meta["silent_why"] = (
            f"nothing in the data changes in a way that sounds: the "
            f"{'pressure' if timbre == 'physical' else 'sound'} peaks at {peak:.3g} "
            f"Pa, round-off against the {level / ROUNDOFF_LEVEL:.3g} Pa its terms "
            f"would make without cancelling; written as silence, not amplified"
        )
        meta["timbre_notes"] = [*meta.get("timbre_notes", []), f"silent: {meta['silent_why']}"]
        out.audio = np.zeros_like(out.audio)
    out.meta.update(meta)
    return out


#: envelopes are rendered at no less than 8 f_cut and :data:`MIN_ENVELOPE_HZ`, at most this many
#: times below the audio rate, and interpolated linearly
MAX_DECIMATION = 256
#: the lowest envelope rate (Hz): it still holds every frequency the high-pass lets
#: through below 5 × 20 Hz, where the share of audible sound is judged
MIN_ENVELOPE_HZ = 250.0


def envelope_rate(rate: int, f_cut: float) -> int:
    """Sample rate (Hz, dividing ``rate``) of the envelope renders: ``rate`` / k with k
    the largest divisor of ``rate`` not above ``rate / max(8 f_cut, MIN_ENVELOPE_HZ)`` and
    :data:`MAX_DECIMATION`.

    Parameters
    ----------
    rate : int
        The audio sample rate, Hz.
    f_cut : float
        The highest frequency (Hz) the envelopes hold (:func:`cutoff_hz`).

    Returns
    -------
    int
        The envelope rate in Hz (``rate`` itself when no decimation fits).

    Examples
    --------
    >>> envelope_rate(48000, 5.0), envelope_rate(44100, 5.0), envelope_rate(8000, 2000.0)
    (250, 252, 8000)
    """
    k = int(min(MAX_DECIMATION, max(1.0, rate // max(8.0 * f_cut, MIN_ENVELOPE_HZ))))
    while rate % k:
        k -= 1
    return rate // k


def _smooth_render(
    tracks: SourceTracks,
    path: ListenerPath,
    kw: dict[str, Any],
    f_cut: float,
    bounds: tuple[float, ...] | None = None,
) -> Rendered:
    """:func:`render` of a signal band-limited to about ``f_cut`` (an envelope |q|,
    or the pressure under the data's Nyquist frequency) at :func:`envelope_rate`,
    linearly interpolated to the audio rate: the retarded-time sum is evaluated
    exactly at every envelope sample, and most of the per-sample cost is saved."""
    coarse, n, k = _coarse_render(tracks, path, kw, f_cut, bounds)
    return _upsampled(coarse, coarse.audio, n, k)


def _coarse_render(
    tracks: SourceTracks,
    path: ListenerPath,
    kw: dict[str, Any],
    f_cut: float,
    bounds: tuple[float, ...] | None = None,
) -> tuple[Rendered, int, int]:
    """The envelope-rate render of :func:`_smooth_render` before interpolation:
    ``(coarse, n, k)``, ``n`` samples at the audio rate, ``k`` audio samples per
    envelope sample (``coarse`` has ``n // k + 2`` samples; ``k`` 1: ``coarse``
    is the audio-rate render itself)."""
    rate = int(kw["rate"])
    er = envelope_rate(rate, f_cut)
    if er == rate:
        out = render_tracks(tracks, path, bounds=bounds, **kw)
        return out, out.audio.shape[1], 1
    dur = kw["duration"] if kw["duration"] is not None else path.duration - kw["start"]
    n = round(dur * rate)
    k = rate // er
    coarse = render_tracks(
        tracks, path, bounds=bounds, **{**kw, "rate": er, "duration": (n // k + 2) / er}
    )
    return coarse, n, k


def _envelope_render(
    tracks: SourceTracks,
    path: ListenerPath,
    kw: dict[str, Any],
    *,
    f_cut: float,
    bounds: tuple[float, ...] | None,
    c0: float,
) -> Rendered:
    """:func:`change_envelope` in every channel, taken at the envelope rate (sources
    merged as :func:`_joined`) and interpolated to the audio rate."""
    coarse, n, k = _envelope_coarse(tracks, path, kw, f_cut=f_cut, bounds=bounds, c0=c0)
    return _upsampled(coarse, coarse.audio, n, k)


def _envelope_coarse(
    tracks: SourceTracks,
    path: ListenerPath,
    kw: dict[str, Any],
    *,
    f_cut: float,
    bounds: tuple[float, ...] | None,
    c0: float,
) -> tuple[Rendered, int, int]:
    """:func:`_envelope_render` before its interpolation to the audio rate: the
    envelopes at the envelope rate (a :class:`Rendered`), ``n`` and ``k`` as
    :func:`_coarse_render`."""
    joined = _joined(tracks, path, "timbre:change", lambda join: join(change_tracks(tracks)), c0)
    coarse, n, k = _coarse_render(joined, path, kw, f_cut, bounds)
    step_s = _data_step(tracks) * float(kw["time_scale"])
    parts = receivers_of(coarse.layout) or [None]
    env = np.empty_like(coarse.audio)
    c = 0
    for r in parts:  # each receiver's channels (the ears of binaural: AmbiX each)
        lay = coarse.layout if r is None else r.layout
        m = lay.n_channels
        env[c : c + m] = change_envelope(
            coarse.audio[c : c + m], coarse.rate, step_s, ambisonic=is_ambisonic(lay)
        )
        c += m
    return (
        Rendered(
            audio=env,
            rate=coarse.rate,
            layout=coarse.layout,
            time_scale=coarse.time_scale,
            meta=coarse.meta,
        ),
        n,
        k,
    )


def _upsampled(coarse: Rendered, e: NDArray[np.float64], n: int, k: int) -> Rendered:
    """Envelope-rate samples ``e (n_channels, ≥ n // k + 2)`` of ``coarse``
    linearly interpolated to ``n`` samples at ``k`` times the rate."""
    if k == 1:
        return Rendered(
            audio=e,
            rate=coarse.rate,
            layout=coarse.layout,
            time_scale=coarse.time_scale,
            meta=coarse.meta,
        )
    w = _lerp_weights(n, k)
    audio = np.empty((e.shape[0], n))
    m = n // k  # whole envelope steps; then the n - m k samples of a last one
    for c in range(e.shape[0]):  # per channel: the temporaries stay in cache
        pair = e[c, : m + 2]
        # sample j = i k + r is e[i] (1 - r/k) + e[i + 1] r/k: per step a row
        if m:
            steps = audio[c, : m * k].reshape(m, k)
            np.multiply(pair[:m, None], w[2][:k], out=steps)
            steps += pair[1 : m + 1, None] * w[3][:k]
        tail = audio[c, m * k :]
        np.multiply(pair[w[0][m * k :]], w[2][m * k :], out=tail)
        tail += pair[w[1][m * k :]] * w[3][m * k :]
    return Rendered(
        audio=audio,
        rate=coarse.rate * k,
        layout=coarse.layout,
        time_scale=coarse.time_scale,
        meta={**coarse.meta, "envelope_rate_hz": coarse.rate},
    )


@functools.lru_cache(maxsize=8)
def _lerp_weights(n: int, k: int) -> tuple[NDArray[Any], ...]:
    """Indices and weights of linear interpolation by ``k``: sample j of the
    output is ``e[i0] (1 − frac) + e[i0 + 1] frac`` with ``i0 = j // k``,
    ``frac = (j mod k) / k`` (cached: callers must not modify them)."""
    j = np.arange(n)
    i0, frac = j // k, (j % k) / k
    out = (i0, i0 + 1, 1.0 - frac, frac)
    for a in out:
        a.flags.writeable = False
    return out


def cutoff_hz(tracks: SourceTracks, time_scale: float) -> float:
    """Nyquist frequency of the data's time stepping in playback time (Hz): the
    ``extended`` cut-off f_cut (paper 001 §4 and Table 1 use the simulation's
    Nyquist, 180 Hz).

    Parameters
    ----------
    tracks : SourceTracks
        The sources; the median step of their ``times (T,)`` (s) is the
        data's step (1 s for a single step).
    time_scale : float
        Playback seconds per data second.

    Returns
    -------
    float
        ``0.5 / (step * time_scale)`` in Hz.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 4)),
    ...                   radius=np.full(1, 0.05), times=np.arange(4) * 0.1)
    >>> round(cutoff_hz(tr, 1.0), 9), round(cutoff_hz(tr, 0.1), 9)  # data played 10x faster
    (5.0, 50.0)
    """
    return 0.5 / (_data_step(tracks) * time_scale)


def _extended(
    tracks: SourceTracks,
    path: ListenerPath,
    kw: dict[str, Any],
    *,
    bounds: tuple[float, ...] | None,
    seed: int,
    alpha: float,
    c0: float,
    start: float,
    meta: dict[str, Any],
    coarse: tuple[Rendered, int, int] | None = None,
    highpass_hz: float = 0.0,
) -> Rendered:
    from scipy.fft import rfft

    f_cut = cutoff_hz(tracks, float(kw["time_scale"]))
    meta.update({"alpha": alpha, "f_cut_hz": f_cut})
    # below half the output high-pass the low band is inaudible and filtered out
    keep_low = f_cut > 0.5 * highpass_hz
    rate = int(kw["rate"])
    if f_cut >= 0.45 * rate or tracks.n_sources == 0:
        meta["beta"] = 0.0
        return render_tracks(tracks, path, bounds=bounds, **kw)
    if coarse is None:
        joined = _joined(tracks, path, "timbre:joined", lambda join: join(tracks), c0)
        # without the low band in the output, its mono sum is all β needs
        coarse = _coarse_render(
            joined, path, kw if keep_low else {**kw, "layout": "mono"}, f_cut, bounds
        )
    low_r, n, k = coarse
    if n < 4:
        meta["beta"] = 0.0
        return render_tracks(tracks, path, bounds=bounds, **kw)
    env_c, _, _ = _envelope_coarse(tracks, path, kw, f_cut=f_cut, bounds=bounds, c0=c0)
    env = _upsampled(env_c, env_c.audio, n, k)

    def shape(f: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.maximum(f, 0.25 * f_cut) ** (-alpha / 2)

    def carrier_at(r: int) -> Any:
        def carrier(clock: _Clock) -> NDArray[np.float64]:
            return clock.noise(
                _noise_table(clock.size, r, (int(seed), 1), shape, ("power", alpha, f_cut))
            )

        return carrier

    env.audio *= _carriers(tracks, path, env, carrier_at(rate), start=start, c0=c0)
    # the noise band in single precision (a third of the cost; 1e-6 of a noise's level)
    high = _crossover(env.audio, rate, f_cut, "highpass", single=True).astype(np.float64)
    # Eq. 13, power summed over the channels: low + β high matches the physical
    # power under g(f).  Spectra are normalised by their length (amplitudes, the
    # same for any sample rate), so the physical pressure's may come from its
    # envelope-rate render when the low band is not kept (then the cross term,
    # which needs the low band at the audio rate, is left out: random-phase
    # noise is uncorrelated with it)
    sigma = max(f_cut * 10.0 / 180.0, 3.0 * rate / n)  # Table 1: σ 10 Hz at 180 Hz

    def weights(
        m: int, r: float
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
        f = np.asarray(np.fft.rfftfreq(m, 1.0 / r), dtype=np.float64)
        g2 = np.exp(-(((f - f_cut) / sigma) ** 2)) * (f > 0)
        band = g2 > 1e-30 * g2.max(initial=0.0)  # where the weights are not negligible
        return f, band, g2[band]

    low = None
    H: NDArray[Any] | None = None
    if keep_low or k == 1:
        # the audio-rate spectrum's weights (the other branch reads none)
        f, band, g2 = weights(n, rate)
        # (in single precision: the sums below need 6 digits, at half the cost)
        H = rfft(high.astype(np.float32), axis=-1) / n
        Hb = H[:, band]
        a = float(np.sum(np.abs(Hb) ** 2 * g2))
    else:
        # the noise band's power at the cut-off from the same noise spectrum read at
        # the envelope rate (which holds the cut-off and 20 Hz many times over):
        # the audio-rate transform is not needed
        m_c = env_c.audio.shape[1]
        noise_c = env_c.audio * _carriers(
            tracks, path, env_c, carrier_at(env_c.rate), start=start, c0=c0
        )
        Hc = rfft(_crossover(noise_c, env_c.rate, f_cut, "highpass"), axis=-1) / m_c
        _, hb, hg2 = weights(m_c, env_c.rate)
        a = float(np.sum(np.abs(Hc[:, hb]) ** 2 * hg2))
    if keep_low:
        phys_full = _upsampled(low_r, low_r.audio, n, k).audio
        low = _crossover(phys_full, rate, f_cut, "lowpass")
        P, L = (rfft(x.astype(np.float32), axis=-1) / n for x in (phys_full, low))
        Pb, Lb = P[:, band], L[:, band]
        b = float(2 * np.sum(np.real(Lb * np.conj(Hb)) * g2))
    else:
        m = low_r.audio.shape[1]
        _, cb, cg2 = weights(m, low_r.rate)
        P = rfft(low_r.audio, axis=-1) / m
        fc = np.fft.rfftfreq(m, 1.0 / low_r.rate)
        Pb = P[:, cb]
        Lb = Pb * _lowpass_response(np.asarray(fc[cb], dtype=np.float64), low_r.rate, f_cut)
        # the two grids' bins differ: weight each spectrum's bins by its own g2
        b = 0.0
        c_l = float(np.sum(np.abs(Lb) ** 2 * cg2) - np.sum(np.abs(Pb) ** 2 * cg2))
    if keep_low:
        c_l = float(np.sum(np.abs(Lb) ** 2 * g2) - np.sum(np.abs(Pb) ** 2 * g2))
    disc = b * b - 4 * a * c_l
    beta = (-b + np.sqrt(disc)) / (2 * a) if a > 0 and disc >= 0 else 0.0
    beta = float(max(beta, 0.0))
    meta["beta_rule"] = "Eq. 13"
    if beta == 0.0 and a > 0:
        # changes whose pressure has no power left at the cut-off (they are slow
        # against the data's step): the noise carries the physical pressure's
        # RMS over the band the changes occupy (its level instead of its
        # spectrum at f_cut)
        # (power per sample summed over the channels: the low band may be their mono sum)
        p2 = float(np.sum(_crossover(low_r.audio, low_r.rate, 0.25 * f_cut, "highpass") ** 2))
        p2 /= low_r.audio.shape[1]
        h2 = float(np.sum(high**2)) / high.shape[1]
        if p2 > 0 and h2 > 0:
            beta = float(np.sqrt(p2 / h2))
            meta["beta_rule"] = "rms"
    meta["beta"] = beta
    # below half the high-pass the low band is left out of the output: what the
    # high-pass would leave of it is the ramp response of slow changes (a DC step
    # in and out), infrasonic and no part of the sound
    meta["low_band"] = "kept" if keep_low else "below half the high-pass: left out"
    # the output's spectrum before the high-pass is β H (+ L): its share above
    # 20 Hz without another transform
    high *= beta
    if H is not None:
        H *= beta
        if keep_low:
            assert low is not None
            H += L
            high += low
        spec = np.sum(H.real**2 + H.imag**2, axis=0, dtype=np.float64)
        total = float(spec.sum())
        share = float(spec[f > 20.0].sum() / total) if total > 0 else 0.0
    else:
        # the power below 20 Hz per sample from the envelope-rate spectrum (Parseval,
        # one-sided), against the output's power per sample
        fc2 = np.fft.rfftfreq(m_c, 1.0 / env_c.rate)
        w = np.where(fc2 == 0, 1.0, 2.0)
        below = float(np.sum((np.abs(Hc) ** 2 * w)[:, fc2 <= 20.0])) * beta**2
        total = float(np.sum(high**2)) / n
        share = min(max(1.0 - below / total, 0.0), 1.0) if total > 0 else 0.0
    meta["share_above_20hz_unfiltered"] = share
    return Rendered(
        audio=high, rate=rate, layout=env.layout, time_scale=env.time_scale, meta=env.meta
    )


def _lowpass_response(f: NDArray[np.float64], rate: float, f_cut: float) -> NDArray[np.complex128]:
    """The frequency response at ``f`` of the crossover's low side (:func:`_crossover`)."""
    from scipy.signal import sosfreqz

    sos = butter_sos(2, float(f_cut), "lowpass", float(rate))
    _, h = sosfreqz(
        np.concatenate([sos, sos]), worN=np.asarray(f, dtype=np.float64), fs=float(rate)
    )
    return np.asarray(h)


def _crossover(
    x: NDArray[np.float64], rate: float, f_cut: float, kind: str, *, single: bool = False
) -> NDArray[Any]:
    """One side of a causal 4th-order Linkwitz–Riley crossover at ``f_cut`` (the two
    sides sum to an all-pass: the band split of Eq. 12 without pre-echo), started
    in its steady state for the first sample (:func:`highpass_start`): a sound
    already going on at the start passes without a transient."""
    from scipy.signal import sosfilt

    sos = np.concatenate([butter_sos(2, float(f_cut), kind, float(rate))] * 2)
    a = np.asarray(x)
    if a.shape[-1] == 0:
        return a
    zi = highpass_start(sos, a[..., 0])  # (solved in double precision)
    if single:
        sos, a, zi = sos.astype(np.float32), a.astype(np.float32), zi.astype(np.float32)
    out, _ = sosfilt(sos, a, axis=-1, zi=zi)
    return np.asarray(out)


def _tone(hz: float, phase_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """A unit-RMS sine of ``hz`` at the emission times ``phase_s`` (s): the
    cycles are counted in double precision, the sine of their fraction taken
    in single precision (1e-7 of the amplitude, at a fraction of the cost)."""
    cyc = phase_s * hz
    cyc -= np.floor(cyc)
    return np.sin(cyc.astype(np.float32) * np.float32(2 * np.pi)) * np.sqrt(2.0)


def _share_above(audio: NDArray[np.float64], rate: float, hz: float) -> float:
    """The share of the energy of ``audio (n_channels, n)`` above ``hz`` (as
    :func:`loudness`; the spectrum in single precision: six digits)."""
    from scipy.fft import rfft

    spec = np.zeros(audio.shape[-1] // 2 + 1)
    for x in audio:  # per channel: the spectra stay small
        X = rfft(x.astype(np.float32))
        spec += X.real.astype(np.float64) ** 2 + X.imag.astype(np.float64) ** 2
    total = float(spec.sum())
    f = np.fft.rfftfreq(audio.shape[-1], 1.0 / rate)
    return float(spec[f > hz].sum() / total) if total > 0 else 0.0


def _type_tracks(tracks: SourceTracks) -> dict[str, SourceTracks]:
    """Per type that occurs (monopole, dipole, quadrupole): the tracks of q where
    the source has that type."""
    q = np.asarray(tracks.q, dtype=np.float64)
    kind = np.asarray(tracks.kind)
    out: dict[str, SourceTracks] = {}
    for code, name in enumerate(TYPES, start=1):
        on = kind == code
        if np.any(on & (q != 0)):
            out[name] = _subset(tracks, np.where(on, q, 0.0))
    return out


def _tonal(
    tracks: SourceTracks,
    path: ListenerPath,
    kw: dict[str, Any],
    *,
    bounds: tuple[float, ...] | None,
    seed: int,
    carriers: dict[str, tuple[Any, ...]],
    c0: float,
    start: float,
    meta: dict[str, Any],
    by_type: dict[str, SourceTracks] | None = None,
) -> Rendered:
    if by_type is None and tracks.kind is None and tracks.n_sources > 0:  # (no sources: silence)
        raise ParameterError(
            "the tonal timbre needs the source types of the tracks (kind); "
            "build them with SourceSeries.tracks(), or give by_type"
        )
    bad = set(carriers) - set(TYPES)
    if bad:
        raise ParameterError(f"tonal carriers are given per type {TYPES}, got {sorted(bad)}")
    if bounds is not None:
        check_distance(path, bounds)
    audio: NDArray[np.float64] | None = None
    base: Rendered | None = None
    used = {}
    f_cut = cutoff_hz(tracks, float(kw["time_scale"]))
    if by_type is None:
        by_type = cached_on_tracks(tracks, "timbre:types", "", lambda: _type_tracks(tracks))
    envs: dict[str, Rendered] = {}
    # each type's changes scaled so that its largest equals the largest of all types
    # (a property of the data, not of this render: distance and direction keep
    # their effect; loudness across types is not physical)
    peak = {
        name: float(np.max(np.abs(change_tracks(t).q), initial=0.0))
        for name, t in by_type.items()
        if t is not None and t.n_sources
    }
    top = max(peak.values(), default=0.0)
    for name in TYPES:
        sub = by_type.get(name)
        if sub is None or sub.n_sources == 0 or name not in carriers or not peak.get(name):
            continue
        env = _envelope_render(sub, path, kw, f_cut=f_cut, bounds=bounds, c0=c0)
        if float(np.max(np.abs(env.audio), initial=0.0)) > 0:
            env.audio *= top / peak[name]
            envs[name] = env
    for code, name in enumerate(TYPES, start=1):
        if name not in envs:
            continue
        env = envs[name]
        sub = by_type[name]
        rate = env.rate
        if audio is None:
            base, audio = env, np.zeros_like(env.audio)
        spec = carriers[name]
        if spec[0] == "tone":

            def carrier(clock: _Clock, f: float = float(spec[1])) -> NDArray[np.float64]:
                return _tone(f, clock.phase_s())

        elif spec[0] == "noise":
            f_lo, f_hi = float(spec[1]), float(spec[2])

            def band(f: NDArray[np.float64], f_lo: float = f_lo, f_hi: float = f_hi) -> Any:
                return ((f >= f_lo) & (f <= f_hi)).astype(np.float64)

            def carrier(
                clock: _Clock,
                *,
                band: Any = band,
                code: int = code,
                f_lo: float = f_lo,
                f_hi: float = f_hi,
                rate: int = rate,
            ) -> NDArray[np.float64]:
                return clock.noise(
                    _noise_table(clock.size, rate, (int(seed), 2, code), band, ("band", f_lo, f_hi))
                )

        else:
            raise ParameterError(
                f"tonal carrier for {name} must be ('tone', Hz) or "
                f"('noise', low Hz, high Hz), got {spec!r}"
            )
        audio += env.audio * _carriers(_abs_tracks(sub), path, env, carrier, start=start, c0=c0)
        used[name] = list(spec)
    meta["carriers"] = used
    if audio is not None:
        meta["share_above_20hz_unfiltered"] = _share_above(audio, float(kw["rate"]), 20.0)
    if base is None or audio is None:  # nothing changes: silence of the right shape
        empty = SourceTracks(
            positions=np.zeros((0, 3)),
            q=np.zeros((0, tracks.times.size)),
            radius=np.zeros(0),
            times=tracks.times,
            origin=tracks.origin,
            end=tracks.end,
        )
        base = render_tracks(empty, path, **kw)
        audio = base.audio
    return Rendered(
        audio=audio, rate=base.rate, layout=base.layout, time_scale=base.time_scale, meta=base.meta
    )


def _abs_tracks(tracks: SourceTracks) -> SourceTracks:
    """The tracks with |q| (the weights of the carriers' mean emission time), cached."""
    out: SourceTracks = cached_on_tracks(
        tracks, "timbre:abs", "", lambda: _subset(tracks, np.abs(np.asarray(tracks.q)))
    )
    return out
