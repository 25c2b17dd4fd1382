"""What a Dask worker process does once when it starts, before it runs any task.

A fresh worker process pays two costs that have nothing to do with the size
of the work it is given, and that a long-running cluster pays only once:

* **Loading the numba kernels.**  The detection and synthesis kernels are
  compiled ahead (``cache=True``), but every new process still loads them
  from the cache and starts numba's threading layer: ~0.5 s per process
  measured on the 2-core bench machine (many seconds when the kernel sources
  changed and the cache must be rebuilt).  :func:`warm_kernels` runs a tiny
  detection and a tiny synthesis so that this happens when the worker joins
  the cluster, not inside the first task of a run.
* **The allocator.**  ``distributed``'s nanny starts workers with
  ``MALLOC_TRIM_THRESHOLD_=65536``.  Setting any glibc malloc threshold
  turns off glibc's dynamic mmap threshold, so every array above 128 KiB is
  a fresh ``mmap``: each task's frame-sized temporaries (read, ``10**x``,
  gradients, strengths) page-fault and are zeroed by the kernel again on
  every use.  Measured on the detection tasks of a 48³ volume: 2.5-3× slower
  than the same calls in a normal process.  :func:`tune_allocator` gives the
  worker the settings of any auralize process
  (:func:`auralize.runtime.allocator.tune`, forced over the nanny's), so a
  worker computes as fast as a serial run, and its resident memory still
  falls back after a task.

:class:`WorkerSetup` is a ``distributed`` worker plugin doing both; the
:class:`~auralize.distributed.runner.Runner` registers it on every cluster it
connects to or starts (also on workers that join later, e.g. replacements
of a worker that died).
"""

from __future__ import annotations

import asyncio
import os
import time
from typing import Any


def tune_allocator() -> bool:
    """This worker's allocator set as in any auralize process, over the nanny's
    environment setting (False: not glibc, or ``AURALIZE_MALLOC_TUNING=0``)."""
    from auralize.runtime.allocator import tune

    return tune(force=True) == "tuned"


def warm_kernels() -> dict[str, Any]:
    """Load the readers and the detection and synthesis kernels (a tiny detection and render).

    Returns what was done and how long it took (``seconds``); a failure is
    reported (``error``), not raised: a worker that could not warm up still
    runs tasks, it just loads the kernels in its first one.
    """
    t0 = time.perf_counter()
    done: dict[str, Any] = {"pid": os.getpid()}
    try:
        import numpy as np

        import auralize.io
        import auralize.io.hdf5  # noqa: F401
        from auralize.datasets.synthetic import make_monopole
        from auralize.distributed.runner import numba_threads
        from auralize.emitters.synthesis import render_tracks
        from auralize.listener import ListenerPath
        from auralize.sources.detection import Thresholds, detect

        with numba_threads(1):
            vol = make_monopole(size=8, steps=3)
            series = detect(vol, mapping="identity", thresholds=Thresholds(0.0, 0.0, 0.0))
            tracks = series.tracks()
            path = ListenerPath.point(np.full(3, 2.0), duration=0.01)
            render_tracks(tracks, path, rate=8000, layout="ring8", time_scale=1.0, threads=1)
        done["kernels"] = True
    except Exception as exc:
        done["error"] = f"{type(exc).__name__}: {exc}"
    done["seconds"] = time.perf_counter() - t0
    return done


def setup_worker() -> dict[str, Any]:
    """Allocator and kernels of this worker process (see the module docstring)."""
    out = {"allocator": tune_allocator()}
    out.update(warm_kernels())
    return out


try:  # the plugin base class; this module is also usable without distributed
    from distributed.diagnostics.plugin import WorkerPlugin as _Base
except ImportError:  # pragma: no cover - distributed is not installed
    _Base = object


class WorkerSetup(_Base):  # type: ignore[misc,valid-type]
    """``distributed`` worker plugin: :func:`setup_worker` once per worker process.

    The set-up runs in a thread, so the worker keeps answering the
    scheduler's heartbeats while the kernels load; its result is kept in
    ``report``.
    """

    name = "auralize-worker-setup"
    idempotent = True

    def __init__(self) -> None:
        self.report: dict[str, Any] = {}

    async def setup(self, worker: Any) -> None:
        loop = asyncio.get_running_loop()
        self.report = await loop.run_in_executor(None, setup_worker)


def setup_report(dask_worker: Any = None) -> dict[str, Any]:
    """What :class:`WorkerSetup` reported on this worker (for ``Client.run``)."""
    plug = None if dask_worker is None else dask_worker.plugins.get(WorkerSetup.name)
    return dict(getattr(plug, "report", {}) or {"pid": os.getpid(), "missing": True})
