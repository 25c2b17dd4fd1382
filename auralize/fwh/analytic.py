"""Exact linear sound fields stored as volume data: the FW-H verification cases.

A point source of volume flow ``q(t) = A exp(−(t − tc)²/2σ²)`` at ``xs``
(off the grid nodes), from its velocity potential (linear acoustics, a medium
at rest):

    monopole   φ = −q(τ)/(4π r),   τ = t − r/c0
               p' = −ρ0 ∂φ/∂t = ρ0 q'(τ)/(4π r)
               u = ∇φ = r̂ [q(τ)/(4π r²) + q'(τ)/(4π r c0)]
    dipole     φ_d = ∂φ/∂z = z h,  h = q/(4π r³) + q'/(4π r² c0)
               p' = −ρ0 (z/r) [q'/(4π r²) + q''/(4π r c0)]
               u = h ẑ + z ∂h/∂r r̂,  ∂h/∂r = −[3q/r⁴ + 3q'/(r³ c0) + q''/(r² c0²)]/4π

stored as density ρ0 + p'/c0², velocity u and pressure p0 + p' on a uniform
grid (:func:`pulse_volume`), which is what a compressible simulation that
resolves its acoustics stores.  The defaults (σ = 0.5 ms: the spectrum peaks
at λ = 2π c0 σ ≈ 1.08 m, 21 grid spacings and 21 steps per peak period) are
those of ``tests/test_fwh.py`` and ``auralize bench``'s FW-H rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auralize.errors import ParameterError
from auralize.volume import CallableFrames, TimeVolume

__all__ = ["Pulse", "pulse_field", "pulse_volume"]

KINDS = ("monopole", "dipole")


@dataclass(frozen=True)
class Pulse:
    """A Gaussian pulse of volume flow (module docstring).

    Attributes
    ----------
    amplitude : float
        A, m³/s.
    sigma : float
        σ, s.
    centre : float
        tc, s.
    c0, rho0, p0 : float
        Speed of sound (m/s), density (kg/m³) and pressure (Pa) at rest.
    """

    amplitude: float = 5e-3
    sigma: float = 5e-4
    centre: float = 6e-3
    c0: float = 343.0
    rho0: float = 1.2
    p0: float = 101325.0

    def q(self, tau: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """``q`` and its first two derivatives at the emission times ``tau``."""
        s = tau - self.centre
        g = self.amplitude * np.exp(-(s**2) / (2 * self.sigma**2))
        return g, -s / self.sigma**2 * g, (s**2 / self.sigma**4 - 1 / self.sigma**2) * g


def pulse_field(kind: str, xs: ArrayLike, t: ArrayLike, points: ArrayLike,
                pulse: Pulse | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:  # fmt: skip
    """The exact ``(p', u)`` of a monopole or z-dipole pulse at ``xs`` (module docstring).

    Parameters
    ----------
    kind : {"monopole", "dipole"}
    xs : (3,) float
        The source's position, m.
    t : float or array
        Times, s (broadcast against the points' leading axes).
    points : (..., 3) float
        Where, m (not at ``xs``).
    pulse : Pulse, optional
        The pulse (default :class:`Pulse`).

    Returns
    -------
    p : (...) float
        Acoustic pressure, Pa.
    u : (..., 3) float
        Particle velocity, m/s.

    Examples
    --------
    >>> import numpy as np
    >>> p, u = pulse_field("monopole", (0, 0, 0), 6e-3 + 10 / 343, np.array([10.0, 0, 0]))
    >>> round(float(p), 12), u.shape  # q' = 0 at the pulse's centre
    (0.0, (3,))
    """
    if kind not in KINDS:
        raise ParameterError(f"kind must be one of {KINDS}, got {kind!r}")
    pu = pulse or Pulse()
    c0, rho0 = pu.c0, pu.rho0
    d = np.asarray(points, dtype=np.float64) - np.asarray(xs, dtype=np.float64)
    r = np.linalg.norm(d, axis=-1)
    rh = d / r[..., None]
    q, q1, q2 = pu.q(np.asarray(t, dtype=np.float64) - r / c0)
    if kind == "monopole":
        p = rho0 * q1 / (4 * np.pi * r)
        u = rh * (q / (4 * np.pi * r**2) + q1 / (4 * np.pi * r * c0))[..., None]
        return p, u
    z = d[..., 2]
    p = -rho0 * (z / r) * (q1 / (4 * np.pi * r**2) + q2 / (4 * np.pi * r * c0))
    h = q / (4 * np.pi * r**3) + q1 / (4 * np.pi * r**2 * c0)
    hr = -(3 * q / r**4 + 3 * q1 / (r**3 * c0) + q2 / (r**2 * c0**2)) / (4 * np.pi)
    u = h[..., None] * np.array([0.0, 0.0, 1.0]) + (z * hr)[..., None] * rh
    return p, u


def pulse_volume(kind: str = "monopole", xs: ArrayLike = (0.013, -0.007, 0.011), *,
                 n: int = 41, spacing: float = 0.05, origin: float = -1.0, steps: int = 85,
                 dt: float = 1.5e-4, names: tuple[str, ...] = ("density", "velocity", "pressure"),
                 pulse: Pulse | None = None) -> TimeVolume:  # fmt: skip
    """The exact field of :func:`pulse_field` stored on an ``n³`` grid at ``steps`` steps,
    computed step by step when read.

    Parameters
    ----------
    kind : {"monopole", "dipole"}
    xs : (3,) float
        The source, m (keep it off the grid nodes).
    n, spacing, origin : int, float, float
        Points per axis, their spacing (m) and the first one's coordinate (m) on
        every axis.
    steps, dt : int, float
        Time steps and their spacing, s (from 0).
    names : tuple of str
        The fields stored, of ``density``, ``velocity``, ``pressure`` and ``momentum``.
    pulse : Pulse, optional

    Returns
    -------
    TimeVolume

    Examples
    --------
    >>> vol = pulse_volume(n=9, spacing=0.25, steps=6)
    >>> vol.dims, vol.n_steps, vol.field_names
    ((9, 9, 9), 6, ['density', 'velocity', 'pressure'])
    """
    pu = pulse or Pulse()
    unknown = sorted(set(names) - {"density", "velocity", "pressure", "momentum"})
    if unknown:
        raise ParameterError(f"unknown field(s) {unknown}: choose density, velocity, pressure, "
                             f"momentum")  # fmt: skip
    ax = origin + spacing * np.arange(n)
    z, y, x = np.meshgrid(ax, ax, ax, indexing="ij")
    pts = np.stack([x, y, z], axis=-1)
    times = dt * np.arange(steps)
    cache: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

    def get(k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if k not in cache:
            cache.clear()
            cache[k] = pulse_field(kind, xs, times[k], pts, pu)
        return cache[k]

    shape = (n, n, n)
    makers = {
        "density": (lambda k: pu.rho0 + get(k)[0] / pu.c0**2, shape),
        "velocity": (lambda k: get(k)[1], (*shape, 3)),
        "pressure": (lambda k: pu.p0 + get(k)[0], shape),
        "momentum": (lambda k: (pu.rho0 + get(k)[0] / pu.c0**2)[..., None] * get(k)[1],
                     (*shape, 3)),
    }  # fmt: skip
    fields = {k: CallableFrames(makers[k][0], steps, makers[k][1]) for k in names}
    return TimeVolume(origin=np.full(3, origin), spacing=np.full(3, spacing), dims=shape,
                      times=times, fields=dict(fields), source=f"<analytic {kind} pulse>")  # fmt: skip
