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

import math
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.constants import RHO0 as RHO0  # (re-exported)
from auralize.emitters import C0
from auralize.emitters._kernels import render_pieces, render_runs, tables
from auralize.emitters._kernels.accumulate import _integrate_tasks
from auralize.emitters._kernels.arrivals import _LINE, _row_lines
from auralize.emitters._kernels.common import (
    _CHUNK,
    KNOT_ROW,
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
from auralize.errors import ListenerPathError, ParameterError
from auralize.listener import ListenerPath
from auralize.runtime.jit import await_kernel, kernel_args
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import (
    Layout,
    get_layout,
    is_ambisonic,
    is_binaural,
    listener_frame,
    pan_gains,
    receiver_paths,
    triangulate,
)

#: unpanned and AmbiX layouts (the binaural ears among them) are summed by
#: runs of pieces (:mod:`auralize.emitters._kernels.render_runs`) unless most of their pieces' arrivals cross listener captures (None); True
#: forces the runs, False the piece-wise kernel (for tests)
_BY_RUNS: bool | None = None
INTERPOLATIONS = ("linear", "cubic")


@dataclass
class Rendered:
    """Synthesized audio ``(n_channels, n_samples)`` in pascals, plus how it was made
    (also what the sound-model plugins return; ``time_scale`` 1 for sound that is
    not a playback of data time)."""

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


@dataclass
class _Prepared:
    """A render's times and listener, in data seconds (:func:`prepare_render`): the
    padded knot times, the listener's captures (times, positions, velocity on each
    interval), its forward and up ``(N, 6)`` sampled from ``orient_clock[0]`` at rate
    ``orient_clock[1]``, the output's first time, samples per data second and length."""

    knot_times: NDArray[np.float64]
    capture_times: NDArray[np.float64]
    capture_pos: NDArray[np.float64]
    capture_vel: NDArray[np.float64]
    orient_table: NDArray[np.float64]
    orient_clock: NDArray[np.float64]
    t_start: float
    fs: float
    n_samples: int


def knot_times(tracks: SourceTracks) -> NDArray[np.float64]:
    """The data times padded with one silent step before and after."""
    t = np.asarray(tracks.times, dtype=np.float64)
    if t.size >= 2:
        d0, d1 = t[1] - t[0], t[-1] - t[-2]
    else:
        d0 = d1 = 1.0
    return np.concatenate([[t[0] - d0], t, [t[-1] + d1]])


def _pad_knots(tracks: SourceTracks) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    tn = knot_times(tracks)
    t = tracks.times
    q = np.zeros((tracks.n_sources, t.size + 2))
    q[:, 1:-1] = tracks.q / (4.0 * np.pi)
    return tn, q


def _tangents(tn: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Central-difference tangents dq/dτ at each knot (zero at the padded ends)."""
    m = np.zeros_like(q)
    if q.shape[1] > 2:
        m[:, 1:-1] = (q[:, 2:] - q[:, :-2]) / (tn[2:] - tn[:-2])
    return m


def _knots(
    tracks: SourceTracks,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Padded knot times, q/(4π) and tangents, cached on the tracks (block-wise
    and live rendering call the synthesis many times with the same tracks)."""
    key = (id(tracks.q), tracks.q.shape, id(tracks.times))
    cached = tracks.cache.get("knots")
    if cached is not None and cached[0] == key:
        return cached[1]
    tn, q = _pad_knots(tracks)
    out = (tn, np.ascontiguousarray(q), np.ascontiguousarray(_tangents(tn, q)))
    tracks.cache["knots"] = (key, out)
    return out


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


def panning_arrays(lay: Layout) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The kernel's speaker azimuths and channels (:meth:`Layout.panning_arrays`);
    for an AmbiX layout one placeholder per channel (its gains come from the
    spherical-harmonic table of :func:`pan_table`).

    Raises
    ------
    ParameterError
        For ``binaural``: render to :func:`auralize.spatial.layouts.synthesis_layout` and
        filter with :func:`auralize.spatial.layouts.output_stage` (as
        :func:`auralize.emitters.timbre.render_timbre` does).
    """
    if is_ambisonic(lay):
        return np.zeros(lay.n_channels), np.arange(lay.n_channels, dtype=np.int64)
    if is_binaural(lay):
        raise ParameterError(
            "auralize.emitters.synthesis.render_tracks pans to speaker or AmbiX layouts; for binaural render to "
            "auralize.spatial.layouts.synthesis_layout('binaural') (the ear receivers) and filter with "
            "auralize.spatial.layouts.output_stage, or use auralize.emitters.timbre.render_timbre"
        )
    return lay.panning_arrays()


def pan_table(lay: Layout, spk_az: NDArray[np.float64]) -> NDArray[np.float64]:
    """The kernel's panning table: speaker-pair inverse bases (2-D VBAP) for a
    horizontal layout, the triangle table of 3-D VBAP for one with elevation
    (see :func:`auralize.emitters._kernels.gains._gains3`), the SN3D factors and order
    for an AmbiX layout (see :func:`auralize.emitters._kernels.gains._gains_sh`)."""
    if is_ambisonic(lay):
        n = int(lay.meta["order"])
        tab = np.zeros(((n + 1) ** 2, 2))
        for o in range(n + 1):
            for m in range(-o, o + 1):
                a = abs(m)
                tab[o * o + o + m, 0] = math.sqrt(
                    (1.0 if a == 0 else 2.0) * math.factorial(o - a) / math.factorial(o + a)
                )
        from auralize.spatial.layouts import ambix_channels

        tab[:, 1] = -1.0  # each harmonic's output channel (a layout may keep a subset)
        tab[ambix_channels(lay), 1] = np.arange(lay.n_channels)
        return tab
    if lay.n_channels == 1 or lay.is_horizontal or spk_az.size == 0:
        return _pair_inverses(spk_az)
    tri = triangulate(lay)
    rows = [
        np.concatenate([inv.reshape(9), ch.astype(np.float64)])
        for inv, ch in zip(tri.inverse, tri.channels, strict=True)
    ]
    for d, nb in zip(tri.imaginary_directions, tri.imaginary_neighbours, strict=True):
        mask = float(sum(1 << int(c) for c in nb))
        rows.append(np.concatenate([d, [mask], np.zeros(5), [-2.0, -2.0, -2.0]]))
    return np.ascontiguousarray(np.array(rows).reshape(-1, 12))


def _pair_inverses(spk_az: NDArray[np.float64]) -> NDArray[np.float64]:
    """Inverse bases (n, 4) of adjacent speaker pairs for 2-D VBAP, or when a
    layout has an arc of 180° or more (then the kernel uses its angular law)
    the table of its arc wider than 180° (:func:`_wide_arc`)."""
    n = spk_az.size
    if n < 2:
        return np.zeros((0, 4))
    a0 = spk_az
    a1 = np.roll(spk_az, -1)
    span = np.mod(a1 - a0, 2 * np.pi)
    if n < 3 or np.any(span >= np.pi - 1e-9) or np.any(span <= 1e-9):
        return _wide_arc(spk_az, span)
    base = np.stack(
        [np.stack([np.cos(a0), np.cos(a1)], -1), np.stack([np.sin(a0), np.sin(a1)], -1)], 1
    )  # (n, 2, 2)
    return np.ascontiguousarray(np.linalg.inv(base).reshape(n, 4))


def _wide_arc(spk_az: NDArray[np.float64], span: NDArray[np.float64]) -> NDArray[np.float64]:
    """The kernel's table (1, 7) of a horizontal layout's arc wider than 180°
    (spanning ``span`` from speaker i to i + 1, counter-clockwise): i, the
    unit vectors (forward, left) of its two ends and of its middle (see
    :func:`auralize.emitters._kernels.gains._wide_end`); (0, 4) when no arc
    is clearly wider than 180° (by 1e-6 rad)."""
    wide = np.flatnonzero(span > np.pi + 1e-6)
    if spk_az.size < 2 or wide.size != 1:
        return np.zeros((0, 4))
    i = int(wide[0])
    a, b = float(spk_az[i]), float(spk_az[(i + 1) % spk_az.size])
    m = a + 0.5 * float(span[i])
    return np.array([[float(i), np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(m), np.sin(m)]])


def _pieces(tracks: SourceTracks, tn: NDArray[np.float64], interp: str) -> tuple[NDArray[Any], ...]:
    """The sounding pieces in chunks, sorted by knot row: ``(chunk_start, chunk_count, piece_data)``
    (cached on the tracks; built in two compiled passes over q).

    Piece n of a source (padded knots n and n + 1) sounds when q or its
    tangent is non-zero at either knot; a typical volume has a fraction of
    its vertices sounding at any step, and the kernel reads only these.  Row
    n's pieces fill chunks ``chunk_start[n]:chunk_start[n+1]`` of ``_CHUNK`` (chunk c holds
    ``chunk_count[c]``); per piece ``piece_data (C, 8, _CHUNK)``: the source's position,
    clamp radius, q/(4π) and dq/dτ at both knots (for linear interpolation
    dq/dτ is the piece's slope), contiguous per chunk so that the kernel
    streams it.
    """
    return cached_on_tracks(tracks, "pieces", interp, lambda: _build_pieces(tracks, tn, interp))


def cached_on_tracks(tracks: SourceTracks, name: str, interp: str, build: Any) -> Any:
    """``build()``, cached on the tracks under ``name`` while their arrays are the same."""
    key = (id(tracks.q), tracks.q.shape, id(tracks.times), id(tracks.positions), interp)
    cached = tracks.cache.get(name)
    if cached is not None and cached[0] == key:
        return cached[1]
    out = build()
    tracks.cache[name] = (key, out)
    return out


def _track_arrays(tracks: SourceTracks) -> tuple[NDArray[np.float64], ...]:
    """q, positions (K, 3) and radii of the tracks as contiguous float64 arrays."""
    return (
        np.ascontiguousarray(tracks.q, dtype=np.float64),
        np.ascontiguousarray(np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)),
        np.ascontiguousarray(tracks.radius, dtype=np.float64),
    )


def _build_pieces(
    tracks: SourceTracks, tn: NDArray[np.float64], interp: str
) -> tuple[NDArray[Any], ...]:
    q, pos, radius = _track_arrays(tracks)
    cubic = interp == "cubic"
    W = _CHUNK
    none = np.zeros(1, dtype=np.int64)
    counts = tables.build_pieces(
        *kernel_args(q, tn, pos, radius, cubic, True, none, none, np.zeros((1, 8, W)))
    )
    chunk_start = np.concatenate([[0], np.cumsum(-(-counts // W))]).astype(np.int64)
    chunk_count = np.zeros(int(chunk_start[-1]), dtype=np.int64)
    piece_data = np.empty((int(chunk_start[-1]), 8, W))  # lanes past chunk_count are never read
    tables.build_pieces(
        *kernel_args(q, tn, pos, radius, cubic, False, chunk_start, chunk_count, piece_data)
    )
    return chunk_start, chunk_count, piece_data


def _runs(tracks: SourceTracks, tn: NDArray[np.float64], interp: str) -> tuple[NDArray[Any], ...]:
    """The runs of sounding pieces in chunks, for unpanned layouts:
    ``(run_row, run_len, run_count, run_offset, knot_data)`` (cached on the tracks; see
    :func:`auralize.emitters._kernels.render_runs.render_task`).

    A run is a maximal stretch of consecutive sounding pieces of a source
    (the same pieces as :func:`_pieces`).  Runs that start in the same row,
    longest first, fill chunks of ``_CHUNK`` lanes: chunk g starts in row
    ``run_row[g]``, holds ``run_count[g]`` runs of at most ``run_len[g]`` pieces and its
    knot data at ``knot_data[run_offset[g]:]``.
    """
    return cached_on_tracks(tracks, "runs", interp, lambda: _build_runs(tracks, tn, interp))


def _build_runs(
    tracks: SourceTracks, tn: NDArray[np.float64], interp: str
) -> tuple[NDArray[Any], ...]:
    q, pos, radius = _track_arrays(tracks)
    cubic = interp == "cubic"
    W = _CHUNK
    none = np.zeros(0, dtype=np.int64)
    n = tables.find_runs(*kernel_args(q, tn, cubic, True, none, none, none))
    src, r0, length = (np.empty(n, dtype=np.int64) for _ in range(3))
    tables.find_runs(*kernel_args(q, tn, cubic, False, src, r0, length))
    order = np.lexsort((-length, r0))
    src, r0, length = src[order], r0[order], length[order]
    # chunks: _CHUNK runs at a time among those that start in the same row
    head = np.flatnonzero(np.append(True, r0[1:] != r0[:-1]) if n else np.zeros(0, bool))
    in_row = np.arange(n) - np.repeat(head, np.diff(np.append(head, n)))
    lane = in_row % W
    starts = np.flatnonzero(lane == 0)
    chunk = np.cumsum(lane == 0) - 1
    run_row, run_len = r0[starts], length[starts]
    run_count = np.diff(np.append(starts, n)).astype(np.int64)
    size = (KNOT_ROW.KNOT + 2 * (run_len + 1)) * W
    run_offset = np.concatenate([[0], np.cumsum(size)[:-1]]).astype(np.int64)
    knot_data = np.zeros(int(size.sum()))
    tables.fill_runs(
        *kernel_args(q, tn, pos, radius, cubic, src, r0, length, chunk, lane, run_offset, knot_data)
    )
    return run_row, run_len, run_count, run_offset, knot_data


def _split(weight: NDArray[np.float64], n_threads: int) -> NDArray[np.int64]:
    """Edges of at most ``n_threads`` contiguous ranges of items of about equal total weight."""
    cum = np.concatenate([[0.0], np.cumsum(weight)])
    cuts = np.searchsorted(cum, cum[-1] * np.arange(1, max(n_threads, 1)) / n_threads)
    edges = np.unique(np.concatenate([[0], np.clip(cuts, 0, weight.size), [weight.size]]))
    return edges.astype(np.int64) if edges.size >= 2 else np.array([0, weight.size])


def _tasks(
    chunk_start: NDArray[np.int64], n_lo: int, n_hi: int, n_threads: int, cost: NDArray[np.float64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Split the chunks of rows n_lo..n_hi-1 in ``n_threads`` contiguous ranges
    of about equal cost (a chunk of row n costs ``cost[n]``); returns
    ``task_chunks (T, 2)`` and each task's first and last knot rows (T, 2)."""
    c_a = int(chunk_start[n_lo])
    rows = np.arange(n_lo, n_hi)
    edges = c_a + _split(np.repeat(cost[rows], np.diff(chunk_start)[rows]), n_threads)
    task = np.stack([edges[:-1], edges[1:]], axis=1)
    first = np.searchsorted(chunk_start, task[:, 0], side="right") - 1
    last = np.searchsorted(chunk_start, np.maximum(task[:, 1] - 1, task[:, 0]), side="right") - 1
    return task, np.stack(
        [np.clip(first, n_lo, n_hi - 1), np.clip(last, n_lo, n_hi - 1) + 1], axis=1
    )


def _run_tasks(
    run_row: NDArray[np.int64],
    run_len: NDArray[np.int64],
    run_count: NDArray[np.int64],
    n_lo: int,
    n_hi: int,
    n_threads: int,
    cost: NDArray[np.float64],
) -> NDArray[np.int64]:
    """Split the knot rows n_lo..n_hi in ``n_threads`` ranges of about equal
    cost (per row: the runs' lanes swept there, times ``cost[n]``); returns
    each task's first and last knot rows (T, 2) (the runs are cut there)."""
    n = cost.size + 1
    ends = np.minimum(run_row + run_len, cost.size)
    live = np.bincount(run_row, weights=run_count, minlength=n) - np.bincount(
        ends, weights=run_count, minlength=n
    )
    rows = np.arange(n_lo, n_hi)
    edges = n_lo + _split((np.cumsum(live)[:-1] * cost)[rows], n_threads)
    return np.stack([edges[:-1], edges[1:]], axis=1)


#: orientation table resolution (data seconds) and size cap
_ORIENT_DT = 1e-3
_ORIENT_MAX = 200_000


def _orientation_table(
    path: ListenerPath, tc: NDArray[np.float64], time_scale: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Forward/up (N, 6) sampled by slerp every ~1 ms of data time over the path."""
    span = float(tc[-1] - tc[0])
    n = int(min(max(np.ceil(span / _ORIENT_DT) + 1, 2), _ORIENT_MAX)) if span > 0 else 1
    tg = np.linspace(tc[0], tc[-1], n)
    fwd, up = path.orientation_at(path.times[0] + (tg - tc[0]) * time_scale)
    rate = (n - 1) / span if span > 0 else 0.0
    return np.ascontiguousarray(np.hstack([fwd, up])), np.array([tc[0], rate])


def prepare_render(
    tracks: SourceTracks,
    path: ListenerPath,
    *,
    rate: float,
    time_scale: float,
    c0: float,
    duration: float | None,
    bounds: tuple[float, ...] | None,
    start: float = 0.0,
    orientation: bool = True,
    lead: float = 0.0,
) -> _Prepared:
    if not (np.isfinite(rate) and rate > 0):
        raise ParameterError(f"rate must be a positive number of samples per second, got {rate!r}")
    if not (np.isfinite(time_scale) and time_scale > 0):
        raise ParameterError(f"time_scale must be > 0 (playback s per data s), got {time_scale!r}")
    if not (np.isfinite(c0) and c0 > 0):
        raise ParameterError(f"speed of sound c0 must be > 0 m/s, got {c0!r}")
    if not (np.isfinite(lead) and lead >= 0):
        raise ParameterError(f"lead must be >= 0 data seconds, got {lead!r}")
    if bounds is not None:
        check_distance(path, bounds)
    # collapse captures with equal times (the last one wins)
    keep = np.append(np.diff(path.times) > 0, True)
    ptimes, ppos = path.times[keep], path.positions[keep]
    t0 = tracks.t_first + lead
    tc = t0 + (ptimes - path.times[0]) / time_scale
    if tc.size >= 2:
        vc = np.diff(ppos, axis=0) / np.diff(tc)[:, None]
        speed = np.linalg.norm(vc, axis=1)
        if np.any(speed >= c0):
            i = int(np.argmax(speed))
            raise ListenerPathError(
                f"{path.source}: the listener moves at {speed[i]:.1f} m per data second between "
                f"captures {i} and {i + 1} (time_scale={time_scale:g}); synthesis needs it slower "
                f"than sound (c0={c0:g} m/s). Slow the path down or raise time_scale."
            )
    else:
        vc = np.zeros((0, 3))
    if not (np.isfinite(start) and start >= 0):
        raise ParameterError(f"start must be >= 0 playback seconds, got {start!r}")
    if duration is None:
        duration = path.duration - start
    if not (np.isfinite(duration) and duration > 0):
        raise ParameterError(
            f"nothing to render: duration {duration!r} s; give a path longer than one capture "
            f"or a positive duration"
        )
    n_samples = round(duration * rate)
    tn = knot_times(tracks)
    if orientation:
        otab, ot = _orientation_table(path, tc, time_scale)
    else:  # unpanned: the listener's orientation is not needed
        otab, ot = np.zeros((1, 6)), np.array([tc[0], 0.0])
    return _Prepared(
        knot_times=tn,
        capture_times=tc,
        capture_pos=np.ascontiguousarray(ppos),
        capture_vel=np.ascontiguousarray(vc),
        orient_table=otab,
        orient_clock=ot,
        t_start=t0 + start / time_scale,
        fs=float(rate) * time_scale,
        n_samples=int(n_samples),
    )


def source_extent(tracks: SourceTracks) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Bounding box of the source positions and the largest clamp radius (cached)."""
    key = (id(tracks.positions), id(tracks.radius))
    cached = tracks.cache.get("extent")
    if cached is not None and cached[0] == key:
        return cached[1]
    pos = np.asarray(tracks.positions, dtype=np.float64).reshape(-1, 3)
    if pos.shape[0] == 0:
        out = (np.zeros(3), np.zeros(3), 0.0)
    else:
        out = (pos.min(axis=0), pos.max(axis=0), float(np.max(tracks.radius, initial=1e-9)))
    tracks.cache["extent"] = (key, out)
    return out


def _audible_pieces(pr: _Prepared, tracks: SourceTracks, c0: float) -> tuple[int, int, float]:
    """Knot range [n_lo, n_hi] whose pieces can arrive inside the output window,
    and the largest source-listener distance D_max.

    Arrivals of piece n lie in [t_n, t_{n+1} + D_max/c0], D_max being the
    largest source-listener distance (the path is piecewise linear, so the
    farthest point of it is a capture).
    """
    if tracks.n_sources == 0:
        return 0, 0, 0.0
    lo_b, hi_b, r_max = source_extent(tracks)
    far = np.maximum(np.abs(pr.capture_pos - lo_b), np.abs(pr.capture_pos - hi_b))
    d_max = float(np.max(np.linalg.norm(far, axis=1))) + r_max
    t_end = pr.t_start + pr.n_samples / pr.fs
    tn = pr.knot_times
    n_lo = int(np.searchsorted(tn, pr.t_start - d_max / c0, side="left")) - 1
    n_hi = int(np.searchsorted(tn, t_end, side="right"))
    return max(n_lo, 0), min(n_hi, tn.size - 1), d_max


#: a listener farther from the data than this many times the data's diagonal
#: (and than :data:`MAX_DISTANCE_M`) is taken for a mistake
MAX_DISTANCE_FACTOR = 1e4
MAX_DISTANCE_M = 1e6


def box_distances(
    points: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nearest and farthest distance (m) from each of ``points (N, 3)`` to the box [lo, hi]."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    near = np.linalg.norm(np.maximum(np.maximum(lo - p, p - hi), 0.0), axis=1)
    far = np.linalg.norm(np.maximum(np.abs(p - lo), np.abs(p - hi)), axis=1)
    return near, far


def check_distance(path: ListenerPath, bounds: tuple[float, ...]) -> None:
    """Raise :class:`ListenerPathError` if the listener is absurdly far from the data.

    The listener may be anywhere (outside the grid is the usual far-field
    case); a capture farther from the grid's box than
    ``MAX_DISTANCE_FACTOR`` times its diagonal and than ``MAX_DISTANCE_M``
    metres is nonsense (a unit mistake, a stray coordinate).
    """
    b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
    near, _ = box_distances(path.positions, b[:, 0], b[:, 1])
    diag = float(np.linalg.norm(b[:, 1] - b[:, 0]))
    limit = max(MAX_DISTANCE_FACTOR * diag, MAX_DISTANCE_M)
    if np.any(near > limit):
        i = int(np.argmax(near))
        raise ListenerPathError(
            f"{path.source}: capture {i} at t={path.times[i]:g} s, position "
            f"{np.round(path.positions[i], 4).tolist()} is {near[i]:.4g} m from the grid "
            f"x[{b[0, 0]:g}, {b[0, 1]:g}] y[{b[1, 0]:g}, {b[1, 1]:g}] z[{b[2, 0]:g}, {b[2, 1]:g}]; "
            f"listeners must be within {limit:.4g} m of the data"
        )


def check_arrival(
    tracks: SourceTracks,
    path: ListenerPath,
    *,
    time_scale: float,
    duration: float | None = None,
    c0: float = C0,
    lead: float = 0.0,
) -> None:
    """Raise :class:`ListenerPathError` when no sound can reach the listener inside the
    output window (the data ends before the window starts, or the nearest sound
    arrives after it ends)."""
    pr = prepare_render(
        tracks,
        path,
        rate=1000.0,
        time_scale=time_scale,
        c0=c0,
        duration=duration,
        bounds=None,
        orientation=False,
        lead=lead,
    )
    source = path.source
    if tracks.n_sources == 0 or pr.n_samples == 0:
        return
    lo_b, hi_b, _ = source_extent(tracks)
    near, far = box_distances(pr.capture_pos, lo_b, hi_b)
    t_end = pr.t_start + pr.n_samples / pr.fs
    first = tracks.t_first + float(np.min(near)) / c0
    last = tracks.t_last + float(np.max(far)) / c0
    if first >= t_end or last < pr.t_start:
        raise ListenerPathError(
            f"{source}: nothing can be heard: sound from the data reaches the listener between "
            f"data times {first:.6g} and {last:.6g} s, the output covers {pr.t_start:.6g} .. "
            f"{t_end:.6g} s (nearest source {float(np.min(near)):.4g} m away at c0={c0:g} m/s); "
            f"move the listener closer, render longer, or use a smaller time scale"
        )


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


def _line_table(pr: _Prepared, c0: float) -> NDArray[np.float64]:
    """The listener's line on each capture interval j, at row j + 1 (M + 1, 9):
    its position at time tr, velocity, tr, c0² - V² and 1/(c0² - V²); held
    (V = 0) before the first capture and after the last."""
    m = pr.capture_times.size
    interval_lines = np.zeros((m + 1, 9))
    interval_lines[0, :3], interval_lines[0, 6] = pr.capture_pos[0], pr.capture_times[0]
    interval_lines[m, :3], interval_lines[m, 6] = pr.capture_pos[-1], pr.capture_times[-1]
    if m >= 2:
        interval_lines[1:m, :3], interval_lines[1:m, 3:6], interval_lines[1:m, 6] = (
            pr.capture_pos[:-1],
            pr.capture_vel,
            pr.capture_times[:-1],
        )
    interval_lines[:, 7] = c0 * c0 - np.sum(interval_lines[:, 3:6] ** 2, axis=1)
    interval_lines[:, 8] = 1.0 / interval_lines[:, 7]
    return interval_lines


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

    Parameters
    ----------
    tracks : SourceTracks
        From :meth:`auralize.sources.detection.SourceSeries.tracks`.
    path : ListenerPath
        Playback-time captures; the listener is held at the ends.
    rate : int
        Audio sample rate in Hz.
    time_scale : float
        Playback seconds per data second.
    interp : {"linear", "cubic"}
        Time interpolation of the strengths (§3.2.4.3).
    layout : str or Layout
        ``mono``, ``stereo``, ``ring8``, ``5.1``, ``7.1``, a JSON file, or
        ``ambix1..3`` (AmbiX encoding gains per piece); ``binaural`` is refused
        (it needs an output stage after the sum:
        :func:`auralize.emitters.timbre.render_timbre` applies it).
    duration : float, optional
        Playback seconds (default: the path's duration after ``start``).
    start : float
        Playback seconds into the path of the first output sample (block-wise
        and live rendering render consecutive blocks with increasing ``start``;
        the blocks join without seams).
    bounds : tuple, optional
        Grid bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)``; the listener may be
        anywhere, but one absurdly far from them raises
        :class:`ListenerPathError` (see :func:`check_distance`).
    lead : float
        Data seconds between the data's first step and the output's first
        sample (and the path's start): a far listener hears nothing before
        the nearest source's delay, so the output can start there.

    Returns
    -------
    Rendered
        ``audio`` of shape ``(n_channels, n_samples)`` in pascals.
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
    n_lo, n_hi, d_max = _audible_pieces(pr, tracks, c0)
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
        run_row, run_len, run_count, run_offset, knot_data = _runs(tracks, pr.knot_times, interp)
        some = bool(np.any((run_row < n_hi) & (run_row + run_len > n_lo)))
    else:
        chunk_start, chunk_count, piece_data = _pieces(tracks, pr.knot_times, interp)
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
            task_rows = task_chunks = _run_tasks(
                run_row, run_len, run_count, n_lo, n_hi, n_threads, cost
            )
        else:
            task_chunks, task_rows = _tasks(chunk_start, n_lo, n_hi, n_threads, cost)
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
            interval_lines = _line_table(pr, c0)
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
            # speaker pairs (every arc < 180°): gains in SIMD loops; AmbiX: every
            # channel gained (spherical harmonics)
            pairs = panned and pinv.shape[0] > 0 and pinv.shape[1] == 4 and not fold
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
    directly.
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
    tn, q, mt = _knots(tracks)
    for k in range(tracks.n_sources):
        d_vec = tracks.positions[k] - L
        D = np.maximum(np.linalg.norm(d_vec, axis=1), max(tracks.radius[k], 1e-9))
        tau = t - D / c0
        qv = _interp_knots(tn, q[k], mt[k], tau, interp)
        sig = qv / D
        if lay.n_channels == 1:
            out[0] += sig
        else:
            out += pan_gains(lay, listener_frame(d_vec, fwd, up)) * sig
    return out


def _interp_knots(
    tn: NDArray[np.float64],
    q: NDArray[np.float64],
    m: NDArray[np.float64],
    tau: NDArray[np.float64],
    interp: str,
) -> NDArray[np.float64]:
    inside = (tau >= tn[0]) & (tau <= tn[-1])
    n = np.clip(np.searchsorted(tn, tau, side="right") - 1, 0, tn.size - 2)
    h = tn[n + 1] - tn[n]
    s = np.clip((tau - tn[n]) / h, 0, 1)
    if interp == "linear":
        val = q[n] + (q[n + 1] - q[n]) * s
    else:
        s2, s3 = s * s, s * s * s
        val = (
            (2 * s3 - 3 * s2 + 1) * q[n]
            + (s3 - 2 * s2 + s) * m[n] * h
            + (-2 * s3 + 3 * s2) * q[n + 1]
            + (s3 - s2) * m[n + 1] * h
        )
    return np.where(inside, val, 0.0)
