"""Draw the outdoor-propagation figures of docs/outdoor.md and print their measured errors.

One figure per case of ``tests/test_outdoor.py`` (the same tables, sources and
listeners, imported from the test module):

* ``docs/outdoor_iso.png``: α(f) of ISO 9613-1 Eqs. (3)–(5) against the
  standard's Table 1 and ISO 9613-2's octave table, and the differences in
  units of the tables' last digit;
* ``docs/outdoor_air.png``: what a render loses to the air, static (300 m)
  and approaching at Mach 0.1 (the attenuation at the frequency in the air),
  against α(f) D; the volume's sources (one track at 60 m) too;
* ``docs/outdoor_two_ray.png``: a multi-sine 2 m above a ground, heard 20 m
  away at 1.5 m: the rendered transfer function against
  ``|1 + Q (r1/r2) e^(−ik(r2 − r1))|`` for Q = 1, 0.6, −0.8;
* ``docs/outdoor_height.png``: a 1 kHz tone heard by a listener rising from
  0.2 to 6 m (ground Q = 0.9): level against height and the two-ray curve.

Run: ``python scripts/plot_outdoor.py [OUT_DIR]`` (under a minute once the
kernels are compiled; the tests do not run it).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import test_outdoor as T  # noqa: E402  (the tests' tables, signals and two-ray law)

from auralize.emitters import C0, Emitters, FieldSources  # noqa: E402
from auralize.emitters.outdoor import Air, Ground, air_alpha  # noqa: E402
from auralize.listener import ListenerPath  # noqa: E402
from auralize.rendering import render  # noqa: E402
from auralize.sources.detection import SourceTracks  # noqa: E402

RATE = T.RATE


def iso_figure(out: Path) -> None:
    f = np.geomspace(20, 20000, 400)
    fig, (ax, ar) = plt.subplots(1, 2, figsize=(11, 4.2))
    worst = 0.0
    colours = {}
    for t, rh in ((20, 70), (20, 10), (-20, 70), (50, 70), (0, 15)):
        (line,) = ax.loglog(
            f, 1e3 * air_alpha(f, temperature=t, humidity=rh), lw=1, label=f"{t} °C, {rh} %"
        )
        colours[(t, rh)] = line.get_color()
    res = []
    for t, rh, fn, table in T.ISO_TABLE_1:
        fe = 1000.0 * 10.0 ** (T._NOMINAL_K[fn] / 10.0)
        got = 1e3 * float(air_alpha(fe, temperature=t, humidity=rh))
        unit = T._last_digit(table, 3)
        res.append((fe, (got - table) / unit))
        worst = max(worst, abs(got - table) / unit)
        ax.loglog(fe, table, "o", ms=4, mfc="none", color=colours.get((t, rh), "k"))
    fo = 1000.0 * 10.0 ** (np.arange(-12, 10, 3) / 10.0)
    oct_res = []
    for (t, rh), vals in T.ISO_OCTAVES.items():
        got = 1e3 * air_alpha(fo, temperature=t, humidity=rh)
        unit = np.where(np.array(vals) >= 100, 1.0, 0.1)
        oct_res += list(zip(fo, (got - np.array(vals)) / unit, strict=True))
    ax.set(
        xlabel="frequency, Hz",
        ylabel="α, dB/km",
        title="ISO 9613-1 Eqs. (3)–(5) (lines), Table 1 (circles)",
    )
    ax.legend(fontsize=8)
    r = np.array(res)
    o = np.array(oct_res)
    ar.semilogx(r[:, 0], r[:, 1], "o", mfc="none", label=f"9613-1 Table 1 ({len(r)} entries)")
    ar.semilogx(o[:, 0], o[:, 1], "x", label=f"9613-2 Table 2 ({len(o)} entries)")
    ar.axhspan(-0.5, 0.5, color="0.9", zorder=0, label="± half the last digit")
    ar.set(
        xlabel="frequency, Hz",
        ylabel="computed − table, units of the last digit",
        ylim=(-1, 1),
        title="against the tables' rounding",
    )
    ar.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "outdoor_iso.png", dpi=110)
    plt.close(fig)
    print(
        f"ISO 9613-1 Table 1: {len(r)} entries, largest |computed − table| "
        f"{worst:.2f} of the last digit; ISO 9613-2 Table 2: {len(o)} entries, largest "
        f"{np.max(np.abs(o[:, 1])):.2f}"
    )


def air_figure(out: Path) -> None:
    fig, (ax, af) = plt.subplots(1, 2, figsize=(11, 4.2))
    air = Air(15.0, 50.0)
    fs = np.arange(250.0, 16001.0, 250.0)
    em = Emitters(T._multisine(fs, 1.0)[None], RATE, [[0.0, 300.0, 0.0]])
    path = ListenerPath.point((0, 0, 0), duration=1.0)
    dry = T._amplitudes(render(em, path, rate=RATE).audio[0], fs, 0.9, 0.08)
    wet = T._amplitudes(render(em, path, rate=RATE, air=air).audio[0], fs, 0.9, 0.08)
    got = 20 * np.log10(dry / wet)
    want = air.alpha(fs) * 300.0
    ok = want < 60
    ax.plot(fs / 1e3, want, "k-", lw=1, label="α(f) · 300 m")
    ax.plot(fs[ok] / 1e3, got[ok], "o", ms=3, mfc="none", label="rendered, static source")
    print(
        f"air, static source at 300 m (15 °C, 50 %): largest error "
        f"{np.max(np.abs(got[ok] - want[ok])):.3f} dB up to {want[ok].max():.0f} dB"
    )
    # a source approaching at Mach 0.1: the air takes α at the frequency in the air
    v = 0.1 * C0
    t = np.arange(RATE) / RATE
    traj = np.zeros((1, t.size, 3))
    traj[0, :, 1] = 200.0 - v * t
    tones = np.array([2000.0, 4000.0, 6000.0, 8000.0, 10000.0])
    air2 = Air(20.0, 70.0)
    moving, emitted = [], []
    tau = (200.0 - C0 * 0.9) / (v - C0)
    D = 200.0 - v * tau
    for f in tones:
        e = Emitters(np.sin(2 * np.pi * f * t)[None], RATE, traj)
        p = ListenerPath.point((0, 0, 0), duration=1.0)
        w = slice(int(0.88 * RATE), int(0.92 * RATE))
        d0 = render(e, p, rate=RATE).audio[0][w]
        d1 = render(e, p, rate=RATE, air=air2).audio[0][w]
        moving.append(20 * np.log10(np.std(d0) / np.std(d1)))
        emitted.append(float(air2.alpha(f)) * D)
    fh = tones / 0.9
    ax.plot(
        fh / 1e3, air2.alpha(fh) * D, "C1-", lw=1, label=f"α(f/(1 − M)) · {D:.0f} m, 20 °C 70 %"
    )
    ax.plot(fh / 1e3, moving, "s", color="C1", mfc="none", label="rendered, approaching at M 0.1")
    ax.plot(fh / 1e3, emitted, "C1:", lw=1, label="α at the emitted frequency (not used)")
    err = np.max(np.abs(np.array(moving) - air2.alpha(fh) * D))
    print(f"air, source approaching at Mach 0.1 ({D:.1f} m): largest error {err:.3f} dB")
    ax.set(
        xlabel="frequency heard, kHz",
        ylabel="loss to the air, dB",
        ylim=(0, 65),
        title="emitters: filtered along each path",
    )
    ax.legend(fontsize=8)
    # the volume's sources: one track, the physical timbre, at 60 m
    dr = 24000
    tt = np.arange(int(0.5 * dr)) / dr
    tones = np.array([1000.0, 2000.0, 3000.0, 4000.0, 5000.0, 6000.0])
    got_f = []
    for f in tones:
        tr = SourceTracks(
            positions=np.array([[0.0, 0.0, 2.0]]),
            q=np.sin(2 * np.pi * f * tt)[None],
            radius=np.full(1, 0.1),
            times=tt,
        )
        fsrc = FieldSources(tr, timbre="physical")
        lp = ListenerPath.point((60.0, 0, 0.0), duration=0.3)
        kw = dict(rate=48000, highpass_hz=0.0, duration=0.3)
        w = slice(int(0.22 * 48000), int(0.29 * 48000))
        a = render(fsrc, lp, **kw).audio[0][w]
        b = render(fsrc, lp, air=air2, **kw).audio[0][w]
        got_f.append(20 * np.log10(np.std(a) / np.std(b)))
    Dv = math.hypot(60.0, 2.0)
    ff = np.linspace(500, 6500, 100)
    af.plot(ff / 1e3, air2.alpha(ff) * Dv, "k-", lw=1, label=f"α(f) · {Dv:.1f} m")
    af.plot(tones / 1e3, got_f, "o", mfc="none", label="rendered (physical timbre)")
    print(
        f"air, the volume's sources at {Dv:.1f} m: largest error "
        f"{np.max(np.abs(np.array(got_f) - air2.alpha(tones) * Dv)):.3f} dB"
    )
    af.set(
        xlabel="frequency, kHz",
        ylabel="loss to the air, dB",
        title="the volume's sources: their output at D̄(t)",
    )
    af.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "outdoor_air.png", dpi=110)
    plt.close(fig)


def two_ray_figure(out: Path) -> None:
    fs = np.arange(25.0, 4001.0, 25.0)
    hs, hr, d = 2.0, 1.5, 20.0
    em = Emitters(T._multisine(fs, 0.6)[None], RATE, [[0.0, 0.0, hs]])
    path = ListenerPath.point((d, 0, hr), duration=0.6)
    dry = T._amplitudes(render(em, path, rate=RATE).audio[0], fs, 0.2, 0.4)
    fig, ax = plt.subplots(figsize=(9, 4.2))
    r1, r2 = math.hypot(d, hr - hs), math.hypot(d, hr + hs)
    ff = np.linspace(10, 4000, 2000)
    for i, Q in enumerate((1.0, 0.6, -0.8)):
        wet = T._amplitudes(
            render(em, path, rate=RATE, ground=Ground(0.0, Q)).audio[0], fs, 0.2, 0.4
        )
        want = T._two_ray(Q, hs, hr, d, fs)
        ax.plot(
            ff,
            20 * np.log10(T._two_ray(Q, hs, hr, d, ff)),
            f"C{i}-",
            lw=1,
            label=f"|1 + Q r1/r2 e^(−ikΔ)|, Q = {Q:g}",
        )
        ax.plot(fs, 20 * np.log10(wet / dry), f"C{i}o", ms=3, mfc="none")
        ok = want > 0.3
        print(
            f"two-ray, Q = {Q:g}: largest |rendered − predicted| {np.max(np.abs(wet / dry - want)):.4f} "
            f"of the direct sound; {np.max(np.abs(20 * np.log10(wet[ok] / dry[ok] / want[ok]))):.3f} dB "
            f"where within 10 dB of it"
        )
    for k in range(4):
        ax.axvline((2 * k + 1) * C0 / (2 * (r2 - r1)), color="0.7", lw=0.6, ls=":")
    ax.set(
        xlabel="frequency, Hz",
        ylabel="level re the direct sound, dB",
        ylim=(-30, 8),
        title=f"source 2 m, listener 1.5 m high, 20 m apart; dips (dotted) at "
        f"(2k + 1) c0 / 2(r2 − r1) = {C0 / (2 * (r2 - r1)):.0f} Hz, …",
    )
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    fig.savefig(out / "outdoor_two_ray.png", dpi=110)
    plt.close(fig)


def height_figure(out: Path) -> None:
    f, hs, d, Q = 1000.0, 1.0, 10.0, 0.9
    dur = 3.0
    t = np.arange(int(dur * RATE)) / RATE
    em = Emitters(np.sin(2 * np.pi * f * t)[None], RATE, [[0.0, 0.0, hs]])
    path = ListenerPath.line((d, 0, 0.2), (d, 0, 6.0), duration=dur)
    wet = render(em, path, rate=RATE, ground=Ground(0.0, Q)).audio[0]
    dry = render(em, path, rate=RATE).audio[0]
    win = int(0.01 * RATE)
    c = np.arange(int(0.2 * RATE), t.size - win, win)
    rms = lambda x: np.sqrt(np.mean(x[c[:, None] + np.arange(win)] ** 2, axis=1))  # noqa: E731
    got = rms(wet) / rms(dry)
    hr = np.interp((c + win / 2) / RATE, path.times, path.positions[:, 2])
    r1, r2 = np.hypot(d, hr - hs), np.hypot(d, hr + hs)
    want = np.abs(1 + Q * r1 / r2 * np.exp(-2j * np.pi * f / C0 * (r2 - r1)))
    fig, ax = plt.subplots(figsize=(9, 4.2))
    ax.plot(hr, 20 * np.log10(want), "k-", lw=1, label="|1 + Q r1/r2 e^(−ikΔ)| at the height heard")
    ax.plot(hr[::3], 20 * np.log10(got[::3]), "o", ms=3, mfc="none", label="rendered (10 ms RMS)")
    ok = want > 0.3
    print(
        f"two-ray over height (moving listener): largest error "
        f"{np.max(np.abs(20 * np.log10(got[ok] / want[ok]))):.3f} dB where within 10 dB "
        f"of the direct sound"
    )
    ax.set(
        xlabel="listener height, m",
        ylabel="level re the direct sound, dB",
        title="1 kHz, source 1 m high, 10 m away, ground Q = 0.9; listener rising at 1.9 m/s",
    )
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "outdoor_height.png", dpi=110)
    plt.close(fig)


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs"
    out.mkdir(parents=True, exist_ok=True)
    iso_figure(out)
    air_figure(out)
    two_ray_figure(out)
    height_figure(out)


if __name__ == "__main__":
    main()
