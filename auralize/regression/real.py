"""Real-data regression: what the readers and the detector make of the shipped real datasets.

For every dataset in ``auralize/data/`` that this project did not make (plus the
generated netCDF case), :func:`compute` records the reader's grid and times,
the valid-point ratio, and — for series of two steps or more — the per-step
source counts and a short rendered clip's RMS and spectral centroid.
``python -m auralize.regression.real [--update] [NAME ...]`` compares them with (or
rewrites) ``auralize/data/regression/realdata.json``; ``tests/test_realdata.py``
calls :func:`compare`.

Grids and times are compared exactly (relative 1e-9); they depend on the
readers alone.  Counts, RMS and centroid depend on the detector and the
synthesis too: when either changes on purpose, refresh the file with
``--update`` and review the diff.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from typing import Any

import numpy as np

from auralize.datasets.real import CASES, DATASETS, dataset_path
from auralize.regression.compare import count_changes, relative_change
from auralize.runtime.files import atomic_write

STORE = DATASETS / "regression" / "realdata.json"

#: Tolerances: grid/times relative; valid ratio absolute; counts relative (at least 2);
#: rms and centroid relative.
TOLERANCES = {"grid": 1e-9, "valid_ratio": 1e-3, "counts": 0.02, "rms": 0.02, "centroid": 0.02}


def compute(name: str) -> dict[str, Any]:
    """Recompute the figures of one case (seconds per case)."""
    from auralize.io import ResampledWarning, open_volume
    from auralize.listener import ListenerPath
    from auralize.pipeline import auralize, detect_sources
    from auralize.regression.compare import spectral_centroid

    case = CASES[name]
    out: dict[str, Any] = {}
    with dataset_path(name) as path, warnings.catch_warnings():
        warnings.simplefilter("ignore", ResampledWarning)
        vol = open_volume(path)
        out.update(
            dims=list(vol.dims),
            origin=vol.origin.tolist(),
            spacing=vol.spacing.tolist(),
            times=vol.times.tolist(),
            physical_times=vol.physical_times,
            fields=vol.field_names,
            valid_ratio=vol.valid_ratio,
        )
        if vol.n_steps < 2:
            return out
        vol = vol.load()
        series = detect_sources(vol, mapping=case["mapping"], **case["fields"])
        out["mapping"] = series.meta["mapping"]
        out["counts"] = series.counts()
        out["unavailable"] = series.meta.get("unavailable", {})
        valid = vol.valid_mask().reshape(-1)
        out["sources_outside_mesh"] = int(
            sum(np.count_nonzero(~valid[f.index]) for f in series.frames)
        )
        r = case["render"]
        if r is not None:
            listener = ListenerPath.point(r["listener"], duration=r["duration"])
            rendered, _ = auralize(
                vol,
                listener,
                series=series,
                rate=8000,
                time_scale=r["time_scale"],
                duration=r["duration"],
                timbre=r.get("timbre", "physical"),
            )
            x = rendered.audio[0]
            out["rms"] = float(np.sqrt(np.mean(x**2)))
            out["centroid"] = spectral_centroid(x, rendered.rate) if np.any(x) else 0.0
    return out


def _close(a: object, b: object, rtol: float) -> bool:
    return bool(
        np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=rtol, atol=1e-12)
    )


def compare(name: str, got: dict[str, Any] | None = None) -> list[str]:
    """Differences between recomputed and stored figures beyond the tolerances."""
    stored = json.loads(STORE.read_text())[name]
    got = got if got is not None else compute(name)
    problems: list[str] = []
    for key in ("dims", "fields", "physical_times"):
        if got[key] != stored[key]:
            problems.append(f"{key}: {got[key]} vs stored {stored[key]}")
    for key in ("origin", "spacing", "times"):
        if len(got[key]) != len(stored[key]) or not _close(
            got[key], stored[key], TOLERANCES["grid"]
        ):
            problems.append(f"{key}: {got[key]} vs stored {stored[key]}")
    if abs(got["valid_ratio"] - stored["valid_ratio"]) > TOLERANCES["valid_ratio"]:
        problems.append(
            f"valid_ratio: {got['valid_ratio']:.4f} vs stored {stored['valid_ratio']:.4f}"
        )
    if ("counts" in got) != ("counts" in stored):
        problems.append("counts: present in only one of recomputed and stored")
    elif "counts" in got:
        problems += [
            str(m) for m in count_changes(got["counts"], stored["counts"], rel=TOLERANCES["counts"])
        ]
    for key in ("rms", "centroid"):
        if key in stored:
            m = relative_change(
                key, key, got.get(key, np.nan), stored[key], rtol=TOLERANCES[key], atol=1e-15
            )
            if m is not None:
                problems.append(str(m))
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m auralize.regression.real")
    ap.add_argument("names", nargs="*", default=list(CASES))
    ap.add_argument("--update", action="store_true", help="rewrite the stored figures")
    args = ap.parse_args(argv)
    stored = json.loads(STORE.read_text()) if STORE.exists() else {}
    status = 0
    for name in args.names:
        got = compute(name)
        if args.update:
            stored[name] = got
            print(f"{name}: stored")
            continue
        problems = compare(name, got) if name in stored else [f"{name}: nothing stored"]
        print(f"{name}: {'ok' if not problems else 'CHANGED'}")
        for p in problems:
            print("   ", p)
        status |= bool(problems)
    if args.update:
        atomic_write(STORE, (json.dumps(stored, indent=1) + "\n").encode())
    return status


if __name__ == "__main__":
    sys.exit(main())
