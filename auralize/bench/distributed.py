"""Benchmark rows of the Dask back end, for ``auralize bench``.

:func:`bench_dask` measures, on a chunked explosion file (256³ × 100 steps,
or 48³ × 12 with ``quick``):

* distributed detection with a local cluster of 1 and of 2 single-threaded
  worker processes, writing the sources file (the tasks save their sources,
  the client assembles the file): wall time, throughput ratio (target ≥ 1.7×
  on 2 cores) and the peak resident memory of the 2-worker run — of the
  client and of the largest worker separately, and of client + workers
  together (target ≤ 4 GiB).  Memory is sampled by a thread of this process
  every :data:`SAMPLE_S` seconds with ``psutil`` (``memory_info().rss`` of
  this process and of each worker process, whose pids the workers report),
  from the start to the end of the detection; the total is the largest sum
  of the samples taken at the same instant;
* synthesis of 60 s of ``ring8`` audio from the detected sources across 1 and
  2 workers;
* a projection for 512³ × 1000 steps from the measured cost per voxel-step.

**How it is timed.**  Both worker counts run the same tasks (chunks of
:data:`DETECT_CHUNK_STEPS` steps; the synthesis split
:func:`~auralize.distributed.synth.plan_tasks` chooses for 2 workers), on
a fresh local cluster per run, from submission until the sources file is on
disk (detection) or the audio is in the client (synthesis).  Not timed: the
cluster's start-up and the workers' one-time set-up
(:mod:`auralize.distributed.worker_setup`: kernels loaded, allocator), and the
client's own first import and kernel load (:func:`warm_client`) — what a
long-running cluster and session have done once before their first run.
1- and 2-worker runs alternate ``repeats`` times and the medians are
reported, with the CPU other processes used meanwhile (:class:`CpuShare`):
on a shared machine the ratio means little when that is not near 0.

The big file is written once (``auralize.distributed.write_chunked_explosion``,
float32, ~27 GB) to ``$AURALIZE_BENCH_DIR`` (default a private per-user folder
``auralize_bench-<uid>`` in the system temporary folder, see :func:`bench_dir`)
and reused; the temporary of a run killed while writing it is removed by the
next run.
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from auralize.plugins import BenchRow

GIB = float(1 << 30)
#: detection thresholds of the benchmark (relative to the series' peaks)
BENCH_THRESHOLDS = ("5%", "5%", "5%")
#: seconds between two memory samples
SAMPLE_S = 0.05
#: time steps per detection task (both runs use the same tasks)
DETECT_CHUNK_STEPS = 10
#: synthesis rate and layout of the benchmark
SYNTH_RATE, SYNTH_LAYOUT = 44100, "ring8"
#: other processes' CPU (cores) below which the machine counts as quiet
QUIET_CORES = 0.25


class PeakRSS:
    """Peak resident memory of some processes, sampled by a background thread.

    ``psutil.Process(pid).memory_info().rss`` of each pid every ``interval``
    seconds while the ``with`` block runs (and once at its start and end).
    ``peak[pid]`` is each process's largest sample, ``total`` the largest sum
    over the processes of samples taken together.
    """

    def __init__(self, pids: Sequence[int], interval: float = SAMPLE_S) -> None:
        import psutil

        self.procs = {pid: psutil.Process(pid) for pid in pids}
        self.interval = interval
        self.peak = dict.fromkeys(self.procs, 0)
        self.total = 0
        self.samples = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True, name="peak-rss")

    def sample(self) -> None:
        import psutil

        now = 0
        for pid, proc in self.procs.items():
            try:
                rss = int(proc.memory_info().rss)
            except psutil.Error:  # the process ended (a worker was replaced)
                continue
            self.peak[pid] = max(self.peak[pid], rss)
            now += rss
        self.total = max(self.total, now)
        self.samples += 1

    def _loop(self) -> None:
        while not self._stop.wait(self.interval):
            self.sample()

    def __enter__(self) -> PeakRSS:
        self.sample()
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        self.sample()


def bench_dir() -> Path:
    """The benchmark's data folder: ``$AURALIZE_BENCH_DIR``, else a private per-user folder
    ``auralize_bench-<uid>`` in the system temporary folder.

    The folder is created mode 0700 and must belong to this user and not be
    writable by others (the shared temporary folder is writable by everyone: a
    fixed name there could be pre-created, or its file swapped, by another
    user); otherwise :class:`~auralize.errors.OutputError`.  Written files
    persist between runs (they take minutes to make).
    """
    from auralize.errors import OutputError

    env = os.environ.get("AURALIZE_BENCH_DIR")
    if env:
        folder = Path(env).expanduser()
        folder.mkdir(parents=True, exist_ok=True)
        return folder
    folder = Path(tempfile.gettempdir()) / f"auralize_bench-{os.getuid()}"
    try:
        folder.mkdir(mode=0o700)
    except FileExistsError:
        pass
    st = os.lstat(folder)
    import stat

    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid() or st.st_mode & 0o022:
        raise OutputError(
            f"{folder} is not a private folder of this user (owner uid {st.st_uid}, mode "
            f"{stat.filemode(st.st_mode)}); remove it or set AURALIZE_BENCH_DIR"
        )
    return folder


def big_file(size: int, steps: int) -> Path:
    """The chunked explosion file for the benchmark (written once, then reused)."""
    from auralize.distributed import write_chunked_explosion

    folder = bench_dir()
    path = folder / f"explosion_{size}x{steps}.h5"
    if not path.exists():
        write_chunked_explosion(path, size, steps, 0, generator="analytic")
    return path


class CpuShare:
    """CPU used during a ``with`` block: by some processes, and by everything else.

    ``psutil.cpu_times()`` of the machine (busy = all but idle and iowait)
    and of each of ``pids`` at the start and end of the block.  ``others``
    is the mean number of cores busy with other processes: on a shared
    machine, a 2-worker run only scales if that stays well below 1.  (Under
    Linux's autogroup scheduling, another session's busy process takes its
    fair share of the cores whatever its nice level.)
    """

    def __init__(self, pids: Sequence[int]) -> None:
        import psutil

        self.procs = [psutil.Process(pid) for pid in pids]
        self.others = 0.0
        self.ours = 0.0

    @staticmethod
    def _busy() -> float:
        import psutil

        t = psutil.cpu_times()
        return float(
            sum(t)
            - t.idle
            - getattr(t, "iowait", 0.0)
            - getattr(t, "guest", 0.0)
            - getattr(t, "guest_nice", 0.0)
        )

    def _ours(self) -> float:
        import psutil

        total = 0.0
        for p in self.procs:
            try:
                c = p.cpu_times()
            except psutil.Error:
                continue
            total += c.user + c.system
        return total

    def __enter__(self) -> CpuShare:
        self._t = time.perf_counter()
        self._busy0, self._ours0 = self._busy(), self._ours()
        return self

    def __exit__(self, *exc: object) -> None:
        wall = max(time.perf_counter() - self._t, 1e-9)
        ours = self._ours() - self._ours0
        self.ours = ours / wall
        self.others = max(self._busy() - self._busy0 - ours, 0.0) / wall


@dataclass
class Timed:
    """One timed run: its result, seconds, and what the machine did meanwhile."""

    result: Any
    seconds: float
    setup_seconds: float
    cpu: CpuShare
    mem: PeakRSS | None = None
    worker_pids: list[int] = field(default_factory=list)


def warm_client() -> None:
    """Load what the timed code loads in this (the client's) process, once.

    A long-running session has done this before its first run; the first
    timed run of the benchmark would otherwise pay it and the next not.
    """
    import auralize.sources.sources_file  # noqa: F401 - written by the detection
    from auralize.distributed.worker_setup import warm_kernels

    warm_kernels()


def _detect(path: Path, workers: int, size: int) -> Timed:
    """Detection on a fresh local cluster (its start-up and worker set-up not timed)."""
    from auralize.distributed import Runner, detect_distributed
    from auralize.io import open_volume
    from auralize.sources.detection import Thresholds

    vol = open_volume(path, fields=["log10_density"])
    out = path.with_name(f"{path.stem}_sources_{workers}w.h5")
    with Runner("distributed", workers=workers, processes=True, log=None) as run:
        worker_pids = sorted(set(run.client.run(os.getpid).values()))
        pids = [os.getpid(), *worker_pids]
        with PeakRSS(pids) as mem, CpuShare(pids) as cpu:
            t = time.perf_counter()
            series = detect_distributed(
                vol,
                mapping="paper-density",
                thresholds=Thresholds(*BENCH_THRESHOLDS),
                runner=run,
                output=out,
                restart=True,
                chunk_steps=DETECT_CHUNK_STEPS,
            )
            elapsed = time.perf_counter() - t
        return Timed(series, elapsed, run.setup_seconds, cpu, mem, worker_pids)


def _synth(
    tracks: Any, path: Any, workers: int, *, time_scale: float, block: int, groups: int
) -> Timed:
    """60 s of ring8 on a fresh local cluster, in blocks of ``block`` samples × ``groups``."""
    from auralize.distributed import Runner, render_distributed

    with Runner("distributed", workers=workers, processes=True, log=None) as run:
        pids = [os.getpid(), *sorted(set(run.client.run(os.getpid).values()))]
        with CpuShare(pids) as cpu:
            t = time.perf_counter()
            out = render_distributed(
                tracks,
                path,
                rate=SYNTH_RATE,
                layout=SYNTH_LAYOUT,
                time_scale=time_scale,
                runner=run,
                block_seconds=block / SYNTH_RATE,
                groups=groups,
            )
            elapsed = time.perf_counter() - t
        return Timed(out, elapsed, run.setup_seconds, cpu)


def others_busy(seconds: float = 1.0) -> float:
    """Cores kept busy by other processes over the next ``seconds`` (this one sleeps)."""
    with CpuShare([os.getpid()]) as cpu:
        time.sleep(seconds)
    return cpu.others


def wait_quiet(max_wait: float, limit: float = QUIET_CORES) -> float:
    """Wait (up to ``max_wait`` s) until other processes use < ``limit`` cores; the last level."""
    t0 = time.perf_counter()
    while True:
        level = others_busy()
        if level < limit or time.perf_counter() - t0 >= max_wait:
            return level


def _alternate(
    fn: Callable[[int], Timed], repeats: int, quiet_wait: float = 0.0
) -> dict[int, list[Timed]]:
    """``fn(1)``, ``fn(2)``, ``fn(1)``, … ``repeats`` times each (slow drifts hit both).

    With ``quiet_wait`` > 0, each run first waits up to that many seconds for
    the other processes on the machine to quieten down (:func:`wait_quiet`).
    """
    runs: dict[int, list[Timed]] = {1: [], 2: []}
    for _ in range(repeats):
        for w in (1, 2):
            if quiet_wait > 0:
                wait_quiet(quiet_wait)
            runs[w].append(fn(w))
    return runs


def _median(runs: list[Timed]) -> Timed:
    """The run of median time (the upper one of an even count)."""
    return sorted(runs, key=lambda r: r.seconds)[len(runs) // 2]


def _runs_note(runs: list[Timed]) -> str:
    times = ", ".join(f"{r.seconds:.2f}" for r in runs)
    others = ", ".join(f"{r.cpu.others:.2f}" for r in runs)
    setup = max(r.setup_seconds for r in runs)
    return (
        f"median of {len(runs)} runs ({times} s); other processes busy {others} cores "
        f"meanwhile; fresh local cluster per run, its start-up and worker set-up "
        f"(≤ {setup:.1f} s: kernels loaded, see auralize.distributed.worker_setup) not timed"
    )


def bench_dask(
    quick: bool, repeats: int | None = None, quiet_wait: float | None = None
) -> list[BenchRow]:
    """Detection and synthesis on Dask, 1 vs 2 workers; memory; a 512³ × 1000 projection.

    Each measurement alternates 1- and 2-worker runs ``repeats`` times
    (default 3 with ``quick``, else 1; ``$AURALIZE_BENCH_REPEATS``) and
    reports the medians.  ``quiet_wait`` (``$AURALIZE_BENCH_QUIET_WAIT``,
    default 0): seconds each run may wait for other processes to leave the
    cores (:func:`wait_quiet`); the rows say how busy they were anyway.
    """
    from auralize.listener import ListenerPath

    if repeats is None:
        repeats = int(os.environ.get("AURALIZE_BENCH_REPEATS", 3 if quick else 1))
    repeats = max(1, int(repeats))
    if quiet_wait is None:
        quiet_wait = float(os.environ.get("AURALIZE_BENCH_QUIET_WAIT", 0.0))
    size, steps = (48, 12) if quick else (256, 100)
    label = f"{size}³ × {steps}"
    rows: list[BenchRow] = []
    t = time.perf_counter()
    path = big_file(size, steps)
    rows.append(
        BenchRow(
            "dask",
            f"chunked explosion file {label}",
            path.stat().st_size / GIB,
            "GiB",
            note=f"{path} (reused if present; {time.perf_counter() - t:.0f} s)",
        )
    )
    warm_client()
    det = _alternate(lambda w: _detect(path, w, size), repeats, quiet_wait)
    d1, d2 = _median(det[1]), _median(det[2])
    s1, t1, s2, t2 = d1.result, d1.seconds, d2.result, d2.seconds
    same = all(
        np.array_equal(a.strength, b.strength) and np.array_equal(a.index, b.index)
        for a, b in zip(s1.frames, s2.frames, strict=True)
    )
    sc1, sc2 = s1.meta["scale"], s2.meta["scale"]
    mem = max((r.mem for r in det[2] if r.mem is not None), key=lambda m: m.total)
    worker_pids = next(r.worker_pids for r in det[2] if r.mem is mem)
    client = mem.peak[os.getpid()]
    worker_peak = max(mem.peak[p] for p in worker_pids)
    in_task = max(sc2["peak_rss_per_process"], default=0)
    n_src = int(s2.frames.offsets[-1]) if hasattr(s2.frames, "offsets") else -1
    how = (
        f"psutil rss sampled every {SAMPLE_S * 1000:.0f} ms by a client thread "
        f"({mem.samples} samples; largest of {len(det[2])} runs)"
    )
    rows.append(
        BenchRow(
            "dask",
            f"detection {label}, 1 worker",
            t1,
            "s",
            note=f"{sc1['tasks']} tasks of ≤ {sc1['chunk_steps']} steps × "
            f"{len(sc1['slabs'])} slabs, plus the preparation passes; "
            f"{_runs_note(det[1])}",
        )
    )
    rows.append(
        BenchRow(
            "dask",
            f"detection {label}, 2 workers",
            t2,
            "s",
            note=("sources identical to 1 worker; " if same else "SOURCES DIFFER; ")
            + _runs_note(det[2]),
        )
    )
    ratio = t1 / t2
    rows.append(
        BenchRow(
            "dask",
            "detection throughput 2 vs 1 workers",
            ratio,
            "×",
            target="≥ 1.7×",
            met=ratio >= 1.7,
            note=f"{os.cpu_count()} cores, shared machine; ratio of the medians; "
            f"same tasks in both runs, timed from submission to the sources "
            f"file on disk",
        )
    )
    rows.append(
        BenchRow(
            "dask",
            f"detection {label} peak memory, client",
            client / GIB,
            "GiB",
            note=f"{how}; sources written by the workers, the client assembles "
            f"the output file ({n_src} source points)",
        )
    )
    rows.append(
        BenchRow(
            "dask",
            f"detection {label} peak memory, largest of 2 workers",
            worker_peak / GIB,
            "GiB",
            note=f"{how}; the tasks' own ru_maxrss (RUSAGE_SELF): {in_task / GIB:.2f} GiB",
        )
    )
    rows.append(
        BenchRow(
            "dask",
            f"detection {label} peak memory, client + 2 workers",
            mem.total / GIB,
            "GiB",
            target="≤ 4 GiB",
            met=mem.total <= 4 * GIB,
            note="largest sum of the samples taken at the same instant (shared "
            "pages counted in each process)",
        )
    )
    # projection: cost per voxel-step measured on one worker (includes the
    # mapping's two statistics passes, reading and the ghost overhead)
    per_voxel_step = t1 / (size**3 * steps)
    big = 512**3 * 1000 * per_voxel_step
    rows.append(
        BenchRow(
            "dask",
            "projection 512³ × 1000, 1 worker",
            big / 3600,
            "h",
            note=f"{per_voxel_step * 1e9:.1f} ns per voxel-step measured; "
            f"64 workers ≈ {big / 64 / 60:.0f} min, 256 ≈ {big / 256 / 60:.0f} "
            f"min (+ I/O: {512**3 * 4 * 1000 / 1e12:.1f} TB float32 read "
            f"once per pass, 3 passes); per-task memory stays ~1 GiB",
        )
    )
    # synthesis: 60 s of ring8 from these sources
    tracks = s2.tracks()
    vol_t = float(s2.times[-1] - s2.times[0])
    c = np.full(3, 0.5 * (size - 1))
    lp = ListenerPath.orbit(c, radius=0.3 * size, duration=60.0, turns=0.5, height=1.0)
    ts = 60.0 / vol_t
    # both runs split the work as render_distributed would for 2 workers
    from auralize.distributed.synth import plan_tasks

    block, groups = plan_tasks(tracks, round(lp.duration * SYNTH_RATE), 8, 2)
    syn = _alternate(
        lambda w: _synth(tracks, lp, w, time_scale=ts, block=block, groups=groups),
        repeats,
        quiet_wait,
    )
    y1, y2 = _median(syn[1]), _median(syn[2])
    a1, u1, a2, u2 = y1.result, y1.seconds, y2.result, y2.seconds
    err = float(np.max(np.abs(a1.audio - a2.audio)) / max(np.max(np.abs(a1.audio)), 1e-300))
    rows.append(
        BenchRow(
            "dask",
            "synthesis 60 s ring8, 1 worker",
            u1,
            "s",
            note=f"{tracks.n_sources} source points, {a1.meta['tasks']} tasks "
            f"({a1.meta['blocks']} blocks × {a1.meta['groups']} source groups, "
            f"the same in both runs); {_runs_note(syn[1])}",
        )
    )
    rows.append(
        BenchRow(
            "dask",
            "synthesis 60 s ring8, 2 workers",
            u2,
            "s",
            note=f"max diff to 1 worker {err:.1e} of peak; {_runs_note(syn[2])}",
        )
    )
    rows.append(
        BenchRow(
            "dask",
            "synthesis throughput 2 vs 1 workers",
            u1 / u2,
            "×",
            target="≥ 1.7×",
            met=u1 / u2 >= 1.7,
            note="ratio of the medians; timed from submission to the audio in the client",
        )
    )
    return rows


def main() -> None:  # pragma: no cover - manual use
    import argparse
    import json
    from dataclasses import asdict

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json")
    ap.add_argument("--repeats", type=int, help="runs per measurement (median reported)")
    ap.add_argument(
        "--quiet-wait",
        type=float,
        help="seconds each run may wait for other processes to leave the cores",
    )
    args = ap.parse_args()
    rows = bench_dask(args.quick, args.repeats, args.quiet_wait)
    for r in rows:
        flag = "" if r.met is None else (" [met]" if r.met else " [NOT met]")
        print(f"{r.name:55s} {r.value:10.3f} {r.unit:4s} {r.target}{flag}  {r.note}")
    if args.json:
        Path(args.json).write_text(json.dumps([asdict(r) for r in rows], indent=1))


if __name__ == "__main__":  # pragma: no cover
    main()
