"""Aerodynamic sound emitted by sound textures (paper 004 §6, Eqs. 3–4), as dipole emitters.

For every point source l (:meth:`AeroObject.sources`):

* its velocity relative to the air, ``u = wind - v_source`` (§4, Fig. 3c),
  gives by property 3 of §5.1 the effective speed ``v cos φ`` (the component
  perpendicular to the object's axis n; φ is the angle between the flow and
  the plane normal to n — the paper's "angle between n and c" must be read
  this way, since a flow along the axis sheds nothing) and the projected
  flow direction c' (angle θ in the section frame e1, e2);
* Eq. 3: the texture coordinate advances as ``s_k = s_{k-1} + (v/v0) Δt``,
  and ``g_l = (v/v0)^e w(s_k, c')`` with the amplitude exponent e = 3 for the
  pressure law (docs/design.md; ``"physical"``) or the paper's e = 6
  (``"paper"``).  The flow direction is folded into the texture's
  fundamental domain and the neighbouring sampled directions are
  interpolated linearly (§7.3); the texture loops (its ends are blended
  when it is made).  A 10 ms fade-in at emission time 0 replaces the
  paper's "object static at t = 0" start.
* Eq. 4 / Eq. 1, ``p(q, t) = Σ_l (q - o_l) · g_l(τ_l) Δh_l / (4π c0 r_l²)``,
  is a sum of point dipoles: with û = (q - o_l)/r_l it is
  ``û · G_l(τ_l) / r_l`` for the world-frame dipole vector
  ``G_l = Δh_l g_l / (4π c0)`` (g rotated from the section frame to the
  world).  This module emits G_l as table emitters
  (:class:`AeroEmission`, :class:`auralize.emitters.TableEmitters`: G = Q g
  with the 3x2 matrix Q linear per block and g the texture read at the
  texture coordinate); the sound engine
  (:func:`auralize.emitters.render_emitters`, distance law exponent 1) does
  the retarded time τ_l = t - r_l/c0, the 1/r, the Doppler shift of moving
  sources and the panning to any layout.

Smooth quantities (kinematics, amplitude, section frame, direction look-up,
texture coordinate) live on a grid of one value per ``block`` emission
samples and are interpolated linearly within a block, computed by one
numba pass (:func:`_q_kernel`, sources split over up to two threads); the
engine reads the texture per output sample.  ``engine="numpy"`` runs the
reference numpy path (:func:`kinematics_reference`,
:func:`emission_reference`: G stored), whose samples equal the table
emitters' up to rounding.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from auralize.emitters import C0, Emitters, TableEmitters
from auralize.emitters.parallel import N_THREADS, run_pieces
from auralize.emitters.synthesis import Rendered
from auralize.errors import ParameterError
from auralize.listener import ListenerPath
from auralize.spatial.layouts import Layout

from .objects import AeroObject, Motion, Wind, quat_to_matrix
from .texture import SoundTexture

_NJIT = {"cache": True, "nogil": True, "error_model": "numpy"}
EXPONENTS = {"physical": 3.0, "paper": 6.0}


def resolve_exponent(exponent: str | float) -> float:
    """``"physical"`` → 3 (pressure ∝ v³), ``"paper"`` → 6 (Eq. 3 as printed), or a number."""
    if isinstance(exponent, str):
        if exponent in EXPONENTS:
            return EXPONENTS[exponent]
        try:
            return float(exponent)
        except ValueError:
            raise ParameterError(
                f"exponent must be 'physical', 'paper' or a number, got {exponent!r}"
            ) from None
    e = float(exponent)
    if not math.isfinite(e):
        raise ParameterError(f"exponent must be finite, got {exponent!r}")
    return e


# Work is split between up to two threads (the kernels release the GIL).
_N_THREADS = N_THREADS


def _parts(S: int) -> list[tuple[int, int]]:
    """Contiguous ranges of ``range(S)``, up to four per thread (taken in turn)."""
    n = max(1, min(4 * _N_THREADS if _N_THREADS > 1 else 1, S))
    edges = [S * i // n for i in range(n + 1)]
    return [(edges[i], edges[i + 1]) for i in range(n)]


def _run(fn: Callable[[int], None], n: int) -> None:
    """``fn(i)`` for every i < n on up to two threads (:func:`auralize.emitters.parallel.run_pieces`)."""
    run_pieces(fn, n)


def _in_parts(fn: Callable[[int, int], None], S: int) -> None:
    parts = _parts(S)
    _run(lambda i: fn(*parts[i]), len(parts))


@dataclass
class Kinematics:
    """Per-source quantities on a uniform emission-time grid ``t = j · dt`` (j < J).

    pos (S, J, 3) m; e1, e2 (S, J, 3) unit section axes; c1, c2 (S, J) the
    flow direction's components along e1, e2; speed (S, J) = v cos φ / v0;
    s (S, J) texture time (s); span (S,) Δh (m).
    """

    dt: float
    pos: NDArray[np.float64]
    e1: NDArray[np.float64]
    e2: NDArray[np.float64]
    c1: NDArray[np.float64]
    c2: NDArray[np.float64]
    speed: NDArray[np.float64]
    s: NDArray[np.float64]
    span: NDArray[np.float64]


def _apply(R: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Matrices ``R (J, 3, 3)`` applied to vectors ``v (S, 3)`` -> ``(S, J, 3)``."""
    return np.ascontiguousarray(np.matmul(R, v.T).transpose(2, 0, 1))


def kinematics_reference(
    obj: AeroObject,
    v0: float,
    *,
    motion: Motion | None,
    wind: Wind | None,
    dt: float,
    duration: float,
) -> Kinematics:
    """Source kinematics and the texture-coordinate recurrence of Eq. 3 (§6), in numpy.

    The reference for :func:`kinematics` (same quantities, one numba pass).
    """
    if motion is None and wind is None:
        raise ParameterError("give a motion (object moving) or a wind (static object), or both")
    centres, span, axes, refs = obj.sources()
    S = centres.shape[0]
    J = int(math.ceil(duration / dt)) + 3
    t = np.arange(J) * dt
    if motion is not None:
        # spline the pose (origin and rotation matrix: 12 components), then place the sources
        tm = motion.times
        tc = np.clip(t, tm[0], tm[-1])
        moving = ((t >= tm[0]) & (t <= tm[-1])).astype(np.float64)
        R = quat_to_matrix(motion.quaternions).reshape(-1, 9)
        spl = CubicSpline(tm, np.concatenate([motion.positions, R], 1), axis=0)
        v = spl(tc)
        dv = spl(tc, 1) * moving[:, None]
        Rt = v[:, 3:].reshape(J, 3, 3)
        dRt = dv[:, 3:].reshape(J, 3, 3)
        pos = v[None, :, :3] + _apply(Rt, centres)
        vel = dv[None, :, :3] + _apply(dRt, centres)
        n = _apply(Rt, axes)
        e = _apply(Rt, refs)
    else:
        pos = np.broadcast_to(centres[:, None], (S, J, 3)).copy()
        vel = np.zeros((S, J, 3))
        n = np.broadcast_to(axes[:, None], (S, J, 3)).copy()
        e = np.broadcast_to(refs[:, None], (S, J, 3)).copy()
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    e -= np.sum(e * n, 2, keepdims=True) * n
    e /= np.linalg.norm(e, axis=2, keepdims=True)
    e2 = np.cross(n, e)
    u = -vel
    if wind is not None:
        u = u + wind.velocities(S, t)
    u_perp = u - np.sum(u * n, 2, keepdims=True) * n  # property 3 (§5.1, Fig. 5)
    vp = np.linalg.norm(u_perp, axis=2)
    safe = np.where(vp > 1e-12, vp, 1.0)
    c1 = np.where(vp > 1e-12, np.sum(u_perp * e, 2) / safe, 1.0)
    c2 = np.where(vp > 1e-12, np.sum(u_perp * e2, 2) / safe, 0.0)
    a = vp / v0
    s = np.concatenate([np.zeros((S, 1)), np.cumsum(0.5 * (a[:, 1:] + a[:, :-1]) * dt, axis=1)], 1)
    return Kinematics(dt, pos, e, e2, c1, c2, a, s, span)


@numba.njit(**_NJIT)
def _kin_kernel(  # noqa: PLR0913, PLR0917 (a compiled kernel: its arrays are its arguments)
    p: NDArray[np.float64],
    dp: NDArray[np.float64],
    R: NDArray[np.float64],
    dR: NDArray[np.float64],
    centres: NDArray[np.float64],
    axes: NDArray[np.float64],
    refs: NDArray[np.float64],
    wind: NDArray[np.float64],
    has_wind: bool,
    v0: float,
    dt: float,
    pos: NDArray[np.float64],
    e1o: NDArray[np.float64],
    e2o: NDArray[np.float64],
    c1o: NDArray[np.float64],
    c2o: NDArray[np.float64],
    ao: NDArray[np.float64],
    so: NDArray[np.float64],
    k0: int,
    k1: int,
) -> None:
    """Fused :func:`kinematics_reference` after the pose spline: poses ``p (J, 3)``,
    ``R (J, 3, 3)`` and their time derivatives -> per-source arrays (written in place)."""
    J = p.shape[0]
    for k in range(k0, k1):
        cx, cy, cz = centres[k, 0], centres[k, 1], centres[k, 2]
        ax, ay, az = axes[k, 0], axes[k, 1], axes[k, 2]
        rx, ry, rz = refs[k, 0], refs[k, 1], refs[k, 2]
        for j in range(J):
            pos[k, j, 0] = p[j, 0] + (R[j, 0, 0] * cx + R[j, 0, 1] * cy + R[j, 0, 2] * cz)
            pos[k, j, 1] = p[j, 1] + (R[j, 1, 0] * cx + R[j, 1, 1] * cy + R[j, 1, 2] * cz)
            pos[k, j, 2] = p[j, 2] + (R[j, 2, 0] * cx + R[j, 2, 1] * cy + R[j, 2, 2] * cz)
            vx = dp[j, 0] + (dR[j, 0, 0] * cx + dR[j, 0, 1] * cy + dR[j, 0, 2] * cz)
            vy = dp[j, 1] + (dR[j, 1, 0] * cx + dR[j, 1, 1] * cy + dR[j, 1, 2] * cz)
            vz = dp[j, 2] + (dR[j, 2, 0] * cx + dR[j, 2, 1] * cy + dR[j, 2, 2] * cz)
            nx = R[j, 0, 0] * ax + R[j, 0, 1] * ay + R[j, 0, 2] * az
            ny = R[j, 1, 0] * ax + R[j, 1, 1] * ay + R[j, 1, 2] * az
            nz = R[j, 2, 0] * ax + R[j, 2, 1] * ay + R[j, 2, 2] * az
            ex = R[j, 0, 0] * rx + R[j, 0, 1] * ry + R[j, 0, 2] * rz
            ey = R[j, 1, 0] * rx + R[j, 1, 1] * ry + R[j, 1, 2] * rz
            ez = R[j, 2, 0] * rx + R[j, 2, 1] * ry + R[j, 2, 2] * rz
            nn = math.sqrt(nx * nx + ny * ny + nz * nz)
            nx /= nn
            ny /= nn
            nz /= nn
            en = ex * nx + ey * ny + ez * nz
            ex -= en * nx
            ey -= en * ny
            ez -= en * nz
            ee = math.sqrt(ex * ex + ey * ey + ez * ez)
            ex /= ee
            ey /= ee
            ez /= ee
            fx = ny * ez - nz * ey
            fy = nz * ex - nx * ez
            fz = nx * ey - ny * ex
            ux, uy, uz = -vx, -vy, -vz
            if has_wind:
                ux += wind[k, j, 0]
                uy += wind[k, j, 1]
                uz += wind[k, j, 2]
            un = ux * nx + uy * ny + uz * nz
            ux -= un * nx
            uy -= un * ny
            uz -= un * nz
            vp = math.sqrt(ux * ux + uy * uy + uz * uz)
            if vp > 1e-12:
                c1o[k, j] = (ux * ex + uy * ey + uz * ez) / vp
                c2o[k, j] = (ux * fx + uy * fy + uz * fz) / vp
            else:
                c1o[k, j] = 1.0
                c2o[k, j] = 0.0
            e1o[k, j, 0] = ex
            e1o[k, j, 1] = ey
            e1o[k, j, 2] = ez
            e2o[k, j, 0] = fx
            e2o[k, j, 1] = fy
            e2o[k, j, 2] = fz
            ao[k, j] = vp / v0
        acc = 0.0
        so[k, 0] = 0.0
        for j in range(1, J):
            acc += 0.5 * (ao[k, j] + ao[k, j - 1]) * dt
            so[k, j] = acc


def kinematics(
    obj: AeroObject,
    v0: float,
    *,
    motion: Motion | None,
    wind: Wind | None,
    dt: float,
    duration: float,
) -> Kinematics:
    """Source kinematics and the texture-coordinate recurrence of Eq. 3 (§6).

    The pose spline is evaluated in scipy; everything per source and step
    runs in one numba pass (:func:`_kin_kernel`), equal to
    :func:`kinematics_reference` up to rounding.
    """
    if motion is None and wind is None:
        raise ParameterError("give a motion (object moving) or a wind (static object), or both")
    centres, span, axes, refs = obj.sources()
    S = centres.shape[0]
    J = int(math.ceil(duration / dt)) + 3
    t = np.arange(J) * dt
    if motion is not None:
        tm = motion.times
        tc = np.clip(t, tm[0], tm[-1])
        moving = ((t >= tm[0]) & (t <= tm[-1])).astype(np.float64)
        R = quat_to_matrix(motion.quaternions).reshape(-1, 9)
        spl = CubicSpline(tm, np.concatenate([motion.positions, R], 1), axis=0)
        v = spl(tc)
        dv = spl(tc, 1) * moving[:, None]
        p = np.ascontiguousarray(v[:, :3])
        dp = np.ascontiguousarray(dv[:, :3])
        Rt = np.ascontiguousarray(v[:, 3:]).reshape(J, 3, 3)
        dRt = np.ascontiguousarray(dv[:, 3:]).reshape(J, 3, 3)
    else:
        p = np.zeros((J, 3))
        dp = np.zeros((J, 3))
        Rt = np.ascontiguousarray(np.broadcast_to(np.eye(3), (J, 3, 3)))
        dRt = np.zeros((J, 3, 3))
    uw = np.ascontiguousarray(wind.velocities(S, t)) if wind is not None else np.zeros((1, 1, 3))
    pos = np.empty((S, J, 3))
    e1 = np.empty((S, J, 3))
    e2 = np.empty((S, J, 3))
    c1 = np.empty((S, J))
    c2 = np.empty((S, J))
    a = np.empty((S, J))
    s = np.empty((S, J))
    f = np.ascontiguousarray
    args = (
        p,
        dp,
        Rt,
        dRt,
        f(centres, dtype=np.float64),
        f(axes, dtype=np.float64),
        f(refs, dtype=np.float64),
        uw,
        wind is not None,
        float(v0),
        float(dt),
        pos,
        e1,
        e2,
        c1,
        c2,
        a,
        s,
    )
    _in_parts(lambda k0, k1: _kin_kernel(*args, k0, k1), S)
    return Kinematics(dt, pos, e1, e2, c1, c2, a, s, span)


#: bytes of per-block tables (table emitters) per rendered window
CHUNK_BYTES = 16 << 20
#: output samples between the engine's control points (retarded time, distance law, dipole
#: projection, panning gains) for these emitters: twice the engine's default, as the table
#: emitters are evaluated exactly inside each table block (:func:`auralize.emitters._sampled.
#: _seg_table`) and only the amplitude weights and panning gains are taken linear between
#: control points.  Bench case (16 sources of a swinging stick, 4 s at 44.1 kHz) against a
#: per-sample render (:mod:`auralize.emitters.reference`) of the emission sampled 4x finer,
#: of the peak: mono 1.4e-4 at most, 7e-6 r.m.s.; ring8 6.2e-4 at most (the linear panning
#: gains), 1.0e-5 r.m.s. over the channels.  For comparison, 32-sample control points with
#: the emission index linear between them: 1.0e-3 at most in both (5.5e-4 after the first
#: 50 ms), 4.4e-5 and 1.6e-5 r.m.s.; 32-sample control points here: 1.4e-4 and 2.6e-4.
CONTROL_BLOCK = 64
#: bytes of the table emitters' arrays per source and block
_BLOCK_BYTES = 176


@numba.njit(**_NJIT)
def _q_kernel(  # noqa: PLR0913, PLR0917 (a compiled kernel: its arrays are its arguments)
    e1: NDArray[np.float64],
    e2: NDArray[np.float64],
    speed: NDArray[np.float64],
    scale: NDArray[np.float64],
    c1: NDArray[np.float64],
    c2: NDArray[np.float64],
    s: NDArray[np.float64],
    M: NDArray[np.float64],
    iso: bool,
    ja: int,
    dt_fade: float,
    exponent: float,
    tex_rate: float,
    qa: NDArray[np.float64],
    qb: NDArray[np.float64],
    ph: NDArray[np.float64],
    k0: int,
    k1: int,
) -> None:
    """The table-emitter arrays of sources ``k0 <= k < k1`` for the n blocks from grid point
    ``ja`` (what :meth:`AeroEmission._table_of` and the products ``[e1a e2a] M`` give, in one
    pass): ``qa, qb (S, n, 3, 2)`` the matrices ``Q = amp [e1 e2] M`` at each block's start
    and end with the block's direction map M (``iso``: the rotation by the flow direction
    ``[[c1, −c2], [c2, c1]]``, else ``M (S, n, 4)``), amp the faded ``speed^e`` times
    ``scale = Δh / (4π c0)``; ``ph (S, n + 1)`` the texture position (texture samples)."""
    n = qa.shape[1]
    for k in range(k0, k1):
        p00 = p01 = p10 = p11 = 0.0
        for b in range(n + 1):
            g = ja + b
            on = min(max(g * dt_fade, 0.0), 1.0)
            on = on * on * (3 - 2 * on)
            sp = speed[k, g]
            amp = on * (sp * sp * sp if exponent == 3.0 else sp**exponent) * scale[k]
            ph[k, b] = s[k, g] * tex_rate
            x0, x1, x2 = amp * e1[k, g, 0], amp * e1[k, g, 1], amp * e1[k, g, 2]
            y0, y1, y2 = amp * e2[k, g, 0], amp * e2[k, g, 1], amp * e2[k, g, 2]
            if b > 0:  # the end of block b - 1, with its map
                qb[k, b - 1, 0, 0] = x0 * p00 + y0 * p10
                qb[k, b - 1, 0, 1] = x0 * p01 + y0 * p11
                qb[k, b - 1, 1, 0] = x1 * p00 + y1 * p10
                qb[k, b - 1, 1, 1] = x1 * p01 + y1 * p11
                qb[k, b - 1, 2, 0] = x2 * p00 + y2 * p10
                qb[k, b - 1, 2, 1] = x2 * p01 + y2 * p11
            if b == n:
                break
            if iso:
                p00, p01, p10, p11 = c1[k, g], -c2[k, g], c2[k, g], c1[k, g]
            else:
                p00, p01, p10, p11 = M[k, b, 0], M[k, b, 1], M[k, b, 2], M[k, b, 3]
            qa[k, b, 0, 0] = x0 * p00 + y0 * p10
            qa[k, b, 0, 1] = x0 * p01 + y0 * p11
            qa[k, b, 1, 0] = x1 * p00 + y1 * p10
            qa[k, b, 1, 1] = x1 * p01 + y1 * p11
            qa[k, b, 2, 0] = x2 * p00 + y2 * p10
            qa[k, b, 2, 1] = x2 * p01 + y2 * p11


def emission_reference(
    table: tuple[NDArray[Any], ...], tex: SoundTexture, K: int
) -> NDArray[np.float64]:
    """The samples of the table emitters of :meth:`AeroEmission._emitters`, in numpy (every
    sample at once): ``G (S, 3, B K)``, from the arrays ``(e1a, e2a, M, j0, j1, w, s)`` of
    :meth:`AeroEmission._table` (``K`` samples a block)."""
    e1a, e2a, M, j0, j1, w, s = table
    S, B = j0.shape
    frac = np.arange(K) / K
    Mr = M.reshape(S, B, 2, 2)
    Qa = e1a[:, :-1, :, None] * Mr[:, :, None, 0] + e2a[:, :-1, :, None] * Mr[:, :, None, 1]
    Qz = e1a[:, 1:, :, None] * Mr[:, :, None, 0] + e2a[:, 1:, :, None] * Mr[:, :, None, 1]
    Q = Qa[:, :, None] + frac[:, None, None] * (Qz - Qa)[:, :, None]  # (S, B, K, 3, 2)
    p = (s[:, :-1, None] + frac * (s[:, 1:] - s[:, :-1])[..., None]) * tex.rate  # (S, B, K)

    def row(j: NDArray[np.int64]) -> NDArray[np.float64]:
        N = tex.lengths[j][..., None]
        q = np.mod(p, N)
        i = np.minimum(np.floor(q).astype(np.int64), N - 1)
        f = (q - i)[..., None]
        i1 = np.where(i + 1 < N, i + 1, 0)
        jj = np.broadcast_to(j[..., None], i.shape)
        return tex.g[jj, i] + f * (tex.g[jj, i1] - tex.g[jj, i])

    g = (1 - w[..., None, None]) * row(j0) + w[..., None, None] * row(j1)  # (S, B, K, 2)
    G = np.einsum("sbkcd,sbkd->scbk", Q, g)
    return G.reshape(S, 3, B * K)


@dataclass
class AeroEmission:
    """The aerodynamic sound of one object as point dipoles: a part of :class:`auralize.emitters.Sound`.

    At the object's S point sources, the world-frame dipole vectors
    ``G_l(τ) = Δh_l g_l(τ) / (4π c0)`` (Pa·m; Eq. 4) on emission samples
    ``τ = j / rate`` for ``0 <= τ < duration`` (zero outside), with the
    sources' trajectories sampled every ``block`` samples.  They are
    generated window by window (:meth:`emitters`), so memory stays bounded
    for long renders; :meth:`render_part` renders them through
    :func:`auralize.emitters.render_emitters` one output window at a time.

    Build it with :func:`emission`.
    """

    texture: SoundTexture
    kin: Kinematics
    rate: float
    block: int
    exponent: float
    c0: float = C0
    fade: float = 0.01
    radius: float = 0.05
    static: bool = False
    engine: str = "numba"
    name: str = "aero"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.n_blocks = self.kin.pos.shape[1] - 3  # the grid has 3 points past the last block
        self._lo = self.kin.pos.min(axis=0)  # (J, 3): the sources' box at each grid point
        self._hi = self.kin.pos.max(axis=0)

    @property
    def n_sources(self) -> int:
        return int(self.kin.pos.shape[0])

    @property
    def duration(self) -> float:
        """Seconds of emission (whole blocks)."""
        return self.n_blocks * self.kin.dt

    def _table(self, ja: int, jb: int) -> tuple[NDArray[Any], ...]:
        """Per-block quantities of blocks ``ja..jb`` for :func:`emission_reference` (Eq. 3, §7.3).

        Cut from a table of many blocks at once (:meth:`_table_of`, up to
        about :data:`CHUNK_BYTES`), made again when a window leaves it: the
        values are the same element by element, with fewer numpy calls.
        """
        span = getattr(self, "_span", None)
        if span is None or not (span[0] <= ja and jb <= span[1]):
            per_block = 112 * self.n_sources  # bytes of table per block
            cb = max(jb, min(self.n_blocks - 1, ja + CHUNK_BYTES // per_block))
            self._span = span = (ja, cb)
            self._tab = self._table_of(ja, cb)
        o = ja - span[0]
        n = jb - ja + 1
        f = np.ascontiguousarray
        e1a, e2a, M, j0, j1, w, st = self._tab
        return (
            f(e1a[:, o : o + n + 1]),
            f(e2a[:, o : o + n + 1]),
            f(M[:, o : o + n]),
            f(j0[:, o : o + n]),
            f(j1[:, o : o + n]),
            f(w[:, o : o + n]),
            f(st[:, o : o + n + 1]),
        )

    def _table_of(self, ja: int, jb: int) -> tuple[NDArray[Any], ...]:
        """:meth:`_table` of blocks ``ja..jb`` computed directly."""
        kin = self.kin
        g = slice(ja, jb + 2)
        on = np.clip(np.arange(ja, jb + 2) * kin.dt / self.fade, 0.0, 1.0)
        on = on * on * (3 - 2 * on)
        sp = kin.speed[:, g]
        power = sp * sp * sp if self.exponent == 3.0 else sp**self.exponent
        amp = on * power * (kin.span[:, None] / (4 * np.pi * self.c0))
        c1, c2 = kin.c1[:, ja : jb + 1], kin.c2[:, ja : jb + 1]  # flow direction c' (unit)
        tex = self.texture
        if tex.section.symmetry[0] == 0 and tex.directions_deg.size == 1:
            # isotropic section, one sampled direction: the map is the rotation by θ itself,
            # [[cos θ, −sin θ], [sin θ, cos θ]] = [[c1, −c2], [c2, c1]]
            j0 = np.zeros(c1.shape, dtype=np.int64)
            j1, w = j0, np.zeros(c1.shape)
            M = np.stack([c1, -c2, c2, c1], axis=-1)
        else:
            j0, j1, w, M = tex.lookup(np.arctan2(c2, c1))
            M = M.reshape(*c1.shape, 4)
        f = np.ascontiguousarray
        return (
            f(amp[..., None] * kin.e1[:, g]),
            f(amp[..., None] * kin.e2[:, g]),
            f(M),
            f(j0),
            f(j1),
            f(w),
            f(kin.s[:, g]),
        )

    def _emitters(self, ja: int, jb: int) -> Emitters:
        """Emitters of blocks ``ja..jb``: :class:`auralize.emitters.TableEmitters` reading the
        texture (``engine="numba"``), or the samples of :func:`emission_reference` stored."""
        K = self.block
        kin, tex = self.kin, self.texture
        # the grid points of the blocks and the one after (all of them from the first block
        # on: the whole array, no copy; past the emission the signal is zero)
        pos = kin.pos[:, 0] if self.static else kin.pos[:, ja : None if ja == 0 else jb + 2]
        if self.engine == "numpy":
            G = emission_reference(self._table(ja, jb), tex, K)
            return Emitters(
                G,
                self.rate,
                pos,
                t0=ja * kin.dt,
                pos_rate=self.rate / K,
                radius=self.radius,
                law=1.0,
                name=self.name,
            )
        # G = Q g with Q = amp [e1 e2] M (3x2) at both ends of each block, M the block's map
        S, n = self.n_sources, jb - ja + 1
        iso = tex.section.symmetry[0] == 0 and tex.directions_deg.size == 1
        if iso:  # isotropic section, one sampled direction: M is the rotation by θ itself
            j0 = np.zeros((S, n), dtype=np.int64)
            j1, w, M = j0, np.zeros((S, n)), np.zeros((1, 1, 4))
        else:
            j0, j1, w, M = tex.lookup(np.arctan2(kin.c2[:, ja : jb + 1], kin.c1[:, ja : jb + 1]))
            M = np.ascontiguousarray(M.reshape(S, n, 4))
        qa, qb, ph = np.empty((S, n, 3, 2)), np.empty((S, n, 3, 2)), np.empty((S, n + 1))
        scale = np.ascontiguousarray(kin.span, dtype=np.float64) / (4 * np.pi * self.c0)
        args = (
            kin.e1,
            kin.e2,
            kin.speed,
            scale,
            kin.c1,
            kin.c2,
            kin.s,
            M,
            iso,
            ja,
            kin.dt / self.fade,
            float(self.exponent),
            float(tex.rate),
            qa,
            qb,
            ph,
        )
        _in_parts(lambda k0, k1: _q_kernel(*args, k0, k1), S)
        return TableEmitters(
            tex.g,
            tex.lengths,
            qa=qa,
            qb=qb,
            phase=ph,
            r0=j0,
            r1=j1,
            w=w,
            block=K,
            rate=self.rate,
            positions=pos,
            t0=ja * kin.dt,
            pos_rate=self.rate / K,
            radius=self.radius,
            law=1.0,
            name=self.name,
            check=False,
        )

    def emitters(self, tau0: float = 0.0, tau1: float | None = None) -> Emitters:
        """The dipole emitters of emission times ``[tau0, tau1]`` (s; default: all), in whole blocks."""
        dt = self.kin.dt
        ja = max(0, math.floor(tau0 / dt))
        jb = self.n_blocks - 1 if tau1 is None else min(self.n_blocks - 1, math.floor(tau1 / dt))
        if jb < ja:
            raise ParameterError(
                f"emission window [{tau0:g}, {tau1:g}] s is outside [0, {self.duration:g}] s"
            )
        return self._emitters(ja, jb)

    def _window(
        self, path: ListenerPath, t_a: float, t_b: float, c0: float
    ) -> tuple[int, int] | None:
        """Blocks that can be heard during ``[t_a, t_b]`` (playback s), or None.

        Bounds only (no retarded time): the distance between the box of the
        listener's positions and the box of the sources' positions limits the
        delay; each pass narrows the sources' box to the emission times found.
        """
        t0 = path.times[0]
        inside = path.times[(path.times > t0 + t_a) & (path.times < t0 + t_b)]
        L = path.position_at(np.concatenate([[t0 + t_a, t0 + t_b], inside]))
        llo, lhi = L.min(axis=0), L.max(axis=0)
        dt = self.kin.dt
        ja, jb = 0, self.n_blocks - 1
        for _ in range(4):
            plo = self._lo[ja : jb + 2].min(axis=0)
            phi = self._hi[ja : jb + 2].max(axis=0)
            d_hi = float(np.linalg.norm(np.maximum(np.abs(lhi - plo), np.abs(phi - llo))))
            d_lo = float(np.linalg.norm(np.maximum(0.0, np.maximum(plo - lhi, llo - phi))))
            a = max(ja, math.floor((t_a - d_hi / c0) / dt) - 1)
            b = min(jb, math.floor((t_b - d_lo / c0) / dt) + 1)
            if a > b:
                return None
            if (a, b) == (ja, jb):
                break
            ja, jb = a, b
        return ja, jb

    def render_part(
        self,
        path: ListenerPath,
        *,
        rate: int = 44100,
        layout: str | Layout = "mono",
        duration: float | None = None,
        start: float = 0.0,
        c0: float = C0,
        backend: str = "auto",
    ) -> Rendered:
        """Render along ``path`` with the engine, one output window at a time.

        Each window's emitters cover every emission time that window can hear
        (:meth:`_window`), so the windows join exactly as one render of all
        the emission would.
        """
        from auralize.emitters import render_emitters
        from auralize.spatial.layouts import output_stage

        stage = output_stage(layout, int(rate))  # binaural: AmbiX windows, the ears once at the end
        lay = stage.synthesis_layout
        dur = path.duration - start if duration is None else float(duration)
        n_out = int(round(dur * rate))
        out: NDArray[np.float64] | None = None
        blocks = CHUNK_BYTES / (_BLOCK_BYTES * self.n_sources)
        step = max(256, int(blocks * self.block * rate / self.rate))
        step = max(1, -(-n_out // max(1, -(-n_out // step))))  # windows of equal length
        for na in range(0, n_out, step):
            nb = min(n_out, na + step)
            t_a = start + na / rate
            # the emission the window hears, and that of the control points around it
            pad = CONTROL_BLOCK / rate
            win = self._window(path, t_a - pad, start + nb / rate + pad, c0)
            if win is None:
                continue
            r = render_emitters(
                self._emitters(*win),
                path,
                rate=rate,
                layout=lay,
                duration=(nb - na) / rate,
                start=t_a,
                c0=c0,
                backend=backend,
                block=CONTROL_BLOCK,
            )
            if na == 0 and nb == n_out and r.audio.shape == (lay.n_channels, n_out):
                out = r.audio  # one window: its audio is the result
                break
            if out is None:
                out = np.zeros((lay.n_channels, n_out))
            m = min(nb - na, r.audio.shape[1])
            out[:, na : na + m] = r.audio[:, :m]
        if out is None:  # nothing audible
            out = np.zeros((lay.n_channels, n_out))
        return stage.finish(
            Rendered(audio=out, rate=int(rate), layout=lay, meta={**self.meta, "model": self.name})
        )


def no_ears(stereo: object) -> None:
    """Refuse the former ``stereo="ears"`` option (two ear receivers)."""
    if stereo is not None and stereo != "pan":
        raise ParameterError(
            f"stereo={stereo!r}: the aero model no longer renders two ear receivers; stereo is "
            "panned (VBAP) like every layout; binaural ears come with the binaural output"
        )


def emission(
    texture: SoundTexture,
    obj: AeroObject,
    *,
    motion: Motion | None = None,
    wind: Wind | None = None,
    rate: float = 44100,
    duration: float,
    exponent: str | float = "physical",
    c0: float = C0,
    min_distance: float = 0.05,
    fade: float = 0.01,
    block: int = 32,
    engine: str = "numba",
) -> AeroEmission:
    """The emitted aerodynamic sound of ``obj`` (§6, Eqs. 3–4) as point dipoles.

    Parameters
    ----------
    texture : SoundTexture
        Texture of the object's cross-section at base speed v0.
    obj : AeroObject
        Polylines split into point sources at Δh ≈ 3D.
    motion : Motion, optional
        Object poses (moving object: its Doppler shift comes from the engine).
    wind : Wind, optional
        Wind on the object (both may be given: relative velocity).
    rate : float
        Emission sample rate (Hz).
    duration : float
        Seconds of emission from playback time 0.
    exponent : "physical" (pressure ∝ v³, default), "paper" (v⁶) or a number.
    c0 : float
        Speed of sound (m/s) of Eq. 4's 1/(4π c0).
    min_distance : float
        Distances are clamped here (m) by the engine: no 1/0 at a source.
    fade : float
        Fade-in (s) at emission time 0.
    block : int
        Emission samples per kinematics step.
    engine : "numba" (default) or "numpy" (the reference path), equal up to rounding.

    Returns
    -------
    AeroEmission
    """
    if not isinstance(texture, SoundTexture):
        raise ParameterError(f"texture must be a SoundTexture, got {type(texture).__name__}")
    e = resolve_exponent(exponent)
    if not (math.isfinite(rate) and rate >= 1000):
        raise ParameterError(f"rate must be >= 1000 Hz, got {rate!r}")
    if not (math.isfinite(duration) and duration > 0):
        raise ParameterError(f"duration must be > 0 s, got {duration!r}")
    if engine not in ("numba", "numpy"):
        raise ParameterError(f"engine must be 'numba' or 'numpy', got {engine!r}")
    if not (fade > 0 and int(block) >= 1 and min_distance > 0):
        raise ParameterError(
            f"fade, block and min_distance must be > 0, got {fade!r}, {block!r}, {min_distance!r}"
        )
    K = int(block)
    kin_fn = kinematics if engine == "numba" else kinematics_reference
    kin = kin_fn(obj, texture.speed, motion=motion, wind=wind, dt=K / rate, duration=duration)
    meta = {
        "n_sources": int(kin.pos.shape[0]),
        "exponent": e,
        "texture_speed": texture.speed,
        "max_speed_mps": float(kin.speed.max() * texture.speed),
    }
    return AeroEmission(
        texture,
        kin,
        float(rate),
        K,
        e,
        c0=float(c0),
        fade=float(fade),
        radius=float(min_distance),
        static=motion is None,
        engine=engine,
        meta=meta,
    )


def render(  # noqa: PLR0913 (keyword-only options)
    texture: SoundTexture,
    obj: AeroObject,
    path: ListenerPath,
    *,
    motion: Motion | None = None,
    wind: Wind | None = None,
    rate: int = 44100,
    layout: str | Layout = "mono",
    exponent: str | float = "physical",
    duration: float | None = None,
    c0: float = C0,
    min_distance: float = 0.05,
    fade: float = 0.01,
    block: int = 32,
    engine: str = "numba",
    backend: str = "auto",
    stereo: str | None = None,
) -> Rendered:
    """Render the aerodynamic sound of ``obj`` heard along ``path`` (§6, Eqs. 3–4).

    :func:`emission` at the output rate for the path's duration, rendered by
    the sound engine (:meth:`AeroEmission.render_part`, equal to
    ``auralize.emitters.render_sound(Sound([part]), path, ...)``).

    Parameters
    ----------
    texture, obj, motion, wind, exponent, c0, min_distance, fade, block, engine
        As for :func:`emission`.
    path : ListenerPath
        Listener; output sample n is heard at playback time n / rate.
    rate : int
        Output (and emission) sample rate (Hz).
    layout : str or Layout
        ``mono``, ``stereo``, ``ring8``, ``5.1``, ``7.1`` or a JSON layout
        (panned by the layout's own law, 3-D VBAP for layouts with elevation).
    duration : float, optional
        Seconds to render (default: the path's duration).
    backend : {"auto", "reference"}
        The engine's backend.
    stereo : None
        Removed (two ear receivers); any value but ``"pan"`` is refused.

    Returns
    -------
    Rendered
        ``audio (n_channels, n_samples)`` in Pa.

    Examples
    --------
    >>> from auralize_aero import circle, compute_texture, stick
    >>> tex = compute_texture(circle(0.01), resolution=6, duration=0.005, u_lattice=0.15,
    ...                       cache=False)
    >>> out = render(tex, stick(), ListenerPath.point((0, 1, 0), duration=0.1),
    ...              wind=Wind(10.0), layout="ring8")
    >>> out.audio.shape
    (8, 4410)
    """
    no_ears(stereo)
    dur = path.duration if duration is None else float(duration)
    part = emission(
        texture,
        obj,
        motion=motion,
        wind=wind,
        rate=rate,
        duration=dur,
        exponent=exponent,
        c0=c0,
        min_distance=min_distance,
        fade=fade,
        block=block,
        engine=engine,
    )
    # the one part rendered directly: auralize.emitters.render_sound would sum it into a second buffer
    return part.render_part(path, rate=rate, layout=layout, duration=dur, c0=c0, backend=backend)
