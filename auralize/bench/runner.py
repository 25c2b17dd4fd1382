"""``auralize bench``: timings side by side with the papers' tables.

Core figures (paper 003 §4.2): source detection per time step for grids of
10³ … 256³ (all three types + ΔV spheres, in one pass; the paper timed each
type separately) and synthesis time per audio frame.  Sound-model plugins add
their own rows through a ``bench(quick)`` class method returning
:class:`BenchRow` objects.

This is a benchmark, not a test: it prints figures and whether each target
was met; it fails nothing.
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import json
import os
import platform
import time
from dataclasses import asdict
from typing import Any

import numpy as np

from auralize.plugins import BenchRow
from auralize.runtime.timing import batch_times, best_of

#: paper 003 §4.2, seconds per time step (monopole, dipole, quadrupole)
PAPER_DETECT_S = {
    10: (0.064, 0.056, 0.065),
    20: (4.001, 3.912, 4.074),
    30: (44.990, 42.735, 46.812),
    40: (261.664, 254.755, 264.676),
    50: (1011.354, 1002.721, 1012.081),
    64: (6201.703, 6183.029, 6210.341),
}
#: paper 003 §4.2, microseconds per audio frame
PAPER_FRAME_US = {10: 7, 20: 16, 30: 23, 40: 65, 50: 102, 64: 236}


#: detection thresholds of the synthesis benchmarks: they give the 64³ explosion
#: at least 10,000 active source points per step on average (the synthesis target case)
BENCH_THRESHOLDS = ("0.6%", "0.1%", "0.05%")


def _smooth_volume(n: int, steps: int = 3, seed: int = 0):
    """A log10-density field with explosion-like structure at any size (for timing)."""
    from scipy import ndimage

    from auralize.volume import TimeVolume

    rng = np.random.default_rng(seed)
    base = ndimage.gaussian_filter(rng.normal(size=(n, n, n)), max(n / 32, 1.0), mode="wrap")
    x = np.linspace(-1, 1, n)
    r = np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)
    frames = []
    for k in range(steps):
        shell = np.exp(-(((r - 0.3 - 0.05 * k) / 0.06) ** 2))
        frames.append(np.clip(base / base.std() * 0.3 + 1.2 * shell - 1.0, -2.2, 0.5))
    return TimeVolume.from_arrays({"log10_density": np.stack(frames)}, times=np.arange(steps) / 30)


def bench_detection(sizes: list[int]) -> list[BenchRow]:
    from auralize.sources.detection import (
        StepCache,
        Thresholds,
        classify_sources,
        steady_strength,
        step_strengths,
        strength_stats,
    )
    from auralize.sources.mapping import get_mapping

    rows = []
    per_step = {}
    for n in sizes:
        vol = _smooth_volume(n)
        m = get_mapping("paper-density")
        m.prepare(vol)
        qmean = steady_strength(vol, m)
        thr = Thresholds().resolve(strength_stats(vol, m, qmean=qmean))
        cache = StepCache(vol, m, qmean=qmean)
        for k in range(3):
            cache.get(k)
        buf = np.empty((3, n, n, n))
        kinds = np.empty((n, n, n), dtype=np.int8)

        def run(cache=cache, buf=buf, thr=thr, vol=vol, kinds=kinds) -> None:
            s = step_strengths(vol, cache, 1, buf)
            classify_sources(s, thr, vol.spacing, kinds=kinds)  # as detection classifies

        t = best_of(run, repeat=3 if n >= 200 else 5)
        tmap = best_of(functools.partial(m.map, vol, 1), repeat=3)
        per_step[n] = t
        paper = PAPER_DETECT_S.get(n)
        rows.append(
            BenchRow(
                "detection",
                f"{n}³ per step (3 types + ΔV)",
                t * 1e3,
                "ms",
                target="≤ 10 ms" if n == 64 else "",
                met=(t <= 0.010) if n == 64 else None,
                paper=f"{sum(paper):.3f} s (sum of 3 types)" if paper else "",
                note=f"mapping (paper-density) {tmap * 1e3:.1f} ms more",
            )
        )
    if 64 in per_step and 128 in per_step:
        ratio = per_step[128] / per_step[64]
        rows.append(
            BenchRow(
                "detection",
                "128³ / 64³ cost (8× voxels)",
                ratio,
                "×",
                target="≤ 10×",
                met=ratio <= 10,
            )
        )
    return rows


class _CountedFrames:
    """A FrameSource that counts its reads (the bench's read count)."""

    def __init__(self, src: Any, counter: list[int]) -> None:
        self.src, self.counter = src, counter

    @property
    def n_steps(self) -> int:
        return int(self.src.n_steps)

    @property
    def frame_shape(self) -> tuple[int, ...]:
        return tuple(self.src.frame_shape)

    def read(self, step: int) -> Any:
        self.counter[0] += 1
        return self.src.read(step)


def bench_detection_whole(quick: bool) -> list[BenchRow]:
    """Detection through the API, whole process: ``detect_sources`` on the 64³
    explosion held in memory (default mapping and ``auto`` thresholds: the
    mapping's statistics, the steady anchors, the threshold statistics and
    detection), total time over the steps, with the frame reads and mapping
    evaluations it made."""
    from auralize.datasets.synthetic import make_explosion
    from auralize.pipeline import detect_sources

    steps = 20 if quick else 70
    detect_sources(make_explosion(size=16, steps=6))  # compiled kernels loaded, not timed
    vol = make_explosion(size=64, steps=steps).load()
    reads = [0]
    for name in list(vol.fields):
        vol.fields[name] = _CountedFrames(vol.fields[name], reads)
    times = []
    for _ in range(2):
        reads[0] = 0
        t0 = time.perf_counter()
        series = detect_sources(vol)
        times.append(time.perf_counter() - t0)
    t = min(times) / steps
    meta: dict[str, Any] = dict(series.meta)
    return [
        BenchRow(
            "detection",
            "detection per step, 64³, whole process",
            t * 1e3,
            "ms",
            target="≤ 10 ms",
            met=t <= 0.010,
            note=f"detect_sources on the explosion, {steps} steps in memory, mapping "
            f"{meta['mapping']['name']}, auto thresholds (floor "
            f"{meta['thresholds']['floor']}): {reads[0] / steps:.2f} frame reads "
            f"per step (it reads one field); best of 2",
        )
    ]


def bench_synthesis(quick: bool) -> list[BenchRow]:
    from auralize.datasets.synthetic import make_explosion
    from auralize.emitters.synthesis import render_tracks
    from auralize.listener import ListenerPath
    from auralize.sources.detection import Thresholds, detect

    size = 32 if quick else 64
    vol = make_explosion(size=size).load()
    th = Thresholds(*BENCH_THRESHOLDS)
    t0 = time.perf_counter()
    series = detect(vol, mapping="paper-density", thresholds=th)
    t_detect = time.perf_counter() - t0
    tracks = series.tracks()
    active = float(np.mean([sum(c.values()) for c in series.counts()]))
    c = vol.center
    path = ListenerPath.line(
        c + [-0.4 * c[0], -0.3 * c[1], 0],
        c + [0.4 * c[0], 0.35 * c[1], 2],
        duration=float(vol.times[-1] + 0.1),
    )
    rows = [
        BenchRow(
            "synthesis",
            f"explosion {size}³: source points",
            active,
            "per step (mean)",
            target="≥ 10,000" if size == 64 else "",
            met=(active >= 10_000) if size == 64 else None,
            note=f"{tracks.n_sources} distinct vertices; detection of {vol.n_steps} steps "
            f"{t_detect:.2f} s",
        )
    ]
    # the first render of a set of tracks builds its runs of sounding pieces
    # (mono; panned layouts: its list of pieces), reused by every later render:
    # other paths, blocks, live
    from auralize.sources.detection import SourceTracks

    fresh = SourceTracks(tracks.positions, tracks.q, tracks.radius, tracks.times)
    t0 = time.perf_counter()
    render_tracks(fresh, path, duration=1e-3)
    t_prep = time.perf_counter() - t0
    for layout in ("mono", "ring8"):
        times = batch_times(functools.partial(render_tracks, tracks, path, layout=layout), repeat=5)
        t = float(np.median(times))
        dur = path.duration
        speed = dur / t
        n_ch = 1 if layout == "mono" else 8
        rows.append(
            BenchRow(
                "synthesis",
                f"explosion {size}³ → {layout}, {dur:.2f} s of audio",
                speed,
                "× real time",
                target="≥ 100× per channel" if layout == "mono" else "",
                met=speed >= 100 if layout == "mono" else None,
                paper=f"{PAPER_FRAME_US[64]} µs/frame ≈ 0.1× real time" if size == 64 else "",
                note=f"median of 5 batches (fastest {dur / times.min():.0f}×); "
                f"{t / (dur * 44100) * 1e6:.3f} µs per audio frame"
                + (
                    f"; {speed * n_ch:.0f}× real time per channel"
                    if n_ch > 1
                    else f"; runs of pieces built once per tracks in {t_prep:.2f} s"
                ),
            )
        )
    rows += _timbre_rows(tracks, path, size)
    rows += whole_field_rows(vol, size)
    from auralize.bench.immersive import binaural_render_row

    rows.append(binaural_render_row(tracks, path, size))
    # recorded paths (as the viewer records them): captures every 50 or 100 ms
    # of playback (17 or 33 ms of data at time scale 3, half a data step or
    # one), so most pieces' arrivals cross a capture; they are split there
    # (the listener's velocity changes) into parts summed in SIMD loops
    for hz, what in ((20.0, "a 20 Hz orbit"), (10.0, "a 10 Hz recorded path")):
        orbit = ListenerPath.orbit(
            c,
            radius=0.3 * size,
            duration=3 * float(vol.times[-1]),
            turns=0.5,
            height=1.0,
            rate_hz=hz,
        )
        times = batch_times(
            functools.partial(render_tracks, tracks, orbit, layout="ring8", time_scale=3.0),
            repeat=5,
        )
        speed = orbit.duration / float(np.median(times))
        rows.append(
            BenchRow(
                "synthesis",
                f"explosion {size}³ → ring8 along {what}"
                + (f", {orbit.duration:.2f} s" if hz == 20.0 else ""),
                speed,
                "× real time",
                target="≥ 50× real time" if hz == 10.0 and size == 64 else "",
                met=speed >= 50 if hz == 10.0 and size == 64 else None,
                note=f"{orbit.duration:.2f} s, time scale 3, {orbit.times.size} captures; median of "
                f"5 batches (fastest "
                f"{orbit.duration / times.min():.0f}×); {speed * 8:.0f}× real time per channel",
            )
        )
    return rows


def whole_field_rows(vol: Any, size: int) -> list[BenchRow]:
    """The default render of the explosion (``auralize render FILE``: the whole field
    heard, the default orbit, ``timbre="auto"``, 10 s): building the field's rows
    (every point's strengths, the blocks' proxies), the render from them to mono
    and ring8, and the compression's error against every point heard as itself."""
    from auralize.emitters.synthesis import render_tracks
    from auralize.emitters.timbre import render_timbre
    from auralize.pipeline import heard_sound, plan_render
    from auralize.sources.field import field_tracks

    rows: list[BenchRow] = []
    plan = plan_render(vol, None)
    t0 = time.perf_counter()
    hs = heard_sound(vol, path=plan.path)
    t_field = time.perf_counter() - t0
    fm = hs.meta["field"]
    rows.append(
        BenchRow(
            "whole field",
            f"explosion {size}³: field rows",
            t_field,
            "s",
            note=f"{fm['valid_points']:,} points × {vol.n_steps} steps → {fm['rows']:,} rows "
            f"(blocks of {fm['block'][0]}³, {fm['proxies_per_block']} proxies)",
        )
    )
    kw: dict[str, Any] = dict(time_scale=plan.time_scale, duration=plan.duration, lead=plan.lead)
    for layout, target in (("mono", 100.0), ("ring8", 50.0)):
        fn = functools.partial(
            render_timbre,
            hs.tracks,
            plan.path,
            layout=layout,
            timbre="auto",
            by_type=hs.by_type,
            **kw,
        )
        times = batch_times(fn, repeat=5)
        t = float(np.median(times))
        speed = plan.duration / t
        total = plan.duration / (t + t_field)
        rows.append(
            BenchRow(
                "whole field",
                f"explosion {size}³ → {layout}, default render",
                speed,
                "× real time",
                target=f"≥ {target:g}×" if size == 64 else "",
                met=speed >= target if size == 64 else None,
                note=f"{plan.duration:g} s of audio in {t * 1e3:.0f} ms (median of 5, timbre auto → "
                f"{fn().meta['timbre']}); with the field rows built: {total:.1f}× real time",
            )
        )
    every = field_tracks(vol, hs_mapping(vol), block=1).tracks()
    kw4: dict[str, Any] = {**kw, "rate": 4000}
    a = render_tracks(every, plan.path, **kw4).audio[0]
    b = render_tracks(hs.tracks, plan.path, **kw4).audio[0]
    A, B = np.fft.rfft(a), np.fft.rfft(b)
    f = np.fft.rfftfreq(a.size, 1 / 4000)
    nyq = 0.5 / (float(np.median(np.diff(vol.times))) * plan.time_scale)
    band = f <= nyq
    e_in = float(np.sqrt(np.sum(np.abs(A - B)[band] ** 2) / np.sum(np.abs(A)[band] ** 2)))
    e_all = float(np.sqrt(np.sum(np.abs(A - B) ** 2) / np.sum(np.abs(A) ** 2)))
    above = float(np.sum(np.abs(A)[~band] ** 2) / np.sum(np.abs(A) ** 2))
    rows.append(
        BenchRow(
            "whole field",
            f"explosion {size}³: compression error",
            100 * e_in,
            "% RMS",
            target="≤ 2 %",
            met=e_in <= 0.02,
            note=f"below the data's Nyquist ({nyq:.3g} Hz in playback), against every point heard "
            f"as itself along the default orbit; all frequencies {100 * e_all:.1f} % (the "
            f"interpolation's images above it hold {100 * above:.1f} % of the energy)",
        )
    )
    return rows


def _cpu_time(fn: Any, repeat: int = 3) -> float:
    """Median CPU time (s, every thread of the process) of ``fn`` over ``repeat``
    calls after one warm-up: on a shared machine wall time measures the
    neighbours too."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return float(np.median(times))


def scaling_scene(n_sources: int, steps: int, seed: int = 0) -> Any:
    """Tracks of ``n_sources`` points in a 20 m cube over ``steps`` data steps at
    30 Hz, each sounding (a random strength) at about half of them: the
    synthesis's own cost, without a detection."""
    from auralize.sources.detection import SourceTracks

    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n_sources, steps)) * (rng.uniform(size=(n_sources, steps)) < 0.5)
    return SourceTracks(
        positions=rng.uniform(-10.0, 10.0, size=(n_sources, 3)),
        q=q,
        radius=np.full(n_sources, 0.2),
        times=np.arange(steps) / 30.0,
    )


def scaling_rows(quick: bool) -> list[BenchRow]:
    """No cliffs: the synthesis's CPU time against the number of sources (1k, 10k,
    100k), the duration (1× and 3×) and the layout (stereo against ring8), on
    :func:`scaling_scene` heard from an orbit 30 m from its centre (captures
    at 20 Hz, the head sweeping, so that every speaker hears the sources),
    1 s of data per 10 s of audio.  ``quick``: 2 s and 1k, 10k sources."""
    from auralize.emitters.synthesis import render_tracks
    from auralize.listener import ListenerPath

    dur = 2.0 if quick else 10.0
    steps = round(30 * dur / 10.0) + 1

    def run(k: int, mult: int, layout: str, face: str = "sweep") -> float:
        tracks = scaling_scene(k, steps * mult)
        # (half a turn per 10 s of audio: 94 m per data second)
        path = ListenerPath.orbit(
            (0.0, 0.0, 0.0),
            radius=30.0,
            duration=dur * mult,
            turns=0.05 * dur * mult,
            height=1.0,
            face=face,
        )
        return _cpu_time(
            functools.partial(
                render_tracks, tracks, path, time_scale=10.0, layout=layout, duration=dur * mult
            )
        )

    rows: list[BenchRow] = []
    sizes = (1_000, 10_000) if quick else (1_000, 10_000, 100_000)
    t_k = {k: run(k, 1, "ring8") for k in sizes}
    for k, t in t_k.items():
        rows.append(
            BenchRow(
                "scaling",
                f"{k // 1000}k sources → ring8, {dur:g} s",
                t,
                "CPU-s",
                note=f"{steps} data steps, orbit at 20 Hz captures",
            )
        )
    if 100_000 in t_k:
        r = t_k[100_000] / t_k[10_000]
        rows.append(
            BenchRow(
                "scaling",
                "10× sources (10k → 100k), ring8",
                r,
                "× CPU time",
                target="≤ 11×",
                met=r <= 11.0,
            )
        )
    else:
        r = t_k[10_000] / t_k[1_000]
        rows.append(
            BenchRow(
                "scaling",
                "10× sources (1k → 10k), ring8",
                r,
                "× CPU time",
                note="the target (≤ 11×) is set for 10k → 100k (full bench)",
            )
        )
    for layout in ("mono", "ring8"):
        one = t_k[10_000] if layout == "ring8" else run(10_000, 1, layout)
        r = run(10_000, 3, layout) / one
        rows.append(
            BenchRow(
                "scaling",
                f"3× duration (10k sources), {layout}",
                r,
                "× CPU time",
                target="≤ 3.3×",
                met=r <= 3.3,
                note=f"{dur:g} s → {3 * dur:g} s of audio from 3× the data steps; "
                f"{one:.3f} CPU-s at 1×",
            )
        )
    # stereo folds the directions behind to the front and pans them by its one
    # speaker pair, as ring8 pans by its pairs: the head sweeping puts the
    # sources all around, facing them keeps them in front
    for face, what in (("sweep", "head sweeping"), ("center", "facing the sources")):
        t_st = run(10_000, 1, "stereo", face)
        t_r8 = t_k[10_000] if face == "sweep" else run(10_000, 1, "ring8", face)
        r = t_st / t_r8
        rows.append(
            BenchRow(
                "scaling",
                f"stereo / ring8 (10k sources, {what})",
                r,
                "× CPU time",
                target="≤ 1×",
                met=r <= 1.0,
                note=f"stereo {t_st:.3f} CPU-s, ring8 {t_r8:.3f} CPU-s, {dur:g} s",
            )
        )
    return rows


def timbre_cost_rows(quick: bool) -> list[BenchRow]:
    """What the default timbre costs: ``render_timbre(timbre="auto")`` (``extended``
    on the explosion, whose data are slow) against ``timbre="physical"`` of the
    same default render (the whole field heard along the default orbit, 10 s),
    CPU time, median of 5."""
    from auralize.datasets.synthetic import make_explosion
    from auralize.emitters.timbre import render_timbre
    from auralize.pipeline import heard_sound, plan_render

    size = 32 if quick else 64
    vol = make_explosion(size=size).load()
    plan = plan_render(vol, None)
    hs = heard_sound(vol, path=plan.path)
    kw: dict[str, Any] = dict(
        time_scale=plan.time_scale, duration=plan.duration, lead=plan.lead, by_type=hs.by_type
    )
    rows: list[BenchRow] = []
    for layout in ("mono", "stereo", "ring8"):
        t = {}
        used = ""
        for timbre in ("physical", "auto"):
            fn = functools.partial(
                render_timbre, hs.tracks, plan.path, layout=layout, timbre=timbre, **kw
            )
            t[timbre] = _cpu_time(fn, repeat=5)
            used = str(fn().meta["timbre"])
        r = t["auto"] / t["physical"]
        rows.append(
            BenchRow(
                "timbre",
                f"explosion {size}³ → {layout}: default timbre / physical",
                r,
                "× CPU time",
                target="≤ 1.25×",
                met=r <= 1.25,
                note=f"auto ({used}) {t['auto'] * 1e3:.0f} ms, physical {t['physical'] * 1e3:.0f} ms "
                f"CPU for {plan.duration:g} s of audio (median of 5)",
            )
        )
    rows.append(_timbre_whole_call_row(size))
    return rows


def _timbre_whole_call_row(size: int) -> BenchRow:
    """The same comparison for the call a user makes: :func:`auralize.render` of the
    explosion with its defaults (the field's rows built, the default orbit, 10 s,
    mono) against ``timbre="physical"``, each on a freshly loaded volume (nothing
    cached from the run before), CPU time, median of 3."""
    import auralize
    from auralize.datasets.synthetic import make_explosion

    def call(timbre: str) -> float:
        vol = make_explosion(size=size).load()
        t0 = time.process_time()
        auralize.render(vol, timbre=timbre)
        return time.process_time() - t0

    call("auto")  # kernels loaded, textures cached
    t: dict[str, list[float]] = {"physical": [], "auto": []}
    for _ in range(3):
        for timbre in t:
            t[timbre].append(call(timbre))
    auto, phys = float(np.median(t["auto"])), float(np.median(t["physical"]))
    r = auto / phys
    return BenchRow(
        "timbre",
        f"auralize.render(explosion {size}³): default timbre / physical",
        r,
        "× CPU time",
        target="≤ 1.25×",
        met=r <= 1.25,
        note=f"the whole call: auto {auto:.3f} CPU-s, physical {phys:.3f} CPU-s (median of 3)",
    )


def hs_mapping(vol: Any) -> Any:
    """The default mapping of ``vol``, prepared."""
    from auralize.pipeline import resolve_mapping

    m = resolve_mapping(vol)
    m.prepare(vol)
    return m


def _timbre_rows(tracks: Any, path: Any, size: int) -> list[BenchRow]:
    """``extended`` and ``tonal`` renders (auralize.emitters.timbre) along the synthesis rows' path:
    the merged envelope tracks (per path), their runs or pieces, the per-type
    tracks and the noise tables are built by the first render of the tracks
    and reused, as for ``physical``."""
    from auralize.emitters.timbre import render_timbre

    rows = []
    dur = path.duration
    for timbre in ("extended", "tonal"):
        for layout in ("mono", "ring8"):
            fn = functools.partial(render_timbre, tracks, path, layout=layout, timbre=timbre)
            times = batch_times(fn, repeat=5)
            t = float(np.median(times))
            n_ch = 1 if layout == "mono" else 8
            per_ch = dur / t * n_ch
            rows.append(
                BenchRow(
                    "synthesis",
                    f"explosion {size}³ → {layout}, timbre {timbre}",
                    per_ch,
                    "× real time/ch",
                    target="≥ 50× per channel" if size == 64 else "",
                    met=per_ch >= 50 if size == 64 else None,
                    note=f"{dur:.2f} s of audio in {t * 1e3:.0f} ms (median of 5 batches, fastest "
                    f"{dur / times.min() * n_ch:.0f}× per channel); 20 Hz high-pass included",
                )
            )
    return rows


def emitters_rows(quick: bool) -> list[BenchRow]:
    """The emitters engine's sampled backend on the plugins' typical cases.

    * vortex-like: 36 static emitters with 11,025 Hz signals (a texture's
      rate) to ring8 at 44.1 kHz along an orbit, and the same signals given
      at 44.1 kHz;
    * aero-like: 20 moving dipole emitters (a 0.6 m rod swung at 200 Hz
      poses, tip ≈ 40 m/s) at 44.1 kHz to mono and ring8.

    The plugins' own rows (their ``bench`` hooks) time the models end to end.
    """
    from scipy.signal import resample_poly

    from auralize.emitters import Emitters
    from auralize.emitters.engine import render_emitters
    from auralize.listener import ListenerPath

    rows: list[BenchRow] = []
    rng = np.random.default_rng(0)
    # vortex: a 6 x 6 grid of static sub-volume centres, 11,025 Hz signals
    dur = 2.0 if quick else 10.0
    fe = 11025.0
    g = np.linspace(-1.0, 1.0, 6)
    xx, zz = np.meshgrid(g, g + 1.5)
    pos = np.stack([xx.ravel(), np.zeros(36), zz.ravel()], axis=1)
    n_e = int((dur + 0.05) * fe)
    sig = rng.normal(size=(36, n_e))
    em = Emitters(sig, fe, pos, t0=-0.05, name="vortex-like")
    orbit = ListenerPath.orbit((0.0, 0.0, 1.5), radius=4.0, duration=dur, turns=1.0)
    fn = functools.partial(render_emitters, em, orbit, rate=44100, layout="ring8")
    t = best_of(fn, repeat=3)
    meta = fn().meta
    note = (
        f"{dur:g} s in {t * 1e3:.0f} ms; internal rate {meta['internal_rate_hz']:.0f} Hz, "
        f"signals upsampled to {meta['signal_rate_hz']:.0f} Hz inside, {meta['threads']} threads"
    )
    rows.append(
        BenchRow(
            "emitters",
            "36 static emitters 11 kHz → ring8, engine",
            dur / t,
            "× real time",
            note=note,
        )
    )
    up = resample_poly(sig, 4, 1, axis=1)
    em44 = Emitters(up, 44100.0, pos, t0=-0.05, name="vortex-like")
    fe44 = functools.partial(render_emitters, em44, orbit, rate=44100, layout="ring8")
    t44 = best_of(fe44, repeat=3)
    rows.append(
        BenchRow(
            "emitters",
            "… the same given at 44.1 kHz, engine",
            dur / t44,
            "× real time",
            note=f"{dur:g} s in {t44 * 1e3:.0f} ms; signals upsampled beforehand (not timed)",
        )
    )
    # aero: a rod of 20 dipoles swung about its grip
    dur = 2.0 if quick else 5.0
    S, length, prate = 20, 0.6, 200.0
    tp = np.arange(int(dur * prate) + 2) / prate
    ang = np.deg2rad(80.0) * np.sin(2 * np.pi * 2.0 * tp)
    r = (np.arange(S) + 0.5) / S * length
    traj = np.stack(
        [r[:, None] * np.cos(ang)[None], r[:, None] * np.sin(ang)[None], np.zeros((S, tp.size))],
        axis=-1,
    )
    n = int(dur * 44100)
    G = rng.normal(size=(S, 3, n)) * 1e-3
    dip = Emitters(G, 44100.0, traj, pos_rate=prate, name="aero-like")
    path = ListenerPath.point((0.3, 1.0, 0.2), duration=dur)
    for layout in ("mono", "ring8"):
        f = functools.partial(render_emitters, dip, path, rate=44100, layout=layout)
        t = best_of(f, repeat=3)
        rows.append(
            BenchRow(
                "emitters",
                f"20 moving dipoles 44.1 kHz → {layout}, engine",
                dur / t,
                "× real time",
                note=f"{dur:g} s in {t * 1e3:.0f} ms",
            )
        )
    return rows


def plugin_rows(quick: bool) -> list[BenchRow]:
    from auralize.plugins import registry

    rows: list[BenchRow] = []
    for name, cls in registry().items():
        try:
            rows.extend(cls.bench(quick))
        except Exception as exc:  # a benchmark reports, it does not crash
            rows.append(BenchRow(name, "benchmark failed", float("nan"), "", note=str(exc)))
    return rows


def format_rows(rows: list[BenchRow]) -> str:
    out = []
    group = None
    for r in rows:
        if r.group != group:
            group = r.group
            out.append(f"\n[{group}]")
        mark = {True: "ok  ", False: "MISS", None: "    "}[r.met]
        val = f"{r.value:,.3f}" if abs(r.value) < 1000 else f"{r.value:,.0f}"
        line = f"  {mark} {r.name:48s} {val:>12s} {r.unit:14s}"
        if r.target:
            line += f" target {r.target}"
        if r.paper:
            line += f" | paper {r.paper}"
        if r.note:
            line += f" | {r.note}"
        out.append(line)
    return "\n".join(out)


def _detection_rows(args: argparse.Namespace) -> list[BenchRow]:
    sizes = (
        [int(s) for s in args.sizes.split(",")]
        if args.sizes
        else ([10, 20, 32] if args.quick else [10, 20, 30, 40, 50, 64, 128, 256])
    )
    return bench_detection(sizes) + bench_detection_whole(args.quick)


def _lazy(module: str, name: str, **fixed: Any) -> Any:
    """``args -> rows`` of ``module.name(args.quick)`` (or of ``fixed`` keyword
    arguments taken from ``args``), imported when the group runs."""

    def rows(args: argparse.Namespace) -> list[BenchRow]:
        fn = getattr(importlib.import_module(module), name)
        if fixed:
            return fn(**{k: bool(getattr(args, v, False)) for k, v in fixed.items()})
        return fn(args.quick)

    return rows


def _dask_rows(args: argparse.Namespace) -> list[BenchRow]:
    if importlib.util.find_spec("dask") is None:
        print("\n[dask] skipped: install the 'dask' extra for the scale-out rows")
        return []
    from auralize.bench.distributed import bench_dask

    # the full Dask rows write a 27 GB, 256³ x 100-step file: only when asked
    return bench_dask(not getattr(args, "dask_full", False))


#: the bench's groups in the order they run: name -> ``args -> rows``
#: (``auralize bench --only NAME,...`` runs some of them)
GROUPS: dict[str, Any] = {
    "detection": _detection_rows,
    "synthesis": lambda args: bench_synthesis(args.quick),
    "timbre": lambda args: timbre_cost_rows(args.quick),
    "scaling": lambda args: scaling_rows(args.quick),
    "emitters": lambda args: emitters_rows(args.quick),
    "compile": _lazy("auralize.bench.compile", "compile_rows"),
    "immersive": _lazy("auralize.bench.immersive", "immersive_rows"),
    "readers": _lazy("auralize.bench.readers", "bench_readers", full="readers_full"),
    "efficiency": _lazy("auralize.bench.efficiency", "efficiency_rows"),
    "fwh": _lazy("auralize.bench.fwh", "fwh_rows"),
    "outdoor": _lazy("auralize.bench.outdoor", "outdoor_rows"),
    "output": _lazy("auralize.bench.output", "bench_output"),
    "viewer": _lazy("auralize.bench.viewer", "bench_viewer"),
    "dask": _dask_rows,
    "plugins": lambda args: plugin_rows(args.quick),
}


def bench_groups(text: str) -> list[str]:
    """argparse type of ``bench --only``: comma-separated names of :data:`GROUPS`.

    Parameters
    ----------
    text : str
        ``"timbre,scaling"``.

    Returns
    -------
    list of str
        The names, in the order given.

    Raises
    ------
    argparse.ArgumentTypeError
        An empty list or a name that is not a group (the groups are listed).

    Examples
    --------
    >>> bench_groups("timbre,efficiency")
    ['timbre', 'efficiency']
    """
    names = [t.strip() for t in text.split(",") if t.strip()]
    unknown = [n for n in names if n not in GROUPS]
    if not names or unknown:
        raise argparse.ArgumentTypeError(
            f"unknown bench group {', '.join(map(repr, unknown)) or repr(text)}; "
            f"the groups are {', '.join(GROUPS)}"
        )
    return names


def run_bench(args: argparse.Namespace) -> int:
    print(
        f"auralize bench on {platform.machine()} ({os.cpu_count()} cores), "
        f"python {platform.python_version()}"
    )
    only = getattr(args, "only", None)
    rows: list[BenchRow] = []
    for name, fn in GROUPS.items():
        if only and name not in only:
            continue
        more = fn(args)
        if more:
            print(format_rows(more), flush=True)
        rows += more
    if args.json:
        from auralize.runtime.files import atomic_write

        atomic_write(args.json, json.dumps([asdict(r) for r in rows], indent=2).encode())
    return 0
