"""Exact linear sound fields stored as volume data: the FW-H verification cases.

Every case is a closed-form solution of the linear acoustic equations in a
medium at rest (ρ0, c0), stored as density ρ0 + p'/c0², velocity u and
pressure p0 + p' on a uniform grid, computed step by step when read — what a
compressible simulation that resolves its acoustics stores.

**Stationary point sources** (:func:`pulse_field`, :func:`pulse_volume`).  A
point source of volume flow ``q(t) = A exp(−(t − tc)²/2σ²)`` at ``xs`` (off
the grid nodes), from its velocity potential:

    monopole   φ = −q(τ)/(4π r),   τ = t − r/c0
               p' = −ρ0 ∂φ/∂t = ρ0 q'(τ)/(4π r)
               u = ∇φ = r̂ [q(τ)/(4π r²) + q'(τ)/(4π r c0)]
    dipole     φ_d = ∂φ/∂z = z h,  h = q/(4π r³) + q'/(4π r² c0)
               p' = −ρ0 (z/r) [q'/(4π r²) + q''/(4π r c0)]
               u = h ẑ + z ∂h/∂r r̂,  ∂h/∂r = −[3q/r⁴ + 3q'/(r³ c0) + q''/(r² c0²)]/4π

The defaults (σ = 0.5 ms: the spectrum peaks at λ = 2π c0 σ ≈ 1.08 m, 21
grid spacings and 21 steps per peak period) are those of
``tests/test_fwh.py`` and ``auralize bench``'s FW-H rows.

**Point sources moving on a circle** (:func:`rotating_field`,
:func:`rotating_volume`).  The monopole of volume flow q(t) moving on the path
y(t) (subsonic) has the potential (the Liénard–Wiechert form, e.g. Dowling &
Ffowcs Williams, *Sound and Sources of Sound*, 1983; on a circle these are
the rotating point sources FW-H codes are verified on)

    φ(x, t) = −q(τ) / (4π R*),   R* = r (1 − M_r) = r − d·v/c0,

with d = x − y(τ), r = |d|, v = ẏ(τ), a = ÿ(τ), M_r = d·v/(r c0) and the
emission time τ the root of t − τ − |x − y(τ)|/c0 = 0 (Newton's method,
vectorised over the points; the slope 1 − M_r never vanishes below Mach 1).
As a function of (τ, x), with ∂τ/∂t = r/R* and ∇τ = −d/(c0 R*),

    ∂φ/∂τ|x = −[q'/R* − q ∂R*/∂τ / R*²]/4π,  ∂R*/∂τ = −d·v/r + v²/c0 − d·a/c0
    ∇φ|τ    = q (d/r − v/c0) / (4π R*²)
    p' = −ρ0 ∂φ/∂τ ∂τ/∂t,   u = ∇φ|τ + ∂φ/∂τ ∇τ.

The moving dipole of axis d̂ is φ_d = d̂·∇φ: with (c0⁻²∂²/∂t² − ∇²)φ =
−q(t) δ(x − y(t)) and the wave operator commuting with d̂·∇, it is the field
of the source −d̂·∇[q δ(x − y(t))].  Its p' and u take one more derivative of
the closed form d̂·u(τ, x) in τ and x, by the complex step (∂F/∂s =
Im F(s + i h)/h, exact to rounding: no difference is taken).  With Ω = 0
both reduce to :func:`pulse_field`.

**Pulsating sphere** (:class:`PulsatingSphere`).  A sphere of radius a whose
surface moves radially with velocity U(t) radiates φ = −f(τ)/r, τ = t −
(r − a)/c0, where u_r(a, t) = U(t) makes f' + (c0/a) f = c0 a U.  For
U = U0 exp(−(t − tc)²/2σ²), with T = t − tc and β = c0/a,

    f(t) = c0 a U0 σ √(π/2) exp(−T²/2σ²) erfcx((βσ² − T)/(σ√2)),

and p' = ρ0 f'(τ)/r, u = r̂ [f(τ)/r² + f'(τ)/(c0 r)] outside the sphere (its
radiation impedance is in f: a point source of the same volume flow 4πa²U
would give ρ0 a² U'(τ)/r instead).  Inside the sphere there is no fluid: the
stored fields are NaN there (no-data, the volume's valid mask).

**The sound of a flow outside it** (:class:`SpinningSound`,
:func:`spinning_volume`).  The ``spinning`` dataset's vortex
(:func:`auralize.datasets.synthetic.make_spinning`: density ρ0, velocity v
divergence-free, the pattern turning at Ω = π f) makes, by Lighthill's
analogy, the pressure

    p(x, t) = ∫ s(y, t − |x − y|/c0) / (4π |x − y|) dV,   s = ∂²(ρ0 v_i v_j)/∂y_i∂y_j,

which for the stream function ψ of the dataset (v = (∂ψ/∂y, −∂ψ/∂x, 0)) is
s = −2ρ0 (ψ_xx ψ_yy − ψ_xy²) = 2ρ0 ψ² (x'²/a² + y'²/b² − 1)/(a² b²) in the
turning axes (x', y').  The pattern turns rigidly, s(y, t) = s⁰(R(−Ωt) y),
so its azimuthal Fourier modes e^{imφ} (m even) sound at mΩ, and outside the
flow the expansion of the free-space Green's function (Jackson, *Classical
Electrodynamics*, 3rd ed., eq. 9.98) gives each mode exactly:

    p(x, t) = 2 Re Σ_{m>0} e^{−imΩt} i k_m Σ_{l≥m} A_lm h_l(k_m r) Y_lm(x̂),
    A_lm = ∫ s⁰(y) j_l(k_m |y|) Y*_lm(ŷ) dV,   k_m = mΩ/c0,

(A_lm by the trapezoid rule on a fine grid: spectrally accurate for the
Gaussian source), and u = 2 Re Σ e^{−imΩt} ∇P_m/(i mΩ ρ0) from the linear
momentum equation.  The steady part (m = 0) is left out: it is no sound, the
volume sum removes the data's steady state too, and outside the flow a
steady pressure gradient would accelerate the fluid without end (the
prescribed rotation needs a force the linear field does not have).  Each
term h_l Y_lm solves the wave equation outside the origin, so a truncated
sum is itself an exact exterior field.  Stored with the flow's own velocity
(:func:`spinning_volume`), these are the data a compressible simulation of
the vortex would hold outside it: FW-H on a surface around the vortex and
the volume (Lighthill) sum of the flow must then agree.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import erfc, erfcx, sph_harm_y, spherical_jn, spherical_yn

from auralize.constants import C0
from auralize.datasets.synthetic import SpinningParams, make_spinning
from auralize.errors import ParameterError
from auralize.volume import CallableFrames, TimeVolume

__all__ = [
    "Orbit",
    "PulsatingSphere",
    "Pulse",
    "SpinningSound",
    "Tone",
    "pulse_field",
    "pulse_volume",
    "retarded_time",
    "rotating_field",
    "rotating_potential",
    "rotating_volume",
    "sphere_volume",
    "spinning_volume",
]

KINDS = ("monopole", "dipole")
#: the fields a volume of this module can store
NAMES = ("density", "velocity", "pressure", "momentum")
#: the complex step of the moving dipole's derivatives (s and m: exact for any tiny step)
STEP = 1e-20

Array = NDArray[np.float64]
# real or complex (the complex step) arrays
Num = NDArray[Any]
Field = Callable[[float, NDArray[np.float64]], tuple[NDArray[np.float64], NDArray[np.float64]]]


class Emission(Protocol):
    """Volume flow q(τ) of a point source and the medium it sounds in."""

    @property
    def c0(self) -> float: ...
    @property
    def rho0(self) -> float: ...
    @property
    def p0(self) -> float: ...

    def q(self, tau: Num) -> tuple[Num, ...]: ...


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

    Examples
    --------
    >>> [round(float(v), 9) + 0.0 for v in Pulse().q(np.array(6e-3))]  # at its centre
    [0.005, 0.0, -20000.0]
    """

    amplitude: float = 5e-3
    sigma: float = 5e-4
    centre: float = 6e-3
    c0: float = 343.0
    rho0: float = 1.2
    p0: float = 101325.0

    def q(self, tau: Num) -> tuple[Num, ...]:
        """``q`` and its first two derivatives at the emission times ``tau`` (real or
        complex)."""
        s = tau - self.centre
        g = self.amplitude * np.exp(-(s**2) / (2 * self.sigma**2))
        return g, -s / self.sigma**2 * g, (s**2 / self.sigma**4 - 1 / self.sigma**2) * g


@dataclass(frozen=True)
class Tone:
    """A steady tone of volume flow ``q(τ) = A sin(2π f τ + ψ)``.

    Attributes
    ----------
    amplitude : float
        A, m³/s.
    frequency : float
        f, Hz.
    phase : float
        ψ, rad.
    c0, rho0, p0 : float
        Speed of sound (m/s), density (kg/m³) and pressure (Pa) at rest.

    Examples
    --------
    >>> [round(float(v), 6) for v in Tone(amplitude=1.0, frequency=0.5).q(np.array(0.0))]
    [0.0, 3.141593, -0.0]
    """

    amplitude: float = 5e-3
    frequency: float = 250.0
    phase: float = 0.0
    c0: float = 343.0
    rho0: float = 1.2
    p0: float = 101325.0

    def q(self, tau: Num) -> tuple[Num, ...]:
        """``q`` and its first two derivatives at the emission times ``tau`` (real or
        complex)."""
        w = 2 * np.pi * self.frequency
        arg = w * tau + self.phase
        s, c = np.sin(arg), np.cos(arg)
        return self.amplitude * s, self.amplitude * w * c, -self.amplitude * w**2 * s


@dataclass(frozen=True)
class Orbit:
    """Uniform circular motion y(τ) = c + R (cos(Ωτ + α), sin(Ωτ + α), 0).

    Attributes
    ----------
    radius : float
        R, m.
    omega : float
        Ω, rad/s (counter-clockwise about +z; 0: at rest).
    centre : (3,) float
        c, m: the circle lies in the plane z = c_z.
    angle : float
        α, rad: the position at τ = 0.

    Examples
    --------
    >>> o = Orbit(radius=0.2, omega=686.0, centre=(0.0, 0.0, 0.0))
    >>> round(o.mach(343.0), 3)
    0.4
    >>> y, v, a = o.kinematics(np.array(0.0))
    >>> np.round(v, 6).tolist(), np.round(a, 3).tolist()
    ([-0.0, 137.2, 0.0], [-94119.2, -0.0, 0.0])
    """

    radius: float = 0.2
    omega: float = 686.0
    centre: tuple[float, float, float] = (0.013, -0.007, 0.011)
    angle: float = 0.0

    def mach(self, c0: float) -> float:
        """The source's Mach number Ω R / c0."""
        return abs(self.omega) * self.radius / c0

    def kinematics(self, tau: Num) -> tuple[Num, ...]:
        """Position, velocity and acceleration ``(..., 3)`` at ``tau`` (real or complex)."""
        ph = self.omega * tau + self.angle
        c, s = np.cos(ph), np.sin(ph)
        z = np.zeros_like(c)
        R, W = self.radius, self.omega
        cz = np.asarray(self.centre, dtype=np.float64)
        y = np.stack([R * c + cz[0], R * s + cz[1], z + cz[2]], axis=-1)
        v = np.stack([-R * W * s, R * W * c, z], axis=-1)
        a = np.stack([-R * W**2 * c, -R * W**2 * s, z], axis=-1)
        return y, v, a


def _medium(em: Emission | None, default: Emission) -> Emission:
    return default if em is None else em


def _kind(kind: str) -> None:
    if kind not in KINDS:
        raise ParameterError(f"kind must be one of {KINDS}, got {kind!r}")


def pulse_field(
    kind: str, xs: ArrayLike, t: ArrayLike, points: ArrayLike, pulse: Pulse | None = None
) -> tuple[Array, Array]:
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
    _kind(kind)
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


# ------------------------------------------------------------------ moving sources


def retarded_time(
    orbit: Orbit, t: ArrayLike, points: ArrayLike, *, c0: float = 343.0, max_iter: int = 50
) -> Array:
    """The emission time τ with t − τ − |x − y(τ)|/c0 = 0, per point (Newton's method).

    Parameters
    ----------
    orbit : Orbit
        The source's path (subsonic: Ω R < c0).
    t : float or array
        Observer times, s (broadcast against the points' leading axes).
    points : (..., 3) float
        Observer positions, m.
    c0 : float
        Speed of sound, m/s.
    max_iter : int
        Newton iterations at most (it converges in a few).

    Returns
    -------
    (...) float
        τ, s.

    Examples
    --------
    >>> o = Orbit(radius=0.2, omega=686.0, centre=(0.0, 0.0, 0.0))
    >>> x = np.array([10.0, 0.0, 0.0])
    >>> tau = retarded_time(o, 0.05, x)
    >>> y, _, _ = o.kinematics(tau)
    >>> bool(abs(0.05 - tau - np.linalg.norm(x - y) / 343.0) < 1e-15)
    True
    """
    if not orbit.mach(c0) < 1:
        raise ParameterError(
            f"the source moves at Mach {orbit.mach(c0):.3g}: the retarded time "
            f"is unique only below Mach 1 (Ω R < c0)"
        )
    x = np.asarray(points, dtype=np.float64)
    tt = np.asarray(t, dtype=np.float64)
    centre = np.asarray(orbit.centre, dtype=np.float64)
    dist = np.linalg.norm(x - centre, axis=-1)
    tau = np.asarray(tt - dist / c0, dtype=np.float64)
    # converged to rounding: steps of a few ulps of the times and delays involved
    scale = float(np.max(np.abs(tt), initial=0.0) + np.max(dist, initial=0.0) / c0)
    tol = 64 * np.finfo(np.float64).eps * max(scale, 1e-300)
    for _ in range(max_iter):
        y, v, _ = orbit.kinematics(tau)
        rv = x - y
        r = np.sqrt(np.sum(rv * rv, axis=-1))
        f = tau + r / c0 - tt
        df = 1.0 - np.sum(rv * v, axis=-1) / (r * c0)
        step = f / df
        tau = tau - step
        if float(np.max(np.abs(step))) <= tol:
            break
    return np.asarray(tau, dtype=np.float64)


def _monopole_tau_x(tau: Num, x: Num, orbit: Orbit, em: Emission) -> tuple[Num, ...]:
    """∂φ/∂τ|x, ∇φ|τ, ∂τ/∂t and ∇τ of the moving monopole at (τ, x) (real or complex)."""
    c0 = em.c0
    y, v, a = orbit.kinematics(tau)
    rv = x - y
    r = np.sqrt(np.sum(rv * rv, axis=-1))
    rv_v = np.sum(rv * v, axis=-1)
    Rs = r - rv_v / c0
    q, q1, _ = em.q(tau)
    Rs_tau = -rv_v / r + np.sum(v * v, axis=-1) / c0 - np.sum(rv * a, axis=-1) / c0
    phi_tau = -(q1 / Rs - q * Rs_tau / Rs**2) / (4 * np.pi)
    phi_x = (q / (4 * np.pi * Rs**2))[..., None] * (rv / r[..., None] - v / c0)
    return phi_tau, phi_x, r / Rs, -rv / (c0 * Rs)[..., None]


def _monopole_u(tau: Num, x: Num, orbit: Orbit, em: Emission) -> Num:
    phi_tau, phi_x, _, grad_tau = _monopole_tau_x(tau, x, orbit, em)
    return phi_x + phi_tau[..., None] * grad_tau


def rotating_potential(
    kind: str,
    orbit: Orbit,
    t: ArrayLike,
    points: ArrayLike,
    emission: Emission | None = None,
    *,
    axis: ArrayLike = (0.0, 0.0, 1.0),
) -> Array:
    """The velocity potential φ (monopole) or φ_d = d·∇φ (dipole) of a source on a circle.

    :func:`rotating_field` is ``p' = −ρ0 ∂φ/∂t`` and ``u = ∇φ`` of it.

    Parameters
    ----------
    kind, orbit, t, points, emission, axis
        As :func:`rotating_field`.

    Returns
    -------
    (...) float
        φ, m³/s per m (m²/s).

    Examples
    --------
    >>> still = Orbit(omega=0.0, centre=(0.0, 0.0, 0.0), radius=0.0)
    >>> phi = rotating_potential("monopole", still, 0.02, np.array([0.0, 0.0, 5.0]), Pulse())
    >>> q, _, _ = Pulse().q(np.array(0.02 - 5.0 / 343.0))
    >>> bool(abs(phi + q / (4 * np.pi * 5.0)) < 1e-15)
    True
    """
    _kind(kind)
    em = _medium(emission, Tone())
    x = np.asarray(points, dtype=np.float64)
    tt = np.broadcast_to(np.asarray(t, dtype=np.float64), x.shape[:-1])
    tau = retarded_time(orbit, tt, x, c0=em.c0)
    if kind == "dipole":
        d = np.asarray(axis, dtype=np.float64)
        return np.asarray(_monopole_u(tau, x, orbit, em) @ (d / np.linalg.norm(d)))
    y, v, _ = orbit.kinematics(tau)
    rv = x - y
    r = np.sqrt(np.sum(rv * rv, axis=-1))
    q, _, _ = em.q(tau)
    return np.asarray(-q / (4 * np.pi * (r - np.sum(rv * v, axis=-1) / em.c0)))


def rotating_field(
    kind: str,
    orbit: Orbit,
    t: ArrayLike,
    points: ArrayLike,
    emission: Emission | None = None,
    *,
    axis: ArrayLike = (0.0, 0.0, 1.0),
) -> tuple[Array, Array]:
    """The exact ``(p', u)`` of a monopole or dipole moving on a circle (module docstring).

    Parameters
    ----------
    kind : {"monopole", "dipole"}
    orbit : Orbit
        The source's path (subsonic).
    t : float or array
        Times, s (broadcast against the points' leading axes).
    points : (..., 3) float
        Where, m (never on the source).
    emission : Pulse or Tone, optional
        The volume flow q(τ) and the medium (default :class:`Tone`).
    axis : (3,) float
        The dipole's axis d (normalised; default z, across the plane of rotation).

    Returns
    -------
    p : (...) float
        Acoustic pressure, Pa.
    u : (..., 3) float
        Particle velocity, m/s.

    Examples
    --------
    >>> still = Orbit(omega=0.0, centre=(0.0, 0.0, 0.0), radius=0.0)
    >>> x = np.array([0.0, 3.0, 4.0])
    >>> p, _ = rotating_field("dipole", still, 0.02, x, Pulse())
    >>> q, _ = pulse_field("dipole", (0, 0, 0), 0.02, x)
    >>> bool(abs(p - q) < 1e-12 * abs(q))
    True
    """
    _kind(kind)
    em = _medium(emission, Tone())
    x = np.asarray(points, dtype=np.float64)
    tt = np.broadcast_to(np.asarray(t, dtype=np.float64), x.shape[:-1])
    tau = retarded_time(orbit, tt, x, c0=em.c0)
    if kind == "monopole":
        phi_tau, phi_x, tau_t, grad_tau = _monopole_tau_x(tau, x, orbit, em)
        p = -em.rho0 * phi_tau * tau_t
        u = phi_x + phi_tau[..., None] * grad_tau
        return np.asarray(p, dtype=np.float64), np.asarray(u, dtype=np.float64)
    d = np.asarray(axis, dtype=np.float64)
    d = d / np.linalg.norm(d)
    # G(τ, x) = d·u_monopole(τ, x); its partial derivatives by the complex step
    g_tau = np.imag(_monopole_u(tau + 1j * STEP, x, orbit, em) @ d) / STEP
    g_x = np.empty(x.shape)
    for k in range(3):
        e = np.zeros(3)
        e[k] = STEP
        g_x[..., k] = np.imag(_monopole_u(tau, x + 1j * e, orbit, em) @ d) / STEP
    _, _, tau_t, grad_tau = _monopole_tau_x(tau, x, orbit, em)
    p = -em.rho0 * g_tau * tau_t
    u = g_x + g_tau[..., None] * grad_tau
    return np.asarray(p, dtype=np.float64), np.asarray(u, dtype=np.float64)


# ------------------------------------------------------------------ pulsating sphere


@dataclass(frozen=True)
class PulsatingSphere:
    """A sphere whose surface moves radially with U(t) = U0 exp(−(t − tc)²/2σ²).

    Attributes
    ----------
    radius : float
        a, m.
    centre : (3,) float
        m.
    velocity : float
        U0, m/s.
    sigma, t_centre : float
        σ and tc, s.
    c0, rho0, p0 : float
        The medium at rest.

    Examples
    --------
    >>> s = PulsatingSphere()
    >>> x = np.array(s.centre) + [0.0, 0.0, s.radius]  # on the surface
    >>> p, u = s.field(np.array([2e-3, 3e-3, 4e-3]), x)
    >>> bool(np.allclose(u[:, 2], s.surface_velocity(np.array([2e-3, 3e-3, 4e-3]))))
    True
    """

    radius: float = 0.15
    centre: tuple[float, float, float] = (0.013, -0.007, 0.011)
    velocity: float = 0.01
    sigma: float = 5e-4
    t_centre: float = 3e-3
    c0: float = 343.0
    rho0: float = 1.2
    p0: float = 101325.0

    def surface_velocity(self, t: ArrayLike) -> Array:
        """U(t), m/s."""
        s = np.asarray(t, dtype=np.float64) - self.t_centre
        return np.asarray(self.velocity * np.exp(-(s**2) / (2 * self.sigma**2)))

    def f(self, tau: ArrayLike) -> tuple[Array, Array]:
        """The outgoing wave's strength f and f' (m³/s, m³/s²) at emission times ``tau``."""
        T = np.asarray(tau, dtype=np.float64) - self.t_centre
        a, sg = self.radius, self.sigma
        beta = self.c0 / a
        z = (beta * sg**2 - T) / (sg * np.sqrt(2.0))
        # exp(−βT + β²σ²/2) erfc(z) = exp(−T²/2σ²) erfcx(z): the scaled form while z ≥ 0
        with np.errstate(over="ignore"):
            F = np.where(
                z >= 0,
                np.exp(-(T**2) / (2 * sg**2)) * erfcx(np.maximum(z, 0.0)),
                np.exp(np.minimum(-beta * T + 0.5 * (beta * sg) ** 2, 0.0))
                * erfc(np.minimum(z, 0.0)),
            )
        f = self.c0 * a * self.velocity * sg * np.sqrt(np.pi / 2) * F
        f1 = self.c0 * a * self.surface_velocity(tau) - beta * f
        return np.asarray(f), np.asarray(f1)

    def field(self, t: ArrayLike, points: ArrayLike) -> tuple[Array, Array]:
        """The exact ``(p', u)`` outside the sphere (NaN inside it).

        Parameters
        ----------
        t : float or array
            Times, s (broadcast against the points' leading axes).
        points : (..., 3) float
            Where, m.

        Returns
        -------
        p : (...) float
            Acoustic pressure, Pa.
        u : (..., 3) float
            Particle velocity, m/s.
        """
        d = np.asarray(points, dtype=np.float64) - np.asarray(self.centre, dtype=np.float64)
        r = np.linalg.norm(d, axis=-1)
        f, f1 = self.f(np.asarray(t, dtype=np.float64) - (r - self.radius) / self.c0)
        out = r < self.radius
        rs = np.where(out, 1.0, r)
        p = np.where(out, np.nan, self.rho0 * f1 / rs)
        ur = np.where(out, np.nan, f / rs**2 + f1 / (self.c0 * rs))
        return p, (ur / rs)[..., None] * d

    def point_source_pressure(self, t: ArrayLike, points: ArrayLike) -> Array:
        """p' = ρ0 a² U'(τ)/r of a point source of the same volume flow 4πa²U (no
        radiation impedance): what the sphere is *not*, for comparison."""
        d = np.asarray(points, dtype=np.float64) - np.asarray(self.centre, dtype=np.float64)
        r = np.linalg.norm(d, axis=-1)
        s = np.asarray(t, dtype=np.float64) - (r - self.radius) / self.c0 - self.t_centre
        du = -s / self.sigma**2 * self.velocity * np.exp(-(s**2) / (2 * self.sigma**2))
        return np.asarray(self.rho0 * self.radius**2 * du / r)


# ------------------------------------------------------------------ volumes


def _grid_volume(
    fn: Field,
    *,
    n: int,
    spacing: float,
    origin: ArrayLike,
    steps: int,
    dt: float,
    names: tuple[str, ...],
    c0: float,
    rho0: float,
    p0: float,
    source: str,
    valid: Callable[[Array], NDArray[np.bool_]] | None = None,
) -> TimeVolume:
    """A TimeVolume of ``fn(t, points) -> (p', u)`` on an ``n³`` grid, step by step."""
    unknown = sorted(set(names) - set(NAMES))
    if unknown:
        raise ParameterError(
            f"unknown field(s) {unknown}: choose density, velocity, pressure, momentum"
        )
    org = np.broadcast_to(np.asarray(origin, dtype=np.float64), (3,)).copy()
    axes = [org[i] + spacing * np.arange(n) for i in range(3)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    pts = np.stack([x, y, z], axis=-1)
    times = np.arange(steps, dtype=np.float64) * float(dt)
    cache: dict[int, tuple[Array, Array]] = {}

    def get(k: int) -> tuple[Array, Array]:
        if k not in cache:
            cache.clear()
            cache[k] = fn(float(times[k]), pts)
        return cache[k]

    shape = (n, n, n)
    makers = {
        "density": (lambda k: rho0 + get(k)[0] / c0**2, shape),
        "velocity": (lambda k: get(k)[1], (*shape, 3)),
        "pressure": (lambda k: p0 + get(k)[0], shape),
        "momentum": (lambda k: (rho0 + get(k)[0] / c0**2)[..., None] * get(k)[1], (*shape, 3)),
    }
    fields = {k: CallableFrames(makers[k][0], steps, makers[k][1]) for k in names}
    mask = None if valid is None else valid(pts)
    return TimeVolume(
        origin=org,
        spacing=np.full(3, spacing),
        dims=shape,
        times=times,
        fields=dict(fields),
        source=source,
        valid=mask,
        check_finite=mask is None,
    )


def pulse_volume(
    kind: str = "monopole",
    xs: ArrayLike = (0.013, -0.007, 0.011),
    *,
    n: int = 41,
    spacing: float = 0.05,
    origin: float = -1.0,
    steps: int = 85,
    dt: float = 1.5e-4,
    names: tuple[str, ...] = ("density", "velocity", "pressure"),
    pulse: Pulse | None = None,
) -> TimeVolume:
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
    _kind(kind)
    pu = pulse or Pulse()
    return _grid_volume(
        lambda t, pts: pulse_field(kind, xs, t, pts, pu),
        n=n,
        spacing=spacing,
        origin=origin,
        steps=steps,
        dt=dt,
        names=names,
        c0=pu.c0,
        rho0=pu.rho0,
        p0=pu.p0,
        source=f"<analytic {kind} pulse>",
    )


def rotating_volume(
    kind: str = "monopole",
    orbit: Orbit | None = None,
    emission: Emission | None = None,
    *,
    axis: ArrayLike = (0.0, 0.0, 1.0),
    n: int = 25,
    spacing: float = 0.05,
    origin: ArrayLike = -0.6,
    steps: int = 100,
    dt: float = 1.5e-4,
    names: tuple[str, ...] = ("density", "velocity", "pressure"),
) -> TimeVolume:
    """The exact field of :func:`rotating_field` on an ``n³`` grid, step by step.

    Parameters
    ----------
    kind : {"monopole", "dipole"}
    orbit : Orbit, optional
        Default :class:`Orbit` (R = 0.2 m, Mach 0.4, about a point off the nodes).
    emission : Pulse or Tone, optional
        Default :class:`Tone` (250 Hz).
    axis : (3,) float
        The dipole's axis.
    n, spacing, origin : int, float, float or (3,) float
        Points per axis, spacing (m), the first point (m).
    steps, dt : int, float
        Time steps and their spacing, s (from 0).
    names : tuple of str
        Fields stored (``density``, ``velocity``, ``pressure``, ``momentum``).

    Returns
    -------
    TimeVolume

    Examples
    --------
    >>> vol = rotating_volume(n=9, spacing=0.15, steps=4)
    >>> vol.dims, vol.n_steps, vol.frame("pressure", 0).shape
    ((9, 9, 9), 4, (9, 9, 9))
    """
    _kind(kind)
    ob = orbit or Orbit()
    em = _medium(emission, Tone())
    return _grid_volume(
        lambda t, pts: rotating_field(kind, ob, t, pts, em, axis=axis),
        n=n,
        spacing=spacing,
        origin=origin,
        steps=steps,
        dt=dt,
        names=names,
        c0=em.c0,
        rho0=em.rho0,
        p0=em.p0,
        source=f"<analytic rotating {kind}>",
    )


def sphere_volume(
    sphere: PulsatingSphere | None = None,
    *,
    n: int = 25,
    spacing: float = 0.05,
    origin: ArrayLike = -0.6,
    steps: int = 60,
    dt: float = 1.5e-4,
    names: tuple[str, ...] = ("density", "velocity", "pressure"),
) -> TimeVolume:
    """The exact field of a :class:`PulsatingSphere` on an ``n³`` grid, step by step;
    the points inside the sphere are no-data (the volume's valid mask, NaN).

    Parameters
    ----------
    sphere : PulsatingSphere, optional
    n, spacing, origin : int, float, float or (3,) float
        Points per axis, spacing (m), the first point (m).
    steps, dt : int, float
        Time steps and their spacing, s (from 0).
    names : tuple of str
        Fields stored (``density``, ``velocity``, ``pressure``, ``momentum``).

    Returns
    -------
    TimeVolume

    Examples
    --------
    >>> vol = sphere_volume(n=9, spacing=0.15, steps=4)
    >>> int((~vol.valid_mask()).sum())  # grid points inside the sphere
    4
    """
    sp = sphere or PulsatingSphere()
    centre = np.asarray(sp.centre, dtype=np.float64)

    def outside(pts: Array) -> NDArray[np.bool_]:
        return np.asarray(np.linalg.norm(pts - centre, axis=-1) >= sp.radius)

    return _grid_volume(
        sp.field,
        n=n,
        spacing=spacing,
        origin=origin,
        steps=steps,
        dt=dt,
        names=names,
        c0=sp.c0,
        rho0=sp.rho0,
        p0=sp.p0,
        source="<analytic pulsating sphere>",
        valid=outside,
    )


# ------------------------------------------------------------------ the sound of a flow


def _spherical(x: Array) -> tuple[Array, Array, Array]:
    r = np.linalg.norm(x, axis=-1)
    theta = np.arccos(np.clip(x[..., 2] / np.where(r > 0, r, 1.0), -1.0, 1.0))
    return r, theta, np.arctan2(x[..., 1], x[..., 0])


class SpinningSound:
    """Lighthill's pressure of the ``spinning`` dataset's flow, outside the flow
    (module docstring).

    Parameters
    ----------
    params : SpinningParams, optional
        The dataset's parameters (:class:`auralize.datasets.synthetic.SpinningParams`).
    c0 : float
        Speed of sound, m/s (the dataset's is :data:`auralize.constants.C0`).
    l_max, m_max : int
        The highest degree l and azimuthal order m kept (m even; the
        coefficients fall by about 10³ per step of 2 in l or m).
    nodes : int
        Quadrature points per axis for A_lm (a grid of ±5 Gaussian radii).

    Attributes
    ----------
    omega : float
        Ω, rad/s: the pattern's turning rate (the sound's frequencies are mΩ/2π).
    coefficients : dict of (l, m) to complex
        A_lm, Pa m (the ``ρ0 v v`` source integrated against j_l Y*_lm).

    Examples
    --------
    >>> snd = SpinningSound(l_max=4, m_max=2, nodes=32)
    >>> p, u = snd.field(np.array([0.0, 1 / 360]), np.array([[1.0, 0.0, 0.0]]))
    >>> p.shape, u.shape, bool(abs(p[0, 0] + p[1, 0]) < 1e-3 * abs(p[0, 0]))  # half a period
    ((2, 1), (2, 1, 3), True)
    """

    def __init__(
        self,
        params: SpinningParams | None = None,
        *,
        c0: float = C0,
        l_max: int = 8,
        m_max: int = 6,
        nodes: int = 48,
    ) -> None:
        self.params = params or SpinningParams()
        self.c0 = float(c0)
        self.rho0 = float(self.params.rho0)
        self.omega = float(np.pi * self.params.frequency)
        if not (2 <= m_max <= l_max):
            raise ParameterError(f"need 2 <= m_max <= l_max, got m_max={m_max}, l_max={l_max}")
        sg = self.params.sigma
        a, b = sg, 0.5 * sg
        axes = [np.linspace(-5 * w, 5 * w, nodes) for w in (a, b, sg)]
        X, Y, Z = np.meshgrid(*axes, indexing="ij")
        dV = float(np.prod([ax[1] - ax[0] for ax in axes]))
        src = self.source(np.stack([X, Y, Z], axis=-1)) * dV
        r, theta, phi = _spherical(np.stack([X, Y, Z], axis=-1))
        self.coefficients: dict[tuple[int, int], complex] = {}
        for m in range(2, m_max + 1, 2):
            k = m * self.omega / self.c0
            for deg in range(m, l_max + 1, 2):  # s⁰ is even in z: odd l - m vanish
                w = spherical_jn(deg, k * r) * np.conj(sph_harm_y(deg, m, theta, phi))
                self.coefficients[(deg, m)] = complex(np.sum(src * w))

    def source(self, points: ArrayLike) -> Array:
        """s⁰ = ∂²(ρ0 v_i v_j)/∂y_i∂y_j at t = 0 (Pa/m²) at ``points (..., 3)``."""
        y = np.asarray(points, dtype=np.float64)
        sg = self.params.sigma
        a, b = sg, 0.5 * sg
        q = y[..., 0] ** 2 / a**2 + y[..., 1] ** 2 / b**2
        psi2 = (self.params.speed * sg) ** 2 * np.exp(-q - y[..., 2] ** 2 / sg**2)
        return np.asarray(2 * self.rho0 * psi2 / (a**2 * b**2) * (q - 1.0))

    def modes(self, points: ArrayLike) -> dict[int, Num]:
        """P_m (complex pressure amplitude of e^{−imΩt}, Pa) at ``points (..., 3)``."""
        r, theta, phi = _spherical(np.asarray(points, dtype=np.float64))
        out: dict[int, Num] = {}
        for (deg, m), A in self.coefficients.items():
            k = m * self.omega / self.c0
            h = spherical_jn(deg, k * r) + 1j * spherical_yn(deg, k * r)
            out[m] = out.get(m, 0) + 1j * k * A * h * sph_harm_y(deg, m, theta, phi)
        return out

    def mode_fields(self, points: ArrayLike) -> dict[int, tuple[Num, Num]]:
        """(P_m, U_m): complex amplitudes of p' and u at ``points (..., 3)``; U_m =
        ∇P_m/(i mΩ ρ0), the gradient by central differences with a step of 10⁻⁵ r
        (truncation and rounding both near 10⁻¹⁰ of it)."""
        x = np.asarray(points, dtype=np.float64)
        step = 1e-5 * np.linalg.norm(x, axis=-1)[..., None]
        base = self.modes(x)
        grads: dict[int, list[Num]] = {m: [] for m in base}
        for k in range(3):
            e = np.zeros(3)
            e[k] = 1.0
            fp, fm = self.modes(x + step * e), self.modes(x - step * e)
            for m in base:
                grads[m].append((fp[m] - fm[m]) / (2 * step[..., 0]))
        return {
            m: (base[m], np.stack(grads[m], axis=-1) / (1j * m * self.omega * self.rho0))
            for m in base
        }

    def field(self, t: ArrayLike, points: ArrayLike) -> tuple[Array, Array]:
        """The exact ``(p', u)`` of the sound outside the flow.

        Parameters
        ----------
        t : (n_t,) float
            Times, s.
        points : (..., 3) float
            Where, m (outside the flow: beyond about 4 Gaussian radii).

        Returns
        -------
        p : (n_t, ...) float
            Acoustic pressure, Pa.
        u : (n_t, ..., 3) float
            Acoustic particle velocity, m/s.
        """
        tt = np.atleast_1d(np.asarray(t, dtype=np.float64))
        fm = self.mode_fields(points)
        x = np.asarray(points, dtype=np.float64)
        p = np.zeros((tt.size, *x.shape[:-1]))
        u = np.zeros((tt.size, *x.shape))
        for m, (P, Um) in fm.items():
            e = np.exp(-1j * m * self.omega * tt).reshape(-1, *([1] * (x.ndim - 1)))
            p += 2 * np.real(e * P)
            u += 2 * np.real(e[..., None] * Um)
        return p, u


def spinning_volume(
    params: SpinningParams | None = None,
    *,
    sound: SpinningSound | None = None,
    inner: float = 4.0,
    flow: bool = True,
    p0: float = 101325.0,
) -> TimeVolume:
    """The ``spinning`` dataset's flow with its sound: what FW-H needs, on the dataset's grid.

    Velocity = the dataset's flow + the acoustic velocity, density ρ0 + p'/c0²,
    pressure p0 + p' (:class:`SpinningSound`), at the dataset's steps; the
    points nearer to the centre than ``inner`` Gaussian radii σ (inside the
    flow, where the exterior field is not the pressure) are no-data (NaN).

    Parameters
    ----------
    params : SpinningParams, optional
        The dataset's parameters.
    sound : SpinningSound, optional
        Its sound (made from ``params`` when not given).
    inner : float
        Radius of the no-data core, in σ.
    flow : bool
        Add the flow's own velocity (True) or store the sound alone.
    p0 : float
        Ambient pressure, Pa.

    Returns
    -------
    TimeVolume

    Examples
    --------
    >>> vol = spinning_volume(sound=SpinningSound(l_max=2, m_max=2, nodes=24))
    >>> vol.dims, vol.field_names, round(vol.valid_ratio, 3)
    ((32, 32, 32), ['density', 'velocity', 'pressure'], 0.78)
    """
    snd = sound or SpinningSound(params)
    pr = snd.params
    if pr.freeze_after is not None:
        raise ParameterError(
            "spinning_volume holds a vortex that keeps turning: freeze_after "
            f"must be None, got {pr.freeze_after!r}"
        )
    data = make_spinning(
        **{
            k: getattr(pr, k)
            for k in (
                "size",
                "steps",
                "kL",
                "frequency",
                "speed",
                "rho0",
                "per_period",
                "freeze_after",
            )
        }
    )
    n = data.dims[0]
    ax = data.origin[0] + data.spacing[0] * np.arange(n)
    Z, Y, X = np.meshgrid(ax, ax, ax, indexing="ij")
    pts = np.stack([X, Y, Z], axis=-1)
    valid = np.linalg.norm(pts, axis=-1) >= inner * pr.sigma
    fm = snd.mode_fields(pts[valid])
    times = data.times
    shape = data.dims
    cache: dict[int, tuple[Array, Array]] = {}

    def get(k: int) -> tuple[Array, Array]:
        if k not in cache:
            cache.clear()
            p = np.full(shape, np.nan)
            u = np.full((*shape, 3), np.nan)
            pv = np.zeros(int(valid.sum()))
            uv = np.zeros((pv.size, 3))
            for m, (P, Um) in fm.items():
                e = np.exp(-1j * m * snd.omega * times[k])
                pv += 2 * np.real(e * P)
                uv += 2 * np.real(e * Um)
            if flow:
                uv += data.frame("velocity", k)[valid]
            p[valid], u[valid] = pv, uv
            cache[k] = (p, u)
        return cache[k]

    T = times.size
    fields = {
        "density": CallableFrames(lambda k: snd.rho0 + get(k)[0] / snd.c0**2, T, shape),
        "velocity": CallableFrames(lambda k: get(k)[1], T, (*shape, 3)),
        "pressure": CallableFrames(lambda k: p0 + get(k)[0], T, shape),
    }
    return TimeVolume(
        origin=data.origin,
        spacing=data.spacing,
        dims=shape,
        times=times,
        fields=dict(fields),
        source="<analytic spinning vortex and its sound>",
        valid=valid,
        check_finite=False,
    )
