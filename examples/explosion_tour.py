"""Explosion tour: open the explosion, detect its sources, fly an orbit, hear it in ring8.

Run with ``auralize script examples/explosion_tour.py [OUTDIR] [--size N --steps T]``
or ``python examples/explosion_tour.py``.  Writes ``tour.wav`` (8 channels),
``tour.csv`` (the recorded path), ``tour.png`` and ``tour.json`` (the session,
which ``auralize view --session tour.json`` reopens).
"""

import argparse
from pathlib import Path

from auralize.simple import (
    CreateListenerPath,
    DetectSources,
    GetSession,
    OpenDataFile,
    RecordListenerPath,
    RenderAudio,
    ResetSession,
    SaveAudio,
    SaveListenerPath,
    SaveScreenshot,
    SaveSession,
    Show,
)

ap = argparse.ArgumentParser()
ap.add_argument("outdir", nargs="?", default="tour-out")
ap.add_argument("--size", type=int, default=32)
ap.add_argument("--steps", type=int, default=8)
ap.add_argument("--duration", type=float, default=2.0, help="playback seconds")
args = ap.parse_args()
out = Path(args.outdir)
out.mkdir(parents=True, exist_ok=True)

ResetSession()
explosion = OpenDataFile("dataset:explosion", size=args.size, steps=args.steps)
series = DetectSources(monopole="3%", dipole="0.3%", quadrupole="0.1%")
view = Show(explosion, representation="volume", step=args.steps // 2)
print("sources at the middle step:", series.counts()[args.steps // 2])

# fly around the centre while the camera is recorded as the listener (10 Hz)
c = explosion.Volume.center
r = 0.35 * (explosion.Volume.bounds[1] - explosion.Volume.bounds[0])
keyframes = [
    {"position": c + [r, 0, 0.2 * r], "focal_point": c},
    {"position": c + [0, r, 0.3 * r], "focal_point": c},
    {"position": c + [-r, 0, 0.2 * r], "focal_point": c},
]
duration = args.duration  # playback seconds; the data are stretched to fill them
vol = explosion.Volume
GetSession().audio["time_scale"] = duration / float(vol.times[-1] - vol.times[0])
path = RecordListenerPath(keyframes, duration=duration, rate_hz=10)
SaveListenerPath(out / "tour.csv")

rendered = RenderAudio(layout="ring8")
SaveAudio(out / "tour.wav")
view.CameraPosition = c + [3 * r, -3 * r, 2.5 * r]
view.CameraFocalPoint = c
view.CameraViewUp = (0, 0, 1)
SaveScreenshot(out / "tour.png", resolution=(640, 480))
SaveSession(out / "tour.json")
print(f"{path.n_captures} captures; {rendered.audio.shape[0]} channels, {rendered.duration:.2f} s")

# an orbit path made without a view, for comparison
CreateListenerPath("orbit", radius=r, height=0.1 * r)
print("orbit render peak (Pa):", float(abs(RenderAudio(layout="mono").audio).max()))
