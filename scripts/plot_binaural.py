"""Plot the default binaural output's ITD and ILD against the source azimuth.

Renders white noise from a static emitter 30 m away at each azimuth of the
horizontal plane through the default ``binaural`` layout (the ears as receivers)
and through the spherical-head model's own HRIR pair, and plots both:
the ITD below 1.5 kHz and in 2–10 kHz (Woodworth's ray regime), and the ILD in the
third octaves around 1 and 4 kHz.  Writes ``docs/binaural.png``.

    .venv/bin/python scripts/plot_binaural.py [OUT.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy.signal import butter, resample_poly, sosfiltfilt, welch

from auralize.emitters import C0, Emitters, render_emitters
from auralize.listener import ListenerPath
from auralize.spatial import hrtf as H

RATE = 48000


def itd(ears: np.ndarray, band: float | tuple[float, float]) -> float:
    """Lag (ms) of the left ear behind the right, by cross-correlation in ``band``."""
    kind = "bandpass" if isinstance(band, tuple) else "lowpass"
    lo, ro = sosfiltfilt(butter(4, band, kind, fs=RATE, output="sos"), ears, axis=-1)
    n, up = lo.size, 16
    cc = np.fft.irfft(np.fft.rfft(lo, 2 * n) * np.conj(np.fft.rfft(ro, 2 * n)), 2 * n * up)
    m = int(up * RATE * 1e-3)
    return 1e3 * (int(np.argmax(np.r_[cc[-m:], cc[: m + 1]])) - m) / up / RATE


def ild(ears: np.ndarray, f_hz: float) -> float:
    """Right minus left level (dB) in the third octave around ``f_hz``."""
    f, p = welch(ears, fs=RATE, nperseg=1024)
    band = (f > f_hz * 2 ** (-1 / 6)) & (f < f_hz * 2 ** (1 / 6))
    return float(10 * np.log10(p[1, band].sum() / p[0, band].sum()))


def ears_at(az_deg: float, sig: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rendered ears and the model's ears for a source at ``az_deg`` (listener frame)."""
    k = 4200
    dist = k * C0 / RATE
    a = np.radians(az_deg)
    world = dist * np.array([-np.sin(a), np.cos(a), 0.0])  # the listener faces +y, left is -x
    n = 2 * sig.size
    out = render_emitters(
        Emitters(sig[None], RATE // 2, world[None]),
        ListenerPath.point((0, 0, 0), duration=n / RATE),
        rate=RATE,
        layout="binaural",
    ).audio
    d = np.array([np.cos(a), np.sin(a), 0.0])
    up = resample_poly(sig, 2, 1)
    ref = H.binaural_direct(
        np.r_[np.zeros(k), up[: n - k]] / dist, H.spherical_head_hrirs(d[None], RATE).ir[0]
    )
    return out[:, k + 500 :], ref[:, k + 500 :]


def main(out: Path) -> None:
    sig = np.random.default_rng(1).normal(size=RATE // 4)
    az = np.arange(-180, 181, 10)
    rows = []
    for a in az:
        e, r = ears_at(float(a), sig)
        rows.append(
            [itd(x, b) for x in (e, r) for b in (1500.0, (2000.0, 10000.0))]
            + [ild(x, f) for x in (e, r) for f in (1000.0, 4000.0)]
        )
    v = np.array(rows)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax1.plot(az, v[:, 0], "C0-", label="rendered, < 1.5 kHz")
    ax1.plot(az, v[:, 2], "C0:", label="model, < 1.5 kHz")
    ax1.plot(az, v[:, 1], "C1-", label="rendered, 2–10 kHz")
    ax1.plot(az, v[:, 3], "C1:", label="model, 2–10 kHz")
    w = 0.0875 / C0 * (np.radians(np.abs(az)) + np.sin(np.radians(np.abs(az)))) * 1e3
    w = np.where(
        np.abs(az) <= 90,
        w,
        0.0875 / C0 * 1e3 * (np.pi - np.radians(np.abs(az)) + np.sin(np.radians(np.abs(az)))),
    )
    ax1.plot(az, -np.sign(az) * w, "k--", lw=0.8, label="Woodworth (ears at ±90°)")
    ax1.set(
        xlabel="source azimuth (°, + left)",
        ylabel="ITD (ms, + right ear first)",
        title="Interaural time difference",
    )
    ax1.legend(fontsize=7)
    ax2.plot(az, v[:, 4], "C0-", label="rendered, 1 kHz")
    ax2.plot(az, v[:, 6], "C0:", label="model, 1 kHz")
    ax2.plot(az, v[:, 5], "C1-", label="rendered, 4 kHz")
    ax2.plot(az, v[:, 7], "C1:", label="model, 4 kHz")
    ax2.set(
        xlabel="source azimuth (°, + left)",
        ylabel="ILD (dB, right − left)",
        title="Interaural level difference",
    )
    ax2.legend(fontsize=7)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.set_xticks(np.arange(-180, 181, 45))
    fig.suptitle(
        "auralize --layout binaural (ears as receivers, spherical head a = 8.75 cm) "
        "against the Brown & Duda model",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(
        Path(sys.argv[1])
        if len(sys.argv) > 1
        else Path(__file__).parent.parent / "docs" / "binaural.png"
    )
