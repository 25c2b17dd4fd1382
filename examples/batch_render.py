"""Batch render: one volume, many listener paths, one WAV per path.

``auralize script examples/batch_render.py OUTDIR [--layout stereo]`` renders
orbits at several radii and heights plus straight fly-throughs, detecting the
sources only once, and writes ``OUTDIR/<name>.wav`` and ``<name>.csv``.
"""

import argparse
from pathlib import Path

import numpy as np

from auralize.simple import (
    CreateListenerPath,
    DetectSources,
    OpenDataFile,
    RenderAudio,
    ResetSession,
    SaveAudio,
    SaveListenerPath,
)

ap = argparse.ArgumentParser()
ap.add_argument("outdir", type=Path)
ap.add_argument("--size", type=int, default=32)
ap.add_argument("--steps", type=int, default=8)
ap.add_argument("--layout", default="stereo")
args = ap.parse_args()
args.outdir.mkdir(parents=True, exist_ok=True)

ResetSession()
src = OpenDataFile("dataset:explosion", size=args.size, steps=args.steps)
DetectSources()  # once; every render below reuses the sources
vol = src.Volume
c, L = vol.center, vol.bounds[1] - vol.bounds[0]
paths = {
    f"orbit-r{int(100 * f)}-h{int(100 * h)}": ("orbit", {"radius": f * L, "height": h * L})
    for f in (0.2, 0.4)
    for h in (0.0, 0.2)
}
for axis in range(3):
    d = np.zeros(3)
    d[axis] = 0.45 * L
    paths[f"line-{'xyz'[axis]}"] = ("line", {"start": c - d, "end": c + d})
for name, (kind, kw) in paths.items():
    CreateListenerPath(kind, **kw)
    r = RenderAudio(layout=args.layout)
    SaveAudio(args.outdir / f"{name}.wav")
    SaveListenerPath(args.outdir / f"{name}.csv")
    print(f"{name:16s} peak {np.max(np.abs(r.audio)):.4g} Pa")
print(f"{len(paths)} renders in {args.outdir}")
