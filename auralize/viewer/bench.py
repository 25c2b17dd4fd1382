"""Interactivity figures for ``auralize bench`` (timed off screen, no window).

With the explosion loaded and its sources shown, stepping the time slider must
redraw in ≤ 100 ms, and recording (one capture, the path polyline update)
must add no visible lag (≤ 16 ms per capture: less than one 60 Hz frame).
"""

from __future__ import annotations

import time

import numpy as np

from auralize.bench import BenchRow


def bench_viewer(quick: bool) -> list[BenchRow]:
    """Time the viewer's update calls off screen (64³ explosion; 32³ when ``quick``)."""
    from auralize.simple import _prefer_egl

    _prefer_egl()
    import pyvista as pv

    from auralize.pipeline import load
    from auralize.viewer.detection import Detection
    from auralize.viewer.recorder import PathRecorder
    from auralize.viewer.scene import Scene, camera_pose

    size, steps = (32, 8) if quick else (64, 30)
    vol = load("dataset:explosion", size=size, steps=steps)
    det = Detection(vol)
    det.run()
    rows: list[BenchRow] = []
    plotter = pv.Plotter(off_screen=True, window_size=[1024, 768])
    try:
        scene = Scene(plotter)
        scene.set_volume(vol)
        scene.prefetch()
        scene.set_sources(det.get)
        n_src = max(sum(c.values()) for c in (det.counts(n) for n in range(steps)) if c)
        for rep in ("volume", "slices", "contour"):
            scene.set_representation(rep)
            scene.set_step(0)
            times = [scene.set_step(n) for n in list(range(1, steps)) * (1 if quick else 2)]
            t = float(np.median(times))
            rows.append(BenchRow(
                "viewer", f"time step redraw, {rep} ({size}³, sources shown)", t * 1e3, "ms",
                target="≤ 100 ms", met=t <= 0.100,
                note=f"max {max(times) * 1e3:.0f} ms; up to {n_src} ΔV spheres; 1024×768 off screen",
            ))  # fmt: skip
        scene.set_representation("volume")
        rec = PathRecorder(rate_hz=10)
        rec.start()
        cost = []
        for k in range(50):
            plotter.camera.azimuth = 2.0 * k
            t0 = time.perf_counter()
            rec.capture(*camera_pose(plotter.camera), t=k / 10)
            scene.set_path(rec.path(), render=False)
            cost.append(time.perf_counter() - t0)
        rec.stop()
        c = float(np.median(cost))
        rows.append(BenchRow("viewer", "recording: capture + path update", c * 1e3, "ms",
                             target="≤ 16 ms (< one 60 Hz frame)", met=c <= 0.016,
                             note="paper 003 §4.1 captures at 6–10 Hz"))  # fmt: skip
    finally:
        plotter.close()
    return rows
