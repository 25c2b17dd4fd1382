"""Benchmark rows of the immersive formats (AmbiX encoding, binaural decoding).

:func:`immersive_rows` times the stages that a binaural or Ambisonic render
adds to a loudspeaker render, on explosion-like signals (broadband noise
bursts from moving emitters):

* the AmbiX order-3 encoding gains (:func:`auralize.spatial.ambisonics.sh_gains`)
  per million directions — a renderer evaluates them per emitter and sample
  (or per piece);
* encoding moving emitters into ambix3 in numpy (gains per sample, multiply
  and sum), in emitter-seconds of audio per second;
* the binaural decoder (16 channels → 2 ears, SH-domain filters, FFT
  overlap-add), whole signals and 50 ms live blocks (p95 against the live
  target of half a block);
* live binaural blocks of the 32³ explosion (:func:`auralize.pipeline.render` with
  ``layout="binaural", block=2205``, the blocks ``auralize play`` plays: the synthesis of
  the block to the ear receivers, the ears' filters and the 20 Hz high-pass, the
  worker's whole job per 50 ms block at 44.1 kHz), p95 of the wall
  time against half a block, with the CPU time per block and the load average
  in the note (the machine may be shared).

:func:`binaural_render_row` times the whole binaural render of the
synthesis benchmark's explosion (:func:`auralize.bench.runner.bench_synthesis`).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from auralize.plugins import BenchRow
from auralize.runtime.timing import batch_times


def _moving_emitters(n_em: int, n: int, rate: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Explosion-like signals ``(n_em, n)`` (decaying noise bursts) and per-sample
    listener-frame directions ``(n_em, n, 3)`` (each emitter circling at its own rate)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    onset = rng.uniform(0, t[-1] * 0.8, n_em)
    env = np.exp(-np.clip(t[None, :] - onset[:, None], 0, None) * 8.0) * (
        t[None, :] >= onset[:, None]
    )
    sig = rng.normal(size=(n_em, n)) * env
    w = rng.uniform(-1.5, 1.5, n_em)[:, None]
    el = rng.uniform(-0.6, 0.6, n_em)[:, None]
    az = w * t[None, :] + rng.uniform(0, 2 * np.pi, n_em)[:, None]
    d = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el) + 0 * az], -1)
    return sig, d


def immersive_rows(quick: bool) -> list[BenchRow]:
    """Timings of AmbiX encoding and binaural decoding (see the module docstring)."""
    from auralize.spatial.ambisonics import sh_gains
    from auralize.spatial.hrtf import BinauralDecoder, default_hrirs

    rate = 48000
    rows: list[BenchRow] = []
    n_dir = 200_000 if quick else 1_000_000
    d = np.random.default_rng(1).normal(size=(n_dir, 3))
    t = float(np.median(batch_times(lambda: sh_gains(3, d), repeat=3, min_time=0.3)))
    rows.append(
        BenchRow(
            "immersive",
            "ambix3 SH gains (16 per direction)",
            t * 1e6 / n_dir,
            "s per million directions",
            note=f"numpy, {n_dir:,} directions per call",
        )
    )
    n_em, secs = (10, 1.0) if quick else (20, 2.0)
    sig, dirs = _moving_emitters(n_em, int(secs * rate), rate)

    def encode() -> np.ndarray:
        out = np.zeros((16, sig.shape[1]))
        for s in range(n_em):  # one emitter at a time bounds the memory
            out += sh_gains(3, dirs[s]) * sig[s]
        return out

    t0 = time.perf_counter()
    amb = encode()
    t_enc = time.perf_counter() - t0
    rows.append(
        BenchRow(
            "immersive",
            f"ambix3 encoding of {n_em} moving emitters, {secs:g} s (numpy, per-sample gains)",
            n_em * secs / t_enc,
            "emitter-seconds per second",
            note="the numba kernels pan per piece instead; this is the numpy reference cost",
        )
    )
    dur = 2.0 if quick else 10.0
    reps = int(np.ceil(dur * rate / amb.shape[1]))
    long = np.tile(amb, (1, reps))[:, : int(dur * rate)]
    hrirs = default_hrirs(rate)
    t0 = time.perf_counter()
    dec = BinauralDecoder(hrirs, 3)
    t_setup = time.perf_counter() - t0
    t = float(np.median(batch_times(lambda: dec.process(long), repeat=3, min_time=0.5)))
    speed = dur / t
    rows.append(
        BenchRow(
            "immersive",
            f"binaural decoder ambix3 → 2 ears, {dur:g} s at {rate} Hz",
            speed,
            "× real time",
            note=f"{1000 / speed:.1f} ms per second of audio, {100 * 20 / speed:.0f} % of the "
            f"budget of a binaural render at 20× real time; SH-domain MagLS filters of the "
            f"spherical-head model, "
            f"{dec.filters.shape[2]} taps, built in {t_setup:.2f} s",
        )
    )
    block = rate // 20
    live = BinauralDecoder(hrirs, 3)
    times = []
    for k in range(60 if quick else 200):
        s0 = (k * block) % (long.shape[1] - block)
        t0 = time.perf_counter()
        live.process(long[:, s0 : s0 + block])
        times.append(time.perf_counter() - t0)
    p95 = float(np.percentile(times[5:], 95)) * 1e3
    rows.append(
        BenchRow(
            "immersive",
            "binaural decoder, 50 ms live blocks: p95",
            p95,
            "ms",
            target="< 25 ms (half a block)",
            met=p95 < 25.0,
            note=f"{p95 / 50 * 100:.1f} % of the block",
        )
    )
    rows.append(live_binaural_row(quick))
    return rows


def live_binaural_row(quick: bool) -> BenchRow:
    """p95 time of a live binaural block (see the module docstring)."""
    import os

    from auralize.bench import BENCH_THRESHOLDS
    from auralize.datasets import make_explosion
    from auralize.listener import ListenerPath
    from auralize.pipeline import render
    from auralize.sources import Thresholds, detect
    from auralize.spatial.layouts import synthesis_layout

    steps = 60
    vol = make_explosion(size=32, steps=steps).load()
    tracks = detect(vol, mapping="paper-density", thresholds=Thresholds(*BENCH_THRESHOLDS)).tracks()
    c = vol.center
    path = ListenerPath.line(
        c + [-0.4 * c[0], -0.3 * c[1], 0], c + [0.4 * c[0], 0.35 * c[1], 2], duration=steps / 30.0
    )
    blocks = render(tracks, path, layout="binaural", rate=44100, block=2205)
    blocks.block(0)  # the tracks' pieces and the decoder's spectra are built once
    wall, cpu = [], []
    for _ in range(1 if quick else 3):
        for i in range(blocks.n_blocks):
            t0, c0 = time.perf_counter(), time.process_time()
            blocks.block(i)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
    w, cp = 1e3 * np.asarray(wall), 1e3 * np.asarray(cpu)
    p95 = float(np.percentile(w, 95))
    return BenchRow(
        "immersive",
        "live binaural, 32³ explosion, 50 ms blocks at 44.1 kHz: p95",
        p95,
        "ms",
        target="< 25 ms (half a block)",
        met=p95 < 25.0,
        note=f"wall mean {w.mean():.1f} ms, max {w.max():.1f}; CPU per block p95 "
        f"{np.percentile(cp, 95):.1f} ms, mean {cp.mean():.1f} (all threads); "
        f"{blocks.n_blocks} blocks × {len(w) // blocks.n_blocks}; synthesis to "
        f"{synthesis_layout('binaural').name}; load average {os.getloadavg()[0]:.1f}",
    )


def binaural_render_row(tracks: Any, path: Any, size: int) -> BenchRow:
    """The binaural render of the explosion's tracks along ``path``
    (:func:`auralize.emitters.timbre.render_timbre`, ``physical``: the synthesis
    to the two ear receivers, the ears' filters and the 20 Hz high-pass),
    against the target of 20× real time; the synthesis of the intermediate
    alone in the note."""
    import functools

    from auralize.emitters.synthesis import render_tracks
    from auralize.emitters.timbre import render_timbre
    from auralize.spatial.layouts import output_stage

    fn = functools.partial(render_timbre, tracks, path, layout="binaural", timbre="physical")
    fn()  # the decoder's filters and the tracks' pieces are built once
    times = batch_times(fn, repeat=5)
    t = float(np.median(times))
    lay = output_stage("binaural", 44100).synthesis_layout
    t_amb = float(
        np.median(batch_times(functools.partial(render_tracks, tracks, path, layout=lay), repeat=3))
    )
    speed = path.duration / t
    return BenchRow(
        "synthesis",
        f"explosion {size}³ → binaural, {path.duration:.2f} s of audio",
        speed,
        "× real time",
        target="≥ 20×" if size == 64 else "",
        met=speed >= 20 if size == 64 else None,
        note=f"median of 5 batches (fastest {path.duration / times.min():.1f}×); the synthesis "
        f"to {lay.name} alone {path.duration / t_amb:.1f}× ({lay.n_channels} channels"
        + (f", {len(lay.meta['receivers'])} receivers" if lay.meta.get("receivers") else "")
        + ")",
    )
