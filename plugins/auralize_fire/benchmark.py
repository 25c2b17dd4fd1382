"""``auralize bench`` rows of the fire plugin (paper 001 Table 2, §6).

* bandwidth extension (§4) of each real low-frequency input of the shared
  ``fire-lowfreq`` folder (target: the 10 s flame_jet in ≤ 0.2 s; paper's
  Matlab 256 s);
* texture synthesis (§5) of the flame_jet input with a 15 s training clip
  (target ≤ 20 s; paper 54 s); quick mode times 2 s with 3 s;
* flame-front extraction + flux on one 64³ step (target ≤ 0.2 s; paper
  5–20 s per step);
* the fire's emitter (1 s, moving) rendered by the sound engine along a
  10 Hz orbit, mono and ring8.

The real inputs are read from ``../shared/datasets/fire-lowfreq`` when it is
present; otherwise those rows say they were skipped and the shipped 2 s
excerpt is used instead.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from auralize.plugins import BenchRow, best_of

PAPER_BE_S = {"dragon": 223, "candle": 151, "torch": 63, "flame_jet": 256, "burning_brick": 64}
PAPER_STS_S = {"dragon": 56, "candle": 86, "torch": 41, "flame_jet": 54, "burning_brick": 20}
PAPER_TRAIN_S = {"dragon": 15, "candle": 10, "torch": 16, "flame_jet": 15, "burning_brick": 8}
DATA = Path(__file__).resolve().parent / "data"


def shared_inputs() -> dict[str, np.ndarray]:
    """The five real inputs from the shared folder (empty when it is absent)."""
    from auralize_fire.model import SHARED

    man = SHARED / "manifest.json"
    if not man.is_file():
        return {}
    out = {}
    for ex in json.loads(man.read_text())["examples"]:
        f = SHARED / f"{ex['name']}.f32"
        if f.is_file():
            out[ex["name"]] = np.fromfile(f, dtype="<f4").astype(np.float64)
    return out


def fire_bench(quick: bool) -> list[BenchRow]:
    from auralize_fire.bandwidth import bandwidth_extend
    from auralize_fire.clips import fire_training_clip
    from auralize_fire.flamefront import extract_front
    from auralize_fire.lowfreq import highpass
    from auralize_fire.texture import texture_synthesize

    rate = 44100
    rows: list[BenchRow] = []
    g = "fire (paper 001)"
    inputs = shared_inputs()
    if not inputs:
        rows.append(
            BenchRow(
                g,
                "real inputs",
                float("nan"),
                "",
                note="skipped: "
                "../shared/datasets/fire-lowfreq not found; using the shipped 2 s excerpt",
            )
        )
        inputs = {
            "candle (2 s excerpt)": np.fromfile(DATA / "candle_2s.f32", dtype="<f4").astype(float)
        }
    for name, x in inputs.items():
        xh = highpass(x, rate)
        t = best_of(lambda xh=xh: bandwidth_extend(xh, rate, seed=0), repeat=3)
        key = name.split(" ")[0]
        is_target = name == "flame_jet"
        rows.append(
            BenchRow(
                g,
                f"bandwidth extension {name} ({x.size / rate:.1f} s)",
                t,
                "s",
                target="≤ 0.2 s" if is_target else "",
                met=(t <= 0.2) if is_target else None,
                paper=f"{PAPER_BE_S[key]} s (Matlab)" if key in PAPER_BE_S else "",
            )
        )
    # texture synthesis
    names = ["flame_jet"] if "flame_jet" in inputs else list(inputs)[:1]
    if not quick and "flame_jet" in inputs:
        names = [n for n in inputs]
    for name in names:
        x = inputs[name]
        train_s = PAPER_TRAIN_S.get(name, 15)
        if quick:
            x, train_s = x[: 2 * rate], 3
        xh = highpass(x, rate)
        clip = fire_training_clip(float(train_s), rate, seed=0)
        texture_synthesize(xh[: rate // 4], clip[:rate], levels=6)  # compile / warm up
        t0 = time.perf_counter()
        texture_synthesize(xh, clip)
        t = time.perf_counter() - t0
        is_target = name == "flame_jet" and not quick
        rows.append(
            BenchRow(
                g,
                f"texture synthesis {name} ({x.size / rate:.1f} s, train {train_s} s)",
                t,
                "s",
                target="≤ 20 s" if is_target else "",
                met=(t <= 20) if is_target else None,
                paper=f"{PAPER_STS_S[name]} s" if name in PAPER_STS_S and not quick else "",
                note="procedural training clip",
            )
        )
    # flame front + flux on a 64³ step
    from scipy import ndimage

    n = 64
    rng = np.random.default_rng(0)
    ax = np.linspace(-1, 1, n)
    z, y, xx = np.meshgrid(ax, ax, ax, indexing="ij")
    turb = ndimage.gaussian_filter(rng.normal(size=(n, n, n)), 2.0)
    burn = np.exp(-(xx**2 + y**2) / 0.15 - (z + 0.2) ** 2 / 0.5) * (1 + 4 * turb / turb.std() * 0.1)
    vel = rng.normal(size=(n, n, n, 3))
    org, sp = np.full(3, -1.0), np.full(3, 2 / (n - 1))

    def step() -> float:
        return extract_front(burn, 0.3, origin=org, spacing=sp).flux(vel, org, sp)

    t = best_of(step, repeat=3)
    n_tri = extract_front(burn, 0.3, origin=org, spacing=sp).areas.size
    rows.append(
        BenchRow(
            g,
            "flame front + flux, 64³ step",
            t,
            "s",
            target="≤ 0.2 s",
            met=t <= 0.2,
            paper="5–20 s per step (Houdini SOP)",
            note=f"{n_tri} triangles, B-spline refine 2",
        )
    )
    rows.extend(_render_rows())
    return rows


def _render_rows() -> list[BenchRow]:
    """The fire's emitter (1 s, moving) rendered by the engine along a 10 Hz orbit."""
    from auralize.emitters import Emitters, render_emitters
    from auralize.listener import ListenerPath

    rate = 44100
    sig = np.random.default_rng(0).standard_normal(rate)
    traj = np.stack([np.linspace(0, 0.5, rate), np.zeros(rate), np.full(rate, 0.3)], 1)
    em = Emitters(sig[None], rate, traj[None], name="fire")
    path = ListenerPath.orbit((0, 0, 0), radius=2.0, duration=1.0, rate_hz=10)
    rows = []
    for lay in ("mono", "ring8"):
        t = best_of(lambda lay=lay: render_emitters(em, path, rate=rate, layout=lay), repeat=3)
        rows.append(
            BenchRow(
                "fire (paper 001)",
                f"render 1 s moving fire → {lay}, 10 Hz orbit",
                t * 1e3,
                "ms",
                note=f"{1 / t:.0f}× real time (emitters engine)",
            )
        )
    return rows
