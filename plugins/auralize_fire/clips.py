"""Audio in and out for the fire plugin, and a procedural crackle/roar clip.

The paper trains §5 on commercial recordings we do not ship;
:func:`fire_training_clip` synthesises a stand-in with the two ingredients of
fire sound: a broadband *roar* (noise with a flame-like f^-α fall-off above
a few hundred Hz, slowly flickering) and *crackle* (a Poisson train of short
decaying resonant clicks of heavy-tailed amplitudes, 1.5–6 kHz).

Audio files: WAV/FLAC (any channel count, averaged to mono) through
soundfile, and raw float32 little-endian mono (``.f32``/``.bin``, as in the
shared ``fire-lowfreq`` folder) with an explicit rate.
"""

from __future__ import annotations

import json
from fractions import Fraction
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy import signal as sps

from auralize.errors import DataError, FormatError, ParameterError

RAW_SUFFIXES = (".f32", ".bin", ".raw")


def fire_training_clip(
    duration: float,
    rate: int = 44100,
    *,
    seed: int = 0,
    crackle_rate: float = 25.0,
    roar_alpha: float = 2.0,
    crackle_gain: float = 1.0,
) -> NDArray[np.float64]:
    """A procedurally synthesised fire clip (roar + crackle), peak 0.5.

    Parameters
    ----------
    duration : seconds.
    rate : sample rate in Hz.
    seed : random seed (same seed, same clip).
    crackle_rate : mean crackles per second (Poisson).
    roar_alpha : power-law exponent of the roar above its 300 Hz corner.
    crackle_gain : crackle level relative to the roar.

    Returns
    -------
    (round(duration · rate),) clip.

    Examples
    --------
    >>> clip = fire_training_clip(1.0, 8000, seed=3)
    >>> clip.shape, float(np.max(np.abs(clip)))
    ((8000,), 0.5)
    """
    if not duration > 0:
        raise ParameterError(f"clip duration must be positive, got {duration!r} s")
    if rate < 8000:
        raise ParameterError(f"clip rate must be >= 8000 Hz, got {rate!r}")
    rng = np.random.default_rng(seed)
    n = round(duration * rate)
    f = np.fft.rfftfreq(n, 1.0 / rate)
    # roar: |X(f)| ∝ (1 + (f/300)²)^(-α/4), high-passed at 40 Hz, random phases
    shape = (1 + (f / 300.0) ** 2) ** (-roar_alpha / 4) * (f > 40)
    roar = np.fft.irfft(shape * np.exp(2j * np.pi * rng.random(f.size)), n=n)
    roar /= np.std(roar)
    # flicker: slowly varying positive envelope (0.5–6 Hz)
    flick = np.fft.irfft(np.exp(2j * np.pi * rng.random(f.size)) * ((f > 0.5) & (f < 6)), n=n)
    roar *= 1.0 + 0.6 * flick / max(np.max(np.abs(flick)), 1e-12)
    # crackle: Poisson clicks, decaying resonances 1.5–6 kHz, Pareto amplitudes
    out = roar * 0.3
    n_ev = rng.poisson(crackle_rate * duration)
    t0 = rng.integers(0, n, n_ev)
    amp = (rng.pareto(2.5, n_ev) + 1.0) * 0.6 * crackle_gain
    fc = rng.uniform(1500, min(6000, 0.4 * rate), n_ev)
    tau = rng.uniform(0.0005, 0.002, n_ev)
    m = int(0.012 * rate)
    tt = np.arange(m) / rate
    for k in range(n_ev):
        click = np.exp(-tt / tau[k]) * np.sin(2 * np.pi * fc[k] * tt + rng.uniform(0, 2 * np.pi))
        e = min(n, t0[k] + m)
        out[t0[k] : e] += amp[k] * click[: e - t0[k]]
    return 0.5 * out / np.max(np.abs(out))


def read_audio(
    path: str | Path, *, rate: int | None = None, option: str = "--input-rate"
) -> tuple[NDArray[np.float64], int]:
    """Read a mono signal from WAV/FLAC or raw float32 (``.f32``/``.bin``).

    Parameters
    ----------
    path : file name.
    rate : for raw files, the sample rate (default: ``sample_rate`` of a
        ``manifest.json`` beside the file); for WAV/FLAC, the rate the caller
        expects — a different rate in the file is an error.
    option : the command-line option that gives ``rate`` (named in errors).

    Returns
    -------
    (signal (n,), rate in Hz)
    """
    p = Path(path)
    if not p.is_file():
        raise FormatError(f"{p}: no such audio file")
    if p.suffix.lower() in RAW_SUFFIXES:
        if rate is None:
            man = p.parent / "manifest.json"
            try:
                rate = int(json.loads(man.read_text())["sample_rate"])
            except (OSError, KeyError, ValueError, TypeError):
                raise ParameterError(
                    f"{p}: raw float32 audio needs its sample rate: pass {option} HZ "
                    "(or put a manifest.json with sample_rate beside it)"
                ) from None
        raw = p.read_bytes()
        if len(raw) % 4:
            raise FormatError(f"{p}: {len(raw)} bytes is not a whole number of float32 samples")
        x = np.frombuffer(raw, dtype="<f4").astype(np.float64)
        return x, int(rate)
    import soundfile as sf

    try:
        data, file_rate = sf.read(str(p), dtype="float64", always_2d=True)
    except Exception as exc:  # soundfile raises its own error types
        raise FormatError(f"{p}: cannot read audio ({exc}); use WAV, FLAC or raw .f32") from None
    if rate is not None and int(rate) != int(file_rate):
        raise ParameterError(
            f"{p}: file is at {file_rate} Hz but {option} {rate} Hz was given; "
            f"rates must match (omit {option} for WAV/FLAC)"
        )
    return data.mean(axis=1), int(file_rate)


def resample(x: NDArray[np.floating], rate_in: int, rate_out: int) -> NDArray[np.float64]:
    """Polyphase resampling ``rate_in`` -> ``rate_out`` (used for training clips)."""
    if rate_in <= 0 or rate_out <= 0:
        raise ParameterError(f"sample rates must be positive, got {rate_in} -> {rate_out}")
    if rate_in == rate_out:
        return np.asarray(x, dtype=np.float64)
    fr = Fraction(int(rate_out), int(rate_in)).limit_denominator(1000)
    return sps.resample_poly(np.asarray(x, dtype=np.float64), fr.numerator, fr.denominator)


def check_rate(rate: float, *, what: str = "signal", minimum: float = 8000.0) -> int:
    """A sensible audio rate (DataError names the signal and the rate)."""
    if not (np.isfinite(rate) and rate >= minimum):
        raise DataError(f"{what} sample rate {rate!r} Hz is too low; need >= {minimum:g} Hz")
    return int(rate)
