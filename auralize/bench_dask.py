"""Benchmark rows of the Dask back end (issue 9), for ``auralize bench``.

:func:`bench_dask` measures, on a chunked explosion file (256³ × 100 steps,
or 48³ × 12 with ``quick``):

* distributed detection with a local cluster of 1 and of 2 single-threaded
  worker processes, writing the sources file (streamed by the client chunk
  by chunk): wall time, throughput ratio (target ≥ 1.7× on 2 cores) and the
  peak resident memory of the 2-worker run — of the client and of the
  largest worker separately, and of client + workers together (target
  ≤ 4 GiB).  Memory is sampled by a thread of this process every
  :data:`SAMPLE_S` seconds with ``psutil`` (``memory_info().rss`` of this
  process and of each worker process, whose pids the workers report), from
  the start to the end of the detection; the total is the largest sum of
  the samples taken at the same instant;
* synthesis of 60 s of ``ring8`` audio from the detected sources across 1 and
  2 workers;
* a projection for 512³ × 1000 steps from the measured cost per voxel-step.

The big file is written once (``auralize.scale.write_chunked_explosion``,
float32, ~27 GB) to ``$AURALIZE_BENCH_DIR`` (default the system temporary
folder) and reused.
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from auralize.bench import BenchRow

GIB = float(1 << 30)
#: detection thresholds of the benchmark (relative to the series' peaks)
BENCH_THRESHOLDS = ("5%", "5%", "5%")
#: seconds between two memory samples
SAMPLE_S = 0.05


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


def big_file(size: int, steps: int) -> Path:
    """The chunked explosion file for the benchmark (written once, then reused)."""
    from auralize.scale import write_chunked_explosion

    folder = Path(os.environ.get("AURALIZE_BENCH_DIR", tempfile.gettempdir())) / "auralize_bench"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"explosion_{size}x{steps}.h5"
    if not path.exists():
        write_chunked_explosion(path, size, steps, 0, generator="analytic")
    return path


def _detect(path: Path, workers: int, size: int):
    """Detection on a local cluster; the sources, seconds and the memory sampler."""
    from auralize.io import open_volume
    from auralize.scale import Runner, detect_distributed
    from auralize.sources import Thresholds

    vol = open_volume(path, fields=["log10_density"])
    out = path.with_name(f"{path.stem}_sources_{workers}w.h5")
    with Runner("distributed", workers=workers, processes=True, log=None) as run:
        worker_pids = sorted(set(run.client.run(os.getpid).values()))
        with PeakRSS([os.getpid(), *worker_pids]) as mem:
            t = time.perf_counter()  # the cluster's start-up is not timed
            series = detect_distributed(vol, mapping="paper-density",
                                        thresholds=Thresholds(*BENCH_THRESHOLDS), runner=run,
                                        output=out, restart=True, chunk_steps=10)  # fmt: skip
            elapsed = time.perf_counter() - t
        return series, elapsed, mem, worker_pids


def _synth(tracks, path, workers: int, time_scale: float):
    from auralize.scale import Runner, render_distributed

    with Runner("distributed", workers=workers, processes=True, log=None) as run:
        t = time.perf_counter()
        out = render_distributed(tracks, path, rate=44100, layout="ring8", time_scale=time_scale,
                                 runner=run)  # fmt: skip
        return out, time.perf_counter() - t


def bench_dask(quick: bool) -> list[BenchRow]:
    """Detection and synthesis on Dask, 1 vs 2 workers; memory; a 512³ × 1000 projection."""
    from auralize.listener import ListenerPath

    size, steps = (48, 12) if quick else (256, 100)
    label = f"{size}³ × {steps}"
    rows: list[BenchRow] = []
    t = time.perf_counter()
    path = big_file(size, steps)
    rows.append(BenchRow("dask", f"chunked explosion file {label}", path.stat().st_size / GIB,
                         "GiB", note=f"{path} (reused if present; {time.perf_counter() - t:.0f} s)"))  # fmt: skip
    s1, t1, _, _ = _detect(path, 1, size)
    s2, t2, mem, worker_pids = _detect(path, 2, size)
    same = all(np.array_equal(a.strength, b.strength) and np.array_equal(a.index, b.index)
               for a, b in zip(s1.frames, s2.frames, strict=True))  # fmt: skip
    sc1, sc2 = s1.meta["scale"], s2.meta["scale"]
    client = mem.peak[os.getpid()]
    worker_peak = max(mem.peak[p] for p in worker_pids)
    in_task = max(sc2["peak_rss_per_process"], default=0)
    n_src = int(s2.frames.offsets[-1]) if hasattr(s2.frames, "offsets") else -1
    how = (f"psutil rss sampled every {SAMPLE_S * 1000:.0f} ms by a client thread "
           f"({mem.samples} samples)")  # fmt: skip
    rows.append(BenchRow("dask", f"detection {label}, 1 worker", t1, "s",
                         note=f"{sc1['tasks']} tasks of {sc1['chunk_steps']} steps × "
                              f"{len(sc1['slabs'])} slabs"))  # fmt: skip
    rows.append(BenchRow("dask", f"detection {label}, 2 workers", t2, "s",
                         note="sources identical to 1 worker" if same else "SOURCES DIFFER"))  # fmt: skip
    ratio = t1 / t2
    rows.append(BenchRow("dask", "detection throughput 2 vs 1 workers", ratio, "×",
                         target="≥ 1.7×", met=ratio >= 1.7,
                         note=f"{os.cpu_count()} cores, shared machine"))  # fmt: skip
    rows.append(BenchRow("dask", f"detection {label} peak memory, client", client / GIB, "GiB",
                         note=f"{how}; sources streamed to the output file ({n_src} "
                              f"source points)"))  # fmt: skip
    rows.append(BenchRow("dask", f"detection {label} peak memory, largest of 2 workers",
                         worker_peak / GIB, "GiB",
                         note=f"{how}; the tasks' own ru_maxrss (RUSAGE_SELF): "
                              f"{in_task / GIB:.2f} GiB"))  # fmt: skip
    rows.append(BenchRow("dask", f"detection {label} peak memory, client + 2 workers",
                         mem.total / GIB, "GiB", target="≤ 4 GiB", met=mem.total <= 4 * GIB,
                         note="largest sum of the samples taken at the same instant (shared "
                              "pages counted in each process)"))  # fmt: skip
    # projection: cost per voxel-step measured on one worker (includes the
    # mapping's two statistics passes, reading and the ghost overhead)
    per_voxel_step = t1 / (size**3 * steps)
    big = 512**3 * 1000 * per_voxel_step
    rows.append(BenchRow("dask", "projection 512³ × 1000, 1 worker", big / 3600, "h",
                         note=f"{per_voxel_step * 1e9:.1f} ns per voxel-step measured; "
                              f"64 workers ≈ {big / 64 / 60:.0f} min, 256 ≈ {big / 256 / 60:.0f} "
                              f"min (+ I/O: {512**3 * 4 * 1000 / 1e12:.1f} TB float32 read "
                              f"once per pass, 3 passes); per-task memory stays ~1 GiB"))  # fmt: skip
    # synthesis: 60 s of ring8 from these sources
    tracks = s2.tracks()
    vol_t = float(s2.times[-1] - s2.times[0])
    c = np.full(3, 0.5 * (size - 1))
    lp = ListenerPath.orbit(c, radius=0.3 * size, duration=60.0, turns=0.5, height=1.0)
    ts = 60.0 / vol_t
    a1, u1 = _synth(tracks, lp, 1, ts)
    a2, u2 = _synth(tracks, lp, 2, ts)
    err = float(np.max(np.abs(a1.audio - a2.audio)) / max(np.max(np.abs(a1.audio)), 1e-300))
    rows.append(BenchRow("dask", "synthesis 60 s ring8, 1 worker", u1, "s",
                         note=f"{tracks.n_sources} source points, {a1.meta['blocks']} blocks"))  # fmt: skip
    rows.append(BenchRow("dask", "synthesis 60 s ring8, 2 workers", u2, "s",
                         note=f"max diff to 1 worker {err:.1e} of peak"))  # fmt: skip
    rows.append(BenchRow("dask", "synthesis throughput 2 vs 1 workers", u1 / u2, "×",
                         target="≥ 1.7×", met=u1 / u2 >= 1.7))  # fmt: skip
    return rows


def main() -> None:  # pragma: no cover - manual use
    import argparse
    import json
    from dataclasses import asdict

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = bench_dask(args.quick)
    for r in rows:
        flag = "" if r.met is None else (" [met]" if r.met else " [NOT met]")
        print(f"{r.name:55s} {r.value:10.3f} {r.unit:4s} {r.target}{flag}  {r.note}")
    if args.json:
        Path(args.json).write_text(json.dumps([asdict(r) for r in rows], indent=1))


if __name__ == "__main__":  # pragma: no cover
    main()
