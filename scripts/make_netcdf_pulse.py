"""Write ``auralize/data/netcdf-pulse/pulse.nc``: a small CF-1.8 netCDF classic file.

A pulsating Gaussian density blob (the acoustic monopole of paper 003 §4,
Eq. 6 form: ρ = ρ0 + A sin(2π f t) g(r)) with its linearised mass-conserving
radial velocity, on a 24 × 20 × 16 grid over 12 steps, written the way a
climate/ocean model writes netCDF:

- ``time`` in ``"milliseconds since 2001-01-01 00:00:00"`` (1 ms steps),
- ``density`` packed as int16 with ``scale_factor``/``add_offset``,
- ``u``, ``v``, ``w`` float32 with ``_FillValue`` over a "land" corner
  (x < 0.02 m and y < 0.02 m), which readers must treat as no-data,
- coordinate variables ``x``, ``y``, ``z`` in metres, ``y`` stored
  decreasing (north to south) as many gridded products do.

Run from the repository root: ``python scripts/make_netcdf_pulse.py``.
The output is deterministic (no randomness).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.io import netcdf_file

OUT = Path(__file__).resolve().parent.parent / "auralize" / "data" / "netcdf-pulse" / "pulse.nc"


def main() -> None:
    nx, ny, nz, nt = 20, 16, 12, 10
    h = 0.005  # m
    x = np.arange(nx) * h
    y = np.arange(ny)[::-1] * h  # stored decreasing
    z = np.arange(nz) * h
    t_ms = np.arange(nt, dtype=np.float64)  # 1 ms steps
    f_hz, amp, rho0, sigma = 250.0, 0.01, 1.2, 0.015
    c = np.array([x.mean(), (ny - 1) * h / 2, z.mean()])
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    r2 = (xx - c[0]) ** 2 + (yy - c[1]) ** 2 + (zz - c[2]) ** 2
    g = np.exp(-r2 / (2 * sigma**2))
    t = t_ms * 1e-3
    rho = rho0 + amp * np.sin(2 * np.pi * f_hz * t)[:, None, None, None] * g
    # Continuity, linearised: ∂ρ/∂t = -ρ0 ∇·v with v radial: v = -(σ²/ρ0) ∂A/∂t ∇g / g · g
    dadt = amp * 2 * np.pi * f_hz * np.cos(2 * np.pi * f_hz * t)
    vel = [
        (dadt[:, None, None, None] * sigma**2 / rho0) * g * (comp / sigma**2)
        for comp in (xx - c[0], yy - c[1], zz - c[2])
    ]
    land = (xx < 0.02) & (yy < 0.02)
    fill = np.float32(-9999.0)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    tmp = OUT.with_suffix(".tmp")
    with netcdf_file(tmp, "w", version=2) as f:
        f.Conventions = "CF-1.8"
        f.title = "Pulsating Gaussian density blob (acoustic monopole), auralize test case"
        f.source = "scripts/make_netcdf_pulse.py"
        for name, size in (("time", None), ("z", nz), ("y", ny), ("x", nx)):
            f.createDimension(name, size)
        tv = f.createVariable("time", "f8", ("time",))
        tv.units = "milliseconds since 2001-01-01 00:00:00"
        tv.standard_name = "time"
        tv.axis = "T"
        tv[:] = t_ms
        for name, vals in (("x", x), ("y", y), ("z", z)):
            cv = f.createVariable(name, "f8", (name,))
            cv.units = "m"
            cv.axis = name.upper()
            cv[:] = vals
        scale = (rho.max() - rho.min()) / 60000.0
        offset = (rho.max() + rho.min()) / 2
        dv = f.createVariable("density", "i2", ("time", "z", "y", "x"))
        dv.units = "kg m-3"
        dv.long_name = "air density"
        dv.scale_factor = np.float64(scale)
        dv.add_offset = np.float64(offset)
        dv[:] = np.round((rho - offset) / scale).astype(np.int16)
        for name, comp, std in zip(
            ("u", "v", "w"),
            vel,
            ("eastward_velocity", "northward_velocity", "upward_velocity"),
            strict=True,
        ):
            vv = f.createVariable(name, "f4", ("time", "z", "y", "x"))
            vv.units = "m s-1"
            vv.standard_name = std
            vv._FillValue = fill
            vv[:] = np.where(land[None], fill, comp).astype(np.float32)
    tmp.replace(OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
