"""Draw the FW-H verification figures of docs/fwh.md and print their measured errors.

One figure per case of ``tests/test_fwh_verification.py`` (the same fields,
surfaces and observers, imported from the test module):

* ``docs/fwh_rotating_monopole.png``: a monopole on a circle at Mach 0.4, heard
  40 m away in the plane of rotation and above it, against the closed form and
  the same field without its Doppler factor; errors of four surfaces;
* ``docs/fwh_rotating_dipole.png``: the dipole across the plane (a rotor's
  thrust): waveforms above the plane and the peak against elevation;
* ``docs/fwh_pulsating_sphere.png``: the pulsating sphere through a box and a
  sphere, against the exact solution and a point source of the same flow;
* ``docs/fwh_volume_sum.png``: the spinning vortex heard by the volume
  (Lighthill) sum of its stress and by FW-H on its stored sound.

Run: ``python scripts/plot_fwh_verification.py [OUT_DIR]`` (about a minute;
the tests do not run it).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import test_fwh_verification as V  # noqa: E402  (the tests' fields, surfaces, observers)

import auralize.pipeline as ap  # noqa: E402
from auralize.datasets.synthetic import make_spinning  # noqa: E402
from auralize.fwh import (  # noqa: E402
    box_surface,
    fwh_pressure,
    fwh_time_window,
    sample_surface,
    sphere_surface,
)
from auralize.fwh.analytic import (  # noqa: E402
    PulsatingSphere,
    SpinningSound,
    retarded_time,
    rotating_field,
    rotating_volume,
    sphere_volume,
    spinning_volume,
)

DPI = 90


def _room(ax, frac: float = 0.6) -> None:  # type: ignore[no-untyped-def]
    """Make room below the curves for a legend."""
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo - frac * (hi - lo), hi)


def _pct(x: float) -> str:
    return f"{100 * x:.2f} %"


def rotating_monopole(out: Path) -> None:
    vol = rotating_volume("monopole", V.ORBIT, V.TONE, **V.GRID)  # type: ignore[arg-type]
    surfaces = {
        "box ±0.45 m, h": V._box(0.45),
        "box ±0.55 m, h": V._box(0.55),
        "box ±0.45 m, h/2": V._box(0.45, panel=V.H / 2),
        "box ±0.45 m, 2h": V._box(0.45, panel=2 * V.H),
    }
    samples = {k: sample_surface(vol, s, rho0=V.RHO0, c0=V.C0) for k, s in surfaces.items()}
    obs = V._observers(40.0, V.ROT_ANGLES)
    t = V._window(list(samples.values()), obs, n_t=800)
    exact, _ = rotating_field("monopole", V.ORBIT, t[None, :], V._at(obs, t), V.TONE)
    tau = retarded_time(V.ORBIT, t[None, :], V._at(obs, t), c0=V.C0)
    y, _, _ = V.ORBIT.kinematics(tau)
    naive = V.RHO0 * V.TONE.q(tau)[1] / (4 * np.pi * np.linalg.norm(V._at(obs, t) - y, axis=-1))
    ps = {k: fwh_pressure(s, None, obs, t) for k, s in samples.items()}
    ref = ps["box ±0.45 m, h"]
    print("rotating monopole (elevation, azimuth):", V.ROT_ANGLES)
    for k, p in ps.items():
        print(
            f"  {k:18s} vs exact",
            [_pct(e) for e in V._rms_err(p, exact)],
            " vs box ±0.45 h",
            [_pct(e) for e in V._rms_err(p, ref)],
        )
    print("  no Doppler factor vs FW-H", [_pct(e) for e in V._rms_err(ref, naive)])
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.0))
    for ax, i in zip(axes[:2], (0, 2), strict=True):
        el, az = V.ROT_ANGLES[i]
        ax.plot(1e3 * t, exact[i], "k-", lw=2.5, label="closed form")
        ax.plot(
            1e3 * t,
            ref[i],
            "C1--",
            lw=1.5,
            label=f"FW-H box ±0.45 m: RMS error {_pct(V._rms_err(ref[i], exact[i]))}",
        )
        ax.plot(1e3 * t, naive[i], "C0:", lw=1.2, label="without the Doppler factor")
        ax.set(
            xlabel="observer time (ms)",
            ylabel="p' (Pa)",
            title=f"40 m, elevation {el}°, azimuth {az}°",
        )
        _room(ax)
        ax.legend(loc="lower left", fontsize=7)
    ax = axes[2]
    width = 0.2
    for j, (k, p) in enumerate(ps.items()):
        ax.bar(np.arange(len(obs)) + (j - 1.5) * width, 100 * V._rms_err(p, exact), width, label=k)
    ax.axhline(100 * V.TOL_ROTATING, color="k", lw=1, ls="--", label="tolerance")
    ax.set_xticks(np.arange(len(obs)), [f"{e}°/{a}°" for e, a in V.ROT_ANGLES], fontsize=8)
    ax.set(
        xlabel="observer (elevation/azimuth)",
        ylabel="RMS error (%)",
        title="four surfaces against the closed form",
    )
    ax.legend(fontsize=7)
    fig.suptitle("Monopole on a circle (R = 0.2 m, Mach 0.4, 250 Hz tone)", fontsize=11)
    fig.tight_layout()
    fig.savefig(out, dpi=DPI)


def rotating_dipole(out: Path) -> None:
    vol = rotating_volume("dipole", V.ORBIT, V.TONE, **V.GRID)  # type: ignore[arg-type]
    smp = sample_surface(vol, V._box(0.45), rho0=V.RHO0, c0=V.C0)
    obs = V._observers(40.0, V.ROT_ANGLES)
    t = V._window([smp], obs, n_t=800)
    p = fwh_pressure(smp, None, obs, t)
    exact, _ = rotating_field("dipole", V.ORBIT, t[None, :], V._at(obs, t), V.TONE)
    err = V._rms_err(p[2:], exact[2:])
    print(
        "rotating dipole",
        V.ROT_ANGLES[2:],
        [_pct(e) for e in err],
        "in-plane peak / loudest",
        _pct(np.abs(p[:2]).max() / np.abs(p).max()),
    )
    elev = np.arange(-90, 91, 15)
    obs2 = V._observers(40.0, [(e, 60) for e in elev])
    t2 = V._window([smp], obs2, n_t=600)
    p2 = fwh_pressure(smp, None, obs2, t2)
    e2, _ = rotating_field("dipole", V.ORBIT, t2[None, :], V._at(obs2, t2), V.TONE)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.0))
    for ax, i in zip(axes[:2], (2, 5), strict=True):
        el, az = V.ROT_ANGLES[i]
        ax.plot(1e3 * t, exact[i], "k-", lw=2.5, label="closed form")
        ax.plot(
            1e3 * t,
            p[i],
            "C1--",
            lw=1.5,
            label=f"FW-H: RMS error {_pct(V._rms_err(p[i], exact[i]))}",
        )
        ax.set(
            xlabel="observer time (ms)",
            ylabel="p' (Pa)",
            title=f"40 m, elevation {el}°, azimuth {az}°",
        )
        _room(ax)
        ax.legend(loc="lower left", fontsize=7)
    ax = axes[2]
    ax.plot(elev, np.abs(e2).max(axis=1), "k-", lw=2.5, label="closed form")
    ax.plot(elev, np.abs(p2).max(axis=1), "C1o", label="FW-H")
    ax.set(
        xlabel="elevation from the plane of rotation (°)",
        ylabel="peak |p'| (Pa)",
        title="peak pressure at 40 m, azimuth 60°",
    )
    ax.legend(fontsize=8)
    fig.suptitle(
        "Dipole across the plane of rotation (a rotor's thrust) on the same circle", fontsize=11
    )
    fig.tight_layout()
    fig.savefig(out, dpi=DPI)


def pulsating_sphere(out: Path) -> None:
    sp = PulsatingSphere(t_centre=4e-3, c0=V.C0, rho0=V.RHO0)
    vol = sphere_volume(sp, n=25, spacing=V.H, origin=-0.6, steps=80, dt=1.5e-4)
    surfaces = {
        "box ±0.4 m": V._box(0.4),
        "box ±0.3 m": V._box(0.3),
        "sphere r = 0.35 m": sphere_surface(V.XS, 0.35, resolution=3),
    }
    samples = {k: sample_surface(vol, s, rho0=V.RHO0, c0=V.C0) for k, s in surfaces.items()}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.0))
    for ax, R in zip(axes, (40.0, 3.0), strict=True):
        obs = V._observers(R, [(0, 0), (35, 45), (90, 0), (-20, 200)])
        t = V._window(list(samples.values()), obs, n_t=600)
        exact, _ = sp.field(t[None, :], V._at(obs, t))
        point = sp.point_source_pressure(t[None, :], V._at(obs, t))
        ax.plot(1e3 * t, exact[1], "k-", lw=2.5, label="exact (radiation impedance)")
        for j, (k, smp) in enumerate(samples.items()):
            p = fwh_pressure(smp, None, obs, t)
            err = V._rms_err(p, exact)
            print(f"pulsating sphere {R:g} m {k:18s}", [_pct(e) for e in err])
            ax.plot(
                1e3 * t, p[1], f"C{j + 1}--", lw=1.3, label=f"FW-H {k}: RMS error {_pct(err[1])}"
            )
        print(
            f"pulsating sphere {R:g} m point source vs exact",
            [_pct(e) for e in V._rms_err(point, exact)],
        )
        ax.plot(1e3 * t, point[1], "C0:", lw=1.2, label="point source of the same volume flow")
        ax.set(
            xlabel="observer time (ms)",
            ylabel="p' (Pa)",
            title=f"{R:g} m, elevation 35°, azimuth 45°",
        )
        ax.legend(loc="upper right", fontsize=7)
    fig.suptitle(
        f"Pulsating sphere (a = {sp.radius} m, surface velocity a σ = "
        f"{1e3 * sp.sigma} ms Gaussian pulse)",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(out, dpi=DPI)


def volume_sum(out: Path) -> None:
    snd = SpinningSound(V.SPIN, c0=V.C0)
    sg = V.SPIN.sigma
    vol = spinning_volume(sound=snd)
    smp = sample_surface(
        vol, box_surface((-6 * sg, 6 * sg) * 3, panel_size=vol.spacing[0]), rho0=V.RHO0, c0=V.C0
    )
    cut = sample_surface(
        vol,
        box_surface((-4.45 * sg, 4.45 * sg) * 3, panel_size=vol.spacing[0]),
        rho0=V.RHO0,
        c0=V.C0,
    )
    flow = make_spinning(size=V.SPIN.size, kL=V.SPIN.kL).load()
    R = 30 * V.C0 / V.SPIN.frequency
    rate = 20000
    nyquist = 0.5 / float(flow.times[1] - flow.times[0])
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.0))
    for ax, d in zip(axes, ([1.0, 0, 0], [np.cos(0.6), np.sin(0.6), 0.3]), strict=True):
        x = R * np.asarray(d) / np.linalg.norm(d)
        res, _ = ap.auralize(
            flow,
            listener=x,
            rate=rate,
            time_scale=1.0,
            timbre="physical",
            highpass_hz=0.0,
            layout="mono",
        )
        tv = res.meta["lead_data_s"] + np.arange(res.audio.shape[1]) / rate
        w = fwh_time_window(smp.times, smp.surface, x[None], c0=V.C0)[0]
        sel = (tv >= w[0]) & (tv <= w[1])
        t, vs = tv[sel], res.audio[0, sel]
        p = fwh_pressure(smp, None, x[None], t)[0]
        pc = fwh_pressure(cut, None, x[None], t)[0]
        exact = snd.field(t, x[None])[0][:, 0]
        band = V._harmonics(t, vs, V.SPIN.frequency, nyquist)
        ok = np.isfinite(pc)
        print(
            f"spinning vortex, direction {np.round(d, 2).tolist()}: FW-H vs exact "
            f"{_pct(V._rms_err(p, exact))}, volume sum vs FW-H {_pct(V._rms_err(vs, p))} "
            f"as rendered, {_pct(V._rms_err(band, p))} below {nyquist:g} Hz; box at 4.45 σ "
            f"vs exact {_pct(V._rms_err(pc[ok], exact[ok]))}"
        )
        n = min(t.size, int(3 / V.SPIN.frequency * rate))
        s = slice(0, n)
        ax.plot(1e3 * t[s], 1e6 * exact[s], "k-", lw=2.5, label="exact (Lighthill, multipoles)")
        ax.plot(
            1e3 * t[s],
            1e6 * p[s],
            "C1--",
            lw=1.5,
            label=f"FW-H, box at 6σ: {_pct(V._rms_err(p, exact))}",
        )
        ax.plot(
            1e3 * t[s],
            1e6 * vs[s],
            "C0-",
            lw=0.8,
            alpha=0.8,
            label=f"volume sum as rendered: {_pct(V._rms_err(vs, p))} from FW-H",
        )
        ax.plot(
            1e3 * t[s],
            1e6 * band[s],
            "C2:",
            lw=1.5,
            label=f"volume sum below {nyquist:g} Hz: {_pct(V._rms_err(band, p))}",
        )
        ax.plot(
            1e3 * t[s],
            1e6 * pc[s],
            "C3-.",
            lw=1.0,
            label=f"FW-H, box at 4.45σ (cuts the flow): {_pct(V._rms_err(pc[ok], exact[ok]))}",
        )
        ax.set(
            xlabel="observer time (ms)",
            ylabel="p' (µPa)",
            title=f"{R:.0f} m along {np.round(np.asarray(d) / np.linalg.norm(d), 2).tolist()}",
        )
        _room(ax, 0.9)
        ax.legend(loc="lower left", fontsize=7)
    fig.suptitle(
        f"Spinning vortex (kL = {V.SPIN.kL}, {V.SPIN.frequency:g} Hz): FW-H = the "
        f"volume (Lighthill) sum",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(out, dpi=DPI)


def main(out_dir: Path) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, fn in (
        ("fwh_rotating_monopole", rotating_monopole),
        ("fwh_rotating_dipole", rotating_dipole),
        ("fwh_pulsating_sphere", pulsating_sphere),
        ("fwh_volume_sum", volume_sum),
    ):
        path = out_dir / f"{name}.png"
        fn(path)
        plt.close("all")
        print(f"wrote {path} ({path.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs")
