"""The synthesis kernels' inputs built in Python: the layout's panning table, the
sounding pieces and their runs in chunks of lanes (built by compiled passes over the
strengths, cached on the tracks), and the split of the work into tasks of about equal
cost.  :mod:`auralize.emitters.synthesis` renders from them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.emitters._kernels import tables
from auralize.emitters._kernels.common import _CHUNK, KNOT_ROW
from auralize.errors import ParameterError
from auralize.runtime.jit import kernel_args
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import Layout, is_ambisonic, is_binaural, triangulate


def panning_arrays(lay: Layout) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The kernel's speaker azimuths and channels (:meth:`Layout.panning_arrays`);
    for an AmbiX layout one placeholder per channel (its gains come from the
    spherical-harmonic table of :func:`pan_table`).

    Parameters
    ----------
    lay : Layout
        A speaker, mono or AmbiX layout.

    Returns
    -------
    azimuths : ndarray, shape (S,)
        Speaker azimuths, rad in (-π, π], increasing, counter-clockwise from the
        listener's forward direction (empty for mono; zeros for AmbiX).
    channels : ndarray of int64, shape (S,)
        The output channel of each azimuth.

    Raises
    ------
    ParameterError
        For ``binaural``: render to :func:`auralize.spatial.layouts.synthesis_layout` and
        filter with :func:`auralize.spatial.layouts.output_stage` (as
        :func:`auralize.emitters.timbre.render_timbre` does).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters.synthesis import panning_arrays
    >>> from auralize.spatial.layouts import get_layout
    >>> az, ch = panning_arrays(get_layout("stereo"))
    >>> np.degrees(az).round(6).tolist(), ch.tolist()
    ([-30.0, 30.0], [1, 0])
    >>> [a.tolist() for a in panning_arrays(get_layout("ambix1"))]
    [[0.0, 0.0, 0.0, 0.0], [0, 1, 2, 3]]
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
    for an AmbiX layout (see :func:`auralize.emitters._kernels.gains._gains_sh`).

    Parameters
    ----------
    lay : Layout
        The output layout.
    spk_az : ndarray, shape (S,)
        Its speaker azimuths, rad, as :func:`panning_arrays` returns them.

    Returns
    -------
    ndarray
        Horizontal layout: ``(S, 4)``, row i the inverse (row-major) of the
        2 × 2 basis of the unit vectors of speakers i and i + 1, so that it
        maps a direction (x forward, y left) to the pair's gains; when one arc
        is wider than 180° instead ``(1, 7)``: that arc's first speaker and the
        unit vectors of its ends and middle; ``(0, 4)`` for fewer than two
        speakers.  With elevation: ``(R, 12)``, per triangle its inverse 3 × 3
        basis and channels, then the imaginary speakers' directions.  AmbiX of
        order n: ``((n + 1)², 2)``, per harmonic (ACN order) its SN3D factor
        and output channel (-1 when the layout leaves it out).

    Examples
    --------
    On ``ring8`` a direction halfway between the front (0°) and front-left
    (45°) speakers gets equal gains from row 3, the pair (0°, 45°):

    >>> import numpy as np
    >>> from auralize.emitters.synthesis import pan_table, panning_arrays
    >>> from auralize.spatial.layouts import get_layout
    >>> lay = get_layout("ring8")
    >>> az, ch = panning_arrays(lay)
    >>> tab = pan_table(lay, az)
    >>> tab.shape, np.degrees(az[3:5]).round(6).tolist()
    ((8, 4), [0.0, 45.0])
    >>> g = tab[3].reshape(2, 2) @ [np.cos(np.pi / 8), np.sin(np.pi / 8)]
    >>> bool(np.isclose(g[0], g[1]))
    True
    >>> pan_table(get_layout("ambix1"), np.zeros(4)).tolist()
    [[1.0, 0.0], [1.0, 1.0], [1.0, 2.0], [1.0, 3.0]]
    """
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
        return _pair_inverses(spk_az, fold=lay.fold_front)
    tri = triangulate(lay)
    rows = [
        np.concatenate([inv.reshape(9), ch.astype(np.float64)])
        for inv, ch in zip(tri.inverse, tri.channels, strict=True)
    ]
    for d, nb in zip(tri.imaginary_directions, tri.imaginary_neighbours, strict=True):
        mask = float(sum(1 << int(c) for c in nb))
        rows.append(np.concatenate([d, [mask], np.zeros(5), [-2.0, -2.0, -2.0]]))
    return np.ascontiguousarray(np.array(rows).reshape(-1, 12))


def _pair_inverses(spk_az: NDArray[np.float64], *, fold: bool = False) -> NDArray[np.float64]:
    """Inverse bases (n, 4) of adjacent speaker pairs for 2-D VBAP, or when a
    layout has an arc of 180° or more (then the kernel uses its angular law)
    the table of its arc wider than 180° (:func:`_wide_arc`).

    Two speakers both in front (forward components > 0) of a layout that folds
    rear directions to the front (``fold``, stereo) give their front pair alone
    (1, 4): every folded direction has a non-negative forward component, so
    the pair's two gains are never both negative, and with the negative one
    clamped to 0 the pair's law is the angular law's (2-D VBAP inside the pair,
    outside it the nearer speaker takes all; see
    :func:`auralize.emitters._kernels.gains._gains_plane`)."""
    n = spk_az.size
    if n < 2:
        return np.zeros((0, 4))
    a0 = spk_az
    a1 = np.roll(spk_az, -1)
    span = np.mod(a1 - a0, 2 * np.pi)
    front = fold and n == 2 and bool(np.all(np.cos(spk_az) > 0.0))
    if not front and (n < 3 or np.any(span >= np.pi - 1e-9) or np.any(span <= 1e-9)):
        return _wide_arc(spk_az, span)
    base = np.stack(
        [np.stack([np.cos(a0), np.cos(a1)], -1), np.stack([np.sin(a0), np.sin(a1)], -1)], 1
    )  # (n, 2, 2)
    inv = np.linalg.inv(base).reshape(n, 4)
    return np.ascontiguousarray(inv[:1] if front else inv)


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


def sounding_pieces(
    tracks: SourceTracks, tn: NDArray[np.float64], interp: str
) -> tuple[NDArray[Any], ...]:
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
    """``build()``, cached on the tracks under ``name`` while their arrays are the same.

    The cache (``tracks.cache``) is keyed by the identity of the tracks' ``q``,
    ``times`` and ``positions`` arrays, the shape of ``q`` and ``interp``: block-wise
    and live rendering call the synthesis many times with the same tracks and
    build their tables once.

    Parameters
    ----------
    tracks : SourceTracks
        The tracks whose ``cache`` holds the result.
    name : str
        The cache entry.
    interp : str
        The interpolation the result depends on (part of the key).
    build : callable
        ``build()`` makes the result when it is not cached.

    Returns
    -------
    object
        What ``build()`` returned, now or on an earlier call with the same arrays.

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.emitters.synthesis import cached_on_tracks
    >>> from auralize.sources.detection import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 2)),
    ...                   radius=np.full(1, 0.1), times=np.arange(2.0))
    >>> calls = []
    >>> def build():
    ...     calls.append(1)
    ...     return len(calls)
    >>> cached_on_tracks(tr, "n", "cubic", build), cached_on_tracks(tr, "n", "cubic", build)
    (1, 1)
    >>> cached_on_tracks(tr, "n", "linear", build)  # another key: built again
    2
    """
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


def sounding_runs(
    tracks: SourceTracks, tn: NDArray[np.float64], interp: str
) -> tuple[NDArray[Any], ...]:
    """The runs of sounding pieces in chunks, for unpanned layouts:
    ``(run_row, run_len, run_count, run_offset, knot_data)`` (cached on the tracks; see
    :func:`auralize.emitters._kernels.render_runs.render_task`).

    A run is a maximal stretch of consecutive sounding pieces of a source
    (the same pieces as :func:`sounding_pieces`).  Runs that start in the same row,
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


def piece_tasks(
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


def run_tasks(
    run_row: NDArray[np.int64],
    run_len: NDArray[np.int64],
    run_count: NDArray[np.int64],
    n_lo: int,
    n_hi: int,
    *,
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
