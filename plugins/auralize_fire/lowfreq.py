"""Low-frequency fire sound (paper 001 §3.1, §3.3, §6).

p(t) = dI/dt with I(t) = ∫_S(t) u·n dS (Eq. 6).  I is known at the
simulation steps t_i; Eqs. 10–11 interpolate it with the Mitchell–Netravali
cubic filter ψ and evaluate the derivative at audio rate,
p(t) = Σ_i ψ_i'(t) I(t_i).  Constants and the 1/r of Eq. 3 are omitted as in
the paper, so p is in m³/s² (proportional to pressure).  §6 then high-passes
p at 30 Hz before bandwidth extension or texture synthesis.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import signal as sps

from auralize.errors import DataError, ParameterError
from auralize.volume import TimeVolume
from auralize_fire.flamefront import FlameFront, extract_front

#: Mitchell & Netravali's recommended filter (B = C = 1/3)
MN_B = 1.0 / 3.0
MN_C = 1.0 / 3.0


def mitchell_netravali(
    x: NDArray[np.floating] | float, *, B: float = MN_B, C: float = MN_C, derivative: bool = False
) -> NDArray[np.float64]:
    """Mitchell–Netravali cubic ψ(x) (or dψ/dx) in sample units (paper 001 Eq. 10).

    Parameters
    ----------
    x : array_like
        Offsets in units of the simulation step.
    B, C : float
        Filter family parameters (default 1/3, 1/3).
    derivative : return dψ/dx.

    Examples
    --------
    ψ(0) = 8/9, ψ(±1) = 1/18, zero from |x| = 2 on; the shifted copies sum to one:

    >>> np.allclose(mitchell_netravali([0.0, 1.0, -1.0, 2.0]), [8 / 9, 1 / 18, 1 / 18, 0.0])
    True
    >>> round(float(mitchell_netravali(np.arange(-2, 3) + 0.3).sum()), 12)
    1.0
    """
    t = np.asarray(x, dtype=np.float64)
    a = np.abs(t)
    c3i, c2i, c0i = 12 - 9 * B - 6 * C, -18 + 12 * B + 6 * C, 6 - 2 * B
    c3o, c2o, c1o, c0o = -B - 6 * C, 6 * B + 30 * C, -12 * B - 48 * C, 8 * B + 24 * C
    if not derivative:
        inner = (c3i * a**3 + c2i * a**2 + c0i) / 6
        outer = (c3o * a**3 + c2o * a**2 + c1o * a + c0o) / 6
        return np.where(a < 1, inner, np.where(a < 2, outer, 0.0))
    inner = (3 * c3i * a**2 + 2 * c2i * a) / 6
    outer = (3 * c3o * a**2 + 2 * c2o * a + c1o) / 6
    return np.sign(t) * np.where(a < 1, inner, np.where(a < 2, outer, 0.0))


def interpolate_series(
    values: NDArray[np.floating],
    dt: float,
    t: NDArray[np.floating],
    *,
    derivative: bool = False,
    B: float = MN_B,
    C: float = MN_C,
) -> NDArray[np.float64]:
    """Ĩ(t) = Σ ψ_i(t) I_i or p(t) = Σ ψ_i'(t) I_i for uniformly sampled I (Eqs. 10–11).

    Parameters
    ----------
    values : (N,) samples I(t_i) at t_i = i dt.
    dt : float
        Simulation step in seconds.
    t : (M,) evaluation times in seconds (relative to t_0).
    derivative : evaluate dĨ/dt (units of I per second).

    Returns
    -------
    (M,) array.  The series is extended by linear extrapolation past its ends,
    so a linear I(t) has the exact slope everywhere.
    """
    v = np.asarray(values, dtype=np.float64)
    if v.ndim != 1 or v.size < 2:
        raise DataError(f"need at least 2 simulation steps to interpolate, got {v.size}")
    pad = np.concatenate(
        [v[0] - (v[1] - v[0]) * np.arange(2, 0, -1), v, v[-1] + (v[-1] - v[-2]) * np.arange(1, 3)]
    )
    u = np.asarray(t, dtype=np.float64) / dt
    i0 = np.clip(np.floor(u).astype(np.int64), 0, v.size - 2)
    out = np.zeros(u.shape)
    for k in (-1, 0, 1, 2):
        w = mitchell_netravali(u - (i0 + k), B=B, C=C, derivative=derivative)
        out += w * pad[i0 + k + 2]
    return out / dt if derivative else out


def highpass(
    p: NDArray[np.floating], rate: float, cutoff_hz: float = 30.0, *, order: int = 2
) -> NDArray[np.float64]:
    """The 30 Hz high-pass of paper 001 §6 (Butterworth, run forwards and backwards).

    Zero phase, so the filtered sound stays synchronised with the flames;
    the forward–backward pass doubles the order (default: 4th-order slope).
    ``cutoff_hz = 0`` returns the signal unchanged.
    """
    x = np.asarray(p, dtype=np.float64)
    if cutoff_hz == 0:
        return x.copy()
    if not 0 < cutoff_hz < rate / 2:
        raise ParameterError(f"high-pass cutoff must be in (0, {rate / 2:g}) Hz, got {cutoff_hz!r}")
    sos = sps.butter(order, cutoff_hz, btype="highpass", fs=rate, output="sos")
    padlen = min(x.size - 1, 3 * int(rate / cutoff_hz))
    return sps.sosfiltfilt(sos, x, padlen=max(padlen, 0))


@dataclass
class FluxSeries:
    """I(t_i) of a flame simulation (paper 001 Eq. 5) and per-step front statistics."""

    times: NDArray[np.float64]
    flux: NDArray[np.float64]  # m³/s
    area: NDArray[np.float64]  # m²
    centroid: NDArray[np.float64]  # (T, 3) area-weighted front centre, metres
    iso: float
    meta: dict[str, object] = field(default_factory=dict)

    @property
    def dt(self) -> float:
        return float(np.median(np.diff(self.times))) if self.times.size > 1 else 0.0


def default_iso(volume: TimeVolume, burn_field: str, fraction: float = 0.1) -> float:
    """``fraction`` of the largest |B| over all steps (the front encloses the burning region)."""
    peak = max(float(np.max(np.abs(volume.frame(burn_field, n)))) for n in range(volume.n_steps))
    if peak == 0:
        raise DataError(
            f"{volume.source}: field {burn_field!r} is zero at every step; "
            "nothing burns, so there is no flame front"
        )
    return fraction * peak


def check_fields(volume: TimeVolume, burn_field: str, velocity_field: str) -> None:
    """Clear errors for missing or mis-shaped fields (FieldError / DataError)."""
    volume._get(burn_field)
    volume._get(velocity_field)
    if volume.is_vector(burn_field):
        raise DataError(
            f"{volume.source}: flame-front field {burn_field!r} must be a scalar "
            "field (burn rate, fuel, temperature or level set)"
        )
    if not volume.is_vector(velocity_field):
        raise DataError(
            f"{volume.source}: velocity field {velocity_field!r} must be a vector field"
        )
    if volume.n_steps < 2:
        raise DataError(
            f"{volume.source}: need at least 2 time steps for dI/dt, got {volume.n_steps}"
        )


def front_at(
    volume: TimeVolume,
    step: int,
    *,
    burn_field: str = "burn",
    iso: float,
    refine: int = 2,
    inside: str = "high",
) -> FlameFront:
    """The flame front of one step of a volume (paper 001 §3.2)."""
    return extract_front(
        volume.frame(burn_field, step),
        iso,
        origin=volume.origin,
        spacing=volume.spacing,
        refine=refine,
        inside=inside,
    )


def flux_series(
    volume: TimeVolume,
    *,
    burn_field: str = "burn",
    velocity_field: str = "velocity",
    iso: float | None = None,
    refine: int = 2,
    inside: str = "high",
) -> FluxSeries:
    """I(t) = ∫ u·n dS over the flame front at each simulation step (Eq. 5).

    Parameters
    ----------
    volume : TimeVolume with a scalar ``burn_field`` and a vector ``velocity_field`` (m/s).
    iso : iso-value of the front; None = 10 % of the peak |B| over all steps.
    refine, inside : see :func:`~auralize_fire.flamefront.extract_front`.

    Returns
    -------
    FluxSeries with ``flux`` (T,) in m³/s.
    """
    check_fields(volume, burn_field, velocity_field)
    level = default_iso(volume, burn_field) if iso is None else float(iso)
    T = volume.n_steps
    flux, area, cen = np.zeros(T), np.zeros(T), np.zeros((T, 3))
    for n in range(T):
        front = front_at(volume, n, burn_field=burn_field, iso=level, refine=refine, inside=inside)
        if front.areas.size:
            flux[n] = front.flux(volume.frame(velocity_field, n), volume.origin, volume.spacing)
            area[n] = front.area
            cen[n] = np.average(front.centroids, axis=0, weights=front.areas)
        else:
            cen[n] = volume.center
    if not np.any(area > 0):
        raise DataError(
            f"{volume.source}: field {burn_field!r} never crosses iso = {level:g}; "
            "choose an iso-value between its minimum and maximum"
        )
    return FluxSeries(
        volume.times.copy(),
        flux,
        area,
        cen,
        level,
        meta={
            "burn_field": burn_field,
            "velocity_field": velocity_field,
            "refine": refine,
            "inside": inside,
        },
    )


def lowfreq_pressure(
    series: FluxSeries,
    *,
    rate: int = 44100,
    highpass_hz: float = 30.0,
    B: float = MN_B,
    C: float = MN_C,
) -> NDArray[np.float64]:
    """p(t) = dĨ/dt at audio rate (Eqs. 9–11), then the 30 Hz high-pass of §6.

    Parameters
    ----------
    series : FluxSeries (times need not be exactly uniform: I is first
        resampled linearly onto a uniform grid at the median step).
    rate : audio sample rate in Hz.
    highpass_hz : cutoff of the §6 high-pass (0 = off).

    Returns
    -------
    (n,) p at t_0 + k / rate for k = 0 … ⌊(t_N - t_0) rate⌋, in m³/s².
    """
    if rate <= 0:
        raise ParameterError(f"rate must be positive, got {rate!r}")
    t, flux = series.times - series.times[0], series.flux
    if not np.all(np.isfinite(flux)):
        raise DataError("flux series contains NaN or Inf")
    dt = series.dt
    if not np.allclose(np.diff(t), dt, rtol=1e-3, atol=0):
        n_u = round(t[-1] / dt) + 1
        tu = np.arange(n_u) * dt
        flux = np.interp(tu, t, flux)
        t = tu
    n = int(np.floor(t[-1] * rate + 1e-9)) + 1
    p = interpolate_series(flux, dt, np.arange(n) / rate, derivative=True, B=B, C=C)
    return highpass(p, rate, highpass_hz) if highpass_hz else p
