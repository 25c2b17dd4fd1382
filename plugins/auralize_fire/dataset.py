"""The built-in ``fire`` dataset: a small combustion simulation (paper 001 §2.1).

A premixed-style fuel model on a coarse grid, stepped at 360 Hz like the
paper's simulations (§6):

* fuel is injected (with a flickering inflow rate) with an upward velocity
  and above the ignition temperature T_I at a disc on the floor;
* fuel, temperature and velocity are advected semi-Lagrangian (trilinear);
* where f > 0 and T > T_I, Δf = min(f, b Δt) is burnt (§2.1): temperature
  rises by ``heat`` Δf, and a divergence source φ = ``expansion`` Δf/Δt
  models the expanding gases (Eq. 1, ∇·u = φ);
* buoyancy ∝ (T - T_amb)/T_amb, exponential cooling, and a seeded
  synthetic turbulence force (a few travelling solenoidal modes);
* the pressure projection enforces ∇·u = φ with an FFT Poisson solve
  (periodic box; the plume is faded out near the top so it does not wrap).

Fields: ``burn`` (fuel consumption rate Δf/Δt, 1/s — the Houdini "burn"
field of §3.2), ``temperature`` (K) and ``velocity`` (m/s).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from auralize.errors import ParameterError
from auralize.volume import TimeVolume


@dataclass(frozen=True)
class FireParams:
    size: int = 32
    steps: int = 90
    seed: int = 0
    rate_hz: float = 360.0  # simulation steps per second (paper §6)
    width: float = 0.5  # m, box edge
    t_amb: float = 300.0  # K
    t_ignite: float = 600.0  # K, ignition temperature T_I
    t_source: float = 900.0  # K, injected gas
    burn_rate: float = 6.0  # b: fuel fraction burnt per second
    heat: float = 1500.0  # K per unit fuel burnt
    expansion: float = 1.0  # φ per unit burn rate
    buoyancy: float = 6.0  # m/s² per unit (T - T_amb)/T_amb
    cooling: float = 8.0  # 1/s
    inflow: float = 1.2  # m/s upward injection speed
    flicker_hz: float = 9.0  # inflow modulation (puffing)
    turbulence: float = 4.0  # m/s² synthetic turbulence amplitude


def _check(size: int, steps: int) -> None:
    if not isinstance(size, int | np.integer) or not 8 <= size <= 256:
        raise ParameterError(f"fire dataset size must be an integer in 8..256, got {size!r}")
    if not isinstance(steps, int | np.integer) or steps < 2:
        raise ParameterError(f"fire dataset steps must be an integer >= 2, got {steps!r}")


def simulate_fire(
    p: FireParams,
) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float32]]:
    """Run the simulation; returns burn (T, n, n, n), temperature, velocity (T, n, n, n, 3)."""
    n = p.size
    h = p.width / (n - 1)
    dt = 1.0 / p.rate_hz
    rng = np.random.default_rng(p.seed)
    ax = np.arange(n) * h - 0.5 * p.width
    Z, Y, X = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    r_src = np.hypot(ax[None, :, None], ax[None, None, :])
    src = (r_src < 0.12 * p.width) & (Z < 3)
    fade = np.clip((n - 1 - Z) / 4.0, 0.0, 1.0)  # absorb near the top
    fuel = np.zeros((n, n, n))
    temp = np.full((n, n, n), p.t_amb)
    vel = np.zeros((3, n, n, n))  # components x, y, z on (z, y, x)
    k = 2 * np.pi * np.fft.fftfreq(n, d=h)
    kz, ky, kx = np.meshgrid(k, k, k, indexing="ij")
    k2 = kx**2 + ky**2 + kz**2
    k2[0, 0, 0] = 1.0
    # synthetic turbulence: travelling modes u = A (a × k̂) sin(k·x - ωt + ϕ)
    n_modes = 6
    kv = rng.normal(size=(n_modes, 3))
    kv *= (2 * np.pi / (0.15 * p.width)) / np.linalg.norm(kv, axis=1, keepdims=True)
    av = np.cross(rng.normal(size=(n_modes, 3)), kv)
    av /= np.linalg.norm(av, axis=1, keepdims=True)
    om = rng.uniform(5, 20, n_modes) * 2 * np.pi
    ph = rng.uniform(0, 2 * np.pi, n_modes)
    xs = np.stack([ax[X], ax[Y], ax[Z]])
    phase_noise = np.cumsum(rng.normal(0, 0.6, p.steps))
    burn_out = np.zeros((p.steps, n, n, n), np.float32)
    temp_out = np.zeros((p.steps, n, n, n), np.float32)
    vel_out = np.zeros((p.steps, n, n, n, 3), np.float32)
    for s in range(p.steps):
        t = s * dt
        q = 1.0 + 0.5 * np.sin(2 * np.pi * p.flicker_hz * t + phase_noise[s])
        fuel[src] = q
        temp[src] = p.t_source
        vel[2][src] = p.inflow * q
        # semi-Lagrangian advection (back-trace, trilinear)
        coords = np.stack([Z - dt * vel[2] / h, Y - dt * vel[1] / h, X - dt * vel[0] / h])
        fuel = ndimage.map_coordinates(fuel, coords, order=1, mode="nearest")
        temp = ndimage.map_coordinates(temp, coords, order=1, mode="nearest")
        vel = np.stack([ndimage.map_coordinates(v, coords, order=1, mode="nearest") for v in vel])
        # combustion (§2.1)
        lit = (fuel > 0) & (temp > p.t_ignite)
        dfuel = np.where(lit, np.minimum(fuel, p.burn_rate * dt), 0.0)
        fuel -= dfuel
        temp += p.heat * dfuel
        burn = dfuel / dt
        phi = p.expansion * burn
        # forces: buoyancy, cooling, turbulence
        temp = p.t_amb + (temp - p.t_amb) * np.exp(-p.cooling * dt)
        vel[2] += dt * p.buoyancy * (temp - p.t_amb) / p.t_amb
        hot = np.clip((temp - p.t_amb) / (p.t_source - p.t_amb), 0.0, 1.0)
        for m in range(n_modes):
            arg = np.tensordot(kv[m], xs, axes=1) - om[m] * t + ph[m]
            vel += dt * p.turbulence * hot * np.sin(arg) * av[m][:, None, None, None]
        fuel *= fade
        temp = p.t_amb + (temp - p.t_amb) * fade
        vel *= fade
        # projection: ∇·u = φ (spectral, periodic box)
        vh = np.fft.fftn(vel, axes=(1, 2, 3))
        div = 1j * (kx * vh[0] + ky * vh[1] + kz * vh[2]) - np.fft.fftn(phi)
        pres = -div / k2
        pres[0, 0, 0] = 0.0
        vh[0] -= 1j * kx * pres
        vh[1] -= 1j * ky * pres
        vh[2] -= 1j * kz * pres
        vel = np.fft.ifftn(vh, axes=(1, 2, 3)).real
        burn_out[s] = burn
        temp_out[s] = temp
        vel_out[s] = np.moveaxis(vel, 0, -1)
    return burn_out, temp_out, vel_out


def make_fire(*, size: int = 32, steps: int = 90, seed: int = 0, **kw: float) -> TimeVolume:
    """The ``fire`` dataset: burn rate, temperature and velocity of a flickering flame.

    Parameters
    ----------
    size : grid points per axis (box edge 0.5 m).
    steps : simulation steps at 360 Hz (default 90 = 0.25 s).
    seed : turbulence and flicker seed (same seed, same data).

    Returns
    -------
    TimeVolume with ``burn`` (1/s), ``temperature`` (K) and ``velocity`` (m/s).

    Examples
    --------
    >>> vol = make_fire(size=12, steps=4)
    >>> vol.field_names, vol.dims
    (['burn', 'temperature', 'velocity'], (12, 12, 12))
    """
    _check(size, steps)
    p = FireParams(size=int(size), steps=int(steps), seed=int(seed), **kw)
    burn, temp, vel = simulate_fire(p)
    h = p.width / (p.size - 1)
    vol = TimeVolume.from_arrays(
        {"burn": burn, "temperature": temp, "velocity": vel},
        origin=(-0.5 * p.width, -0.5 * p.width, 0.0),
        spacing=h,
        times=np.arange(p.steps) / p.rate_hz,
        source="dataset:fire",
    )
    vol.attrs = {"dataset": "fire", **asdict(p)}
    return vol
