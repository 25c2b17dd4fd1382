"""Stable-fluids solver for the texture pre-process and the built-in plume (paper 000 §5.1).

The paper simulates the turbulent field with the method of Fedkiw, Stam and
Jensen [FSJ01]: semi-Lagrangian advection, pressure projection and vorticity
confinement on a voxel grid.  This module implements that scheme on a
staggered (MAC) grid of ``nx × ny × nz`` cubic cells of edge ``h``:

* ``u`` lives on x-faces, shape ``(nz, ny, nx)``; ``v`` on y-faces,
  ``(nz, ny, nx)``; ``w`` on z-faces, ``(nz + 1, ny, nx)``.  Arrays follow the
  project's ``(z, y, x)`` order.
* sides (x, y) are periodic; the bottom face ``w[0]`` is a prescribed inflow
  (the caller sets it every step); the top is a natural outflow boundary
  (pressure zero on the top face, velocities extrapolated).
* advection: semi-Lagrangian with the linear back-trace of [FSJ01] and
  trilinear sampling (numba kernel: the per-face gather with periodic/clamped
  boundaries is a loop numpy cannot express without many temporaries).
* projection: the discrete 7-point Poisson problem is solved *exactly* with
  an FFT in x and y and an eigen-decomposition of the 1-D z operator
  (Neumann bottom, Dirichlet top), so the discrete divergence after the
  projection is at round-off level.
* vorticity confinement [FSJ01, Eq. 11]: ``f = ε h (N × ω)``.  Here
  ``ε = eps0 · U / h`` with the dimensionless ``eps0`` and the reference speed
  ``U``, so the force scales as ``U²/h`` and the flow is self-similar in ``U``
  (a requirement for the u⁴ law of the sound texture, §3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import NDArray

from auralize.errors import ParameterError
from auralize.runtime.jit import configure as _configure_numba

_configure_numba()  # cache folder, OMP wait policy, compile notice

# Staggering offsets (in cells) of the sample points of each field: (ox, oy, oz).
OFF_U = (0.0, 0.5, 0.5)
OFF_V = (0.5, 0.0, 0.5)
OFF_W = (0.5, 0.5, 0.0)
OFF_C = (0.5, 0.5, 0.5)


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def _sample(f, gx, gy, gz):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """Trilinear sample of ``f (nz, ny, nx)`` at grid coords; periodic x/y, clamped z."""
    nz, ny, nx = f.shape
    if gz < 0.0:
        gz = 0.0
    elif gz > nz - 1:
        gz = float(nz - 1)
    k0 = int(gz)
    if k0 > nz - 2:
        k0 = max(nz - 2, 0)
    tz = gz - k0
    k1 = min(k0 + 1, nz - 1)
    gx = gx - nx * np.floor(gx / nx)
    gy = gy - ny * np.floor(gy / ny)
    i0 = min(int(gx), nx - 1)
    j0 = min(int(gy), ny - 1)
    tx = gx - i0
    ty = gy - j0
    i1 = i0 + 1 if i0 + 1 < nx else 0
    j1 = j0 + 1 if j0 + 1 < ny else 0
    c00 = f[k0, j0, i0] * (1 - tx) + f[k0, j0, i1] * tx
    c01 = f[k0, j1, i0] * (1 - tx) + f[k0, j1, i1] * tx
    c10 = f[k1, j0, i0] * (1 - tx) + f[k1, j0, i1] * tx
    c11 = f[k1, j1, i0] * (1 - tx) + f[k1, j1, i1] * tx
    c0 = c00 * (1 - ty) + c01 * ty
    c1 = c10 * (1 - ty) + c11 * ty
    return c0 * (1 - tz) + c1 * tz


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def _advect_velocity(u, v, w, dt_h):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """Semi-Lagrangian self-advection of the MAC velocity by one step ([FSJ01] §3).

    Linear back-trace ``x − Δt v(x)`` from every face, with the other two
    components at the face averaged from their four neighbouring faces, and a
    trilinear sample at the foot.  ``dt_h`` is ``Δt / h`` (m/s → cells).
    Periodic in x and y; clamped (outflow extrapolation / inflow value) in z.
    """
    nz, ny, nx = u.shape
    u2 = np.empty_like(u)
    v2 = np.empty_like(v)
    w2 = np.empty_like(w)
    for k in range(nz):
        for j in range(ny):
            jm = j - 1 if j > 0 else ny - 1
            jp = j + 1 if j < ny - 1 else 0
            for i in range(nx):
                im = i - 1 if i > 0 else nx - 1
                ip = i + 1 if i < nx - 1 else 0
                # u-face (i, j+½, k+½)
                vv = 0.25 * (v[k, j, im] + v[k, j, i] + v[k, jp, im] + v[k, jp, i])
                ww = 0.25 * (w[k, j, im] + w[k, j, i] + w[k + 1, j, im] + w[k + 1, j, i])
                u2[k, j, i] = _sample(u, i - dt_h * u[k, j, i], j - dt_h * vv, k - dt_h * ww)
                # v-face (i+½, j, k+½)
                uu = 0.25 * (u[k, jm, i] + u[k, jm, ip] + u[k, j, i] + u[k, j, ip])
                ww = 0.25 * (w[k, jm, i] + w[k, j, i] + w[k + 1, jm, i] + w[k + 1, j, i])
                v2[k, j, i] = _sample(v, i - dt_h * uu, j - dt_h * v[k, j, i], k - dt_h * ww)
    for k in range(nz + 1):
        ka = k - 1 if k > 0 else 0
        kb = k if k < nz else nz - 1
        for j in range(ny):
            jp = j + 1 if j < ny - 1 else 0
            for i in range(nx):
                ip = i + 1 if i < nx - 1 else 0
                # w-face (i+½, j+½, k)
                uu = 0.25 * (u[ka, j, i] + u[ka, j, ip] + u[kb, j, i] + u[kb, j, ip])
                vv = 0.25 * (v[ka, j, i] + v[ka, jp, i] + v[kb, j, i] + v[kb, jp, i])
                w2[k, j, i] = _sample(w, i - dt_h * uu, j - dt_h * vv, k - dt_h * w[k, j, i])
    return u2, v2, w2


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def _advect(q, ox, oy, oz, u, v, w, dt_h):  # type: ignore[no-untyped-def]  # noqa: PLR0917 (a compiled kernel: its arrays are its arguments)  # pragma: no cover
    """Semi-Lagrangian advection of a field ``q`` sampled at cell offsets ``(ox, oy, oz)``.

    Linear back-trace with the velocity sampled trilinearly at the point.
    """
    nz, ny, nx = q.shape
    out = np.empty_like(q)
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                x = i + ox
                y = j + oy
                z = k + oz
                a = _sample(u, x, y - 0.5, z - 0.5)
                b = _sample(v, x - 0.5, y, z - 0.5)
                c = _sample(w, x - 0.5, y - 0.5, z)
                out[k, j, i] = _sample(q, x - dt_h * a - ox, y - dt_h * b - oy, z - dt_h * c - oz)
    return out


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def _cell_vorticity(u, v, w, h):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """Cell-centred vorticity of the MAC velocity (central differences of cell velocities)."""
    nz, ny, nx = u.shape
    uc = np.empty((nz, ny, nx, 3))
    for k in range(nz):
        for j in range(ny):
            jp = j + 1 if j < ny - 1 else 0
            for i in range(nx):
                ip = i + 1 if i < nx - 1 else 0
                uc[k, j, i, 0] = 0.5 * (u[k, j, i] + u[k, j, ip])
                uc[k, j, i, 1] = 0.5 * (v[k, j, i] + v[k, jp, i])
                uc[k, j, i, 2] = 0.5 * (w[k, j, i] + w[k + 1, j, i])
    om = np.empty((nz, ny, nx, 3))
    for k in range(nz):
        ka = k - 1 if k > 0 else 0
        kb = k + 1 if k < nz - 1 else nz - 1
        hz = (kb - ka) * h
        for j in range(ny):
            ja = j - 1 if j > 0 else ny - 1
            jb = j + 1 if j < ny - 1 else 0
            for i in range(nx):
                ia = i - 1 if i > 0 else nx - 1
                ib = i + 1 if i < nx - 1 else 0
                dvz_dy = (uc[k, jb, i, 2] - uc[k, ja, i, 2]) / (2 * h)
                dvy_dz = (uc[kb, j, i, 1] - uc[ka, j, i, 1]) / hz
                dvx_dz = (uc[kb, j, i, 0] - uc[ka, j, i, 0]) / hz
                dvz_dx = (uc[k, j, ib, 2] - uc[k, j, ia, 2]) / (2 * h)
                dvy_dx = (uc[k, j, ib, 1] - uc[k, j, ia, 1]) / (2 * h)
                dvx_dy = (uc[k, jb, i, 0] - uc[k, ja, i, 0]) / (2 * h)
                om[k, j, i, 0] = dvz_dy - dvy_dz
                om[k, j, i, 1] = dvx_dz - dvz_dx
                om[k, j, i, 2] = dvy_dx - dvx_dy
    return om


@dataclass
class StableFluids:
    """Incompressible inviscid flow on a periodic-sided box (paper 000 §5.1, [FSJ01]).

    Parameters
    ----------
    shape : (nz, ny, nx)
        Number of cells.
    h : float
        Cell edge in metres.
    dt : float
        Time step in seconds (the paper uses 1 ms, §5.1).
    eps0 : float
        Dimensionless vorticity-confinement strength (0 disables it).
    speed_ref : float
        Reference speed U (m/s) of the confinement scaling ``ε = eps0·U/h``.

    Examples
    --------
    >>> s = StableFluids((8, 6, 6), h=0.01, dt=1e-3)
    >>> s.w[:] = 1.0
    >>> s.step()
    >>> float(abs(s.divergence()).max()) < 1e-9
    True
    """

    shape: tuple[int, int, int]
    h: float
    dt: float = 1e-3
    eps0: float = 0.0
    speed_ref: float = 1.0
    u: NDArray[np.float64] = field(init=False, repr=False)
    v: NDArray[np.float64] = field(init=False, repr=False)
    w: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        nz, ny, nx = (int(s) for s in self.shape)
        if min(nz, ny, nx) < 3:
            raise ParameterError(
                f"the fluid grid needs at least 3 cells per axis, got {self.shape}"
            )
        if not (self.h > 0 and self.dt > 0):
            raise ParameterError(f"h and dt must be positive, got h={self.h!r}, dt={self.dt!r}")
        self.shape = (nz, ny, nx)
        self.u = np.zeros((nz, ny, nx))
        self.v = np.zeros((nz, ny, nx))
        self.w = np.zeros((nz + 1, ny, nx))
        h2 = self.h**2
        # 1-D z operator: Neumann at the bottom face (inflow prescribed), Dirichlet p=0 at the top face
        lz = np.diag(np.full(nz, -2.0)) + np.diag(np.ones(nz - 1), 1) + np.diag(np.ones(nz - 1), -1)
        lz[0, 0] = -1.0
        lz[-1, -1] = -3.0
        lam_z, self._vz = np.linalg.eigh(lz / h2)
        self._vzt = np.ascontiguousarray(self._vz.T)
        kx = np.arange(nx // 2 + 1)
        ky = np.fft.fftfreq(ny) * ny
        lam_x = (2 * np.cos(2 * np.pi * kx / nx) - 2) / h2
        lam_y = (2 * np.cos(2 * np.pi * ky / ny) - 2) / h2
        lam = lam_z[:, None, None] + lam_y[None, :, None] + lam_x[None, None, :]
        self._inv_lam = (1.0 / lam).reshape(nz, -1)  # all < 0: the top Dirichlet face fixes φ

    # ------------------------------------------------------------ operators
    def divergence(self) -> NDArray[np.float64]:
        """Discrete divergence per cell ``(nz, ny, nx)`` in 1/s."""
        u, v, w = self.u, self.v, self.w
        return (
            (np.roll(u, -1, axis=2) - u) + (np.roll(v, -1, axis=1) - v) + (w[1:] - w[:-1])
        ) / self.h

    def project(self) -> None:
        """Make the velocity discretely divergence-free (exact Poisson solve)."""
        nz, ny, nx = self.shape
        rhs = np.fft.rfft2(self.divergence(), axes=(1, 2))
        m = rhs.shape[1] * rhs.shape[2]
        rhs = (self._vzt @ rhs.reshape(nz, m)) * self._inv_lam
        phi = np.fft.irfft2((self._vz @ rhs).reshape(nz, ny, -1), s=(ny, nx), axes=(1, 2))
        h = self.h
        self.u -= (phi - np.roll(phi, 1, axis=2)) / h
        self.v -= (phi - np.roll(phi, 1, axis=1)) / h
        self.w[1:-1] -= (phi[1:] - phi[:-1]) / h
        self.w[-1] -= (-2.0 * phi[-1]) / h  # ghost φ = -φ (p = 0 on the top face)

    def cell_velocity(self) -> NDArray[np.float64]:
        """Velocity at cell centres ``(nz, ny, nx, 3)`` in m/s."""
        uc = 0.5 * (self.u + np.roll(self.u, -1, axis=2))
        vc = 0.5 * (self.v + np.roll(self.v, -1, axis=1))
        wc = 0.5 * (self.w[1:] + self.w[:-1])
        return np.stack([uc, vc, wc], axis=-1)

    def vorticity(self) -> NDArray[np.float64]:
        """Vorticity at cell centres ``(nz, ny, nx, 3)`` in 1/s (central differences)."""
        return _cell_vorticity(self.u, self.v, self.w, self.h)

    def advect(
        self, q: NDArray[np.float64], offset: tuple[float, float, float]
    ) -> NDArray[np.float64]:
        """Semi-Lagrangian advection of any staggered field by the current velocity."""
        return _advect(q, *offset, self.u, self.v, self.w, self.dt / self.h)

    def confine(self) -> None:
        """Add the vorticity-confinement force of [FSJ01] over one step."""
        if self.eps0 <= 0:
            return
        om = self.vorticity()
        f = _confinement(om, np.sqrt(np.einsum("...i,...i->...", om, om)), self.h)
        self.add_cell_force(self.eps0 * self.speed_ref * f)  # ε h (N×ω), ε = eps0 U / h

    def add_cell_force(self, f: NDArray[np.float64]) -> None:
        """Add ``dt · f`` for a cell-centred acceleration ``f (nz, ny, nx, 3)`` in m/s²."""
        dt = self.dt
        self.u += dt * 0.5 * (f[..., 0] + np.roll(f[..., 0], 1, axis=2))
        self.v += dt * 0.5 * (f[..., 1] + np.roll(f[..., 1], 1, axis=1))
        self.w[1:-1] += dt * 0.5 * (f[1:, ..., 2] + f[:-1, ..., 2])
        self.w[-1] += dt * f[-1, ..., 2]

    def step(self) -> None:
        """Advance one time step: advect, confine, project (bottom ``w[0]`` is kept)."""
        inflow = self.w[0].copy()
        self.u, self.v, self.w = _advect_velocity(self.u, self.v, self.w, self.dt / self.h)
        self.w[0] = inflow
        self.confine()
        self.project()


@numba.njit(cache=True, fastmath=True, error_model="numpy")
def _confinement(om, mag, h):  # type: ignore[no-untyped-def]  # pragma: no cover - numba
    """N × ω with N = ∇|ω| / |∇|ω|| (periodic x/y, one-sided z ends) [FSJ01 Eq. 10-11]."""
    nz, ny, nx = mag.shape
    out = np.zeros((nz, ny, nx, 3))
    for k in range(nz):
        ka = k - 1 if k > 0 else 0
        kb = k + 1 if k < nz - 1 else nz - 1
        for j in range(ny):
            ja = j - 1 if j > 0 else ny - 1
            jb = j + 1 if j < ny - 1 else 0
            for i in range(nx):
                ia = i - 1 if i > 0 else nx - 1
                ib = i + 1 if i < nx - 1 else 0
                gx = (mag[k, j, ib] - mag[k, j, ia]) / (2 * h)
                gy = (mag[k, jb, i] - mag[k, ja, i]) / (2 * h)
                gz = (mag[kb, j, i] - mag[ka, j, i]) / ((kb - ka) * h)
                gn = np.sqrt(gx * gx + gy * gy + gz * gz)
                if gn < 1e-12:
                    continue
                gx /= gn
                gy /= gn
                gz /= gn
                ox, oy, oz = om[k, j, i, 0], om[k, j, i, 1], om[k, j, i, 2]
                out[k, j, i, 0] = gy * oz - gz * oy
                out[k, j, i, 1] = gz * ox - gx * oz
                out[k, j, i, 2] = gx * oy - gy * ox
    return out


def curl(
    vel: NDArray[np.floating], h: float | NDArray[np.floating], *, periodic_xy: bool = False
) -> NDArray[np.float64]:
    """Vorticity ω = ∇ × v of a point/cell field ``(nz, ny, nx, 3)`` (1/s).

    Central differences (one-sided at non-periodic ends); ``h`` is a scalar or
    ``(hx, hy, hz)`` in metres.
    """
    v = np.asarray(vel, dtype=np.float64)
    hx, hy, hz = np.broadcast_to(np.asarray(h, dtype=np.float64), (3,))

    def d(a: NDArray[np.float64], axis: int, step: float) -> NDArray[np.float64]:
        if a.shape[axis] < 2:
            return np.zeros_like(a)
        if periodic_xy and axis in (1, 2):
            return (np.roll(a, -1, axis=axis) - np.roll(a, 1, axis=axis)) / (2 * step)
        return np.gradient(a, step, axis=axis)

    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    return np.stack(
        [d(vz, 1, hy) - d(vy, 0, hz), d(vx, 0, hz) - d(vz, 2, hx), d(vy, 2, hx) - d(vx, 1, hy)],
        axis=-1,
    )


def smooth_noise(
    rng: np.random.Generator, shape: tuple[int, int], corr_cells: float
) -> NDArray[np.float64]:
    """Zero-mean, unit-variance periodic random field smoothed over ``corr_cells`` cells."""
    white = rng.standard_normal(shape)
    ny, nx = shape
    ky = np.fft.fftfreq(ny)[:, None]
    kx = np.fft.fftfreq(nx)[None, :]
    filt = np.exp(-2 * (np.pi * corr_cells) ** 2 * (kx**2 + ky**2))
    out = np.fft.ifft2(np.fft.fft2(white) * filt).real
    out -= out.mean()
    sd = out.std()
    return out / sd if sd > 0 else out
