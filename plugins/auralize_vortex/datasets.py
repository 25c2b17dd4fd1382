"""Built-in dataset ``fire-plume``: a small buoyant fire plume (paper 000 §7, Fig. 5).

The paper's fire runs on 15 × 15 × 20 voxels with a randomly perturbed heat
source temperature.  This generator runs the same stable-fluids solver as the
texture pre-process (:class:`auralize_vortex.fluid.StableFluids`) with

* a burner disc in the middle of the bottom face (radius 0.2·n_x cells)
  blowing at ``burner_speed`` and holding the excess temperature
  ``T_s (1 + 0.3 ξ(t))`` (ξ smooth random, seeded — §7 "randomly perturbed");
* the rest of the bottom face a wall, periodic sides, an outflow top;
* Boussinesq buoyancy ``a_z = g ΔT / T_ambient`` and Newtonian cooling of the
  excess temperature with time constant 0.25 s, vorticity confinement eps0 = 0.3.

After a 1 s spin-up the cell-centred velocity (m/s) and excess temperature (K)
are stored every 1/30 s (the paper's 10–20 fps interactive rate, rounded to
the project's 30 Hz) as a TimeVolume whose points are the cell centres.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from auralize.errors import ParameterError
from auralize.volume import TimeVolume
from auralize_vortex.fluid import OFF_C, StableFluids, smooth_noise

G = 9.81
T_AMBIENT = 293.0


def make_fire_plume(
    *,
    size: int = 15,
    steps: int = 60,
    seed: int = 0,
    spacing: float = 0.04,
    source_temperature: float = 400.0,
    burner_speed: float = 0.5,
    frame_rate: float = 30.0,
    substeps: int = 4,
) -> TimeVolume:
    """Simulate the buoyant plume; ``size`` cells across (n_z = round(4/3 size)), ``steps`` frames.

    Parameters
    ----------
    size : n_x = n_y (paper: 15); n_z = round(4·size/3) (paper: 20).
    steps : stored frames at ``frame_rate`` Hz.
    seed : random seed of the heat-source perturbation.
    spacing : voxel edge in m (0.04 m: a 0.6 × 0.6 × 0.8 m fire).

    Returns
    -------
    TimeVolume with ``velocity (T, nz, ny, nx, 3)`` m/s and ``temperature`` K.

    Examples
    --------
    >>> vol = make_fire_plume(size=6, steps=3)
    >>> vol.dims, vol.field_names
    ((6, 6, 8), ['velocity', 'temperature'])
    """
    if not isinstance(size, int | np.integer) or not 6 <= size <= 128:
        raise ParameterError(f"fire-plume size must be an integer in 6..128, got {size!r}")
    if not isinstance(steps, int | np.integer) or steps < 2:
        raise ParameterError(f"fire-plume steps must be an integer >= 2, got {steps!r}")
    nx = ny = int(size)
    nz = int(round(4 * size / 3))
    h = float(spacing)
    dt = 1.0 / (frame_rate * substeps)
    fl = StableFluids((nz, ny, nx), h=h, dt=dt, eps0=0.3, speed_ref=2.0)
    rng = np.random.default_rng(seed)
    jj, ii = np.meshgrid(np.arange(ny) + 0.5, np.arange(nx) + 0.5, indexing="ij")
    burner = np.hypot(ii - nx / 2, jj - ny / 2) <= max(0.2 * nx, 1.0)
    temp = np.zeros((nz, ny, nx))
    # smooth random perturbation of the source temperature: a few random sinusoids
    freqs = rng.uniform(0.5, 4.0, 5)
    phases = rng.uniform(0, 2 * np.pi, 5)
    inflow = np.where(burner, burner_speed * (1 + 0.1 * smooth_noise(rng, (ny, nx), 1.0)), 0.0)
    cool = math.exp(-dt / 0.25)
    n_spin = int(round(1.0 / dt))
    n_total = n_spin + (int(steps) - 1) * substeps + 1
    vel = np.empty((int(steps), nz, ny, nx, 3))
    tem = np.empty((int(steps), nz, ny, nx))
    for n in range(n_total):
        t = n * dt
        xi = float(np.sum(np.sin(2 * np.pi * freqs * t + phases))) / math.sqrt(2.5)
        ts = source_temperature * max(0.0, 1 + 0.3 * xi)
        fl.w[0] = inflow
        temp = fl.advect(temp, OFF_C) * cool
        temp[0][burner] = ts
        force = np.zeros((nz, ny, nx, 3))
        force[..., 2] = G * temp / T_AMBIENT
        fl.add_cell_force(force)
        fl.step()
        k = n - n_spin
        if k >= 0 and k % substeps == 0:
            vel[k // substeps] = fl.cell_velocity()
            tem[k // substeps] = temp
    times = np.arange(int(steps)) / frame_rate
    vol = TimeVolume.from_arrays(
        {"velocity": vel, "temperature": tem},
        origin=0.5 * h,
        spacing=h,
        times=times,
        source="dataset:fire-plume",
    )
    attrs: dict[str, Any] = {
        "dataset": "fire-plume",
        "size": int(size),
        "steps": int(steps),
        "seed": seed,
        "spacing": h,
        "source_temperature": source_temperature,
        "burner_speed": burner_speed,
        "frame_rate": frame_rate,
        "paper": "000 §7 (fire, 15×15×20 voxels)",
    }
    vol.attrs = attrs
    return vol
