"""Compile the numba kernels ahead, so that the first real command runs at full speed.

The kernels are compiled on first use and kept in one cache folder
(:func:`auralize.runtime.jit.cache_dir`: ``NUMBA_CACHE_DIR``, else
``~/.cache/auralize/numba``).  From a cold cache the synthesis kernels take
minutes of one core (the piece-wise synthesis kernel is one large parallel
function with its helpers inlined), and numba compiles a function on one
core.  :func:`warmup` therefore compiles independent kernel groups
(:data:`GROUPS`) in parallel worker processes, one group per process (at
most two processes, or the core count if smaller), each by running tiny
renders through the public entry points (the pipeline, the synthesis and the
emitters engine), so that exactly the specializations the commands use are
compiled and cached.  A group's progress line is printed as it finishes.  The processes share the on-disk
cache safely: numba keeps each function in its own index and data files,
written to a temporary name and renamed; two processes that compile the same
helper both write the same one signature (each kernel has one, see
:func:`auralize.runtime.jit.kernel_args`).

``scripts/install.sh`` runs it (``auralize warmup``) as a visible step; a
warm cache makes it take a few seconds.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np

#: kernel groups compiled by one worker process each, the longest first (a
#: process that starts first ends last); each names the kernels it compiles
GROUPS: dict[str, str] = {
    "panned": "piece-wise synthesis (stereo, 5.1, ring8, ...): _kernels.render_pieces.render",
    "mono": "detection, field sources, run-sweep synthesis (mono, AmbiX): _kernels.render_runs.render",
    "emitters": "the emitters engine (every sound model): _sampled._render",
}
#: compiled with ``plugins=True``
PLUGIN_GROUPS: dict[str, str] = {"plugins": "the sound-model plugins' kernels (their warm_up)"}


def warmup(*, plugins: bool = False, processes: int | None = None,
           progress: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:  # fmt: skip
    """Compile (or load from the cache) the kernels of the core pipeline.

    Parameters
    ----------
    plugins : bool
        Also the kernels of the shipped sound-model plugins (fire, spark,
        vortex), through their smallest runs.
    processes : int, optional
        Worker processes (default ``min(2, os.cpu_count())``); 1 compiles the
        groups one after the other in this process.
    progress : callable, optional
        Called with each group's result (as in ``groups`` below) when it is ready.

    Returns
    -------
    dict
        ``seconds`` (wall time), ``compiled`` (list of ``(kernel, seconds)``
        compiled in this call; empty when the cache was warm), ``cache``
        (folder), ``processes`` and ``groups`` (per group: ``group``,
        ``seconds``, ``cpu_seconds`` of its process, ``compiled``).
    """
    from auralize.runtime.jit import cache_dir, configure

    configure()
    names = list(GROUPS) + (list(PLUGIN_GROUPS) if plugins else [])
    n_proc = min(2, os.cpu_count() or 1) if processes is None else int(processes)
    n_proc = max(1, min(n_proc, len(names)))
    t0 = time.perf_counter()
    done: list[dict[str, Any]] = []

    def finished(res: dict[str, Any]) -> None:
        done.append(res)
        if progress is not None:
            progress(res)

    if n_proc == 1:
        for name in names:
            finished(compile_group(name))
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        # spawn: a fresh interpreter, no numba state or threads inherited
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(n_proc, mp_context=ctx, initializer=_quiet_worker) as pool:
            futures = [pool.submit(compile_group, name) for name in names]
            try:
                for fut in as_completed(futures):
                    finished(fut.result())
            except BaseException:  # a group failed: start no other
                for fut in futures:
                    fut.cancel()
                raise
    order = {n: i for i, n in enumerate(names)}
    done.sort(key=lambda r: order[r["group"]])
    return {
        "seconds": time.perf_counter() - t0,
        "compiled": [c for r in done for c in r["compiled"]],
        "cache": str(cache_dir()),
        "processes": n_proc,
        "groups": done,
    }


def _quiet_worker() -> None:
    """Worker set-up: the parent reports progress; the workers' compile notices would
    repeat it, interleaved."""
    import logging

    logging.getLogger("auralize").setLevel(logging.ERROR)


def compile_group(name: str) -> dict[str, Any]:
    """Compile (or load) the kernels of group ``name`` of :data:`GROUPS` or
    :data:`PLUGIN_GROUPS` in this process: ``{"group", "seconds", "cpu_seconds", "compiled"}``."""
    from auralize.runtime.jit import compiled_kernels, configure

    configure()
    before = len(compiled_kernels())
    t0, c0 = time.perf_counter(), time.process_time()
    _RUNS[name]()
    return {"group": name, "seconds": time.perf_counter() - t0,
            "cpu_seconds": time.process_time() - c0,
            "compiled": compiled_kernels()[before:]}  # fmt: skip


def _scene() -> tuple[Any, ...]:
    """A tiny volume, an orbit and a point listener path near it."""
    from auralize.datasets.synthetic import make_dataset
    from auralize.listener import ListenerPath

    vol = make_dataset("explosion", size=12, steps=4, seed=0).load()
    centre = np.asarray(vol.center, dtype=np.float64)
    path = ListenerPath.orbit(centre, radius=3.0, duration=0.05, turns=0.1)
    point = ListenerPath.point(centre + 2.0, duration=0.05)
    return vol, centre, path, point


def _warm_panned() -> None:
    # the piece-wise kernel alone (no detection: the "mono" group compiles it), through
    # synthesis.render_tracks, whose kernel_args give every caller this one specialization
    from auralize.emitters.synthesis import render_tracks
    from auralize.listener import ListenerPath
    from auralize.sources.detection import SourceTracks

    t = np.linspace(0.0, 0.1, 5)
    tracks = SourceTracks(np.array([[2.0, 0.0, 0.0], [0.0, 3.0, 1.0]]),
                          np.sin(30.0 * t)[None].repeat(2, axis=0), np.full(2, 0.05), t)  # fmt: skip
    path = ListenerPath.orbit((0.0, 0.0, 0.0), radius=0.5, duration=0.1, turns=0.1)
    for layout in ("ring8", "5.1"):
        render_tracks(tracks, path, rate=8000, layout=layout, time_scale=1.0)


def _warm_mono() -> None:
    from auralize.pipeline import auralize, detect_sources

    vol, _, _, point = _scene()
    series = detect_sources(vol)
    # the run-sweep kernel (a still listener: a moving one, whose captures the arrivals
    # cross, takes the piece-wise kernel of the "panned" group)
    for heard in ("field", "detected"):
        auralize(vol, point, layout="mono", series=series, rate=8000, time_scale=1.0,
                 timbre="physical", heard=heard)  # fmt: skip


def _warm_emitters() -> None:
    # the emitters engine's sampled kernel: one specialization serves every layout, rate
    # and dtype (auralize.runtime.jit.kernel_args)
    from auralize.emitters import Emitters
    from auralize.emitters.engine import render_emitters
    from auralize.listener import ListenerPath

    point = ListenerPath.point((2.0, 2.0, 2.0), duration=0.05)
    render_emitters(Emitters(np.ones((1, 80)), 8000, np.zeros((1, 3))), point, rate=8000)


def _warm_plugins() -> None:
    """Every registered sound model's :meth:`~auralize.plugins.SoundModel.warm_up`."""
    from auralize.plugins import registry

    for cls in registry().values():
        cls().warm_up()


_RUNS: dict[str, Callable[[], None]] = {
    "panned": _warm_panned,
    "mono": _warm_mono,
    "emitters": _warm_emitters,
    "plugins": _warm_plugins,
}
