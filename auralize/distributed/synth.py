"""Distributed synthesis: tasks over audio blocks and source groups, joined without seams.

The pressure heard is a sum over sources (paper 003, §3.2.4, Eq. 9), so the
work splits two ways, and every task is one (block, source group) pair:

* **source groups**: ranges of the tracks' sources, balanced by how often
  they sound.  Each group's tracks go to the workers once (not to every
  worker) and each worker builds the piece list of its groups only, so that
  preparation, too, is divided between the workers.  On worker processes a
  group is :data:`STRIPES` interleaved ranges (stripes) rather than one: the
  cost of a sounding piece depends on where its source is (near the
  listener its panning pair changes more often), and contiguous ranges of a
  volume's vertices are slabs of space, so contiguous groups of equal weight
  differ in cost (by up to a third on 60 s of ring8 from the 256³
  explosion, four groups).  The
  audio of a block is the sum of its groups' renders, added in group order
  (the result does not depend on which task finishes first).
* **blocks** of playback time: :func:`auralize.emitters.synthesis.render_tracks` evaluates
  any block ``[start, start + duration)`` on its own; the retarded-time
  look-back a block needs (sources heard in it were emitted up to
  ``D_max / c0`` earlier) is found inside ``render`` from the whole tracks.
  Joined, blocks equal the one-piece render (to rounding, ~1e-12 relative;
  see ``tests/test_physics.py``).  Each block pays for its own look-back.

:func:`plan_tasks` picks the default split between the two.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.distributed.runner import Runner, numba_threads
from auralize.emitters.synthesis import C0, INTERPOLATIONS, Rendered, prepare_render, render_tracks
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.sources.detection import SourceTracks
from auralize.spatial.layouts import get_layout, output_stage

#: default block length: at most this many samples × channels per task (its
#: accumulator takes 32 bytes per value: 1 GiB)
BLOCK_VALUES = 1 << 25
#: knot columns sampled per source to weigh the groups (how often it sounds)
WEIGHT_COLUMNS = 16
#: sounding pieces that make a source group worth its own pass over the samples
PIECES_PER_GROUP = 2_000_000
#: interleaved ranges per source group when the groups travel to worker processes
STRIPES = 8


def render_block(  # noqa: PLR0917 (a Dask task: its arguments travel as one tuple)
    tracks: SourceTracks | PackedTracks,
    path: ListenerPath,
    a: int,
    b: int,
    rate: int,
    kw: dict[str, Any],
    threads: int | None,
) -> np.ndarray:
    """Samples ``[a, b)`` of the rendering of ``tracks`` (one task)."""
    if isinstance(tracks, PackedTracks):
        tracks = tracks.tracks()
    # (all the kernel's parallel loops on the task's threads: a worker's other
    # cores belong to other workers)
    with numba_threads(threads):
        out = render_tracks(
            tracks,
            path,
            rate=rate,
            start=a / rate,
            duration=(b - a) / rate,
            threads=threads or None,
            **kw,
        )
    if out.audio.shape[1] != b - a:  # pragma: no cover - guards sample rounding
        raise ParameterError(f"block {a}:{b} rendered {out.audio.shape[1]} samples")
    return out.audio


def _sounding(tracks: SourceTracks) -> NDArray[np.float64]:
    """Per source, about how many of its knots sound (non-zero strengths in
    :data:`WEIGHT_COLUMNS` sampled knot columns, scaled up); cached."""
    key = (id(tracks.q), tracks.q.shape)
    cached = tracks.cache.get("sounding")
    if cached is not None and cached[0] == key:
        return cached[1]
    q = np.asarray(tracks.q)
    if q.ndim != 2 or q.shape[1] == 0:
        out = np.zeros(tracks.n_sources)
    else:
        step = max(1, -(-q.shape[1] // WEIGHT_COLUMNS))
        out = np.count_nonzero(q[:, ::step], axis=1).astype(np.float64) * step
    tracks.cache["sounding"] = (key, out)
    return out


def source_groups(
    tracks: SourceTracks, n_groups: int, stripes: int = 1
) -> list[list[tuple[int, int]]]:
    """Split the sources in ≤ ``n_groups`` groups of about equal work, each
    ``stripes`` contiguous ranges ``(a, b)``: weighted by the non-zero
    strengths in :data:`WEIGHT_COLUMNS` sampled knot columns (the kernel's
    cost grows with the sounding pieces), the sources are cut in
    ``n_groups × stripes`` ranges of equal weight and group g takes ranges
    g, g + n_groups, g + 2·n_groups, … (so each group samples the whole
    volume).  Groups and ranges are never empty; no sources give no group."""
    k = tracks.n_sources
    if k == 0:
        return []
    n_groups = max(1, min(int(n_groups), k))
    stripes = max(1, min(int(stripes), k // n_groups))
    n = n_groups * stripes
    cum = np.cumsum(_sounding(tracks) + 1e-3)
    cuts = np.searchsorted(cum, cum[-1] * np.arange(1, n) / n, side="left") + 1
    edges = np.unique(np.concatenate([[0], np.clip(cuts, 1, k - 1) if k > 1 else [], [k]]))
    ranges = [(int(a), int(b)) for a, b in itertools.pairwise(edges)]
    # (cuts falling on the same source merge: then fewer ranges, or groups)
    n_groups = min(n_groups, len(ranges))
    return [ranges[g::n_groups] for g in range(n_groups)]


def plan_tasks(
    tracks: SourceTracks, n_samples: int, n_channels: int, n_workers: int, groups: int | None = None
) -> tuple[int, int]:
    """Default split of a rendering: ``(block_samples, groups)``.

    A source group's task costs its sounding pieces plus the whole block's
    samples (accumulator, integration, the result's trip back), whatever its
    size; a block costs its samples plus its look-back pieces.  So: one group
    per :data:`PIECES_PER_GROUP` sounding pieces (estimated from the
    non-zero strengths), at most two per worker, and the remaining
    parallelism (two tasks per worker in all) from blocks; blocks of at most
    :data:`BLOCK_VALUES` samples × channels.  Given ``groups``, only the
    blocks are planned.
    """
    n_samples = max(int(n_samples), 1)
    want = 2 * max(int(n_workers), 1)
    if groups is None:
        pieces = float(np.sum(_sounding(tracks)))
        groups = int(min(want, max(1, pieces // PIECES_PER_GROUP), max(tracks.n_sources, 1)))
    groups = max(int(groups), 1)
    blocks = -(-want // groups)
    cap = max(BLOCK_VALUES // max(int(n_channels), 1), 1)
    blocks = max(blocks, -(-n_samples // cap))
    return -(-n_samples // blocks), groups


def _subset(tracks: SourceTracks, a: int, b: int) -> SourceTracks:
    """Sources ``a … b-1`` (views of the arrays: no copy, nothing cached)."""
    return SourceTracks(
        positions=tracks.positions[a:b],
        q=tracks.q[a:b],
        radius=tracks.radius[a:b],
        times=tracks.times,
        index=None if tracks.index is None else tracks.index[a:b],
        origin=tracks.origin,
        end=tracks.end,
    )


class PackedTracks:
    """Source tracks as they travel to a worker: the strengths ``q`` as their
    non-zero entries only (a volume's vertices sound a small part of the time:
    the 256³ explosion's q is 95 % zeros, 2.5 GB dense, 0.2 GB packed).

    :meth:`tracks` unpacks them once per process and keeps the result (and so
    the piece list the synthesis caches on it) for the worker's later tasks;
    pickling sends only the packed arrays.
    """

    def __init__(self, tracks: SourceTracks, ranges: list[tuple[int, int]] | None = None) -> None:
        """Pack ``tracks``, or only its sources in ``ranges`` (in that order)."""
        if ranges is None:
            ranges = [(0, tracks.n_sources)]
        parts = [_subset(tracks, a, b) for a, b in ranges]
        T = np.shape(tracks.q)[1] if np.ndim(tracks.q) == 2 else 0
        n = sum(b - a for a, b in ranges)
        self.shape = (n, T)
        flats, values, row = [], [], 0
        for p in parts:
            q = np.ascontiguousarray(p.q, dtype=np.float64)
            f = np.flatnonzero(q)
            values.append(q.ravel()[f])
            flats.append(f + row * T)
            row += q.shape[0]
        flat = np.concatenate(flats) if flats else np.zeros(0, dtype=np.int64)
        self.flat = flat.astype(np.uint32) if n * T < (1 << 32) else flat
        self.values = np.concatenate(values) if values else np.zeros(0)
        self.positions = np.ascontiguousarray(
            np.concatenate([np.asarray(p.positions, dtype=np.float64) for p in parts])
        )
        self.radius = np.ascontiguousarray(
            np.concatenate([np.asarray(p.radius, dtype=np.float64) for p in parts])
        )
        self.times = np.ascontiguousarray(tracks.times, dtype=np.float64)
        self.index = None if tracks.index is None else np.concatenate([p.index for p in parts])
        self.origin, self.end = tracks.origin, tracks.end
        self._tracks: SourceTracks | None = None

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k != "_tracks"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._tracks = None

    def tracks(self) -> SourceTracks:
        """The tracks (unpacked on first use in this process, then reused)."""
        if self._tracks is None:
            q = np.zeros(self.shape)
            q.ravel()[self.flat] = self.values
            self._tracks = SourceTracks(
                positions=self.positions,
                q=q,
                radius=self.radius,
                times=self.times,
                index=self.index,
                origin=self.origin,
                end=self.end,
            )
        return self._tracks


def render_distributed(  # noqa: PLR0913 (keyword-only options)
    tracks: SourceTracks,
    path: ListenerPath,
    *,
    rate: int = 44100,
    time_scale: float = 1.0,
    interp: str = "cubic",
    layout: str = "mono",
    c0: float = C0,
    duration: float | None = None,
    bounds: tuple[float, ...] | None = None,
    block_seconds: float | None = None,
    groups: int | None = None,
    runner: Runner | None = None,
    scheduler: str = "sync",
    address: str | None = None,
    workers: int | None = None,
    log: Any = print,
    lead: float = 0.0,
) -> Rendered:
    """:func:`auralize.emitters.synthesis.render_tracks` split into (block, source group) tasks over Dask workers.

    Parameters
    ----------
    tracks, path, rate, time_scale, interp, layout, c0, duration, bounds, lead
        As for :func:`auralize.emitters.synthesis.render_tracks`.
    block_seconds : float, optional
        Playback seconds per block.  Every block pays for the retarded-time
        look-back it needs, so fewer, longer blocks do less work in all.
    groups : int, optional
        Source groups.  Each group's tracks are sent to the workers once and
        its piece list is built by the workers that render it; each group's
        task passes over all the block's samples.  Defaults for both from
        :func:`plan_tasks`: groups for many sounding pieces, blocks for long
        outputs and few pieces, two tasks per worker.
    runner, scheduler, address, workers
        Where to run (see :class:`~auralize.distributed.runner.Runner`).

    Returns
    -------
    Rendered
        ``audio (n_channels, n_samples)`` in pascals, equal to the one-piece
        render (to rounding); ``meta["blocks"]``, ``meta["groups"]`` and
        ``meta["tasks"]`` say how it was split.

    Examples
    --------
    >>> tr = SourceTracks(positions=np.zeros((3, 3)), q=np.ones((3, 4)), radius=np.ones(3),
    ...                   times=np.arange(4) / 30)
    >>> p = ListenerPath.point([5.0, 0, 0], duration=0.1)
    >>> out = render_distributed(tr, p, rate=8000, block_seconds=0.03, groups=2, log=None)
    >>> out.audio.shape, out.meta["blocks"], out.meta["groups"]
    ((1, 800), 4, 2)
    """
    if duration is None:
        duration = path.duration
    if not (np.isfinite(duration) and duration > 0):
        raise ParameterError(f"nothing to render: duration {duration!r} s")
    if block_seconds is not None and not (np.isfinite(block_seconds) and block_seconds > 0):
        raise ParameterError(f"block_seconds must be > 0, got {block_seconds!r}")
    if groups is not None and (not isinstance(groups, int | np.integer) or groups < 1):
        raise ParameterError(f"groups must be a positive integer, got {groups!r}")
    if interp not in INTERPOLATIONS:
        raise ParameterError(f"interp must be one of {INTERPOLATIONS}, got {interp!r}")
    stage = output_stage(get_layout(layout), int(rate))  # binaural: ears after the sum
    lay = stage.synthesis_layout
    # validate here (a bad path or setting fails on the caller, not in a
    # worker), without rendering: the workers build the piece lists
    pr = prepare_render(
        tracks,
        path,
        rate=rate,
        time_scale=time_scale,
        c0=c0,
        duration=duration,
        bounds=bounds,
        orientation=False,
        lead=lead,
    )
    n = pr.n_samples
    audio = np.zeros((lay.n_channels, n))
    own = runner is None
    run = runner or Runner(scheduler, address=address, workers=workers, log=log)
    try:
        if own:
            run.__enter__()
        auto_block, groups = plan_tasks(tracks, n, lay.n_channels, run.n_workers, groups)
        block = max(round(block_seconds * rate), 1) if block_seconds is not None else auto_block
        edges = list(range(0, n, block)) + [n]
        # each group's tracks go to the cluster once (not to every worker),
        # packed when they leave this process; a worker keeps them, and their
        # piece list, between its tasks.  (In this process a group is one
        # range, passed as views: no copy.)
        local = run.scheduler in ("sync", "threads")
        ranges = source_groups(tracks, groups, 1 if local else STRIPES)
        kw: dict[str, Any] = {
            "time_scale": time_scale,
            "interp": interp,
            "layout": lay,
            "c0": c0,
            "bounds": bounds,
            "lead": lead,
        }
        pa = run.share(path)
        n_blocks = len(edges) - 1

        def calls() -> Iterator[tuple[Any, tuple[Any, ...]]]:
            """Group by group: packed, sent, its blocks submitted (the workers
            start on the first groups while the next are being packed)."""
            packed = (_subset(tracks, *r[0]) if local else PackedTracks(tracks, r) for r in ranges)
            for part in run.place_each(packed):
                for i in range(n_blocks):
                    yield (
                        render_block,
                        (part, pa, edges[i], edges[i + 1], rate, kw, run.threads_per_task),
                    )

        # a block's groups are added in group order as they come in (the sum
        # does not depend on which task finishes first), then dropped
        held: dict[int, dict[int, NDArray[np.float64]]] = {}
        added = [0] * n_blocks

        def got(k: int, part: NDArray[np.float64]) -> None:
            g, i = divmod(k, n_blocks)
            held.setdefault(i, {})[g] = part
            wait = held[i]
            while added[i] in wait:
                audio[:, edges[i] : edges[i + 1]] += wait.pop(added[i])
                added[i] += 1
            if not wait:
                del held[i]

        run.run(calls(), got)
        n_workers = run.n_workers
    finally:
        if own:
            run.close()
    out = Rendered(
        audio=audio,
        rate=int(rate),
        layout=lay,
        time_scale=float(time_scale),
        meta={
            "interp": interp,
            "c0": c0,
            "n_sources": tracks.n_sources,
            "t_start_data": pr.t_start,
            "blocks": len(edges) - 1,
            "groups": len(ranges),
            "tasks": n_blocks * len(ranges),
            "workers": n_workers,
            "scheduler": run.scheduler,
        },
    )
    return stage.finish(out)
