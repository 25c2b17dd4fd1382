"""Out-of-core and distributed preprocessing on Dask.

The same pipeline, on a laptop, a workstation or a cluster:

* :mod:`auralize.distributed.chunked` — lazy chunked volumes (Dask arrays, one
  time step per chunk; z-slabs with ghost planes);
* :mod:`auralize.distributed.detect` — distributed, resumable detection,
  bit-identical to :func:`auralize.sources.detection.detect`;
* :mod:`auralize.distributed.synth` — synthesis in independent blocks;
* :mod:`auralize.distributed.runner` — schedulers (sync, threads, processes,
  distributed, ``--address``, local clusters);
* :mod:`auralize.distributed.bigdata` — the chunked big-data explosion recipe.

Dask is optional (``pip install "auralize[dask]"``): ``import auralize`` and
``import auralize.distributed`` do not import it; the functions that need it raise
:class:`~auralize.errors.MissingDependencyError` with the install command.
"""

from __future__ import annotations

from auralize.distributed.bigdata import AnalyticExplosion, write_chunked_explosion
from auralize.distributed.chunked import (
    DaskFrames,
    SlabFrames,
    chunked_volume,
    slab_volume,
    to_dask,
    volume_from_dask,
)
from auralize.distributed.detect import (
    H5Frames,
    StateStore,
    detect_distributed,
    plan_chunks,
    plan_slabs,
)
from auralize.distributed.runner import SCHEDULERS, RunError, Runner, SchedulerError
from auralize.distributed.synth import render_distributed

__all__ = [
    "SCHEDULERS",
    "AnalyticExplosion",
    "DaskFrames",
    "H5Frames",
    "RunError",
    "Runner",
    "SchedulerError",
    "SlabFrames",
    "StateStore",
    "chunked_volume",
    "detect_distributed",
    "plan_chunks",
    "plan_slabs",
    "render_distributed",
    "slab_volume",
    "to_dask",
    "volume_from_dask",
    "write_chunked_explosion",
]
