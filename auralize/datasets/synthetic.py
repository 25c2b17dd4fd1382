"""Built-in datasets, generated deterministically (nothing large is shipped).

``explosion``
    Paper 003's case (§1, §4.2): an SPH-like burst of particles from the
    centre of a 64³ box (1 m spacing, frames at 30 Hz), deposited on the grid
    with a smoothing kernel, giving ``log10_density`` and the mass-weighted
    ``velocity``.  A few minor secondary bursts add local radiation.
``monopole``
    A compact pulsating density blob ρ = ρ0 + A(t) g(x) with a Gaussian g and
    a tone A(t), no velocity; :func:`monopole_pressure` gives its exact
    retarded-potential pressure (paper 003 Eq. 6).
``spinning``
    A compact spinning quadrupole: an elliptic Gaussian vortex turning at a
    steady rate, constant density, divergence-free velocity (Lighthill's
    classic compact source); :func:`lighthill_far_field` gives its compact
    far field from the same arrays.  ``kL`` sets its compactness,
    ``freeze_after`` stops it turning.

Every generator takes ``size``, ``steps`` and ``seed`` and returns a lazily
evaluated :class:`~auralize.volume.TimeVolume`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from auralize.constants import C0
from auralize.errors import ParameterError
from auralize.volume import CallableFrames, TimeVolume

# --------------------------------------------------------------------- monopole


@dataclass(frozen=True)
class MonopoleParams:
    """Parameters of the ``monopole`` dataset (SI units)."""

    size: int = 32
    steps: int = 300
    spacing: float = 0.25
    rate_hz: float = 3000.0  # volume frames per second
    frequency: float = 150.0
    amplitude: float = 0.01  # kg/m³ peak density excess at the centre
    sigma: float = 0.3  # m, Gaussian radius
    rho0: float = 1.2
    ramp_periods: float = 2.0

    @property
    def center(self) -> NDArray[np.float64]:
        return np.full(3, 0.5 * (self.size - 1) * self.spacing)

    @property
    def blob_volume(self) -> float:
        """∫ g dV = (2π σ²)^{3/2} (m³)."""
        return float((2 * np.pi * self.sigma**2) ** 1.5)

    def envelope(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Raised-cosine fade in/out over ``ramp_periods`` periods."""
        T = (self.steps - 1) / self.rate_hz
        r = self.ramp_periods / self.frequency
        w = np.ones_like(t)
        a = t < r
        w[a] = 0.5 - 0.5 * np.cos(np.pi * np.clip(t[a], 0, None) / r)
        b = t > T - r
        w[b] = 0.5 - 0.5 * np.cos(np.pi * np.clip(T - t[b], 0, None) / r)
        return np.where((t < 0) | (t > T), 0.0, w)

    def signal(self, t: NDArray[np.floating] | float) -> NDArray[np.float64]:
        """A(t): density excess at the blob centre (kg/m³)."""
        tt = np.asarray(t, dtype=np.float64)
        return np.asarray(
            self.amplitude * np.sin(2 * np.pi * self.frequency * tt) * self.envelope(tt)
        )


def make_monopole(*, size: int = 32, steps: int = 300, seed: int = 0, **kw: float) -> TimeVolume:
    """The ``monopole`` dataset (``seed`` is accepted for a uniform interface; it is exact)."""
    p = MonopoleParams(size=check_size(size), steps=check_steps(steps), **kw)
    x = np.arange(p.size) * p.spacing - p.center[0]
    r2 = x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2
    g = np.exp(-r2 / (2 * p.sigma**2))
    times = np.arange(p.steps) / p.rate_hz
    amp = p.signal(times)

    def density(n: int) -> NDArray[np.float64]:
        return p.rho0 + amp[n] * g

    vol = TimeVolume(
        origin=np.zeros(3),
        spacing=np.full(3, p.spacing),
        dims=(p.size,) * 3,
        times=times,
        fields={"density": CallableFrames(density, p.steps, (p.size,) * 3)},
        source="dataset:monopole",
    )
    vol.attrs = {"dataset": "monopole", **asdict(p), "seed": seed}
    return vol


def monopole_pressure(
    p: MonopoleParams,
    point: NDArray[np.floating],
    t: NDArray[np.floating],
    *,
    c0: float = C0,
    n_quad: int = 4000,
) -> NDArray[np.float64]:
    """Exact pressure of the continuous blob at a point, for times ``t`` (paper 003 Eq. 6).

    The source Ψ = ∂ρ/∂t = A'(t) g(|y|) is spherically symmetric, so with
    r = |x - x_c| the retarded potential reduces to one radial integral::

        p(r, t) = c0 / (2 r) ∫₀^∞ s g(s) [A(t - |r - s|/c0) - A(t - (r + s)/c0)] ds

    (integrating A' over each spherical shell).  Evaluated by the trapezoid rule.
    """
    r = float(np.linalg.norm(np.asarray(point, dtype=np.float64) - p.center))
    if r <= 0:
        raise ParameterError("the analytic pressure is evaluated away from the centre (r > 0)")
    s = np.linspace(0.0, 8 * p.sigma, n_quad)
    g = np.exp(-(s**2) / (2 * p.sigma**2))
    tt = np.asarray(t, dtype=np.float64)[:, None]
    integrand = s * g * (p.signal(tt - np.abs(r - s) / c0) - p.signal(tt - (r + s) / c0))
    return np.asarray(c0 / (2 * r) * np.trapezoid(integrand, s, axis=1))


# -------------------------------------------------------------------- explosion


@dataclass(frozen=True)
class ExplosionParams:
    size: int = 64
    steps: int = 30
    seed: int = 0
    particles: int = 160_000
    rate_hz: float = 30.0
    spacing: float = 1.0
    core_fraction: float = 0.3  # share of particles in the exploding core
    speed: float = 24.0  # m/s, median ejecta speed (64-point box; scaled with the box)
    shock_radius: float = 0.42  # blast-wave radius at the last step, fraction of the box
    bursts: int = 4  # minor secondary explosions
    turbulence: float = 1.5  # m/s, random particle velocities
    smoothing: float = 1.0  # SPH kernel width in voxels
    background: float = 1e-2  # background density (linear units)


def make_explosion(*, size: int = 64, steps: int = 30, seed: int = 0, **kw: Any) -> TimeVolume:
    """The ``explosion`` dataset: log10 density and velocity of an SPH-like burst.

    Paper 003 §1/§4.2: matter at the centre explodes into a clumpy ambient
    medium.  Core particles leave the centre with log-normal speeds and
    decelerate by drag; ambient particles (drawn from a log-normal random
    density field, i.e. clumps) are swept outwards by a Sedov–Taylor blast
    wave, R(t) ∝ t^{2/5}, with the post-shock gas velocity 3/4 Ṙ r/R; a few
    minor bursts go off later at random places; every particle also carries a
    small random velocity.  Each frame deposits particle mass and momentum
    with cloud-in-cell weights and a Gaussian smoothing kernel (the SPH
    kernel's role).  Frames at 30 Hz (the paper's data had no physical times).
    """
    p = ExplosionParams(size=check_size(size), steps=check_steps(steps), seed=int(seed), **kw)
    rng = np.random.default_rng(p.seed)
    n = p.size
    L = (n - 1) * p.spacing
    centre = np.full(3, 0.5 * L)
    scale = L / 63.0
    npart = max(int(p.particles * min((n / 64) ** 3, 1.0)), 4000)
    n_core = int(npart * p.core_fraction)
    n_amb = npart - n_core
    # ambient clumps: log-normal random field sampled by voxel
    field = ndimage.gaussian_filter(rng.normal(size=(n, n, n)), 2.5, mode="wrap")
    prob = np.exp(1.5 * field / field.std()).reshape(-1)
    vox = rng.choice(n**3, size=n_amb, p=prob / prob.sum())
    kz, ky, kx = np.unravel_index(vox, (n, n, n))
    amb = (np.stack([kx, ky, kz], 1) + rng.uniform(-0.5, 0.5, (n_amb, 3))) * p.spacing
    # core + secondary bursts
    group = np.zeros(n_core, dtype=np.int64)
    n_sec = n_core // 3 if p.bursts > 0 else 0
    group[n_core - n_sec :] = 1 + rng.integers(0, max(p.bursts, 1), n_sec)
    t_end = (p.steps - 1) / p.rate_hz
    b_t0 = np.concatenate([[0.0], rng.uniform(0.2, 0.6, p.bursts) * t_end])
    b_pos = np.concatenate([centre[None], centre + rng.uniform(-0.3, 0.3, (p.bursts, 3)) * L])
    b_speed = np.concatenate([[p.speed], rng.uniform(0.3, 0.5, p.bursts) * p.speed]) * scale
    dirs = rng.normal(size=(n_core, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    cspeed = b_speed[group] * rng.lognormal(0.0, 0.35, n_core)
    core0 = b_pos[group] + rng.normal(0.0, 2.0 * scale, (n_core, 3))
    pos = np.concatenate([core0, amb])
    mass = np.concatenate([np.full(n_core, 0.5), np.ones(n_amb)])
    jitter = rng.normal(size=(npart, 3)) * p.turbulence * scale
    drag = 1.5  # 1/s
    R1 = p.shock_radius * L
    times = np.arange(p.steps) / p.rate_hz
    sub = 8
    dt = 1.0 / (p.rate_hz * sub)
    P = np.empty((p.steps, npart, 3), dtype=np.float32)
    V = np.empty((p.steps, npart, 3), dtype=np.float32)

    def velocity(x: NDArray[np.float64], t: float) -> NDArray[np.float64]:
        v = jitter.copy()
        age = t - b_t0[group]
        live = age >= 0
        v[:n_core] += np.where(
            live[:, None], dirs * (cspeed * np.exp(-drag * np.clip(age, 0, None)))[:, None], 0
        )
        ts = max(t, 0.5 * dt)
        R = R1 * (ts / max(t_end, dt)) ** 0.4
        Rdot = 0.4 * R / ts
        d = x[n_core:] - centre
        r = np.linalg.norm(d, axis=1) + 1e-12
        inside = r < R
        v[n_core:] += np.where(inside[:, None], (0.75 * Rdot * r / R / r)[:, None] * d, 0)
        return v

    x = pos.copy()
    for k in range(p.steps):
        t = float(times[k])
        P[k], V[k] = x, velocity(x, t)
        if k + 1 < p.steps:
            for j in range(sub):
                x = x + dt * velocity(x, t + j * dt)

    def deposit(k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        g = P[k].astype(np.float64) / p.spacing
        base = np.floor(g).astype(np.int64)
        frac = g - base
        rho = np.zeros(n**3)
        mom = np.zeros((3, n**3))
        vel = V[k].astype(np.float64)
        for corner in range(8):
            o = ((corner >> 0) & 1, (corner >> 1) & 1, (corner >> 2) & 1)
            ix, iy, iz = base[:, 0] + o[0], base[:, 1] + o[1], base[:, 2] + o[2]
            w = (
                (frac[:, 0] if o[0] else 1 - frac[:, 0])
                * (frac[:, 1] if o[1] else 1 - frac[:, 1])
                * (frac[:, 2] if o[2] else 1 - frac[:, 2])
                * mass
            )
            ok = (ix >= 0) & (ix < n) & (iy >= 0) & (iy < n) & (iz >= 0) & (iz < n)
            flat = (iz[ok] * n + iy[ok]) * n + ix[ok]
            wk = w[ok]
            rho += np.bincount(flat, wk, minlength=n**3)
            for c in range(3):
                mom[c] += np.bincount(flat, wk * vel[ok, c], minlength=n**3)
        rho3 = ndimage.gaussian_filter(rho.reshape(n, n, n), p.smoothing, mode="constant")
        mom3 = np.stack(
            [
                ndimage.gaussian_filter(mom[c].reshape(n, n, n), p.smoothing, mode="constant")
                for c in range(3)
            ],
            -1,
        )
        norm = n**3 / npart  # mean particle density -> 1
        rho3 = rho3 * norm + p.background
        return rho3, mom3 * norm / rho3[..., None]

    cache: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

    def frame(k: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if k not in cache:
            cache.clear()
            cache[k] = deposit(k)
        return cache[k]

    shape = (n, n, n)
    vol = TimeVolume(
        origin=np.zeros(3),
        spacing=np.full(3, p.spacing),
        dims=(n, n, n),
        times=times,
        fields={
            "log10_density": CallableFrames(lambda k: np.log10(frame(k)[0]), p.steps, shape),
            "velocity": CallableFrames(lambda k: frame(k)[1], p.steps, (*shape, 3)),
        },
        source="dataset:explosion",
    )
    vol.attrs = {"dataset": "explosion", **asdict(p)}
    return vol


# -------------------------------------------------------------------- spinning


@dataclass(frozen=True)
class SpinningParams:
    """Parameters of the ``spinning`` dataset (SI units).

    The stream function ψ = U σ exp(−(x'²/a² + y'²/b²)/2) exp(−z²/2σ²), with
    (x', y') the axes turned by Ω t, a = σ and b = σ/2, gives the velocity
    v = (∂ψ/∂y, −∂ψ/∂x, 0), divergence-free; the density is ρ0 everywhere.
    The stress ρ0 v_i v_j turns with the vortex, so its integral turns at
    2Ω: the sound's frequency is ``frequency`` = 2Ω/2π.  The source size is
    L = 2σ, and ``kL`` = 2π f L / c0 sets it (the grid spacing is σ/3, the
    frames come ``per_period`` to a period of the sound).
    """

    size: int = 32
    steps: int = 97
    kL: float = 0.4
    frequency: float = 180.0
    speed: float = 1.0  # m/s, the vortex's peak velocity scale U
    rho0: float = 1.2
    per_period: int = 16
    #: the vortex stops turning after this many periods of the sound (None: never)
    freeze_after: float | None = None

    @property
    def length(self) -> float:
        """L = 2σ (m)."""
        return float(self.kL * C0 / (2 * np.pi * self.frequency))

    @property
    def sigma(self) -> float:
        return 0.5 * self.length

    @property
    def spacing(self) -> float:
        return self.sigma / 3.0

    @property
    def dt(self) -> float:
        return 1.0 / (self.frequency * self.per_period)

    def angle(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """The vortex's angle Ω t (held from ``freeze_after`` periods on)."""
        om = np.pi * self.frequency  # Ω: the stress turns at 2Ω = 2π f
        tt = np.asarray(t, dtype=np.float64)
        if self.freeze_after is not None:
            tt = np.minimum(tt, self.freeze_after / self.frequency)
        return om * tt


def make_spinning(*, size: int = 32, steps: int = 97, seed: int = 0, **kw: Any) -> TimeVolume:
    """The ``spinning`` dataset (see :class:`SpinningParams`; ``seed`` is accepted for a
    uniform interface: it is exact)."""
    p = SpinningParams(size=check_size(size), steps=check_steps(steps), **kw)
    n, h, s = p.size, p.spacing, p.sigma
    x = (np.arange(n) - 0.5 * (n - 1)) * h
    Z, Y, X = np.meshgrid(x, x, x, indexing="ij")
    gz = np.exp(-(Z**2) / (2 * s**2))
    a, b = s, 0.5 * s
    times = np.arange(p.steps, dtype=np.float64) * p.dt
    ang = p.angle(times)

    def velocity(k: int) -> NDArray[np.float64]:
        c, sn = np.cos(ang[k]), np.sin(ang[k])
        xp, yp = c * X + sn * Y, -sn * X + c * Y
        e = np.exp(-(xp**2 / a**2 + yp**2 / b**2) / 2) * gz * p.speed * s
        px = e * (-xp / a**2 * c + yp / b**2 * sn)
        py = e * (-xp / a**2 * sn - yp / b**2 * c)
        return np.stack([py, -px, np.zeros_like(X)], -1)

    shape = (n, n, n)
    vol = TimeVolume(
        origin=np.full(3, x[0]),
        spacing=np.full(3, h),
        dims=shape,
        times=times,
        fields={
            "density": CallableFrames(lambda k: np.full(shape, p.rho0), p.steps, shape),
            "velocity": CallableFrames(velocity, p.steps, (*shape, 3)),
        },
        source="dataset:spinning",
    )
    vol.attrs = {"dataset": "spinning", **asdict(p), "seed": seed}
    return vol


def lighthill_far_field(
    volume: TimeVolume, direction: NDArray[np.floating], distance: float, *, c0: float = C0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lighthill's compact far field of a volume's stress, from its own arrays.

    p(r, t) = x̂_i x̂_j / (4π c0² r) ∂²/∂t² ∫ T_ij(y, t − r/c0) dV with T_ij =
    ρ v_i v_j (the trapezoid rule over the grid; the second derivative by
    Fourier differentiation of the series, which must hold whole periods),
    at ``distance`` along ``direction`` from the grid's centre.  Returns the
    emission times ``(T,)`` (the data's: the pressure arrives r/c0 later)
    and the pressure ``(T,)`` in Pa.
    """
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    w = np.array(
        [d[0] ** 2, d[1] ** 2, d[2] ** 2, 2 * d[0] * d[1], 2 * d[0] * d[2], 2 * d[1] * d[2]]
    )
    dV = float(np.prod(volume.spacing))
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
    moment = np.zeros(volume.n_steps)  # x̂_i x̂_j ∫ T_ij dV
    for k in range(volume.n_steps):
        rho = volume.frame("density", k)
        v = volume.frame("velocity", k)
        moment[k] = dV * sum(
            wi * float(np.sum(rho * v[..., i] * v[..., j]))
            for wi, (i, j) in zip(w, pairs, strict=True)
        )
    t = np.asarray(volume.times, dtype=np.float64)
    T = t.size - 1  # the last step repeats the first one period later: drop it
    f = np.fft.rfftfreq(T, t[1] - t[0])
    d2 = np.fft.irfft(np.fft.rfft(moment[:T]) * (2j * np.pi * f) ** 2, T)
    return t[:T], d2 / (4 * np.pi * c0**2 * distance)


# -------------------------------------------------------------- moving pulse


@dataclass(frozen=True)
class MovingPulseParams:
    """A pulsating Gaussian density blob ρ = ρ0 + A sin(2π f t) g(x − U t) moving
    along +x at ``mach`` × c0 through the grid (no velocity field: heard as
    ∂ρ/∂t).  Heard from far ahead its tone is at f/(1 − M), from behind at
    f/(1 + M): the Doppler shift of a moving source, from the retarded time."""

    nx: int = 121
    nyz: int = 13
    steps: int = 193
    frequency: float = 200.0
    mach: float = 0.3
    amplitude: float = 0.01
    sigma: float = 0.1
    spacing: float = 0.05
    per_period: int = 16
    rho0: float = 1.2

    @property
    def dt(self) -> float:
        return 1.0 / (self.frequency * self.per_period)


def make_moving_pulse(**kw: Any) -> TimeVolume:
    """The moving pulsating blob of :class:`MovingPulseParams` (starts at x = 0.5 m)."""
    p = MovingPulseParams(**kw)
    x = np.arange(p.nx) * p.spacing
    yz = (np.arange(p.nyz) - 0.5 * (p.nyz - 1)) * p.spacing
    Z, Y, X = np.meshgrid(yz, yz, x, indexing="ij")
    times = np.arange(p.steps, dtype=np.float64) * p.dt
    U = p.mach * C0

    def density(k: int) -> NDArray[np.float64]:
        t = times[k]
        g = np.exp(-((X - 0.5 - U * t) ** 2 + Y**2 + Z**2) / (2 * p.sigma**2))
        return p.rho0 + p.amplitude * np.sin(2 * np.pi * p.frequency * t) * g

    shape = (p.nyz, p.nyz, p.nx)
    vol = TimeVolume(
        origin=np.array([0.0, yz[0], yz[0]]),
        spacing=np.full(3, p.spacing),
        dims=(p.nx, p.nyz, p.nyz),
        times=times,
        fields={"density": CallableFrames(density, p.steps, shape)},
        source="moving-pulse",
    )
    vol.attrs = {"dataset": "moving-pulse", **asdict(p)}
    return vol


def check_size(size: int) -> int:
    if not isinstance(size, int | np.integer) or size < 4 or size > 1024:
        raise ParameterError(f"--size must be an integer in 4..1024, got {size!r}")
    return int(size)


def check_steps(steps: int) -> int:
    if not isinstance(steps, int | np.integer) or steps < 2:
        raise ParameterError(f"--steps must be an integer >= 2, got {steps!r}")
    return int(steps)


DATASETS: dict[str, Callable[..., TimeVolume]] = {
    "explosion": make_explosion,
    "monopole": make_monopole,
    "spinning": make_spinning,
}

#: what ``auralize dataset`` and ``auralize render`` use for each built-in dataset
DEFAULT_MAPPING = {"explosion": "paper-density", "monopole": "identity", "spinning": "identity"}


def all_datasets() -> dict[str, Callable[..., TimeVolume]]:
    """Core datasets plus those registered by sound-model plugins.

    A plugin's datasets are the ``datasets`` mapping of its class in the
    entry-point group ``auralize.plugins`` (:attr:`auralize.plugins.SoundModel.datasets`),
    read from the entry points themselves (:func:`auralize.runtime.entrypoints.loaded`,
    shared with the sound-model registry) so that the datasets sit below the
    plugin contract.
    """
    from auralize.runtime.entrypoints import loaded

    out = dict(DATASETS)
    for _, _, obj in loaded("auralize.plugins", "sound-model plugin"):
        extra = getattr(obj, "datasets", None) if isinstance(obj, type) else None
        if isinstance(extra, Mapping):
            out.update(extra)
    return out


def make_dataset(
    name: str, *, size: int | None = None, steps: int | None = None, seed: int = 0
) -> TimeVolume:
    """Generate a built-in dataset by name (sizes default per dataset).

    Sound-model plugins contribute datasets through a ``datasets`` class
    attribute ``{name: factory(size=, steps=, seed=) -> TimeVolume}``.
    """
    available = all_datasets()
    try:
        fn = available[name]
    except KeyError:
        raise ParameterError(
            f"unknown dataset {name!r}; choose one of {sorted(available)}"
        ) from None
    kw: dict[str, int] = {"seed": seed}
    if size is not None:
        kw["size"] = size
    if steps is not None:
        kw["steps"] = steps
    return fn(**kw)
