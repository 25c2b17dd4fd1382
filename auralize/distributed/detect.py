"""Distributed, resumable source detection (same results as :func:`auralize.sources.detection.detect`).

The work is cut into tasks of ``chunk_steps`` consecutive time steps × one
z-slab of the grid:

* **time borders** — the strengths of step n are time derivatives over
  steps n-1 and n+1 (one-sided at the first and last step), so a task on steps
  ``[a, b)`` reads steps ``a-1 … b`` (clamped to the series): one ghost step
  on each side, like ``map_overlap`` with depth 1 along time and no boundary
  padding.  Inside a task, each frame is read and mapped once.
* **space borders** — a slab keeps planes ``[z0, z1)`` and reads
  ``g = r + 2`` ghost planes on each side, ``r`` being the reach of the
  acoustic mapping's stencil (1 for ``paper-density``'s gradient, 0 for the
  point-wise ``identity`` and ``cfd``): strengths need the mapped fields one
  plane further, the ΔV radius needs the strengths of the neighbouring
  plane.  Mappings of unknown reach run on whole frames.

Every vertex is computed by the same code on the same numbers as in the
serial :func:`~auralize.sources.detection.detect`, so the sources are bit-identical,
whatever the scheduler, chunking or slabbing.  Relative thresholds use the
series' peak strengths over the same sample steps as
:func:`~auralize.sources.detection.peak_strengths` (computed by tasks too); the
``paper-density`` mapping's series-wide range and gradient scale are gathered
by tasks as well (minima and maxima are exact in any order).

**Resuming.**  With an ``output`` file, finished time chunks are written as
they complete to ``OUTPUT.parts/`` — a chunked sources store: one ``.npz``
per finished chunk of steps (written atomically; its existence is the
per-step "done" record) plus ``manifest.json`` with the settings, the
resolved thresholds and the mapping's statistics.  A run that is interrupted
(Ctrl-C, a crash, a worker that keeps dying, a lost scheduler) resumes from
there when started again with the same settings: finished steps are not
recomputed and the preparation passes are not repeated.  When all steps are
done, ``OUTPUT`` is written (atomically) and the store removed.

**Bounded client memory; no sources through the client.**  With an
``output``, each detection task saves its sources itself, as a slab piece in
``OUTPUT.parts/`` (flushed to disk), and returns only their count: the
sources do not travel through the scheduler to the client, and the client's
CPU (which shares the machine with local workers) is not spent on them.  A
one-slab chunk's piece becomes the chunk's saved part by a rename; the
pieces of a chunk of several slabs are merged into it by the client, one
chunk at a time.  So ``OUTPUT``'s folder must be reachable by the workers
under the same path, as the input file must.  An ``.h5`` ``OUTPUT`` is
assembled from the parts on disk one part at a time (same datasets, dtypes
and attributes as :func:`auralize.sources.sources_file.save_sources_h5` writes
for the serial result).  The returned series then reads its frames lazily
from ``OUTPUT`` (:class:`H5Frames`).  Without ``output`` every step's
sources are returned in memory; a ``.pvd`` ``OUTPUT`` is also written from
frames in memory.

**Task layout.**  The preparation passes (the ``paper-density`` range and
gradient scale, the peak strengths) run as one task per chunk of steps and
slab, like the detection, not one per step: each task has a fixed cost
(scheduling, opening the file, a fresh cache of mapped frames), which is
what dominated small volumes.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import os
import resource
import shutil
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.distributed.chunked import slab_volume
from auralize.distributed.runner import RunError, Runner, numba_threads
from auralize.errors import FormatError, ParameterError
from auralize.runtime.files import atomic_hdf5, atomic_path, stop_if_failed
from auralize.sources.detection import (
    AUTO_SAMPLE_STEPS,
    STEADY_RTOL,
    SourceFrame,
    SourceSeries,
    SteadyBase,
    StepCache,
    StrengthStats,
    Thresholds,
    check_steady,
    classified_fraction,
    classify,
    delta_v_rule,
    extract,
    input_scale,
    require_steps,
    sample_stats,
    sample_steps,
    step_strengths,
    warn_fraction,
)
from auralize.sources.mapping import (
    AcousticMapping,
    CFDMapping,
    IdentityMapping,
    PaperDensityMapping,
    get_mapping,
)
from auralize.volume import TimeVolume

#: default memory budget of one task (bytes): sets the slab thickness
TASK_MEMORY = 1 << 30
#: float64 arrays of one grid plane alive in a detection task (3 steps of ρ, v,
#: ρv; strengths; kernel scratch; kind/radius; mapping temporaries)
PLANES_PER_TASK_PLANE = 40
STATE_SUFFIX = ".parts"
STATE_VERSION = 2


# --------------------------------------------------------------- task layout
def mapping_reach(mapping: AcousticMapping) -> int | None:
    """Planes of input a mapped value depends on beyond its own (None: unknown)."""
    if type(mapping) is PaperDensityMapping:
        return 1
    if type(mapping) in (IdentityMapping, CFDMapping):
        return 0
    return None


def ghost_planes(volume: TimeVolume, *, floor: bool) -> int:
    """Ghost planes a slab reads on each side beyond the mapping's reach, so that its
    kept planes' sources are the whole grid's.

    Uniform grid: the strengths read the mapped fields one plane further (two
    with the floor's 2h stencils, three for its error's neighbourhood), the ΔV
    radius one more.  Curvilinear grid (:mod:`auralize.curvilinear`): the
    quadrupole strength is a divergence of divergences, so it reads two planes
    further (four with the 2h stencils), plus the floor's neighbourhood and the
    radius; the metric terms of each plane come from the grid's points one
    plane away (two for the 2h stencils), which the slab holds as they are.
    """
    if volume.coords is None:
        return 4 if floor else 2
    return 6 if floor else 3


@dataclass(frozen=True)
class Slab:
    """Keep planes ``[z0, z1)``; read planes ``[r0, r1)`` (with ghost planes)."""

    z0: int
    z1: int
    r0: int
    r1: int


def plan_slabs(
    shape: tuple[int, int, int],
    *,
    ghost: int | None,
    planes: int | None = None,
    memory: int = TASK_MEMORY,
) -> list[Slab]:
    """Cut ``nz`` planes into slabs of about ``planes`` kept planes (auto: fit ``memory``).

    ``ghost=None`` means the whole frame in one slab.
    """
    nz, ny, nx = shape
    if ghost is None or nz < 8:
        return [Slab(0, nz, 0, nz)]
    if planes is None:
        per_plane = PLANES_PER_TASK_PLANE * 8 * ny * nx
        planes = max(4, int(memory // per_plane) - 2 * ghost)
    if not isinstance(planes, int | np.integer) or planes < 1:
        raise ParameterError(f"slab planes must be a positive integer, got {planes!r}")
    planes = max(int(planes), 4)  # a slab needs >= 3 planes for the same stencils
    if planes >= nz:
        return [Slab(0, nz, 0, nz)]
    n_slabs = -(-nz // planes)
    edges = np.linspace(0, nz, n_slabs + 1).round().astype(int)
    return [
        Slab(int(a), int(b), max(int(a) - ghost, 0), min(int(b) + ghost, nz))
        for a, b in itertools.pairwise(edges)
    ]


def plan_chunks(steps: Iterable[int], chunk_steps: int) -> list[tuple[int, int]]:
    """Runs of consecutive steps cut into ``[a, b)`` chunks of at most ``chunk_steps``.

    A run of ``L`` steps becomes ``ceil(L / chunk_steps)`` chunks of equal
    length (±1, longer first), not full chunks and a short remainder: 12
    steps with ``chunk_steps=10`` are two tasks of 6, which two workers
    finish together, rather than 10 + 2.
    """
    if not isinstance(chunk_steps, int | np.integer) or chunk_steps < 1:
        raise ParameterError(f"chunk_steps must be a positive integer, got {chunk_steps!r}")
    runs: list[list[int]] = []
    for n in sorted(set(steps)):
        if runs and n == runs[-1][-1] + 1:
            runs[-1].append(n)
        else:
            runs.append([n])
    out: list[tuple[int, int]] = []
    for run in runs:
        k = -(-len(run) // int(chunk_steps))
        size, extra = divmod(len(run), k)
        a = run[0]
        for i in range(k):
            b = a + size + (1 if i < extra else 0)
            out.append((a, b))
            a = b
    return out


# ------------------------------------------------------------------- tasks
def _local(
    volume: TimeVolume, mapping: AcousticMapping, slab: Slab
) -> tuple[TimeVolume, AcousticMapping]:
    """The slab's volume and a private copy of the mapping bound to it (tasks may share objects)."""
    nz = volume.shape[0]
    sub = volume if (slab.r0, slab.r1) == (0, nz) else slab_volume(volume, slab.r0, slab.r1)
    mapping = copy.copy(mapping)
    if isinstance(mapping, PaperDensityMapping):
        # statistics come from the whole series (set by the driver); do not redo them
        mapping._prepared_for = id(sub)
    return sub, mapping


def _rss() -> tuple[int, int]:
    return os.getpid(), int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


def detect_task(  # noqa: PLR0917 (a Dask task: its arguments travel as one tuple)
    volume: TimeVolume,
    mapping: AcousticMapping,
    thr: NDArray[np.float64],
    zero_fraction: float,
    a: int,
    b: int,
    slab: Slab,
    threads: int | None,
    store_dir: str | None = None,
    qmean: NDArray[np.int64] | None = None,
    delta_v: str = "cell",
    floor: float = 0.0,
) -> dict[str, Any]:
    """Sources of steps ``[a, b)`` in planes ``[slab.z0, slab.z1)`` (global flat indices).

    ``qmean`` are the anchor steps of the field's local steady state
    (:class:`~auralize.sources.detection.SteadyBase`; None: the literal
    strengths), ``floor`` the discretisation floor (:class:`~auralize.sources.detection.StepCache`).

    With ``store_dir`` (a run's ``OUTPUT.parts/``) the task saves them there
    itself, as a slab piece (:meth:`StateStore.write_piece`, synced to disk),
    and returns only their count: the sources do not travel through the
    scheduler to the client.
    """
    t0 = time.perf_counter()
    sub, mapping = _local(volume, mapping, slab)
    lo, hi = slab.z0 - slab.r0, slab.z1 - slab.r0
    plane = sub.shape[1] * sub.shape[2]
    frames = []
    tallies = []
    qm = None if qmean is None else SteadyBase(sub, mapping, qmean)
    # a curvilinear slab's cell volumes: its metric terms, from its own points
    cell = None if sub.metric is None else sub.metric.jac
    with numba_threads(threads):
        cache = StepCache(sub, mapping, qmean=qm, floor=floor)
        buf = np.empty((3, *sub.shape))
        for n in range(a, b):
            s = step_strengths(sub, cache, n, buf)
            kind, radius = classify(
                s, thr, sub.spacing, zero_fraction=zero_fraction, delta_v=delta_v, cell=cell
            )
            f = extract(kind[lo:hi], radius[lo:hi], s[:, lo:hi])
            f.index += slab.z0 * plane
            frames.append(f)
            bad = 0 if cache.nodata is None else int(cache.nodata[lo:hi].sum())
            tallies.append(
                [*np.bincount(f.kind, minlength=4)[1:].tolist(), (hi - lo) * plane - bad]
            )
            cache.keep(n, n + 1)
    out: dict[str, Any] = {
        "a": a,
        "b": b,
        "slab": slab,
        "frames": frames,
        "tallies": tallies,
        "count": sum(f.index.size for f in frames),
    }
    if store_dir is not None:
        StateStore.in_dir(store_dir).write_piece(a, slab.z0, frames, sync=True)
        out["frames"] = None
    out.update(seconds=time.perf_counter() - t0, rss=_rss())
    return out


def peak_task(  # noqa: PLR0917 (a Dask task: its arguments travel as one tuple)
    volume: TimeVolume,
    mapping: AcousticMapping,
    steps: Sequence[int],
    slab: Slab,
    threads: int | None,
    qmean: NDArray[np.int64] | None = None,
    floor: float = 0.0,
) -> StrengthStats:
    """|S| statistics of each type over ``steps`` in the slab's kept planes.

    Like :func:`~auralize.sources.detection.strength_stats` (the same sampled points,
    chosen by global index), mapped frames are reused between neighbouring
    sample steps.
    """
    sub, mapping = _local(volume, mapping, slab)
    lo, hi = slab.z0 - slab.r0, slab.z1 - slab.r0
    plane = sub.shape[1] * sub.shape[2]
    parts = []
    qm = None if qmean is None else SteadyBase(sub, mapping, qmean)
    with numba_threads(threads):
        cache = StepCache(sub, mapping, qmean=qm, floor=floor)
        buf = np.empty((3, *sub.shape))
        for n in steps:
            s = step_strengths(sub, cache, int(n), buf)
            nodata = None if cache.nodata is None else cache.nodata[lo:hi]
            parts.append(
                sample_stats(
                    s[:, lo:hi],
                    nodata,
                    slab.z0 * plane,
                    volume.n_points,
                    input_scale(sub, cache, int(n), lo, hi),
                )
            )
            cache.keep(int(n), int(n))
    return StrengthStats.merge(parts)


def steady_task(
    volume: TimeVolume, mapping: AcousticMapping, a: int, b: int, slab: Slab
) -> NDArray[np.float64]:
    """For each step n of ``[a, b)`` with n >= 1, in the slab's kept planes: the largest
    change of the mapped density and mass flux from step n - 1 and their largest
    magnitudes, ``(b - a, 4)`` (rows of step 0: zero), for
    :func:`~auralize.sources.detection.steady_anchors`."""
    from auralize.sources.detection import StepCache as _Cache

    sub, mapping = _local(volume, mapping, slab)
    lo, hi = slab.z0 - slab.r0, slab.z1 - slab.r0
    cache = _Cache(sub, mapping)
    out = np.zeros((b - a, 4))
    for n in range(max(a, 1), b):
        r0, _, m0, _ = cache.get(n - 1)
        r1, _, m1, _ = cache.get(n)
        r0, r1, m0, m1 = r0[lo:hi], r1[lo:hi], m0[lo:hi], m1[lo:hi]
        out[n - a] = [
            float(np.max(np.abs(r1 - r0), initial=0.0)),
            float(np.max(np.abs(m1 - m0), initial=0.0)),
            max(float(np.max(np.abs(r0), initial=0.0)), float(np.max(np.abs(r1), initial=0.0))),
            max(float(np.max(np.abs(m0), initial=0.0)), float(np.max(np.abs(m1), initial=0.0))),
        ]
        cache.keep(n, n)
    return out


def paper_range_task(
    volume: TimeVolume, m: PaperDensityMapping, steps: Sequence[int], slab: Slab
) -> tuple[float, float]:
    """min and max of 10**x over ``steps`` in the slab (no ghost planes needed)."""
    sub = (
        slab_volume(volume, slab.z0, slab.z1)
        if (slab.z0, slab.z1) != (0, volume.shape[0])
        else volume
    )
    lo, hi = np.inf, -np.inf
    for n in steps:
        r = m._rho(sub, int(n))
        lo = min(lo, float(np.nanmin(r, initial=np.inf)))  # no-data (NaN) points do not count
        hi = max(hi, float(np.nanmax(r, initial=-np.inf)))
    return lo, hi


def paper_gradient_task(
    volume: TimeVolume, m: PaperDensityMapping, steps: Sequence[int], slab: Slab
) -> float:
    """Largest |∂ρ̃/∂x_i| over ``steps`` in the slab's kept planes."""
    sub, m = _local(volume, m, slab)  # type: ignore[assignment]
    lo, hi = slab.z0 - slab.r0, slab.z1 - slab.r0
    gmax = 0.0
    for n in steps:
        g = m._grad(sub, m._scaled(m._rho(sub, int(n))))
        gmax = max(gmax, float(np.nanmax(np.abs(g[lo:hi]), initial=0.0)))
    return gmax


# ------------------------------------------------------------- state store
class StateStore:
    """Finished chunks of a detection run: ``OUTPUT.parts/`` (see the module docstring)."""

    def __init__(self, output: str | os.PathLike[str]) -> None:
        self.output = Path(output).expanduser()
        self.dir = self.output.with_name(self.output.name + STATE_SUFFIX)

    @classmethod
    def in_dir(cls, folder: str | os.PathLike[str]) -> StateStore:
        """The store whose folder is ``folder`` (``OUTPUT.parts``), as a task sees it."""
        d = Path(folder)
        if not d.name.endswith(STATE_SUFFIX):
            raise ParameterError(f"{d} is not a detection state folder (*{STATE_SUFFIX})")
        return cls(d.with_name(d.name[: -len(STATE_SUFFIX)]))

    @property
    def manifest_path(self) -> Path:
        return self.dir / "manifest.json"

    def exists(self) -> bool:
        return self.manifest_path.exists()

    def read_manifest(self) -> dict[str, Any]:
        try:
            return dict(json.loads(self.manifest_path.read_text()))
        except (OSError, ValueError) as exc:
            raise FormatError(
                f"{self.manifest_path}: unreadable resume state ({exc}); delete {self.dir} or "
                f"pass restart=True (--restart) to start over"
            ) from None

    def write_manifest(self, data: dict[str, Any]) -> None:
        self.dir.mkdir(parents=True, exist_ok=True)
        with atomic_path(self.manifest_path) as tmp:
            tmp.write_text(json.dumps(data, indent=1, default=_jsonable))

    def clear(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)

    def _chunk_files(self) -> list[Path]:
        return sorted(self.dir.glob("steps_*.npz"))

    def done_steps(self) -> set[int]:
        """Steps whose sources are saved."""
        done: set[int] = set()
        for f in self._chunk_files():
            try:
                a, b = (int(x) for x in f.stem.split("_")[1].split("-"))
            except ValueError:
                continue
            done.update(range(a, b))
        return done

    def write_chunk(self, a: int, frames: list[SourceFrame]) -> None:
        """Save the sources of steps ``a … a+len(frames)-1`` (atomically)."""
        b = a + len(frames)
        _save_frames(self.dir / f"steps_{a:07d}-{b:07d}.npz", frames, sync=True)

    def _piece_path(self, a: int, b: int, z0: int) -> Path:
        return self.dir / f"piece_{a:07d}-{b:07d}_{z0:07d}.npz"

    def write_piece(
        self, a: int, z0: int, frames: list[SourceFrame], *, sync: bool = False
    ) -> None:
        """Park one slab's sources of steps ``a …`` until the chunk's other slabs are in.

        Pieces are not a "done" record: a chunk missing a slab is recomputed.
        ``sync`` flushes the piece to disk (so :meth:`promote_piece` can make
        it the chunk's record without rewriting it).
        """
        self.dir.mkdir(parents=True, exist_ok=True)
        _save_frames(self._piece_path(a, a + len(frames), z0), frames, sync=sync)

    def save_qmean(self, qmean: NDArray[np.float64]) -> None:
        """Keep the run's steady quadrupole strength (for resuming)."""
        self.dir.mkdir(parents=True, exist_ok=True)
        with atomic_path(self.dir / "qmean.npy") as tmp:
            with open(tmp, "wb") as fh:
                np.save(fh, qmean)

    def load_qmean(self) -> NDArray[np.float64]:
        try:
            return np.asarray(np.load(self.dir / "qmean.npy"))
        except (OSError, ValueError) as exc:
            raise FormatError(
                f"{self.dir / 'qmean.npy'}: unreadable resume state ({exc}); delete {self.dir} "
                f"or pass restart=True (--restart) to start over"
            ) from None

    def promote_piece(self, a: int, b: int, z0: int) -> None:
        """Make the piece of a one-slab chunk its saved chunk (a rename, no rewrite)."""
        os.replace(self._piece_path(a, b, z0), self.dir / f"steps_{a:07d}-{b:07d}.npz")

    def take_piece(self, a: int, b: int, z0: int) -> list[SourceFrame]:
        """Read back (and delete) a piece saved by :meth:`write_piece`."""
        f = self._piece_path(a, b, z0)
        off, idx, kind, strength, radius = self._read_part(
            f, "offsets", "index", "kind", "strength", "radius"
        )
        f.unlink()
        return [
            SourceFrame(index=idx[i:j], kind=kind[i:j], strength=strength[i:j], radius=radius[i:j])
            for i, j in itertools.pairwise(off)
        ]

    def clear_pieces(self) -> None:
        """Remove slab pieces of chunks an interrupted run did not finish."""
        for f in self.dir.glob("piece_*.npz"):
            f.unlink(missing_ok=True)

    def _chunk_start(self, f: Path) -> int:
        return int(f.stem.split("_")[1].split("-")[0])

    def _read_part(self, f: Path, *names: str) -> list[NDArray[Any]]:
        try:
            with np.load(f, allow_pickle=False) as z:
                return [z[name] for name in names]
        except (OSError, ValueError, KeyError) as exc:
            raise FormatError(
                f"{f}: unreadable saved chunk ({exc}); delete it to recompute those steps"
            ) from None

    def step_offsets(self, n_steps: int) -> NDArray[np.int64]:
        """``(T+1,)`` row offsets of every step in the concatenated sources (reads counts only)."""
        counts = np.full(n_steps, -1, dtype=np.int64)
        for f in self._chunk_files():
            a = self._chunk_start(f)
            (off,) = self._read_part(f, "offsets")
            counts[a : a + off.size - 1] = np.diff(off)
        missing = np.flatnonzero(counts < 0).tolist()
        if missing:
            raise FormatError(f"{self.dir}: steps {missing[:10]} are not saved")
        offsets = np.zeros(n_steps + 1, dtype=np.int64)
        offsets[1:] = np.cumsum(counts)
        return offsets

    def write_h5(self, head: SourceSeries, path: str | os.PathLike[str]) -> int:
        """Write the saved chunks as a sources file, one part in memory at a time.

        ``head`` gives the times, grid, thresholds and meta (its frames are
        ignored).  The file holds the same datasets, dtypes and attributes as
        :func:`~auralize.sources.sources_file.save_sources_h5` writes for the
        whole series.  Returns the largest number of sources held at once.
        """
        from auralize.sources.sources_file import FORMAT, VERSION

        n_steps = head.times.size
        offsets = self.step_offsets(n_steps)
        total = int(offsets[-1])
        held = 0
        nbytes = 57.0 * total + 16.0 * n_steps + 65536.0  # rows, times and offsets, overhead
        what = f"{total} source points over {n_steps} steps"
        with atomic_hdf5(path, nbytes=nbytes, what=what) as h:
            h.attrs["auralize_format"] = FORMAT
            h.attrs["version"] = VERSION
            h.attrs["origin"] = head.origin
            h.attrs["spacing"] = head.spacing
            h.attrs["dims"] = np.asarray(head.dims)
            h.attrs["thresholds"] = head.thresholds
            h.attrs["meta"] = json.dumps(head.meta, default=str)
            h["time"] = head.times
            h["offsets"] = offsets
            ds = {
                "index": h.create_dataset("index", shape=(total,), dtype=np.int64),
                "position": h.create_dataset("position", shape=(total, 3), dtype=np.float64),
                "kind": h.create_dataset("kind", shape=(total,), dtype=np.int8),
                "strength": h.create_dataset("strength", shape=(total,), dtype=np.float64),
                "radius": h.create_dataset("radius", shape=(total,), dtype=np.float64),
            }
            for f in self._chunk_files():
                a = self._chunk_start(f)
                off, idx, kind, strength, radius = self._read_part(
                    f, "offsets", "index", "kind", "strength", "radius"
                )
                r0, r1 = int(offsets[a]), int(offsets[a + off.size - 1])
                if r1 - r0 != idx.size:
                    raise FormatError(
                        f"{f}: saved chunk holds {idx.size} sources, its offsets "
                        f"say {r1 - r0}; delete it to recompute those steps"
                    )
                held = max(held, idx.size)
                if r1 == r0:
                    continue
                ds["index"][r0:r1] = idx.astype(np.int64)
                ds["position"][r0:r1] = head.positions(idx.astype(np.int64))
                ds["kind"][r0:r1] = kind.astype(np.int8)
                ds["strength"][r0:r1] = strength.astype(np.float64)
                ds["radius"][r0:r1] = radius.astype(np.float64)
                stop_if_failed(h)  # a full disk ends the writer at this part
        return held

    def load_frames(self, n_steps: int) -> list[SourceFrame]:
        """Every step's sources; raises if a step is missing."""
        frames: list[SourceFrame | None] = [None] * n_steps
        for f in self._chunk_files():
            a = int(f.stem.split("_")[1].split("-")[0])
            try:
                with np.load(f, allow_pickle=False) as z:
                    off, idx, kind = z["offsets"], z["index"], z["kind"]
                    strength, radius = z["strength"], z["radius"]
            except (OSError, ValueError, KeyError) as exc:
                raise FormatError(
                    f"{f}: unreadable saved chunk ({exc}); delete it to recompute those steps"
                ) from None
            for k in range(off.size - 1):
                s = slice(off[k], off[k + 1])
                frames[a + k] = SourceFrame(
                    index=idx[s], kind=kind[s], strength=strength[s], radius=radius[s]
                )
        missing = [n for n, f in enumerate(frames) if f is None]
        if missing:
            raise FormatError(f"{self.dir}: steps {missing[:10]} are not saved")
        return frames  # type: ignore[return-value]


class H5Frames(Sequence[SourceFrame]):
    """The frames of a sources HDF5 file, read one step at a time when asked for.

    Stands for ``SourceSeries.frames`` so a detection written to a file need
    not be held in memory; ``frames[n]`` and iteration read only those rows.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        import h5py

        self.path = Path(path)
        with h5py.File(self.path, "r") as h:
            self.offsets = np.asarray(h["offsets"][()], dtype=np.int64)

    def __len__(self) -> int:
        return int(self.offsets.size - 1)

    def _read(self, h: Any, n: int) -> SourceFrame:
        s = slice(int(self.offsets[n]), int(self.offsets[n + 1]))
        return SourceFrame(
            index=h["index"][s], kind=h["kind"][s], strength=h["strength"][s], radius=h["radius"][s]
        )

    def __getitem__(self, n: Any) -> Any:
        import h5py

        if isinstance(n, slice):
            return [self[k] for k in range(*n.indices(len(self)))]
        k = int(n) + len(self) if int(n) < 0 else int(n)
        if not 0 <= k < len(self):
            raise IndexError(f"step {n} out of range for {len(self)} steps")
        with h5py.File(self.path, "r") as h:
            return self._read(h, k)

    def __iter__(self) -> Iterator[SourceFrame]:
        import h5py

        with h5py.File(self.path, "r") as h:
            for n in range(len(self)):
                yield self._read(h, n)


def _save_frames(path: Path, frames: list[SourceFrame], *, sync: bool) -> None:
    """Consecutive steps' sources as one ``.npz`` (offsets + concatenated rows), atomically."""
    off = np.zeros(len(frames) + 1, dtype=np.int64)
    off[1:] = np.cumsum([f.index.size for f in frames])
    with atomic_path(path, suffix=".part") as tmp, open(tmp, "wb") as fh:
        np.savez(
            fh,
            offsets=off,
            index=np.concatenate([f.index for f in frames]).astype(np.int64),
            kind=np.concatenate([f.kind for f in frames]).astype(np.int8),
            strength=np.concatenate([f.strength for f in frames]).astype(np.float64),
            radius=np.concatenate([f.radius for f in frames]).astype(np.float64),
        )
        if sync:
            fh.flush()
            os.fsync(fh.fileno())


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def fingerprint(
    volume: TimeVolume, mapping: AcousticMapping, thresholds: Thresholds, **options: str
) -> str:
    """What makes two runs the same (grid, times, source, mapping, threshold settings, options)."""
    h = hashlib.sha256()
    h.update(
        json.dumps(
            {
                "source": volume.source,
                "dims": list(volume.dims),
                "fields": volume.field_names,
                "origin": volume.origin.tolist(),
                "spacing": volume.spacing.tolist(),
                "mapping": mapping.describe(),
                "thresholds": thresholds.describe(),
                **options,
            },
            sort_keys=True,
            default=_jsonable,
        ).encode()
    )
    h.update(np.ascontiguousarray(volume.times).tobytes())
    if volume.coords is not None:
        h.update(np.ascontiguousarray(volume.coords).tobytes())
    return h.hexdigest()


# ------------------------------------------------------------------ driver
@dataclass
class _Run:
    volume: TimeVolume
    mapping: AcousticMapping
    runner: Runner
    slabs: list[Slab]
    #: the volume as shipped to the workers (once per run)
    shared: Any
    #: runs of steps one preparation task covers
    groups: list[tuple[int, int]]

    def tasks(
        self, fn: Callable[..., Any], steps: Iterable[int], *extra: Any, mapping: Any = None
    ) -> list[Any]:
        """Lazy ``fn(volume, mapping, steps, slab, *extra)``, one per step group and slab.

        ``mapping`` (default: the run's) may be a lazy call's result.
        """
        m = self.mapping if mapping is None else mapping
        steps = sorted(set(int(n) for n in steps))
        out = []
        for a, b in self.groups:
            mine = [n for n in steps if a <= n < b]
            if mine:
                out += [self.runner.call(fn, self.shared, m, mine, s, *extra) for s in self.slabs]
        return out


def _with_range(m: PaperDensityMapping, ranges: list[tuple[float, float]]) -> PaperDensityMapping:
    """A copy of ``m`` with the series' range of 10**x (from the range tasks)."""
    m = copy.copy(m)
    m._lo = float(min([np.inf, *(r[0] for r in ranges)]))
    m._hi = float(max([-np.inf, *(r[1] for r in ranges)]))
    return m


def _with_gscale(m: PaperDensityMapping, gmax: list[float]) -> PaperDensityMapping:
    """A copy of ``m`` with its velocity scale (from the gradient tasks)."""
    m = copy.copy(m)
    g = max([0.0, *gmax])
    m._gscale = m.velocity_max / g if g > 0 else 0.0
    return m


def _merge_stats(parts: list[StrengthStats]) -> StrengthStats:
    return StrengthStats.merge(parts)


def _anchors(blocks: list[list[NDArray[np.float64]]], n_steps: int) -> NDArray[np.int64]:
    """The anchor steps of the field's local steady state from the steady tasks'
    maxima (``blocks[i]``: block i's per-slab rows), as
    :func:`~auralize.sources.detection.steady_anchors` finds them."""
    rows = np.concatenate([np.max(np.stack(parts), axis=0) for parts in blocks])
    anchors = {0, n_steps - 1}
    for n in range(1, n_steps):
        dr, dm, sr, sm = rows[n]
        if dr <= STEADY_RTOL * sr and dm <= STEADY_RTOL * sm:
            anchors.update((n - 1, n))
    return np.array(sorted(anchors), dtype=np.int64)


def _stack(*parts: Any) -> list[Any]:
    return list(parts)


def _prepare_paper(run: _Run) -> Any:
    """The paper-density mapping with its series-wide statistics: a lazy call.

    Range tasks, then gradient tasks (which need the range), each reduced by
    a small task, all submitted at once: the passes follow each other on the
    workers without a round trip through the client.
    """
    m = run.mapping
    assert isinstance(m, PaperDensityMapping)
    AcousticMapping.prepare(m, run.volume)  # field checks only
    T = run.volume.n_steps
    call = run.runner.call
    ranged = call(_with_range, m, run.tasks(paper_range_task, range(T)))
    return call(_with_gscale, ranged, run.tasks(paper_gradient_task, range(T), mapping=ranged))


def _peaks(
    run: _Run, mapping: Any, qmean: Any, max_steps: int = AUTO_SAMPLE_STEPS, floor: float = 0.0
) -> Any:
    """The |S| statistics of each type over the sample steps: a lazy call."""
    steps = sample_steps(run.volume.n_steps, max_steps)
    peaks = run.tasks(
        peak_task, steps.tolist(), run.runner.threads_per_task, qmean, floor, mapping=mapping
    )
    return run.runner.call(_merge_stats, peaks)


#: steps per steady task
STEADY_BLOCK = 8


def _steady_node(run: _Run, mapping: Any) -> Any:
    """The anchor steps of the local steady state, from per-block, per-slab tasks: a
    lazy call (a mapping without velocity has no stress: the first and last step)."""
    call = run.runner.call
    T = run.volume.n_steps
    # (``mapping`` may be a lazy call's result; which fields exist is the run's mapping's)
    if T < 3 or run.mapping.unavailable(run.volume).get("quadrupole"):
        return np.array(sorted({0, T - 1}), dtype=np.int64)
    blocks = [
        call(
            _stack,
            *[
                call(steady_task, run.shared, mapping, a, min(a + STEADY_BLOCK, T), s)
                for s in run.slabs
            ],
        )
        for a in range(0, T, STEADY_BLOCK)
    ]
    return call(_anchors, blocks, T)


def detect_distributed(  # noqa: PLR0913 (keyword-only options)
    volume: TimeVolume,
    *,
    mapping: str | AcousticMapping | None = "identity",
    thresholds: Thresholds | None = None,
    output: str | os.PathLike[str] | None = None,
    runner: Runner | None = None,
    scheduler: str = "sync",
    address: str | None = None,
    workers: int | None = None,
    chunk_steps: int = 8,
    slab_planes: int | None = None,
    task_memory: int = TASK_MEMORY,
    restart: bool = False,
    steady: str = "remove",
    delta_v: str = "cell",
    on_chunk: Callable[[range], None] | None = None,
    log: Callable[[str], None] | None = print,
    **mapping_fields: str,
) -> SourceSeries:
    """Detect sources like :func:`auralize.sources.detection.detect`, in parallel, out of core, resumably.

    Parameters
    ----------
    volume : TimeVolume
        At least two steps; read lazily, one slab of one step at a time.
    mapping, thresholds, **mapping_fields
        As for :func:`auralize.sources.detection.detect`.
    output : path-like, optional
        ``.h5``/``.hdf5`` or ``.pvd`` sources file, written when all steps are
        done; finished chunks are kept in ``OUTPUT.parts/`` until then, and a
        new run with the same settings resumes from them.  An HDF5 output is
        assembled from those parts one at a time, so the client's memory
        does not grow with the number of sources.  The tasks write their
        sources to ``OUTPUT.parts/`` themselves: the workers must see
        ``OUTPUT``'s folder under the same path.
    runner : Runner, optional
        An open :class:`~auralize.distributed.runner.Runner`; otherwise one is made
        from ``scheduler``, ``address`` and ``workers`` and closed afterwards.
    chunk_steps : int
        Time steps per task (each task reads one extra step on each side).
    slab_planes : int, optional
        z-planes kept per task (default: what fits ``task_memory`` bytes).
    restart : bool
        Discard saved state of an earlier run instead of resuming it.
    steady, delta_v
        As for :func:`auralize.sources.detection.detect`; the steady quadrupole
        strength is gathered by tasks (per block of steps and slab).
    on_chunk : callable, optional
        Called with the ``range`` of steps of every chunk just saved (and
        after it is saved); an exception raised there stops the run, leaving
        a resumable state.

    Returns
    -------
    SourceSeries
        Bit-identical frames to the serial detection (with an HDF5
        ``output``, an :class:`H5Frames` reading them from it on demand);
        ``meta["scale"]``
        tells which steps were computed by this call, the number of tasks,
        the slabs and the peak memory of the processes that ran them.

    Raises
    ------
    ParameterError
        Bad options, or saved state from different settings (``restart``
        discards it).
    RunError
        A worker kept dying on a task; finished chunks are saved.

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_monopole
    >>> vol = make_monopole(size=12, steps=6)
    >>> s = detect_distributed(vol, thresholds=Thresholds(1e-3, 1e-3, 1e-3), chunk_steps=2,
    ...                        log=None)
    >>> s.n_steps, s.meta["scale"]["tasks"]
    (6, 3)
    """
    require_steps(volume)
    m = get_mapping(mapping, **mapping_fields)
    check_steady(steady)
    delta_v_rule(delta_v)
    thresholds = thresholds or Thresholds()
    out = _checked_output(task_memory, output)
    reach = mapping_reach(m)
    slabs = plan_slabs(
        volume.shape,
        ghost=None if reach is None else reach + ghost_planes(volume, floor=thresholds.floor > 0),
        planes=slab_planes,
        memory=int(task_memory),
    )
    plan_chunks([], chunk_steps)  # validates chunk_steps
    store = StateStore(out) if out is not None else None
    key = fingerprint(volume, m, thresholds, steady=steady, delta_v=delta_v)
    state = _stored_state(store, key, restart=restart)
    own = runner is None
    run_ = runner or Runner(scheduler, address=address, workers=workers, log=log)
    t0 = time.perf_counter()
    try:
        if own:
            run_.__enter__()
        # the volume goes to the workers once (for the preparation passes and detection)
        vol = run_.share(volume)
        run = _Run(volume, m, run_, slabs, vol, plan_chunks(range(volume.n_steps), chunk_steps))
        # the preparation (statistics, peaks, thresholds) and the detection form one
        # graph: m_node, peak_node and thr_node are values, or lazy calls whose results
        # arrive with the detection tasks' (and are saved before any chunk is)
        m_node, q_node, peak, thr, state_known = _prepare(
            run, m, state, store=store, steady=steady, thresholds=thresholds
        )
        lazy = {
            name: node
            for name, node in (("mapping", m_node), ("peak", peak), ("thr", thr), ("qmean", q_node))
            if _is_lazy(node)
        }
        if store is not None:
            store.clear_pieces()
        done = store.done_steps() if store is not None else set()
        todo = [n for n in range(volume.n_steps) if n not in done]
        chunks = plan_chunks(todo, chunk_steps)
        frames: list[SourceFrame | None] = [None] * volume.n_steps
        pending: dict[int, dict[Slab, list[SourceFrame]]] = {}
        rss: dict[int, int] = {}
        task_seconds = [0.0]
        n_sources = [0]
        parts_dir = None if store is None else str(store.dir)
        nthr = run_.threads_per_task
        calls = [
            (
                detect_task,
                (
                    vol,
                    m_node,
                    thr,
                    thresholds.zero_fraction,
                    a,
                    b,
                    s,
                    nthr,
                    parts_dir,
                    q_node,
                    delta_v,
                    thresholds.floor,
                ),
            )
            for a, b in chunks
            for s in slabs
        ]
        # per (chunk, slab): monopole, dipole, quadrupole and valid point-steps (a task
        # that ran twice, after a worker died, counts once)
        tallies: dict[tuple[int, int], NDArray[np.int64]] = {}
        known: dict[str, Any] = {}
        early: list[dict[str, Any]] = []

        def save_state() -> None:
            nonlocal m, peak, thr, state
            if "mapping" in known:
                m = known["mapping"]
            if "peak" in known:
                peak = known["peak"]
            if isinstance(peak, StrengthStats):
                peak = peak.peak
            if "thr" in known:
                thr = known["thr"]
            if "qmean" in known and store is not None:
                store.save_qmean(known["qmean"])
            state = {
                "version": STATE_VERSION,
                "fingerprint": key,
                "mapping_state": _mapping_state(m),
                "thresholds": thr,
                "peak": peak,
                "n_steps": volume.n_steps,
                "source": volume.source,
            }
            if store is not None:
                store.write_manifest(state)

        if not state_known and not lazy:
            save_state()
            state_known = True

        def got(_i: int, res: dict[str, Any]) -> None:
            if not state_known:  # (not in practice: detection depends on the state)
                early.append(res)
                return
            pid, peak_rss = res["rss"]
            rss[pid] = max(rss.get(pid, 0), peak_rss)
            task_seconds[0] += res["seconds"]
            n_sources[0] += res["count"]
            tallies[(res["a"], res["slab"].z0)] = np.sum(res["tallies"], axis=0, dtype=np.int64)
            a, b = res["a"], res["b"]
            parts = pending.setdefault(a, {})
            # with a store, the task saved its slab's sources as a piece; they wait
            # on disk for the chunk's other slabs (tasks finish in any order)
            parts[res["slab"]] = res["frames"]
            del res
            if len(parts) < len(slabs):
                return
            del pending[a]
            _chunk_done(store, slabs, parts, a=a, b=b, frames=frames)
            del parts
            if on_chunk is not None:
                on_chunk(range(a, b))

        names = list(lazy)

        def got_any(i: int, res: Any) -> None:
            nonlocal state_known
            if i < len(names):
                known[names[i]] = res
                if len(known) == len(names):
                    save_state()
                    state_known = True
                    while early:
                        got(-1, early.pop(0))
                return
            got(i - len(names), res)

        outputs = [lazy[n] for n in names] + [run_.call(fn, *args) for fn, args in calls]
        run_.compute(outputs, got_any)
        if not state_known:  # nothing to detect (every step resumed) and no state yet
            raise RunError("the preparation passes did not deliver their results")
        elapsed = time.perf_counter() - t0
        n_workers = run_.n_workers
    finally:
        if own:
            run_.close()
    streamed = out is not None and store is not None and out.suffix.lower() != ".pvd"
    if store is not None and not streamed:
        frames = store.load_frames(volume.n_steps)  # type: ignore[assignment]
    fraction = _fractions(tallies, frames if not todo else None, volume.n_points)
    warn_fraction(fraction, volume.source)
    if isinstance(peak, StrengthStats):
        peak = peak.peak
    series = SourceSeries(
        frames=[] if streamed else frames,  # type: ignore[arg-type]
        times=volume.times.copy(),
        origin=volume.origin.copy(),
        spacing=volume.spacing.copy(),
        dims=volume.dims,
        thresholds=np.asarray(thr),
        meta={
            "mapping": m.describe(),
            "thresholds": thresholds.describe(),
            "peak": None if peak is None else np.asarray(peak).tolist(),
            "source": volume.source,
            "steady": steady,
            "delta_v": delta_v,
            "fraction": fraction,
            **({"grid": "curvilinear"} if volume.coords is not None else {}),
            "scale": {
                "scheduler": run_.scheduler,
                "workers": n_workers,
                "computed_steps": todo,
                "resumed_steps": len(done),
                "tasks": len(calls),
                "chunks": len(chunks),
                "chunk_steps": chunk_steps,
                "slabs": [(s.z0, s.z1) for s in slabs],
                "seconds": elapsed,
                "task_seconds": task_seconds[0],
                "computed_sources": n_sources[0],
                "peak_rss_per_process": sorted(rss.values(), reverse=True),
            },
        },
        coords=volume.coords,
    )
    if streamed:
        assert out is not None and store is not None
        store.write_h5(series, out)
        store.clear()
        return replace(series, frames=H5Frames(out))  # type: ignore[arg-type]
    if out is not None and store is not None:
        from auralize.sources.sources_file import save_sources_pvd

        save_sources_pvd(series, out)
        store.clear()
    return series


def _chunk_done(
    store: StateStore | None,
    slabs: list[Slab],
    parts: dict[Slab, list[SourceFrame]],
    *,
    a: int,
    b: int,
    frames: list[SourceFrame | None],
) -> None:
    """Steps ``a``..``b`` have every slab's sources (``parts``, or the pieces the tasks saved
    in ``store``): merged across slabs, into the store's chunk or into ``frames``."""
    if store is not None and len(slabs) == 1:
        store.promote_piece(a, b, slabs[0].z0)  # synced by the task
        return
    if store is not None:
        parts = {s: store.take_piece(a, b, s.z0) for s in slabs}
    merged = [_merge([parts[s][k] for s in slabs]) for k in range(b - a)]
    if store is not None:
        store.write_chunk(a, merged)
    else:
        frames[a:b] = merged


def _checked_output(task_memory: Any, output: str | os.PathLike[str] | None) -> Path | None:
    """The sources output (``.h5``/``.hdf5``/``.pvd``, or None) once ``task_memory`` is a
    whole number of bytes of at least 1 MiB."""
    if not isinstance(task_memory, int | np.integer) or task_memory < (1 << 20):
        raise ParameterError(f"task_memory must be at least 1 MiB (bytes), got {task_memory!r}")
    out = Path(output).expanduser() if output is not None else None
    if out is not None and out.suffix.lower() not in (".h5", ".hdf5", ".pvd"):
        raise ParameterError(f"{out}: sources output must end in .h5/.hdf5 or .pvd")
    return out


def _mapping_state(m: AcousticMapping) -> dict[str, float]:
    """What a resumed run needs of the mapping's preparation (the paper density's range)."""
    if isinstance(m, PaperDensityMapping):
        return {"lo": m._lo, "hi": m._hi, "gscale": m._gscale}
    return {}


def _stored_state(store: StateStore | None, key: str, *, restart: bool) -> dict[str, Any]:
    """The saved manifest of an earlier run with the same settings (``{}``: none, or
    discarded with ``restart``); another run's state is refused."""
    if store is None or not store.exists():
        return {}
    if restart:
        store.clear()
        return {}
    state = store.read_manifest()
    if state.get("fingerprint") != key or state.get("version") != STATE_VERSION:
        raise ParameterError(
            f"{store.dir} holds a detection run with other settings (another volume, "
            f"mapping or thresholds); pass restart=True (--restart) to discard it, or "
            f"choose another output"
        )
    return state


def _prepare(
    run: _Run,
    m: AcousticMapping,
    state: dict[str, Any],
    *,
    store: StateStore | None,
    steady: str,
    thresholds: Thresholds,
) -> tuple[Any, Any, Any, Any, bool]:
    """The mapping, steady stress, peaks and thresholds the detection tasks take: from the
    saved state of a resumed run (then known: the last value True), or as nodes of the
    run's graph (values, or lazy calls computed with the detection)."""
    volume = run.volume
    if "mapping_state" in state:
        if isinstance(m, PaperDensityMapping):
            st = state["mapping_state"]
            m._lo, m._hi, m._gscale = float(st["lo"]), float(st["hi"]), float(st["gscale"])
        else:
            m.prepare(volume)
        thr: Any = np.asarray(state["thresholds"], dtype=np.float64)
        peak: Any = None if state.get("peak") is None else np.asarray(state["peak"])
        m_node: Any = m
        q_node: Any = store.load_qmean() if store is not None and steady == "remove" else None
        state_known = True
    else:
        if store is not None:
            store.clear()  # no manifest: whatever is there belongs to no run
        if isinstance(m, PaperDensityMapping):
            m_node = _prepare_paper(run)
        else:
            m.prepare(volume)
            m_node = m
        q_node = _steady_node(run, m_node) if steady == "remove" else None
        peak = (
            _peaks(run, m_node, q_node, floor=thresholds.floor) if thresholds.needs_scale else None
        )
        thr = (
            run.runner.call(thresholds.resolve, peak)
            if peak is not None
            else thresholds.resolve(None)
        )
        state_known = False
    return m_node, q_node, peak, thr, state_known


def _fractions(
    tallies: dict[tuple[int, int], NDArray[np.int64]],
    frames: list[SourceFrame | None] | None,
    n_points: int,
) -> dict[str, float]:
    """The share of the valid point-steps classified per type (and ``any``): counted from
    every step's frames when this run has them all, else from the tasks' tallies."""
    if frames and all(f is not None for f in frames):
        return classified_fraction(frames, n_points)  # type: ignore[arg-type]
    tally = np.sum(list(tallies.values()), axis=0) if tallies else np.zeros(4, dtype=np.int64)
    valid = int(tally[3])
    fraction = {
        k: (int(tally[i]) / valid if valid else 0.0)
        for i, k in enumerate(("monopole", "dipole", "quadrupole"))
    }
    fraction["any"] = sum(fraction.values())
    return fraction


def _is_lazy(obj: Any) -> bool:
    return hasattr(obj, "dask") and hasattr(obj, "key")


def _merge(parts: list[SourceFrame]) -> SourceFrame:
    if len(parts) == 1:
        return parts[0]
    return SourceFrame(
        index=np.concatenate([p.index for p in parts]),
        kind=np.concatenate([p.kind for p in parts]),
        strength=np.concatenate([p.strength for p in parts]),
        radius=np.concatenate([p.radius for p in parts]),
    )
