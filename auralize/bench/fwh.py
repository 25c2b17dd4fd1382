"""``auralize bench`` rows of the FW-H surface integral and of telling data that
hold sound from data that hold sources.

The case is the verification case of ``tests/test_fwh.py``: the exact field of a
pulsating point source stored on a 41³ grid at 85 steps
(:func:`auralize.fwh.analytic.pulse_volume`), heard 40 m away through the default
box (6,144 panels of one grid spacing).  Speed is given as surface panels ×
output samples per second, the figure that grows with what the integral does.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from auralize.runtime.timing import best_of


def fwh_rows(quick: bool) -> list[Any]:
    """FW-H rows: the wave test, the surface's emitters, the render, the error."""
    from auralize.bench.runner import BenchRow
    from auralize.fwh.analytic import pulse_field, pulse_volume
    from auralize.fwh.classify import choose_method, wave_test
    from auralize.fwh.model import FWHSound
    from auralize.listener import ListenerPath
    from auralize.rendering import render

    n = 25 if quick else 41
    vol = pulse_volume(n=n, spacing=2.0 / (n - 1))
    rows: list[Any] = []
    t_test = best_of(lambda: wave_test(vol), repeat=3)
    wt = wave_test(vol)
    assert wt is not None
    rows.append(
        BenchRow(
            "fwh",
            f"wave test, {n}³ x {vol.n_steps} steps",
            t_test * 1e3,
            "ms",
            note=f"residual {100 * wt.residual:.1f} % ({wt.field}): {wt.describe().split(':')[0]}; "
            f"{5 * len(wt.steps)} frames read",
        )
    )
    how = choose_method(vol)
    xs = np.array([0.013, -0.007, 0.011])
    listener = xs + np.array([0.0, 40.0, 0.0])
    lead = 40.0 / 343.0 - 0.002
    t0 = time.perf_counter()
    sound = FWHSound().synthesize(vol, surface=str(how.surface), time_origin=lead)
    t_sound = time.perf_counter() - t0
    panels = sound.parts[0].positions.shape[0]
    rows.append(
        BenchRow(
            "fwh",
            f"surface emitters, {panels:,} panels",
            t_sound,
            "s",
            note=f"sampling {vol.n_steps} steps (the exact field computed as it is read) on "
            f"{how.surface} and Farassat 1A's terms "
            f"(3 emitter sets)",
        )
    )
    path = ListenerPath.point(listener, duration=0.03)
    fn = lambda: render(sound, path, rate=44100, layout="mono", duration=0.03)  # noqa: E731
    t_render = best_of(fn, repeat=3)
    out = fn()
    samples = out.audio.shape[1]
    rows.append(
        BenchRow(
            "fwh",
            "FW-H render 40 m away, mono",
            panels * samples / t_render / 1e6,
            "M panel-samples/s",
            note=f"{samples} samples x {panels:,} panels in {t_render * 1e3:.0f} ms (best of 3)",
        )
    )
    t = lead + np.arange(samples) / 44100
    exact = pulse_field("monopole", xs, t[:, None], listener[None, None, :])[0][:, 0]
    err = float(np.sqrt(np.sum((out.audio[0] - exact) ** 2) / np.sum(exact**2)))
    rows.append(
        BenchRow(
            "fwh",
            "FW-H error against the exact field",
            100 * err,
            "% RMS",
            target="≤ 10 %",
            met=err <= 0.10,
            note="the stored monopole pulse at 40 m (the volume sum hears it at "
            "a fraction of a per cent of its level)",
        )
    )
    return rows
