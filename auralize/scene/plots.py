"""Pictures of rendered audio (matplotlib, Agg backend: no window)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.io.files import atomic_path


def save_spectrogram(audio: NDArray[np.floating], rate: int, out: str | Path, *,
                     channel_names: list[str] | None = None, max_channels: int = 8) -> Path:  # fmt: skip
    """Waveform and spectrogram of each channel (up to ``max_channels``) to a PNG."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from scipy import signal

    a = np.atleast_2d(np.asarray(audio, dtype=np.float64))[:max_channels]
    n_ch = a.shape[0]
    fig, axes = plt.subplots(n_ch, 2, figsize=(12, 1.6 * n_ch + 0.8), squeeze=False,
                             gridspec_kw={"width_ratios": [1, 2]})  # fmt: skip
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


def plot_counts(series: Any, *, ax: Any = None) -> Any:
    """Sources per time step of each type, in the palette of :mod:`auralize.scene.pictures`.

    Parameters
    ----------
    series : SourceSeries
    ax : matplotlib Axes, optional (a new figure's otherwise)

    Returns
    -------
    matplotlib Axes

    Examples
    --------
    >>> from auralize.pipeline import detect_sources, load
    >>> ax = plot_counts(detect_sources(load("dataset:monopole", size=8, steps=6)))
    >>> [line.get_label() for line in ax.get_lines()]
    ['monopole']
    """
    from auralize.scene.pictures import PALETTE

    if ax is None:
        from matplotlib.figure import Figure

        ax = Figure(figsize=(5, 2), layout="constrained").subplots()
    counts = series.counts()
    t = np.asarray(series.times, dtype=np.float64)
    for kind, rgb in PALETTE.items():
        n = np.array([c[kind] for c in counts])
        if n.any():  # the legend lists only what is there
            ax.plot(t, n, color=np.asarray(rgb) / 255, label=kind)
    ax.set_xlabel("data time (s)")
    ax.set_ylabel("sources")
    if ax.get_lines():
        ax.legend(fontsize=7, loc="upper right")
    return ax
