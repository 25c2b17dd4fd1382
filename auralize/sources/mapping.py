"""Acoustic mappings: field values -> density ρ̃ and particle velocity v (paper 003 §3.2.2).

A mapping turns one time step of a :class:`~auralize.volume.TimeVolume` into
``(rho, velocity)`` with shapes ``(nz, ny, nx)`` and ``(nz, ny, nx, 3)`` in
kg/m³ and m/s.  Some mappings need series-wide statistics (the paper rescales
to fixed ranges); they gather them once in :meth:`AcousticMapping.prepare`,
reading the frames one at a time.

Presets (:func:`get_mapping`):

``paper-density``
    The paper's: the field holds log10 density; ``10**x`` is rescaled
    linearly so that the series spans [0.5, 15] (ρ̃), and the particle velocity
    is ∇ρ̃ scaled so that its components span at most [-150, 150] m/s.
``identity``
    ``density`` and ``velocity`` taken as they are (missing velocity = 0).
``cfd``
    ``density`` plus ``momentum`` (v = m/ρ) or ``velocity`` from CFD output.
``incompressible``
    Incompressible CFD (OpenFOAM ``p`` and ``U``, no density): density from
    pressure by the linear acoustic relation ρ' = p'/c0², ρ = ρ0 + ρ'
    (p' = p minus its mean at the first step); kinematic pressure (units
    m² s⁻², OpenFOAM's incompressible solvers) is multiplied by ρ0 first.

Field names default to the first match of each role in the volume
(:func:`match_field`, from :mod:`auralize.roles`, re-exported here): case-insensitive, with the names the writing tools
use: OpenFOAM (``U``, ``p``, ``rho``), PLOT3D (``Density``, ``Momentum``),
VTK/ParaView (``velocity``, ``Velocity``, ``rho``, ``pressure``), FLUENT
(``SV_DENSITY``, ``SV_P``, ``SV_U``/``SV_V``/``SV_W``), CGNS (``Density``,
``Pressure``, ``VelocityX/Y/Z``, ``MomentumX/Y/Z``) and CF standard names
(``air_density``, ``air_pressure``, ``eastward_wind``/``northward_wind``/
``upward_air_velocity``).  A velocity or momentum stored as three scalar
components is assembled into one vector field (:func:`assemble_vector`).

A user function ``fn(frames: dict[str, ndarray]) -> (rho, velocity)`` is
wrapped by :class:`FunctionMapping`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from auralize.constants import C0
from auralize.errors import DataError, FieldError, ParameterError
from auralize.roles import COMPONENT_NAMES as COMPONENT_NAMES
from auralize.roles import ROLE_NAMES as ROLE_NAMES
from auralize.roles import VECTOR_ROLES as VECTOR_ROLES
from auralize.roles import assemble_vector as assemble_vector
from auralize.roles import match_field as match_field
from auralize.roles import role_reason as role_reason
from auralize.volume import TimeVolume

Frame = NDArray[np.float64]


def _velocity_or_zero(volume: TimeVolume, name: str, step: int, shape: tuple[int, ...]) -> Frame:
    """The velocity frame ``name`` at ``step``, or zeros ``(*shape, 3)`` when it is missing."""
    if name not in volume.fields:
        return np.zeros((*shape, 3))
    v = volume.frame(name, step)
    _check_vector(volume, name, v)
    return v


def _without_velocity(volume: TimeVolume, name: str) -> dict[str, str]:
    """The source types a missing velocity field ``name`` leaves out (``{}`` when present)."""
    if name in volume.fields:
        return {}
    why = f"no velocity field ({name!r} is not in the volume)"
    return {"dipole": why, "quadrupole": why}


class AcousticMapping:
    """Base class of the acoustic mappings (paper 003 §3.2.2): field values to ρ̃ and v.

    ``prepare(volume)`` once, then ``map(volume, step)`` per step, which gives
    the density ρ̃ ``(nz, ny, nx)`` in kg/m³ and the particle velocity v
    ``(nz, ny, nx, 3)`` in m/s (components x, y, z).  Subclasses set
    :attr:`name`, :meth:`required_fields` and :meth:`map`; the base class maps
    nothing.

    Examples
    --------
    >>> m = AcousticMapping()
    >>> m.name, m.mass_flux, m.required_fields(), m.describe()
    ('base', 'mapped', [], {'name': 'base'})
    """

    name = "base"
    #: how the continuity residual's mass flux is made (:func:`auralize.sources.field.mass_flux_rule`):
    #: "mapped" ρ̃v; "constant" ρ0 v (density not carried by the flow); "none" (no flow)
    mass_flux = "mapped"

    def unavailable(self, volume: TimeVolume) -> dict[str, str]:
        """Source types this mapping cannot compute on ``volume``, with the reason.

        A mapping without a velocity field gives v = 0, so no dipoles or
        quadrupoles (their strengths need the momentum ρv).

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.

        Returns
        -------
        dict of str to str
            Source type (``"dipole"``, ``"quadrupole"``) to the reason it cannot
            be computed; empty (the base class's answer) when all three can.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2))})
        >>> AcousticMapping().unavailable(vol)
        {}
        """
        return {}

    def required_fields(self) -> list[str]:
        """Names of the fields :meth:`prepare` requires in the volume.

        Returns
        -------
        list of str
            Field names (the base class requires none).

        Examples
        --------
        >>> AcousticMapping().required_fields()
        []
        """
        return []

    def prepare(self, volume: TimeVolume) -> None:
        """Check fields exist and gather series-wide statistics (default: none).

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.

        Raises
        ------
        FieldError
            A field of :meth:`required_fields` is not in the volume.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2))})
        >>> IdentityMapping().prepare(vol)
        >>> IdentityMapping(density="rho").prepare(vol)
        Traceback (most recent call last):
        ...
        auralize.errors.FieldError: <memory>: mapping 'identity' needs field(s) ['rho']; ...
        """
        missing = [f for f in self.required_fields() if f not in volume.fields]
        if missing:
            raise FieldError(
                f"{volume.source}: mapping {self.name!r} needs field(s) {missing}; the volume "
                f"has {volume.field_names}. Name the field with --density-field/"
                f"--velocity-field/--momentum-field/--pressure-field NAME (Python: density=NAME "
                f"...) or choose another --mapping"
            )

    def prepare_series(self, volume: TimeVolume, *, hold_bytes: int = 0) -> None:
        """:meth:`prepare`, for a caller that maps every step next, each once.

        A mapping whose statistics read the frames may keep up to
        ``hold_bytes`` of what it read for those :meth:`map` calls (each kept
        frame handed out once, then dropped), so that each frame is read
        once; :meth:`release` drops what is left.  Default: :meth:`prepare`.

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.
        hold_bytes : int
            Most bytes of frames read by the statistics kept for :meth:`map`
            (0: none kept).

        Raises
        ------
        FieldError
            A field of :meth:`required_fields` is not in the volume.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2))})
        >>> m = IdentityMapping()
        >>> m.prepare_series(vol, hold_bytes=1 << 20)
        >>> m.map(vol, 1)[0].shape
        (2, 2, 2)
        >>> m.release()
        """
        self.prepare(volume)

    def release(self) -> None:
        """Drop the frames :meth:`prepare_series` kept and :meth:`map` has not used.

        Examples
        --------
        >>> AcousticMapping().release()  # the base class keeps nothing
        """

    def map(self, volume: TimeVolume, step: int) -> tuple[Frame, Frame]:
        """Density and particle velocity of one step (subclasses implement it).

        Parameters
        ----------
        volume : TimeVolume
            The volume.
        step : int
            Time step, ``0 <= step < volume.n_steps``.

        Returns
        -------
        rho : ndarray, shape (nz, ny, nx)
            Density ρ̃, kg/m³.
        velocity : ndarray, shape (nz, ny, nx, 3)
            Particle velocity v (components x, y, z), m/s.

        Raises
        ------
        NotImplementedError
            In the base class.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2))})
        >>> AcousticMapping().map(vol, 0)
        Traceback (most recent call last):
        ...
        NotImplementedError
        """
        raise NotImplementedError  # pragma: no cover - abstract

    def describe(self) -> dict[str, object]:
        """The mapping's name and settings, as saved with detected sources.

        Returns
        -------
        dict
            ``{"name": ...}`` plus the subclass's field names and parameters.

        Examples
        --------
        >>> AcousticMapping().describe()
        {'name': 'base'}
        """
        return {"name": self.name}


@dataclass
class IdentityMapping(AcousticMapping):
    """Density and velocity fields taken as they are (missing velocity = 0).

    Parameters
    ----------
    density : str
        Name of the scalar density field, kg/m³.
    velocity : str
        Name of the vector velocity field, m/s; when the volume lacks it,
        v = 0 (no dipoles or quadrupoles, :meth:`unavailable`).

    Examples
    --------
    >>> vol = TimeVolume.from_arrays({"rho": np.full((2, 2, 3, 4), 1.2)})
    >>> m = IdentityMapping(density="rho")
    >>> rho, v = m.map(vol, 1)
    >>> rho.shape, v.shape, float(rho[0, 0, 0]), float(np.abs(v).max())
    ((2, 3, 4), (2, 3, 4, 3), 1.2, 0.0)
    """

    density: str = "density"
    velocity: str = "velocity"
    name = "identity"

    def required_fields(self) -> list[str]:
        """The density field's name (the velocity is optional).

        Returns
        -------
        list of str
            ``[density]``.

        Examples
        --------
        >>> IdentityMapping(density="rho").required_fields()
        ['rho']
        """
        return [self.density]

    def map(self, volume: TimeVolume, step: int) -> tuple[Frame, Frame]:
        """The density and velocity frames of ``step`` as they are.

        Parameters
        ----------
        volume : TimeVolume
            The volume.
        step : int
            Time step.

        Returns
        -------
        rho : ndarray, shape (nz, ny, nx)
            The density field, kg/m³.
        velocity : ndarray, shape (nz, ny, nx, 3)
            The velocity field, m/s (zeros when the volume has none).

        Raises
        ------
        DataError
            The density is not scalar or the velocity not a 3-vector on the grid.

        Examples
        --------
        >>> u = np.zeros((2, 2, 2, 2, 3))
        >>> u[..., 0] = 5.0
        >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2)), "velocity": u})
        >>> rho, v = IdentityMapping().map(vol, 0)
        >>> v[0, 0, 0].tolist()
        [5.0, 0.0, 0.0]
        """
        rho = volume.frame(self.density, step)
        _check_scalar(volume, self.density, rho)
        return rho, _velocity_or_zero(volume, self.velocity, step, rho.shape)

    def unavailable(self, volume: TimeVolume) -> dict[str, str]:
        """Dipoles and quadrupoles when the volume has no velocity field.

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.

        Returns
        -------
        dict of str to str
            ``{"dipole": why, "quadrupole": why}`` without the velocity field,
            else ``{}``.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2))})
        >>> sorted(IdentityMapping().unavailable(vol))
        ['dipole', 'quadrupole']
        """
        return _without_velocity(volume, self.velocity)

    def describe(self) -> dict[str, object]:
        """The mapping's name and field names.

        Returns
        -------
        dict
            ``{"name", "density", "velocity"}``.

        Examples
        --------
        >>> IdentityMapping(density="rho").describe()
        {'name': 'identity', 'density': 'rho', 'velocity': 'velocity'}
        """
        return {"name": self.name, "density": self.density, "velocity": self.velocity}


@dataclass
class IncompressibleMapping(AcousticMapping):
    """Density from pressure for incompressible CFD: ρ = ρ0 + (p - p_ref)/c0².

    The linear acoustic relation (isentropic, small amplitude) between a
    pressure fluctuation and a density fluctuation, ρ' = p'/c0², gives an
    incompressible solver's output (pressure and velocity, constant or no
    density) a density whose time derivative is the monopole source.  The
    reference ``p_ref`` is the mean pressure over the valid points of the
    first step; the velocity is taken as it is (missing: zero, and no dipoles
    or quadrupoles).

    Parameters
    ----------
    pressure, velocity : str
        Field names.
    rho0 : float
        Ambient density in kg/m³ (default 1.2).
    c0 : float
        Speed of sound in m/s (default 343).
    kinematic : bool or None
        True: the pressure field is kinematic (p/ρ, m² s⁻², as OpenFOAM's
        incompressible solvers write it) and is multiplied by ``rho0``;
        None: decided from the field's units (``attrs["units"]``).

    Examples
    --------
    A pressure rise of c0² · 0.01 Pa over the first step's mean is a density
    0.01 kg/m³ above ρ0:

    >>> p = np.full((2, 2, 2, 2), 1e5)
    >>> p[1] += 343.0**2 * 0.01
    >>> vol = TimeVolume.from_arrays({"p": p})
    >>> m = IncompressibleMapping(pressure="p", c0=343.0)
    >>> m.prepare(vol)
    >>> rho, v = m.map(vol, 1)
    >>> round(float(rho[0, 0, 0]), 12), float(np.abs(v).max())
    (1.21, 0.0)
    """

    pressure: str = "pressure"
    velocity: str = "velocity"
    rho0: float = 1.2
    c0: float = C0
    kinematic: bool | None = None
    name = "incompressible"
    mass_flux = "constant"
    _p_ref: float = dataclasses.field(default=np.nan, init=False, repr=False)
    _scale: float = dataclasses.field(default=1.0, init=False, repr=False)
    _prepared_for: int = dataclasses.field(default=0, init=False, repr=False)

    def required_fields(self) -> list[str]:
        """The pressure field's name (the velocity is optional).

        Returns
        -------
        list of str
            ``[pressure]``.

        Examples
        --------
        >>> IncompressibleMapping(pressure="p").required_fields()
        ['p']
        """
        return [self.pressure]

    def prepare(self, volume: TimeVolume) -> None:
        """Check the pressure field, decide whether it is kinematic and take p_ref.

        ``p_ref`` is the mean of the first step's pressure over its finite
        points (0 if it has none).

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.

        Raises
        ------
        FieldError
            The pressure field is not in the volume.
        DataError
            The pressure field is not scalar.

        Examples
        --------
        Kinematic pressure (m² s⁻², in ``attrs["units"]``) is multiplied by ρ0:

        >>> vol = TimeVolume.from_arrays({"p": np.zeros((2, 2, 2, 2))})
        >>> vol.attrs["units"] = {"p": "m2 s-2"}
        >>> m = IncompressibleMapping(pressure="p")
        >>> m.prepare(vol)
        >>> m.describe()["kinematic_scale"]
        1.2
        """
        super().prepare(volume)
        kinematic = self.kinematic
        if kinematic is None:
            units = volume.attrs.get("units")
            unit = units.get(self.pressure, "") if isinstance(units, dict) else ""
            kinematic = str(unit).replace(" ", "") in ("m2s-2", "m^2/s^2", "m2/s2", "m^2s^-2")
        self._scale = self.rho0 if kinematic else 1.0
        p0 = volume.frame(self.pressure, 0)
        _check_scalar(volume, self.pressure, p0)
        finite = np.isfinite(p0)
        self._p_ref = float(p0[finite].mean()) if finite.any() else 0.0
        self._prepared_for = id(volume)

    def map(self, volume: TimeVolume, step: int) -> tuple[Frame, Frame]:
        """ρ = ρ0 + (p - p_ref) · s / c0² and the velocity field of ``step``.

        ``s`` is ρ0 for kinematic pressure, else 1; the mapping is prepared
        for ``volume`` first if it is not yet.

        Parameters
        ----------
        volume : TimeVolume
            The volume.
        step : int
            Time step.

        Returns
        -------
        rho : ndarray, shape (nz, ny, nx)
            Density, kg/m³.
        velocity : ndarray, shape (nz, ny, nx, 3)
            The velocity field, m/s (zeros when the volume has none).

        Raises
        ------
        FieldError
            The pressure field is not in the volume.
        DataError
            The pressure is not scalar or the velocity not a 3-vector on the grid.

        Examples
        --------
        >>> p = np.zeros((2, 2, 2, 2))
        >>> p[1] = 343.0**2
        >>> vol = TimeVolume.from_arrays({"pressure": p})
        >>> rho, _ = IncompressibleMapping(c0=343.0).map(vol, 1)
        >>> float(rho.mean())
        2.2
        """
        if self._prepared_for != id(volume):
            self.prepare(volume)
        p = volume.frame(self.pressure, step)
        _check_scalar(volume, self.pressure, p)
        rho = self.rho0 + (p - self._p_ref) * (self._scale / self.c0**2)
        return rho, _velocity_or_zero(volume, self.velocity, step, rho.shape)

    def unavailable(self, volume: TimeVolume) -> dict[str, str]:
        """Dipoles and quadrupoles when the volume has no velocity field.

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.

        Returns
        -------
        dict of str to str
            ``{"dipole": why, "quadrupole": why}`` without the velocity field,
            else ``{}``.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"pressure": np.ones((2, 2, 2, 2))})
        >>> IncompressibleMapping().unavailable(vol)["dipole"]
        "no velocity field ('velocity' is not in the volume)"
        """
        return _without_velocity(volume, self.velocity)

    def describe(self) -> dict[str, object]:
        """The mapping's name, field names and parameters.

        Returns
        -------
        dict
            ``{"name", "pressure", "velocity", "rho0", "c0", "kinematic_scale"}``
            (``kinematic_scale``: ρ0 for kinematic pressure, 1 otherwise, as
            the last :meth:`prepare` decided).

        Examples
        --------
        >>> IncompressibleMapping(pressure="p", c0=340.0).describe()["c0"]
        340.0
        """
        return {
            "name": self.name,
            "pressure": self.pressure,
            "velocity": self.velocity,
            "rho0": self.rho0,
            "c0": self.c0,
            "kinematic_scale": self._scale,
        }


@dataclass
class CFDMapping(AcousticMapping):
    """Density plus momentum (v = m/ρ) or velocity, e.g. from a CFD solver.

    Parameters
    ----------
    density : str
        Name of the scalar density field, kg/m³.
    momentum : str
        Name of the vector momentum field ρv, kg/(m²·s); used when present.
    velocity : str
        Name of the vector velocity field, m/s; used when there is no momentum.

    Examples
    --------
    >>> m_ = np.zeros((2, 2, 2, 2, 3))
    >>> m_[..., 2] = 6.0
    >>> vol = TimeVolume.from_arrays({"density": np.full((2, 2, 2, 2), 2.0), "momentum": m_})
    >>> rho, v = CFDMapping().map(vol, 0)
    >>> v[1, 1, 1].tolist()
    [0.0, 0.0, 3.0]
    """

    density: str = "density"
    momentum: str = "momentum"
    velocity: str = "velocity"
    name = "cfd"

    def required_fields(self) -> list[str]:
        """The density field's name (momentum or velocity: :meth:`prepare` checks).

        Returns
        -------
        list of str
            ``[density]``.

        Examples
        --------
        >>> CFDMapping(density="Density").required_fields()
        ['Density']
        """
        return [self.density]

    def prepare(self, volume: TimeVolume) -> None:
        """Check the density field and a momentum or velocity field exist.

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.

        Raises
        ------
        FieldError
            No density field, or neither a momentum nor a velocity field.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2))})
        >>> CFDMapping().prepare(vol)
        Traceback (most recent call last):
        ...
        auralize.errors.FieldError: <memory>: mapping 'cfd' needs a momentum field 'momentum' ...
        """
        super().prepare(volume)
        if self.momentum not in volume.fields and self.velocity not in volume.fields:
            raise FieldError(
                f"{volume.source}: mapping 'cfd' needs a momentum field {self.momentum!r} or a "
                f"velocity field {self.velocity!r}; the volume has {volume.field_names}"
            )

    def map(self, volume: TimeVolume, step: int) -> tuple[Frame, Frame]:
        """The density of ``step`` and the velocity m/ρ (or the velocity field).

        Parameters
        ----------
        volume : TimeVolume
            The volume.
        step : int
            Time step.

        Returns
        -------
        rho : ndarray, shape (nz, ny, nx)
            The density field, kg/m³.
        velocity : ndarray, shape (nz, ny, nx, 3)
            Momentum over density, or the velocity field, m/s.

        Raises
        ------
        DataError
            A field of the wrong shape, or a density ≤ 0 where momentum is
            divided by it.

        Examples
        --------
        >>> u = np.ones((2, 2, 2, 2, 3))
        >>> vol = TimeVolume.from_arrays({"density": np.ones((2, 2, 2, 2)), "velocity": u})
        >>> rho, v = CFDMapping().map(vol, 1)
        >>> float(v.sum())
        24.0
        """
        rho = volume.frame(self.density, step)
        _check_scalar(volume, self.density, rho)
        if self.momentum in volume.fields:
            m = volume.frame(self.momentum, step)
            _check_vector(volume, self.momentum, m)
            if np.any(rho <= 0):
                raise DataError(
                    f"{volume.source}: density {self.density!r} at step {step} has non-positive "
                    f"values (min {rho.min():g}); cannot divide momentum by it"
                )
            return rho, m / rho[..., None]
        v = volume.frame(self.velocity, step)
        _check_vector(volume, self.velocity, v)
        return rho, v

    def describe(self) -> dict[str, object]:
        """The mapping's name and field names.

        Returns
        -------
        dict
            ``{"name", "density", "momentum", "velocity"}``.

        Examples
        --------
        >>> CFDMapping().describe()["momentum"]
        'momentum'
        """
        return {
            "name": self.name,
            "density": self.density,
            "momentum": self.momentum,
            "velocity": self.velocity,
        }


@dataclass
class PaperDensityMapping(AcousticMapping):
    """The mapping of paper 003 §3.2.2 for log10-density data.

    ρ̃ = 0.5 + 14.5 (10**x - lo) / (hi - lo), where lo and hi are the smallest
    and largest 10**x over the whole series; v = ∇ρ̃ · 150 / G, where G is the
    largest |∂ρ̃/∂x_i| over the series, so components fall in [-150, 150].
    The gradient is :func:`numpy.gradient`'s (central differences inside,
    one-sided at the faces), on a curvilinear grid through its metric terms.

    Parameters
    ----------
    field : str
        Name of the scalar field holding log10 of the density.
    rho_range : (2,) tuple of float
        The range ``(a, b)`` ρ̃ spans over the series, kg/m³ (the paper's
        [0.5, 15]).
    velocity_max : float
        The largest |v_i| over the series, m/s (the paper's 150).

    Examples
    --------
    >>> from auralize.datasets.synthetic import make_explosion
    >>> vol = make_explosion(size=8, steps=3)
    >>> m = PaperDensityMapping()
    >>> m.prepare(vol)
    >>> rho, v = m.map(vol, 1)
    >>> rho.shape, v.shape
    ((8, 8, 8), (8, 8, 8, 3))
    >>> bool(0.5 <= rho.min() and rho.max() <= 15.0 and np.abs(v).max() <= 150.0)
    True
    """

    field: str = "log10_density"
    rho_range: tuple[float, float] = (0.5, 15.0)
    velocity_max: float = 150.0
    name = "paper-density"
    mass_flux = "none"
    _lo: float = dataclasses.field(default=np.nan, init=False, repr=False)
    _hi: float = dataclasses.field(default=np.nan, init=False, repr=False)
    _gscale: float = dataclasses.field(default=np.nan, init=False, repr=False)
    _prepared_for: int = dataclasses.field(default=0, init=False, repr=False)
    #: what :meth:`prepare_series` read, each handed to :meth:`map` once: per step ρ̃ and
    #: its gradient (not yet scaled), or ρ̃
    _held: dict[int, Frame | tuple[Frame, Frame]] = dataclasses.field(
        default_factory=dict, init=False, repr=False
    )

    def required_fields(self) -> list[str]:
        """The log10-density field's name.

        Returns
        -------
        list of str
            ``[field]``.

        Examples
        --------
        >>> PaperDensityMapping(field="log_rho").required_fields()
        ['log_rho']
        """
        return [self.field]

    def _rho(
        self, volume: TimeVolume, step: int, extremes: Frame | None = None, out: Frame | None = None
    ) -> Frame:
        """10**x of step ``step`` (into ``out`` when it fits); with ``extremes (2,)``, its
        smallest and largest values (NaN ignored) there."""
        x = volume.frame(self.field, step)
        _check_scalar(volume, self.field, x)
        r = _pow10(x, extremes, out)
        if r is None:
            raise DataError(
                f"{volume.source}: field {self.field!r} is read as log10 density by the "
                f"'paper-density' mapping, but holds values up to {np.nanmax(np.abs(x)):g}; "
                f"use the 'identity' mapping for linear densities"
            )
        return r

    def prepare(self, volume: TimeVolume) -> None:
        """Gather the series' range of 10**x and its largest gradient component.

        Two passes over the frames: lo and hi of 10**x, then the largest
        |∂ρ̃/∂x_i| G of the rescaled ρ̃ (NaN points ignored).

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.

        Raises
        ------
        FieldError
            The field is not in the volume.
        DataError
            The field is not scalar, or holds a value with |x| > 300 (not log10
            of a density).

        Examples
        --------
        Two steps of uniform densities 10 and 100: ρ̃ is 0.5 and 15:

        >>> x = np.ones((2, 2, 2, 2))
        >>> x[1] = 2.0
        >>> vol = TimeVolume.from_arrays({"log10_density": x})
        >>> m = PaperDensityMapping()
        >>> m.prepare(vol)
        >>> float(m.map(vol, 0)[0].max()), float(m.map(vol, 1)[0].min())
        (0.5, 15.0)
        """
        self._prepare(volume, 0)

    def prepare_series(self, volume: TimeVolume, *, hold_bytes: int = 0) -> None:
        """:meth:`prepare` reading each frame once: the 10**x frames of its first
        pass (lo, hi) are kept, up to ``hold_bytes``, for its gradient pass, which
        keeps (on a uniform grid, as the bytes allow: 32 a point) each step's ρ̃ and
        gradient for the next :meth:`map` of the step, else the 10**x frame (frames
        beyond it are read again).

        Parameters
        ----------
        volume : TimeVolume
            The volume to be mapped.
        hold_bytes : int
            Most bytes of frames kept for :meth:`map` (0: none, as :meth:`prepare`).

        Raises
        ------
        FieldError
            The field is not in the volume.
        DataError
            The field is not scalar, or holds a value with |x| > 300.

        Examples
        --------
        The kept frames map to the same numbers as those read again:

        >>> from auralize.datasets.synthetic import make_explosion
        >>> vol = make_explosion(size=8, steps=3)
        >>> held, again = PaperDensityMapping(), PaperDensityMapping()
        >>> held.prepare_series(vol, hold_bytes=1 << 20)
        >>> again.prepare(vol)
        >>> all(np.array_equal(held.map(vol, n)[1], again.map(vol, n)[1]) for n in range(3))
        True
        >>> held.release()
        """
        self._prepare(volume, hold_bytes)

    def release(self) -> None:
        """Drop the frames :meth:`prepare_series` kept that :meth:`map` has not used.

        Examples
        --------
        >>> from auralize.datasets.synthetic import make_explosion
        >>> vol = make_explosion(size=8, steps=3)
        >>> m = PaperDensityMapping()
        >>> m.prepare_series(vol, hold_bytes=1 << 20)
        >>> m.release()
        >>> m.map(vol, 0)[0].shape  # read and mapped again
        (8, 8, 8)
        """
        self._held = {}

    def _prepare(self, volume: TimeVolume, hold_bytes: int) -> None:
        super().prepare(volume)
        self._held = {}
        room = min(int(hold_bytes) // max(8 * volume.n_points, 1), volume.n_steps)
        # the kept frames, and the gradients held below, each in one block: a large
        # allocation is mapped in huge pages (numpy asks for them), so the frames' first
        # touch costs a few page faults, not one per 4 kB page
        block: Frame | None = None
        kept: dict[int, Frame] = {}
        lo, hi = np.inf, -np.inf
        extremes = np.empty(2)
        for n in range(volume.n_steps):
            keep = len(kept) < room
            r = self._rho(volume, n, extremes, None if block is None or not keep else block[n])
            lo = min(lo, float(extremes[0]))  # no-data (NaN) points do not count
            hi = max(hi, float(extremes[1]))
            if keep:
                if block is None:
                    block = np.empty((room, *r.shape), dtype=r.dtype)
                    block[n] = r
                    r = block[n]
                kept[n] = r
        self._lo, self._hi = lo, hi
        # ρ̃ (scaled in place) and its gradient (scale 1: the same differences the mapped
        # velocity scales)
        uniform = volume.metric is None
        spare = int(hold_bytes) - 8 * volume.n_points * len(kept)
        n_grad = min(len(kept), max(spare, 0) // max(24 * volume.n_points, 1)) if uniform else 0
        grads = np.empty((n_grad, *volume.shape, 3)) if n_grad else None
        scratch: Frame | None = None
        held: dict[int, Frame | tuple[Frame, Frame]] = {}
        gmax = 0.0
        for n in range(volume.n_steps):
            was = kept.pop(n) if n in kept else None
            rho = self._scaled(self._rho(volume, n) if was is None else was, in_place=True)
            if not uniform:
                gmax = max(gmax, _gradient_absmax(rho, volume))
            else:
                hold = was is not None and grads is not None and n < n_grad
                if hold and grads is not None:
                    g = grads[n]
                else:
                    if scratch is None:
                        scratch = np.empty((*rho.shape, 3))
                    g = scratch
                gmax = max(gmax, _gradient_max(rho, volume, g))
                if hold:
                    held[n] = (rho, g)
                    continue
            if was is not None:
                held[n] = rho
        self._gscale = self.velocity_max / gmax if gmax > 0 else 0.0
        self._prepared_for = id(volume)
        self._held = held

    def _scaled(self, r: Frame, *, in_place: bool = False) -> Frame:
        """ρ̃ of the 10**x frame ``r`` (``in_place``: into ``r``)."""
        a, b = self.rho_range
        lo, span = self._lo, self._hi - self._lo
        if span <= 0:
            if in_place:
                r[...] = a
                return r
            return np.full_like(r, a)
        return _slabwise(lambda y: a + (b - a) * (y - lo) / span, r, r if in_place else None)

    @staticmethod
    def _grad(volume: TimeVolume, rho: Frame, scale: float = 1.0) -> Frame:
        """∇ρ̃ · ``scale`` (components x, y, z): :func:`numpy.gradient`'s differences,
        in the detection's compiled stencil (the same numbers); on a curvilinear grid
        its metric terms (:meth:`~auralize.curvilinear.CurvilinearMetric.gradient`)."""
        from auralize.sources.detection import gradient

        if volume.metric is not None:
            return np.asarray(volume.metric.gradient(rho) * scale)
        return gradient(rho, volume.spacing, scale)

    def map(self, volume: TimeVolume, step: int) -> tuple[Frame, Frame]:
        """ρ̃ of ``step`` rescaled to ``rho_range`` and v = ∇ρ̃ · ``velocity_max`` / G.

        The mapping is prepared for ``volume`` first if it is not yet; a step
        kept by :meth:`prepare_series` is handed out once.

        Parameters
        ----------
        volume : TimeVolume
            The volume.
        step : int
            Time step.

        Returns
        -------
        rho : ndarray, shape (nz, ny, nx)
            ρ̃, kg/m³, in ``rho_range`` over the series.
        velocity : ndarray, shape (nz, ny, nx, 3)
            The scaled gradient (components x, y, z), m/s.

        Raises
        ------
        FieldError
            The field is not in the volume.
        DataError
            The field is not scalar, or holds a value with |x| > 300.

        Examples
        --------
        A log10 density rising linearly along x: ρ̃ spans [0.5, 15] and v_x
        peaks at 150 m/s:

        >>> x = np.broadcast_to(np.linspace(0.0, 1.0, 4), (2, 2, 2, 4)).copy()
        >>> vol = TimeVolume.from_arrays({"log10_density": x})
        >>> rho, v = PaperDensityMapping().map(vol, 0)
        >>> float(rho.min()), float(rho.max()), float(v[..., 0].max()), float(np.abs(v[..., 1:]).max())
        (0.5, 15.0, 150.0, 0.0)
        """
        if self._prepared_for != id(volume):
            self.prepare(volume)
        hit = self._held.pop(step, None)
        if hit is None:
            rho = self._scaled(self._rho(volume, step), in_place=True)
            return rho, self._grad(volume, rho, self._gscale)
        if isinstance(hit, tuple):  # ρ̃ and its gradient: scaled as _grad would (g · scale)
            rho, g = hit
            scale = self._gscale

            def times(sl: slice) -> None:
                np.multiply(g[sl], scale, out=g[sl])

            if not _in_slabs(times, g):
                np.multiply(g, scale, out=g)
            return rho, g
        return hit, self._grad(volume, hit, self._gscale)

    def describe(self) -> dict[str, object]:
        """The mapping's name, field name and ranges.

        Returns
        -------
        dict
            ``{"name", "field", "rho_range", "velocity_max"}``.

        Examples
        --------
        >>> PaperDensityMapping().describe()
        {'name': 'paper-density', 'field': 'log10_density', 'rho_range': [0.5, 15.0], 'velocity_max': 150.0}
        """
        return {
            "name": self.name,
            "field": self.field,
            "rho_range": list(self.rho_range),
            "velocity_max": self.velocity_max,
        }


@dataclass
class FunctionMapping(AcousticMapping):
    """Wrap ``fn(frames) -> (rho, velocity)``; ``frames`` maps field names to arrays.

    Parameters
    ----------
    fn : callable
        ``fn(frames)``, ``frames`` a dict of field name to the step's frame
        (``(nz, ny, nx)`` or ``(nz, ny, nx, 3)``), returning the density
        ``(nz, ny, nx)`` in kg/m³ and the velocity ``(nz, ny, nx, 3)`` in m/s.
    fields : list of str, optional
        The fields ``fn`` reads (required by :meth:`prepare`); None: every
        field of the volume, none required.

    Examples
    --------
    >>> vol = TimeVolume.from_arrays({"T": np.full((2, 2, 2, 2), 300.0)})
    >>> m = FunctionMapping(lambda f: (f["T"] / 250.0, np.zeros((*f["T"].shape, 3))), ["T"])
    >>> float(m.map(vol, 0)[0].mean())
    1.2
    """

    fn: Callable[[dict[str, Frame]], tuple[Frame, Frame]]
    fields: list[str] | None = None
    name = "function"

    def required_fields(self) -> list[str]:
        """The fields the function reads, as given (none when not given).

        Returns
        -------
        list of str
            A copy of ``fields`` (``[]`` for None).

        Examples
        --------
        >>> FunctionMapping(lambda f: f, ["a", "b"]).required_fields()
        ['a', 'b']
        """
        return list(self.fields or [])

    def map(self, volume: TimeVolume, step: int) -> tuple[Frame, Frame]:
        """``fn`` of the step's frames, checked and as float64.

        NaN/Inf in the result are accepted (as no-data) only where the input
        has no data (``volume.valid`` False, or a non-finite input value).

        Parameters
        ----------
        volume : TimeVolume
            The volume.
        step : int
            Time step.

        Returns
        -------
        rho : ndarray, shape (nz, ny, nx)
            Density, kg/m³.
        velocity : ndarray, shape (nz, ny, nx, 3)
            Particle velocity, m/s.

        Raises
        ------
        DataError
            ``fn`` returned the wrong shapes, or NaN/Inf where the input is
            valid and finite.

        Examples
        --------
        >>> vol = TimeVolume.from_arrays({"a": np.ones((2, 2, 2, 2))})
        >>> FunctionMapping(lambda f: (f["a"], f["a"])).map(vol, 0)
        Traceback (most recent call last):
        ...
        auralize.errors.DataError: mapping function returned shapes (2, 2, 2) and (2, 2, 2); ...
        """
        names = self.fields if self.fields is not None else volume.field_names
        frames = {n: volume.frame(n, step) for n in names}
        rho, v = self.fn(frames)
        rho = np.asarray(rho, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        if rho.shape != volume.shape or v.shape != (*volume.shape, 3):
            raise DataError(
                f"mapping function returned shapes {rho.shape} and {v.shape}; expected "
                f"{volume.shape} and {(*volume.shape, 3)}"
            )
        bad = ~(np.isfinite(rho) & np.isfinite(v).all(axis=-1))
        if bad.any():
            # NaN/Inf are no-data where the input has none (outside the mesh, NaN cells)
            nodata = np.zeros(volume.shape, dtype=bool)
            valid = getattr(volume, "valid", None)
            if valid is not None:
                nodata |= ~np.asarray(valid, dtype=bool)
            for f in frames.values():
                fin = np.isfinite(f)
                nodata |= ~(fin if f.ndim == 3 else fin.all(axis=-1))
            if (bad & ~nodata).any():
                raise DataError(
                    f"mapping function returned NaN/Inf at step {step} at "
                    f"{int((bad & ~nodata).sum())} points whose input is valid and finite"
                )
        return rho, v


PRESETS: dict[str, type[AcousticMapping]] = {
    "paper-density": PaperDensityMapping,
    "identity": IdentityMapping,
    "cfd": CFDMapping,
    "incompressible": IncompressibleMapping,
}


def get_mapping(
    spec: str | AcousticMapping | Callable[..., tuple[Frame, Frame]] | None = None,
    **field_names: str,
) -> AcousticMapping:
    """Return a mapping from a preset name, an instance or a function.

    Parameters
    ----------
    spec : str, AcousticMapping or callable, optional
        Preset name (``paper-density``, ``identity``, ``cfd``,
        ``incompressible``; default ``identity``), a mapping (returned as it
        is) or a function ``fn(frames) -> (rho, velocity)``
        (:class:`FunctionMapping`).
    **field_names
        Field-name overrides for the preset, e.g. ``density="rho"`` or
        ``field="log_rho"``; None values are left out.

    Returns
    -------
    AcousticMapping

    Raises
    ------
    ParameterError
        An unknown preset, or an override the preset does not take.

    Examples
    --------
    >>> get_mapping("identity", density="rho").density
    'rho'
    """
    if spec is None:
        spec = "identity"
    if isinstance(spec, AcousticMapping):
        return spec
    if callable(spec):
        return FunctionMapping(spec)
    try:
        cls = PRESETS[spec]
    except KeyError:
        raise ParameterError(
            f"unknown mapping {spec!r}; choose one of {sorted(PRESETS)} or pass a function"
        ) from None
    try:
        return cls(**{k: v for k, v in field_names.items() if v is not None})
    except TypeError as exc:
        raise ParameterError(f"mapping {spec!r}: {exc}") from None


def _in_slabs(fn: Callable[[slice], None], x: Frame) -> bool:
    """:func:`auralize.sources.detection.in_slabs`: ``fn`` over slabs of ``x`` on the
    detection's threads, or False when ``x`` is small (nothing called)."""
    from auralize.sources.detection import in_slabs

    return in_slabs(fn, x)


def _slabwise(fn: Callable[[Frame], Frame], x: Frame, out: Frame | None = None) -> Frame:
    """``fn(x)`` of an elementwise ``fn`` (into ``out``, which may be ``x``, when given), for
    a large ``x`` in slabs along its first axis on the detection's threads (each value
    is computed alone, so the same numbers)."""
    if x.ndim == 0 or x.shape[0] < 2:
        if out is None:
            return fn(x)
        out[...] = fn(x)
        return out
    dest = np.empty_like(fn(x[:1]), shape=x.shape) if out is None else out

    def piece(sl: slice) -> None:
        dest[sl] = fn(x[sl])

    if not _in_slabs(piece, x):
        dest[...] = fn(x)
    return dest


def _pow10(x: Frame, extremes: Frame | None = None, out: Frame | None = None) -> Frame | None:
    """``np.power(10.0, x)`` (into ``out`` when its shape and dtype are the result's), None if
    some ``|x|`` is above 300 (NaN ignored: no log10 density), and with ``extremes (2,)``
    its smallest and largest values, NaN ignored (``np.nanmin``, ``np.nanmax``, from
    ±inf).  A large frame in slabs along its first axis on the detection's threads
    (numpy releases the GIL; each value is computed alone, so the slabs give the same
    numbers)."""
    like = np.power(10.0, x.reshape(-1)[:1])
    if out is None or out.shape != x.shape or out.dtype != like.dtype:
        out = np.empty_like(like, shape=x.shape)
    rows = max(1, x.shape[0]) if x.ndim else 1
    too_big = [False] * rows
    tops = np.full((rows, 2), [np.inf, -np.inf])

    def piece(sl: slice) -> None:
        xs, rs = (x[sl], out[sl]) if x.ndim else (x, out)
        # max |x| > 300, without |x| made
        if (
            np.fmax.reduce(xs, axis=None, initial=-np.inf) > 300
            or np.fmin.reduce(xs, axis=None, initial=np.inf) < -300
        ):
            too_big[sl.start] = True
            return
        np.power(10.0, xs, out=rs)
        if extremes is not None:
            tops[sl.start] = (
                np.fmin.reduce(rs, axis=None, initial=np.inf),
                np.fmax.reduce(rs, axis=None, initial=-np.inf),
            )

    if not _in_slabs(piece, x):
        piece(slice(0, rows))
    if any(too_big):
        return None
    if extremes is not None:
        extremes[0], extremes[1] = tops[:, 0].min(), tops[:, 1].max()
    return out


def _gradient_max(f: Frame, volume: TimeVolume, out: Frame) -> float:
    """The gradient of ``f`` on the uniform grid of ``volume`` (scale 1) into ``out
    (nz, ny, nx, 3)``, and its :func:`_gradient_absmax`."""
    from auralize.sources.detection import gradient_max

    return gradient_max(f, volume.spacing, out)


def _gradient_absmax(f: Frame, volume: TimeVolume) -> float:
    """``np.nanmax(np.abs(np.gradient(f)), initial=0.0)`` over the axes of 2 points or more
    (on a curvilinear grid, of its metric gradient)."""
    from auralize.sources.detection import gradient_absmax

    if volume.metric is not None:
        return float(np.nanmax(np.abs(volume.metric.gradient(f)), initial=0.0))
    return gradient_absmax(f, volume.spacing)


def _check_scalar(volume: TimeVolume, name: str, arr: Frame) -> None:
    if arr.shape != volume.shape:
        raise DataError(
            f"{volume.source}: field {name!r} must be scalar {volume.shape}, got {arr.shape}"
        )


def _check_vector(volume: TimeVolume, name: str, arr: Frame) -> None:
    if arr.shape != (*volume.shape, 3):
        raise DataError(
            f"{volume.source}: field {name!r} must be a 3-vector {(*volume.shape, 3)}, "
            f"got {arr.shape}"
        )
