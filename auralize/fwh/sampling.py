"""The flow on an FW-H surface: density, velocity and pressure at the panel centres.

Fields are found by role (:func:`auralize.sources.mapping.match_field`) and made
into ``(ρ, u)`` by the core's acoustic mappings, so the FW-H integral sees
the flow every other part of auralize sees:

* density with velocity or momentum: the ``cfd`` mapping
  (:class:`auralize.sources.mapping.CFDMapping`, v = m/ρ for momentum);
* pressure without density: the ``incompressible`` mapping
  (:class:`auralize.sources.mapping.IncompressibleMapping`, ρ = ρ0 + p'/c0², its
  kinematic-pressure scaling and its reference, the first step's mean);
* the pressure fluctuation p' = p − p0 from a pressure field (p0 the mean of
  the first step over its finite points, or given); without one, the linear
  acoustic relation p' = c0² (ρ − ρ0), the inverse of the incompressible
  mapping's rule.  With pressure but no density, p' = c0² (ρ − ρ0) of the
  mapping's ρ, which is that mapping's (p − p_ref) in pascals.

Sampling is trilinear at the panel centres: the eight corner indices and
weights are computed once, each step is one gather (no loop over panels).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auralize.constants import C0, RHO0
from auralize.errors import DataError, FieldError, ParameterError
from auralize.fwh.surface import Surface
from auralize.sources.mapping import AcousticMapping, CFDMapping, IncompressibleMapping, match_field
from auralize.volume import TimeVolume

#: the default ambient density (kg/m³), docs/design.md


@dataclass
class SurfaceSamples:
    """The flow sampled on a surface's panel centres at every data step.

    Attributes
    ----------
    times : (T,) float
        Data times in seconds.
    rho : (T, P) float
        Density ρ in kg/m³.
    velocity : (T, P, 3) float
        Fluid velocity u in m/s.
    p_prime : (T, P) float
        Pressure fluctuation p − p0 in Pa.
    surface : Surface
    rho0, c0, p0 : float
        Ambient density, speed of sound, ambient pressure (NaN: p' came from ρ).
    fields : dict
        The roles found (``density``, ``velocity``, ``momentum``,
        ``pressure``: field name or None) and the mapping used.
    """

    times: NDArray[np.float64]
    rho: NDArray[np.float64]
    velocity: NDArray[np.float64]
    p_prime: NDArray[np.float64]
    surface: Surface
    rho0: float
    c0: float
    p0: float
    fields: dict[str, Any] = field(default_factory=dict)


def trilinear_weights(
    volume: TimeVolume, points: NDArray[np.floating]
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Flat C-order indices ``(N, 8)`` and weights ``(N, 8)`` of trilinear interpolation.

    ``points (N, 3)`` must lie inside the grid (every axis of at least two
    points).  ``frame.reshape(-1, ...)[idx]`` weighted by ``w`` and summed
    over the last axis but one is the interpolated value.

    Examples
    --------
    >>> import numpy as np
    >>> vol = TimeVolume.from_arrays({"a": np.zeros((1, 2, 2, 2))}, spacing=1.0)
    >>> f = np.arange(8.0).reshape(2, 2, 2)  # f = x + 2 y + 4 z
    >>> idx, w = trilinear_weights(vol, np.array([[0.25, 0.5, 0.75]]))
    >>> float((f.reshape(-1)[idx] * w).sum())
    4.25
    """
    if volume.coords is not None:
        from auralize.errors import DataError

        raise DataError(
            f"{volume.source}: the FW-H integral samples its surface on a uniform grid, and this "
            f"curvilinear grid is read on its own points: add --resample (curvilinear='resample' "
            f"in Python) to read it resampled onto a uniform grid"
        )
    nx, ny, nz = volume.dims
    f = (np.asarray(points, dtype=np.float64) - volume.origin) / volume.spacing
    base = np.empty((f.shape[0], 3), dtype=np.int64)
    frac = np.empty((f.shape[0], 3))
    for a, n in enumerate((nx, ny, nz)):
        i0 = np.clip(np.floor(f[:, a]).astype(np.int64), 0, max(n - 2, 0))
        base[:, a] = i0
        frac[:, a] = np.clip(f[:, a] - i0, 0.0, 1.0)
    idx = np.empty((f.shape[0], 8), dtype=np.int64)
    w = np.empty((f.shape[0], 8))
    c = 0
    for dk in (0, 1):
        for dj in (0, 1):
            for di in (0, 1):
                i, j, k = base[:, 0] + di, base[:, 1] + dj, base[:, 2] + dk
                idx[:, c] = (k * ny + j) * nx + i
                w[:, c] = (
                    (frac[:, 0] if di else 1 - frac[:, 0])
                    * (frac[:, 1] if dj else 1 - frac[:, 1])
                    * (frac[:, 2] if dk else 1 - frac[:, 2])
                )
                c += 1
    return idx, w


def check_inside(volume: TimeVolume, surface: Surface) -> None:
    """Raise :class:`DataError` unless every panel corner lies inside the grid's box."""
    gb = np.asarray(volume.bounds).reshape(3, 2)
    pts = surface.corners.reshape(-1, 3)
    tol = 1e-9 * max(float(np.max(np.abs(gb))), 1.0)
    out = ~np.all((pts >= gb[:, 0] - tol) & (pts <= gb[:, 1] + tol), axis=1)
    if out.any():
        sb = ", ".join(f"{v:g}" for v in surface.bounds)
        vb = ", ".join(f"{v:g}" for v in volume.bounds)
        raise DataError(
            f"FW-H surface {surface.description or surface.kind!r} (bounds {sb}) is not inside "
            f"the grid of {volume.source} (bounds {vb}): {int(out.sum())} panel corners lie "
            f"outside. Place the surface inside the data, around the sources"
        )


def resolve_fields(
    volume: TimeVolume,
    *,
    density: str | None = None,
    velocity: str | None = None,
    momentum: str | None = None,
    pressure: str | None = None,
) -> dict[str, str | None]:
    """The fields playing density, velocity, momentum and pressure (given or matched)."""
    roles = {"density": density, "velocity": velocity, "momentum": momentum, "pressure": pressure}
    out: dict[str, str | None] = {}
    for role, name in roles.items():
        if name is not None and name not in volume.fields:
            raise FieldError(
                f"{volume.source}: no field {name!r} for the {role}; the volume has "
                f"{volume.field_names}"
            )
        out[role] = name if name is not None else match_field(volume, role)
    if out["velocity"] is None and out["momentum"] is None:
        raise FieldError(
            f"{volume.source}: the FW-H integral needs the flow velocity (a vector field named "
            f"velocity, U, ... or momentum with density); the volume has {volume.field_names}. "
            f"Name it with velocity=NAME"
        )
    if out["density"] is None and out["pressure"] is None:
        raise FieldError(
            f"{volume.source}: the FW-H integral needs a density or a pressure field; the "
            f"volume has {volume.field_names}. Name one with density=NAME or pressure=NAME"
        )
    if out["density"] is None and out["velocity"] is None:
        raise FieldError(
            f"{volume.source}: momentum {out['momentum']!r} needs a density to give the "
            f"velocity; the volume has {volume.field_names}"
        )
    return out


def _mapping(roles: dict[str, str | None], rho0: float, c0: float) -> AcousticMapping:
    if roles["density"] is not None:
        # names not in the volume make CFDMapping take the other one
        return CFDMapping(
            density=roles["density"],
            momentum=roles["momentum"] or "\0",
            velocity=roles["velocity"] or "\0",
        )
    assert roles["pressure"] is not None and roles["velocity"] is not None
    return IncompressibleMapping(
        pressure=roles["pressure"], velocity=roles["velocity"], rho0=rho0, c0=c0
    )


@dataclass(frozen=True)
class _Sampler:
    """How the surface samples the volume: the mapping of ρ and u, the trilinear
    indices ``idx`` and weights ``w`` of the panel centres, the pressure field (None:
    p' from ρ) with its ambient value ``p0``, and ρ0, c0."""

    mapping: AcousticMapping
    idx: NDArray[np.int64]
    w: NDArray[np.float64]
    pname: str | None
    p0: float | None
    rho0: float
    c0: float

    def step(
        self, volume: TimeVolume, n: int
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """ρ, u and p' at the panel centres at step ``n``."""
        idx, w = self.idx, self.w
        r, u = self.mapping.map(volume, n)
        rho = np.einsum("pc,pc->p", r.reshape(-1)[idx], w)
        vel = np.einsum("pcj,pc->pj", u.reshape(-1, 3)[idx], w)
        if self.pname is not None:
            assert self.p0 is not None
            pp = np.einsum("pc,pc->p", volume.frame(self.pname, n).reshape(-1)[idx], w) - self.p0
        else:  # the linear acoustic relation p' = c0² ρ'
            pp = self.c0**2 * (rho - self.rho0)
        return rho, vel, pp


def panel_pressure(
    volume: TimeVolume, surface: Surface, step: int, *, rho0: float = RHO0, c0: float = C0
) -> NDArray[np.float64]:
    """The pressure fluctuation p' (Pa) on the panel centres of ``surface`` at one step.

    The same interpolation and field rules as :func:`sample_surface` (p' from the
    pressure less its first step's mean, or c0² (ρ − ρ0) without a pressure
    field), for one step only: what the viewer colours the FW-H surface by.

    Parameters
    ----------
    volume : TimeVolume
        Uniform grid with the FW-H fields (see :func:`resolve_fields`).
    surface : Surface
        Inside the grid.
    step : int
        Time step index.
    rho0, c0 : float
        Ambient density (kg/m³) and speed of sound (m/s).

    Returns
    -------
    (P,) float
        p' in Pa per panel (NaN where the data have none).

    Examples
    --------
    >>> import numpy as np
    >>> from auralize.fwh.surface import box_surface
    >>> p = 1e5 + np.arange(2.0)[:, None, None, None] * np.ones((2, 5, 5, 5))  # +1 Pa at step 1
    >>> vol = TimeVolume.from_arrays({"pressure": p, "velocity": np.zeros((2, 5, 5, 5, 3))},
    ...                              spacing=1.0)
    >>> panel_pressure(vol, box_surface((1, 3, 1, 3, 1, 3), n=2), 1).round(9)[:3].tolist()
    [1.0, 1.0, 1.0]
    """
    check_inside(volume, surface)
    roles = resolve_fields(volume)
    mapping = _mapping(roles, rho0, c0)
    mapping.prepare(volume)
    idx, w = trilinear_weights(volume, surface.centres)
    pname = roles["pressure"] if roles["density"] is not None else None
    p0 = None
    if pname is not None:
        first = volume.frame(pname, 0)
        finite = np.isfinite(first)
        p0 = float(first[finite].mean()) if finite.any() else 0.0
    return _Sampler(mapping, idx, w, pname, p0, rho0, c0).step(volume, int(step))[2]


def sample_surface(
    volume: TimeVolume,
    surface: Surface,
    *,
    rho0: float = RHO0,
    c0: float = C0,
    p0: float | None = None,
    density: str | None = None,
    velocity: str | None = None,
    momentum: str | None = None,
    pressure: str | None = None,
) -> SurfaceSamples:
    """Sample ρ, u and p' on the panel centres of ``surface`` at every step of ``volume``.

    Parameters
    ----------
    volume : TimeVolume
        At least 4 steps; fields found by role unless named.
    surface : Surface
        Inside the grid.
    rho0, c0 : float
        Ambient density (kg/m³) and speed of sound (m/s).
    p0 : float, optional
        Ambient pressure (Pa); default the mean of the first step's pressure.
        Only with a density field (without one the incompressible mapping's
        reference, the same mean, is used).
    density, velocity, momentum, pressure : str, optional
        Field names (default: :func:`auralize.sources.mapping.match_field`).

    Raises
    ------
    FieldError
        No velocity (or momentum with density), no density or pressure.
    DataError
        Surface outside the grid, NaN (no-data) on the surface, too few steps.
    """
    for name, val in (("rho0", rho0), ("c0", c0)):
        if not (np.isfinite(val) and val > 0):
            raise ParameterError(f"{name} must be a positive number, got {val!r}")
    if volume.n_steps < 4:
        raise DataError(
            f"{volume.source}: the FW-H integral needs at least 4 time steps (time "
            f"derivatives, cubic retarded-time interpolation), got {volume.n_steps}"
        )
    check_inside(volume, surface)
    roles = resolve_fields(
        volume, density=density, velocity=velocity, momentum=momentum, pressure=pressure
    )
    if roles["density"] is None and p0 is not None:
        raise ParameterError(
            f"{volume.source}: p0 applies to a volume with density and pressure; with pressure "
            f"{roles['pressure']!r} only, the density is made from p' = p − (first step's mean) "
            f"by the incompressible mapping, and that reference is used"
        )
    mapping = _mapping(roles, rho0, c0)
    mapping.prepare(volume)
    idx, w = trilinear_weights(volume, surface.centres)
    pname = roles["pressure"] if roles["density"] is not None else None
    if pname is not None and p0 is None:
        first = volume.frame(pname, 0)
        finite = np.isfinite(first)
        p0 = float(first[finite].mean()) if finite.any() else 0.0
    if p0 is not None and not np.isfinite(p0):
        raise ParameterError(f"p0 must be finite, got {p0!r}")
    T, P = volume.n_steps, surface.n_panels
    rho = np.empty((T, P))
    vel = np.empty((T, P, 3))
    pp = np.empty((T, P))
    sampler = _Sampler(mapping, idx, w, pname, p0, rho0, c0)
    for n in range(T):
        rho[n], vel[n], pp[n] = sampler.step(volume, n)
        bad = ~(np.isfinite(rho[n]) & np.isfinite(vel[n]).all(axis=1) & np.isfinite(pp[n]))
        if bad.any():
            raise DataError(
                f"{volume.source}: step {n} (t={volume.times[n]:g} s) has no data (NaN) at "
                f"{int(bad.sum())} of the {P} FW-H panels; place the surface where the data are "
                f"valid"
            )
    return SurfaceSamples(
        times=volume.times.copy(),
        rho=rho,
        velocity=vel,
        p_prime=pp,
        surface=surface,
        rho0=float(rho0),
        c0=float(c0),
        p0=float("nan") if p0 is None else float(p0),
        fields={**roles, "mapping": mapping.name},
    )
