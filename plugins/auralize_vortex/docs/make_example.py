"""Render the built-in fire plume to ring8 and plot its spectrogram (README example).

Run: ``.venv/bin/python plugins/auralize_vortex/docs/make_example.py``
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from auralize_vortex import render_vortex, texture
from auralize_vortex.datasets import make_fire_plume
from scipy.signal import spectrogram

from auralize.audio.output import write_audio
from auralize.listener import ListenerPath
from auralize.runtime.files import atomic_path

HERE = Path(__file__).parent


def main() -> None:
    tex, cached = texture()  # default: 8 speeds 0.5..6 m/s, cached after the first run
    plume = make_fire_plume(steps=60)  # 15 x 15 x 20 voxels, 2 s at 30 Hz
    path = ListenerPath.point(plume.center + [0.0, -2.0, 0.0], duration=2.0)
    r = render_vortex(plume, path, tex, layout="ring8")
    write_audio(HERE / "plume_ring8.wav", r.audio, r.rate, channel_mask=r.layout.channel_mask)
    mono = r.audio.sum(axis=0)
    f, t, s = spectrogram(mono, fs=r.rate, nperseg=2048, noverlap=1536)
    fig, ax = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    ax[0].plot(np.arange(mono.size) / r.rate, mono * 1e6, lw=0.5)
    ax[0].set_ylabel("pressure (µPa)")
    ax[0].set_title("fire-plume, 36 sub-volumes, ring8 summed (listener 2 m away)")
    ax[1].pcolormesh(t, f, 10 * np.log10(s + 1e-30), shading="auto", cmap="magma")
    ax[1].set_ylim(0, 600)
    ax[1].set_ylabel("frequency (Hz)")
    ax[1].set_xlabel("time (s)")
    fig.tight_layout()
    with atomic_path(HERE / "plume_spectrogram.png") as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    print(f"texture {'reused' if cached else 'computed'}; rms by speed {tex.rms()}")


if __name__ == "__main__":
    main()
