"""Pressure at a moving listener by retarded-time summation (paper 003 §3.2.4.2–3.2.4.4).

For every source point k (a vertex that is a source at some step) the
synthesis sums, at each audio sample time t and listener position L(t),

    p(t) = 1/(4π) Σ_k q_k(t - D_k(t)/c0) / D_k(t),   D_k(t) = |L(t) - x_k|,

where q_k(τ) = S_k(τ) ΔV_k(τ) is the vertex's strength times its ΔV-sphere
volume (Eqs. 15–17; the three types share this form), interpolated in time
between the steps linearly or by a cubic Hermite spline with central-difference
tangents (§3.2.4.3).  A vertex that is not a source at a step has q = 0 there,
so sources fade in and out over one step; the series is padded with one
silent step before the first and after the last.  "Reachable" sources
(§3.2.4.2) are exactly those whose emission time t - D/c0 lies inside the
data: arrival delay, 1/D decay and the Doppler shift of a moving listener all
come out of this evaluation.

A listener inside a ΔV sphere would see D → 0: D is clamped to the vertex's
largest ΔV radius.  The listener may be anywhere else, inside the grid or
far outside it; only nonsense is refused (:func:`check_distance`: farther
than 10⁴ grid diagonals and 1000 km; :func:`check_arrival`: nothing can be
heard in the output window).

Time mapping (docs/design.md): audio sample n is at data time
``t0 + lead + n / (rate · time_scale)`` and at playback time ``n / rate`` on
the listener path; propagation uses physical c0 in data time.  ``lead``
(default 0) skips the sound's travel to a far listener.

The fast algorithm (:mod:`auralize.emitters._kernels.render_pieces`; for unpanned and
AmbiX output :mod:`auralize.emitters._kernels.render_runs`, one emission per knot, unless the path is
recorded: captures that most pieces' arrivals cross) costs
O(sources × steps + samples) instead of O(sources × samples) and gives the
sample-by-sample result (:func:`render_reference`) to ~1e-6 relative.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.constants import RHO0
from auralize.emitters import C0
from auralize.emitters._kernels import render_pieces, render_runs
from auralize.emitters._kernels.accumulate import _integrate_tasks
from auralize.emitters._kernels.arrivals import _LINE, _row_lines
from auralize.emitters._kernels.common import (
    _CHUNK,
    ROW,
    RUN_ROW,
    Accumulator,
    KnotRows,
    Lanes,
    Listener,
    Panning,
    PieceTable,
    RunTable,
    Scratch,
)
from auralize.emitters._synth_prepare import (
    MAX_DISTANCE_FACTOR,
    MAX_DISTANCE_M,
    audible_rows,
    box_distances,
    capture_interval_lines,
    check_arrival,
    check_distance,
    interpolate_knots,
    knot_times,
    padded_knots,
    prepare_render,
    source_extent,
)
from auralize.emitters._synth_tables import (
    cached_on_tracks,
    pan_table,
    panning_arrays,
    piece_tasks,
    run_tasks,
    sounding_pieces,
    sounding_runs,
)
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.runtime.jit import await_kernel, kernel_args
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import (
    Layout,
    get_layout,
    is_ambisonic,
    listener_frame,
    pan_gains,
    receiver_paths,
)

#: unpanned and AmbiX layouts (the binaural ears among them) are summed by
#: runs of pieces (:mod:`auralize.emitters._kernels.render_runs`) unless most of their pieces' arrivals cross listener captures (None); True
#: forces the runs, False the piece-wise kernel (for tests)
_BY_RUNS: bool | None = None
INTERPOLATIONS = ("linear", "cubic")

#: the public names, those of the steps before the kernels
#: (:mod:`~auralize.emitters._synth_prepare`, :mod:`~auralize.emitters._synth_tables`)
#: included: the other packages import them from here
__all__ = [
    "C0",
    "INTERPOLATIONS",
    "MAX_DISTANCE_FACTOR",
    "MAX_DISTANCE_M",
    "RHO0",
    "Rendered",
    "box_distances",
    "cached_on_tracks",
    "check_arrival",
    "check_distance",
    "knot_times",
    "pan_table",
    "panning_arrays",
    "prepare_render",
    "render_reference",
    "render_tracks",
    "source_extent",
]


@dataclass
class Rendered:
    """Synthesized audio ``(n_channels, n_samples)`` in pascals, plus how it was made
    (also what the sound-model plugins return; ``time_scale`` 1 for sound that is
    not a playback of data time).

    Parameters
    ----------
    audio : ndarray, shape (n_channels, n_samples)
        Pressure at the listener, Pa, in the layout's channel order, time last.
    rate : int
        Sample rate, Hz.
    layout : Layout
        The speaker (or AmbiX, binaural) layout the channels belong to.
    time_scale : float
        Playback seconds per data second (1 for sound that is not a playback of
        data time).
    meta : dict
        How it was made: :func:`render_tracks` records ``interp``, ``c0`` (m/s),
        ``n_sources``, ``t_start_data`` (data time of the first sample, s) and
        ``lead_s``; plugins add their own keys.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters.synthesis import Rendered
    >>> from auralize.spatial.layouts import get_layout
    >>> r = Rendered(np.zeros((2, 4800)), 48000, get_layout("stereo"))
    >>> r.duration, r.time_scale
    (0.1, 1.0)
    >>> r
    <Rendered: 0.1 s, stereo (2 ch) at 48000 Hz, peak 0 Pa, RMS 0 Pa>
    """

    def _repr_html_(self) -> str:
        """Notebook display (:mod:`auralize.runtime.notebook`)."""
        from auralize.runtime.notebook import rendered_html

        return rendered_html(self)

    audio: NDArray[np.float64]
    rate: int
    layout: Layout
    time_scale: float = 1.0
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """Playback length, s: ``n_samples / rate``.

        Examples
        --------
        >>> import numpy as np
        >>> from auralize.emitters.synthesis import Rendered
        >>> from auralize.spatial.layouts import get_layout
        >>> Rendered(np.zeros((1, 22050)), 44100, get_layout("mono")).duration
        0.5
        """
        return self.audio.shape[1] / self.rate

    def __repr__(self) -> str:
        """One line: length, layout, rate and level (never the samples)."""
        a = self.audio
        peak = float(np.max(np.abs(a), initial=0.0))
        rms = float(np.sqrt(np.mean(np.square(a)))) if a.size else 0.0
        return (
            f"<Rendered: {self.duration:.4g} s, {self.layout.name} ({a.shape[0]} ch) at "
            f"{self.rate} Hz, peak {peak:.4g} Pa, RMS {rms:.4g} Pa>"
        )


_WORK = threading.local()


def _workspace(name: str, shape: tuple[int, ...], dtype: type = np.float64) -> NDArray[Any]:
    """A reusable work array of ``shape`` (per thread; contents undefined).

    Reusing memory between calls avoids first-touch page faults, which cost
    more than the arithmetic for block-wise and live rendering.
    """
    store = getattr(_WORK, "arrays", None)
    if store is None:
        store = _WORK.arrays = {}
    size = int(np.prod(shape))
    buf = store.get(name)
    if buf is None or buf.size < size:
        buf = store[name] = np.empty(max(size, 1), dtype=dtype)
    return buf[:size].reshape(shape)


def _task_scratch(n_ch: int, gain: float = 1.0) -> Scratch:
    """A task's :class:`~auralize.emitters._kernels.common.Scratch`: four gain vectors of
    ``n_ch`` filled with ``gain``, the listener's frame, the parts' counts."""
    return Scratch(
        np.full(n_ch, gain),
        np.full(n_ch, gain),
        np.full(n_ch, gain),
        np.full(n_ch, gain),
        np.zeros(6),
        np.empty(2 * _CHUNK),
    )


_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()
#: the most tasks (and threads) a render is split into
_MAX_TASKS = 8


def _each_task(fn: Callable[[int], int], n_tasks: int) -> list[int]:
    """``fn(j)`` of every task ``0 <= j < n_tasks``, one thread each (this one included):
    the task kernels release the GIL and write disjoint windows of the accumulator."""
    global _POOL
    if n_tasks <= 1:
        return [fn(j) for j in range(n_tasks)]
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(
                max_workers=_MAX_TASKS - 1, thread_name_prefix="auralize-synthesis"
            )
        pool = _POOL
    others = [pool.submit(fn, j) for j in range(1, n_tasks)]
    try:
        first = fn(0)
    finally:
        wait(others)
    return [first, *(f.result() for f in others)]


#: rows whose arrivals may cross more listener captures than this are summed
#: piece by piece (:func:`auralize.emitters._kernels.pieces._piece_general`), not in parts
_MAX_PART_CAPTURES = 48


def render_tracks(
    tracks: SourceTracks,
    path: ListenerPath,
    *,
    rate: int = 44100,
    time_scale: float = 1.0,
    interp: str = "cubic",
    layout: str | Layout = "mono",
    c0: float = C0,
    duration: float | None = None,
    bounds: tuple[float, ...] | None = None,
    start: float = 0.0,
    threads: int | None = None,
    lead: float = 0.0,
) -> Rendered:
    """Synthesize the pressure heard along ``path`` (fast algorithm).

    Evaluates the retarded-time sum p(t) = 1/(4π) Σ_k q_k(t - D_k/c0) / D_k over
    the reachable sources (paper 003 §3.2.4.2–3.2.4.4, Eqs. 15–17), with q_k
    interpolated between the data's steps (§3.2.4.3) and D_k clamped to the
    source's ΔV radius; arrival delay, 1/D decay and Doppler come out of the
    evaluation.  Piece by piece in compiled kernels, O(sources × steps +
    samples); equal to :func:`render_reference` to ~1e-6 relative.

    Parameters
    ----------
    tracks : SourceTracks
        From :meth:`auralize.sources.detection.SourceSeries.tracks`.
    path : ListenerPath
        Playback-time captures; the listener is held at the ends.
    rate : int
        Audio sample rate in Hz.
    time_scale : float
        Playback seconds per data second; sample n is at data time
        ``t_first + lead + start / time_scale + n / (rate · time_scale)``.
    interp : {"linear", "cubic"}
        Time interpolation of the strengths (§3.2.4.3): linear, or the cubic
        Hermite spline with central-difference tangents.
    layout : str or Layout
        ``mono``, ``stereo``, ``ring8``, ``5.1``, ``7.1``, a JSON file, or
        ``ambix1..3`` (AmbiX encoding gains per piece); ``binaural`` is refused
        (it needs an output stage after the sum:
        :func:`auralize.emitters.timbre.render_timbre` applies it).
    c0 : float
        Speed of sound, m/s (propagation runs in data time with physical c0).
    duration : float, optional
        Playback seconds (default: the path's duration after ``start``).
    bounds : tuple, optional
        Grid bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)``; the listener may be
        anywhere, but one absurdly far from them raises
        :class:`ListenerPathError` (see :func:`check_distance`).
    start : float
        Playback seconds into the path of the first output sample (block-wise
        and live rendering render consecutive blocks with increasing ``start``;
        the blocks join without seams).
    threads : int, optional
        Most threads the work is split over (default: the machine's cores; at
        most 8).
    lead : float
        Data seconds between the data's first step and the output's first
        sample (and the path's start): a far listener hears nothing before
        the nearest source's delay, so the output can start there.

    Returns
    -------
    Rendered
        ``audio`` of shape ``(n_channels, n_samples)`` in pascals,
        ``n_samples = round(duration · rate)``.

    Raises
    ------
    ParameterError
        ``interp`` is not one of :data:`INTERPOLATIONS`; the layout is unknown or
        ``binaural``; ``rate``, ``time_scale`` or ``c0`` is not positive,
        ``lead`` or ``start`` negative, or nothing is left to render.
    ListenerPathError
        The listener moves as fast as sound (in data time) or is absurdly far
        from ``bounds``.

    Examples
    --------
    One source of constant q = 1 (four steps 0.1 s apart) heard 17 m away: after
    its onset has arrived (17 m / 343 m/s ≈ 0.05 s), the pressure is the closed
    form q / (4π D).

    >>> import numpy as np
    >>> from auralize.emitters.synthesis import render_tracks
    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 4)),
    ...                   radius=np.full(1, 0.1), times=np.arange(4) * 0.1)
    >>> out = render_tracks(tr, ListenerPath.point([17.0, 0, 0], duration=0.4), rate=8000)
    >>> out.audio.shape, out.meta["interp"]
    ((1, 3200), 'cubic')
    >>> bool(np.isclose(out.audio[0, 1600], 1 / (4 * np.pi * 17)))  # data time 0.2 s
    True
    """
    if interp not in INTERPOLATIONS:
        raise ParameterError(f"interp must be one of {INTERPOLATIONS}, got {interp!r}")
    lay = get_layout(layout)
    ears = receiver_paths(lay, path)
    if ears:  # several receivers (the ears): each along its own path, channels stacked
        outs = [
            render_tracks(
                tracks,
                p,
                rate=rate,
                time_scale=time_scale,
                interp=interp,
                layout=rl,
                c0=c0,
                duration=duration,
                bounds=bounds,
                start=start,
                threads=threads,
                lead=lead,
            )
            for rl, p in ears
        ]
        return Rendered(
            audio=np.concatenate([o.audio for o in outs]),
            rate=int(rate),
            layout=lay,
            time_scale=float(time_scale),
            meta=outs[0].meta,
        )
    spk_az, spk_ch = panning_arrays(lay)
    pr = prepare_render(
        tracks,
        path,
        rate=rate,
        time_scale=time_scale,
        c0=c0,
        duration=duration,
        bounds=bounds,
        start=start,
        orientation=spk_az.size > 0,
        lead=lead,
    )
    n_threads = max(1, min(threads or os.cpu_count() or 1, _MAX_TASKS))
    # accumulation blocks keep the running sums short (numerical safety); no
    # longer than the output (their memory is cleared at every call)
    shift = int(min(15, max(6, np.ceil(np.log2(max(pr.n_samples, 1))))))
    block = 1 << shift
    cubic = interp == "cubic"
    n_lo, n_hi, d_max = audible_rows(pr, tracks, c0)
    # rows whose arrivals can straddle a listener capture (one at or past
    # the output's end only cuts the pieces: no extra cost)
    t_end = min(pr.knot_times[-1] + d_max / c0, pr.t_start + (pr.n_samples - 1) / pr.fs)
    t_caps = pr.capture_times[(pr.capture_times > pr.knot_times[0]) & (pr.capture_times < t_end)]
    hi = np.searchsorted(t_caps, pr.knot_times[1:] + d_max / c0, side="right")
    costly = np.append(hi > np.searchsorted(t_caps, pr.knot_times[:-1], side="right"), False)
    # unpanned or AmbiX (gains at the knots): runs of pieces, one emission per
    # knot; else piece by piece.  The runs split pieces at captures in scalar
    # code, the piece-wise kernel in SIMD loops (parts): a recorded path, whose
    # captures most pieces' arrivals cross, takes the piece-wise kernel
    ambix = is_ambisonic(lay)
    runs_ok = ambix or (spk_az.size == 0 and lay.n_channels == 1)
    if _BY_RUNS is None:
        by_runs = runs_ok and not (n_hi > n_lo and float(np.mean(costly[n_lo:n_hi])) > 0.5)
    else:
        by_runs = _BY_RUNS and runs_ok
    if by_runs:
        run_row, run_len, run_count, run_offset, knot_data = sounding_runs(
            tracks, pr.knot_times, interp
        )
        some = bool(np.any((run_row < n_hi) & (run_row + run_len > n_lo)))
    else:
        chunk_start, chunk_count, piece_data = sounding_pieces(tracks, pr.knot_times, interp)
        some = bool(chunk_start[n_hi] > chunk_start[n_lo])
    audio = np.zeros((lay.n_channels, pr.n_samples))
    if tracks.n_sources and n_hi > n_lo and pr.n_samples > 0 and some:
        # rows whose arrivals can pass the next capture (at or after the
        # output's end too) solve two candidate lines: half as dear again
        nxt = np.searchsorted(pr.capture_times, pr.knot_times, side="right")
        ahead = pr.capture_times[np.minimum(nxt, pr.capture_times.size - 1)]
        two = (nxt < pr.capture_times.size) & (pr.knot_times + d_max / c0 >= ahead)
        two |= np.append(two[1:], False)  # (either knot of a row's pieces)
        cost = np.where(costly, 2.0, np.where(two, 1.5, 1.0))
        if by_runs:
            task_rows = task_chunks = run_tasks(
                run_row, run_len, run_count, n_lo, n_hi, n_threads=n_threads, cost=cost
            )
        else:
            task_chunks, task_rows = piece_tasks(chunk_start, n_lo, n_hi, n_threads, cost)
        n_blocks = (pr.n_samples + block - 1) // block
        # each task's output window: arrivals of the pieces between knot rows
        # ra and rb lie in [t_ra, t_rb + D_max/c0]
        first = (pr.knot_times[task_rows[:, 0]] - pr.t_start) * pr.fs
        last = (pr.knot_times[task_rows[:, 1]] + d_max / c0 - pr.t_start) * pr.fs + 2.0
        blo = np.clip(np.floor(first / block), 0, n_blocks - 1).astype(np.int64)
        bhi = np.clip(np.floor(last / block) + 1, 1, n_blocks).astype(np.int64)
        nb = np.maximum(bhi - blo, 1)
        size = nb * lay.n_channels * block * 4
        # (a task emits nothing before its first arrival: the rows before it
        # are neither cleared nor summed)
        m_lo = np.maximum(np.floor(first), blo * block)
        task_blk = np.ascontiguousarray(
            np.stack([blo, nb, np.concatenate([[0], np.cumsum(size)[:-1]]), m_lo], axis=1),
            dtype=np.int64,
        )
        acc = _workspace("acc", (int(size.sum()),))
        row_lines = _workspace("lines", (pr.knot_times.size, 2 * _LINE + 1))
        # per task, a row for each listener capture heard inside the output:
        # the emissions of pieces split there are summed in it (in cache)
        k_ct = int(np.searchsorted(pr.capture_times, pr.t_start - 1.0 / pr.fs, side="right"))
        k_end = int(
            np.searchsorted(pr.capture_times, pr.t_start + pr.n_samples / pr.fs, side="left")
        )
        capture_sums = _workspace(
            "captures", (task_blk.shape[0], max(k_end - k_ct, 0) * lay.n_channels * 4)
        )
        if not by_runs:
            # rows whose arrivals may cross captures: pieces split into parts
            # at them (the captures k with t_n < t_k <= t_{n+1} + D_max/c0)
            k_lo = np.searchsorted(pr.capture_times, pr.knot_times[:-1], side="right")
            k_hi = np.searchsorted(pr.capture_times, pr.knot_times[1:] + d_max / c0, side="right")
            parts = (k_hi > k_lo) & (k_hi - k_lo <= _MAX_PART_CAPTURES)
            row_captures = np.zeros((pr.knot_times.size, 2), dtype=np.int64)
            row_captures[:-1, 0] = k_lo
            row_captures[:-1, 1] = np.where(parts, k_hi, k_lo)
            interval_lines = capture_interval_lines(pr, c0)
        n_ch = lay.n_channels
        n_tasks = task_blk.shape[0]
        _row_lines(
            *kernel_args(
                pr.knot_times,
                pr.capture_times,
                pr.capture_pos,
                pr.capture_vel,
                float(c0),
                d_max,
                n_lo,
                n_hi,
                row_lines,
            )
        )
        lis = Listener(
            *kernel_args(
                pr.capture_times, pr.capture_pos, pr.capture_vel, pr.orient_table, pr.orient_clock
            )
        )
        const_orient = bool(np.all(pr.orient_table == pr.orient_table[0]))
        sums = Accumulator(
            *kernel_args(
                acc, task_blk, capture_sums, k_ct, shift, pr.n_samples, pr.t_start, pr.fs, n_ch
            )
        )
        if by_runs:
            # unpanned, or AmbiX: every channel gained from the harmonic table
            # (placeholder speakers for the scalar code)
            ch = np.arange(n_ch, dtype=np.int64)
            pan = Panning(
                *kernel_args(
                    np.zeros(n_ch if ambix else 0),
                    ch,
                    ch,
                    pan_table(lay, spk_az) if ambix else np.zeros((0, 4)),
                    False,
                    ambix,
                    False,
                    ambix,
                    const_orient,
                )
            )
            runs = RunTable(
                *kernel_args(run_row, run_len, run_count, run_offset, knot_data, task_chunks)
            )
            rows = KnotRows(
                *kernel_args(
                    pr.knot_times,
                    n_lo,
                    n_hi,
                    row_lines,
                    np.zeros((0, 2), dtype=np.int64),
                    np.zeros((0, 9)),
                )
            )
            n_rows = RUN_ROW.END if ambix else RUN_ROW.PLAIN_END

            def task(j: int) -> int:
                return int(
                    render_runs.render_task(
                        j,
                        runs,
                        rows,
                        cubic,
                        float(c0),
                        lis,
                        pan,
                        sums,
                        _task_scratch(n_ch),
                        np.zeros(n_rows * _CHUNK),
                        np.zeros((3, n_ch if ambix else 0, _CHUNK)),
                        np.empty((5, _CHUNK)),
                    )
                )
        else:
            pinv = pan_table(lay, spk_az)
            panned = spk_az.size > 0
            fold = bool(lay.fold_front)
            # speaker pairs (every arc < 180°, or stereo's front pair): gains in SIMD
            # loops; AmbiX: every channel gained (spherical harmonics)
            pairs = panned and pinv.shape[0] > 0 and pinv.shape[1] == 4
            dense = panned and pinv.shape[1] == 2
            nxt = np.roll(spk_ch, -1) if spk_ch.size else np.zeros(1, dtype=np.int64)
            pan = Panning(
                *kernel_args(spk_az, spk_ch, nxt, pinv, fold, panned, pairs, dense, const_orient)
            )
            table = PieceTable(*kernel_args(piece_data, chunk_start, chunk_count, task_chunks))
            rows = KnotRows(
                *kernel_args(pr.knot_times, n_lo, n_hi, row_lines, row_captures, interval_lines)
            )
            ng = n_ch if panned else 1

            def task(j: int) -> int:
                lanes = Lanes(
                    np.empty(ROW.PIECE_END * _CHUNK),
                    np.empty(ROW.END * _CHUNK),
                    np.zeros((_CHUNK, ng)),
                    np.zeros((_CHUNK, ng)),
                    np.zeros((ng if dense else 0, _CHUNK)),
                    np.zeros((ng if dense else 0, _CHUNK)),
                    np.empty((5, _CHUNK)),
                )
                return int(
                    render_pieces.render_task(
                        j,
                        table,
                        rows,
                        cubic,
                        float(c0),
                        lis,
                        pan,
                        sums,
                        _task_scratch(n_ch, 0.0),
                        lanes,
                    )
                )

        # (a kernel compiling in the background is waited for, then loaded from the cache)
        await_kernel(render_runs.render_task if by_runs else render_pieces.render_task)
        bad = sum(_each_task(task, n_tasks))
        _integrate_tasks(*kernel_args(acc, task_blk, n_tasks, n_ch, block, pr.n_samples, audio))
        if bad:
            raise RuntimeError(
                f"internal error: {bad} synthesis pieces fell outside their output windows"
            )
    return Rendered(
        audio=audio,
        rate=int(rate),
        layout=lay,
        time_scale=float(time_scale),
        meta={
            "interp": interp,
            "c0": c0,
            "n_sources": tracks.n_sources,
            "t_start_data": pr.t_start,
            "lead_s": lead,
        },
    )


def render_reference(
    tracks: SourceTracks,
    path: ListenerPath,
    *,
    rate: int = 44100,
    time_scale: float = 1.0,
    interp: str = "cubic",
    layout: str | Layout = "mono",
    c0: float = C0,
    duration: float | None = None,
    start: float = 0.0,
    lead: float = 0.0,
) -> NDArray[np.float64]:
    """Brute-force sample-by-sample evaluation of the same sum (O(sources × samples)).

    For tests and validation only: for every sample, every source's distance,
    emission time, interpolated strength and panning gain are computed
    directly (paper 003 §3.2.4.2–3.2.4.4, Eqs. 15–17), in NumPy, one source at
    a time.  :func:`render_tracks` gives the same to ~1e-6 relative.

    Parameters
    ----------
    tracks : SourceTracks
        The sources' strengths q = S·ΔV at the data's steps.
    path : ListenerPath
        Playback-time captures; the listener is held at the ends.
    rate : int
        Audio sample rate, Hz.
    time_scale : float
        Playback seconds per data second.
    interp : {"linear", "cubic"}
        Time interpolation of the strengths (§3.2.4.3).
    layout : str or Layout
        As for :func:`render_tracks`; binaural renders each ear's receiver.
    c0 : float
        Speed of sound, m/s.
    duration : float, optional
        Playback seconds (default: the path's duration after ``start``).
    start : float
        Playback seconds into the path of the first output sample.
    lead : float
        Data seconds between the data's first step and the first sample.

    Returns
    -------
    ndarray, shape (n_channels, n_samples)
        Pressure at the listener, Pa (the ``audio`` :func:`render_tracks` returns).

    Raises
    ------
    ParameterError
        An unknown layout, or a rate, time scale, speed of sound, lead, start or
        duration that is not valid (as :func:`prepare_render`).
    ListenerPathError
        The listener moves as fast as sound in data time.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters.synthesis import render_reference, render_tracks
    >>> from auralize.listener import ListenerPath
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.array([[0.0, 1, 3, 2]]),
    ...                   radius=np.full(1, 0.1), times=np.arange(4) * 0.1)
    >>> path = ListenerPath.point([17.0, 0, 0], duration=0.4)
    >>> ref = render_reference(tr, path, rate=8000)
    >>> ref.shape
    (1, 3200)
    >>> fast = render_tracks(tr, path, rate=8000).audio
    >>> bool(np.max(np.abs(fast - ref)) < 1e-6 * np.max(np.abs(ref)))
    True
    """
    lay = get_layout(layout)
    ears = receiver_paths(lay, path)
    if ears:
        return np.concatenate(
            [
                render_reference(
                    tracks,
                    p,
                    rate=rate,
                    time_scale=time_scale,
                    interp=interp,
                    layout=rl,
                    c0=c0,
                    duration=duration,
                    start=start,
                    lead=lead,
                )
                for rl, p in ears
            ]
        )
    pr = prepare_render(
        tracks,
        path,
        rate=rate,
        time_scale=time_scale,
        c0=c0,
        duration=duration,
        bounds=None,
        start=start,
        lead=lead,
    )
    n = np.arange(pr.n_samples)
    t = pr.t_start + n / pr.fs
    tp = path.times[0] + start + n / rate  # playback time on the path
    L = path.position_at(tp)
    fwd, up = path.orientation_at(tp)
    out = np.zeros((lay.n_channels, pr.n_samples))
    tn, q, mt = padded_knots(tracks)
    for k in range(tracks.n_sources):
        d_vec = tracks.positions[k] - L
        D = np.maximum(np.linalg.norm(d_vec, axis=1), max(tracks.radius[k], 1e-9))
        tau = t - D / c0
        qv = interpolate_knots(tn, q[k], mt[k], tau, interp)
        sig = qv / D
        if lay.n_channels == 1:
            out[0] += sig
        else:
            out += pan_gains(lay, listener_frame(d_vec, fwd, up)) * sig
    return out
