"""Distributed synthesis: audio rendered in independent blocks, concatenated without seams.

:func:`auralize.synthesis.render` evaluates any block ``[start, start +
duration)`` of playback time on its own: the retarded-time look-back a block
needs (sources heard in it were emitted up to ``D_max / c0`` earlier) is
found inside ``render`` from the whole source tracks, which every task gets.
So blocks are independent tasks, and joined they equal the one-piece render
(to rounding, ~1e-12 relative; see ``tests/test_physics.py``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.scale.runner import Runner
from auralize.sources import SourceTracks
from auralize.synthesis import C0, Rendered, render


def render_block(tracks: SourceTracks, path: ListenerPath, a: int, b: int, rate: int,
                 kw: dict[str, Any], threads: int | None) -> np.ndarray:  # fmt: skip
    """Samples ``[a, b)`` of the rendering (one task)."""
    out = render(tracks, path, rate=rate, start=a / rate, duration=(b - a) / rate,
                 threads=threads or None, **kw)  # fmt: skip
    if out.audio.shape[1] != b - a:  # pragma: no cover - guards sample rounding
        raise ParameterError(f"block {a}:{b} rendered {out.audio.shape[1]} samples")
    return out.audio


def render_distributed(
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
    runner: Runner | None = None,
    scheduler: str = "sync",
    address: str | None = None,
    workers: int | None = None,
    log: Any = print,
) -> Rendered:
    """:func:`auralize.synthesis.render` split into blocks over Dask workers.

    Parameters
    ----------
    tracks, path, rate, time_scale, interp, layout, c0, duration, bounds
        As for :func:`auralize.synthesis.render`.
    block_seconds : float, optional
        Playback seconds per task (default: four blocks per worker).  Every
        block also pays for the retarded-time look-back it needs, so fewer,
        longer blocks do less work in all; more blocks balance better when
        the sound gets denser along the path.
    runner, scheduler, address, workers
        Where to run (see :class:`~auralize.scale.runner.Runner`).

    Returns
    -------
    Rendered
        ``audio (n_channels, n_samples)`` in pascals, equal to the one-piece
        render; ``meta["blocks"]`` is the number of tasks.

    Examples
    --------
    >>> from auralize.sources import SourceTracks
    >>> tr = SourceTracks(positions=np.zeros((1, 3)), q=np.ones((1, 4)), radius=np.ones(1),
    ...                   times=np.arange(4) / 30)
    >>> p = ListenerPath.point([5.0, 0, 0], duration=0.1)
    >>> render_distributed(tr, p, rate=8000, block_seconds=0.03, log=None).audio.shape
    (1, 800)
    """
    if duration is None:
        duration = path.duration
    if not (np.isfinite(duration) and duration > 0):
        raise ParameterError(f"nothing to render: duration {duration!r} s")
    if block_seconds is not None and not (np.isfinite(block_seconds) and block_seconds > 0):
        raise ParameterError(f"block_seconds must be > 0, got {block_seconds!r}")
    n = round(duration * rate)
    own = runner is None
    run = runner or Runner(scheduler, address=address, workers=workers, log=log)
    try:
        if own:
            run.__enter__()
        block = (round(block_seconds * rate) if block_seconds is not None
                 else -(-n // (4 * run.n_workers)))  # fmt: skip
        block = max(int(block), 1)
        edges = list(range(0, n, block)) + [n]
        kw: dict[str, Any] = {"time_scale": time_scale, "interp": interp, "layout": layout, "c0": c0,
              "bounds": bounds}  # fmt: skip
        # validate once on the caller (bad paths fail here, not in a worker) by
        # rendering one sample; every block, the first included, is a task
        first = render(tracks, path, rate=rate, start=0.0, duration=1.0 / rate, **kw)
        # each block goes into its place as it arrives (while the workers go on),
        # not concatenated at the end
        audio = np.empty((first.audio.shape[0], n), dtype=first.audio.dtype)
        # workers in other processes build their own caches (once per worker: the
        # shared tracks stay in its memory between its tasks); do not ship ours
        local = run.scheduler in ("sync", "threads")
        tr = run.share(tracks if local else dataclasses.replace(tracks, cache={}))
        pa = run.share(path)
        calls = [(render_block, (tr, pa, edges[i], edges[i + 1], rate, kw, run.threads_per_task))
                 for i in range(len(edges) - 1)]  # fmt: skip

        def got(i: int, block_audio: np.ndarray) -> None:
            audio[:, edges[i] : edges[i + 1]] = block_audio

        run.run(calls, got)
        n_workers = run.n_workers
    finally:
        if own:
            run.close()
    return Rendered(audio=audio, rate=int(rate), layout=first.layout, time_scale=float(time_scale),
                    meta={**first.meta, "blocks": len(edges) - 1, "workers": n_workers,
                          "scheduler": run.scheduler})  # fmt: skip
