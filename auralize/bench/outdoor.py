"""``auralize bench`` rows of outdoor propagation: what the air and the ground cost.

The air filter (:mod:`auralize.emitters.outdoor`) runs on every emitted
sample of the emitter sets (a short-time Fourier transform with a gain per
frame and frequency) and on every output sample of the volume's sources; the
ground doubles the sources the engine renders.  Figures are CPU seconds
(medians of several runs, all threads counted), so other work on the machine
changes them little; "× the render" compares a render with the option to the
same render without it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np


def _cpu(fn: Callable[[], object], repeat: int) -> float:
    """Median CPU seconds of ``fn`` over ``repeat`` runs, after one warm-up."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return float(np.median(times))


def outdoor_rows(quick: bool) -> list[Any]:
    """Outdoor rows: the air filter on static and moving emitters, on the volume's output,
    and the ground image, each against the render it is part of."""
    from auralize.bench.runner import BenchRow
    from auralize.emitters import Emitters, Sound
    from auralize.emitters.outdoor import Air, Ground, absorbed_emitters, frame_length, received
    from auralize.emitters.synthesis import Rendered
    from auralize.listener import ListenerPath
    from auralize.rendering import render
    from auralize.spatial.layouts import get_layout

    rate = 44100
    S = 16 if quick else 64
    dur = 1.0 if quick else 4.0
    repeat = 3 if quick else 5
    n = int(dur * rate)
    rng = np.random.default_rng(0)
    sig = rng.normal(size=(S, n))
    pos = np.column_stack(
        [rng.uniform(-50, 50, S), rng.uniform(100, 300, S), rng.uniform(1, 20, S)]
    )
    still = Emitters(sig, rate, pos)
    t = np.arange(0, n, 441) / rate
    traj = pos[:, None, :] + np.array([30.0, 0.0, 0.0]) * t[None, :, None]  # 30 m/s along x
    moving = Emitters(sig, rate, np.ascontiguousarray(traj), pos_rate=100.0)
    path = ListenerPath.line((0, 0, 1.7), (20, 0, 1.7), duration=dur)
    air = Air(20.0, 70.0)
    rows: list[Any] = []
    for what, em in (("static", still), ("moving (Doppler-shifted α)", moving)):

        def filtered(em: Emitters = em) -> object:
            return absorbed_emitters(em, path, air)

        def rendered(em: Emitters = em) -> object:
            return render(em, path, rate=rate, layout="ring8")

        t_air = _cpu(filtered, repeat)
        t_dry = _cpu(rendered, repeat)
        rows.append(
            BenchRow(
                "outdoor",
                f"air filter, {S} {what} emitters",
                S * n / t_air / 1e6,
                "M emitter-samples/CPU-s",
                note=f"{S} x {dur:g} s at {rate} Hz filtered in {t_air:.2f} CPU-s: "
                f"{(t_air + t_dry) / t_dry:.2f} x the ring8 render without air",
            )
        )
    t_dry = _cpu(lambda: render(still, path, rate=rate, layout="ring8"), repeat)
    t_wet = _cpu(
        lambda: render(still, path, rate=rate, layout="ring8", ground=Ground(0.0, 0.8)), repeat
    )
    rows.append(
        BenchRow(
            "outdoor",
            f"ground image, {S} static emitters",
            t_wet / t_dry,
            "× the render",
            note=f"ring8, {dur:g} s: {t_wet:.2f} against {t_dry:.2f} CPU-s (every source twice)",
        )
    )
    C = 8
    audio = rng.normal(size=(C, n))
    lay = get_layout("ring8")

    def run(k: dict[str, Any]) -> Rendered:
        a = int(round(k["start"] * rate))
        m = int(round(k["duration"] * rate))
        out = np.zeros((C, m))
        have = max(0, min(m, n - a))
        out[:, :have] = audio[:, a : a + have]
        return Rendered(audio=out, rate=rate, layout=lay, meta={})

    kw = {"rate": rate, "start": 0.0, "duration": dur}
    t_rec = _cpu(lambda: received(run, kw, path, air, lambda tt: 200.0 + 0.0 * tt), repeat)
    rows.append(
        BenchRow(
            "outdoor",
            "air filter on a render's output (the volume's sources)",
            C * n / t_rec / 1e6,
            "M channel-samples/CPU-s",
            note=f"ring8, {dur:g} s at {rate} Hz in {t_rec:.2f} CPU-s (frames of "
            f"{frame_length(rate)} samples, a gain per frame and frequency)",
        )
    )
    both = Sound([still])
    t_both = _cpu(
        lambda: render(both, path, rate=rate, layout="ring8", air=air, ground=Ground(0.0, 0.8)),
        repeat,
    )
    rows.append(
        BenchRow(
            "outdoor",
            f"air + ground, {S} static emitters",
            t_both / t_dry,
            "× the render",
            note=f"ring8, {dur:g} s: {t_both:.2f} against {t_dry:.2f} CPU-s",
        )
    )
    return rows
