"""Pictures of rendered audio (matplotlib, Agg backend: no window)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from auralize.runtime.files import atomic_path
from auralize.runtime.notebook import plot_counts as plot_counts


def save_spectrogram(
    audio: NDArray[np.floating],
    rate: int,
    out: str | Path,
    *,
    channel_names: list[str] | None = None,
    max_channels: int = 8,
) -> Path:
    """Waveform and spectrogram of each channel (up to ``max_channels``) to a PNG.

    Examples
    --------
    >>> import tempfile
    >>> out = save_spectrogram(np.zeros((1, 4800)), 48000, Path(tempfile.mkdtemp()) / "s.png")
    >>> out.read_bytes()[:4]
    b'\x89PNG'
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from scipy import signal

    a = np.atleast_2d(np.asarray(audio, dtype=np.float64))[:max_channels]
    n_ch = a.shape[0]
    fig, axes = plt.subplots(
        n_ch, 2, figsize=(12, 1.6 * n_ch + 0.8), squeeze=False, gridspec_kw={"width_ratios": [1, 2]}
    )
    t = np.arange(a.shape[1]) / rate
    peak = float(np.max(np.abs(a))) or 1.0
    for c in range(n_ch):
        name = channel_names[c] if channel_names else f"ch {c}"
        axes[c, 0].plot(t, a[c], lw=0.5, color="k")
        axes[c, 0].set_ylim(-peak, peak)
        axes[c, 0].set_ylabel(name)
        nper = min(2048, max(64, a.shape[1] // 8))
        f, tt, sxx = signal.spectrogram(a[c], fs=rate, nperseg=nper, noverlap=nper // 2)
        db = 10 * np.log10(sxx + 1e-20 * peak**2)
        axes[c, 1].pcolormesh(tt, f, db, shading="auto", vmin=db.max() - 80, vmax=db.max())
        axes[c, 1].set_yscale("symlog", linthresh=100)
        axes[c, 1].set_ylim(20, rate / 2)
    axes[-1, 0].set_xlabel("time (s)")
    axes[-1, 1].set_xlabel("time (s)")
    axes[0, 1].set_title("spectrogram (dB, 80 dB range)")
    fig.tight_layout()
    out = Path(out)
    with atomic_path(out, suffix=".part.png") as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)
    return out
