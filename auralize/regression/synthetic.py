"""Dataset regression: figures a dataset must keep producing, stored in ``auralize/data/regression``.

``python -m auralize.regression.synthetic [--update] [NAME ...]`` recomputes the figures
of the built-in datasets and compares them with (or rewrites) the stored JSON.
The test suite calls :func:`compare` so a change in detection or synthesis
that moves these figures is caught.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from auralize.regression.compare import count_changes, relative_change
from auralize.regression.compare import spectral_centroid as spectral_centroid
from auralize.runtime.files import atomic_write

#: shipped with the package (wheel and checkout alike)
STORE = Path(__file__).resolve().parents[1] / "data" / "regression"

#: relative tolerances of the stored figures (of the physical pressure, unfiltered: the
#: figures follow detection and synthesis, not the output high-pass)
TOLERANCES = {"counts": 0.01, "rms": 0.01, "centroid": 0.02}

CASES: dict[str, dict[str, Any]] = {
    "explosion": {
        "dataset": "explosion",
        "size": 64,
        "steps": 30,
        "seed": 0,
        "mapping": "paper-density",
        "thresholds": ["auto", "auto", "auto"],
        "rate": 44100,
        "interp": "cubic",
        "highpass_hz": 0.0,
        "path": {"start": [12.0, 20.0, 30.0], "end": [50.0, 40.0, 34.0], "duration": 1.0},
    },
}


def compute(name: str) -> dict[str, Any]:
    """Recompute the figures of one case."""
    from auralize.datasets.synthetic import make_dataset
    from auralize.listener import ListenerPath
    from auralize.pipeline import auralize, detect_sources
    from auralize.sources.detection import Thresholds

    case = CASES[name]
    vol = make_dataset(case["dataset"], size=case["size"], steps=case["steps"], seed=case["seed"])
    vol = vol.load()
    p = case["path"]
    path = ListenerPath.line(p["start"], p["end"], duration=p["duration"])
    th = Thresholds(*case["thresholds"])
    # what is drawn (the detected sources) and what is heard (the whole field)
    series = detect_sources(vol, mapping=case["mapping"], thresholds=th)
    out, _ = auralize(
        vol,
        path,
        mapping=case["mapping"],
        thresholds=th,
        rate=case["rate"],
        interp=case["interp"],
        timbre="physical",
        time_scale=1.0,
        highpass_hz=case.get("highpass_hz", 0.0),
    )
    x = out.audio[0]
    return {
        "case": case,
        "counts": series.counts(),
        "thresholds": series.thresholds.tolist(),
        "rms": float(np.sqrt(np.mean(x**2))),
        "centroid": spectral_centroid(x, out.rate),
    }


def compare(name: str, got: dict[str, Any] | None = None) -> list[str]:
    """Differences between recomputed and stored figures beyond the tolerances, one line
    per moved figure (:mod:`auralize.regression.compare`)."""
    stored = json.loads((STORE / f"{name}.json").read_text())
    got = got or compute(name)
    moved = count_changes(got["counts"], stored["counts"], rel=TOLERANCES["counts"])
    for key in ("rms", "centroid"):
        m = relative_change(key, key, got[key], stored[key], rtol=TOLERANCES[key])
        if m is not None:
            moved.append(m)
    return [str(m) for m in moved]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m auralize.regression.synthetic")
    ap.add_argument("names", nargs="*", default=list(CASES))
    ap.add_argument("--update", action="store_true", help="rewrite the stored figures")
    args = ap.parse_args(argv)
    status = 0
    for name in args.names:
        got = compute(name)
        if args.update:
            atomic_write(STORE / f"{name}.json", json.dumps(got, indent=1).encode())
            print(f"{name}: stored (rms {got['rms']:.4g} Pa, centroid {got['centroid']:.1f} Hz)")
            continue
        problems = compare(name, got)
        print(f"{name}: {'ok' if not problems else 'CHANGED'}")
        for p in problems:
            print("   ", p)
        status |= bool(problems)
    return status


if __name__ == "__main__":
    sys.exit(main())
