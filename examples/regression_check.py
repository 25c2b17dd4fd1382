"""Dataset regression check: detect sources and compare per-step counts with expectations.

``auralize script examples/regression_check.py EXPECTED.json [--update]``
writes the expectations with ``--update`` and otherwise exits with status 1
when any per-type count of any step differs by more than ``--tolerance``
(relative, default 2 %), or the rendered peak pressure by more than 5 %.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from auralize.simple import (
    CreateListenerPath,
    DetectSources,
    OpenDataFile,
    RenderAudio,
    ResetSession,
)

ap = argparse.ArgumentParser()
ap.add_argument("expected", type=Path)
ap.add_argument("--dataset", default="dataset:explosion")
ap.add_argument("--size", type=int, default=32)
ap.add_argument("--steps", type=int, default=8)
ap.add_argument("--tolerance", type=float, default=0.02)
ap.add_argument("--update", action="store_true")
args = ap.parse_args()

ResetSession()
src = OpenDataFile(args.dataset, size=args.size, steps=args.steps)
series = DetectSources(monopole="3%", dipole="0.3%", quadrupole="0.1%")
CreateListenerPath(
    "point", at=src.Volume.center + 0.25 * (src.Volume.bounds[1] - src.Volume.bounds[0])
)
peak = float(np.max(np.abs(RenderAudio(layout="mono").audio)))
found = {
    "dataset": args.dataset,
    "size": args.size,
    "steps": args.steps,
    "counts": series.counts(),
    "peak_pa": peak,
}

if args.update:
    args.expected.write_text(json.dumps(found, indent=2))
    print(f"wrote {args.expected}")
    sys.exit(0)

want = json.loads(args.expected.read_text())
problems = []
for n, (a, b) in enumerate(zip(found["counts"], want["counts"], strict=True)):
    for kind in ("monopole", "dipole", "quadrupole"):
        if abs(a[kind] - b[kind]) > args.tolerance * max(b[kind], 10):
            problems.append(f"step {n} {kind}: {a[kind]} found, {b[kind]} expected")
if abs(peak - want["peak_pa"]) > 0.05 * abs(want["peak_pa"]):
    problems.append(f"peak pressure {peak:.4g} Pa, expected {want['peak_pa']:.4g} Pa")
for p in problems:
    print("REGRESSION:", p)
print("ok" if not problems else f"{len(problems)} regression(s)")
sys.exit(1 if problems else 0)
