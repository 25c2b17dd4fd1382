"""2-D incompressible flow past a cross-section: lattice Boltzmann D2Q9 (paper 004 §5.2).

The paper solves the incompressible Navier–Stokes equations by finite
differences (stable fluids) or finite elements.  We use the lattice
Boltzmann method (D2Q9, BGK collision), which sheds a
Kármán street reliably on a modest grid and recovers incompressible flow at
low Mach number (lattice inflow speed 0.08, Ma ≈ 0.14).

Boundary conditions follow §5.2.2: uniform inflow on one side (x = 0 here;
the paper's y = 0), natural (zero normal gradient) conditions on the lateral
sides, a fixed-pressure outlet with extrapolated non-equilibrium part, and
no slip on the body (half-way bounce-back on a staircase mask).  The flow
starts from rest: the inflow speed ramps up smoothly, with a small seeded
transverse kick that breaks the symmetry so that shedding starts early.

All kernels are numba-compiled loops (``cache=True``): a fused pull-stream +
collide sweep per step and the pressure integral over the body faces.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

EX = np.array([0, 1, 0, -1, 0, 1, -1, -1, 1], dtype=np.int64)
EY = np.array([0, 0, 1, 0, -1, 1, 1, -1, -1], dtype=np.int64)
WT = np.array([4 / 9] + [1 / 9] * 4 + [1 / 36] * 4)
OPP = np.array([0, 3, 4, 1, 2, 7, 8, 5, 6], dtype=np.int64)
CS2 = 1.0 / 3.0


@numba.njit(cache=True, inline="always")
def _feq(
    i: int,
    rho: float,
    ux: float,
    uy: float,
    ex: NDArray[np.int64],
    ey: NDArray[np.int64],
    wt: NDArray[np.float64],
) -> float:
    eu = ex[i] * ux + ey[i] * uy
    return wt[i] * rho * (1.0 + 3.0 * eu + 4.5 * eu * eu - 1.5 * (ux * ux + uy * uy))


@numba.njit(cache=True, inline="always")
def _pull(
    f: NDArray[np.float64],
    solid: NDArray[np.bool_],
    i: int,
    j: int,
    y: int,
    x: int,
    dy: int,
    dx: int,
) -> float:
    """Population i arriving at (y, x) from (y-dy, x-dx); half-way bounce-back off the body."""
    if solid[y - dy, x - dx]:
        return f[j, y, x]
    return f[i, y - dy, x - dx]


@numba.njit(cache=True)
def _sweep(
    f: NDArray[np.float64],
    g: NDArray[np.float64],
    solid: NDArray[np.bool_],
    om: float,
    sponge: NDArray[np.float64],
    u0: float,
) -> None:
    """One pull-stream + BGK-collide sweep of the interior nodes, f -> g (post-collision).

    ``sponge (ny, nx)`` in [0, 1) relaxes the populations further towards the
    free-stream equilibrium (ρ = 1, u = (u0, 0)) near the open boundaries, an
    absorbing layer that keeps the weakly compressible scheme's start-up
    pressure waves from reflecting back onto the body.
    """
    ny, nx = solid.shape
    w0, w1, w2 = 4.0 / 9.0, 1.0 / 9.0, 1.0 / 36.0
    for y in range(1, ny - 1):
        for x in range(1, nx - 1):
            if solid[y, x]:
                continue
            f0 = f[0, y, x]
            f1 = _pull(f, solid, 1, 3, y, x, 0, 1)
            f2 = _pull(f, solid, 2, 4, y, x, 1, 0)
            f3 = _pull(f, solid, 3, 1, y, x, 0, -1)
            f4 = _pull(f, solid, 4, 2, y, x, -1, 0)
            f5 = _pull(f, solid, 5, 7, y, x, 1, 1)
            f6 = _pull(f, solid, 6, 8, y, x, 1, -1)
            f7 = _pull(f, solid, 7, 5, y, x, -1, -1)
            f8 = _pull(f, solid, 8, 6, y, x, -1, 1)
            rho = f0 + f1 + f2 + f3 + f4 + f5 + f6 + f7 + f8
            ux = (f1 - f3 + f5 - f6 - f7 + f8) / rho
            uy = (f2 - f4 + f5 + f6 - f7 - f8) / rho
            q = 1.0 - 1.5 * (ux * ux + uy * uy)
            o = om
            s = sponge[y, x]
            if s > 0.0:  # blend towards the free stream: relax both moments and populations
                rho = (1.0 - s) * rho + s
                ux = (1.0 - s) * ux + s * u0
                uy = (1.0 - s) * uy
                q = 1.0 - 1.5 * (ux * ux + uy * uy)
                o = om + s * (1.0 - om)
            a = 1.0 - o
            r0 = o * rho
            g[0, y, x] = a * f0 + r0 * w0 * q
            e = ux
            g[1, y, x] = a * f1 + r0 * w1 * (q + 3.0 * e + 4.5 * e * e)
            e = uy
            g[2, y, x] = a * f2 + r0 * w1 * (q + 3.0 * e + 4.5 * e * e)
            e = -ux
            g[3, y, x] = a * f3 + r0 * w1 * (q + 3.0 * e + 4.5 * e * e)
            e = -uy
            g[4, y, x] = a * f4 + r0 * w1 * (q + 3.0 * e + 4.5 * e * e)
            e = ux + uy
            g[5, y, x] = a * f5 + r0 * w2 * (q + 3.0 * e + 4.5 * e * e)
            e = -ux + uy
            g[6, y, x] = a * f6 + r0 * w2 * (q + 3.0 * e + 4.5 * e * e)
            e = -ux - uy
            g[7, y, x] = a * f7 + r0 * w2 * (q + 3.0 * e + 4.5 * e * e)
            e = ux - uy
            g[8, y, x] = a * f8 + r0 * w2 * (q + 3.0 * e + 4.5 * e * e)


@numba.njit(cache=True)
def _boundaries(
    g: NDArray[np.float64],
    u_in: float,
    v_in: float,
    ex: NDArray[np.int64],
    ey: NDArray[np.int64],
    wt: NDArray[np.float64],
) -> None:
    """Inlet (x=0): velocity u_in, v_in; outlet (x=nx-1): ρ = 1; lateral sides: zero gradient.

    Inlet and outlet use the equilibrium plus the non-equilibrium part of the
    neighbouring interior node (Guo's extrapolation).
    """
    _, ny, nx = g.shape
    for y in range(1, ny - 1):
        for side in range(2):
            xb = 0 if side == 0 else nx - 1
            xn = 1 if side == 0 else nx - 2
            rho = 0.0
            mx = 0.0
            my = 0.0
            for i in range(9):
                v = g[i, y, xn]
                rho += v
                mx += ex[i] * v
                my += ey[i] * v
            un = mx / rho
            vn = my / rho
            if side == 0:
                rb, ub, vb = rho, u_in, v_in
            else:
                rb, ub, vb = 1.0, un, vn
            for i in range(9):
                g[i, y, xb] = (
                    _feq(i, rb, ub, vb, ex, ey, wt) + g[i, y, xn] - _feq(i, rho, un, vn, ex, ey, wt)
                )
    for x in range(nx):
        for i in range(9):
            g[i, 0, x] = g[i, 1, x]
            g[i, ny - 1, x] = g[i, ny - 2, x]


@numba.njit(cache=True)
def _pressure_force(
    f: NDArray[np.float64], fy_: NDArray[np.int64], fx_: NDArray[np.int64], nrm: NDArray[np.float64]
) -> tuple[float, float]:
    """∮ n (ρ - 1) c_s² dl over the staircase faces, in lattice units (Eq. 2 without d/dt)."""
    sx = 0.0
    sy = 0.0
    for k in range(fy_.size):
        rho = 0.0
        for i in range(9):
            rho += f[i, fy_[k], fx_[k]]
        p = (rho - 1.0) / 3.0
        sx += p * nrm[k, 0]
        sy += p * nrm[k, 1]
    return sx, sy


@numba.njit(cache=True)
def _run(
    f: NDArray[np.float64],
    g: NDArray[np.float64],
    solid: NDArray[np.bool_],
    om: float,
    sponge: NDArray[np.float64],
    u_in: NDArray[np.float64],
    v_in: NDArray[np.float64],
    fy_: NDArray[np.int64],
    fx_: NDArray[np.int64],
    nrm: NDArray[np.float64],
    force: NDArray[np.float64],
    ex: NDArray[np.int64],
    ey: NDArray[np.int64],
    wt: NDArray[np.float64],
) -> int:
    """Advance ``u_in.size`` steps; returns 0 if the result is in f, 1 if in g."""
    a, b = f, g
    flip = 0
    for n in range(u_in.size):
        _sweep(a, b, solid, om, sponge, u_in[n])
        _boundaries(b, u_in[n], v_in[n], ex, ey, wt)
        force[n, 0], force[n, 1] = _pressure_force(b, fy_, fx_, nrm)
        a, b = b, a
        flip ^= 1
    return flip


def equilibrium(
    rho: NDArray[np.float64], ux: NDArray[np.float64], uy: NDArray[np.float64]
) -> NDArray[np.float64]:
    """D2Q9 equilibrium ``(9, ny, nx)`` of density and velocity fields ``(ny, nx)``."""
    eu = EX[:, None, None] * ux + EY[:, None, None] * uy
    return WT[:, None, None] * rho * (1 + 3 * eu + 4.5 * eu**2 - 1.5 * (ux**2 + uy**2))


def sponge_layer(
    shape: tuple[int, int], *, width: float, strength: float = 0.25
) -> NDArray[np.float64]:
    """Absorbing-layer strength ``(ny, nx)``: 0 inside, rising quadratically to ``strength``
    over ``width`` cells at the lateral sides and the outlet (not the inlet)."""
    ny, nx = shape
    y = np.arange(ny, dtype=np.float64)
    x = np.arange(nx, dtype=np.float64)
    dy = np.clip((width - np.minimum(y, ny - 1 - y)) / width, 0, 1)
    dx = np.clip((width - (nx - 1 - x)) / width, 0, 1)
    d = np.maximum(dy[:, None], dx[None, :])
    return np.ascontiguousarray(strength * d**2)


def body_faces(
    solid: NDArray[np.bool_],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Staircase faces of the body: fluid nodes next to a solid node across an axis link.

    Returns the fluid nodes' (y, x) indices and the outward unit normal of the
    body at each face (pointing from the solid into the fluid), so that
    ``Σ p n dl`` is the surface integral of Eq. 2.  The faces of a closed body
    sum to zero normal, so a uniform pressure gives no force.
    """
    ys, xs, ns = [], [], []
    fluid = ~solid
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        # fluid node at (y, x) whose neighbour (y+dy, x+dx) is solid: normal = -(dx, dy)
        nb = np.zeros_like(solid)
        nb[max(0, -dy) : solid.shape[0] - max(0, dy), max(0, -dx) : solid.shape[1] - max(0, dx)] = (
            solid[
                max(0, dy) : solid.shape[0] - max(0, -dy), max(0, dx) : solid.shape[1] - max(0, -dx)
            ]
        )
        yy, xx = np.nonzero(fluid & nb)
        ys.append(yy)
        xs.append(xx)
        ns.append(np.broadcast_to([-float(dx), -float(dy)], (yy.size, 2)))
    return np.concatenate(ys), np.concatenate(xs), np.ascontiguousarray(np.concatenate(ns))


@dataclass
class FlowRecord:
    """Lift/drag history of one simulation, in lattice units.

    ``force (n, 2)``: pressure force per unit span on the fluid side
    (``∮ n p dl``, Eq. 2 before d/dt), one row per lattice step, for the
    recorded steps only; ``periodic`` tells whether the periodicity test passed
    before recording started; ``warmup_steps`` how many steps were discarded.
    """

    force: NDArray[np.float64]
    warmup_steps: int
    periodic: bool
    period_steps: float


def _crossing_periods(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Upward zero crossings (fractional indices) of x - mean, and peak amplitudes between them."""
    y = x - x.mean()
    idx = np.nonzero((y[:-1] < 0) & (y[1:] >= 0))[0]
    frac = idx + (-y[idx]) / (y[idx + 1] - y[idx])
    amps = np.array([np.ptp(x[a : b + 1]) for a, b in itertools.pairwise(idx)])
    return frac, amps


def simulate(
    solid: NDArray[np.bool_],
    *,
    u_lat: float,
    nu_lat: float,
    record_steps: int,
    d_cells: float,
    seed: int = 0,
    min_warmup_steps: int | None = None,
    max_warmup_steps: int | None = None,
    chunk_steps: int | None = None,
) -> FlowRecord:
    """Run the LBM from rest until the shedding is periodic, then record ``record_steps`` steps.

    Parameters
    ----------
    solid : (ny, nx) bool
        Body mask (True inside); the flow enters at x = 0 towards +x.
    u_lat : float
        Inflow speed in lattice units (≲ 0.1 for incompressibility).
    nu_lat : float
        Kinematic viscosity in lattice units (τ = 3ν + ½).
    record_steps : int
        Steps to record after the flow has become periodic.
    d_cells : float
        Body size D in cells (sets convective time D / u_lat for the warm-up).
    seed : int
        Seeds the sign and size of the symmetry-breaking transverse kick.
    min_warmup_steps, max_warmup_steps : int, optional
        Bounds of the warm-up (default 25 and 400 convective times D / u).

    Returns
    -------
    FlowRecord
    """
    ny, nx = solid.shape
    conv = d_cells / u_lat  # steps per convective time
    min_w = int(25 * conv) if min_warmup_steps is None else int(min_warmup_steps)
    max_w = int(400 * conv) if max_warmup_steps is None else int(max_warmup_steps)
    chunk = int(5 * conv) if chunk_steps is None else int(chunk_steps)
    om = 1.0 / (3.0 * nu_lat + 0.5)
    sponge = sponge_layer(solid.shape, width=max(4.0, 1.5 * d_cells))
    rng = np.random.default_rng(seed)
    kick = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.1))
    ramp = 4 * conv

    def inflow(n0: int, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        t = np.arange(n0, n0 + n, dtype=np.float64)
        u = u_lat * np.where(t < ramp, 0.5 - 0.5 * np.cos(np.pi * np.minimum(t / ramp, 1)), 1.0)
        v = np.where(t < 2 * ramp, kick * u_lat * np.sin(np.pi * t / (2 * ramp)) ** 2, 0.0)
        return u, v

    f = equilibrium(np.ones((ny, nx)), np.where(solid, 0.0, u_lat), np.zeros((ny, nx)))
    g = f.copy()
    fy_, fx_, nrm = body_faces(solid)
    hist: list[NDArray[np.float64]] = []
    step = 0
    periodic = False
    period = float("nan")
    while step < max_w:
        n = chunk
        u, v = inflow(step, n)
        force = np.empty((n, 2))
        if _run(f, g, solid, om, sponge, u, v, fy_, fx_, nrm, force, EX, EY, WT):
            f, g = g, f
        step += n
        hist.append(force[:, 1])
        if step < min_w:
            continue
        lift = np.concatenate(hist)[-int(min(step, 30 * conv)) :]
        cross, amps = _crossing_periods(lift)
        if amps.size >= 4:
            per = np.diff(cross[-5:])
            a = amps[-4:]
            if np.std(per) < 0.01 * np.mean(per) and np.std(a) < 0.02 * np.mean(a) and a.mean() > 0:
                periodic = True
                period = float(np.mean(per))
                break
        if not np.all(np.isfinite(lift)):
            break
    warm = step
    u, v = inflow(step, record_steps)
    force = np.empty((record_steps, 2))
    _run(f, g, solid, om, sponge, u, v, fy_, fx_, nrm, force, EX, EY, WT)
    if not periodic:
        cross, _ = _crossing_periods(force[:, 1])
        if cross.size >= 2:
            period = float(np.mean(np.diff(cross)))
    return FlowRecord(force=force, warmup_steps=warm, periodic=periodic, period_steps=period)
