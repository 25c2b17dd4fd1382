"""Draw docs/fwh.png, the verification figure of docs/fwh.md.

Three panels from the exact linear fields of ``tests/test_fwh.py`` (a
Gaussian-pulse monopole and z-dipole stored as density, velocity and
pressure on a 41³ grid), through :func:`auralize.fwh.fwh_pressure`:

1. the monopole heard 40 m away through a box: FW-H against the closed form;
2. the dipole's peak pressure at 40 m against angle: FW-H and |cos θ|;
3. the same monopole through two boxes and a sphere, and through a box
   beside the source (no source inside: silent).

The fields are the test module's (imported from ``tests/``), so the figure
shows what the tests check.  Run: ``python scripts/make_fwh_figure.py [OUT.png]``
(about 15 s).
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

import test_fwh as F  # noqa: E402  (the tests' closed-form fields)

from auralize.fwh import (  # noqa: E402
    box_surface,
    fwh_pressure,
    fwh_time_window,
    sample_surface,
    sphere_surface,
)


def main(out: Path) -> None:
    mono = F._volume("monopole")
    box = sample_surface(mono, box_surface(F.BOX, panel_size=F.H))
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))

    obs = F._observers(40.0, [0])
    p, exact, t = F._compare("monopole", box, obs, n_t=600)
    err = F._rms_err(p, exact)[0]
    ax = axes[0]
    ax.plot(1e3 * t, exact[0], "k-", lw=2.5, label="closed form")
    ax.plot(1e3 * t, p[0], "C1--", lw=1.5, label=f"FW-H box ({box.surface.n_panels} panels)")
    ax.set(
        xlabel="observer time (ms)",
        ylabel="p' (Pa)",
        title=f"monopole at 40 m: RMS error {100 * err:.2f} %",
    )
    ax.legend(loc="lower left", fontsize=8)

    dip = sample_surface(F._volume("dipole"), box_surface(F.BOX, panel_size=F.H))
    deg = np.arange(0, 181, 15)
    obs = F._observers(40.0, deg)
    p, exact, _ = F._compare("dipole", dip, obs)
    ax = axes[1]
    th = np.linspace(0, 180, 200)
    ax.plot(th, np.abs(np.cos(np.radians(th))), "k-", lw=2.5, label="|cos θ|")
    ax.plot(deg, np.abs(p).max(axis=1) / np.abs(p).max(), "C1o", label="FW-H peak / on-axis")
    ax.set(
        xlabel="angle from the dipole axis θ (°)",
        ylabel="relative peak pressure",
        title="dipole directivity at 40 m",
    )
    ax.legend(fontsize=8)

    obs = F._observers(40.0, [60])
    others = {
        "box 1.2 m": box,
        "box 0.75 m (off-centre)": sample_surface(
            mono, box_surface((-0.35, 0.4, -0.4, 0.35, -0.3, 0.45), panel_size=F.H)
        ),
        "sphere r = 0.75 m": sample_surface(
            mono, sphere_surface((0.02, 0, -0.01), 0.75, resolution=3)
        ),
        "box beside the source": sample_surface(
            mono, box_surface((-0.9, -0.2, -0.5, 0.5, -0.5, 0.5), panel_size=F.H)
        ),
    }
    w = np.concatenate([fwh_time_window(s.times, s.surface, obs) for s in others.values()])
    t = np.linspace(w[:, 0].max(), w[:, 1].min(), 600)
    exact = F._field("monopole", F.XS, t, obs[0])[0]
    ax = axes[2]
    ax.plot(1e3 * t, exact, "k-", lw=3, label="closed form")
    for i, (name, smp) in enumerate(others.items()):
        p = fwh_pressure(smp, None, obs, t)[0]
        e = F._rms_err(p, exact) if "beside" not in name else np.abs(p).max() / np.abs(exact).max()
        tag = "peak" if "beside" in name else "RMS err"
        ax.plot(1e3 * t, p, f"C{i + 1}--", lw=1.2, label=f"{name}: {tag} {100 * e:.2f} %")
    ax.set(xlabel="observer time (ms)", ylabel="p' (Pa)", title="surface independence (θ = 60°)")
    ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "fwh.png")
