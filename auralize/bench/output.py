"""``auralize bench`` rows of the output layer.

* the 64³ explosion (300 steps at 30 Hz: 10 s of data, thresholds
  :data:`auralize.bench.runner.BENCH_THRESHOLDS`, ≥ 10,000 active sources per step)
  rendered along a 10 s path to ring8 — target ≥ 50× faster than real time;
* live playback at 44.1 kHz × 8 channels in 50 ms blocks — per-block
  synthesis time of the blocks ``auralize play`` plays
  (:func:`auralize.pipeline.render` with ``block=``, the 20 Hz high-pass included:
  the worker's job) against the 50 ms budget;
* an actual live playback (:func:`auralize.audio.live.play`) on a file-backed ALSA
  device (``file`` plugin over ``null``, defined in a temporary
  ``$XDG_CONFIG_HOME/alsa/asoundrc``) — underruns counted.  The null device
  is not paced by a clock, so this row shows whether synthesis keeps ahead of
  a consumer with a half-block wait budget.

``quick`` uses the 32³ explosion over 2 s.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np

from auralize.bench.runner import BENCH_THRESHOLDS, BenchRow, best_of


def _scene(quick: bool):  # type: ignore[no-untyped-def]
    from auralize.datasets.synthetic import make_explosion
    from auralize.listener import ListenerPath
    from auralize.sources.detection import Thresholds, detect

    size, steps = (32, 60) if quick else (64, 300)
    vol = make_explosion(size=size, steps=steps).load()
    series = detect(vol, mapping="paper-density", thresholds=Thresholds(*BENCH_THRESHOLDS))
    tracks = series.tracks()
    c = vol.center
    dur = steps / 30.0
    path = ListenerPath.line(
        c + [-0.4 * c[0], -0.3 * c[1], 0], c + [0.4 * c[0], 0.35 * c[1], 2], duration=dur
    )
    return size, tracks, path


def _live_on_file_device(tracks, path, seconds: float) -> BenchRow:  # type: ignore[no-untyped-def]
    from auralize.audio.live import play
    from auralize.audio.output import refresh_devices
    from auralize.pipeline import render

    old = os.environ.get("XDG_CONFIG_HOME")
    with tempfile.TemporaryDirectory() as tmp:
        cfg = Path(tmp) / "alsa"
        cfg.mkdir()
        (cfg / "asoundrc").write_text(
            'pcm.auralize_bench {\n type file\n slave.pcm "null"\n'
            f' file "{Path(tmp) / "out.raw"}"\n format "raw"\n}}\n'
        )
        os.environ["XDG_CONFIG_HOME"] = tmp
        try:
            refresh_devices()
            blocks = render(tracks, path, layout="ring8", block=2205, duration=seconds)
            rep = play(blocks, device="auralize_bench")
        finally:
            if old is None:
                os.environ.pop("XDG_CONFIG_HOME", None)
            else:
                os.environ["XDG_CONFIG_HOME"] = old
            refresh_devices()
    return BenchRow(
        "output",
        f"live play, file-backed ALSA device, {seconds:.1f} s ring8",
        rep.underruns,
        "underruns",
        target="0",
        met=rep.underruns == 0,
        note=f"synthesis {rep.synth_ms_mean:.1f} ms/block mean, {rep.synth_ms_max:.1f} max; "
        f"wall {rep.wall_s:.2f} s",
    )


def bench_output(quick: bool) -> list[BenchRow]:
    """Benchmark rows of the output layer (see the module docstring)."""
    from auralize.emitters.synthesis import render_tracks
    from auralize.pipeline import render

    t0 = time.perf_counter()
    size, tracks, path = _scene(quick)
    t_scene = time.perf_counter() - t0
    dur = path.duration
    rows = []
    t = best_of(
        lambda: render_tracks(tracks, path, layout="ring8"),
        repeat=1 if not quick else 3,
        min_time=0.0,
    )
    rows.append(
        BenchRow(
            "output",
            f"explosion {size}³ → ring8 file, {dur:.0f} s path",
            dur / t,
            "× real time",
            target="≥ 50×",
            met=dur / t >= 50,
            note=f"{t:.2f} s for {dur:.0f} s; {tracks.n_sources} source points, "
            f"{int(np.count_nonzero(tracks.q))} (source, step) pairs; data made in {t_scene:.0f} s",
        )
    )
    blocks = render(tracks, path, layout="ring8", rate=44100, block=2205)
    blocks.block(0)
    times = []
    for i in range(blocks.n_blocks):
        t1 = time.perf_counter()
        blocks.block(i)
        times.append(time.perf_counter() - t1)
    ms = 1e3 * np.asarray(times)
    p95 = float(np.percentile(ms, 95))
    rows.append(
        BenchRow(
            "output",
            "live: synthesis per 50 ms block, 44.1 kHz × 8 ch",
            p95,
            "ms (95th pct)",
            target="≤ 50 ms",
            met=float(ms.max()) <= 50.0,
            note=f"mean {ms.mean():.1f} ms, max {ms.max():.1f} ms over {blocks.n_blocks} blocks; "
            f"{int(np.sum(ms > 50))} over budget",
        )
    )
    try:
        rows.append(_live_on_file_device(tracks, path, min(dur, 2.0)))
    except Exception as exc:  # a benchmark reports, it does not crash
        rows.append(
            BenchRow(
                "output",
                "live play on a file-backed ALSA device",
                float("nan"),
                "",
                note=f"not run: {exc}",
            )
        )
    return rows
