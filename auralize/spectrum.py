"""Numbers as the field reports them: sound pressure level, OASPL and ⅓-octave bands.

What OpenFOAM's ``noise`` utility and the aeroacoustics papers tabulate, from any
pressure signal in pascals: an auralize render (``--normalize none``, or a
normalised file whose sidecar records its gain), the pressure at an observer
from the volume sum or from FW-H.

* **OASPL** = 10 log10(⟨p²⟩ / p_ref²) dB, p_ref = 20 µPa, over the whole
  signal (the mean removed: a static pressure is not sound).
* **⅓-octave bands**: base-10 centres f_m = 1000 · 10^((n−30)/10) Hz (IEC 61260-1),
  edges f_m · 10^(±1/20); each band's level is the energy of the one-sided
  periodogram in it (Parseval: the bands of the whole audible range sum to
  the OASPL of what lies in that range).
* **A-weighted** overall level (dBA) with the A curve of IEC 61672-1.
* A narrowband Welch spectrum (Pa²/Hz) for the plot.

Examples
--------
>>> import numpy as np
>>> rate = 48000
>>> t = np.arange(rate) / rate
>>> s = spectrum(np.sqrt(2) * 1.0 * np.sin(2 * np.pi * 1000 * t)[None], rate)  # 1 Pa rms
>>> round(float(s.oaspl[0]), 2), s.band_label(int(np.argmax(s.band_levels[0])))
(93.98, '1000')
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.errors import FormatError, MissingFileError, ParameterError

__all__ = [
    "P_REF",
    "Spectrum",
    "a_weighting_db",
    "observer_pressure",
    "read_pascals",
    "spectrum",
    "third_octaves",
]

#: reference pressure of sound pressure levels in air, Pa
P_REF = 20e-6
#: nominal labels of the base-10 ⅓-octave centres (IEC 61260-1, Annex E), n = 10 .. 43
_NOMINAL = (
    "10",
    "12.5",
    "16",
    "20",
    "25",
    "31.5",
    "40",
    "50",
    "63",
    "80",
    "100",
    "125",
    "160",
    "200",
    "250",
    "315",
    "400",
    "500",
    "630",
    "800",
    "1000",
    "1250",
    "1600",
    "2000",
    "2500",
    "3150",
    "4000",
    "5000",
    "6300",
    "8000",
    "10000",
    "12500",
    "16000",
    "20000",
)


def third_octaves(
    fmin: float = 10.0, fmax: float = 20000.0
) -> tuple[NDArray[np.float64], list[str]]:
    """Exact base-10 ⅓-octave centres (Hz) from ``fmin`` to ``fmax`` and their nominal labels.

    Examples
    --------
    >>> fm, labels = third_octaves(900, 1300)
    >>> [round(float(f), 1) for f in fm], labels
    ([1000.0, 1258.9], ['1000', '1250'])
    """
    n = np.arange(10, 44)
    fm = 1000.0 * 10.0 ** ((n - 30) / 10.0)
    keep = (fm >= fmin * 10 ** (-1 / 20)) & (fm <= fmax * 10 ** (1 / 20))
    return fm[keep], [_NOMINAL[i] for i in np.flatnonzero(keep)]


def a_weighting_db(f: NDArray[np.floating]) -> NDArray[np.float64]:
    """The A-weighting (dB) at frequencies ``f`` (Hz), IEC 61672-1 Eq. (E.6): 0 dB at 1 kHz.

    Examples
    --------
    >>> [round(float(v), 1) for v in a_weighting_db(np.array([100.0, 1000.0, 10000.0]))]
    [-19.1, 0.0, -2.5]
    """
    f2 = np.asarray(f, dtype=np.float64) ** 2
    ra = (12194.0**2 * f2**2) / (
        (f2 + 20.6**2) * np.sqrt((f2 + 107.7**2) * (f2 + 737.9**2)) * (f2 + 12194.0**2)
    )
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(ra) + 2.00


def _level(mean_square: NDArray[np.floating]) -> NDArray[np.float64]:
    """dB re 20 µPa of a mean square pressure (−inf for silence)."""
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(np.asarray(mean_square, dtype=np.float64) / P_REF**2)


@dataclass
class Spectrum:
    """Levels of a pressure signal per channel (see the module docstring).

    Attributes
    ----------
    rate : int, Hz.
    duration : float, seconds analysed.
    channels : list of str, channel names.
    oaspl : (n_ch,) dB re 20 µPa.
    oaspl_a : (n_ch,) dBA.
    band_centres : (n_b,) exact ⅓-octave centres, Hz; ``band_labels`` nominal.
    band_levels : (n_ch, n_b) dB re 20 µPa.
    freqs, psd : Welch narrowband spectrum, Hz and Pa²/Hz ``(n_ch, n_f)``.
    source : str, what was analysed.
    """

    rate: int
    duration: float
    channels: list[str]
    oaspl: NDArray[np.float64]
    oaspl_a: NDArray[np.float64]
    band_centres: NDArray[np.float64]
    band_labels: list[str]
    band_levels: NDArray[np.float64]
    freqs: NDArray[np.float64]
    psd: NDArray[np.float64]
    source: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def band_label(self, i: int) -> str:
        return self.band_labels[i]

    def __repr__(self) -> str:
        from auralize.runtime.reprs import summary

        levels = ", ".join(
            f"{c} {v:.1f} dB ({a:.1f} dBA)"
            for c, v, a in zip(self.channels, self.oaspl, self.oaspl_a, strict=True)
        )
        return summary(
            f"Spectrum {self.source}".strip(),
            [
                ("signal", f"{self.duration:.4g} s at {self.rate} Hz, {len(self.channels)} ch"),
                ("OASPL", levels),
                (
                    "bands",
                    f"{len(self.band_centres)} third octaves, {self.band_labels[0]} – "
                    f"{self.band_labels[-1]} Hz"
                    if self.band_labels
                    else "none",
                ),
            ],
        )

    def as_dict(self) -> dict[str, Any]:
        """JSON-able: levels in dB re 20 µPa (``null`` for silence), per channel."""

        def db(v: float) -> float | None:
            return round(float(v), 3) if math.isfinite(v) else None

        return {
            "source": self.source,
            "rate": self.rate,
            "duration_s": self.duration,
            "reference_pa": P_REF,
            "weighting": "Z (and A for oaspl_dba)",
            "band_centres_hz": [round(float(f), 3) for f in self.band_centres],
            "band_labels_hz": list(self.band_labels),
            "channels": {
                c: {
                    "oaspl_db": db(self.oaspl[i]),
                    "oaspl_dba": db(self.oaspl_a[i]),
                    "bands_db": [db(v) for v in self.band_levels[i]],
                }
                for i, c in enumerate(self.channels)
            },
            **self.meta,
        }

    def csv_text(self) -> str:
        """One row per ⅓-octave band (nominal and exact centre), one column per channel,
        then the OASPL and dBA rows."""
        head = ["band_hz", "centre_hz", *(f"{c}_db" for c in self.channels)]
        rows = [",".join(head)]
        for j, (lab, fm) in enumerate(zip(self.band_labels, self.band_centres, strict=True)):
            vals = [f"{v:.3f}" if math.isfinite(v) else "" for v in self.band_levels[:, j]]
            rows.append(",".join([lab, f"{fm:.3f}", *vals]))
        for name, arr in (("OASPL", self.oaspl), ("OASPL_A", self.oaspl_a)):
            vals = [f"{v:.3f}" if math.isfinite(v) else "" for v in arr]
            rows.append(",".join([name, "", *vals]))
        return "\n".join(rows) + "\n"

    def save(self, path: str | Path) -> Path:
        """Write the levels as ``.csv`` or ``.json`` (atomically); returns the path."""
        from auralize.runtime.files import atomic_write

        p = Path(path)
        suffix = p.suffix.lower()
        if suffix == ".csv":
            atomic_write(p, self.csv_text().encode())
        elif suffix == ".json":
            atomic_write(p, (json.dumps(self.as_dict(), indent=2) + "\n").encode())
        else:
            raise ParameterError(f"{p}: the levels are written as .csv or .json, got {suffix!r}")
        return p

    def plot(self, path: str | Path) -> Path:
        """A picture (PNG/SVG/PDF): ⅓-octave levels as bars and the narrowband spectrum."""
        import matplotlib

        matplotlib.use("Agg", force=False)
        from matplotlib.figure import Figure

        from auralize.runtime.files import atomic_path

        fig = Figure(figsize=(8, 6), layout="constrained")
        ax1, ax2 = fig.subplots(2, 1)
        n = len(self.channels)
        width = 1.0 / (n + 1)
        x = np.arange(len(self.band_centres))
        for i, c in enumerate(self.channels):
            lv = np.where(np.isfinite(self.band_levels[i]), self.band_levels[i], np.nan)
            ax1.bar(
                x + (i - (n - 1) / 2) * width,
                lv,
                width=width,
                label=f"{c}: {self.oaspl[i]:.1f} dB, {self.oaspl_a[i]:.1f} dBA",
            )
        ax1.set_xticks(x[::3], [self.band_labels[k] for k in x[::3]])
        ax1.set_xlabel("⅓-octave band (Hz)")
        ax1.set_ylabel("SPL (dB re 20 µPa)")
        ax1.legend(fontsize=8)
        ax1.set_title(f"{self.source}: OASPL and ⅓-octave bands".strip(": "))
        for i, c in enumerate(self.channels):
            with np.errstate(divide="ignore"):
                ax2.semilogx(
                    self.freqs[1:], 10 * np.log10(self.psd[i, 1:] / P_REF**2), lw=0.8, label=c
                )
        ax2.set_xlabel("frequency (Hz)")
        ax2.set_ylabel("PSD (dB re 20 µPa²/Hz)")
        ax2.grid(True, which="both", lw=0.3)
        out = Path(path)
        with atomic_path(out) as tmp:
            fig.savefig(tmp, format=out.suffix.lstrip(".").lower() or "png", dpi=120)
        return out


def spectrum(
    audio: NDArray[np.floating],
    rate: int,
    *,
    channels: list[str] | None = None,
    fmin: float = 10.0,
    fmax: float | None = None,
    source: str = "",
) -> Spectrum:
    """Levels of ``audio (n_channels, n_samples)`` in pascals at ``rate`` Hz.

    Parameters
    ----------
    audio : (n_channels, n_samples) or (n_samples,) array, Pa.
    rate : int, Hz.
    channels : list of str, optional
        Channel names (default ``ch0``, ``ch1``, ...).
    fmin, fmax : float
        The ⅓-octave bands reported (default 10 Hz to the highest band below
        the Nyquist frequency, at most 20 kHz).
    source : str
        What the signal is (recorded with the levels).

    Returns
    -------
    Spectrum

    Raises
    ------
    ParameterError
        No samples, a non-finite sample, or a bad rate.
    """
    p = np.asarray(audio, dtype=np.float64)
    if p.ndim == 1:
        p = p[None]
    if p.ndim != 2 or p.shape[1] < 2:
        raise ParameterError(
            f"spectrum: a signal (n_channels, n_samples) of at least 2 samples "
            f"is needed, got shape {p.shape}"
        )
    if not np.all(np.isfinite(p)):
        raise ParameterError("spectrum: the signal holds NaN or Inf samples")
    if not (isinstance(rate, int | np.integer) and rate > 0):
        raise ParameterError(f"spectrum: the rate must be a whole number of Hz > 0, got {rate!r}")
    rate = int(rate)
    p = p - p.mean(axis=1, keepdims=True)  # a static pressure is not sound
    n = p.shape[1]
    top = min(20000.0, rate / 2 / 10 ** (1 / 20)) if fmax is None else float(fmax)
    fm, labels = third_octaves(fmin, top)
    # one-sided periodogram, Pa²/Hz: its sum × df is the mean square (Parseval)
    spec = np.fft.rfft(p, axis=1)
    power = np.abs(spec) ** 2 / (n * n)
    power[:, 1:] *= 2.0
    if n % 2 == 0:
        power[:, -1] /= 2.0  # the Nyquist bin has no mirror
    f = np.fft.rfftfreq(n, 1.0 / rate)
    lo, hi = fm * 10 ** (-1 / 20), fm * 10 ** (1 / 20)
    band = np.searchsorted(lo, f, side="right") - 1  # the band whose lower edge is below f
    inside = (band >= 0) & (f < hi[np.clip(band, 0, len(fm) - 1)]) if len(fm) else f < 0
    ms_bands = np.zeros((p.shape[0], len(fm)))
    for_bins = np.flatnonzero(inside)
    np.add.at(ms_bands.T, band[for_bins], power[:, for_bins].T)
    mean_square = power.sum(axis=1)
    weight = 10.0 ** (a_weighting_db(np.maximum(f, 1e-9)) / 10.0)
    weight[0] = 0.0
    from scipy.signal import welch

    nper = int(min(n, 2 ** max(8, int(np.log2(rate / 2.0)))))  # about 2 Hz resolution
    freqs, psd = welch(p, fs=rate, nperseg=nper, axis=1)
    names = list(channels) if channels else [f"ch{i}" for i in range(p.shape[0])]
    if len(names) != p.shape[0]:
        raise ParameterError(f"spectrum: {len(names)} channel names for {p.shape[0]} channels")
    return Spectrum(
        rate=rate,
        duration=n / rate,
        channels=names,
        oaspl=_level(mean_square),
        oaspl_a=_level((power * weight).sum(axis=1)),
        band_centres=fm,
        band_labels=labels,
        band_levels=_level(ms_bands),
        freqs=np.asarray(freqs, dtype=np.float64),
        psd=np.asarray(psd, dtype=np.float64),
        source=source,
    )


def read_pascals(path: str | Path) -> tuple[NDArray[np.float64], int, list[str], str]:
    """An audio file auralize wrote, in pascals: ``(audio, rate, channel names, units)``.

    A WAV or FLAC with its sidecar ``FILE.json``: the sidecar's ``gain``
    (output units per pascal) turns samples back into pascals, its layout
    names the channels.  A file without a sidecar is refused (its samples'
    unit is unknown) unless it is named in pascals some other way.

    Raises
    ------
    MissingFileError, FormatError
    """
    p = Path(path).expanduser()
    if not p.is_file():
        raise MissingFileError(f"{p}: audio file not found")
    side_path = Path(f"{p}.json")
    if not side_path.is_file():
        raise FormatError(
            f"{p}: no sidecar {side_path.name}, so the samples' unit is unknown; "
            f"analyse a file written by auralize (render, play --output, ...)"
        )
    from auralize.runtime.json_check import read_json

    side = read_json(side_path)
    if not isinstance(side, dict) or side.get("auralize_format") != "audio-sidecar":
        raise FormatError(f"{side_path}: not an auralize audio sidecar")
    gain = side.get("gain")
    if not (
        isinstance(gain, int | float)
        and not isinstance(gain, bool)
        and gain > 0
        and math.isfinite(gain)
    ):
        raise FormatError(f"{side_path}: no usable 'gain' (output units per pascal): {gain!r}")
    if p.suffix.lower() == ".wav":
        from auralize.audio.output import read_wav

        audio, rate, _ = read_wav(p)
    elif p.suffix.lower() == ".flac":
        import soundfile as sf

        try:
            data, rate = sf.read(str(p), dtype="float64", always_2d=True)
        except RuntimeError as exc:
            raise FormatError(f"{p}: not a readable FLAC file ({exc})") from None
        audio = np.ascontiguousarray(data.T)
    else:
        raise FormatError(f"{p}: spectrum reads .wav and .flac files, got {p.suffix!r}")
    layout = side.get("layout") if isinstance(side.get("layout"), dict) else {}
    speakers = layout.get("speakers") if isinstance(layout, dict) else None
    names = (
        [str(s.get("name", f"ch{i}")) for i, s in enumerate(speakers)]
        if isinstance(speakers, list) and len(speakers) == audio.shape[0]
        else [f"ch{i}" for i in range(audio.shape[0])]
    )
    return audio / float(gain), int(rate), names, str(side.get("units", ""))


def observer_pressure(
    volume: Any, listener: Any, *, method: str = "volume", surface: Any = None, rate: int = 44100
) -> tuple[NDArray[np.float64], str]:
    """The acoustic pressure (Pa) at ``listener`` from ``volume``, in physical time.

    Parameters
    ----------
    volume : TimeVolume
    listener : (3,) observer position, m.
    method : ``"volume"`` or ``"fwh"``
        ``volume``: the volume sum of the whole field (paper 003 §3.2.4,
        :func:`auralize.pipeline.auralize` at time scale 1, ``physical``
        timbre, no high-pass), as long as the data's sound lasts there;
        ``fwh``: the permeable FW-H integral over ``surface``
        (:func:`auralize.fwh.fwh_pressure`), over the observer times every
        panel's retarded time covers.  Data that hold sound waves
        (compressible fields) need ``fwh``.
    surface : str or Surface
        FW-H surface (``box=...``, ``sphere=...``, ``file=PATH``;
        :func:`auralize.fwh.surface_from_spec`).
    rate : int
        Samples per second of the pressure, Hz.

    Returns
    -------
    (pressure (1, n), what)
        The pressure and a description of the method.
    """
    at = np.asarray(listener, dtype=np.float64).reshape(1, 3)
    if method == "fwh":
        from auralize.fwh import fwh_pressure, fwh_time_window, sample_surface, surface_from_spec

        if surface is None or surface == "":
            raise ParameterError(
                "--method fwh needs --surface box=x0;x1;y0;y1;z0;z1, "
                "sphere=cx;cy;cz;r or file=PATH (a closed surface around the "
                "sources, inside the grid)"
            )
        smp = sample_surface(volume, surface_from_spec(surface))
        t0, t1 = (float(v) for v in fwh_time_window(smp.times, smp.surface, at)[0])
        n = int(np.floor((t1 - t0) * rate))
        if n < 2:
            raise ParameterError(
                f"{volume.source}: the data last too short to hear the FW-H "
                f"surface at {tuple(at[0])}"
            )
        p = fwh_pressure(smp, None, at, t0 + np.arange(n) / rate)
        return np.asarray(p, dtype=np.float64), f"FW-H on {surface}"
    if method != "volume":
        raise ParameterError(f"method must be 'volume' or 'fwh', got {method!r}")
    from auralize.pipeline import auralize

    out, _ = auralize(
        volume,
        listener=at[0],
        rate=int(rate),
        time_scale=1.0,
        method="volume",
        timbre="physical",
        highpass_hz=0.0,
        layout="mono",
    )
    return out.audio, "volume sum (whole field)"
