"""Permeable-surface Ffowcs Williams–Hawkings integral, Farassat's formulation 1A.

Sources on the surface f = 0 (n̂ outward, v the surface velocity; Di
Francescantonio 1997 and Brentner & Farassat 1998 for the permeable form;
Farassat 2007, NASA/TM-2007-214853, for formulation 1A):

    U_i = (1 − ρ/ρ0) v_i + ρ u_i / ρ0                       (mass flux, per ρ0)
    Q   = ρ0 U_n = (ρ0 − ρ) v_n + ρ u_n                      ("thickness" source)
    L_i = P_ij n_j + ρ u_i (u_n − v_n),  P_ij = (p − p0) δ_ij ("loading" source)

The viscous stress is neglected in P_ij (it is small against p − p0 outside
a boundary layer, and the data rarely hold it).  The quadrupole (volume)
term outside the surface is neglected: the surface must enclose every
source, and the flow outside it be acoustic.

For a stationary surface (M = v/c0 = 0; the data's grid does not move)
formulation 1A reduces to

    4π p'(x, t) = ∫ [ Q̇ / r ]_ret dS                                     (thickness)
                + (1/c0) ∫ [ L̇_r / r ]_ret dS + ∫ [ L_r / r² ]_ret dS     (loading)

with r = |x − y| from the panel y to the observer x, r̂ = (x − y)/r,
L_r = L · r̂, the dot a time derivative, and [·]_ret evaluated at the
retarded time τ = t − r/c0.  (The moving-surface 1A terms, with Doppler
factors 1/(1 − M_r)² and 1/(1 − M_r)³, are written in docs/fwh.md; they
vanish for M = 0.)

Time derivative and retarded-time interpolation: each panel's Q(τ) and
L(τ) are interpolated by one cubic spline through the data steps
(not-a-knot ends; any strictly increasing times): Q̇, L̇ and L at the
retarded time are the spline's derivative and value there.  Against a
centred difference followed by a Hermite interpolation this is one
approximation instead of two, with errors O(Δt⁴) for the value and O(Δt³)
for the derivative (centred differences: O(Δt²)), and L̇ is continuous
(C² spline), so an observer's signal has no kinks at the data steps.  The
spline is linear in the data: the panel terms are combined per observer in
the spline's coefficients, then evaluated once at each panel's retarded
time (a gather, no loop over panels).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from auralize.constants import RHO0
from auralize.emitters import C0, Emitters, Sound
from auralize.errors import ParameterError
from auralize.fwh.sampling import SurfaceSamples, sample_surface
from auralize.fwh.surface import Surface
from auralize.volume import TimeVolume

#: gathered entries (times × panels) per chunk of :func:`fwh_pressure_from_sources`
CHUNK = 1 << 20


def fwh_sources(
    rho: NDArray[np.float64],
    velocity: NDArray[np.float64],
    p_prime: NDArray[np.float64],
    normals: NDArray[np.float64],
    *,
    rho0: float = RHO0,
    surface_velocity: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The permeable FW-H sources Q = ρ0 U_n and L_i on panels.

    Parameters
    ----------
    rho : (..., P) float
        Density (kg/m³).
    velocity : (..., P, 3) float
        Fluid velocity u (m/s).
    p_prime : (..., P) float
        p − p0 (Pa).
    normals : (P, 3) float
        Unit outward normals.
    rho0 : float
        Ambient density.
    surface_velocity : (..., P, 3) float, optional
        Surface velocity v (default 0: stationary).

    Returns
    -------
    Q : (..., P) float
        ρ0 U_n = (ρ0 − ρ) v_n + ρ u_n, kg m⁻² s⁻¹.
    L : (..., P, 3) float
        (p − p0) n_i + ρ u_i (u_n − v_n), Pa (viscous stress neglected).

    Examples
    --------
    >>> import numpy as np
    >>> Q, L = fwh_sources(np.array([1.2]), np.array([[2.0, 0, 0]]), np.array([5.0]),
    ...                    np.array([[1.0, 0, 0]]), rho0=1.2)
    >>> Q.tolist(), L.tolist()
    ([2.4], [[9.8, 0.0, 0.0]])
    """
    u_n = np.einsum("...pi,pi->...p", velocity, normals)
    if surface_velocity is None:
        v_n = np.zeros_like(u_n)
        Q = rho * u_n
    else:
        v_n = np.einsum("...pi,pi->...p", surface_velocity, normals)
        Q = (rho0 - rho) * v_n + rho * u_n
    L = p_prime[..., None] * normals + (rho * (u_n - v_n))[..., None] * velocity
    return Q, L


def _splines(
    times: NDArray[np.float64], Q: NDArray[np.float64], L: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Cubic-spline coefficients (4, T−1, P) of Q and (4, T−1, P, 3) of L (PPoly order)."""
    cq = CubicSpline(times, Q, axis=0).c
    cl = CubicSpline(times, L, axis=0).c
    return cq, cl


def _check_observers(observers: Any) -> NDArray[np.float64]:
    x = np.asarray(observers, dtype=np.float64)
    if x.ndim == 1:
        x = x[None]
    if x.ndim != 2 or x.shape[1] != 3 or not np.isfinite(x).all():
        raise ParameterError(
            f"observers must be finite (n_obs, 3) positions, got shape {np.shape(observers)}"
        )
    return x


def _geometry(
    surface: Surface, x: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Distances r (P,) and unit vectors r̂ (P, 3) from the panels to observer x."""
    rv = x - surface.centres
    r = np.linalg.norm(rv, axis=1)
    if np.any(r <= 0):
        raise ParameterError(f"observer {x.tolist()} lies on a panel centre of the FW-H surface")
    return r, rv / r[:, None]


def fwh_time_window(
    times: NDArray[np.float64], surface: Surface, observers: Any, *, c0: float = C0
) -> NDArray[np.float64]:
    """Observer times ``(n_obs, 2)`` whose retarded times all lie inside the data.

    For observer x, every panel's τ = t − r/c0 is in ``[times[0], times[-1]]``
    iff ``times[0] + max r / c0 <= t <= times[-1] + min r / c0`` (an empty
    window when the surface is larger than the data's duration × c0).
    """
    x = _check_observers(observers)
    out = np.empty((x.shape[0], 2))
    for o in range(x.shape[0]):
        r = np.linalg.norm(x[o] - surface.centres, axis=1)
        out[o] = (times[0] + r.max() / c0, times[-1] + r.min() / c0)
    return out


def fwh_pressure_from_sources(
    times: NDArray[np.float64],
    Q: NDArray[np.float64],
    L: NDArray[np.float64],
    surface: Surface,
    *,
    observers: Any,
    t: Any,
    c0: float = C0,
) -> NDArray[np.float64]:
    """Formulation 1A (stationary surface) from sampled sources.

    Parameters
    ----------
    times : (T,) float
        Data times (s), strictly increasing, T >= 4.
    Q : (T, P) float
        ρ0 U_n on each panel.
    L : (T, P, 3) float
        Loading vector on each panel.
    surface : Surface
        Stationary (its panel centres, areas).
    observers : (n_obs, 3) float
        Fixed observer positions (m), outside the surface.
    t : (n_t,) float
        Observer times (s).
    c0 : float

    Returns
    -------
    (n_obs, n_t) float
        p'(x, t) in Pa; NaN where a panel's retarded time falls outside the
        data (see :func:`fwh_time_window`).
    """
    if not surface.stationary:
        raise ParameterError(
            "fwh_pressure handles a stationary surface only (surface velocity "
            "is not zero); the moving-surface terms are not implemented yet"
        )
    times = np.asarray(times, dtype=np.float64)
    x = _check_observers(observers)
    tt = np.asarray(t, dtype=np.float64).reshape(-1)
    if not np.isfinite(tt).all():
        raise ParameterError("observer times contain NaN or Inf")
    cq, cl = _splines(times, Q, L)
    P = surface.n_panels
    T = times.size
    dt = np.diff(times)
    uniform = bool(np.all(np.abs(dt - dt.mean()) <= 1e-9 * dt.mean()))
    out = np.full((x.shape[0], tt.size), np.nan)
    slack = 1e-9 * (times[-1] - times[0])  # round-off of t − r/c0 at the window's ends
    cols = np.arange(P)
    step = max(1, CHUNK // P)
    for o in range(x.shape[0]):
        r, rhat = _geometry(surface, x[o])
        lr = np.einsum("ckpi,pi->ckp", cl, rhat)  # L_r coefficients (4, T-1, P)
        # A = (Q + L_r/c0) dS / r is differentiated, B = L_r dS / r² taken as is:
        # A'(s) + B(s) = B0 s³ + (3 A0 + B1) s² + (2 A1 + B2) s + (A2 + B3)
        cA = (cq + lr / c0) * (surface.areas / r)
        cB = lr * (surface.areas / r**2)
        coef = np.stack([cB[0], 3.0 * cA[0] + cB[1], 2.0 * cA[1] + cB[2], cA[2] + cB[3]])
        planes = coef.reshape(4, -1)  # (4, (T-1)·P), interval-major
        delay = r / c0
        for a in range(0, tt.size, step):
            tau = tt[a : a + step, None] - delay[None, :]
            inside = np.all((tau >= times[0] - slack) & (tau <= times[-1] + slack), axis=1)
            if uniform:
                k = np.clip(((tau - times[0]) / dt.mean()).astype(np.int64), 0, T - 2)
            else:
                k = np.clip(np.searchsorted(times, tau, side="right") - 1, 0, T - 2)
            s = tau - times[k]
            flat = k * P + cols
            p = ((planes[0][flat] * s + planes[1][flat]) * s + planes[2][flat]) * s
            p += planes[3][flat]
            out[o, a : a + step] = np.where(inside, p.sum(axis=1) / (4.0 * np.pi), np.nan)
    return out


def fwh_pressure(
    volume: TimeVolume | SurfaceSamples,
    surface: Surface | None,
    observers: Any,
    times: Any,
    *,
    rho0: float = RHO0,
    c0: float = C0,
    p0: float | None = None,
    solid: bool = False,
    **fields: str,
) -> NDArray[np.float64]:
    """Acoustic pressure at fixed observers by the permeable FW-H integral (formulation 1A).

    Parameters
    ----------
    volume : TimeVolume or SurfaceSamples
        Density and/or pressure, and velocity (or momentum), at >= 4 steps;
        or samples from :func:`auralize.fwh.sampling.sample_surface` (then
        ``surface``, ``rho0``, ``c0``, ``p0`` and ``fields`` are theirs).
    surface : Surface
        Closed, stationary, inside the grid, enclosing every source
        (:func:`auralize.fwh.surface.box_surface`, ``sphere_surface``,
        ``mesh_surface``).
    observers : (n_obs, 3) float
        Observer positions in metres, outside the surface.
    times : (n_t,) float
        Observer times in data seconds.
    rho0, c0 : float
        Ambient density (kg/m³, default 1.2) and speed of sound (m/s, 343).
    p0 : float, optional
        Ambient pressure (Pa); default the mean of the first step's pressure.
    solid : bool
        The surface is an impermeable, no-slip body (the flow velocity on it
        zero): the thickness source Q vanishes and the loading is L_i = p' n_i,
        Curle's loading noise of the body (Curle 1955; Farassat 2007 §3).
        Default False: a permeable surface in the flow.
    **fields : str
        ``density=``, ``velocity=``, ``momentum=``, ``pressure=`` field names
        (default: found by role, :func:`auralize.sources.mapping.match_field`).

    Returns
    -------
    ndarray, shape (n_obs, n_t)
        p'(x, t) in Pa; NaN where some panel's retarded time t − r/c0 lies
        outside the data's times (:func:`fwh_time_window`).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.fwh import box_surface, fwh_pressure
    >>> from auralize.volume import TimeVolume
    >>> T, n = 6, 5
    >>> still = {"density": np.full((T, n, n, n), 1.2), "velocity": np.zeros((T, n, n, n, 3))}
    >>> vol = TimeVolume.from_arrays(still, spacing=0.1, times=np.arange(T) * 1e-3)
    >>> s = box_surface((0.1, 0.3, 0.1, 0.3, 0.1, 0.3), n=2)
    >>> p = fwh_pressure(vol, s, [[10.0, 0, 0]], [0.031, 0.032])
    >>> p.shape, bool(np.abs(p).max() < 1e-12)
    ((1, 2), True)
    """
    smp = _samples(
        volume, surface, "fwh_pressure", solid=solid, rho0=rho0, c0=c0, p0=p0, fields=fields
    )
    Q, L = fwh_sources(
        smp.rho,
        smp.velocity,
        smp.p_prime,
        smp.surface.normals,
        rho0=smp.rho0,
        surface_velocity=None if smp.surface.stationary else smp.surface.velocity,
    )
    return fwh_pressure_from_sources(
        smp.times, Q, L, smp.surface, observers=observers, t=times, c0=smp.c0
    )


def _samples(
    volume: TimeVolume | SurfaceSamples,
    surface: Surface | None,
    what: str,
    *,
    solid: bool,
    rho0: float,
    c0: float,
    p0: float | None,
    fields: dict[str, str],
) -> SurfaceSamples:
    """The surface samples of ``volume`` (sampled on ``surface`` unless given as samples);
    ``solid``: the surface is an impermeable, no-slip wall, the flow velocity on it zero."""
    if isinstance(volume, SurfaceSamples):
        smp = volume
    else:
        if surface is None:
            raise ParameterError(f"{what} needs a surface")
        smp = sample_surface(volume, surface, rho0=rho0, c0=c0, p0=p0, **fields)
    if solid:
        if not smp.surface.stationary:
            raise ParameterError("a solid (impermeable) FW-H surface must be stationary here")
        smp = replace(smp, velocity=np.zeros_like(smp.velocity))
    return smp


def fwh_emitters(
    volume: TimeVolume | SurfaceSamples,
    surface: Surface | None = None,
    *,
    rho0: float = RHO0,
    c0: float = C0,
    p0: float | None = None,
    oversample: int = 4,
    time_origin: float | None = None,
    solid: bool = False,
    **fields: str,
) -> Sound:
    """The FW-H surface as engine emitters: a monopole and two dipoles per panel.

    Formulation 1A for a stationary surface is, panel by panel, what the
    engine (:mod:`auralize.emitters`) evaluates for point emitters at the
    panel centre: a monopole ``q = Q̇ dS / 4π`` (1/D law), a dipole
    ``G = L̇ dS / (4π c0)`` (1/D) and a dipole ``G = L dS / 4π`` (1/D²),
    each heard as ``û · G / D^e`` with û from the panel to the listener.  So
    the engine does the retarded time, a moving listener's Doppler shift
    and any speaker layout.  Hear it from outside the surface only: inside,
    the integral is not the field (it is zero plus what the data's sources
    inside do), and the clamp radius (half a panel) bounds it.

    Parameters
    ----------
    volume, surface, rho0, c0, p0, solid, **fields
        As :func:`fwh_pressure`.
    oversample : int
        Emission samples per data step (the splines are evaluated at this
        rate, so the engine's own interpolation adds little error).
    time_origin : float, optional
        Data second at playback time 0 (the listener path's first capture);
        default the data's first time.

    Returns
    -------
    Sound
        Three :class:`~auralize.emitters.Emitters` parts (``fwh-thickness``,
        ``fwh-loading-far``, ``fwh-loading-near``), signals over the data's
        times (zero outside them); ``meta`` holds the surface and fields.
    """
    smp = _samples(
        volume, surface, "fwh_emitters", solid=solid, rho0=rho0, c0=c0, p0=p0, fields=fields
    )
    if not smp.surface.stationary:
        raise ParameterError("fwh_emitters handles a stationary surface only")
    if isinstance(oversample, bool) or not (
        isinstance(oversample, int | np.integer) and 1 <= oversample <= 64
    ):
        raise ParameterError(f"oversample must be an integer in 1..64, got {oversample!r}")
    times = smp.times
    Q, L = fwh_sources(smp.rho, smp.velocity, smp.p_prime, smp.surface.normals, rho0=smp.rho0)
    sq = CubicSpline(times, Q, axis=0)
    sl = CubicSpline(times, L, axis=0)
    span = float(times[-1] - times[0])
    rate = oversample * (times.size - 1) / span
    n = int(np.floor(span * rate + 1e-9)) + 1
    te = times[0] + np.arange(n) / rate
    dS = smp.surface.areas
    k = 1.0 / (4.0 * np.pi)
    mono = np.ascontiguousarray((sq(te, 1) * (k * dS)).T)  # (P, n)
    far = np.ascontiguousarray((sl(te, 1) * (k * dS / smp.c0)[:, None]).transpose(1, 2, 0))
    near = np.ascontiguousarray((sl(te) * (k * dS)[:, None]).transpose(1, 2, 0))
    origin = float(times[0]) if time_origin is None else float(time_origin)
    radius = 0.5 * np.sqrt(dS)
    pos = smp.surface.centres
    common: dict[str, Any] = dict(
        rate=rate, positions=pos, t0=float(times[0]) - origin, radius=radius
    )
    parts = [
        Emitters(mono, law="physical", name="fwh-thickness", **common),
        Emitters(far, law="physical", name="fwh-loading-far", **common),
        Emitters(near, law=2.0, name="fwh-loading-near", **common),
    ]
    meta = {
        "model": "fwh",
        "surface": smp.surface.description,
        "panels": smp.surface.n_panels,
        "fields": smp.fields,
        "rho0": smp.rho0,
        "c0": smp.c0,
        "p0": smp.p0,
        "time_origin": origin,
    }
    return Sound(parts=list(parts), meta=meta, name="fwh")
