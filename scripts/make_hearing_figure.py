"""Draw docs/hearing.png, the figure of docs/hearing.md ("What you hear and why").

Three panels, each from the library's own renders:

1. a compact spinning quadrupole (the ``spinning`` dataset) heard 30 wavelengths
   away: the whole field (the default), the detected sources (paper 003) and
   Lighthill's compact far field from the same arrays, at two compactnesses;
2. the same vortex turning for 3 periods, then still: level against time in
   every timbre (the default render at a fixed listener);
3. the default orbit of the 32³ explosion on ring8: each channel's share of
   the energy.

Run: ``python scripts/make_hearing_figure.py [OUT.png]`` (about a minute).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import auralize.pipeline as ap
from auralize.datasets.synthetic import (
    SpinningParams,
    lighthill_far_field,
    make_spinning,
)
from auralize.emitters.synthesis import C0


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def compact_panel(ax: plt.Axes) -> None:
    labels, field, detected, lighthill = [], [], [], []
    for kL in (0.4, 0.04):
        vol = make_spinning(kL=kL).load()
        p = SpinningParams(kL=kL)
        r = 30 * C0 / p.frequency
        where = vol.center + [r, 0.0, 0.0]
        span = float(vol.times[-1])
        out = {}
        for heard in ("field", "detected"):
            o, _ = ap.auralize(
                vol, listener=where, duration=span, time_scale=1.0, heard=heard, timbre="physical"
            )
            x = o.audio[0]
            out[heard] = _rms(x[x.size // 4 :])
        _, ref = lighthill_far_field(vol, np.array([1.0, 0.0, 0.0]), r)
        labels.append(f"kL = {kL:g}")
        field.append(20 * np.log10(out["field"] / 2e-5))
        detected.append(20 * np.log10(out["detected"] / 2e-5))
        lighthill.append(20 * np.log10(_rms(ref) / 2e-5))
    x = np.arange(len(labels))
    ax.bar(x - 0.25, lighthill, 0.25, label="Lighthill, compact (closed form)", color="0.6")
    ax.bar(x, field, 0.25, label="heard: whole field (default)", color="tab:blue")
    ax.bar(x + 0.25, detected, 0.25, label="heard: detected sources", color="tab:red")
    ax.set_xticks(x, labels)
    ax.set_ylabel("level 30 λ away (dB re 20 µPa)")
    ax.set_title("A spinning vortex: every point, or thresholds")
    ax.legend(fontsize=7, loc="lower left")


def freeze_panel(ax: plt.Axes) -> None:
    p = SpinningParams(kL=0.4, freeze_after=3.0)
    vol = make_spinning(kL=0.4, size=24, steps=16 * 12 + 1, freeze_after=3.0).load()
    r = 30 * C0 / p.frequency
    span = float(vol.times[-1])
    for timbre, colour in (
        ("physical", "tab:blue"),
        ("extended", "tab:orange"),
        ("tonal", "tab:green"),
    ):
        o, _ = ap.auralize(
            vol, listener=vol.center + [r, 0.0, 0.0], duration=span, time_scale=1.0, timbre=timbre
        )
        x = o.audio[0]
        w = int(0.002 * o.rate)
        n = x.size // w
        lev = 20 * np.log10(np.maximum(np.sqrt(np.mean(x[: n * w].reshape(n, w) ** 2, 1)), 1e-12))
        t = (np.arange(n) + 0.5) * w / o.rate * 1e3
        ax.plot(t, lev - lev[: n // 5].max(), color=colour, label=timbre)
    ax.axvline(3.0 / p.frequency * 1e3, color="k", lw=0.8, ls="--")
    ax.text(3.0 / p.frequency * 1e3, 2, " the vortex stops", fontsize=7, va="bottom")
    ax.set_ylim(-120, 10)
    ax.set_xlabel("playback time (ms)")
    ax.set_ylabel("level (dB re its level while turning)")
    ax.set_title("Nothing changes: nothing is heard")
    ax.legend(fontsize=7, loc="lower left")


def layout_panel(ax: plt.Axes) -> None:
    vol = ap.load("dataset:explosion", size=32).load()
    out, _ = ap.auralize(vol, layout="ring8")
    e = np.sum(out.audio**2, axis=1)
    names = out.layout.channel_names
    ax.bar(range(8), 100 * e / e.sum(), color="tab:purple")
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_xticks(range(8), [f"{n}\n{45 * k}°" for k, n in enumerate(names)], fontsize=7)
    ax.set_ylabel("share of the energy (%)")
    ax.set_title("Default orbit, ring8: the data pass round the head")


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path(__file__).resolve().parent.parent / "docs" / "hearing.png"
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    compact_panel(axes[0])
    freeze_panel(axes[1])
    layout_panel(axes[2])
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
