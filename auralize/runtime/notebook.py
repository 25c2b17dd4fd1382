"""Rich displays for Jupyter notebooks (``_repr_html_`` of the core objects).

:class:`~auralize.volume.TimeVolume` shows its grid, fields and times;
:class:`~auralize.sources.detection.SourceSeries` its source counts per type (in the
palette of :mod:`auralize.palette`); :class:`~auralize.listener.ListenerPath`
a small plot of the path; :class:`~auralize.emitters.synthesis.Rendered` an inline
audio player and a spectrogram.  Everything is self-contained HTML (pictures
and sound as ``data:`` URIs); matplotlib draws with the Agg backend.

The core types import this module when a notebook displays them, so it sits at
the bottom of the layers: it imports no other part of auralize than the palette
and reads the objects it shows through their attributes (a render's layout
folds its own channels to stereo, :meth:`auralize.spatial.layouts.Layout.downmix`;
the player's WAV bytes are written with :mod:`wave`).

Examples
--------
>>> from auralize.datasets.synthetic import make_monopole
>>> html = make_monopole(size=8, steps=4)._repr_html_()
>>> "<table" in html and "density" in html
True
"""

from __future__ import annotations

import base64
import html
import io
import wave
from typing import Any

import numpy as np

from auralize.palette import PALETTE

#: longest audio put into a notebook player (seconds; longer renders are cut)
MAX_PLAYER_S = 60.0


def _table(rows: list[tuple[str, str]], title: str) -> str:
    body = "".join(
        f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
        f"<td style='text-align:left'>{v}</td></tr>"
        for k, v in rows
    )
    return f"<div><b>{html.escape(title)}</b><table>{body}</table></div>"


def _png(fig: Any) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    return f"<img src='data:image/png;base64,{base64.b64encode(buf.getvalue()).decode('ascii')}'/>"


def _figure(w: float, h: float, ncols: int = 1) -> Any:
    """A bare matplotlib Figure and its axes (no pyplot: the notebook's backend and its
    figures are left alone)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), layout="constrained")
    return fig, fig.subplots(1, ncols)


def volume_html(vol: Any) -> str:
    """Grid, spacing, bounds, times and fields of a :class:`TimeVolume`."""
    b = vol.bounds
    t = f"{vol.n_steps} steps, {vol.times[0]:g} … {vol.times[-1]:g} s" + (
        "" if vol.physical_times else " (no times in the source: frames at 30 Hz)"
    )
    fields = ", ".join(
        f"{html.escape(n)} ({'vector' if vol.is_vector(n) else 'scalar'})" for n in vol.field_names
    )
    rows = [
        ("source", html.escape(str(vol.source))),
        ("grid", f"{vol.dims[0]} × {vol.dims[1]} × {vol.dims[2]} points"),
        ("spacing", ", ".join(f"{s:g}" for s in vol.spacing) + " m"),
        ("bounds", f"x [{b[0]:g}, {b[1]:g}] y [{b[2]:g}, {b[3]:g}] z [{b[4]:g}, {b[5]:g}] m"),
        ("times", t),
        ("fields", fields),
    ]
    return _table(rows, "TimeVolume")


def series_html(series: Any) -> str:
    """Source counts per type: total over the steps, most in one step (palette colours)."""
    counts = series.counts()
    rows = []
    for kind, rgb in PALETTE.items():
        per = np.array([c[kind] for c in counts])
        name = f"<span style='color:rgb{rgb};font-weight:bold'>{kind}</span>"
        rows.append(
            (
                kind,
                f"{name}: {int(per.sum())} over {series.n_steps} steps, "
                f"at most {int(per.max(initial=0))} in a step",
            )
        )
    out = _table(rows, f"SourceSeries ({series.n_steps} steps)")
    if series.n_steps > 1:
        fig, ax = _figure(5, 1.8)
        plot_counts(series, ax=ax)
        out += _png(fig)
    return out


def plot_counts(series: Any, *, ax: Any = None) -> Any:
    """Sources per time step of each type, in the palette of :mod:`auralize.palette`.

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


def path_html(path: Any) -> str:
    """Captures, duration and a small plot of the path (top view and height)."""
    fig, (a1, a2) = _figure(6, 2.4, ncols=2)
    p = path.positions
    a1.plot(p[:, 0], p[:, 1], color="#ffaa00")
    a1.plot(p[:1, 0], p[:1, 1], "o", color="k", ms=3)
    a1.set_xlabel("x (m)")
    a1.set_ylabel("y (m)")
    a1.set_aspect("equal", adjustable="datalim")
    a1.set_title("top view", fontsize=9)
    a2.plot(path.times, p[:, 2], color="#ffaa00")
    a2.set_xlabel("t (s)")
    a2.set_ylabel("z (m)")
    rows = [
        ("captures", str(path.n_captures)),
        ("duration", f"{path.duration:g} s"),
        ("source", html.escape(str(getattr(path, "source", "")))),
    ]
    return _table(rows, "ListenerPath") + _png(fig)


def wav_data_uri(audio: np.ndarray, rate: int) -> str:
    """A peak-normalised 16-bit WAV of ``audio (n_channels, n)`` (one or two channels) as a
    ``data:`` URI: the bytes :func:`auralize.audio.output.wav_bytes` writes for ``pcm16``.

    Examples
    --------
    >>> uri = wav_data_uri(np.ones((2, 10)), 8000)
    >>> base64.b64decode(uri.split(",", 1)[1])[:4]
    b'RIFF'
    """
    a = np.asarray(audio, dtype=np.float64)
    peak = float(np.max(np.abs(a), initial=0.0))
    a = a * (0.99 / peak) if peak > 0 else a
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(a.shape[0])
        w.setsampwidth(2)
        w.setframerate(int(rate))
        w.writeframes(np.ascontiguousarray(np.round(a.T * 32767), dtype="<i2").tobytes())
    return "data:audio/wav;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def rendered_html(r: Any) -> str:
    """An audio player (stereo downmix of the layout, loudest sample at full scale) and a
    spectrogram of a :class:`Rendered`."""
    a = np.asarray(r.audio, dtype=np.float64)[:, : int(MAX_PLAYER_S * r.rate)]
    note = ""
    if a.shape[0] > 2:
        try:
            a = r.layout.downmix(a, "stereo")
            note = f" (layout {r.layout.name} folded to stereo for the browser)"
        except Exception:  # a layout without a stereo fold: its first two channels
            a = a[:2]
            note = f" (first two channels of {r.layout.name})"
    fig, ax = _figure(6, 2.2)
    mono = a.mean(axis=0)
    if mono.size > 512:
        with np.errstate(divide="ignore"):  # silent stretches are -inf dB, drawn blank
            ax.specgram(mono, NFFT=512, Fs=r.rate, noverlap=256, cmap="magma")
        ax.set_ylabel("f (Hz)")
        ax.set_xlabel("playback time (s)")
    rows = [
        ("layout", html.escape(str(r.layout.name))),
        ("rate", f"{r.rate} Hz"),
        ("duration", f"{r.duration:.3g} s"),
        ("time scale", f"{r.time_scale:g}"),
        ("peak", f"{float(np.max(np.abs(r.audio), initial=0.0)):.3g} Pa"),
    ]
    player = f"<audio controls src='{wav_data_uri(a, r.rate)}'></audio>{html.escape(note)}"
    return _table(rows, "Rendered") + player + "<br/>" + _png(fig)
